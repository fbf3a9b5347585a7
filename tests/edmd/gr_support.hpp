#pragma once
// Pair statistics holding the exact bin averages of a given g(r), for the contact-fit tests
// (physics_test.cpp, measure_test.cpp): 1000 grains in a box of side 20, 3 snapshots, range 2,
// bins of width `bin`. Each bin's count is the shell integral of g r^(D-1) over the bin's part
// outside the core (r >= 1), by Simpson's rule on 2000 intervals: independent of the fit's
// closed form, and exact to round-off for polynomials of degree <= 4 (a kink must sit on a bin
// edge).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <numbers>

#include "edmd/measure.hpp"

namespace grainbath::edmd::testing {

template <class G>
PairStatistics pair_statistics_of(G g, int dims, double bin) {
  PairStatistics p;
  p.init(dims, {20.0, 20.0, 20.0}, {false, false, false}, 2.0, bin, 0.1);
  p.n = 1000;
  p.snapshots = 3;
  const double volume = dims == 2 ? 400.0 : 8000.0;
  const double unit = dims == 2 ? 2.0 * std::numbers::pi : 4.0 * std::numbers::pi;  // shell = unit * int r^(D-1) dr
  for (std::size_t b = 0; b < p.gr_counts.size(); ++b) {
    const double r0 = b * bin, r1 = r0 + bin, lo = std::max(r0, 1.0), h = (r1 - lo) / 2000;
    double num = 0.0;
    for (int q = 0; r1 > lo && q <= 2000; ++q) {
      const double r = lo + q * h, wq = q == 0 || q == 2000 ? 1.0 : q % 2 ? 4.0 : 2.0;
      num += wq * g(r) * std::pow(r, dims - 1);
    }
    num *= h / 3.0;
    p.gr_counts[b] = 0.5 * p.n * (p.n - 1.0) / volume * unit * num * p.snapshots;
  }
  return p;
}

}  // namespace grainbath::edmd::testing
