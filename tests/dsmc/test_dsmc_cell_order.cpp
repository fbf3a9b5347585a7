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

// The fused step's variant (order_cell_by_key32): the cell's old indices in `stable` and its
// 32-bit keys id ^ 2^31 in `keys`, read in place with other cells' entries (random junk)
// before and after it, up to the padding at the array end; the same order and ids as
// std::sort by id, and nothing written outside the cell.
void check_key32_cell(std::size_t m, std::size_t after, std::uint32_t seed) {
  using grainbath::dsmc::kKey32Padding;
  using grainbath::dsmc::order_cell_by_key32;
  std::mt19937_64 gen(seed);
  const std::size_t b0 = 3, b1 = b0 + m, n = b1 + after;
  std::vector<std::uint64_t> id(n);
  for (std::size_t i = 0; i < n; ++i) id[i] = gen() % 0x100000000ull;  // any 32-bit id, 0 and 2^32 - 1 below
  if (m >= 2) {
    id[b0] = 0xffffffffull;
    id[b0 + 1] = 0;
  }
  std::sort(id.begin(), id.end());
  if (std::unique(id.begin(), id.end()) != id.end()) return;  // distinct ids only (never fails at these sizes)
  std::shuffle(id.begin(), id.end(), gen);
  std::vector<std::uint32_t> stable(n + kKey32Padding);
  std::vector<std::int32_t> keys(n + kKey32Padding);
  for (auto& k : keys) k = static_cast<std::int32_t>(gen());  // junk in the padding
  for (auto& v : stable) v = static_cast<std::uint32_t>(gen());
  std::vector<std::uint32_t> old(n);
  std::iota(old.begin(), old.end(), 0u);
  std::shuffle(old.begin(), old.end(), gen);
  for (std::size_t j = 0; j < n; ++j) {
    stable[j] = old[j];
    keys[j] = static_cast<std::int32_t>(static_cast<std::uint32_t>(id[old[j]]) ^ 0x80000000u);
  }
  std::vector<std::uint32_t> expected(stable.begin() + static_cast<long>(b0), stable.begin() + static_cast<long>(b1));
  std::sort(expected.begin(), expected.end(), [&](std::uint32_t a, std::uint32_t b) { return id[a] < id[b]; });
  std::vector<std::uint32_t> perm(n, 0xdeadbeefu);
  std::vector<std::uint64_t> id_out(n, 0xdeadbeefull);
  order_cell_by_key32(stable.data(), keys.data(), perm.data(), id_out.data(), id.data(), b0, b1);
  for (std::size_t j = b0; j < b1; ++j) {
    EXPECT_EQ(perm[j], expected[j - b0]) << "m " << m << " slot " << j;
    EXPECT_EQ(id_out[j], id[perm[j]]) << "m " << m << " slot " << j;
  }
  for (std::size_t j = 0; j < n; ++j)
    if (j < b0 || j >= b1) {
      EXPECT_EQ(perm[j], 0xdeadbeefu) << "m " << m << " slot " << j;
      EXPECT_EQ(id_out[j], 0xdeadbeefull) << "m " << m << " slot " << j;
    }
}

TEST(DsmcCellOrder, Key32VariantOrdersByIdInPlace) {
  for (std::size_t m : {0u, 1u, 2u, 3u, 4u, 5u, 7u, 8u, 9u, 15u, 16u, 17u, 23u, 24u, 25u, 31u, 32u, 33u, 64u, 65u, 200u})
    for (std::size_t after : {0u, 1u, 2u, 3u, 40u})
      for (std::uint32_t rep = 0; rep < 3; ++rep) check_key32_cell(m, after, 1000u * rep + 17u * static_cast<std::uint32_t>(m + after));
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
