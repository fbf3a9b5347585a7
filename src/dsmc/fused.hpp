#pragma once
// The DSMC step of a spatial box in one parallel region (Issue #7 performance):
// streaming, cell index and counting-sort counts in one pass over the particles, the
// scatter, then per cell the order by id, the gather into the new order and the grain-grain
// collisions while the cell is in L1. The same particle order, random streams and counter
// sums as stream + sort_by_cell + the per-cell collisions, hence bitwise the same results.
#include <emmintrin.h>
#include <immintrin.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "dsmc/collide.hpp"
#include "dsmc/dsmc.hpp"
#include "dsmc/spatial.hpp"
#include "dsmc/state.hpp"

namespace grainbath::dsmc {

class Decomposition;

// True for spatial runs (periodic faces or walls: specular, diffuse, open), unless the
// environment variable GRAINBATH_DSMC_UNFUSED is set (the separate passes, for comparisons
// and tests) or a box with walls has 2^31 cells or more (kStreamedBit).
bool fused_step_applies(const Config& c);

// Streams over dt, orders by (cell, id), fills s.cell_start and collides in every cell;
// `per_block` receives the counters of each block of dec.block_cells() cells (summed in
// block order: the decomposition's reduction blocks, fixed by the case, so the sums are the
// same at any thread or rank count).
// Walls: the grains whose flight crosses one fly by stream_through_walls (spatial.hpp) in
// the streaming pass; `walls` receives the wall exchanges per block of the order before the
// step (Decomposition::block_bounds, into `bounds`), as the separate pass `stream` gives
// them, for the caller to combine; empty in a fully periodic box.
// MPI ranks: the rank's own cells, with the migration of the grains that cross into other
// ranks' cells inside the step (fused.cpp, fused_step); per_block then holds this rank's
// blocks, combined over the ranks in block order here.
void fused_spatial_step(State& s, const Config& c, std::uint64_t seed, std::vector<GrainCounters>& per_block,
                        Decomposition& dec, std::vector<std::size_t>& bounds, std::vector<StreamCounters>& walls);

namespace detail {

// The rows of cells along y per tile of the fused step's block order for `particles` in a 3-D
// box of cells[0..2] cells: cells[1] (the plain order) while a z plane of the previous
// arrays stays in the last-level cache, fewer for large boxes (fused.cpp, fused_step).
// GRAINBATH_DSMC_TILE_ROWS overrides it (tests: the tiled order in small boxes).
std::size_t fused_tile_rows(std::size_t particles, const std::array<int, 3>& cells);

// The cell index of the streaming pass in SIMD. A group of particles whose streamed
// positions x + v dt all lie in [0, L) (wrap_periodic leaves them as they are: ~96 % of pairs
// in DSMC-1) gets its cells here; the cell of an axis is CellGrid::axis as a clamp in
// doubles, min(max(x / h, 0), n - 1) truncated (max gives 0 for NaN, as `!(f > 0)` does),
// and the linear index is formed in doubles (exact below 2^53; the caller takes this path
// below 2^31 cells only), so the cells are those of CellGrid. A group with a coordinate to
// wrap is handed to `scalar(i)` particle by particle. Only correctly rounded operations
// (add, mul, compare, min, max, truncation; no FMA, the AVX2 function does not enable it):
// the SSE2 path (two particles per vector) and the AVX2 path (four) give the same cells
// (tests/dsmc/test_dsmc_cell_order.cpp, DsmcStreamCells.*). Both return the first index
// they did not process (hi - i < the group size remain). With kCount = false the cells are
// only stored (the fused step's prediction of the next step's cells, `cnt` unused).
struct StreamCellsArgs {
  const double* pos[3];
  const double* vel[3];
  double dt;
  double length[3];
  double inv_size[3];  // CellGrid::inv_size
  double top[3];       // cells per axis - 1
  double nx, ny;       // cells along x and y
  bool walled[3] = {false, false, false};  // WallAxes::walled (stream_cells_avx2 with kWalls)
};

template <int Dim, bool kCount = true, class Scalar>
inline std::size_t stream_cells_sse2(const StreamCellsArgs& g, std::size_t i, std::size_t hi, std::uint32_t* cell,
                                     std::uint32_t* cnt, Scalar&& scalar) {
  const __m128d dt2 = _mm_set1_pd(g.dt), zero = _mm_setzero_pd();
  __m128d len[3], inv[3], top[3];
  for (int a = 0; a < 3; ++a) {
    len[a] = _mm_set1_pd(g.length[a]);
    inv[a] = _mm_set1_pd(g.inv_size[a]);
    top[a] = _mm_set1_pd(g.top[a]);
  }
  const __m128d nx = _mm_set1_pd(g.nx), ny = _mm_set1_pd(g.ny);
  for (; i + 2 <= hi; i += 2) {
    __m128d k[3], outside = zero;
    for (int a = 0; a < Dim; ++a) {
      const __m128d xa = _mm_add_pd(_mm_loadu_pd(g.pos[a] + i), _mm_mul_pd(_mm_loadu_pd(g.vel[a] + i), dt2));
      outside = _mm_or_pd(outside, _mm_or_pd(_mm_cmplt_pd(xa, zero), _mm_cmpge_pd(xa, len[a])));
      const __m128d f = _mm_min_pd(_mm_max_pd(_mm_mul_pd(xa, inv[a]), zero), top[a]);
      k[a] = _mm_cvtepi32_pd(_mm_cvttpd_epi32(f));
    }
    if (_mm_movemask_pd(outside) != 0) [[unlikely]] {
      scalar(i);
      scalar(i + 1);
      continue;
    }
    __m128d linear = k[0];
    if constexpr (Dim == 2) linear = _mm_add_pd(k[0], _mm_mul_pd(nx, k[1]));
    if constexpr (Dim == 3) linear = _mm_add_pd(k[0], _mm_mul_pd(nx, _mm_add_pd(k[1], _mm_mul_pd(ny, k[2]))));
    const __m128i kk = _mm_cvttpd_epi32(linear);
    _mm_storel_epi64(reinterpret_cast<__m128i*>(cell + i), kk);
    if constexpr (kCount) {
      ++cnt[static_cast<std::uint32_t>(_mm_cvtsi128_si32(kk))];
      ++cnt[static_cast<std::uint32_t>(_mm_cvtsi128_si32(_mm_shuffle_epi32(kk, 1)))];
    }
  }
  return i;
}

// wrap_periodic (src/dsmc/spatial.hpp) of the lanes of x flagged in `outside` (all bits set
// where x < 0 or x >= L), the others unchanged: x - L floor(x / L) by the same correctly
// rounded operations (divide, floor, multiply, subtract; no FMA: target avx2 does not enable
// it), then a result >= L (x = -tiny) becomes +0: bitwise the scalar function's positions.
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d wrap_periodic_avx2(__m256d x, __m256d L, __m256d outside) {
  const __m256d wrapped = _mm256_sub_pd(x, _mm256_mul_pd(L, _mm256_floor_pd(_mm256_div_pd(x, L))));
  return _mm256_blendv_pd(x, _mm256_andnot_pd(_mm256_cmp_pd(wrapped, L, _CMP_GE_OQ), wrapped), outside);
}

// The same with AVX2, four particles per vector and three-operand instructions: ~40 % of the
// SSE2 path's instructions per particle (docs/performance/dsmc1.md). A group with a
// coordinate to wrap is wrapped in the vector (wrap_periodic's operations), not handed to
// `scalar`: the scalar lambda cost ~3 % of the DSMC-1 step (8 % of the groups of four have
// a particle crossing a face). With kWalls, a particle with a coordinate outside [0, L) on
// a walled axis (g.walled) is handed to `scalar` (the wall's flight) instead of being stored
// and counted; its group's other particles are stored as usual, in lane order.
template <int Dim, bool kCount = true, bool kWalls = false, class Scalar>
[[gnu::target("avx2")]] inline std::size_t stream_cells_avx2(const StreamCellsArgs& g, std::size_t i, std::size_t hi,
                                                             std::uint32_t* cell, std::uint32_t* cnt, [[maybe_unused]] Scalar&& scalar) {
  const __m256d dt4 = _mm256_set1_pd(g.dt), zero = _mm256_setzero_pd();
  __m256d len[3], inv[3], top[3];
  for (int a = 0; a < 3; ++a) {
    len[a] = _mm256_set1_pd(g.length[a]);
    inv[a] = _mm256_set1_pd(g.inv_size[a]);
    top[a] = _mm256_set1_pd(g.top[a]);
  }
  const __m256d nx = _mm256_set1_pd(g.nx), ny = _mm256_set1_pd(g.ny);
  for (; i + 4 <= hi; i += 4) {
    __m256d k[3];
    [[maybe_unused]] int at_wall = 0;  // kWalls: the lanes outside [0, L) on a walled axis
    for (int a = 0; a < Dim; ++a) {
      __m256d xa = _mm256_add_pd(_mm256_loadu_pd(g.pos[a] + i), _mm256_mul_pd(_mm256_loadu_pd(g.vel[a] + i), dt4));
      // ordered, quiet compares: false for NaN, as SSE2's cmplt/cmpge (and wrap_periodic's)
      const __m256d outside = _mm256_or_pd(_mm256_cmp_pd(xa, zero, _CMP_LT_OQ), _mm256_cmp_pd(xa, len[a], _CMP_GE_OQ));
      if (_mm256_movemask_pd(outside) != 0) [[unlikely]] {
        if constexpr (kWalls) {
          if (g.walled[a]) {
            at_wall |= _mm256_movemask_pd(outside);  // no wrap: these lanes' cells are not used
          } else {
            xa = wrap_periodic_avx2(xa, len[a], outside);
          }
        } else {
          xa = wrap_periodic_avx2(xa, len[a], outside);
        }
      }
      const __m256d f = _mm256_min_pd(_mm256_max_pd(_mm256_mul_pd(xa, inv[a]), zero), top[a]);
      k[a] = _mm256_cvtepi32_pd(_mm256_cvttpd_epi32(f));
    }
    __m256d linear = k[0];
    if constexpr (Dim == 2) linear = _mm256_add_pd(k[0], _mm256_mul_pd(nx, k[1]));
    if constexpr (Dim == 3) linear = _mm256_add_pd(k[0], _mm256_mul_pd(nx, _mm256_add_pd(k[1], _mm256_mul_pd(ny, k[2]))));
    const __m128i kk = _mm256_cvttpd_epi32(linear);
    if constexpr (kWalls) {
      if (at_wall != 0) [[unlikely]] {  // the lanes at a wall to `scalar`, the others as below, in order
        alignas(16) std::uint32_t lane[4];
        _mm_store_si128(reinterpret_cast<__m128i*>(lane), kk);
        for (int q = 0; q < 4; ++q) {
          if ((at_wall >> q) & 1) {
            scalar(i + static_cast<std::size_t>(q));
          } else {
            cell[i + static_cast<std::size_t>(q)] = lane[q];
            if constexpr (kCount) ++cnt[lane[q]];
          }
        }
        continue;
      }
    }
    _mm_storeu_si128(reinterpret_cast<__m128i*>(cell + i), kk);
    if constexpr (kCount) {
      ++cnt[static_cast<std::uint32_t>(_mm_cvtsi128_si32(kk))];
      ++cnt[static_cast<std::uint32_t>(_mm_extract_epi32(kk, 1))];
      ++cnt[static_cast<std::uint32_t>(_mm_extract_epi32(kk, 2))];
      ++cnt[static_cast<std::uint32_t>(_mm_extract_epi32(kk, 3))];
    }
  }
  return i;
}

// An opaque copy of a product: under target("avx512f") GCC contracts a * b + c into an FMA
// (AVX-512F implies FMA), which would round differently from the AVX2 and SSE2 paths.
[[gnu::target("avx512f"), gnu::always_inline]] inline __m512d rounded512(__m512d x) {
  __asm__("" : "+v"(x));
  return x;
}

// The fused step's prediction of the next step's cells (stream_cells_avx2 with kCount =
// false) with AVX-512F, eight particles per vector: the same operations in the same order
// (the products kept rounded before their sums, rounded512; ordered quiet compares; max with
// zero second, so NaN gives 0 as there; wrap_periodic's divide, floor, multiply, subtract and
// the >= L to +0 fix), so the same cells. Returns the first index it did not process (fewer
// than eight remain: the caller finishes with stream_cells_avx2 and the scalar expression).
// The pass is a sustained loop over a block's slots, where the halved instruction count wins
// (unlike h-dsmc10's 512-bit Philox refill, a short burst per cell): DSMC-1 at 1e6 ~0.3-0.57
// ms of ~32 ms per step faster (steps alternating between this and the AVX2 pass in one
// process, 8 runs of 99 pairs, 62-91 of 99 faster; docs/performance/dsmc1.md, h-dsmc11).
// The full-mask maskz forms are the plain instructions (GCC 12's unmasked intrinsics pass an
// undefined source and warn).
template <int Dim>
[[gnu::target("avx512f")]] inline std::size_t predict_cells_avx512(const StreamCellsArgs& g, std::size_t i, std::size_t hi,
                                                                  std::uint32_t* cell) {
  constexpr __mmask8 all = 0xff;
  const __m512d dt8 = _mm512_set1_pd(g.dt), zero = _mm512_setzero_pd();
  __m512d len[3], inv[3], top[3];
  for (int a = 0; a < 3; ++a) {
    len[a] = _mm512_set1_pd(g.length[a]);
    inv[a] = _mm512_set1_pd(g.inv_size[a]);
    top[a] = _mm512_set1_pd(g.top[a]);
  }
  const __m512d nx = _mm512_set1_pd(g.nx), ny = _mm512_set1_pd(g.ny);
  for (; i + 8 <= hi; i += 8) {
    __m512d k[3];
    for (int a = 0; a < Dim; ++a) {
      __m512d xa = _mm512_add_pd(_mm512_loadu_pd(g.pos[a] + i), rounded512(_mm512_mul_pd(_mm512_loadu_pd(g.vel[a] + i), dt8)));
      const __mmask8 outside = _mm512_cmp_pd_mask(xa, zero, _CMP_LT_OQ) | _mm512_cmp_pd_mask(xa, len[a], _CMP_GE_OQ);
      if (outside != 0) [[unlikely]] {  // wrap_periodic_avx2's operations
        const __m512d fl =
            _mm512_maskz_roundscale_pd(all, _mm512_div_pd(xa, len[a]), _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
        const __m512d wrapped = _mm512_sub_pd(xa, rounded512(_mm512_mul_pd(len[a], fl)));
        const __mmask8 past = _mm512_cmp_pd_mask(wrapped, len[a], _CMP_GE_OQ);
        xa = _mm512_mask_blend_pd(outside, xa, _mm512_maskz_mov_pd(static_cast<__mmask8>(~past), wrapped));
      }
      const __m512d f = _mm512_maskz_min_pd(all, _mm512_maskz_max_pd(all, _mm512_mul_pd(xa, inv[a]), zero), top[a]);
      k[a] = _mm512_maskz_cvtepi32_pd(all, _mm512_maskz_cvttpd_epi32(all, f));
    }
    __m512d linear = k[0];
    if constexpr (Dim == 2) linear = _mm512_add_pd(k[0], rounded512(_mm512_mul_pd(nx, k[1])));
    if constexpr (Dim == 3)
      linear = _mm512_add_pd(k[0], rounded512(_mm512_mul_pd(nx, _mm512_add_pd(k[1], rounded512(_mm512_mul_pd(ny, k[2]))))));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(cell + i), _mm512_maskz_cvttpd_epi32(all, linear));
  }
  return i;
}

}  // namespace detail

}  // namespace grainbath::dsmc
