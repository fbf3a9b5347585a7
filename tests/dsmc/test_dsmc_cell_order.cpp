// The in-cell order of the cell sort (src/dsmc/cell_order.hpp) must be the order by global
// id whichever branch sorts the cell (32-bit integer ranking, double ranking for ids >= 2^32,
// insertion sort for cells above 64 particles): the fused and the general sort share it,
// and the results at any thread or rank count depend on it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include "dsmc/cell_order.hpp"

namespace {

using grainbath::dsmc::order_cell_by_id;

// One cell [b0, b1) inside a larger array: perm holds old indices, id_out their ids in the
// scatter order (runs of increasing id, as the stable counting sort leaves them).
void check_cell(std::uint64_t id_offset, std::size_t m, std::uint32_t seed) {
  std::mt19937_64 gen(seed);
  const std::size_t n = m + 10, b0 = 5, b1 = b0 + m;
  std::vector<std::uint64_t> id(n);
  // distinct ids, random order, some of them spread to the top of the 32-bit range
  for (std::size_t i = 0; i < n; ++i) id[i] = id_offset + (gen() % 0xffffffffull);
  std::sort(id.begin(), id.end());
  id.erase(std::unique(id.begin(), id.end()), id.end());
  ASSERT_GE(id.size(), b1);
  std::shuffle(id.begin(), id.end(), gen);
  std::vector<std::uint32_t> perm(n);
  std::iota(perm.begin(), perm.end(), 0u);
  std::shuffle(perm.begin() + static_cast<long>(b0), perm.begin() + static_cast<long>(b1), gen);
  std::vector<std::uint64_t> id_out(n, 0);
  for (std::size_t j = b0; j < b1; ++j) id_out[j] = id[perm[j]];
  std::vector<std::uint32_t> expected(perm.begin() + static_cast<long>(b0), perm.begin() + static_cast<long>(b1));
  std::sort(expected.begin(), expected.end(), [&](std::uint32_t a, std::uint32_t b) { return id[a] < id[b]; });
  const std::vector<std::uint32_t> before = perm;
  order_cell_by_id(perm.data(), id_out.data(), id.data(), b0, b1);
  for (std::size_t j = b0; j < b1; ++j) {
    EXPECT_EQ(perm[j], expected[j - b0]) << "m " << m << " slot " << j;
    EXPECT_EQ(id_out[j], id[perm[j]]) << "m " << m << " slot " << j;
  }
  for (std::size_t j = 0; j < b0; ++j) EXPECT_EQ(perm[j], before[j]);  // outside the cell: untouched
  for (std::size_t j = b1; j < n; ++j) EXPECT_EQ(perm[j], before[j]);
}

TEST(DsmcCellOrder, OrdersByIdInEveryBranch) {
  for (std::size_t m : {0u, 1u, 2u, 3u, 4u, 5u, 7u, 8u, 15u, 16u, 17u, 23u, 24u, 25u, 31u, 32u, 33u, 63u, 64u, 65u, 200u}) {
    check_cell(0, m, 11u + static_cast<std::uint32_t>(m));               // 32-bit keys
    check_cell(0x100000000ull, m, 97u + static_cast<std::uint32_t>(m));  // ids above 2^32: doubles
    check_cell(0x7fffff00ull, m, 5u + static_cast<std::uint32_t>(m));    // across 2^31 and 2^32
  }
}

TEST(DsmcCellOrder, ExtremeThirtyTwoBitIds) {
  // 0 and 2^32 - 1 (the key that equals the pad) in one cell
  std::vector<std::uint64_t> id = {0xffffffffull, 0, 0x80000000ull, 0x7fffffffull, 1};
  std::vector<std::uint32_t> perm = {0, 1, 2, 3, 4};
  std::vector<std::uint64_t> id_out = id;
  order_cell_by_id(perm.data(), id_out.data(), id.data(), 0, 5);
  EXPECT_EQ(perm, (std::vector<std::uint32_t>{1, 4, 3, 2, 0}));
  EXPECT_EQ(id_out, (std::vector<std::uint64_t>{0, 1, 0x7fffffffull, 0x80000000ull, 0xffffffffull}));
}

}  // namespace
