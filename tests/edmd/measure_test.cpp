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
#include "operators/random.hpp"
#include "edmd/profile.hpp"
#include "tests/edmd/gr_support.hpp"

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

// One pair, typed by hand, in 2D and 3D, through the cell search (large box) and the direct
// sum (small box), also across a periodic face: g(r)'s count in the bin of r (gr_bin 0.02) and
// Bizon's eqs. 25-26 in the bin of r (corr_bin 0.1): the components of the two velocities along
// the pair (k = r/|r|) and across it. Two snapshots of the same pair at T = 2 and T = 3 (the
// correlations are normalised by the mean T = 2.5).
//   2D: r = 5.05 (0.6, 0.8), v1 = (1, 2), v2 = (-2, 1): par 2.2 x (-0.4) = -0.88; across, along
//       (-0.8, 0.6): 0.4 x 2.2 = 0.88.
//   3D: r = 5.25 (2, 3, 6)/7, v1 = (1, -1, 2), v2 = (0.5, 2, -1): par (11/7)(1/7) = 11/49; across,
//       v1.v2 - par = -3.5 - 11/49 over D - 1 = 2 directions.
TEST(EdmdPairStatistics, VelocityCorrelationsOfOneHandBuiltPair) {
  struct Pair {
    int dims;
    Vec3 L, x1, dr, v1, v2;
    double par, perp_sum;  // <v1par v2par>, <v1perp . v2perp>
    std::size_t gr_bin, corr_bin;
  };
  const Pair pairs[] = {
      {2, {40.0, 40.0, 0.0}, {10.0, 12.0, 0.0}, {3.03, 4.04, 0.0}, {1.0, 2.0, 0.0}, {-2.0, 1.0, 0.0}, -0.88, 0.88, 252, 50},
      {2, {40.0, 40.0, 0.0}, {38.5, 37.0, 0.0}, {3.03, 4.04, 0.0}, {1.0, 2.0, 0.0}, {-2.0, 1.0, 0.0}, -0.88, 0.88, 252, 50},
      {2, {13.0, 13.0, 0.0}, {10.0, 11.0, 0.0}, {3.03, 4.04, 0.0}, {1.0, 2.0, 0.0}, {-2.0, 1.0, 0.0}, -0.88, 0.88, 252, 50},
      {3, {40.0, 40.0, 40.0}, {5.0, 6.0, 38.0}, {1.5, 2.25, 4.5}, {1.0, -1.0, 2.0}, {0.5, 2.0, -1.0}, 11.0 / 49.0,
       -3.5 - 11.0 / 49.0, 262, 52},
      {3, {13.0, 13.0, 13.0}, {5.0, 6.0, 7.0}, {1.5, 2.25, 4.5}, {1.0, -1.0, 2.0}, {0.5, 2.0, -1.0}, 11.0 / 49.0,
       -3.5 - 11.0 / 49.0, 262, 52},
  };
  for (const Pair& q : pairs) {
    for (auto kernel : {PairStatistics::PairKernel::automatic, PairStatistics::PairKernel::scalar}) {
      PairStatistics p;
      p.init(q.dims, q.L, {false, false, false}, 6.0, 0.02, 0.1);
      Vec3 x2 = q.x1 + q.dr;
      x2.x -= q.L.x * std::floor(x2.x / q.L.x), x2.y -= q.L.y * std::floor(x2.y / q.L.y);
      if (q.dims == 3) x2.z -= q.L.z * std::floor(x2.z / q.L.z);
      const std::vector<Vec3> x{q.x1, x2}, v{q.v1, q.v2};
      p.add(x, v, 2.0, kernel);
      p.add(x, v, 3.0, kernel);
      const auto par = p.parallel(), perp = p.perpendicular();
      const std::string where = "pair " + std::to_string(&q - pairs);
      for (std::size_t b = 0; b < p.gr_counts.size(); ++b)
        EXPECT_EQ(p.gr_counts[b], b == q.gr_bin ? 2.0 : 0.0) << where << " g bin " << b;
      EXPECT_NEAR(p.gr_radii()[q.gr_bin], norm(q.dr), 1e-12);
      for (std::size_t c = 0; c < par.size(); ++c) {
        const bool in = c == q.corr_bin;
        EXPECT_EQ(p.corr_counts[c], in ? 2.0 : 0.0) << where << " bin " << c;
        EXPECT_NEAR(par[c], in ? q.par / 2.5 : 0.0, 1e-12) << where << " bin " << c;
        EXPECT_NEAR(perp[c], in ? q.perp_sum / ((q.dims - 1) * 2.5) : 0.0, 1e-12) << where << " bin " << c;
      }
      EXPECT_NEAR(p.corr_radii()[q.corr_bin], norm(q.dr), 1e-12);
    }
  }
}

// The direct sum (boxes too small for the cell search: every run of N <= 4000 grains, whose
// correlations reach L/2) in AVX2 lanes gives add_all_pairs' bits: g(r) counts, both
// correlation sums and their counts, over three snapshots added to the same running sums, in
// 2D and 3D, periodic and with walls, positions not wrapped (up to two box lengths outside
// along the periodic dimensions, so the nearest image rounds c / L of magnitude up to about
// 3), some pairs exactly half a box apart along one axis. Where the CPU lacks AVX2 (or
// GRAINBATH_SIMD=sse2) both sides are the scalar loop and the test says so.
TEST(EdmdPairStatistics, DirectSumInAvx2LanesGivesTheScalarBits) {
  struct Box {
    int dims;
    Vec3 L;
    std::array<bool, 3> walls;
  };
  const Box boxes[] = {
      {2, {10.0, 12.0, 0.0}, {false, false, false}},
      {2, {11.0, 9.5, 0.0}, {false, true, false}},
      {3, {8.0, 9.0, 10.0}, {false, false, false}},
      {3, {9.0, 8.5, 7.0}, {true, false, true}},
  };
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_int_distribution<int> shift(-2, 2);
  for (const Box& box : boxes) {
    const std::size_t n = box.dims == 2 ? 301 : 402;  // not a multiple of the four lanes
    PairStatistics lanes, scalar, direct;
    // 100 sigma asked: clamped to half the shortest side, too small a box for the cells
    for (PairStatistics* p : {&lanes, &scalar, &direct}) p->init(box.dims, box.L, box.walls, 100.0, 0.05, 0.25);
    for (int snapshot = 0; snapshot < 3; ++snapshot) {
      std::vector<Vec3> x(n), v(n);
      for (std::size_t i = 0; i < n; ++i) {
        double c[3] = {0.0, 0.0, 0.0};
        for (int d = 0; d < box.dims; ++d) {
          const double l = d == 0 ? box.L.x : d == 1 ? box.L.y : box.L.z;
          c[d] = u(rng) * l + (box.walls[d] || i % 2 ? 0.0 : shift(rng) * l);
        }
        x[i] = {c[0], c[1], c[2]};
        v[i] = {gauss(rng), gauss(rng), box.dims == 3 ? gauss(rng) : 0.0};
      }
      for (std::size_t i = 0; i + 1 < n; i += 50) x[i + 1].x = x[i].x + 0.5 * box.L.x;  // exact halves
      lanes.add(x, v, 1.0);
      scalar.add(x, v, 1.0, PairStatistics::PairKernel::scalar);
      direct.add_all_pairs(x, v);
    }
    const std::string where = "box " + std::to_string(&box - boxes);
    EXPECT_EQ(lanes.gr_counts, direct.gr_counts) << where;
    EXPECT_EQ(lanes.corr_par, direct.corr_par) << where;
    EXPECT_EQ(lanes.corr_perp, direct.corr_perp) << where;
    EXPECT_EQ(lanes.corr_counts, direct.corr_counts) << where;
    EXPECT_EQ(scalar.gr_counts, direct.gr_counts) << where;
    EXPECT_EQ(scalar.corr_par, direct.corr_par) << where;
    // the pairs were counted: about n(n-1)/2 x (ball of L/2 / box volume) per snapshot
    double pairs = 0.0;
    for (double c : direct.gr_counts) pairs += c;
    double volume = box.L.x * box.L.y * (box.dims == 3 ? box.L.z : 1.0);
    EXPECT_GT(pairs, 3 * 0.25 * 0.5 * n * (n - 1.0) * ball(box.dims, direct.rmax) / volume) << where;
  }
  if (!Philox4x32Lanes::have_avx2()) GTEST_SKIP() << "no AVX2 lanes on this CPU (or GRAINBATH_SIMD=sse2): both sides ran the scalar loop";
}

// The contact fit's window (measure.hpp): the bins reaching above sigma whose centre is at most
// 1 + width, a bin straddling sigma included; NaN with fewer than 3. A g(r) that is one
// quadratic up to r = 1.1 and another beyond, given as exact shell averages (Simpson's rule on
// 2000 intervals per bin, as in EdmdContactFit.RecoversAQuadraticFromItsBinAverages), is
// recovered exactly (1e-9) only from the bins inside [1, 1.1]. 0.035 sigma bins straddle sigma
// (edges 0.98, 1.015, 1.05, 1.085, 1.12): three bins, one of them the straddling one; 0.05 sigma
// bins (edges 1.0, 1.05, 1.1): two, NaN. One bin beyond the window reads the other quadratic
// (0.02 sigma bins: 5.7 + 0.15 instead of 5.7).
TEST(EdmdPairStatistics, ContactFitReadsTheBinsOfItsWindowOnly) {
  auto g = [](double r) {
    if (r < 1.0) return 0.0;
    const double s = r - 1.0;
    return s <= 0.1 ? 5.7 - 40.0 * s + 150.0 * s * s : 5.7 - 40.0 * s + 150.0 * s * s + 60.0 * (s - 0.1);
  };
  for (int dims : {2, 3})
    for (double bin : {0.02, 0.025, 0.035, 0.05}) {
      // the kink at 1.1 is on a bin edge for these widths, or in a bin outside the window
      const PairStatistics p = grainbath::edmd::testing::pair_statistics_of(g, dims, bin);
      if (bin == 0.05) EXPECT_TRUE(std::isnan(p.contact_value())) << dims;
      else EXPECT_NEAR(p.contact_value(), 5.7, 1e-9) << dims << " " << bin;
    }
}

// The velocity histogram of an anisotropic drifting Gaussian (T_x = 1.5 T, T_y = 0.5 T, T_z = T,
// drift along x) against the sample's own moments of c = v_d / sqrt(T): the density integrates
// to the fraction of samples inside +-vmax (exactly), the binned mean and second moment are the
// sample's within the binning error (a value moves by at most w/2 to its bin centre, on
// average 0 with sd w/sqrt(12); Sheppard's w^2/12 added to the second moment), 6 standard errors.
// The Sonine sums: <|c|^4>/<|c|^2>^2 of the sample (independent of the T used to scale c).
TEST(EdmdVelocityHistogram, DensityAndMomentsAreTheSamples) {
  const double T = 2.0, sx = std::sqrt(1.5 * T), sy = std::sqrt(0.5 * T), sz = std::sqrt(T);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (int D : {2, 3}) {
    VelocityHistogram h;
    h.init(5.0, 100);
    const double w = 0.1;
    std::vector<Vec3> all;
    for (int s = 0; s < 4; ++s) {
      std::vector<Vec3> v(25000);
      for (auto& u : v) u = {0.7 + sx * gauss(rng), sy * gauss(rng), D == 3 ? sz * gauss(rng) : 0.0};
      h.add(v, T, D);
      all.insert(all.end(), v.begin(), v.end());
    }
    EXPECT_EQ(h.total, static_cast<double>(all.size()));
    const auto centres = h.centres();
    ASSERT_EQ(centres.size(), 100u);
    EXPECT_NEAR(centres.front(), -4.95, 1e-12);
    EXPECT_NEAR(centres.back(), 4.95, 1e-12);
    for (int d = 0; d < D; ++d) {
      double inside = 0.0, m1 = 0.0, m2 = 0.0, m2sq = 0.0;
      for (const auto& u : all) {
        const double c = (d == 0 ? u.x : d == 1 ? u.y : u.z) / std::sqrt(T);
        if (std::abs(c) >= 5.0) continue;
        inside += 1.0, m1 += c, m2 += c * c, m2sq += c * c * c * c;
      }
      m1 /= inside, m2 /= inside;
      const double rms = std::sqrt(m2sq / inside);
      const auto p = h.density(d);
      double mass = 0.0, h1 = 0.0, h2 = 0.0;
      for (std::size_t b = 0; b < p.size(); ++b) mass += p[b] * w, h1 += centres[b] * p[b] * w, h2 += centres[b] * centres[b] * p[b] * w;
      EXPECT_NEAR(mass, inside / all.size(), 1e-12) << "D " << D << " component " << d;
      h1 /= mass, h2 /= mass;
      const double e1 = 6.0 * w / std::sqrt(12.0 * inside), e2 = 6.0 * 2.0 * std::sqrt(m2) * w / std::sqrt(12.0 * inside);
      EXPECT_NEAR(h1, m1, e1) << "D " << D << " component " << d;
      EXPECT_NEAR(h2, m2 + w * w / 12.0, e2 + 1e-3 * w * w) << "D " << D << " component " << d << " (rms c^2 " << rms << ")";
    }
    double s2 = 0.0, s4 = 0.0;
    for (const auto& u : all) s2 += norm2(u), s4 += norm2(u) * norm2(u);
    EXPECT_NEAR(h.c4_sum * h.samples / (h.c2_sum * h.c2_sum), s4 * all.size() / (s2 * s2), 1e-10);
  }
}

// Per-slab velocity histograms (thesis ch. 9 tails): four grains typed by hand in 5 slabs of
// width 2 along x (one beyond L, wrapped), 8 bins of width 0.5 over [-2, 2); components
// outside go to `outside`, every grain counts once in its slab's `samples`.
TEST(EdmdSlabVelocityHistograms, EachComponentInItsSlabAndBin) {
  SlabProfiles p;
  p.init({2, {10.0, 4.0, 1.0}, 0, 5, true});
  SlabVelocityHistograms h;
  h.init(2, 5, 8, 2.0);
  const std::vector<Vec3> x{{0.5, 1.0, 0.0}, {9.9, 2.0, 0.0}, {10.3, 3.0, 0.0}, {5.0, 0.5, 0.0}};
  const std::vector<Vec3> v{{-1.75, 0.3, 0.0}, {1.9, -2.5, 0.0}, {0.0, 2.2, 0.0}, {-0.2, 0.2, 0.0}};
  h.add(p, x, v);
  std::vector<double> counts(5 * 2 * 8, 0.0);
  auto at = [](int slab, int comp, int bin) { return (slab * 2 + comp) * 8 + bin; };
  counts[at(0, 0, 0)] = 1;  // -1.75
  counts[at(0, 1, 4)] = 1;  // 0.3
  counts[at(4, 0, 7)] = 1;  // 1.9 (its y, -2.5, outside)
  counts[at(0, 0, 4)] = 1;  // 0.0 (x = 10.3 wraps to slab 0; its y, 2.2, outside)
  counts[at(2, 0, 3)] = 1;  // -0.2
  counts[at(2, 1, 4)] = 1;  // 0.2
  EXPECT_EQ(h.counts, counts);
  EXPECT_EQ(h.samples, (std::vector<double>{2, 0, 1, 0, 1}));
  EXPECT_EQ(h.outside, (std::vector<double>{0, 1, 0, 0, 0, 0, 0, 0, 0, 1}));
  const auto c = h.centres();
  for (int b = 0; b < 8; ++b) EXPECT_NEAR(c[b], -1.75 + 0.5 * b, 1e-14);
}

// A hand-made rough collision (impulse not along the line of centres) between grains in slabs 1
// and 2 (width 2 along x, volume 8), with a snapshot whose mean velocity is u = (0.5, -0.3) in
// both: the energy changes and the heat flux are computed here from the grains' velocities
// before and after, in the lab and in the frame moving with u (Irving-Kirkwood: the energy
// handed across, (dE'_j - dE'_i)/2, along r_ij, half of the segment in each slab); the loss is
// booked half at each centre; P_col_ab = J_a r_b, not symmetric for rough grains.
TEST(EdmdSlabBookkeeping, HandMadeRoughCollisionSeenFromTheMovingFrame) {
  SlabProfiles p;
  p.init({2, {10.0, 4.0, 1.0}, 0, 5, true});
  const Vec3 u{0.5, -0.3, 0.0}, c1{0.7, 0.1, 0.0};
  // two grains in slab 1 and two in slab 2, peculiar velocities +-c1
  p.add_snapshot({{2.5, 1.0, 0.0}, {3.5, 2.0, 0.0}, {4.5, 1.0, 0.0}, {5.5, 3.0, 0.0}}, {u + c1, u - c1, u + c1, u - c1});
  const Vec3 n{0.6, 0.8, 0.0}, t{-0.8, 0.6, 0.0};
  const Vec3 vi{1.0, 0.5, 0.0}, vj{-0.5, -0.2, 0.0};
  const double gn = dot(vi - vj, n);  // 1.46, approaching
  const Vec3 J = (0.9 * gn) * n + 0.2 * t;  // to j; i gets -J
  const Vec3 vi1 = vi - J, vj1 = vj + J;
  CollisionRecord rec;
  rec.ri = {3.7, 1.0, 0.0};
  rec.rij = n;  // r_j at x = 4.3: half of the segment in slab 1, half in slab 2
  rec.impulse = J;
  rec.dEi = 0.5 * (norm2(vi1) - norm2(vi));
  rec.dEj = 0.5 * (norm2(vj1) - norm2(vj));
  p.add_collision(rec);
  const double dt = 2.0, V = 8.0;
  p.end_interval(dt);
  const auto r = p.result();
  // moving frame
  const double dEi_u = 0.5 * (norm2(vi1 - u) - norm2(vi - u)), dEj_u = 0.5 * (norm2(vj1 - u) - norm2(vj - u));
  const double handed = 0.5 * (dEj_u - dEi_u);
  for (int k = 0; k < 5; ++k) {
    const double f = (k == 1 || k == 2) ? 0.5 : 0.0;
    const std::string s = " slab " + std::to_string(k);
    EXPECT_NEAR(r.centres[k], 2.0 * k + 1.0, 1e-14) << s;
    EXPECT_NEAR(r.field("loss_rate").mean[k], -f * (rec.dEi + rec.dEj) / (dt * V), 1e-14) << s;
    EXPECT_NEAR(r.field("P_col_xy").mean[k], f * J.x * n.y / (dt * V), 1e-14) << s;
    EXPECT_NEAR(r.field("P_col_yx").mean[k], f * J.y * n.x / (dt * V), 1e-14) << s;
    if (f == 0.0) continue;  // q_col needs the slab's u
    EXPECT_NEAR(r.field("q_col_x").mean[k], f * handed * n.x / (dt * V), 1e-14) << s;
    EXPECT_NEAR(r.field("q_col_y").mean[k], f * handed * n.y / (dt * V), 1e-14) << s;
    // kinetic side of the same slabs: T_x = 0.49, T_y = 0.01, T their mean
    EXPECT_NEAR(r.field("T_x").mean[k], 0.49, 1e-14) << s;
    EXPECT_NEAR(r.field("T").mean[k], 0.25, 1e-14) << s;
    EXPECT_NEAR(r.field("u_y").mean[k], -0.3, 1e-14) << s;
  }
  EXPECT_GT(std::abs(J.x * n.y - J.y * n.x), 0.1);  // the check has teeth: P_col not symmetric
}

// The block bookkeeping behind the profile errors: 2048 sampling intervals, kMaxBlocks = 256,
// so the blocks are merged three times (at 512 closed blocks each) and end as 256 blocks of 8
// intervals, every one holding 8 intervals' snapshots and time. The batch error of a field is
// then the standard error of the 32 batch means of 64 consecutive intervals each (sample
// variance over B - 1), computed here from the interval counts typed in.
TEST(EdmdSlabBookkeeping, BlocksHoldEqualIntervalsAndErrorsAreTheBatchMeansScatter) {
  SlabProfiles p;
  p.init({2, {10.0, 4.0, 1.0}, 0, 1, true});
  const double V = 40.0, dt = 0.5;
  std::mt19937_64 rng(3);
  std::vector<double> grains(2048);
  for (int i = 0; i < 2048; ++i) {
    grains[i] = 1 + static_cast<int>(rng() % 10);
    std::vector<Vec3> x(static_cast<std::size_t>(grains[i]), Vec3{1.0, 1.0, 0.0}), v(x.size(), Vec3{0.0, 0.0, 0.0});
    p.add_snapshot(x, v);
    p.end_interval(dt);
  }
  const auto& acc = p.accumulators();
  EXPECT_EQ(acc.block_intervals, 8u);
  ASSERT_EQ(acc.blocks.size(), 256u);
  EXPECT_EQ(acc.open_intervals, 0u);
  for (const auto& b : acc.blocks) {
    EXPECT_EQ(b.snapshots, 8.0);
    EXPECT_DOUBLE_EQ(b.time, 8 * dt);
  }
  const auto r = p.result(32);
  EXPECT_EQ(r.batches, 32u);
  double total = 0.0, s = 0.0, s2 = 0.0;
  for (int q = 0; q < 32; ++q) {
    double m = 0.0;
    for (int i = 64 * q; i < 64 * (q + 1); ++i) m += grains[i];
    m /= 64.0 * V;
    s += m, s2 += m * m, total += m / 32.0;
  }
  const double se = std::sqrt((s2 - 32.0 * total * total) / 31.0 / 32.0);
  EXPECT_NEAR(r.field("density").mean[0], total, 1e-14);
  EXPECT_NEAR(r.field("density").stderr_[0], se, 1e-10 * se);
}
