// The candidate pair of the NTC collisions (src/dsmc/collide.hpp): i uniform on [0, N) and j
// on the other N - 1 grains, from the two 32-bit halves of one Philox word (below_from); and
// the generator of a cell's collision words (Philox4x32Words, operators/random.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <cstdint>
#include <vector>

#include "dsmc/collide.hpp"
#include "operators/random.hpp"

namespace {

using grainbath::CounterRng;
using grainbath::Philox4x32Lanes;
using grainbath::Philox4x32Words;
using grainbath::Stream;
using grainbath::dsmc::below_from;

TEST(DsmcPairDraw, MultiplyShiftWhenNotRejected) {
  CounterRng rng(3, Stream::grain_collisions, 7, 1);
  for (std::uint32_t range : {1u, 2u, 3u, 16u, 1000u, 0x7fffffffu}) {
    for (int t = 0; t < 1000; ++t) {
      const auto bits = static_cast<std::uint32_t>(rng.bits64());
      const std::uint64_t m = static_cast<std::uint64_t>(bits) * range;
      if (static_cast<std::uint32_t>(m) < range) continue;  // may be rejected: checked below
      CounterRng unused(3, Stream::grain_collisions, 8, 1);
      EXPECT_EQ(below_from(bits, range, unused), static_cast<std::uint32_t>(m >> 32));
      EXPECT_EQ(unused.blocks_used(), 0u);  // no further bits drawn
    }
  }
}

TEST(DsmcPairDraw, RejectedValueIsRedrawnFromTheLowHalfOfFreshWords) {
  // range 2^31 + 1: the biased zone is below 2^32 mod range = 2^31 - 1; bits 0 lands in it
  const std::uint32_t range = 0x80000001u, threshold = (0u - range) % range;
  CounterRng rng(5, Stream::grain_collisions, 11, 2), copy = rng;
  const std::uint32_t got = below_from(0u, range, rng);
  std::uint64_t m = 0;
  do m = static_cast<std::uint64_t>(static_cast<std::uint32_t>(copy.bits64())) * range;
  while (static_cast<std::uint32_t>(m) < threshold);
  EXPECT_EQ(got, static_cast<std::uint32_t>(m >> 32));
  EXPECT_LT(got, range);
}

// The ordered pairs (i, j != i) of N grains drawn as collide_cell does: every pair equally
// likely (chi-square over N (N - 1) pairs, 0.1 % level), never i == j. For both generators:
// collide_cell's (Philox4x32Words, CellCollisionRng) and CounterRng.
template <class Rng>
void expect_ordered_pairs_uniform() {
  for (std::uint32_t n : {2u, 3u, 5u, 16u}) {
    Rng rng(9, Stream::grain_collisions, n, 4);
    std::vector<double> hits(static_cast<std::size_t>(n) * n, 0.0);
    const int draws = 400000;
    for (int t = 0; t < draws; ++t) {
      const std::uint64_t word = rng.bits64();
      const std::uint32_t i = below_from(static_cast<std::uint32_t>(word), n, rng);
      std::uint32_t j = below_from(static_cast<std::uint32_t>(word >> 32), n - 1, rng);
      if (j >= i) ++j;
      ASSERT_LT(i, n);
      ASSERT_LT(j, n);
      ASSERT_NE(i, j);
      hits[static_cast<std::size_t>(i) * n + j] += 1.0;
    }
    const double pairs = static_cast<double>(n) * (n - 1), expected = draws / pairs;
    double chi2 = 0.0;
    for (std::uint32_t i = 0; i < n; ++i)
      for (std::uint32_t j = 0; j < n; ++j)
        if (i != j) chi2 += (hits[i * n + j] - expected) * (hits[i * n + j] - expected) / expected;
    // 0.1 % quantile of chi-square with dof = pairs - 1, Wilson-Hilferty
    const double dof = pairs - 1, z = 3.09;
    const double limit = dof * std::pow(1.0 - 2.0 / (9.0 * dof) + z * std::sqrt(2.0 / (9.0 * dof)), 3);
    EXPECT_LT(chi2, limit) << "N " << n;
  }
}

TEST(DsmcPairDraw, OrderedPairsAreUniform) {
  expect_ordered_pairs_uniform<grainbath::dsmc::CellCollisionRng>();
  expect_ordered_pairs_uniform<CounterRng>();
}

// The collision words of a cell (Philox4x32Words): one group of eight words (two: group2) is computed by
// detail::philox_sse2::group / philox_avx2::group with the round keys advanced in a register; both must give
// Random123's scalar Philox4x32 words (words8_scalar) for keys and counters with high bits
// and block bases up to the 2^32 wrap. Fails if a round key, a multiplier or the word
// packing differs.
// The branch-free bound of cells of 2..24 grains (AVX-512F/VL) gives the SSE2 bound's bits:
// random velocities, ties (equal speeds), zeros and negative zeros, one fast grain, cells
// at the very end of their arrays (the masked loads past them must not fault or count).
TEST(DsmcPairDraw, MaskedBoundEqualsPairSpeedBound) {
  if (!grainbath::dsmc::detail::have_masked_bound()) GTEST_SKIP() << "no AVX-512F/VL (or GRAINBATH_SIMD rules it out)";
  CounterRng rng(9, Stream::grain_collisions, 3, 4);
  for (std::size_t count = 2; count <= 24; ++count) {
    for (int kind = 0; kind < 6; ++kind) {
      for (int rep = 0; rep < 50; ++rep) {
        std::vector<double> v[3];
        for (auto& a : v) {
          a.resize(count);
          for (std::size_t s = 0; s < count; ++s) {
            double x = 2.0 * rng.uniform() - 1.0;
            if (kind == 1) x = std::round(4.0 * x) / 4.0;             // many ties
            if (kind == 2) x = (s % 3 == 0) ? 0.0 : -0.0;             // zeros of both signs
            if (kind == 3 && s == count / 2) x *= 1e6;                // one fast grain
            if (kind == 4) x = -1e-300 * (1.0 + rng.uniform());       // tiny, negative
            if (kind == 5) x = 0.75;                                  // all equal: bound 0
            a[s] = x;
          }
        }
        const double want = grainbath::dsmc::pair_speed_bound(v[0].data(), v[1].data(), v[2].data(), count);
        const double got = grainbath::dsmc::detail::pair_speed_bound_24(v[0].data(), v[1].data(), v[2].data(), count);
        ASSERT_EQ(std::memcmp(&want, &got, sizeof want), 0) << "count " << count << " kind " << kind << ": " << want << " vs " << got;
      }
    }
  }
}

TEST(DsmcCollisionWords, GroupPathsEqualRandom123) {
  for (const std::uint64_t key : {std::uint64_t{0}, std::uint64_t{1}, std::uint64_t{0xfedcba9876543210ull}}) {
    for (const std::uint32_t base : {0u, 4u, 4000000000u, 0xfffffffcu}) {
      for (std::uint32_t a = 0; a < 50; ++a) {
        const std::uint32_t c0 = a * 2654435761u, c1 = (a % 256) << 24 | (a * 40503u & 0xffffffu), c2 = a * 97u + 123456789u;
        std::uint64_t ref[8], sse2[8] = {}, avx2[8] = {};
        Philox4x32Lanes::words8_scalar(key, c0, c1, c2, base, ref);
        grainbath::detail::philox_sse2::group(key, c0, c1, c2, base, sse2);
        for (int j = 0; j < 8; ++j) ASSERT_EQ(sse2[j], ref[j]) << "key " << key << " base " << base << " a " << a;
        if (Philox4x32Lanes::have_avx2()) {
          grainbath::detail::philox_avx2::group(key, c0, c1, c2, base, avx2);
          for (int j = 0; j < 8; ++j) ASSERT_EQ(avx2[j], ref[j]) << "key " << key << " base " << base << " a " << a;
        }
        // group2 (Philox4x32Words::refill): groups base and base + 4 (the counter wraps mod 2^32)
        std::uint64_t ref2[16], sse2_2[16] = {}, avx2_2[16] = {};
        Philox4x32Lanes::words8_scalar(key, c0, c1, c2, base, ref2);
        Philox4x32Lanes::words8_scalar(key, c0, c1, c2, base + 4u, ref2 + 8);
        grainbath::detail::philox_sse2::group2(key, c0, c1, c2, base, sse2_2);
        for (int j = 0; j < 16; ++j) ASSERT_EQ(sse2_2[j], ref2[j]) << "group2 key " << key << " base " << base << " a " << a;
        if (Philox4x32Lanes::have_avx2()) {
          grainbath::detail::philox_avx2::group2(key, c0, c1, c2, base, avx2_2);
          for (int j = 0; j < 16; ++j) ASSERT_EQ(avx2_2[j], ref2[j]) << "group2 key " << key << " base " << base << " a " << a;
        }
      }
    }
  }
  if (!Philox4x32Lanes::have_avx2()) GTEST_SKIP() << "no AVX2 on this CPU: only the SSE2 path was compared";
}

// The generator is counter-based on (seed, stream; cell, step, draw): word d of cell k at
// step s is word d % 8 of the Philox4x32 group with counters (k low, k high | stream << 24,
// s, 4 (d / 8)) under the seed, so it does not depend on which thread or rank handles the
// cell; uniform() is (w >> 11 + 1/2) 2^-53 of the next word. Changing any key part changes
// the words.
TEST(DsmcCollisionWords, KeyedOnSeedStreamCellStepDraw) {
  const std::uint64_t seed = 0x123456789abcdefull, cell = 0x00ab0000cafef00dull, step = 4242;
  Philox4x32Words rng(seed, Stream::grain_collisions, cell, step);
  const auto c0 = static_cast<std::uint32_t>(cell);
  const auto c1 = static_cast<std::uint32_t>(cell >> 32) | static_cast<std::uint32_t>(Stream::grain_collisions) << 24;
  std::uint64_t ref[24];
  for (std::uint32_t g = 0; g < 3; ++g) Philox4x32Lanes::words8_scalar(seed, c0, c1, static_cast<std::uint32_t>(step), 4 * g, ref + 8 * g);
  for (int d = 0; d < 20; ++d) EXPECT_EQ(rng.bits64(), ref[d]) << "draw " << d;
  EXPECT_EQ(rng.uniform(), (static_cast<double>(ref[20] >> 11) + 0.5) * 0x1.0p-53);
  EXPECT_EQ(rng.groups_used(), 4u);  // computed two groups at a time (Philox4x32Words::kWindow)
  const std::uint64_t first = ref[0];
  EXPECT_NE(Philox4x32Words(seed + 1, Stream::grain_collisions, cell, step).bits64(), first);
  EXPECT_NE(Philox4x32Words(seed, Stream::sort_shuffle, cell, step).bits64(), first);
  EXPECT_NE(Philox4x32Words(seed, Stream::grain_collisions, cell + 1, step).bits64(), first);
  EXPECT_NE(Philox4x32Words(seed, Stream::grain_collisions, cell + (1ull << 32), step).bits64(), first);
  EXPECT_NE(Philox4x32Words(seed, Stream::grain_collisions, cell, step + 1).bits64(), first);
}

// The directions of the collisions (Philox4x32Words::unit_vector): unit length, and uniform
// on the sphere to 5 standard errors in the first and second moments (<n> = 0,
// <n_a n_b> = delta_ab / 3), and the uniforms in (0, 1) with mean 1/2.
TEST(DsmcCollisionWords, UnitVectorsAndUniforms) {
  Philox4x32Words rng(77, Stream::grain_collisions, 3, 9);
  const int n = 200000;
  double m[3] = {}, q[3][3] = {}, umean = 0;
  for (int t = 0; t < n; ++t) {
    const grainbath::Vec3 r = rng.unit_vector();
    ASSERT_NEAR(r.x * r.x + r.y * r.y + r.z * r.z, 1.0, 1e-14);
    const double c[3] = {r.x, r.y, r.z};
    for (int a = 0; a < 3; ++a) {
      m[a] += c[a];
      for (int b = 0; b < 3; ++b) q[a][b] += c[a] * c[b];
    }
    const double u = rng.uniform();
    ASSERT_GT(u, 0.0);
    ASSERT_LT(u, 1.0);
    umean += u;
  }
  // var(n_a) = 1/3, var(n_a^2) = 1/5 - 1/9 = 4/45, var(n_a n_b) = 1/15
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(m[a] / n, 0.0, 5 * std::sqrt(1.0 / 3.0 / n));
    for (int b = 0; b < 3; ++b)
      EXPECT_NEAR(q[a][b] / n, a == b ? 1.0 / 3.0 : 0.0, 5 * std::sqrt((a == b ? 4.0 / 45.0 : 1.0 / 15.0) / n));
  }
  EXPECT_NEAR(umean / n, 0.5, 5 * std::sqrt(1.0 / 12.0 / n));
}

// Philox4x32Words::Cursor (collide_cell's draws) gives the generator's words in order,
// across the group boundaries, mixed with uniforms and unit vectors, and hands the index back.
TEST(DsmcCollisionWords, CursorDrawsTheGeneratorsWords) {
  Philox4x32Words a(5, Stream::grain_collisions, 12, 3), b(5, Stream::grain_collisions, 12, 3);
  for (int t = 0; t < 500; ++t) {
    {
      Philox4x32Words::Cursor c(b);
      for (int d = 0; d < t % 7; ++d) ASSERT_EQ(c.bits64(), a.bits64()) << t;
      ASSERT_EQ(c.uniform(), a.uniform()) << t;
      const grainbath::Vec3 r = c.unit_vector(), q = a.unit_vector();
      ASSERT_EQ(r.x, q.x);
      ASSERT_EQ(r.y, q.y);
      ASSERT_EQ(r.z, q.z);
    }
    ASSERT_EQ(b.bits64(), a.bits64()) << t;  // the index written back
  }
  EXPECT_EQ(b.groups_used(), a.groups_used());
}

}  // namespace
