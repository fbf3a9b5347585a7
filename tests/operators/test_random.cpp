// Counter-based RNG: reproducible, independent streams, correct first moments.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <utility>
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
  // a range near 2^32: P(v < 2^30) = 1/3 for range = 3 * 2^30. (This check is blind to the
  // rejection: without it v = floor(3x/4) of the word x, and P(v < 2^30) is 1/3 as well; the
  // uneven classes are v mod 3, checked in BelowIsExactNearTwoToThe32.)
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

// ---------------------------------------------------------------------------------------
// Added by the mutation audit of this file (docs/reviews/mutation-audit-random.md).

namespace {

// Upper Gaussian tail Q(x) = P(Z > x).
double gaussian_q(double x) { return 0.5 * std::erfc(x / std::sqrt(2.0)); }

// Pearson chi-square of counts against expected probabilities (which sum to 1).
double chi_square(const std::vector<double>& counts, const std::vector<double>& p, double n) {
  double chi2 = 0;
  for (std::size_t b = 0; b < counts.size(); ++b) chi2 += (counts[b] - n * p[b]) * (counts[b] - n * p[b]) / (n * p[b]);
  return chi2;
}

}  // namespace

// The words are those of Random123's Philox4x64-10 under the layout documented at the top
// of random.hpp: key (seed, stream), counter (entity, step, block, sequence), all four words
// of a block in order. The reference is r123::Philox4x64 called here with that layout, and
// the header itself is first checked against three known answers of Random123's
// kat_vectors (philox4x64 10: zero, all-ones, and pi's digits as counter and key).
TEST(CounterRng, WordsArePhilox4x64OfTheDocumentedKeyAndCounter) {
  using P = r123::Philox4x64;
  struct Kat {
    P::ctr_type c;
    P::key_type k;
    std::uint64_t out[4];
  };
  const Kat kats[] = {
      {{{0, 0, 0, 0}}, {{0, 0}}, {0x16554d9eca36314cull, 0xdb20fe9d672d0fdcull, 0xd7e772cee186176bull, 0x7e68b68aec7ba23bull}},
      {{{~0ull, ~0ull, ~0ull, ~0ull}}, {{~0ull, ~0ull}},
       {0x87b092c3013fe90bull, 0x438c3c67be8d0224ull, 0x9cc7d7c69cd777b6ull, 0xa09caebf594f0ba0ull}},
      {{{0x243f6a8885a308d3ull, 0x13198a2e03707344ull, 0xa4093822299f31d0ull, 0x082efa98ec4e6c89ull}},
       {{0x452821e638d01377ull, 0xbe5466cf34e90c6cull}},
       {0xa528f45403e61d95ull, 0x38c72dbd566e9788ull, 0xa5a1610e72fd18b5ull, 0x57bd43b5e52b7fe6ull}},
  };
  for (const Kat& kat : kats) {
    const auto o = P{}(kat.c, kat.k);
    for (int j = 0; j < 4; ++j) EXPECT_EQ(o.v[j], kat.out[j]) << j;
  }
  const std::uint64_t seed = 0x0123456789abcdefull, entity = 0xfedcba9876543210ull, step = 0x00000001deadbeefull;
  const Stream stream = Stream::wall_collisions;
  const P::key_type key{{seed, static_cast<std::uint64_t>(stream)}};
  for (const std::uint64_t sequence : {std::uint64_t{0}, std::uint64_t{1}, std::uint64_t{7}}) {
    CounterRng r(seed, stream, entity, step, sequence);
    for (std::uint64_t b = 0; b < 3; ++b) {
      const auto block = P{}(P::ctr_type{{entity, step, b, sequence}}, key);
      for (int j = 0; j < 4; ++j) ASSERT_EQ(r.bits64(), block.v[j]) << "sequence " << sequence << " block " << b << " word " << j;
      EXPECT_EQ(r.blocks_used(), b + 1);
    }
  }
  // the four-argument constructor is sequence 0
  CounterRng r(seed, stream, entity, step);
  for (std::uint64_t b = 0; b < 3; ++b) {
    const auto block = P{}(P::ctr_type{{entity, step, b, 0}}, key);
    for (int j = 0; j < 4; ++j) ASSERT_EQ(r.bits64(), block.v[j]) << "block " << b << " word " << j;
  }
}

// uniform() is the midpoint of the 2^-53 grid cell of the word's top 53 bits,
// ((w >> 11) + 1/2) 2^-53: never 0 or 1 (exponential() = -log u and the normal tails are
// finite), the same mapping as Philox4x32Words::uniform; and the exponential by inversion
// is -log of that uniform. Checked word by word against a generator of the same counter.
TEST(CounterRng, UniformIsTheMidpointOfTheTop53Bits) {
  CounterRng r(11, Stream::initial_positions, 5, 2), words(11, Stream::initial_positions, 5, 2);
  for (int d = 0; d < 1000; ++d) {
    const std::uint64_t w = words.bits64();
    const double u = r.uniform();
    ASSERT_EQ(u, (static_cast<double>(w >> 11) + 0.5) * 0x1.0p-53) << d;
    ASSERT_GT(u, 0.0);
    ASSERT_LT(u, 1.0);
  }
  // the grid's ends: the smallest and largest values uniform() can return
  EXPECT_EQ((static_cast<double>(std::uint64_t{0} >> 11) + 0.5) * 0x1.0p-53, 0x1.0p-54);
  EXPECT_EQ((static_cast<double>(~std::uint64_t{0} >> 11) + 0.5) * 0x1.0p-53, 1.0 - 0x1.0p-54);
}

// The polar method gives two normals per disk point (normal() returns one and keeps the
// other): the pair must be independent standard normals. Under that law the pair's
// exp(-(z1^2 + z2^2)/2) and its angle atan2(z2, z1) are independent uniforms on (0, 1) and
// (-pi, pi): chi-square of each over 50 equal bins (limit at z = 3.72, p ~ 1e-4), and the
// products z1 z2, z1^2 z2^2 of the pair and of neighbouring pairs (means 0 and 1, variances 1
// and 8; 5 standard errors). A spare equal to (or minus) the returned value fails all of these.
TEST(CounterRng, PolarNormalPairsAreIndependent) {
  CounterRng r(31, Stream::initial_velocities, 9, 0);
  const int pairs = 500'000, bins = 50;
  std::vector<double> radial(bins, 0.0), angle(bins, 0.0);
  double prod = 0, prod_sq = 0, next_prod = 0, prev = 0;  // prev: the second normal of the previous pair
  for (int k = 0; k < pairs; ++k) {
    const double z1 = r.normal(), z2 = r.normal();  // one disk point
    prod += z1 * z2;
    prod_sq += z1 * z1 * z2 * z2;
    next_prod += prev * z1;
    prev = z2;
    radial[std::min(bins - 1, static_cast<int>(std::exp(-0.5 * (z1 * z1 + z2 * z2)) * bins))] += 1;
    angle[std::min(bins - 1, static_cast<int>((std::atan2(z2, z1) / std::numbers::pi + 1.0) * 0.5 * bins))] += 1;
  }
  const std::vector<double> flat(bins, 1.0 / bins);
  const double limit = chi2_quantile(bins - 1.0, 3.72);
  EXPECT_LT(chi_square(radial, flat, pairs), limit);
  EXPECT_LT(chi_square(angle, flat, pairs), limit);
  EXPECT_NEAR(prod / pairs, 0.0, 5 / std::sqrt(pairs));
  EXPECT_NEAR(next_prod / pairs, 0.0, 5 / std::sqrt(pairs));
  EXPECT_NEAR(prod_sq / pairs, 1.0, 5 * std::sqrt(8.0 / pairs));
}

// The ziggurat tails on their own, with enough tail draws to see a wrong acceptance
// (the tests above see ~1000): of 6.4e7 normal draws, the ~1.7e4 beyond r have a random
// sign (binomial, 5 standard errors) and the excess |x| - r of the exact Gaussian tail,
// P(|x| > r + a | |x| > r) = Q(r + a) / Q(r): chi-square over 16 bins of equal
// probability (edges by bisection on erfc) and the mean excess to 5 standard errors (the
// sample's own). The exponential's ~2.9e4 tail draws of 6.4e7: excess Exp(1), the same checks.
TEST(Ziggurat, TailsAreTheExactTails) {
  const int n = 64'000'000, bins = 16;
  const double rn = ZigguratTable::normal().r, re = ZigguratTable::exponential().r;
  // excess edges of equal conditional probability: a_b with Q(r + a_b) = (1 - b / bins) Q(r)
  std::vector<double> edges;
  for (int b = 1; b < bins; ++b) {
    double lo = 0, hi = 10;
    for (int it = 0; it < 200; ++it) {
      const double mid = 0.5 * (lo + hi);
      (gaussian_q(rn + mid) > (1.0 - double(b) / bins) * gaussian_q(rn) ? lo : hi) = mid;
    }
    edges.push_back(0.5 * (lo + hi));
  }
  CounterRng r(97, Stream::edmd_background, 1, 0);
  std::vector<double> hist(bins, 0.0), excess;
  double positive = 0;
  for (int k = 0; k < n; ++k) {
    const double x = r.normal_ziggurat();
    if (std::abs(x) <= rn) continue;
    positive += x > 0;
    const double a = std::abs(x) - rn;
    excess.push_back(a);
    hist[std::upper_bound(edges.begin(), edges.end(), a) - edges.begin()] += 1;
  }
  const double tail = static_cast<double>(excess.size());
  ASSERT_GT(tail, 10'000);
  const double limit = chi2_quantile(bins - 1.0, 3.72);
  const double chi2 = chi_square(hist, std::vector<double>(bins, 1.0 / bins), tail);
  EXPECT_LT(chi2, limit) << "normal tail";
  EXPECT_NEAR(positive / tail, 0.5, 5 * 0.5 / std::sqrt(tail));
  double m = 0, m2 = 0;
  for (double a : excess) m += a, m2 += a * a;
  m /= tail;
  const double se = std::sqrt((m2 / tail - m * m) / tail);
  const double exact = std::exp(-0.5 * rn * rn) / std::sqrt(2 * std::numbers::pi) / gaussian_q(rn) - rn;
  EXPECT_NEAR(m, exact, 5 * se);
  std::printf("normal tail: %.0f draws, positive %.4f, chi2 %.1f (limit %.1f), mean excess %.5f +- %.5f (exact %.5f)\n",
              tail, positive / tail, chi2, limit, m, se, exact);

  CounterRng s(98, Stream::edmd_background, 2, 0);
  std::vector<double> ehist(bins, 0.0);
  double etail = 0, esum = 0;
  for (int k = 0; k < n; ++k) {
    const double x = s.exponential_ziggurat();
    if (x <= re) continue;
    etail += 1;
    esum += x - re;
    // P(excess > a) = exp(-a): bin b = floor(bins (1 - exp(-a)))
    ehist[std::min(bins - 1, static_cast<int>(bins * -std::expm1(-(x - re))))] += 1;
  }
  ASSERT_GT(etail, 10'000);
  const double echi2 = chi_square(ehist, std::vector<double>(bins, 1.0 / bins), etail);
  EXPECT_LT(echi2, limit) << "exponential tail";
  EXPECT_NEAR(esum / etail, 1.0, 5 / std::sqrt(etail));
  std::printf("exponential tail: %.0f draws, chi2 %.1f, mean excess %.4f (exact 1)\n", etail, echi2, esum / etail);
}

// below(range) at ranges near 2^32, where the multiply-shift alone is far from uniform: the
// 2^32 words map onto range values in a pattern of period range / 2^k (range = c 2^k, c
// odd), and the rejection of the low products under 2^32 mod range evens it out exactly.
// For range = 3 2^30 the values v = floor(3x/4) of the words x take v mod 3 = 0 for half of
// the words (1/3 after the rejection); for range = 9 2^28 (2^32 mod range = 7 2^28, above
// range / 2) v mod 9 is uneven unless all seven low products 0 .. 6 (times 2^28) are
// rejected. Chi-square of v mod c over c classes of exact probability 1/c (p ~ 1e-4).
TEST(CounterRng, BelowIsExactNearTwoToThe32) {
  CounterRng r(81, Stream::grain_collisions, 7, 0);
  const int n = 300'000;
  for (const auto& [c, k] : {std::pair<std::uint32_t, int>{3, 30}, std::pair<std::uint32_t, int>{9, 28}}) {
    const std::uint32_t range = c << k;
    std::vector<double> hist(c, 0.0);
    for (int t = 0; t < n; ++t) {
      const std::uint32_t v = r.below(range);
      ASSERT_LT(v, range);
      hist[v % c] += 1;
    }
    const double chi2 = chi_square(hist, std::vector<double>(c, 1.0 / c), n);
    EXPECT_LT(chi2, chi2_quantile(c - 1.0, 3.72)) << "range " << c << " 2^" << k << ": chi2 " << chi2;
  }
}

// The stream registry: the numbers are part of every result for a given seed ("never
// renumber"), two consumers must never share one, and Philox4x32Words puts the stream in
// 8 bits of a counter word (streams < 256).
TEST(Stream, RegistryNumbersAreFixedAndDistinct) {
  const std::pair<Stream, std::uint64_t> registry[] = {
      {Stream::initial_velocities, 1},      {Stream::initial_positions, 2},        {Stream::background_first_half, 3},
      {Stream::background_second_half, 4},  {Stream::grain_collisions, 5},         {Stream::sort_shuffle, 6},
      {Stream::edmd_heating, 7},            {Stream::edmd_collisions, 8},          {Stream::edmd_background, 9},
      {Stream::wall_collisions, 10},        {Stream::background_clock, 11},        {Stream::initial_angular_velocities, 12},
      {Stream::background_joined_halves, 13}, {Stream::collision_groups, 14},     {Stream::ntc_initial_remainder, 15},
  };
  std::vector<std::uint64_t> seen;
  for (const auto& [stream, number] : registry) {
    EXPECT_EQ(static_cast<std::uint64_t>(stream), number);
    EXPECT_LT(static_cast<std::uint64_t>(stream), 256u);
    EXPECT_EQ(std::count(seen.begin(), seen.end(), static_cast<std::uint64_t>(stream)), 0) << number;
    seen.push_back(static_cast<std::uint64_t>(stream));
  }
}
