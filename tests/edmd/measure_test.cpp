// The snapshot measurements (src/edmd/measure.*: g(r), Bizon's velocity correlations, the
// velocity histogram) and the slab profiles' bookkeeping (src/edmd/profile.*) on states whose
// answer is known without the code's formulas: an ideal gas of uniform random points, single
// pairs typed by hand, Gaussian samples against their own moments, a hand-made collision
// seen from the moving frame. docs/reviews/mutation-audit-edmd-measure.md lists the
// mutations each test kills.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "edmd/measure.hpp"
#include "edmd/profile.hpp"

using namespace grainbath;
using namespace grainbath::edmd;

namespace {
double ball(int dims, double r) {
  return dims == 2 ? std::numbers::pi * r * r : 4.0 / 3.0 * std::numbers::pi * r * r * r;
}
}  // namespace

// An ideal gas (N uniform random points per snapshot, periodic box) has g(r) = 1 at every r
// with the N(N-1)/2 pairs as the ideal count, and a gas in rigid translation at v0 has both
// velocity correlations equal to |v0|^2/(D T) on average (<cos^2> = 1/D over isotropic pair
// directions), with <v1par v2par> + (D-1) <v1perp.v2perp>/(D-1) = |v0|^2 in every bin
// exactly. The requested range is beyond L/2 in the first two boxes (it must be clamped to
// L/2, where nearest images still see every pair) and no box range is a whole number of bins
// (the last bin is a partial shell). Boxes 1, 2: the direct sum; 3, 4: the cell search with
// the AVX2 lanes where the CPU has them. Tolerances: 5 Poisson standard errors of the pair
// count per bin; over all pairs 5 standard errors (0.07 ... 0.15 %), against 1/N = 0.3 ... 2 %.
TEST(EdmdPairStatistics, IdealGasHasGOfOneInEveryBinAndRigidTranslationCorrelations) {
  struct Box {
    int dims;
    Vec3 L;
    std::size_t n;
    double r_request, r_expect;
    int snapshots;
  };
  const Box boxes[] = {
      {2, {20.3, 20.3, 0.0}, 50, 14.0, 10.15, 2000},
      {3, {9.1, 9.1, 9.1}, 80, 6.0, 4.55, 1000},
      {2, {41.0, 37.0, 0.0}, 150, 7.25, 7.25, 800},
      {3, {14.0, 15.0, 16.0}, 300, 2.75, 2.75, 1500},
  };
  std::mt19937_64 rng(20261206);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
#ifdef _OPENMP
  // thousands of small snapshots: one thread (the OpenMP region's start costs more than the
  // pairs, and 5 times the test's time on a busy machine); the thread counts are
  // EdmdMeasure.PairStatisticsCellSearchEqualsDirectSum's
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
#endif
  for (const Box& box : boxes) {
    const int D = box.dims;
    const double T = 1.7;
    const Vec3 v0{0.8, -1.1, D == 3 ? 0.6 : 0.0};
    const double v02 = norm2(v0);
    PairStatistics p;
    p.init(D, box.L, {false, false, false}, box.r_request, 0.1, 0.25);
    EXPECT_DOUBLE_EQ(p.rmax, box.r_expect);
    std::vector<Vec3> x(box.n), v(box.n, v0);
    for (int s = 0; s < box.snapshots; ++s) {
      for (auto& xi : x) xi = {uni(rng) * box.L.x, uni(rng) * box.L.y, D == 3 ? uni(rng) * box.L.z : 0.0};
      p.add(x, v, T);
    }
    const double volume = D == 2 ? box.L.x * box.L.y : box.L.x * box.L.y * box.L.z;
    const double pairs = 0.5 * box.n * (box.n - 1.0) * box.snapshots;
    const auto g = p.gr();
    double sum_g_w = 0.0, sum_w = 0.0, counted = 0.0;
    for (std::size_t b = 0; b < g.size(); ++b) {
      const double r0 = b * p.gr_bin, r1 = std::min(r0 + p.gr_bin, p.rmax);
      const double w = ball(D, r1) - ball(D, r0), expect = pairs * w / volume;
      EXPECT_NEAR(g[b], 1.0, 5.0 / std::sqrt(expect)) << "box " << (&box - boxes) << " bin " << b << " of " << g.size();
      sum_g_w += g[b] * w, sum_w += w, counted += p.gr_counts[b];
    }
    // every pair closer than the range, and in the mean g = 1 to 5 standard errors
    const double expect_all = pairs * ball(D, p.rmax) / volume;
    std::printf("box %d: %zu bins, shell-weighted mean g - 1 = %+.5f (se %.5f; 1/N = %.4f)\n", int(&box - boxes),
                g.size(), sum_g_w / sum_w - 1.0, 1.0 / std::sqrt(expect_all), 1.0 / box.n);
    EXPECT_NEAR(sum_g_w / sum_w, 1.0, 5.0 / std::sqrt(expect_all));
    EXPECT_NEAR(counted, expect_all, 5.0 * std::sqrt(expect_all));
    // rigid translation
    const auto par = p.parallel(), perp = p.perpendicular();
    double cnt = 0.0, par_mean = 0.0, perp_mean = 0.0;
    for (std::size_t c = 0; c < par.size(); ++c) {
      if (p.corr_counts[c] == 0.0) continue;
      EXPECT_NEAR(par[c] + (D - 1) * perp[c], v02 / T, 1e-12) << c;
      cnt += p.corr_counts[c], par_mean += par[c] * p.corr_counts[c], perp_mean += perp[c] * p.corr_counts[c];
    }
    // sd of cos^2 over isotropic directions: 1/(2 sqrt 2) in 2D, 2/(3 sqrt 5) in 3D
    const double sd = (D == 2 ? 0.3536 : 0.2981) * v02 / T;
    EXPECT_NEAR(par_mean / cnt, v02 / (D * T), 5.0 * sd / std::sqrt(cnt)) << "box " << (&box - boxes);
    EXPECT_NEAR(perp_mean / cnt, v02 / (D * T), 5.0 * sd / std::sqrt(cnt)) << "box " << (&box - boxes);
  }
#ifdef _OPENMP
  omp_set_num_threads(threads);
#endif
}
