#pragma once
// The event calendar: an indexed 4-ary min-heap holding exactly one entry per particle,
// keyed on that particle's next event time (Lubachevsky / Smallenburg-style "one event
// per particle" calendar). Keys are stored inline with the particle index (16 bytes per
// entry), so the four children of a node share one cache line and a sift never chases
// pointers into particle data. Updating a particle's event is a sift up or down from its
// known slot: O(log4 N), no allocation, no stale entries piling up. Events that become
// stale because a partner changed its trajectory are detected lazily when they reach the
// top, through the per-particle event counters (see engine.hpp).
#include <cstdint>
#include <limits>
#include <vector>

namespace grainbath::edmd {

class EventHeap {
 public:
  struct Entry {
    double key;
    std::uint32_t id;
  };
  void reset(std::size_t n) {
    heap_.resize(n);
    pos_.resize(n);
    for (std::uint32_t i = 0; i < n; ++i)
      heap_[i] = {std::numeric_limits<double>::infinity(), i}, pos_[i] = i;
  }
  double key(std::uint32_t i) const { return heap_[pos_[i]].key; }
  std::uint32_t top() const { return heap_[0].id; }
  double top_key() const { return heap_[0].key; }
  // The probable next top after top() is processed (prefetch hint only): the smallest child
  // of the root. kNoHint if there is none.
  static constexpr std::uint32_t kNoHint = 0xffffffffu;
  std::uint32_t runner_up() const {
    std::uint32_t best = kNoHint;
    for (std::size_t k = 1; k <= 4 && k < heap_.size(); ++k)
      if (best == kNoHint || less(heap_[k], heap_[pos_[best]])) best = heap_[k].id;
    return best;
  }
  bool empty() const { return heap_.empty(); }
  // prefetch hints of the calendar's interface: nothing to request here
  void request(std::uint32_t) const {}
  void request_update(std::uint32_t, double) const {}
  template <class OnEntry>
  void request_ahead(OnEntry&&) const {}
  void update(std::uint32_t i, double key) {
    const std::size_t k = pos_[i];
    const Entry e{key, i};
    if (k > 0 && less(e, heap_[(k - 1) / 4])) up(k, e);
    else down(k, e);
  }
  bool valid() const {
    for (std::size_t k = 1; k < heap_.size(); ++k)
      if (less(heap_[k], heap_[(k - 1) / 4])) return false;
    for (std::size_t k = 0; k < heap_.size(); ++k)
      if (pos_[heap_[k].id] != k) return false;
    return true;
  }

 private:
  // Ties broken by particle index so the order never depends on heap history.
  static bool less(const Entry& a, const Entry& b) { return a.key < b.key || (a.key == b.key && a.id < b.id); }
  void up(std::size_t k, const Entry& e) {
    while (k > 0) {
      const std::size_t p = (k - 1) / 4;
      if (!less(e, heap_[p])) break;
      heap_[k] = heap_[p];
      pos_[heap_[k].id] = static_cast<std::uint32_t>(k);
      k = p;
    }
    heap_[k] = e;
    pos_[e.id] = static_cast<std::uint32_t>(k);
  }
  void down(std::size_t k, const Entry& e) {
    const std::size_t n = heap_.size();
    for (;;) {
      const std::size_t c0 = 4 * k + 1;
      if (c0 >= n) break;
      std::size_t c = c0;
      const std::size_t cend = c0 + 4 < n ? c0 + 4 : n;
      for (std::size_t q = c0 + 1; q < cend; ++q)
        if (less(heap_[q], heap_[c])) c = q;
      if (!less(heap_[c], e)) break;
      heap_[k] = heap_[c];
      pos_[heap_[k].id] = static_cast<std::uint32_t>(k);
      k = c;
    }
    heap_[k] = e;
    pos_[e.id] = static_cast<std::uint32_t>(k);
  }
  std::vector<Entry> heap_;
  std::vector<std::uint32_t> pos_;
};

}  // namespace grainbath::edmd
