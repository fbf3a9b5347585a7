// The MPI decomposition's block boundaries (src/dsmc/decomposition.cpp,
// balanced_block_boundaries): a pure function of the block weights and the rank count, so it
// is checked here without MPI. Found 2026-11-27: with the target inside the last block no cut
// was made, and 2 blocks of unequal weight went to one rank (load imbalance 2).
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "dsmc/decomposition.hpp"

using grainbath::dsmc::balanced_block_boundaries;

TEST(DsmcDecomposition, TwoBlocksGoToTwoRanksWhicheverIsHeavier) {
  EXPECT_EQ(balanced_block_boundaries({990, 1012}, 2), (std::vector<std::size_t>{0, 1, 2}));
  EXPECT_EQ(balanced_block_boundaries({1012, 990}, 2), (std::vector<std::size_t>{0, 1, 2}));
  EXPECT_EQ(balanced_block_boundaries({1000, 1000}, 2), (std::vector<std::size_t>{0, 1, 2}));
  // more ranks than blocks: the extra ranks get empty ranges at the end
  const auto three = balanced_block_boundaries({990, 1012}, 3);
  ASSERT_EQ(three.size(), 4u);
  EXPECT_EQ(three.front(), 0u);
  EXPECT_EQ(three.back(), 2u);
  int non_empty = 0;
  for (int r = 0; r < 3; ++r) non_empty += three[r] < three[r + 1];
  EXPECT_EQ(non_empty, 2);
}

// Random weights: contiguous, ordered ranges covering every block, and no rank above the
// even share by more than one block's weight (a cut at the nearest block boundary).
TEST(DsmcDecomposition, EveryRankWithinOneBlockOfItsShare) {
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 2000; ++trial) {
    const std::size_t blocks = 1 + rng() % 40;
    const int ranks = 1 + static_cast<int>(rng() % 8);
    std::vector<std::uint64_t> w(blocks);
    std::uint64_t total = 0, heaviest = 0;
    for (auto& x : w) {
      x = 1 + rng() % 1000;
      total += x;
      heaviest = std::max(heaviest, x);
    }
    const auto first = balanced_block_boundaries(w, ranks);
    ASSERT_EQ(first.size(), static_cast<std::size_t>(ranks) + 1);
    EXPECT_EQ(first.front(), 0u);
    EXPECT_EQ(first.back(), blocks);
    for (int r = 0; r < ranks; ++r) {
      ASSERT_LE(first[r], first[r + 1]);
      std::uint64_t part = 0;
      for (std::size_t b = first[r]; b < first[r + 1]; ++b) part += w[b];
      // part <= total/ranks + heaviest, in integers
      EXPECT_LE(part * ranks, total + heaviest * ranks) << "trial " << trial << " rank " << r;
    }
    // equal weights and at least as many blocks as ranks: every rank gets a block (a block
    // heavier than a share may take two ranks' targets, so not in general)
    std::vector<std::uint64_t> even(blocks, 5);
    const auto e = balanced_block_boundaries(even, ranks);
    if (blocks >= static_cast<std::size_t>(ranks)) {
      for (int r = 0; r < ranks; ++r) EXPECT_LT(e[r], e[r + 1]) << "trial " << trial << " rank " << r;
    }
  }
}
