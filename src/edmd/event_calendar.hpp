#pragma once
// A bounded calendar queue (Paul 2007; the idea of DynamO's bounded priority queue) with
// exactly one entry per particle, an O(1) alternative to EventHeap for large N.
//
// Times in [base, base + M width) go to bucket floor((t - base)/width) mod-free (the window
// is re-based when exhausted); later ones wait in an overflow list and are re-bucketed
// when the window moves. Each bucket is an intrusive doubly-linked list. The minimum is the
// smallest (time, index) in the first non-empty bucket, found by scanning that bucket
// (less than one entry on average: width ~ 1 / (2 x event rate)). The order is the same total order as
// EventHeap's (time, then index), so the two calendars give bitwise identical runs.
// An entry's key and links live in one 32-byte record (two per cache line): an update
// touches three entries (itself and its list neighbours), one cache miss each instead of
// one per array.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/huge_pages.hpp"

namespace grainbath::edmd {

class EventCalendar {
 public:
  // n entries, all at +inf; `width` the bucket width in time, window starting at `base`.
  // defer_links: update() links late (see update()); the engine asks for it at large N only.
  void reset(std::size_t n, double base, double width, bool defer_links = false) {
    defer_ = defer_links;
    // 8n buckets: with the engine's width (a quarter of the mean delay per N) the window
    // spans 4 mean delays, as 2n buckets of 4 times the width did, but a bucket near the
    // front holds about half an entry instead of two, so find_min walks fewer nodes (each a
    // cache miss at N = 10^6): 10^6 disks 1.09-1.12x faster, 10^4 unchanged
    // (docs/performance/edmd.md). heads_ costs 32 bytes per entry.
    const std::size_t m = std::max<std::size_t>(64, std::bit_ceil(8 * n));
    heads_.assign(m, kNone);
    occupied_.assign(m / 64, 0);
    node_.assign(n, Node{});
    overflow_head_ = kNone;
    base_ = base;
    width_ = width > 0 ? width : 1.0;
    inv_width_ = 1.0 / width_;
    cur_ = 0;
    ahead1_ = ahead2_ = 0;
    cached_ = false;
    npending_ = 0;
    for (std::uint32_t i = 0; i < n; ++i) link(i, kOverflow);
  }
  // Deferred link: update() unlinks i at once but links it into its new bucket only
  // kDefer updates later. Linking an entry into an occupied bucket loads the bucket's head
  // (heads_, 32 MiB at N = 10^6) and the occupancy word, both at a random place known only
  // once the new key is: with the link done right away these were the two largest stalls of
  // update() at N = 10^6 (perf on the Intel VM: 40 % and 27 % of its samples); deferred, their
  // lines are requested here and used an event or two later. top() looks at the waiting
  // entries too (an entry earlier than the linked minimum makes it link them all first), so
  // the minimum is the same (time, index) minimum as before and the event order unchanged.
  // Measured in one process (bench_edmd BM_EdmdDeferAB, two engines in alternating chunks):
  // 1.04-1.12x at 10^6 disks, 1.02-1.08x at 10^5 spheres, but 0.93-0.98x at 10^4 disks, where
  // these lines are cached and only the bookkeeping remains; hence only with defer_links
  // (reset), which the engine sets at N >= 50000 (docs/performance/edmd.md).
  void update(std::uint32_t i, double key) {
    if (!defer_) {  // link at once (the calendar's whole cache footprint is small)
      unlink(i);
      node_[i].key = key;
      link(i, slot_for(key));
      if (cached_ && (i == min_ || key < min_key_ || (key == min_key_ && i < min_))) cached_ = false;
      return;
    }
    Node& e = node_[i];
    if (e.where == kPending) drop_pending(i);
    else unlink(i);
    e.key = key;
    if (cached_ && i == min_) cached_ = false;
    if (npending_ == kDefer) {  // the oldest waiting entry is linked now
      link_pending(pending_[0]);
      for (int k = 1; k < kDefer; ++k) pending_[k - 1] = pending_[k];
      --npending_;
    }
    e.where = kPending;
    pending_[npending_++] = i;
    const std::uint32_t s = slot_for(key);
    if (s != kOverflow) __builtin_prefetch(&heads_[s]), __builtin_prefetch(&occupied_[s >> 6]);
  }
  double key(std::uint32_t i) const { return node_[i].key; }
  std::uint32_t top() {
    if (!cached_) find_min();
    if (npending_ > 0) settle();  // never without defer_links: main's path plus this test
    return min_;
  }
  double top_key() {
    if (!cached_) find_min();
    if (npending_ > 0) settle();
    return min_key_;
  }
  // The probable next top once top() has been processed and re-scheduled later (a prefetch
  // hint only, never used for a decision): the earliest other entry of the current bucket
  // (its nodes were just read by find_min), else the head of the next non-empty bucket
  // within a few slots (the head, not necessarily that bucket's minimum: finding the
  // minimum would read the other nodes, i.e. take the cache misses the hint is meant to
  // hide). kNoHint if none is found. Call after top().
  static constexpr std::uint32_t kNoHint = 0xffffffffu;  // = kNone
  std::uint32_t runner_up() const {
    const std::size_t m = heads_.size();
    if (cur_ >= m) return kNoHint;
    std::uint32_t best = kNone;
    double best_key = std::numeric_limits<double>::infinity();
    for (std::uint32_t k = heads_[cur_]; k != kNone; k = node_[k].next) {
      if (k == min_) continue;
      const double key = node_[k].key;
      if (best == kNone || key < best_key || (key == best_key && k < best)) best = k, best_key = key;
    }
    if (best != kNone) return best;
    for (std::size_t s = cur_ + 1; s < m && s <= cur_ + 8; ++s)
      if (occupied(s)) return heads_[s];
    return kNoHint;
  }
  // Prefetch hints (no state changes): the node of i; the lines update(i, key) will touch.
  void request(std::uint32_t i) const { __builtin_prefetch(&node_[i]); }
  void request_update(std::uint32_t i, double key) const {
    const Node& e = node_[i];
    if (e.prev != kNone) __builtin_prefetch(&node_[e.prev]);
    if (e.next != kNone) __builtin_prefetch(&node_[e.next]);
    const std::uint32_t s = slot_for(key);
    if (s != kOverflow) __builtin_prefetch(&heads_[s]);
  }
  // Requests the nodes of the buckets about to become current (a prefetch hint, called once
  // per event at large N): find_min walks a bucket's list, and at N = 10^6 each node of
  // that walk was a dependent cache miss (perf: half of the event loop's own samples).
  // Stage 1, kAhead buckets ahead: each non-empty bucket's first node (the bits, then
  // heads_ of the non-empty buckets, are read in order);
  // stage 2, kAhead/2 ahead: the second node, from the first node's next (requested by
  // stage 1 half a window earlier), and on_entry(k) for both entries (the engine requests
  // their grains' records). A bucket holds about half an entry near the front (the engine's
  // width, engine.cpp rebuild_calendar), and the window moves about two buckets per event.
  // kAhead = 16 and 32 measured the same as 8; a third stage requesting
  // the grains' neighbourhoods two buckets ahead measured slower (docs/performance/edmd.md).
  template <class OnEntry>
  void request_ahead(OnEntry&& on_entry) {
    const std::size_t m = heads_.size();
    if (ahead1_ < cur_) ahead1_ = cur_;
    if (ahead2_ < cur_) ahead2_ = cur_;
    for (const std::size_t end = std::min(cur_ + kAhead, m); ahead1_ < end; ++ahead1_)
      if (occupied(ahead1_)) __builtin_prefetch(&node_[heads_[ahead1_]]);
    for (const std::size_t end = std::min(cur_ + kAhead / 2, m); ahead2_ < end; ++ahead2_)
      if (occupied(ahead2_)) {
        const std::uint32_t h = heads_[ahead2_];
        on_entry(h);
        if (const std::uint32_t nx = node_[h].next; nx != kNone) __builtin_prefetch(&node_[nx]), on_entry(nx);
      }
  }
  bool valid() const {
    for (std::size_t i = 0; i < node_.size(); ++i)
      if (node_[i].where != slot_for(node_[i].key) && node_[i].where != kOverflow && node_[i].where != kPending)
        return false;
    // exactly the waiting entries are marked waiting
    std::size_t waiting = 0;
    for (std::size_t i = 0; i < node_.size(); ++i) waiting += node_[i].where == kPending;
    if (waiting != static_cast<std::size_t>(npending_)) return false;
    for (int k = 0; k < npending_; ++k)
      if (node_[pending_[k]].where != kPending) return false;
    // a bucket's bit is set exactly when its list is not empty
    for (std::size_t s = 0; s < heads_.size(); ++s)
      if (occupied(s) != (heads_[s] != kNone)) return false;
    return true;
  }

 private:
  static constexpr std::uint32_t kNone = 0xffffffffu;
  static constexpr std::uint32_t kOverflow = 0xfffffffeu;
  static constexpr std::size_t kAhead = 8;
  static constexpr std::uint32_t kPending = 0xfffffffdu;  // where: waiting to be linked (update)
  static constexpr int kDefer = 4;  // waiting entries (an event updates one to three)
  struct alignas(32) Node {
    double key = std::numeric_limits<double>::infinity();
    std::uint32_t next = kNone, prev = kNone, where = kOverflow;
  };

  std::uint32_t slot_for(double key) const {
    const double x = (key - base_) * inv_width_;
    if (!(x < static_cast<double>(heads_.size()))) return kOverflow;  // also +inf / NaN
    return x <= 0.0 ? 0u : static_cast<std::uint32_t>(x);
  }
  // One bit per bucket, set while its list is not empty (1 MiB at N = 10^6, held in L2/L3,
  // against the 32 MiB of heads_): an insert into an empty bucket - most of them, at about
  // half an entry per bucket near the front and fewer further out - then only stores the
  // new head instead of first loading the old one from a random line, and find_min skips
  // empty buckets 64 at a time without reading heads_.
  bool occupied(std::size_t slot) const { return (occupied_[slot >> 6] >> (slot & 63)) & 1u; }
  void link(std::uint32_t i, std::uint32_t slot) {
    Node& e = node_[i];
    e.prev = kNone;
    e.where = slot;
    if (slot == kOverflow) {
      e.next = overflow_head_;
      if (overflow_head_ != kNone) node_[overflow_head_].prev = i;
      overflow_head_ = i;
      return;
    }
    std::uint64_t& word = occupied_[slot >> 6];
    const std::uint64_t bit = std::uint64_t{1} << (slot & 63);
    const std::uint32_t h = (word & bit) ? heads_[slot] : kNone;
    e.next = h;
    if (h != kNone) node_[h].prev = i;
    heads_[slot] = i;
    word |= bit;
    if (slot < cur_) cur_ = slot;
  }
  void unlink(std::uint32_t i) {
    const Node& e = node_[i];
    if (e.prev != kNone) {
      node_[e.prev].next = e.next;
    } else if (e.where == kOverflow) {
      overflow_head_ = e.next;
    } else {
      heads_[e.where] = e.next;
      if (e.next == kNone) occupied_[e.where >> 6] &= ~(std::uint64_t{1} << (e.where & 63));
    }
    if (e.next != kNone) node_[e.next].prev = e.prev;
  }
  // Links a waiting entry into its bucket; the cached minimum is dropped if it precedes it.
  void link_pending(std::uint32_t i) {
    const double key = node_[i].key;
    link(i, slot_for(key));
    if (cached_ && (key < min_key_ || (key == min_key_ && i < min_))) cached_ = false;
  }
  void drop_pending(std::uint32_t i) {
    int k = 0;
    while (pending_[k] != i) ++k;
    for (; k + 1 < npending_; ++k) pending_[k] = pending_[k + 1];
    --npending_;
  }
  void link_all_pending() {
    for (int k = 0; k < npending_; ++k) link_pending(pending_[k]);
    npending_ = 0;
  }
  // The (key, index) minimum over all entries, waiting ones included: the minimum of the
  // linked entries, unless a waiting entry precedes it (then all are linked and it is
  // looked for again).
  void settle() {
    for (;;) {
      if (!cached_) find_min();
      bool earlier = false;
      for (int k = 0; k < npending_; ++k) {
        const std::uint32_t p = pending_[k];
        const double key = node_[p].key;
        earlier |= key < min_key_ || (key == min_key_ && p < min_);
      }
      if (!earlier) return;
      link_all_pending();
    }
  }
  // The first non-empty bucket at or after `from` (heads_.size() if none).
  std::size_t next_occupied(std::size_t from) const {
    const std::size_t m = heads_.size();
    if (from >= m) return m;
    std::size_t w = from >> 6;
    std::uint64_t bits = occupied_[w] & (~std::uint64_t{0} << (from & 63));
    while (bits == 0) {
      if (++w == occupied_.size()) return m;
      bits = occupied_[w];
    }
    return (w << 6) + static_cast<std::size_t>(std::countr_zero(bits));
  }
  void find_min() {
    for (;;) {
      const std::size_t m = heads_.size();
      cur_ = next_occupied(cur_);
      if (cur_ < m) {
        std::uint32_t best = heads_[cur_];
        double best_key = node_[best].key;
        for (std::uint32_t k = node_[best].next; k != kNone; k = node_[k].next) {
          const double key = node_[k].key;
          if (key < best_key || (key == best_key && k < best)) best = k, best_key = key;
        }
        min_ = best;
        min_key_ = best_key;
        cached_ = true;
        return;
      }
      if (npending_ > 0) {  // waiting entries first: they may belong to the window
        link_all_pending();
        continue;
      }
      // Window exhausted: every bucket is empty, so every entry is in the overflow list.
      // Move the window to the earliest time and re-bucket all entries, reading the nodes in
      // index order rather than along the list: a walk of the list is a chain of dependent
      // random reads (at N = 10^6 about 0.3 s per re-base, i.e. ~75 ns per collision, once
      // every ~4 collisions per particle), the sweep reads the nodes as a stream and leaves
      // only independent random writes (the bucket heads). The order within a bucket differs
      // from the walk's, which changes nothing: find_min takes the (key, index) minimum.
      const std::uint32_t n = static_cast<std::uint32_t>(node_.size());
      double earliest = std::numeric_limits<double>::infinity();
      for (std::uint32_t k = 0; k < n; ++k) earliest = node_[k].key < earliest ? node_[k].key : earliest;
      if (!std::isfinite(earliest)) {  // nothing scheduled at a finite time: the lowest index
        std::uint32_t arg = 0;         // at +inf, as EventHeap (0 if there is none)
        while (arg < n && !(node_[arg].key == earliest)) ++arg;
        min_ = arg < n ? arg : 0;
        min_key_ = earliest;
        cached_ = true;
        return;
      }
      base_ = earliest;
      overflow_head_ = kNone;
      for (std::uint32_t k = 0; k < n; ++k) link(k, slot_for(node_[k].key));
      cur_ = 0;
      ahead1_ = ahead2_ = 0;
    }
  }

  HugePageVector<std::uint32_t> heads_;
  std::vector<std::uint64_t> occupied_;  // bit s: bucket s's list is not empty
  HugePageVector<Node> node_;
  std::uint32_t overflow_head_ = kNone;
  double base_ = 0.0, width_ = 1.0, inv_width_ = 1.0;
  std::size_t cur_ = 0;
  std::size_t ahead1_ = 0, ahead2_ = 0;  // request_ahead(): buckets before these were requested
  bool cached_ = false;
  std::uint32_t pending_[kDefer] = {};  // waiting entries, oldest first (update)
  int npending_ = 0;
  bool defer_ = false;  // update() links late (reset's defer_links)
  std::uint32_t min_ = 0;
  double min_key_ = 0.0;
};

}  // namespace grainbath::edmd
