#pragma once
// A bounded calendar queue (Paul 2007; the idea of DynamO's bounded priority queue) with
// exactly one entry per particle, an O(1) alternative to EventHeap for large N.
//
// Times in [base, base + M width) go to bucket floor((t - base)/width) mod-free (the window
// is re-based when exhausted); later ones wait in an overflow list and are re-bucketed
// when the window moves. Each bucket is an intrusive doubly-linked list. The minimum is the
// smallest (time, index) in the first non-empty bucket, found by scanning that bucket
// (a few entries when width ~ 2 / event rate). The order is the same total order as
// EventHeap's (time, then index), so the two calendars give bitwise identical runs.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace grainbath::edmd {

class EventCalendar {
 public:
  // n entries, all at +inf; `width` the bucket width in time, window starting at `base`.
  void reset(std::size_t n, double base, double width) {
    const std::size_t m = std::max<std::size_t>(64, std::bit_ceil(2 * n));
    heads_.assign(m, kNone);
    key_.assign(n, std::numeric_limits<double>::infinity());
    next_.assign(n, kNone);
    prev_.assign(n, kNone);
    where_.assign(n, kOverflow);
    overflow_head_ = kNone;
    base_ = base;
    width_ = width > 0 ? width : 1.0;
    inv_width_ = 1.0 / width_;
    cur_ = 0;
    cached_ = false;
    for (std::uint32_t i = 0; i < n; ++i) link(i, kOverflow);
  }
  void update(std::uint32_t i, double key) {
    unlink(i);
    key_[i] = key;
    link(i, slot_for(key));
    if (cached_ && (i == min_ || key < min_key_ || (key == min_key_ && i < min_))) cached_ = false;
  }
  std::uint32_t top() {
    if (!cached_) find_min();
    return min_;
  }
  double top_key() {
    if (!cached_) find_min();
    return min_key_;
  }
  bool valid() const {
    for (std::size_t i = 0; i < key_.size(); ++i)
      if (where_[i] != slot_for(key_[i]) && where_[i] != kOverflow) return false;
    return true;
  }

 private:
  static constexpr std::uint32_t kNone = 0xffffffffu;
  static constexpr std::uint32_t kOverflow = 0xfffffffeu;

  std::uint32_t slot_for(double key) const {
    const double x = (key - base_) * inv_width_;
    if (!(x < static_cast<double>(heads_.size()))) return kOverflow;  // also +inf / NaN
    return x <= 0.0 ? 0u : static_cast<std::uint32_t>(x);
  }
  std::uint32_t& head(std::uint32_t slot) { return slot == kOverflow ? overflow_head_ : heads_[slot]; }
  void link(std::uint32_t i, std::uint32_t slot) {
    std::uint32_t& h = head(slot);
    next_[i] = h;
    prev_[i] = kNone;
    if (h != kNone) prev_[h] = i;
    h = i;
    where_[i] = slot;
    if (slot != kOverflow && slot < cur_) cur_ = slot;
  }
  void unlink(std::uint32_t i) {
    const std::uint32_t slot = where_[i];
    if (prev_[i] != kNone) next_[prev_[i]] = next_[i];
    else head(slot) = next_[i];
    if (next_[i] != kNone) prev_[next_[i]] = prev_[i];
  }
  void find_min() {
    for (;;) {
      const std::size_t m = heads_.size();
      while (cur_ < m && heads_[cur_] == kNone) ++cur_;
      if (cur_ < m) {
        std::uint32_t best = heads_[cur_];
        for (std::uint32_t k = next_[best]; k != kNone; k = next_[k])
          if (key_[k] < key_[best] || (key_[k] == key_[best] && k < best)) best = k;
        min_ = best;
        min_key_ = key_[best];
        cached_ = true;
        return;
      }
      // window exhausted: move it to the earliest overflow time and re-bucket
      double earliest = std::numeric_limits<double>::infinity();
      std::uint32_t arg = kNone;
      for (std::uint32_t k = overflow_head_; k != kNone; k = next_[k])
        if (key_[k] < earliest || (key_[k] == earliest && k < arg)) earliest = key_[k], arg = k;
      if (!std::isfinite(earliest)) {  // nothing scheduled at a finite time
        min_ = arg == kNone ? 0 : arg;
        min_key_ = earliest;
        cached_ = true;
        return;
      }
      base_ = earliest;
      cur_ = 0;
      std::uint32_t k = overflow_head_;
      overflow_head_ = kNone;
      while (k != kNone) {
        const std::uint32_t nx = next_[k];
        link(k, slot_for(key_[k]));
        k = nx;
      }
      cur_ = 0;
    }
  }

  std::vector<std::uint32_t> heads_, next_, prev_, where_;
  std::vector<double> key_;
  std::uint32_t overflow_head_ = kNone;
  double base_ = 0.0, width_ = 1.0, inv_width_ = 1.0;
  std::size_t cur_ = 0;
  bool cached_ = false;
  std::uint32_t min_ = 0;
  double min_key_ = 0.0;
};

}  // namespace grainbath::edmd
