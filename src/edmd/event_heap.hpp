#pragma once
// The event calendar: an indexed binary min-heap holding exactly one entry per particle,
// keyed on that particle's next event time (Lubachevsky / Smallenburg-style "one event
// per particle" calendar). Updating a particle's event is a sift up or down from its
// known slot: O(log N), no allocation, no stale entries piling up. Events that become
// stale because a partner changed its trajectory are detected lazily when they reach the
// top, through the per-particle event counters (see engine.hpp).
#include <cstdint>
#include <vector>

namespace grainbath::edmd {

class EventHeap {
 public:
  void reset(std::size_t n, const double* keys) {
    keys_ = keys;
    heap_.resize(n);
    pos_.resize(n);
    for (std::uint32_t i = 0; i < n; ++i) heap_[i] = i, pos_[i] = i;
    for (std::size_t k = n / 2; k-- > 0;) down(k);
  }
  std::uint32_t top() const { return heap_[0]; }
  bool empty() const { return heap_.empty(); }
  // Call after keys[i] changed.
  void update(std::uint32_t i) {
    const std::size_t k = pos_[i];
    if (k > 0 && less(heap_[k], heap_[(k - 1) / 2])) up(k);
    else down(k);
  }
  // Debug check of the heap property.
  bool valid() const {
    for (std::size_t k = 1; k < heap_.size(); ++k)
      if (less(heap_[k], heap_[(k - 1) / 2])) return false;
    return true;
  }

 private:
  // Ties broken by particle id so the order never depends on heap history.
  bool less(std::uint32_t a, std::uint32_t b) const {
    return keys_[a] < keys_[b] || (keys_[a] == keys_[b] && a < b);
  }
  void up(std::size_t k) {
    const std::uint32_t x = heap_[k];
    while (k > 0) {
      const std::size_t p = (k - 1) / 2;
      if (!less(x, heap_[p])) break;
      heap_[k] = heap_[p];
      pos_[heap_[k]] = static_cast<std::uint32_t>(k);
      k = p;
    }
    heap_[k] = x;
    pos_[x] = static_cast<std::uint32_t>(k);
  }
  void down(std::size_t k) {
    const std::size_t n = heap_.size();
    const std::uint32_t x = heap_[k];
    for (;;) {
      std::size_t c = 2 * k + 1;
      if (c >= n) break;
      if (c + 1 < n && less(heap_[c + 1], heap_[c])) ++c;
      if (!less(heap_[c], x)) break;
      heap_[k] = heap_[c];
      pos_[heap_[k]] = static_cast<std::uint32_t>(k);
      k = c;
    }
    heap_[k] = x;
    pos_[x] = static_cast<std::uint32_t>(k);
  }
  const double* keys_ = nullptr;
  std::vector<std::uint32_t> heap_, pos_;
};

}  // namespace grainbath::edmd
