#pragma once
// Ordering the particles of one cell by global id, shared by the cell sort
// (src/dsmc/spatial.cpp) and the fused step (src/dsmc/fused.cpp).
#include <immintrin.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "operators/random.hpp"  // Philox4x32Lanes::have_avx512: the dispatch rule of every SIMD path

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
// Which run gives the next element is a coin toss where two runs interleave (grains from the
// neighbouring cells), so the merge's branch is mispredicted about once per element of the
// smaller run: in hot-walls (1250 grains a cell) the merge held 19 % of a 1-thread run. The
// fused step's cells (32-bit ids) therefore merge packed words, smallest runs first, in
// AVX-512 or AVX2 lanes where the CPU has them (merge_runs_by_key32; hot-walls 11 % and 4 %
// faster, docs/performance/dsmc1.md).
// A branch-free scalar merge (a select per element) was slower still: its loop-carried
// dependency costs more than the mispredictions of the runs' unequal sizes.
// The scratch is per thread and only grows (no allocation per cell or step).
struct IdSlot {
  std::uint64_t id;
  std::uint32_t slot;
};
// Neighbouring runs of `from` merged pairwise until one is left, `runs` holding the runs'
// r + 1 boundaries (`to`: scratch of the same size; `merge(a, ae, b, be, out)` merges two
// ascending runs, as std::merge). Returns the array
// that holds the result (from or to).
template <class T, class Merge>
inline T* merge_pairwise(T* from, T* to, std::vector<std::size_t>& runs, Merge merge) {
  while (runs.size() > 2) {
    std::size_t kept = 1;
    for (std::size_t r = 0; r + 1 < runs.size(); r += 2) {
      const std::size_t lo = runs[r], mid = runs[r + 1];
      const std::size_t hi = r + 2 < runs.size() ? runs[r + 2] : mid;  // an odd last run is copied
      merge(from + lo, from + mid, from + mid, from + hi, to + lo);
      runs[kept++] = hi;
    }
    runs.resize(kept);
    std::swap(from, to);
  }
  return from;
}
// The natural merge sort of `from[0, m)` (with `to` the same size as scratch): the runs'
// boundaries are found, then merged pairwise. Returns the array that holds the result.
template <class T, class Key>
inline T* natural_merge_sort(T* from, T* to, std::size_t m, std::vector<std::size_t>& runs, Key key) {
  runs.clear();
  runs.push_back(0);
  for (std::size_t a = 1; a < m; ++a)
    if (key(from[a]) < key(from[a - 1])) runs.push_back(a);
  runs.push_back(m);
  const auto by_key = [key](const T& x, const T& y) { return key(x) < key(y); };
  return merge_pairwise(from, to, runs,
                        [by_key](const T* a, const T* ae, const T* b, const T* be, T* out) { std::merge(a, ae, b, be, out, by_key); });
}
inline void merge_runs_by_id(std::uint32_t* __restrict perm, std::uint64_t* __restrict id_out, std::size_t b0,
                             std::size_t b1) {
  thread_local std::vector<IdSlot> scratch;
  thread_local std::vector<std::size_t> runs;
  const std::size_t m = b1 - b0;
  if (scratch.size() < 2 * m) scratch.resize(2 * m);
  IdSlot* from = scratch.data();
  for (std::size_t a = 0; a < m; ++a) from[a] = IdSlot{id_out[b0 + a], perm[b0 + a]};  // id_out: the ids of perm
  const IdSlot* sorted = natural_merge_sort(from, from + m, m, runs, [](const IdSlot& x) { return x.id; });
  for (std::size_t a = 0; a < m; ++a) {
    perm[b0 + a] = sorted[a].slot;
    id_out[b0 + a] = sorted[a].id;
  }
}
// The end of the SIMD merges: the largest register's words [t, te) and what is left of the
// two runs, merged one word at a time (packed words are never UINT64_MAX, which marks a run
// that is used up).
inline std::uint64_t* merge_three_runs(const std::uint64_t* t, const std::uint64_t* te, const std::uint64_t* a,
                                       const std::uint64_t* ae, const std::uint64_t* b, const std::uint64_t* be,
                                       std::uint64_t* out) {
  constexpr std::uint64_t done = std::numeric_limits<std::uint64_t>::max();
  for (;;) {
    const std::uint64_t x = t != te ? *t : done, y = a != ae ? *a : done, z = b != be ? *b : done;
    if (x < y && x < z) {
      *out++ = x;
      ++t;
    } else if (y < z) {
      *out++ = y;
      ++a;
    } else if (z != done) {
      *out++ = z;
      ++b;
    } else {
      return out;
    }
  }
}
// Merging in AVX-512 (packed 64-bit words, never equal, never UINT64_MAX): eight words of
// each run in a register, a bitonic network leaves the eight smallest in one and the eight
// largest in the other; the smallest are stored, and the next eight come from the run whose
// next word is the smaller (the stored eight are then below every word not yet stored). One
// unpredictable branch per eight words instead of one per word (the interleaving of two runs
// is a coin toss per word: DSMC's arrivals from the neighbouring cells among the grains that
// stay). The network: min/max of a and b reversed (the eight smallest and the eight largest,
// each bitonic), then each half-cleaned at distances 4, 2 and 1.
// (GCC 12 warns that the intrinsics' undefined pass-through operand "may be used
// uninitialized" once they are inlined: a false positive of the masked builtins)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
// lane l against lane `partner[l]`: the min where `upper` is clear, the max where it is set
[[gnu::target("avx512f"), gnu::always_inline]] inline __m512i half_clean(__m512i v, __m512i partner, __mmask8 upper) {
  const __m512i p = _mm512_permutexvar_epi64(partner, v);
  return _mm512_mask_blend_epi64(upper, _mm512_min_epu64(v, p), _mm512_max_epu64(v, p));
}
[[gnu::target("avx512f"), gnu::always_inline]] inline void bitonic_merge8(__m512i& a, __m512i& b) {
  b = _mm512_permutexvar_epi64(_mm512_set_epi64(0, 1, 2, 3, 4, 5, 6, 7), b);
  __m512i lo = _mm512_min_epu64(a, b), hi = _mm512_max_epu64(a, b);
  const __m512i d4 = _mm512_set_epi64(3, 2, 1, 0, 7, 6, 5, 4), d2 = _mm512_set_epi64(5, 4, 7, 6, 1, 0, 3, 2),
                d1 = _mm512_set_epi64(6, 7, 4, 5, 2, 3, 0, 1);
  lo = half_clean(half_clean(half_clean(lo, d4, 0xF0), d2, 0xCC), d1, 0xAA);
  hi = half_clean(half_clean(half_clean(hi, d4, 0xF0), d2, 0xCC), d1, 0xAA);
  a = lo;
  b = hi;
}
[[gnu::target("avx512f")]] inline std::uint64_t* merge_words_avx512(const std::uint64_t* a, const std::uint64_t* ae,
                                                                    const std::uint64_t* b, const std::uint64_t* be,
                                                                    std::uint64_t* out) {
  if (ae - a < 8 || be - b < 8) return std::merge(a, ae, b, be, out);
  __m512i low = _mm512_loadu_si512(a), high = _mm512_loadu_si512(b);
  a += 8;
  b += 8;
  for (;;) {
    bitonic_merge8(low, high);
    _mm512_storeu_si512(out, low);
    out += 8;
    if (a != ae && (b == be || *a < *b)) {
      if (ae - a < 8) break;
      low = _mm512_loadu_si512(a);
      a += 8;
    } else {
      if (b == be || be - b < 8) break;
      low = _mm512_loadu_si512(b);
      b += 8;
    }
  }
  // the eight largest so far and what is left of both runs (one of them under eight words)
  alignas(64) std::uint64_t rest[8];
  _mm512_store_si512(rest, high);
  return merge_three_runs(rest, rest + 8, a, ae, b, be, out);
}
#pragma GCC diagnostic pop
// The same in AVX2 lanes, four words at a time (CPUs without AVX-512). AVX2 has no unsigned
// 64-bit min/max, only a signed compare: the words are loaded with their top bit flipped (the
// signed order of the flipped words is the unsigned order of the words), min and max are blends
// on that compare, and the bit is flipped back on the store. The network: min/max of a and b
// reversed, then half-cleaners at distances 2 and 1.
[[gnu::target("avx2"), gnu::always_inline]] inline void min_max4(__m256i a, __m256i b, __m256i& lo, __m256i& hi) {
  const __m256i a_above = _mm256_cmpgt_epi64(a, b);
  lo = _mm256_blendv_epi8(a, b, a_above);
  hi = _mm256_blendv_epi8(b, a, a_above);
}
[[gnu::target("avx2"), gnu::always_inline]] inline void bitonic_merge4(__m256i& a, __m256i& b) {
  __m256i lo, hi, mn, mx;
  min_max4(a, _mm256_permute4x64_epi64(b, 0x1B), lo, hi);  // b reversed: lanes 3, 2, 1, 0
  // distance 2 (partner lanes 2, 3, 0, 1): the min in lanes 0-1, the max in lanes 2-3
  min_max4(lo, _mm256_permute4x64_epi64(lo, 0x4E), mn, mx);
  lo = _mm256_blend_epi32(mn, mx, 0xF0);
  min_max4(hi, _mm256_permute4x64_epi64(hi, 0x4E), mn, mx);
  hi = _mm256_blend_epi32(mn, mx, 0xF0);
  // distance 1 (partner lanes 1, 0, 3, 2): the min in lanes 0 and 2, the max in 1 and 3
  min_max4(lo, _mm256_permute4x64_epi64(lo, 0xB1), mn, mx);
  lo = _mm256_blend_epi32(mn, mx, 0xCC);
  min_max4(hi, _mm256_permute4x64_epi64(hi, 0xB1), mn, mx);
  hi = _mm256_blend_epi32(mn, mx, 0xCC);
  a = lo;
  b = hi;
}
[[gnu::target("avx2"), gnu::always_inline]] inline __m256i load_flipped(const std::uint64_t* p, __m256i top) {
  return _mm256_xor_si256(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(p)), top);
}
[[gnu::target("avx2")]] inline std::uint64_t* merge_words_avx2(const std::uint64_t* a, const std::uint64_t* ae,
                                                               const std::uint64_t* b, const std::uint64_t* be,
                                                               std::uint64_t* out) {
  if (ae - a < 4 || be - b < 4) return std::merge(a, ae, b, be, out);
  const __m256i top = _mm256_set1_epi64x(static_cast<long long>(0x8000000000000000ull));
  __m256i low = load_flipped(a, top), high = load_flipped(b, top);
  a += 4;
  b += 4;
  for (;;) {
    bitonic_merge4(low, high);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out), _mm256_xor_si256(low, top));
    out += 4;
    if (a != ae && (b == be || *a < *b)) {
      if (ae - a < 4) break;
      low = load_flipped(a, top);
      a += 4;
    } else {
      if (b == be || be - b < 4) break;
      low = load_flipped(b, top);
      b += 4;
    }
  }
  // the four largest so far and what is left of both runs (one of them under four words)
  alignas(32) std::uint64_t rest[4];
  _mm256_store_si256(reinterpret_cast<__m256i*>(rest), _mm256_xor_si256(high, top));
  return merge_three_runs(rest, rest + 4, a, ae, b, be, out);
}
// The same for the fused step's 32-bit keys (every id below 2^32): id and old index packed
// into one 64-bit word, id << 32 | index, so that a compare of words is a compare of ids
// (distinct; the index is below 2^32 - 1, so no word is UINT64_MAX) and a merge moves 8
// bytes per element instead of 16. Reads keys[b0, b1) (id ^ 2^31) and stable[b0, b1); writes
// perm and id_out in id order. The merges in AVX-512 where Philox4x32Lanes::have_avx512, else
// in AVX2 where have_avx2, else scalar (the same order).
// Up to kSmallestFirst runs are merged two smallest first (Huffman's order: any order of
// merges gives the one sorted result, ids being distinct): a cell's runs are its grains
// that stay (the largest run, 70 % of a hot-walls cell) and the arrivals from each side, so
// the arrivals are merged among themselves before the one merge with the stayers, and the
// stayers are moved once instead of once per pairwise pass (hot-walls: runs of 1, 182, 839,
// 187 grains; 1.3 instead of 1.85 words merged per grain).
inline constexpr std::size_t kSmallestFirst = 16;
inline void merge_runs_by_key32(const std::uint32_t* __restrict stable, const std::int32_t* __restrict keys,
                                std::uint32_t* __restrict perm, std::uint64_t* __restrict id_out, std::size_t b0,
                                std::size_t b1) {
  thread_local std::vector<std::uint64_t> scratch;
  thread_local std::vector<std::size_t> runs;
  const std::size_t m = b1 - b0;
  if (scratch.size() < 2 * m) scratch.resize(2 * m);
  runs.clear();
  runs.push_back(0);
  {
    std::uint64_t* words = scratch.data();
    std::uint64_t previous = 0;
    for (std::size_t a = 0; a < m; ++a) {
      const std::uint64_t w = (std::uint64_t{static_cast<std::uint32_t>(keys[b0 + a]) ^ 0x80000000u} << 32) | stable[b0 + a];
      if (w < previous) runs.push_back(a);  // (a = 0: no word is below 0)
      words[a] = previous = w;
    }
  }
  runs.push_back(m);
  const bool avx512 = Philox4x32Lanes::have_avx512(), avx2 = Philox4x32Lanes::have_avx2();
  const auto merge = [avx512, avx2](const std::uint64_t* a, const std::uint64_t* ae, const std::uint64_t* b,
                                    const std::uint64_t* be, std::uint64_t* out) {
    if (avx512)
      merge_words_avx512(a, ae, b, be, out);
    else if (avx2)
      merge_words_avx2(a, ae, b, be, out);
    else
      std::merge(a, ae, b, be, out);
  };
  const std::size_t r = runs.size() - 1;
  const std::uint64_t* sorted = scratch.data();
  if (r > kSmallestFirst) {  // many runs (a disordered cell): the pairwise passes
    sorted = merge_pairwise(scratch.data(), scratch.data() + m, runs, merge);
  } else if (r > 1) {
    // the words merged in all: every merge's output, placed one after the other past the m
    // words of the cell
    std::size_t size[kSmallestFirst], count = r, total = 0;
    for (std::size_t q = 0; q < r; ++q) size[q] = runs[q + 1] - runs[q];
    auto two_smallest = [&](const std::size_t* n, std::size_t c, std::size_t& i, std::size_t& j) {
      i = n[0] < n[1] ? 0 : 1;
      j = 1 - i;
      for (std::size_t q = 2; q < c; ++q)
        if (n[q] < n[i]) {
          j = i;
          i = q;
        } else if (n[q] < n[j]) {
          j = q;
        }
    };
    while (count > 1) {
      std::size_t i, j;
      two_smallest(size, count, i, j);
      size[i] += size[j];
      total += size[i];
      size[j] = size[--count];
    }
    if (scratch.size() < m + total) scratch.resize(m + total);
    std::uint64_t* words = scratch.data();
    const std::uint64_t* begin[kSmallestFirst];
    for (std::size_t q = 0; q < r; ++q) {
      begin[q] = words + runs[q];
      size[q] = runs[q + 1] - runs[q];
    }
    std::uint64_t* free = words + m;
    count = r;
    while (count > 1) {
      std::size_t i, j;
      two_smallest(size, count, i, j);
      merge(begin[i], begin[i] + size[i], begin[j], begin[j] + size[j], free);
      begin[i] = free;
      size[i] += size[j];
      free += size[i];
      begin[j] = begin[--count];
      size[j] = size[count];
    }
    sorted = begin[0];
  }
  for (std::size_t a = 0; a < m; ++a) {
    perm[b0 + a] = static_cast<std::uint32_t>(sorted[a]);
    id_out[b0 + a] = sorted[a] >> 32;
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
// of 33-64 particles are handed to order_cell_by_id (`id`: the ids in the old order), larger
// ones to the natural merge sort on packed words (detail::merge_runs_by_key32).
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
      if (m > 64) {  // large cells: the natural merge sort on packed words
        detail::merge_runs_by_key32(stable, keys, perm, id_out, b0, b1);
        return;
      }
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
