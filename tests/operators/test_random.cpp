// Counter-based RNG: reproducible, independent streams, correct first moments.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include "operators/random.hpp"

using namespace grainbath;

TEST(CounterRng, SameKeyAndCounterGiveSameNumbers) {
  CounterRng a(42, Stream::grain_collisions, 7, 3), b(42, Stream::grain_collisions, 7, 3);
  for (int k = 0; k < 100; ++k) ASSERT_EQ(a.uniform(), b.uniform());
}

TEST(CounterRng, DifferentStreamsEntitiesStepsDiffer) {
  CounterRng a(42, Stream::grain_collisions, 7, 3);
  CounterRng b(42, Stream::background_first_half, 7, 3);
  CounterRng c(42, Stream::grain_collisions, 8, 3);
  CounterRng d(42, Stream::grain_collisions, 7, 4);
  CounterRng e(43, Stream::grain_collisions, 7, 3);
  const double x = a.uniform();
  EXPECT_NE(x, b.uniform());
  EXPECT_NE(x, c.uniform());
  EXPECT_NE(x, d.uniform());
  EXPECT_NE(x, e.uniform());
}

TEST(CounterRng, UsesAllFourWordsPerBlock) {
  CounterRng a(1, Stream::grain_collisions, 0, 0);
  for (int k = 0; k < 8; ++k) a.uniform();
  EXPECT_EQ(a.blocks_used(), 2u);
}

TEST(CounterRng, UniformAndNormalMoments) {
  CounterRng r(2024, Stream::initial_velocities, 1, 0);
  const int n = 1'000'000;
  double su = 0, su2 = 0, sn = 0, sn2 = 0, sn4 = 0;
  double umin = 1, umax = 0;
  for (int k = 0; k < n; ++k) {
    const double u = r.uniform();
    su += u;
    su2 += u * u;
    umin = std::min(umin, u);
    umax = std::max(umax, u);
    const double z = r.normal();
    sn += z;
    sn2 += z * z;
    sn4 += z * z * z * z;
  }
  EXPECT_GT(umin, 0.0);
  EXPECT_LT(umax, 1.0);
  // standard errors: uniform mean sqrt(1/12/n); normal mean 1/sqrt(n); <z^2> sqrt(2/n); <z^4> sqrt(96/n)
  EXPECT_NEAR(su / n, 0.5, 5 * std::sqrt(1.0 / 12 / n));
  EXPECT_NEAR(su2 / n, 1.0 / 3, 5 * std::sqrt(4.0 / 45 / n));
  EXPECT_NEAR(sn / n, 0.0, 5 / std::sqrt(n));
  EXPECT_NEAR(sn2 / n, 1.0, 5 * std::sqrt(2.0 / n));
  EXPECT_NEAR(sn4 / n, 3.0, 5 * std::sqrt(96.0 / n));
}

TEST(CounterRng, UnitVectorIsIsotropic) {
  CounterRng r(5, Stream::initial_positions, 0, 0);
  const int n = 400'000;
  double sx = 0, sz2 = 0, len_err = 0;
  for (int k = 0; k < n; ++k) {
    const Vec3 u = r.unit_vector();
    sx += u.x;
    sz2 += u.z * u.z;
    len_err = std::max(len_err, std::abs(norm(u) - 1.0));
  }
  EXPECT_LT(len_err, 1e-14);
  EXPECT_NEAR(sx / n, 0.0, 5 * std::sqrt(1.0 / 3 / n));
  EXPECT_NEAR(sz2 / n, 1.0 / 3, 5 * std::sqrt(4.0 / 45 / n));
}

// ---------------------------------------------------------------------------------------
// Ziggurat samplers (normal_ziggurat, exponential_ziggurat) against the exact distributions.
// Each check uses quantities computed here from erf/exp, not from the sampler's tables,
// except the layer edges, which are only used to place bins where a wrong layer area or a
// wrong wedge test would show.

namespace {

double normal_cdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

// Wilson-Hilferty upper quantile of chi-square with k degrees of freedom at z sigma.
double chi2_quantile(double k, double z) {
  const double a = 2.0 / (9.0 * k);
  return k * std::pow(1.0 - a + z * std::sqrt(a), 3.0);
}

// Kolmogorov-Smirnov distance of a sample from a CDF.
template <class Cdf>
double ks_distance(std::vector<double> x, Cdf cdf) {
  std::sort(x.begin(), x.end());
  const double n = static_cast<double>(x.size());
  double d = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double F = cdf(x[i]);
    d = std::max({d, F - i / n, (i + 1) / n - F});
  }
  return d;
}

}  // namespace

// The bisection for r reproduces the published constants (Marsaglia & Tsang 2000: r =
// 3.6541528853610088 for the normal, 7.69711747013104972 for the exponential, 256 layers),
// and every layer has the base layer's area.
TEST(Ziggurat, TablesCloseWithEqualLayerAreas) {
  const auto& zn = ZigguratTable::normal();
  const auto& ze = ZigguratTable::exponential();
  EXPECT_NEAR(zn.r, 3.6541528853610088, 1e-12);
  EXPECT_NEAR(ze.r, 7.69711747013104972, 1e-12);
  const double vn = zn.r * std::exp(-0.5 * zn.r * zn.r) + std::sqrt(std::numbers::pi / 2) * std::erfc(zn.r / std::sqrt(2.0));
  const double ve = (ze.r + 1.0) * std::exp(-ze.r);
  for (int i = 1; i < ZigguratTable::kLayers; ++i) {
    EXPECT_NEAR(zn.x[i] * (zn.f[i + 1] - zn.f[i]), vn, 1e-12 * vn) << i;
    EXPECT_NEAR(ze.x[i] * (ze.f[i + 1] - ze.f[i]), ve, 1e-12 * ve) << i;
  }
  EXPECT_EQ(zn.x[ZigguratTable::kLayers], 0.0);
  EXPECT_NEAR(zn.x[0] * std::exp(-0.5 * zn.r * zn.r), vn, 1e-14);
}

TEST(Ziggurat, NormalMatchesTheGaussian) {
  CounterRng r(77, Stream::initial_velocities, 3, 0);
  const int n = 4'000'000;
  std::vector<double> ks;
  ks.reserve(1'000'000);
  const auto& z = ZigguratTable::normal();
  // bins in |x| at the layer edges x[255] < ... < x[1] = r, plus [0, x[255]) and the tail
  const int L = ZigguratTable::kLayers;
  std::vector<double> edges;
  for (int i = L - 1; i >= 1; --i) edges.push_back(z.x[i]);  // increasing
  std::vector<double> hist(edges.size() + 1, 0.0);
  double s1 = 0, s2 = 0, s4 = 0, s6 = 0, tail = 0, tail_excess = 0, positive = 0;
  for (int k = 0; k < n; ++k) {
    const double x = r.normal_ziggurat();
    if (k < 1'000'000) ks.push_back(x);
    const double a = std::abs(x), x2 = x * x;
    s1 += x;
    s2 += x2;
    s4 += x2 * x2;
    s6 += x2 * x2 * x2;
    positive += x > 0;
    hist[std::upper_bound(edges.begin(), edges.end(), a) - edges.begin()] += 1;
    if (a > z.r) {
      tail += 1;
      tail_excess += a - z.r;
    }
  }
  // moments, 5 standard errors: Var(x) = 1, Var(x^2) = 2, Var(x^4) = 96, Var(x^6) = 10170
  EXPECT_NEAR(s1 / n, 0.0, 5 * std::sqrt(1.0 / n));
  EXPECT_NEAR(s2 / n, 1.0, 5 * std::sqrt(2.0 / n));
  EXPECT_NEAR(s4 / n, 3.0, 5 * std::sqrt(96.0 / n));
  EXPECT_NEAR(s6 / n, 15.0, 5 * std::sqrt(10170.0 / n));
  EXPECT_NEAR(positive / n, 0.5, 5 * std::sqrt(0.25 / n));
  // chi-square over the layer bins and the tail (exact probabilities from erf)
  double chi2 = 0, lo = 0;
  for (std::size_t b = 0; b < hist.size(); ++b) {
    const double hi = b < edges.size() ? edges[b] : INFINITY;
    const double p = 2.0 * ((b < edges.size() ? normal_cdf(hi) : 1.0) - normal_cdf(lo));
    chi2 += (hist[b] - n * p) * (hist[b] - n * p) / (n * p);
    lo = hi;
  }
  EXPECT_LT(chi2, chi2_quantile(static_cast<double>(hist.size() - 1), 3.72)) << "chi2 = " << chi2;  // p ~ 1e-4
  std::printf("normal: chi2 = %.1f (%zu dof, limit %.1f)\n", chi2, hist.size() - 1,
              chi2_quantile(static_cast<double>(hist.size() - 1), 3.72));
  // the tail: its probability 2 Q(r) and the conditional mean excess phi(r)/Q(r) - r
  const double q = 0.5 * std::erfc(z.r / std::sqrt(2.0));
  const double expected_tail = 2 * q * n;
  EXPECT_NEAR(tail, expected_tail, 5 * std::sqrt(expected_tail));
  const double phi = std::exp(-0.5 * z.r * z.r) / std::sqrt(2 * std::numbers::pi);
  const double mean_excess = phi / q - z.r;  // ~ 1/r
  // excess variance below mean_excess^2 (the tail is lighter than exponential)
  EXPECT_NEAR(tail_excess / tail, mean_excess, 5 * mean_excess / std::sqrt(tail));
  // Kolmogorov-Smirnov on the first 10^6 draws: sqrt(n) D < 1.95 at p = 0.001
  const double ks_n = std::sqrt(1e6) * ks_distance(ks, normal_cdf);
  std::printf("normal: tail %.0f (expected %.1f), mean excess %.5f (exact %.5f), sqrt(n) D = %.3f\n", tail,
              expected_tail, tail_excess / tail, mean_excess, ks_n);
  EXPECT_LT(ks_n, 1.95);
}

TEST(Ziggurat, ExponentialMatchesTheExponential) {
  CounterRng r(78, Stream::initial_velocities, 4, 0);
  const int n = 4'000'000;
  std::vector<double> ks;
  ks.reserve(1'000'000);
  const auto& z = ZigguratTable::exponential();
  const int L = ZigguratTable::kLayers;
  std::vector<double> edges;
  for (int i = L - 1; i >= 1; --i) edges.push_back(z.x[i]);
  std::vector<double> hist(edges.size() + 1, 0.0);
  double s1 = 0, s2 = 0, s3 = 0, tail = 0, tail_excess = 0, far = 0;
  for (int k = 0; k < n; ++k) {
    const double x = r.exponential_ziggurat();
    ASSERT_GE(x, 0.0);
    if (k < 1'000'000) ks.push_back(x);
    s1 += x;
    s2 += x * x;
    s3 += x * x * x;
    hist[std::upper_bound(edges.begin(), edges.end(), x) - edges.begin()] += 1;
    if (x > z.r) {
      tail += 1;
      tail_excess += x - z.r;
    }
    if (x > z.r + 2.0) far += 1;
  }
  // moments 1, 2, 6 with Var = 1, 20, 684
  EXPECT_NEAR(s1 / n, 1.0, 5 * std::sqrt(1.0 / n));
  EXPECT_NEAR(s2 / n, 2.0, 5 * std::sqrt(20.0 / n));
  EXPECT_NEAR(s3 / n, 6.0, 5 * std::sqrt(684.0 / n));
  double chi2 = 0, lo = 0;
  for (std::size_t b = 0; b < hist.size(); ++b) {
    const double hi = b < edges.size() ? edges[b] : INFINITY;
    const double p = std::exp(-lo) - (b < edges.size() ? std::exp(-hi) : 0.0);
    chi2 += (hist[b] - n * p) * (hist[b] - n * p) / (n * p);
    lo = hi;
  }
  EXPECT_LT(chi2, chi2_quantile(static_cast<double>(hist.size() - 1), 3.72)) << "chi2 = " << chi2;
  std::printf("exponential: chi2 = %.1f (%zu dof)\n", chi2, hist.size() - 1);
  const double expected_tail = n * std::exp(-z.r);
  EXPECT_NEAR(tail, expected_tail, 5 * std::sqrt(expected_tail));
  EXPECT_NEAR(tail_excess / tail, 1.0, 5 / std::sqrt(tail));  // memoryless: excess ~ Exp(1)
  const double expected_far = n * std::exp(-z.r - 2.0);
  EXPECT_NEAR(far, expected_far, 5 * std::sqrt(expected_far));
  const double ks_n = std::sqrt(1e6) * ks_distance(ks, [](double x) { return 1.0 - std::exp(-x); });
  std::printf("exponential: tail %.0f (expected %.1f), mean excess %.4f (exact 1), beyond r + 2: %.0f (expected %.1f), "
              "sqrt(n) D = %.3f\n",
              tail, expected_tail, tail_excess / tail, far, expected_far, ks_n);
  EXPECT_LT(ks_n, 1.95);
}

TEST(CounterRng, BelowIsUniformOnTheIntegers) {
  CounterRng r(79, Stream::grain_collisions, 5, 0);
  for (std::uint32_t range : {1u, 2u, 7u, 16u, 1000u}) {
    std::vector<double> hist(range, 0.0);
    const int n = 200'000;
    for (int k = 0; k < n; ++k) {
      const std::uint32_t v = r.below(range);
      ASSERT_LT(v, range);
      hist[v] += 1;
    }
    if (range == 1) continue;
    double chi2 = 0;
    for (double h : hist) chi2 += (h - double(n) / range) * (h - double(n) / range) / (double(n) / range);
    EXPECT_LT(chi2, chi2_quantile(range - 1.0, 3.72)) << range;
  }
  // a range near 2^32 where the multiply-shift bias would be large without the rejection:
  // range = 3 * 2^30; without the rejection values below 2^30 would come out with
  // probability 2/2^32 each instead of 1/range (4/3 of the others... here: P(v < 2^30) = 1/3)
  const std::uint32_t big = 3u << 30;
  double low = 0;
  const int n = 300'000;
  for (int k = 0; k < n; ++k) low += r.below(big) < (1u << 30);
  EXPECT_NEAR(low / n, 1.0 / 3.0, 5 * std::sqrt(2.0 / 9.0 / n));
}

// The integer-SIMD Philox4x32-10 of the bath kernel: every compiled path gives Random123's
// scalar r123::Philox4x32 words (words8_scalar), for ids with high bits, every stream byte
// and step, and block bases far from 0; and the scalar words are Random123's known answer.
TEST(Philox4x32Lanes, SimdPathsEqualRandom123) {
  const auto kat = r123::Philox4x32{}(r123::Philox4x32::ctr_type{{0, 0, 0, 0}}, r123::Philox4x32::key_type{{0, 0}});
  EXPECT_EQ(kat.v[0], 0x6627e8d5u);  // Random123 kat_vectors: philox4x32_10, zero counter and key
  EXPECT_EQ(kat.v[3], 0x9b00dbd8u);
  const std::size_t n = 777;
  std::vector<std::uint32_t> c0(n), c1(n);
  for (std::size_t a = 0; a < n; ++a) {
    c0[a] = static_cast<std::uint32_t>(a * 2654435761u);
    c1[a] = static_cast<std::uint32_t>((a % 256) << 24 | (a * 40503u & 0xffffffu));
  }
  for (const std::uint64_t key : {std::uint64_t{0}, std::uint64_t{1}, std::uint64_t{0xfedcba9876543210ull}}) {
    for (const std::uint32_t base : {0u, 4u, 4000000000u}) {
      std::vector<std::uint64_t> ref(8 * n), sse2(8 * n, 0), avx2(8 * n, 0);
      for (std::size_t a = 0; a < n; ++a) Philox4x32Lanes::words8_scalar(key, c0[a], c1[a], 123456789u, base, &ref[8 * a]);
      detail::philox_sse2::words8(key, c0.data(), c1.data(), 123456789u, base, n, sse2.data());
      EXPECT_EQ(sse2, ref);
      if (Philox4x32Lanes::have_avx2()) {
        detail::philox_avx2::words8(key, c0.data(), c1.data(), 123456789u, base, n, avx2.data());
        EXPECT_EQ(avx2, ref);
      }
      std::vector<std::uint64_t> best(8 * n, 0);
      Philox4x32Lanes::words8(key, c0.data(), c1.data(), 123456789u, base, n, best.data());
      EXPECT_EQ(best, ref);
      // words4 (two blocks per group, the bath kernel's budget), for every group count up to
      // 9 (odd counts take the AVX2 path's single-group tail) and for all n groups
      for (const std::size_t m : {std::size_t{1}, std::size_t{2}, std::size_t{3}, std::size_t{4}, std::size_t{5},
                                  std::size_t{6}, std::size_t{7}, std::size_t{8}, std::size_t{9}, n}) {
        std::vector<std::uint64_t> ref4(4 * m + 4, 7), sse4(4 * m + 4, 7), avx4(4 * m + 4, 7), best4(4 * m + 4, 7);
        for (std::size_t a = 0; a < m; ++a)
          Philox4x32Lanes::words4_scalar(key, c0[a], c1[a], 123456789u, base, &ref4[4 * a]);
        for (std::size_t a = 0; a < m; ++a) {  // words4's blocks are words8's first two
          ASSERT_EQ(ref4[4 * a], ref[8 * a]);
          ASSERT_EQ(ref4[4 * a + 1], ref[8 * a + 1]);
          ASSERT_EQ(ref4[4 * a + 2], ref[8 * a + 4]);
          ASSERT_EQ(ref4[4 * a + 3], ref[8 * a + 5]);
        }
        detail::philox_sse2::words4(key, c0.data(), c1.data(), 123456789u, base, m, sse4.data());
        EXPECT_EQ(sse4, ref4) << m;  // (including the untouched words after the last group)
        if (Philox4x32Lanes::have_avx2()) {
          detail::philox_avx2::words4(key, c0.data(), c1.data(), 123456789u, base, m, avx4.data());
          EXPECT_EQ(avx4, ref4) << m;
        }
        if (Philox4x32Lanes::have_avx512()) {  // four groups per zmm: every m not a multiple of 4 has a short tail
          std::vector<std::uint64_t> z4(4 * m + 4, 7);
          detail::philox_avx512::words4(key, c0.data(), c1.data(), 123456789u, base, m, z4.data());
          EXPECT_EQ(z4, ref4) << m;
        }
        Philox4x32Lanes::words4(key, c0.data(), c1.data(), 123456789u, base, m, best4.data());
        EXPECT_EQ(best4, ref4) << m;
      }
    }
  }
  if (!Philox4x32Lanes::have_avx2()) GTEST_SKIP() << "no AVX2 on this CPU: only the SSE2 path was compared";
}
