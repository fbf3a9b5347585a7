#pragma once
// Ordering the particles of one cell by global id, shared by the cell sort
// (src/dsmc/spatial.cpp) and the fused step (src/dsmc/fused.cpp).
#include <immintrin.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace grainbath::dsmc {

namespace detail {
// Ranking of m <= 4 Q 32-bit keys: Q vectors of four, loaded unaligned from `keys`.
// Transposed: each key in turn is broadcast and compared with all Q vectors, and every
// element whose key is larger counts it (rank[q] -= key_a < kv[q], true is -1). After m
// broadcasts rank[q] holds the ranks of four elements at once: no horizontal sum per element.
// Only the m real keys are broadcast, so the lanes past them (order_cell_by_id's INT32_MAX
// pads, or the next cells' keys where order_cell_by_key32 reads the scatter's arrays in
// place) count nothing towards the real lanes, and their own ranks are never read.
// Writes perm[rank] = stable[a] and id_out[rank] = the id of key a.
template <std::size_t Q>
inline void rank_keys32(const std::int32_t* __restrict keys, const std::uint32_t* __restrict stable, std::size_t m,
                        std::uint32_t* __restrict perm, std::uint64_t* __restrict id_out) {
  using Int4 = std::int32_t __attribute__((vector_size(16)));
  using Int4u = std::int32_t __attribute__((vector_size(16), aligned(4)));  // unaligned loads
  Int4 kv[Q], rank[Q];
  for (std::size_t q = 0; q < Q; ++q) {
    kv[q] = reinterpret_cast<const Int4u*>(keys)[q];
    rank[q] = Int4{0, 0, 0, 0};
  }
  for (std::size_t a = 0; a < m; ++a) {
    const std::int32_t k = keys[a];
    const Int4 key = {k, k, k, k};
    for (std::size_t q = 0; q < Q; ++q) rank[q] -= key < kv[q];
  }
  alignas(16) std::int32_t ranks[4 * Q];
  for (std::size_t q = 0; q < Q; ++q) reinterpret_cast<Int4*>(ranks)[q] = rank[q];
  for (std::size_t a = 0; a < m; ++a) {
    const auto r = static_cast<std::size_t>(ranks[a]);
    perm[r] = stable[a];
    id_out[r] = static_cast<std::uint32_t>(keys[a]) ^ 0x80000000u;
  }
}
// Large cells (above 64 particles: 1D and 2D runs with few, full cells). After a step the
// stable counting sort leaves a cell as a few runs each ascending in id, one per cell the
// particles came from (more with threads, each still ascending); an insertion sort over
// them moves O(m^2) slots (70 % of a 1D run with 2000-particle cells went there). A natural
// merge sort takes O(m log r) for r runs: find the runs, merge neighbouring runs pairwise
// until one is left. Ids are distinct, so the order is the one of any other sort.
// The scratch is per thread and only grows (no allocation per cell or step).
struct IdSlot {
  std::uint64_t id;
  std::uint32_t slot;
};
inline void merge_runs_by_id(std::uint32_t* __restrict perm, std::uint64_t* __restrict id_out, std::size_t b0,
                             std::size_t b1) {
  thread_local std::vector<IdSlot> scratch;
  thread_local std::vector<std::size_t> runs;
  const std::size_t m = b1 - b0;
  if (scratch.size() < 2 * m) scratch.resize(2 * m);
  IdSlot* from = scratch.data();
  IdSlot* to = from + m;
  runs.clear();
  runs.push_back(0);
  for (std::size_t a = 0; a < m; ++a) {
    from[a] = IdSlot{id_out[b0 + a], perm[b0 + a]};  // id_out holds the ids of perm (contiguous)
    if (a > 0 && from[a].id < from[a - 1].id) runs.push_back(a);
  }
  runs.push_back(m);
  const auto by_id = [](const IdSlot& x, const IdSlot& y) { return x.id < y.id; };
  while (runs.size() > 2) {  // runs holds r + 1 boundaries
    std::size_t kept = 1;
    for (std::size_t r = 0; r + 1 < runs.size(); r += 2) {
      const std::size_t lo = runs[r], mid = runs[r + 1];
      const std::size_t hi = r + 2 < runs.size() ? runs[r + 2] : mid;  // an odd last run is copied
      std::merge(from + lo, from + mid, from + mid, from + hi, to + lo, by_id);
      runs[kept++] = hi;
    }
    runs.resize(kept);
    std::swap(from, to);
  }
  for (std::size_t a = 0; a < m; ++a) {
    perm[b0 + a] = from[a].slot;
    id_out[b0 + a] = from[a].id;
  }
}
}  // namespace detail

// Orders the slots [b0, b1) of `perm` (old particle indices) and `id_out` (their ids, in
// the same order) by id. Small cells (the usual 10-30 particles) are sorted by ranking: the
// rank of each id is the count of smaller ids, a branch-free O(m^2) loop in vectors. Ids
// below 2^32 (every id of a run with fewer than 2^32 grains) are compared as 32-bit integers,
// four per SSE2 vector (offset by 2^31 for the signed compare, order preserved); a cell with
// a larger id compares doubles, two per vector (exact below 2^53). Larger cells use a
// natural merge sort (detail::merge_runs_by_id). Every variant gives the same order.
inline void order_cell_by_id(std::uint32_t* __restrict perm, std::uint64_t* __restrict id_out,
                             const std::uint64_t* __restrict id, std::size_t b0, std::size_t b1) {
  using Double2 = double __attribute__((vector_size(16)));  // GCC/Clang vector extensions; SSE2 on x86-64
  using Long2 = long long __attribute__((vector_size(16)));
  using Int4 = std::int32_t __attribute__((vector_size(16)));
  constexpr std::size_t kLocal = 64;
  const std::size_t m = b1 - b0;
  if (m < 2) return;  // already in order (id_out holds the ids of perm)
  if (m <= kLocal) {
    std::uint32_t slots[kLocal];
    alignas(64) std::int32_t keys[kLocal + 4];
    std::uint64_t high = 0;  // any bit above 31 of any id
    for (std::size_t a = 0; a < m; ++a) {
      const std::uint64_t i = id_out[b0 + a];
      high |= i;
      slots[a] = perm[b0 + a];
      keys[a] = static_cast<std::int32_t>(static_cast<std::uint32_t>(i) ^ 0x80000000u);
    }
    if ((high >> 32) == 0) {
      // up to 32 particles, a fixed number of vectors (the compare loop unrolled, the keys in
      // registers): one per four particles
      const std::size_t quads = m == 0 ? 1 : (m + 3) / 4;
      // pad: never smaller than a key (the largest key is INT32_MAX itself)
      for (std::size_t a = m; a < 4 * quads; ++a) keys[a] = std::numeric_limits<std::int32_t>::max();
      switch (quads) {
        case 1: detail::rank_keys32<1>(keys, slots, m, perm + b0, id_out + b0); return;
        case 2: detail::rank_keys32<2>(keys, slots, m, perm + b0, id_out + b0); return;
        case 3: detail::rank_keys32<3>(keys, slots, m, perm + b0, id_out + b0); return;
        case 4: detail::rank_keys32<4>(keys, slots, m, perm + b0, id_out + b0); return;
        case 5: detail::rank_keys32<5>(keys, slots, m, perm + b0, id_out + b0); return;
        case 6: detail::rank_keys32<6>(keys, slots, m, perm + b0, id_out + b0); return;
        case 7: detail::rank_keys32<7>(keys, slots, m, perm + b0, id_out + b0); return;
        case 8: detail::rank_keys32<8>(keys, slots, m, perm + b0, id_out + b0); return;
        default: break;
      }
      const auto* kv = reinterpret_cast<const Int4*>(keys);
      for (std::size_t a = 0; a < m; ++a) {
        const std::int32_t k = keys[a];
        const Int4 key = {k, k, k, k};
        Int4 below = {0, 0, 0, 0};
        for (std::size_t b = 0; b < quads; ++b) below -= (kv[b] < key);  // true is -1
        const auto rank = static_cast<std::size_t>(below[0] + below[1] + below[2] + below[3]);
        perm[b0 + rank] = slots[a];
        id_out[b0 + rank] = static_cast<std::uint32_t>(k) ^ 0x80000000u;
      }
      return;
    }
    alignas(64) double dkeys[kLocal + 2];  // slots[] is already filled
    for (std::size_t a = 0; a < m; ++a) dkeys[a] = static_cast<double>(id_out[b0 + a]);
    const std::size_t pairs = (m + 1) / 2;
    dkeys[m] = std::numeric_limits<double>::infinity();  // pad: never smaller than a key
    const auto* kv = reinterpret_cast<const Double2*>(dkeys);
    for (std::size_t a = 0; a < m; ++a) {
      const Double2 key = {dkeys[a], dkeys[a]};
      Long2 below = {0, 0};
      for (std::size_t b = 0; b < pairs; ++b) below -= (kv[b] < key);  // true is -1
      const auto rank = static_cast<std::size_t>(below[0] + below[1]);
      perm[b0 + rank] = slots[a];
      id_out[b0 + rank] = static_cast<std::uint64_t>(dkeys[a]);
    }
    return;
  }
  (void)id;  // every branch reads the ids from id_out
  detail::merge_runs_by_id(perm, id_out, b0, b1);
}

// The padding order_cell_by_key32 (up to 3 slots) and order_cell_by_key32_avx2 (up to 7)
// may read past the last slot of `keys` and `stable`.
inline constexpr std::size_t kKey32Padding = 8;

// The order by id of order_cell_by_id, for the fused step when every id is below 2^32: the
// scatter leaves the cell's old indices in `stable` (the stable counting-sort order) and the
// keys id ^ 2^31 as int32 in `keys` (the signed compare then orders the ids); this writes
// the slots [b0, b1) of `perm` and `id_out` in id order. Reads `keys` and `stable` (arrays
// padded by kKey32Padding past the last slot; read-only while the cells are ordered, so the
// reads past a cell race with no writer) up to three slots past b1, and saves the copy of
// every key and index into local arrays that order_cell_by_id makes. The same order: cells
// above 32 particles are handed to order_cell_by_id (`id`: the ids in the old order).
inline void order_cell_by_key32(const std::uint32_t* __restrict stable, const std::int32_t* __restrict keys,
                                std::uint32_t* __restrict perm, std::uint64_t* __restrict id_out,
                                const std::uint64_t* __restrict id, std::size_t b0, std::size_t b1) {
  const std::size_t m = b1 - b0;
  switch ((m + 3) / 4) {
    case 0: return;
    case 1:
      if (m == 1) {
        perm[b0] = stable[b0];
        id_out[b0] = static_cast<std::uint32_t>(keys[b0]) ^ 0x80000000u;
        return;
      }
      detail::rank_keys32<1>(keys + b0, stable + b0, m, perm + b0, id_out + b0);
      return;
    case 2: detail::rank_keys32<2>(keys + b0, stable + b0, m, perm + b0, id_out + b0); return;
    case 3: detail::rank_keys32<3>(keys + b0, stable + b0, m, perm + b0, id_out + b0); return;
    case 4: detail::rank_keys32<4>(keys + b0, stable + b0, m, perm + b0, id_out + b0); return;
    case 5: detail::rank_keys32<5>(keys + b0, stable + b0, m, perm + b0, id_out + b0); return;
    case 6: detail::rank_keys32<6>(keys + b0, stable + b0, m, perm + b0, id_out + b0); return;
    case 7: detail::rank_keys32<7>(keys + b0, stable + b0, m, perm + b0, id_out + b0); return;
    case 8: detail::rank_keys32<8>(keys + b0, stable + b0, m, perm + b0, id_out + b0); return;
    default:
      for (std::size_t j = b0; j < b1; ++j) {
        perm[j] = stable[j];
        id_out[j] = static_cast<std::uint32_t>(keys[j]) ^ 0x80000000u;
      }
      order_cell_by_id(perm, id_out, id, b0, b1);
  }
}

namespace detail {
// rank_keys32 in AVX2: the cell's keys in Q8 vectors of eight (m <= 8 Q8), the lanes past
// the m real keys set to INT32_MAX; then for each key a in turn, its rank is the number of
// real keys below it: one broadcast, Q8 compares, their sign masks (movemask) and a popcount,
// and the key's slot is written at once. The same integer compares (key_a > key_b counts b
// for a, as key_b < key_a counted a for b before), so the same ranks and the same order; a
// padded lane is never below a key (none is above INT32_MAX). One loop per cell instead of
// two (the ranks were stored as vectors and read back one by one, where perf showed the
// ranking's samples), no vector store and reload of the ranks: DSMC-1 at 1e6 ~0.3 ms of
// ~31 ms per step faster (alternating steps in one process; docs/performance/dsmc1.md, h-dsmc11).
template <std::size_t Q8>
[[gnu::target("avx2,popcnt"), gnu::always_inline]] inline void rank_keys32_avx2(const std::int32_t* __restrict keys,
                                                                               const std::uint32_t* __restrict stable,
                                                                               std::size_t m, std::uint32_t* __restrict perm,
                                                                               std::uint64_t* __restrict id_out) {
  __m256i kv[Q8];
  const __m256i top = _mm256_set1_epi32(std::numeric_limits<std::int32_t>::max());
  const __m256i count = _mm256_set1_epi32(static_cast<std::int32_t>(m));
  for (std::size_t q = 0; q < Q8; ++q) {
    const auto l = static_cast<std::int32_t>(8 * q);
    const __m256i lane = _mm256_setr_epi32(l, l + 1, l + 2, l + 3, l + 4, l + 5, l + 6, l + 7);
    kv[q] = _mm256_blendv_epi8(top, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(keys) + q),
                               _mm256_cmpgt_epi32(count, lane));
  }
  for (std::size_t a = 0; a < m; ++a) {
    const std::int32_t k = keys[a];
    const __m256i key = _mm256_set1_epi32(k);
    unsigned below = 0;  // bit b: key b is below key a
    for (std::size_t q = 0; q < Q8; ++q)
      below |= static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(key, kv[q])))) << (8 * q);
    const auto r = static_cast<std::size_t>(__builtin_popcount(below));
    perm[r] = stable[a];
    id_out[r] = static_cast<std::uint32_t>(k) ^ 0x80000000u;
  }
}
}  // namespace detail

// order_cell_by_key32 with the ranking in AVX2 (call only where the CPU has AVX2, which every
// such x86 CPU pairs with POPCNT): the same order and ids. Reads `keys` up to seven slots past
// b1 (kKey32Padding).
[[gnu::target("avx2,popcnt")]] inline void order_cell_by_key32_avx2(const std::uint32_t* __restrict stable,
                                                             const std::int32_t* __restrict keys,
                                                             std::uint32_t* __restrict perm,
                                                             std::uint64_t* __restrict id_out,
                                                             const std::uint64_t* __restrict id, std::size_t b0,
                                                             std::size_t b1) {
  const std::size_t m = b1 - b0;
  switch ((m + 7) / 8) {
    case 1:
      if (m < 2) break;
      detail::rank_keys32_avx2<1>(keys + b0, stable + b0, m, perm + b0, id_out + b0);
      return;
    case 2: detail::rank_keys32_avx2<2>(keys + b0, stable + b0, m, perm + b0, id_out + b0); return;
    case 3: detail::rank_keys32_avx2<3>(keys + b0, stable + b0, m, perm + b0, id_out + b0); return;
    case 4: detail::rank_keys32_avx2<4>(keys + b0, stable + b0, m, perm + b0, id_out + b0); return;
    default: break;
  }
  order_cell_by_key32(stable, keys, perm, id_out, id, b0, b1);
}

// order_cell_by_key32 with AVX-512F (call only where the CPU has it; the fused step takes it
// where Philox4x32Lanes::have_avx512): the same order and ids. One path for every cell of
// 2..32 keys: the keys in two 16-lane registers (masked loads, INT32_MAX past the cell, so
// nothing is read past b1), each key's rank the popcount of two compares into mask registers,
// as in rank_keys32_avx2 (the same strict compares, so the same ranks). The AVX2 ranking
// chooses among one to four vectors by the cell's size, a branch the predictor misses for
// about four cells in ten at a mean of 16; here only cells of 0, 1 or more than 32 keys (as
// good as never in DSMC-1) branch off. DSMC-1 at 1e6: ~0.4-0.67 ms of ~32 ms per step faster
// than the AVX2 ranking (steps alternating between the two in one process, 8 x 99 pairs,
// 53-86 of 99 faster; docs/performance/dsmc1.md, h-dsmc11).
[[gnu::target("avx512f,popcnt")]] inline void order_cell_by_key32_avx512(const std::uint32_t* __restrict stable,
                                                                       const std::int32_t* __restrict keys,
                                                                       std::uint32_t* __restrict perm,
                                                                       std::uint64_t* __restrict id_out,
                                                                       const std::uint64_t* __restrict id, std::size_t b0,
                                                                       std::size_t b1) {
  const std::size_t m = b1 - b0;
  if (m < 2 || m > 32) [[unlikely]] {
    order_cell_by_key32(stable, keys, perm, id_out, id, b0, b1);
    return;
  }
  const std::uint64_t valid = (std::uint64_t{1} << m) - 1;  // bit b: key b is in the cell
  const __m512i top = _mm512_set1_epi32(std::numeric_limits<std::int32_t>::max());
  const __m512i kv0 = _mm512_mask_loadu_epi32(top, static_cast<__mmask16>(valid), keys + b0);
  const __m512i kv1 = _mm512_mask_loadu_epi32(top, static_cast<__mmask16>(valid >> 16), keys + b0 + 16);
  for (std::size_t a = 0; a < m; ++a) {
    const std::int32_t k = keys[b0 + a];
    const __m512i key = _mm512_set1_epi32(k);
    const unsigned below = static_cast<unsigned>(_mm512_cmpgt_epi32_mask(key, kv0)) |
                           (static_cast<unsigned>(_mm512_cmpgt_epi32_mask(key, kv1)) << 16);
    const std::size_t r = b0 + static_cast<std::size_t>(__builtin_popcount(below));
    perm[r] = stable[b0 + a];
    id_out[r] = static_cast<std::uint32_t>(k) ^ 0x80000000u;
  }
}

// Counting-sort offsets: `counts` holds [thread][cell] counts on entry and the first slot
// of each (cell, thread) run on exit, in (cell, thread) order, so the sort is stable and its
// result does not depend on the thread count; start[k] is the first slot of cell k and
// start[cells] the total.
inline void counting_sort_offsets(std::uint32_t* counts, int threads, std::size_t cells, std::size_t* start) {
  std::uint32_t offset = 0;
  for (std::size_t k = 0; k < cells; ++k) {
    start[k] = offset;
    for (int u = 0; u < threads; ++u) {
      std::uint32_t& row = counts[static_cast<std::size_t>(u) * cells + k];
      const std::uint32_t here = row;
      row = offset;
      offset += here;
    }
  }
  start[cells] = offset;
}

}  // namespace grainbath::dsmc
