// The in-cell order of the cell sort (src/dsmc/cell_order.hpp) must be the order by global
// id whichever branch sorts the cell (32-bit integer ranking, double ranking for ids >= 2^32,
// natural merge sort for cells above 64 particles): the fused and the general sort share it,
// and the results at any thread or rank count depend on it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include "dsmc/cell_order.hpp"
#include "dsmc/fused.hpp"
#include "dsmc/spatial.hpp"
#include "operators/random.hpp"

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

// The fused step's entry points for the order of a cell by 32-bit keys that this CPU can run:
// the plain one (if asked for), the AVX2 and the AVX-512F ones.
struct Key32EntryPoint {
  const char* isa;
  void (*rank)(const std::uint32_t*, const std::int32_t*, std::uint32_t*, std::uint64_t*, const std::uint64_t*,
               std::size_t, std::size_t);
};
std::vector<Key32EntryPoint> key32_entry_points(bool with_plain) {
  __builtin_cpu_init();
  std::vector<Key32EntryPoint> out;
  if (with_plain) out.push_back({"plain", grainbath::dsmc::order_cell_by_key32});
  if (__builtin_cpu_supports("avx2")) out.push_back({"avx2", grainbath::dsmc::order_cell_by_key32_avx2});
  if (__builtin_cpu_supports("avx512f")) out.push_back({"avx512f", grainbath::dsmc::order_cell_by_key32_avx512});
  return out;
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
  // the SIMD rankings (the fused step's paths on AVX2 and AVX-512F CPUs): the same slots,
  // nothing else written
  for (const auto& v : key32_entry_points(false)) {
    std::vector<std::uint32_t> perm2(n, 0xdeadbeefu);
    std::vector<std::uint64_t> id_out2(n, 0xdeadbeefull);
    v.rank(stable.data(), keys.data(), perm2.data(), id_out2.data(), id.data(), b0, b1);
    EXPECT_EQ(perm2, perm) << v.isa << " m " << m;
    EXPECT_EQ(id_out2, id_out) << v.isa << " m " << m;
  }
}

TEST(DsmcCellOrder, Key32VariantOrdersByIdInPlace) {
  for (std::size_t m : {0u, 1u, 2u, 3u, 4u, 5u, 7u, 8u, 9u, 15u, 16u, 17u, 23u, 24u, 25u, 31u, 32u, 33u, 64u, 65u, 200u})
    for (std::size_t after : {0u, 1u, 2u, 3u, 40u})
      for (std::uint32_t rep = 0; rep < 3; ++rep) check_key32_cell(m, after, 1000u * rep + 17u * static_cast<std::uint32_t>(m + after));
}

// Cells above 64 particles as a step leaves them: r runs, each ascending in id, their ids
// interleaved (particles from r neighbouring cells), also one run (already ordered), the
// worst case of m runs of one (descending ids) and ids above 2^32; against std::sort.
void check_runs_cell(std::size_t m, std::size_t runs, std::uint64_t id_offset, std::uint32_t seed) {
  std::mt19937_64 gen(seed);
  const std::size_t n = m + 7, b0 = 4, b1 = b0 + m;
  std::vector<std::uint64_t> id(n);
  std::vector<std::uint64_t> pool(n);
  for (std::size_t i = 0; i < n; ++i) pool[i] = id_offset + 3 * i + gen() % 3;  // distinct
  std::shuffle(pool.begin(), pool.end(), gen);
  id = pool;
  // the cell's slots: old indices b0..b1 split at random cut points into `runs` pieces, each
  // piece sorted by id (the stable scatter of id-ordered source cells)
  std::vector<std::uint32_t> perm(n);
  std::iota(perm.begin(), perm.end(), 0u);
  std::shuffle(perm.begin() + static_cast<long>(b0), perm.begin() + static_cast<long>(b1), gen);
  std::vector<std::size_t> cuts = {b0, b1};
  for (std::size_t r = 1; r < runs; ++r) cuts.push_back(b0 + gen() % (m + 1));
  std::sort(cuts.begin(), cuts.end());
  const auto by_id = [&](std::uint32_t a, std::uint32_t b) { return id[a] < id[b]; };
  for (std::size_t r = 0; r + 1 < cuts.size(); ++r)
    std::sort(perm.begin() + static_cast<long>(cuts[r]), perm.begin() + static_cast<long>(cuts[r + 1]), by_id);
  if (runs >= m)  // descending: every slot is a run of its own
    std::sort(perm.begin() + static_cast<long>(b0), perm.begin() + static_cast<long>(b1),
              [&](std::uint32_t a, std::uint32_t b) { return id[a] > id[b]; });
  std::vector<std::uint64_t> id_out(n, 0xdeadbeefull);
  for (std::size_t j = b0; j < b1; ++j) id_out[j] = id[perm[j]];
  std::vector<std::uint32_t> expected(perm.begin() + static_cast<long>(b0), perm.begin() + static_cast<long>(b1));
  std::sort(expected.begin(), expected.end(), by_id);
  const std::vector<std::uint32_t> before = perm;
  order_cell_by_id(perm.data(), id_out.data(), id.data(), b0, b1);
  for (std::size_t j = b0; j < b1; ++j) {
    ASSERT_EQ(perm[j], expected[j - b0]) << "m " << m << " runs " << runs << " slot " << j;
    ASSERT_EQ(id_out[j], id[perm[j]]) << "m " << m << " runs " << runs << " slot " << j;
  }
  for (std::size_t j = 0; j < n; ++j)
    if (j < b0 || j >= b1) {
      EXPECT_EQ(perm[j], before[j]);
      EXPECT_EQ(id_out[j], 0xdeadbeefull);
    }
}

TEST(DsmcCellOrder, LargeCellsOfAscendingRuns) {
  std::uint32_t seed = 1;
  for (std::size_t m : {65u, 66u, 100u, 127u, 2000u, 5001u})
    for (std::size_t runs : {1u, 2u, 3u, 5u, 8u, 64u, 65u, 5001u})
      for (std::uint64_t offset : {0ull, 0x1'0000'0000ull}) check_runs_cell(m, std::min(runs, m), offset, ++seed);
}

// The fused step's large cells (order_cell_by_key32 above 64 particles: the packed words'
// merge sort, smallest runs first up to 16 runs, pairwise passes above): cells made of
// ascending runs as a step leaves them — one run, a few of very different sizes (the stayers
// and the arrivals from each side, 1 / 182 / 839 / 187 as in hot-walls), 16 and 17 runs (both
// sides of the switch), every slot a run of its own — read in place with other cells'
// entries around them; against std::sort by id, nothing written outside the cell, and the
// SIMD entry points (AVX2, AVX-512F) with the same slots.
void check_key32_runs_cell(const std::vector<std::size_t>& run_sizes, std::uint32_t seed) {
  using grainbath::dsmc::kKey32Padding;
  std::mt19937_64 gen(seed);
  std::size_t m = 0;
  for (std::size_t r : run_sizes) m += r;
  const std::size_t b0 = 6, b1 = b0 + m, n = b1 + 9;
  std::vector<std::uint64_t> id(n);
  for (std::size_t i = 0; i < n; ++i) id[i] = 4 * i + gen() % 4;  // distinct, below 2^32
  if (n > 2) id[n - 1] = 0xffffffffull;  // the largest 32-bit id in play
  std::shuffle(id.begin(), id.end(), gen);
  std::vector<std::uint32_t> old(n);
  std::iota(old.begin(), old.end(), 0u);
  std::shuffle(old.begin(), old.end(), gen);
  // the cell's slots: runs of the given sizes, each ascending in id (a stable scatter of
  // id-ordered source cells); a run of one is also ascending
  std::size_t at = b0;
  const auto by_id = [&](std::uint32_t a, std::uint32_t b) { return id[a] < id[b]; };
  for (std::size_t r : run_sizes) {
    std::sort(old.begin() + static_cast<long>(at), old.begin() + static_cast<long>(at + r), by_id);
    at += r;
  }
  std::vector<std::uint32_t> stable(n + kKey32Padding, 0x12345u);
  std::vector<std::int32_t> keys(n + kKey32Padding, 77);
  for (std::size_t j = 0; j < n; ++j) {
    stable[j] = old[j] | (j % 5 == 0 ? 0x80000000u : 0u);  // kStreamedBit on some: carried, not compared
    keys[j] = static_cast<std::int32_t>(static_cast<std::uint32_t>(id[old[j]]) ^ 0x80000000u);
  }
  std::vector<std::size_t> expected_j(m);
  std::iota(expected_j.begin(), expected_j.end(), b0);
  std::sort(expected_j.begin(), expected_j.end(), [&](std::size_t a, std::size_t b) { return id[old[a]] < id[old[b]]; });
  for (const auto& v : key32_entry_points(true)) {
    std::vector<std::uint32_t> perm(n, 0xdeadbeefu);
    std::vector<std::uint64_t> id_out(n, 0xdeadbeefull);
    v.rank(stable.data(), keys.data(), perm.data(), id_out.data(), id.data(), b0, b1);
    for (std::size_t q = 0; q < m; ++q) {
      ASSERT_EQ(perm[b0 + q], stable[expected_j[q]]) << v.isa << " m " << m << " runs " << run_sizes.size() << " slot " << q;
      ASSERT_EQ(id_out[b0 + q], id[old[expected_j[q]]]) << v.isa << " m " << m << " slot " << q;
    }
    for (std::size_t j = 0; j < n; ++j)
      if (j < b0 || j >= b1) {
        EXPECT_EQ(perm[j], 0xdeadbeefu) << v.isa << " slot " << j;
        EXPECT_EQ(id_out[j], 0xdeadbeefull) << v.isa << " slot " << j;
      }
  }
}

TEST(DsmcCellOrder, Key32LargeCellsOfAscendingRuns) {
  std::uint32_t seed = 100;
  const std::vector<std::vector<std::size_t>> shapes = {
      {65}, {200}, {1, 182, 839, 187}, {3, 196, 858, 187, 2}, {216, 879, 203}, {40, 40}, {7, 8, 9, 60},
      std::vector<std::size_t>(16, 9), std::vector<std::size_t>(17, 9), std::vector<std::size_t>(16, 1),
      std::vector<std::size_t>(65, 1), std::vector<std::size_t>(300, 1), {1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 500}};
  for (const auto& shape : shapes)
    for (std::uint32_t rep = 0; rep < 4; ++rep) check_key32_runs_cell(shape, ++seed);
  // random shapes: 2 to 40 runs of 1 to 120
  std::mt19937 gen(7);
  for (int rep = 0; rep < 200; ++rep) {
    std::vector<std::size_t> shape(2 + gen() % 39);
    for (auto& r : shape) r = 1 + gen() % 120;
    std::size_t m = 0;
    for (std::size_t r : shape) m += r;
    if (m > 64) check_key32_runs_cell(shape, ++seed);
  }
}

// The SIMD merges of two ascending runs of packed words (detail::merge_words_avx512, eight
// words a register; detail::merge_words_avx2, four, on words with the top bit flipped for the
// signed compare) against std::merge: every pair of lengths 0-40 (the vector loops need a
// register's worth of each; the rest and the largest register are finished one by one),
// words with and without the top bit, runs that interleave at random, one entirely below the
// other, and blocks of eight taken from one side in turn.
using WordMerge = std::uint64_t* (*)(const std::uint64_t*, const std::uint64_t*, const std::uint64_t*,
                                     const std::uint64_t*, std::uint64_t*);
void check_word_merge(const char* isa, WordMerge merge) {
  std::mt19937_64 gen(3);
  for (std::size_t na = 0; na <= 40; ++na)
    for (std::size_t nb = 0; nb <= 40; ++nb)
      for (int shape = 0; shape < 3; ++shape) {
        std::vector<std::uint64_t> all(na + nb);
        // ids across 2^31 (the top bit of the word) and the index in the low half
        for (std::size_t i = 0; i < all.size(); ++i) all[i] = (std::uint64_t{gen() % 0xffffffffull} << 32) | i;
        std::vector<std::uint64_t> a, b;
        std::sort(all.begin(), all.end());
        if (shape == 0) {  // at random
          std::shuffle(all.begin(), all.end(), gen);
          a.assign(all.begin(), all.begin() + static_cast<long>(na));
          b.assign(all.begin() + static_cast<long>(na), all.end());
        } else if (shape == 1) {  // a below b
          a.assign(all.begin(), all.begin() + static_cast<long>(na));
          b.assign(all.begin() + static_cast<long>(na), all.end());
        } else {  // blocks of eight, alternately a's and b's while both need more
          for (std::size_t i = 0; i < all.size(); ++i) {
            const bool to_a = (a.size() < na && ((i / 8) % 2 == 0 || b.size() >= nb));
            (to_a ? a : b).push_back(all[i]);
          }
        }
        std::sort(a.begin(), a.end());
        std::sort(b.begin(), b.end());
        std::vector<std::uint64_t> expected(na + nb), got(na + nb + 1, 0xabcdull);
        std::merge(a.begin(), a.end(), b.begin(), b.end(), expected.begin());
        std::uint64_t* end = merge(a.data(), a.data() + a.size(), b.data(), b.data() + b.size(), got.data());
        ASSERT_EQ(end, got.data() + na + nb) << isa << " na " << na << " nb " << nb << " shape " << shape;
        ASSERT_EQ(got.back(), 0xabcdull) << isa << " written past the end: na " << na << " nb " << nb;
        got.pop_back();
        ASSERT_EQ(got, expected) << isa << " na " << na << " nb " << nb << " shape " << shape;
      }
}

TEST(DsmcCellOrder, MergeOfTwoRunsInSimdLanesIsStdMerge) {
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx2") == 0) GTEST_SKIP() << "no AVX2 on this CPU";
  check_word_merge("avx2", grainbath::dsmc::detail::merge_words_avx2);
  if (__builtin_cpu_supports("avx512f") == 0) GTEST_SKIP() << "no AVX-512F on this CPU: the AVX2 merge only";
  check_word_merge("avx512f", grainbath::dsmc::detail::merge_words_avx512);
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

// The fused step's cell index in SIMD (detail::stream_cells_sse2 / _avx2, src/dsmc/fused.hpp):
// both paths must give the cells of the scalar path, CellGrid(wrap_periodic(x + v dt)),
// particle by particle, and the same counts, for particles that stay inside, leave through a
// face (also to -tiny, and several box lengths), land on a cell face or on the upper box face,
// and a NaN velocity. Fails if a clamp, a compare, the AVX2 path's wrap or the linear index
// differs in one path.
template <int Dim>
void check_stream_cells(std::uint32_t seed) {
  using namespace grainbath::dsmc;
  std::mt19937_64 gen(seed);
  // (5.7 - ulp) * 33 / 5.7 and (3.1 - ulp) * 9 / 3.1 round to 33 and 9: the top clamp is needed
  const double length[3] = {10.0, 5.7, 3.1};
  const std::uint32_t ncell[3] = {40, Dim > 1 ? 33u : 1u, Dim > 2 ? 9u : 1u};
  const std::uint32_t cells = ncell[0] * (Dim > 1 ? ncell[1] : 1u) * (Dim > 2 ? ncell[2] : 1u);
  const double dt = 0.08862;
  const std::size_t n = 4099;  // not a multiple of 2 or 4: the scalar tail too
  std::vector<double> pos[3], vel[3];
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int a = 0; a < 3; ++a) {
    pos[a].resize(n);
    vel[a].resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      pos[a][i] = unit(gen) * length[a];
      vel[a][i] = normal(gen);
      const std::uint64_t r = gen() % 50;
      if (r == 0) {  // on a cell face after the step
        pos[a][i] = std::floor(unit(gen) * ncell[a]) * (length[a] / ncell[a]);
        vel[a][i] = 0.0;
      } else if (r == 1) {  // just below the upper box face
        pos[a][i] = std::nextafter(length[a], 0.0);
        vel[a][i] = 0.0;
      } else if (r == 2) {  // through a face
        pos[a][i] = unit(gen) < 0.5 ? 0.01 : length[a] - 0.01;
        vel[a][i] = pos[a][i] < 1.0 ? -1.0 : 1.0;
      } else if (r == 3) {  // to -tiny: x + L rounds to L, wrap_periodic gives 0
        pos[a][i] = 0.0;
        vel[a][i] = -1e-300;
      } else if (r == 4) {  // several box lengths away (floor(x / L) = +-3)
        vel[a][i] = (unit(gen) < 0.5 ? -3.0 : 3.0) * length[a] / dt;
      }
    }
  }
  vel[0][777] = std::numeric_limits<double>::quiet_NaN();
  double inv[3];
  for (int a = 0; a < 3; ++a) inv[a] = a < Dim ? ncell[a] / length[a] : 0.0;
  auto axis = [&](int a, double x) -> std::uint32_t {
    const double f = x * inv[a];
    if (!(f > 0.0)) return 0;
    const auto k = static_cast<std::uint32_t>(f);
    return k < ncell[a] ? k : ncell[a] - 1;
  };
  std::vector<std::uint32_t> ref(n), ref_count(cells, 0);
  auto scalar_into = [&](std::vector<std::uint32_t>& cell, std::vector<std::uint32_t>& count) {
    return [&](std::size_t i) {
      double x[3] = {0.0, 0.0, 0.0};
      for (int a = 0; a < Dim; ++a) x[a] = wrap_periodic(pos[a][i] + vel[a][i] * dt, length[a]);
      const std::uint32_t k = axis(0, x[0]) + ncell[0] * (axis(1, x[1]) + ncell[1] * axis(2, x[2]));
      cell[i] = k;
      ++count[k];
    };
  };
  {
    auto one = scalar_into(ref, ref_count);
    for (std::size_t i = 0; i < n; ++i) one(i);
  }
  const detail::StreamCellsArgs g{{pos[0].data(), pos[1].data(), pos[2].data()},
                                  {vel[0].data(), vel[1].data(), vel[2].data()},
                                  dt,
                                  {length[0], length[1], length[2]},
                                  {inv[0], inv[1], inv[2]},
                                  {ncell[0] - 1.0, ncell[1] - 1.0, ncell[2] - 1.0},
                                  static_cast<double>(ncell[0]),
                                  static_cast<double>(ncell[1])};
  for (int path = 0; path < 2; ++path) {
    if (path == 1 && !grainbath::Philox4x32Lanes::have_avx2()) continue;
    std::vector<std::uint32_t> cell(n, 0xffffffffu), count(cells, 0);
    auto one = scalar_into(cell, count);
    std::size_t i = path == 0 ? detail::stream_cells_sse2<Dim>(g, 0, n, cell.data(), count.data(), one)
                              : detail::stream_cells_avx2<Dim>(g, 0, n, cell.data(), count.data(), one);
    EXPECT_LT(n - i, path == 0 ? 2u : 4u);
    for (; i < n; ++i) one(i);
    for (std::size_t j = 0; j < n; ++j) ASSERT_EQ(cell[j], ref[j]) << (path ? "AVX2" : "SSE2") << " Dim " << Dim << " particle " << j;
    EXPECT_EQ(count, ref_count) << (path ? "AVX2" : "SSE2") << " Dim " << Dim;
    // without the counts (the fused step's prediction of the next step's cells): the same
    // cells, and `cnt` is not touched
    std::vector<std::uint32_t> cell_only(n, 0xffffffffu), untouched(cells, 0);
    auto only = scalar_into(cell_only, untouched);
    auto store_only = [&](std::size_t q) {
      std::vector<std::uint32_t> scratch(cells, 0);
      scalar_into(cell_only, scratch)(q);
    };
    std::size_t q = path == 0 ? detail::stream_cells_sse2<Dim, false>(g, 0, n, cell_only.data(), nullptr, store_only)
                              : detail::stream_cells_avx2<Dim, false>(g, 0, n, cell_only.data(), nullptr, store_only);
    for (; q < n; ++q) only(q);
    for (std::size_t j = 0; j < n; ++j) ASSERT_EQ(cell_only[j], ref[j]) << (path ? "AVX2" : "SSE2") << " no counts, particle " << j;
  }
  // the prediction with AVX-512F (the fused step's path where the CPU has it), finished as there
  if (grainbath::Philox4x32Lanes::have_avx512()) {
    std::vector<std::uint32_t> cell_only(n, 0xffffffffu), untouched(cells, 0);
    auto only = scalar_into(cell_only, untouched);
    std::size_t q = detail::predict_cells_avx512<Dim>(g, 0, n, cell_only.data());
    EXPECT_LT(n - q, 8u);
    q = detail::stream_cells_avx2<Dim, false>(g, q, n, cell_only.data(), nullptr, only);
    for (; q < n; ++q) only(q);
    for (std::size_t j = 0; j < n; ++j) ASSERT_EQ(cell_only[j], ref[j]) << "AVX-512 Dim " << Dim << " particle " << j;
  }
}

TEST(DsmcStreamCells, SimdPathsGiveTheScalarCells) {
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    check_stream_cells<1>(seed);
    check_stream_cells<2>(seed);
    check_stream_cells<3>(seed);
  }
  if (!grainbath::Philox4x32Lanes::have_avx2()) GTEST_SKIP() << "no AVX2 on this CPU: only the SSE2 path was compared";
}

}  // namespace
