// The two event calendars (EventCalendar, EventHeap) against a reference that is correct by
// construction: a std::set of (time, index) pairs, the total order both must follow so that
// the engine's runs are bitwise the same with either (docs/reviews/mutation-audit-event-calendar.md).
// Long random sequences of updates, pops and re-uses, with ties, +inf, times before the
// current minimum, far beyond the calendar's window and exactly at bucket and window edges.
// Header-only: builds in seconds, runs in about a second in Release.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "edmd/event_calendar.hpp"
#include "edmd/event_heap.hpp"
#include "operators/random.hpp"

using namespace grainbath;
using namespace grainbath::edmd;

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// The order both calendars must give: (time, index), lexicographic.
class Reference {
 public:
  void reset(std::uint32_t n) {
    key_.assign(n, kInfinity);
    set_.clear();
    for (std::uint32_t i = 0; i < n; ++i) set_.insert({kInfinity, i});
  }
  void update(std::uint32_t i, double t) {
    set_.erase({key_[i], i});
    key_[i] = t;
    set_.insert({t, i});
  }
  std::uint32_t top() const { return set_.begin()->second; }
  double top_key() const { return set_.begin()->first; }
  double key(std::uint32_t i) const { return key_[i]; }
  std::uint32_t size() const { return static_cast<std::uint32_t>(key_.size()); }

 private:
  std::vector<double> key_;
  std::set<std::pair<double, std::uint32_t>> set_;
};

// Uniform interface over the two calendars for the driver below.
struct Calendar {
  bool defer;
  EventCalendar q;
  void reset(std::uint32_t n, double base, double width) { q.reset(n, base, width, defer); }
};
struct Heap {
  EventHeap q;
  void reset(std::uint32_t n, double, double) { q.reset(n); }
};

struct Case {
  std::uint32_t n;
  double base, width;
  int steps;
  std::uint64_t seed;
};

// Every observable of the calendar against the reference. `top_key_first`: some callers
// may ask for the time before the index, and both must then be settled.
template <class Q>
void expect_same(Q& q, const Reference& ref, bool top_key_first, const std::string& where) {
  if (top_key_first) {
    ASSERT_EQ(q.q.top_key(), ref.top_key()) << where;
    ASSERT_EQ(q.q.top(), ref.top()) << where;
  } else {
    ASSERT_EQ(q.q.top(), ref.top()) << where;
    ASSERT_EQ(q.q.top_key(), ref.top_key()) << where;
  }
  // a hint only, but always an entry other than the top, or none
  const std::uint32_t hint = q.q.runner_up();
  if (hint != q.q.kNoHint) {
    ASSERT_LT(hint, ref.size()) << where;
    ASSERT_NE(hint, ref.top()) << where;
  }
}

template <class Q>
void check_all_keys(Q& q, const Reference& ref, const std::string& where) {
  for (std::uint32_t i = 0; i < ref.size(); ++i) ASSERT_EQ(q.q.key(i), ref.key(i)) << where << " entry " << i;
  ASSERT_TRUE(q.q.valid()) << where;
}

// One random sequence: the top is re-scheduled (as the engine does with each event) and
// unrelated entries are moved anywhere, earlier than the minimum included.
template <class Q>
void run_case(Q& q, const Case& c) {
  Reference ref;
  CounterRng rng(c.seed, Stream::edmd_collisions, c.n, 0);
  const std::string tag = "n " + std::to_string(c.n) + " width " + std::to_string(c.width);
  q.reset(c.n, c.base, c.width);
  ref.reset(c.n);
  check_all_keys(q, ref, tag + " after reset");
  expect_same(q, ref, false, tag + " after reset");
  // a window holds bit_ceil(8n) >= 64 buckets (EventCalendar::reset); "far" is well beyond it
  const double window = 64.0 * 8.0 * c.n * c.width;
  auto draw_time = [&](double now) {
    const double u = rng.uniform();
    const double near = c.width * (0.25 + 4.0 * rng.exponential());
    if (u < 0.10) return now;                                       // a tie with the minimum
    if (u < 0.15) return kInfinity;                                 // nothing scheduled
    if (u < 0.25) return now + window * (0.5 + 2.0 * rng.uniform());  // at and beyond the window's end
    if (u < 0.28) return now + 1e6 * window * rng.uniform();        // very far
    if (u < 0.35) return ref.key(static_cast<std::uint32_t>(rng.uniform() * c.n));  // a tie with anyone
    if (u < 0.40) return now - near;                                // before the minimum
    if (u < 0.45) return c.base - near;                             // before the first window
    if (u < 0.52) return now + c.width * std::floor(8.0 * rng.uniform());  // exact bucket steps
    if (u < 0.55) return std::nextafter(now + near, kInfinity);
    return now + near;
  };
  double now = c.base;
  for (std::uint32_t i = 0; i < c.n; ++i) {
    const double t = rng.uniform() < 0.05 ? kInfinity : c.base + c.width * c.n * rng.exponential();
    q.q.update(i, t);
    ref.update(i, t);
  }
  for (int step = 0; step < c.steps; ++step) {
    const std::string where = tag + " step " + std::to_string(step);
    expect_same(q, ref, rng.uniform() < 0.2, where);
    if (::testing::Test::HasFatalFailure()) return;
    const std::uint32_t i = ref.top();
    if (std::isfinite(ref.top_key())) now = ref.top_key();
    const double u = rng.uniform();
    if (u < 0.02) {  // every entry at +inf for a moment: the lowest index is the top
      for (std::uint32_t k = 0; k < c.n; ++k) q.q.update(k, kInfinity), ref.update(k, kInfinity);
      expect_same(q, ref, rng.uniform() < 0.5, where + " all at +inf");
      if (::testing::Test::HasFatalFailure()) return;
      for (std::uint32_t k = 0; k < c.n; ++k) {
        const double t = now + c.width * c.n * rng.exponential();
        q.q.update(k, t), ref.update(k, t);
      }
      continue;
    }
    const double t = draw_time(now);
    q.q.update(i, t);
    ref.update(i, t);
    // zero to three further re-schedules (an event updates one to three entries)
    const int more = static_cast<int>(rng.uniform() * 4.0);
    for (int r = 0; r < more; ++r) {
      const auto k = static_cast<std::uint32_t>(rng.uniform() * c.n);
      const double tk = draw_time(now);
      q.q.update(k, tk);
      ref.update(k, tk);
      if (rng.uniform() < 0.1) expect_same(q, ref, rng.uniform() < 0.5, where + " between updates");
      if (::testing::Test::HasFatalFailure()) return;
    }
    const auto k = static_cast<std::uint32_t>(rng.uniform() * c.n);
    ASSERT_EQ(q.q.key(k), ref.key(k)) << where << " entry " << k;
    if (step % 997 == 0) check_all_keys(q, ref, where);
    if (::testing::Test::HasFatalFailure()) return;
  }
  check_all_keys(q, ref, tag + " at the end");
  // ends with the minimum found (and cached): a re-used calendar must not return it again
  expect_same(q, ref, false, tag + " at the end");
}

const std::vector<Case>& cases() {
  static const std::vector<Case> c = {
      {1, 0.0, 0.5, 3000, 1},      {2, 0.0, 0.5, 3000, 2},      {3, -2.0, 0.25, 4000, 3},
      {5, 10.0, 1.0, 6000, 4},     {9, 0.0, 0.01, 6000, 5},     {40, 0.0, 0.003, 10000, 6},
      {130, -50.0, 0.7, 10000, 7}, {700, 0.0, 1e-4, 15000, 8},  {2000, 3.0, 0.02, 15000, 9},
  };
  return c;
}

}  // namespace

TEST(EventQueues, CalendarMatchesASortedSetOverLongRandomSequences) {
  for (const bool defer : {false, true})
    for (const Case& c : cases()) {
      Calendar cal{defer, {}};
      run_case(cal, c);
      if (HasFatalFailure()) return;
    }
}

TEST(EventQueues, HeapMatchesASortedSetOverLongRandomSequences) {
  for (const Case& c : cases()) {
    Heap heap;
    run_case(heap, c);
    if (HasFatalFailure()) return;
  }
}

TEST(EventQueues, ReusedCalendarForgetsItsPreviousContents) {
  // The engine re-sizes and refills the same calendar at every rebuild: nothing of the
  // previous use (cached minimum, waiting entries, overflow list) may leak into the next.
  for (const bool defer : {false, true}) {
    Calendar cal{defer, {}};
    Heap heap;
    std::uint64_t seed = 20;
    for (const std::uint32_t n : {300u, 5u, 2000u, 1u, 64u, 300u}) {
      const Case c{n, 0.1 * n, 0.01, 2000, ++seed};
      run_case(cal, c);
      run_case(heap, c);
      if (HasFatalFailure()) return;
    }
  }
}

TEST(EventQueues, CalendarKeepsTheOrderAtTheWindowEdges) {
  // Keys exactly at and just around base + k width (bucket edges), base + m width (the end
  // of the window: m buckets, m = max(64, bit_ceil(8n))), below the base and at +inf.
  for (const bool defer : {false, true})
    for (const double width : {1.0, 0.5, 0.125, 0.1}) {
      const std::uint32_t n = 8;  // m = 64 buckets
      const double base = 2.0, end = base + 64.0 * width;
      const std::vector<double> edge = {std::nextafter(end, 0.0), end, std::nextafter(end, kInfinity),
                                        base + 63.0 * width, std::nextafter(base + 63.0 * width, 0.0),
                                        base, std::nextafter(base, 0.0), base - 3.0 * width, kInfinity};
      EventCalendar cal;
      Reference ref;
      // scrambled choices of keys for entries 0..7 from `edge`; each on a fresh window
      // (a re-base would move the edges)
      for (std::uint32_t pattern = 0; pattern < 4000; ++pattern) {
        cal.reset(n, base, width, defer);
        ref.reset(n);
        std::uint32_t p = pattern * 2654435761u;
        for (std::uint32_t i = 0; i < n; ++i, p /= 9) {
          cal.update(i, edge[p % 9]);
          ref.update(i, edge[p % 9]);
        }
        ASSERT_EQ(cal.top(), ref.top()) << width << " " << pattern;
        ASSERT_EQ(cal.top_key(), ref.top_key()) << width << " " << pattern;
        // pop everything in order, each to +inf
        for (std::uint32_t k = 0; k < n && std::isfinite(ref.top_key()); ++k) {
          ASSERT_EQ(cal.top(), ref.top()) << width << " " << pattern << " pop " << k;
          const std::uint32_t i = ref.top();
          cal.update(i, kInfinity);
          ref.update(i, kInfinity);
        }
        ASSERT_TRUE(cal.valid()) << width << " " << pattern;
      }
    }
}

TEST(EventQueues, CalendarWithoutAPositiveWidthStillOrders) {
  // reset() takes width 1 for a width that is not positive (no bucket size to divide by).
  for (const double width : {0.0, -1.0})
    for (const bool defer : {false, true}) {
      Calendar cal{defer, {}};
      run_case(cal, Case{50, 0.0, width, 2000, 40});
      if (HasFatalFailure()) return;
    }
}
