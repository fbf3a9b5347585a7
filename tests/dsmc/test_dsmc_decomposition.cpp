// The MPI decomposition's block boundaries (src/dsmc/decomposition.cpp,
// balanced_block_boundaries): a pure function of the block weights and the rank count, so it
// is checked here without MPI. Found 2026-11-27: with the target inside the last block no cut
// was made, and 2 blocks of unequal weight went to one rank (load imbalance 2).
// Also the global blocks of the moments over ranks (src/dsmc/global_blocks.hpp), with the ranks
// simulated one after the other: every block of 4096 particles of the global order is summed
// once, whole, in particle order, whatever the split.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <random>
#include <vector>

#include "dsmc/decomposition.hpp"
#include "dsmc/global_blocks.hpp"

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

namespace {

using Indices = std::vector<std::uint64_t>;  // a block's "sums": the global indices added, in order

// The blocks that the ranks holding `counts` particles (in rank order) produce, over all
// ranks in rank order, as the moments gather them (combine_in_order).
std::vector<Indices> global_blocks_over_ranks(const std::vector<std::size_t>& counts) {
  using namespace grainbath::dsmc;
  std::vector<RankInGlobalBlocks<Indices>> parts;
  std::vector<std::uint64_t> offsets;
  std::uint64_t offset = 0;
  auto range_at = [](std::uint64_t off) {
    return [off](std::size_t lo, std::size_t hi, Indices& s) {
      for (std::size_t i = lo; i < hi; ++i) s.push_back(off + i);
    };
  };
  for (const std::size_t n : counts) {
    const auto range = range_at(offset);
    const auto blocks = [&](const std::vector<std::size_t>& bounds, std::vector<Indices>& out) {
      for (std::size_t k = 0; k + 1 < bounds.size(); ++k) {
        Indices b;
        range(bounds[k], bounds[k + 1], b);
        out.push_back(b);
      }
    };
    parts.push_back(split_into_global_blocks<Indices>(n, offset, blocks, range));
    offsets.push_back(offset);
    offset += n;
  }
  GlobalBlockCarry<Indices> carry;
  std::vector<Indices> done;
  for (std::size_t r = 0; r < counts.size(); ++r)
    continue_global_blocks(parts[r], r + 1 == counts.size(), range_at(offsets[r]), carry, done);
  return done;
}

// what one process sums: [0, 4096), [4096, 8192), ..., the last block partial
std::vector<Indices> global_blocks_of_one_process(std::uint64_t total) {
  std::vector<Indices> blocks;
  for (std::uint64_t lo = 0; lo < total; lo += grainbath::dsmc::kGlobalBlock) {
    Indices b;
    for (std::uint64_t i = lo; i < std::min<std::uint64_t>(total, lo + grainbath::dsmc::kGlobalBlock); ++i) b.push_back(i);
    blocks.push_back(b);
  }
  return blocks;
}

std::string split_text(const std::vector<std::size_t>& counts) {
  std::string t;
  for (const std::size_t n : counts) t += std::to_string(n) + " ";
  return t;
}

}  // namespace

// The splits that reach each branch: a middle rank whose end is a block boundary while its
// start is not (audit D53: that block was left open and lost before the check was <=), a rank
// starting on a boundary, an empty rank, a rank inside one block, a rank with a head, whole
// blocks and a tail, a population of whole blocks, one rank.
TEST(DsmcGlobalBlocks, EveryBlockIsSummedOnceInOrderForTheSplitsOfEachBranch) {
  const std::vector<std::vector<std::size_t>> splits = {
      {4000, 4192, 5000}, {4000, 4192}, {4096, 100, 9000}, {5000, 0, 3000}, {0, 5000},       {100, 200, 300},
      {1000, 10000, 2000}, {4096, 4096}, {8192, 1, 4095, 1}, {10000},       {0},             {4095, 1, 4096, 3}};
  for (const auto& counts : splits) {
    std::uint64_t total = 0;
    for (const std::size_t n : counts) total += n;
    EXPECT_EQ(global_blocks_over_ranks(counts), global_blocks_of_one_process(total)) << "split " << split_text(counts);
  }
}

// Random splits over 1 to 6 ranks, their cuts drawn near block boundaries half of the time.
TEST(DsmcGlobalBlocks, EveryBlockIsSummedOnceInOrderForRandomSplits) {
  std::mt19937_64 rng(20261207);
  for (int trial = 0; trial < 300; ++trial) {
    const int ranks = 1 + static_cast<int>(rng() % 6);
    const std::uint64_t total = rng() % (5 * grainbath::dsmc::kGlobalBlock);
    std::vector<std::uint64_t> cuts = {0, total};
    for (int r = 1; r < ranks; ++r) {
      std::uint64_t c = rng() % (total + 1);
      if (rng() % 2 == 0) {  // a boundary, or one beside it
        const auto boundary = static_cast<std::int64_t>(c / grainbath::dsmc::kGlobalBlock * grainbath::dsmc::kGlobalBlock);
        const std::int64_t beside = boundary + static_cast<std::int64_t>(rng() % 3) - 1;
        c = static_cast<std::uint64_t>(std::clamp<std::int64_t>(beside, 0, static_cast<std::int64_t>(total)));
      }
      cuts.push_back(c);
    }
    std::sort(cuts.begin(), cuts.end());
    std::vector<std::size_t> counts;
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k) counts.push_back(cuts[k + 1] - cuts[k]);
    ASSERT_EQ(global_blocks_over_ranks(counts), global_blocks_of_one_process(total))
        << "trial " << trial << ", split " << split_text(counts);
  }
}
