// The candidate pair of the NTC collisions (src/dsmc/collide.hpp): i uniform on [0, N) and j
// on the other N - 1 grains, from the two 32-bit halves of one Philox word (below_from).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "dsmc/collide.hpp"
#include "operators/random.hpp"

namespace {

using grainbath::CounterRng;
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
// likely (chi-square over N (N - 1) pairs, 0.1 % level), never i == j.
TEST(DsmcPairDraw, OrderedPairsAreUniform) {
  for (std::uint32_t n : {2u, 3u, 5u, 16u}) {
    CounterRng rng(9, Stream::grain_collisions, n, 4);
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

}  // namespace
