#include "dsmc/fused.hpp"

#include <emmintrin.h>
#include <immintrin.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <type_traits>

#include "dsmc/cell_order.hpp"
#include "dsmc/decomposition.hpp"
#include "dsmc/spatial.hpp"
#include "operators/random.hpp"

namespace grainbath::dsmc {

bool fused_step_applies(const Config& c) {
  if (!c.spatial()) return false;
  // walls: the grains that met one this step are marked by the top bit of their cell index
  // (kStreamedBit), which the grid's cells must leave free
  if (!fully_periodic(c.domain) && c.domain.cell_count() >= kStreamedBit) return false;
  // and the old indices too (no process can then hold 2^31 grains: the whole population
  // is fewer); larger populations take the separate passes
  if (c.particles >= kStreamedBit) return false;
  return std::getenv("GRAINBATH_DSMC_UNFUSED") == nullptr;
}

namespace {

// the gather asks for the lines of the particle kAhead slots ahead (its old slot is known
// from perm): the far ones (moved across a z face) come from L3
constexpr std::size_t kAhead = 16;
// and, once per 8 slots, the lines of the new arrays kStoreAhead slots ahead of its stores
// into L2 (prefetcht2; the write-allocate reads then hit L2 instead of, likely, waiting for
// DRAM in an L1 miss buffer). DSMC-1 at 1e6: 29.00 -> 28.49 CPU ns per particle-step, faster in 5 of 5
// interleaved pairs; 64 / 256 / 1024 slots ahead 28.56 / 27.78 / 28.30 (medians of 4,
// docs/performance/dsmc1.md, h-dsmc7)
constexpr std::size_t kStoreAhead = 256;

}  // namespace

namespace detail {

// The tiled block order (fused_step) is taken when a z plane of the previous arrays and ids
// (56 B per particle) exceeds 4 MiB (DSMC-1: 1.4 MB at 1e6, plain order; 6.6 MB at 1e7,
// tiled), with tiles whose three-plane window, (tile_rows + 2) rows x 3 planes, is about
// 3 MiB (DSMC-1 at 1e7: 11 rows; 4 to 16 rows measured alike within the noise, 2 rows
// slower: docs/performance/dsmc1.md).
std::size_t fused_tile_rows(std::size_t particles, const std::array<int, 3>& cells) {
  constexpr double kTiledPlaneBytes = 4.0 * 1024 * 1024, kTileWindowBytes = 3.0 * 1024 * 1024;
  const auto ny = static_cast<std::size_t>(cells[1]);
  const double bytes_per_slot =
      56.0 * static_cast<double>(particles) / (static_cast<double>(cells[0]) * cells[1] * cells[2]);
  const double row_bytes = bytes_per_slot * static_cast<double>(cells[0]);
  if (row_bytes * static_cast<double>(ny) <= kTiledPlaneBytes) return ny;
  const auto window_rows = static_cast<std::size_t>(kTileWindowBytes / (3.0 * row_bytes));
  return std::min(ny, window_rows > 4 ? window_rows - 2 : std::size_t{2});
}

}  // namespace detail

namespace {

// The cell index kernels' arguments: positions and velocities to stream over dt, the grid.
detail::StreamCellsArgs stream_cells_args(const CellGrid& grid, const std::array<double, 3>& length, double dt,
                                          const std::array<const double*, 3>& pos,
                                          const std::array<const double*, 3>& vel) {
  return {{pos[0], pos[1], pos[2]},
          {vel[0], vel[1], vel[2]},
          dt,
          {length[0], length[1], length[2]},
          {grid.inv_size[0], grid.inv_size[1], grid.inv_size[2]},
          {static_cast<double>(grid.cells[0]) - 1.0, static_cast<double>(grid.cells[1]) - 1.0,
           static_cast<double>(grid.cells[2]) - 1.0},
          static_cast<double>(grid.cells[0]),
          static_cast<double>(grid.cells[1])};
}

// The previous arrays (x, y, z, vx, vy, vz, bath residual) and the new ones.
struct GatherArrays {
  const double* from[7];
  double* to[7];
};

// Where the gather fetches the previous arrays ahead of its sweep: per chunk of 8 slots
// starting at slot c, one line of each array at c + offset[w] (modulo n: the box is
// periodic), and of the old ids when `id` is set (they are read by the ranking of a later
// block). See fused_step for the offsets of each block order.
struct WindowFetch {
  std::size_t offset[3];
  int count;
  const std::uint64_t* id;
};

// The gather of slots [j0, j1) from the previous arrays, streaming the positions on the way
// (the same expression as the separate-pass streaming). A function with the pointers as
// restrict locals, not a lambda: through a lambda's captures GCC reloads every pointer after
// each store (measured slower, see docs/performance/dsmc1.md). Per chunk of 8 slots the
// window ahead is fetched (WindowFetch); per slot the lines of the particle kAhead slots
// ahead (the last kAhead slots of the block have none: a loop of their own, no test per slot).
// MPI ranks (kArrivals): the grains that arrived from other ranks this step sit at the old
// indices >= `fresh`, already streamed (their owner streamed them before sending): copied as
// they are. So are the grains that met a wall (boxes with walls): their flight was flown by
// stream_through_walls in the streaming pass, and their old index carries kStreamedBit
// (>= fresh). Otherwise (kArrivals = false) the code as before.
template <int Dim, bool kHazard, bool kArrivals = false>
void gather_slots(const GatherArrays& arrays, const std::uint32_t* __restrict perm, std::size_t j0, std::size_t j1,
                  std::size_t n, const WindowFetch& window, double dt, const double* length, std::size_t fresh = 0) {
  const double* __restrict ox = arrays.from[0];
  const double* __restrict oy = arrays.from[1];
  const double* __restrict oz = arrays.from[2];
  const double* __restrict ovx = arrays.from[3];
  const double* __restrict ovy = arrays.from[4];
  const double* __restrict ovz = arrays.from[5];
  const double* __restrict ohz = arrays.from[6];
  double* __restrict x = arrays.to[0];
  double* __restrict y = arrays.to[1];
  double* __restrict z = arrays.to[2];
  double* __restrict vx = arrays.to[3];
  double* __restrict vy = arrays.to[4];
  double* __restrict vz = arrays.to[5];
  double* __restrict hz = arrays.to[6];
  const double Lx = length[0], Ly = length[1], Lz = length[2];
  auto copy = [=](std::size_t j, std::uint32_t i) __attribute__((always_inline)) {
    if (kArrivals && i >= fresh) {
      i &= kIndexMask;  // a grain that met a wall carries kStreamedBit
      x[j] = ox[i];
      if constexpr (Dim > 1) y[j] = oy[i];
      if constexpr (Dim > 2) z[j] = oz[i];
    } else {
      x[j] = wrap_periodic(ox[i] + ovx[i] * dt, Lx);
      if constexpr (Dim > 1) y[j] = wrap_periodic(oy[i] + ovy[i] * dt, Ly);
      if constexpr (Dim > 2) z[j] = wrap_periodic(oz[i] + ovz[i] * dt, Lz);
    }
    vx[j] = ovx[i];
    vy[j] = ovy[i];
    vz[j] = ovz[i];
    if constexpr (kHazard) hz[j] = ohz[i];
  };
  const std::size_t jp = j1 - j0 > kAhead ? j1 - kAhead : j0;
  for (std::size_t j = j0; j < j1;) {
    const std::size_t e = std::min(j1, (j | 7) + 1);  // the end of this chunk of 8
    if ((j & 7) == 0) {
      for (int w = 0; w < window.count; ++w) {
        std::size_t f = j + window.offset[w];
        if (f >= n) f -= n;
        __builtin_prefetch(ox + f);
        if constexpr (Dim > 1) __builtin_prefetch(oy + f);
        if constexpr (Dim > 2) __builtin_prefetch(oz + f);
        __builtin_prefetch(ovx + f);
        __builtin_prefetch(ovy + f);
        __builtin_prefetch(ovz + f);
        if constexpr (kHazard) __builtin_prefetch(ohz + f);
        if (window.id != nullptr) __builtin_prefetch(window.id + f);
      }
    }
    for (const std::size_t ep = std::min(e, jp); j < ep; ++j) {
      const std::uint32_t f = kArrivals ? perm[j + kAhead] & kIndexMask : perm[j + kAhead];
      __builtin_prefetch(ox + f);
      if constexpr (Dim > 1) __builtin_prefetch(oy + f);
      if constexpr (Dim > 2) __builtin_prefetch(oz + f);
      __builtin_prefetch(ovx + f);
      __builtin_prefetch(ovy + f);
      __builtin_prefetch(ovz + f);
      if constexpr (kHazard) __builtin_prefetch(ohz + f);
      copy(j, perm[j]);
    }
    for (; j < e; ++j) copy(j, perm[j]);
  }
}

// The same gather with AVX2, four slots at a time: the four old indices' values are loaded
// one by one into a vector (the loads are random), the positions x + v dt of the four and the
// test 0 <= x < L are computed in vectors and the new arrays stored four slots at a time
// (contiguous). A group with a coordinate to wrap is wrapped in the vector
// (detail::wrap_periodic_avx2, wrap_periodic's operations). Only correctly rounded
// operations (no FMA): bitwise the positions of gather_slots and of the separate-pass
// streaming (DsmcReproducibility compares the fused step, on this path where the CPU has
// AVX2, with the separate passes). The prefetches are those of
// gather_slots (the window ahead once per 8 slots, the lines of the slot kAhead ahead), but
// the window and the new arrays' lines kStoreAhead ahead go to L2 (measured here only).
// the values of four old indices in one vector (lane q from index q)
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d lanes(const double* __restrict a, std::uint32_t i0, std::uint32_t i1,
                                                                 std::uint32_t i2, std::uint32_t i3) {
  return _mm256_set_pd(a[i3], a[i2], a[i1], a[i0]);
}

template <int Dim, bool kHazard, bool kArrivals = false>
[[gnu::target("avx2")]] void gather_slots_avx2(const GatherArrays& arrays, const std::uint32_t* __restrict perm,
                                               std::size_t j0, std::size_t j1, std::size_t n, const WindowFetch& window,
                                               double dt, const double* length, std::size_t fresh = 0) {
  const double* __restrict ox = arrays.from[0];
  const double* __restrict oy = arrays.from[1];
  const double* __restrict oz = arrays.from[2];
  const double* __restrict ovx = arrays.from[3];
  const double* __restrict ovy = arrays.from[4];
  const double* __restrict ovz = arrays.from[5];
  const double* __restrict ohz = arrays.from[6];
  double* __restrict x = arrays.to[0];
  double* __restrict y = arrays.to[1];
  double* __restrict z = arrays.to[2];
  double* __restrict vx = arrays.to[3];
  double* __restrict vy = arrays.to[4];
  double* __restrict vz = arrays.to[5];
  double* __restrict hz = arrays.to[6];
  const double* const from_pos[3] = {ox, oy, oz};
  const double* const from_vel[3] = {ovx, ovy, ovz};
  double* const to_pos[3] = {x, y, z};
  double* const to_vel[3] = {vx, vy, vz};
  const __m256d dt4 = _mm256_set1_pd(dt), zero = _mm256_setzero_pd();
  auto fetch = [&](std::size_t f) __attribute__((always_inline)) {
    __builtin_prefetch(ox + f);
    if constexpr (Dim > 1) __builtin_prefetch(oy + f);
    if constexpr (Dim > 2) __builtin_prefetch(oz + f);
    __builtin_prefetch(ovx + f);
    __builtin_prefetch(ovy + f);
    __builtin_prefetch(ovz + f);
    if constexpr (kHazard) __builtin_prefetch(ohz + f);
  };
  // The window ahead (WindowFetch: `lead` slots ahead in the plain order, two planes ahead in
  // the tiled one) comes from DRAM: fetched into L2 only (prefetcht2), not L1 as the lines of
  // the slot kAhead ahead. (The likely reason, not measurable on the VM without hardware
  // counters: a prefetch into L1 holds an L1 miss buffer for the whole DRAM latency, which
  // the gather's own misses then wait for.) DSMC-1 at 1e6: 30.07 -> 29.11 CPU ns
  // per particle-step, faster in 5 of 6 interleaved pairs (docs/performance/dsmc1.md, h-dsmc7).
  auto fetch_far = [&](std::size_t f) __attribute__((always_inline)) {
    __builtin_prefetch(ox + f, 0, 1);
    if constexpr (Dim > 1) __builtin_prefetch(oy + f, 0, 1);
    if constexpr (Dim > 2) __builtin_prefetch(oz + f, 0, 1);
    __builtin_prefetch(ovx + f, 0, 1);
    __builtin_prefetch(ovy + f, 0, 1);
    __builtin_prefetch(ovz + f, 0, 1);
    if constexpr (kHazard) __builtin_prefetch(ohz + f, 0, 1);
  };
  std::size_t j = j0;
  for (; j + 4 <= j1; j += 4) {
    const std::size_t c8 = (j + 7) & ~std::size_t{7};  // the multiple of 8 in [j, j + 4), if any
    if (c8 < j + 4) {
      for (int w = 0; w < window.count; ++w) {
        std::size_t f = c8 + window.offset[w];
        if (f >= n) f -= n;
        fetch_far(f);
        if (window.id != nullptr) __builtin_prefetch(window.id + f, 0, 1);
      }
      if (c8 + kStoreAhead < n) {
        const std::size_t d = c8 + kStoreAhead;
        __builtin_prefetch(x + d, 1, 1);
        if constexpr (Dim > 1) __builtin_prefetch(y + d, 1, 1);
        if constexpr (Dim > 2) __builtin_prefetch(z + d, 1, 1);
        __builtin_prefetch(vx + d, 1, 1);
        __builtin_prefetch(vy + d, 1, 1);
        __builtin_prefetch(vz + d, 1, 1);
        if constexpr (kHazard) __builtin_prefetch(hz + d, 1, 1);
      }
    }
    for (std::size_t q = 0; q < 4 && j + q + kAhead < j1; ++q)
      fetch(kArrivals ? perm[j + q + kAhead] & kIndexMask : perm[j + q + kAhead]);
    const std::uint32_t i0 = perm[j], i1 = perm[j + 1], i2 = perm[j + 2], i3 = perm[j + 3];
    if constexpr (kArrivals) {
      // a group with a grain that arrived from another rank (already streamed): slot by slot,
      // the others streamed by the scalar expression (bitwise the vector's, see above)
      if (std::max(std::max(i0, i1), std::max(i2, i3)) >= fresh) [[unlikely]] {
        for (std::size_t q = j; q < j + 4; ++q) {
          const std::uint32_t i = perm[q] & kIndexMask;  // (kStreamedBit: met a wall, streamed)
          const bool own = perm[q] < fresh;  // not yet streamed
          x[q] = own ? wrap_periodic(ox[i] + ovx[i] * dt, length[0]) : ox[i];
          if constexpr (Dim > 1) y[q] = own ? wrap_periodic(oy[i] + ovy[i] * dt, length[1]) : oy[i];
          if constexpr (Dim > 2) z[q] = own ? wrap_periodic(oz[i] + ovz[i] * dt, length[2]) : oz[i];
          vx[q] = ovx[i];
          vy[q] = ovy[i];
          vz[q] = ovz[i];
          if constexpr (kHazard) hz[q] = ohz[i];
        }
        continue;
      }
    }
    for (int a = 0; a < 3; ++a) {
      const __m256d v = lanes(from_vel[a], i0, i1, i2, i3);
      _mm256_storeu_pd(to_vel[a] + j, v);
      if (a >= Dim) continue;
      const __m256d p = _mm256_add_pd(lanes(from_pos[a], i0, i1, i2, i3), _mm256_mul_pd(v, dt4));
      const __m256d outside =
          _mm256_or_pd(_mm256_cmp_pd(p, zero, _CMP_LT_OQ), _mm256_cmp_pd(p, _mm256_set1_pd(length[a]), _CMP_GE_OQ));
      if (_mm256_movemask_pd(outside) == 0) [[likely]] {
        _mm256_storeu_pd(to_pos[a] + j, p);
      } else {  // wrap_periodic in the vector (fused.hpp): the same positions
        _mm256_storeu_pd(to_pos[a] + j, detail::wrap_periodic_avx2(p, _mm256_set1_pd(length[a]), outside));
      }
    }
    if constexpr (kHazard) _mm256_storeu_pd(hz + j, lanes(ohz, i0, i1, i2, i3));
  }
  for (; j < j1; ++j) {  // the last 0-3 slots of the block, as gather_slots
    const std::uint32_t i = kArrivals ? perm[j] & kIndexMask : perm[j];
    if (kArrivals && perm[j] >= fresh) {
      x[j] = ox[i];
      if constexpr (Dim > 1) y[j] = oy[i];
      if constexpr (Dim > 2) z[j] = oz[i];
    } else {
      x[j] = wrap_periodic(ox[i] + ovx[i] * dt, length[0]);
      if constexpr (Dim > 1) y[j] = wrap_periodic(oy[i] + ovy[i] * dt, length[1]);
      if constexpr (Dim > 2) z[j] = wrap_periodic(oz[i] + ovz[i] * dt, length[2]);
    }
    vx[j] = ovx[i];
    vy[j] = ovy[i];
    vz[j] = ovz[i];
    if constexpr (kHazard) hz[j] = ohz[i];
  }
}

// The cells [k0, k1) in id order by order_cell_by_key32_avx2 (cell_order.hpp): the ranking
// in eight-lane compares, the same order as order_cell_by_key32.
[[gnu::target("avx2,popcnt")]] void order_cells_by_key32_avx2(const std::uint32_t* __restrict stable,
                                                       const std::int32_t* __restrict key32,
                                                       std::uint32_t* __restrict perm, std::uint64_t* __restrict id_out,
                                                       const std::uint64_t* __restrict id, const std::size_t* start,
                                                       std::size_t k0, std::size_t k1) {
  for (std::size_t k = k0; k < k1; ++k) order_cell_by_key32_avx2(stable, key32, perm, id_out, id, start[k], start[k + 1]);
}

// The same with order_cell_by_key32_avx512 (where Philox4x32Lanes::have_avx512): one path for
// cells of 2..32 keys, no branch on the cell's size.
[[gnu::target("avx512f,popcnt")]] void order_cells_by_key32_avx512(const std::uint32_t* __restrict stable,
                                                                 const std::int32_t* __restrict key32,
                                                                 std::uint32_t* __restrict perm,
                                                                 std::uint64_t* __restrict id_out,
                                                                 const std::uint64_t* __restrict id,
                                                                 const std::size_t* start, std::size_t k0, std::size_t k1) {
  for (std::size_t k = k0; k < k1; ++k) order_cell_by_key32_avx512(stable, key32, perm, id_out, id, start[k], start[k + 1]);
}

// MPI ranks (dec.size() > 1): the rank holds the grains of its cells [cell_lo, cell_hi) and
// the step runs in two parallel regions with the migration between them. The first streams
// and counts as one process does and sets aside the grains whose new cell is another rank's
// (their streamed positions packed by the scalar expression, bitwise the gather's); after
// Decomposition::migrate_records the grains that arrived are appended to the previous
// arrays, already streamed (the gather copies them as they are: kArrivals), and counted; the
// second region scatters, orders, gathers and collides the rank's own blocks only. A cell's
// grains and their order by id are those of one process, so are the random words (keyed by
// cell and step) and the per-block counters (combined in block order by the caller).
template <int Dim, class Law>
void fused_step(State& s, const Config& c, const Law& law, std::uint64_t seed, std::vector<GrainCounters>& per_block,
                Decomposition& dec, std::vector<std::size_t>& bounds, std::vector<StreamCounters>& walls) {
  Particles& p = s.particles;
  const std::size_t kCellBlock = dec.block_cells();
  const bool ranks = dec.size() > 1;
  const std::size_t n0 = p.size(), cells = c.domain.cell_count();
  const auto cell_lo = static_cast<std::uint32_t>(ranks ? dec.first_cell(dec.rank()) : 0);
  const auto cell_hi = static_cast<std::uint32_t>(ranks ? dec.end_cell(dec.rank()) : cells);
  const std::size_t first_blk = ranks ? dec.first_block() : 0;
  // (the old indices leave kStreamedBit free: grains that met a wall carry it)
  if (n0 >= kStreamedBit) throw std::runtime_error("fused_spatial_step: more than 2^31 - 1 particles in one process");
  SortScratch& w = s.sort;
  // Boxes with walls: a grain whose flight x + v dt crosses a wall on some axis
  // (WallAxes::crosses) flies by stream_through_walls in the streaming pass, in place in
  // the previous arrays, and is marked as streamed (kStreamedBit); the gather copies it as it
  // is. Its wall events go to the per-block StreamCounters of the separate pass's blocks
  // (Decomposition::block_bounds of the order before the step), added in particle order.
  const WallAxes axes(c.domain);
  const bool walled = axes.any();
  walls.clear();
  if (walled) {
    dec.block_bounds(s, c, bounds);
    walls.assign(bounds.size() - 1, StreamCounters{});
  }
  NoFillVector<double>().swap(w.gather);  // not used here
  // The cells of this step's streaming, if the previous fused step predicted them
  // (SortScratch::next_cell): it did so for this step number, and the arrays are still the
  // ones it left (no reorder, no resize since). Then the streaming pass below only counts,
  // reading 4 bytes per particle instead of x and v (48 B, from DRAM at 1e6: the arrays
  // are read again by the gather). Without a bath nothing changes x or v between two steps;
  // with one (bath_substep kicks v in place) no prediction is made.
  const bool predicted = w.next_cell_step == s.step && w.next_cell.size() == n0 && w.next_cell_x == p.x.data() &&
                         w.next_cell_vx == p.vx.data();
  // (walls: a predicted cell would not say whether the grain meets a wall)
  const bool predict = !medium_present(c) && !walled;
  if (predicted) w.cell.swap(w.next_cell);
  // the state before the step moves to the scratch arrays; Particles receives the new order
  NoFillVector<double>* state_arrays[7] = {&p.x, &p.y, &p.z, &p.vx, &p.vy, &p.vz, &p.bath_hazard};
  bool active[7] = {};
  // which arrays the grains carry follows from the configuration, not only from emptiness: a
  // rank with no grains may receive some in this step (positions in Dim axes, velocities
  // always, the bath residual iff a medium is present, as in the driver's initial state)
  const bool medium = medium_present(c);
  for (int a = 0; a < 7; ++a) {
    const bool carried = a < 3 ? a < Dim : a < 6 ? true : medium;
    if (!carried && state_arrays[a]->empty()) continue;
    active[a] = true;
    // not zero-filled (core/no_fill_vector.hpp): after the swap Particles holds the unfilled
    // array, and the gather below writes each of its n slots
    w.previous[a].resize(n0);
    state_arrays[a]->swap(w.previous[a]);
  }
  w.cell.resize(n0);
  const bool hazard = active[6];
  const int max_threads = omp_get_max_threads();
  if (w.counts.size() < static_cast<std::size_t>(max_threads) * cells) w.counts.resize(static_cast<std::size_t>(max_threads) * cells);
  s.cell_start.resize(cells + 1);
  const std::size_t blocks = (cells + kCellBlock - 1) / kCellBlock;
  const std::size_t my_blocks = ranks ? dec.end_block() - first_blk : blocks;
  per_block.assign(my_blocks, GrainCounters{});

  const CellGrid grid(c.domain);
  const double dt = c.dt, Lx = c.domain.length[0], Ly = c.domain.length[1], Lz = c.domain.length[2];
  // as in the driver's grain_step: the density of a grain's partners in its cell
  const double weight = c.grains.density * c.domain.volume() / static_cast<double>(c.particles);
  const double cell_volume = c.domain.cell_volume();
  const auto step = static_cast<std::uint64_t>(s.step);
  // The gather below reads the previous arrays at the old index of each particle, which lies
  // near its new index: a particle that moved at most one cell per axis came from a cell at
  // most `reach` cells away (x-fastest numbering), i.e. about reach * n / cells slots. Each
  // line of the previous arrays is therefore read within a window of +-reach cells around
  // the sweep (2.5 MB at 40^3 x 16), which stays in cache; the leading edge of the window is
  // fetched ahead, one line of each array per 8 particles.
  const std::size_t reach = 1 + c.domain.cells[0] * (1 + (Dim > 1 ? c.domain.cells[1] : 0));
  // (MPI ranks: the grains per cell of the rank's own cells)
  const std::size_t span = std::max<std::size_t>(1, cell_hi - cell_lo);
  const std::size_t lead = (reach * n0 + span - 1) / span + 64;
  // The order of the blocks. Each line of the previous arrays is used three times in the
  // sweep, by the new cells of its own z plane and of the planes above and below, i.e. one
  // and two planes of the sweep apart. Where three planes of the previous arrays stay in the
  // last-level cache (DSMC-1 at 1e6: 3 x 1.4 MB with the ids) the plain order of the blocks
  // is best (measured, docs/performance/dsmc1.md). At 1e7 (86^3 cells: 6.6 MB a plane) the
  // second and third uses go back to DRAM, so the blocks are taken in tiles of `tile_rows`
  // rows of cells along y, each tile swept through all z planes: a line is then used again
  // within (tile_rows + 2) rows of three planes (~3 MB), and only the rows on a tile's edges
  // are read twice from memory. The block order changes nothing in the results: a block's
  // cells are ordered, gathered, collided and predicted from its own slots, its counters go
  // to per_block[blk] and are summed in block order (fused_spatial_step), and its random
  // words are keyed by cell and step.
  const std::size_t nx = c.domain.cells[0], ny = Dim > 1 ? c.domain.cells[1] : 1, nz = Dim > 2 ? c.domain.cells[2] : 1;
  const std::size_t plane = nx * ny;
  // (a z plane's bytes: from the whole population's density, also on a rank)
  std::size_t tile_rows = Dim == 3 ? detail::fused_tile_rows(ranks ? static_cast<std::size_t>(c.particles) : n0, c.domain.cells) : ny;
  if (const char* forced = std::getenv("GRAINBATH_DSMC_TILE_ROWS"); forced != nullptr && Dim == 3)
    tile_rows = std::max<std::size_t>(1, std::strtoull(forced, nullptr, 10));  // tests: the tiled order in small boxes
  const bool tiled = tile_rows < ny;
  if (!tiled) {
    w.block_order.clear();
  } else if (w.block_order.size() != blocks || w.block_order_rows != tile_rows || w.block_order_plane != plane) {
    // built once per run (the grid is fixed), not per step
    std::vector<std::pair<std::size_t, std::uint32_t>> keyed(blocks);  // (tile, z, y, x of the first cell), block
    for (std::size_t b = 0; b < blocks; ++b) {
      const std::size_t k = b * kCellBlock, ix = k % nx, iy = (k / nx) % ny, iz = k / plane;
      keyed[b] = {(((iy / tile_rows) * nz + iz) * ny + iy) * nx + ix, static_cast<std::uint32_t>(b)};
    }
    std::sort(keyed.begin(), keyed.end());
    w.block_order.resize(blocks);
    for (std::size_t b = 0; b < blocks; ++b) w.block_order[b] = keyed[b].second;
    w.block_order_rows = tile_rows;
    w.block_order_plane = plane;
  }
  // this rank's blocks in the block order (one process: all of them)
  std::vector<std::uint32_t> my_order;
  if (tiled && ranks) {
    for (std::uint32_t b : w.block_order)
      if (b >= first_blk && b < first_blk + my_blocks) my_order.push_back(b);
  }
  const std::uint32_t* block_order = !tiled ? nullptr : ranks ? my_order.data() : w.block_order.data();
  std::size_t* start = s.cell_start.data();
  std::uint32_t* counts = w.counts.data();
  const double length[3] = {Lx, Ly, Lz};
  const bool avx2 = Philox4x32Lanes::have_avx2();
  // the ranking and the prediction (GRAINBATH_SIMD=avx2 rules it out)
  const bool avx512 = Philox4x32Lanes::have_avx512();
  const bool simd_cells = cells < 0x80000000u;
  // MPI ranks: per thread, the (increasing) indices of the grains that streamed into
  // another rank's cells
  std::vector<std::vector<std::uint32_t>> leavers(ranks ? static_cast<std::size_t>(max_threads) : 0);
  // boxes with walls: per thread, the grains that left through an open face, and those
  // that met a wall and stay (marked kStreamedBit)
  std::vector<std::size_t> gone(static_cast<std::size_t>(max_threads), 0), met_wall(static_cast<std::size_t>(max_threads), 0);
  if (walled && w.wall_events.size() < static_cast<std::size_t>(max_threads))
    w.wall_events.resize(static_cast<std::size_t>(max_threads));
  const double sigma_wall = std::sqrt(c.domain.wall_temperature / c.grains.mass);
  int threads_used = 1;
  {
    std::uint32_t* __restrict cell = w.cell.data();
    // not restrict: a grain that meets a wall is flown in place through these pointers, and
    // the SIMD kernels read the same arrays through stream_args (cell and counts are
    // uint32_t, so the doubles' loads need no restrict to stay out of their way)
    double* const ox = w.previous[0].data();
    double* const oy = Dim > 1 ? w.previous[1].data() : nullptr;
    double* const oz = Dim > 2 ? w.previous[2].data() : nullptr;
    double* const ovx = w.previous[3].data();
    double* const ovy = w.previous[4].data();
    double* const ovz = w.previous[5].data();
    // the cell index kernels' arguments for this step's streaming (previous arrays)
    const detail::StreamCellsArgs stream_args = stream_cells_args(grid, {Lx, Ly, Lz}, dt, {ox, oy, oz}, {ovx, ovy, ovz});
    detail::StreamCellsArgs walled_args = stream_args;
    for (int a = 0; a < 3; ++a) walled_args.walled[a] = axes.walled[a];
#pragma omp parallel
    {
      const int threads = omp_get_num_threads(), t = omp_get_thread_num();
#pragma omp single
      threads_used = threads;
      const std::size_t lo = n0 * t / threads, hi = n0 * (t + 1) / threads;
      std::uint32_t* __restrict cnt = counts + static_cast<std::size_t>(t) * cells;
      std::fill(cnt, cnt + cells, 0u);
      // cell index after streaming, and the counts: reads the state once, writes 4 bytes
      // (the streamed positions are recomputed by the gather, bitwise the same expression)
      auto stream_one = [&](std::size_t i) {
        const double xi = wrap_periodic(ox[i] + ovx[i] * dt, Lx);
        double yi = 0.0, zi = 0.0;
        if constexpr (Dim > 1) yi = wrap_periodic(oy[i] + ovy[i] * dt, Ly);
        if constexpr (Dim > 2) zi = wrap_periodic(oz[i] + ovz[i] * dt, Lz);
        const std::uint32_t k = grid(xi, yi, zi);
        cell[i] = k;
        ++cnt[k];
      };
      // boxes with walls: a grain that crosses a wall flies by stream_through_walls, in place
      // (through the previous arrays' own pointers), with its wall events logged in order
      std::vector<WallEvent>* events = walled ? &w.wall_events[static_cast<std::size_t>(t)] : nullptr;
      if (events != nullptr) events->clear();
      std::size_t& gone_here = gone[static_cast<std::size_t>(t)];
      std::size_t& met_here = met_wall[static_cast<std::size_t>(t)];
      auto stream_one_walled = [&](std::size_t i) {
        bool crosses = axes.crosses(0, ox[i] + ovx[i] * dt);
        if constexpr (Dim > 1) crosses = crosses || axes.crosses(1, oy[i] + ovy[i] * dt);
        if constexpr (Dim > 2) crosses = crosses || axes.crosses(2, oz[i] + ovz[i] * dt);
        if (!crosses) {
          stream_one(i);
          return;
        }
        double* const pos[3] = {ox + i, Dim > 1 ? oy + i : nullptr, Dim > 2 ? oz + i : nullptr};
        double* const vel[3] = {ovx + i, ovy + i, ovz + i};
        struct Sink {
          std::vector<WallEvent>& log;
          std::uint32_t index;
          void wall(double energy) { log.push_back({index, 0, energy}); }
          void left(double energy) { log.push_back({index, 1, energy}); }
        } sink{*events, static_cast<std::uint32_t>(i)};
        CounterRng rng(seed, Stream::wall_collisions, p.id[i], step);
        if (!stream_through_walls(pos, vel, c.domain, axes, dt, sigma_wall, c.grains.mass, rng, sink)) {
          cell[i] = kRemoved;  // left through an open face
          ++gone_here;
          return;
        }
        const std::uint32_t k = grid(*pos[0], Dim > 1 ? *pos[1] : 0.0, Dim > 2 ? *pos[2] : 0.0);
        cell[i] = k | kStreamedBit;
        ++cnt[k];
        ++met_here;
      };
      std::size_t i = lo;
      if (predicted) {
        for (; i < hi; ++i) ++cnt[cell[i]];  // the cells are known: the counts only
      } else if (walled) {
        // the groups inside the box cross no wall: their cells in SIMD as below, the others
        // grain by grain
        i = avx2 ? detail::stream_cells_avx2<Dim, true, true>(walled_args, i, hi, cell, cnt, stream_one_walled)
                 : detail::stream_cells_sse2<Dim>(walled_args, i, hi, cell, cnt, stream_one_walled);
        for (; i < hi; ++i) stream_one_walled(i);
      } else if (simd_cells) {
        // the cells of the groups inside the box in SIMD (detail::stream_cells_*, fused.hpp):
        // AVX2 where the CPU has it, else SSE2; the same cells on both
        i = avx2 ? detail::stream_cells_avx2<Dim>(stream_args, i, hi, cell, cnt, stream_one)
                 : detail::stream_cells_sse2<Dim>(stream_args, i, hi, cell, cnt, stream_one);
      }
      for (; i < hi; ++i) stream_one(i);
      if (ranks) {  // the leavers: not counted here (a pass over the 4-byte cells)
        std::vector<std::uint32_t>& mine = leavers[static_cast<std::size_t>(t)];
        mine.clear();
        const std::uint32_t cell_mask = walled ? kIndexMask : kRemoved;
        for (std::size_t j = lo; j < hi; ++j) {
          if (walled && cell[j] == kRemoved) continue;  // left the box
          const std::uint32_t k = cell[j] & cell_mask;
          if (k < cell_lo || k >= cell_hi) {
            --cnt[k];
            mine.push_back(static_cast<std::uint32_t>(j));
          }
        }
      }
    }
  }
  // the wall events into the blocks' counters, in particle order (the threads' ranges are
  // consecutive), as the separate streaming pass adds them
  std::size_t gone_all = 0, met_all = 0;
  if (walled) {
    std::size_t b = 0;
    for (int t = 0; t < threads_used; ++t) {
      gone_all += gone[static_cast<std::size_t>(t)];
      met_all += met_wall[static_cast<std::size_t>(t)];
      for (const WallEvent& e : w.wall_events[static_cast<std::size_t>(t)]) {
        while (e.index >= bounds[b + 1]) ++b;
        StreamCounters& cnt = walls[b];
        if (e.left != 0) {
          cnt.removed_energy += e.energy;
          cnt.removed += 1;
        } else {
          cnt.wall_energy += e.energy;
        }
      }
    }
  }
  // MPI ranks: the leavers go to their owners (their streamed positions by the scalar
  // expression, bitwise the gather's; a grain that met a wall as it is), the arrivals are appended to the previous arrays
  // (already streamed: indices >= n0) and counted with the last thread's grains
  std::size_t arrived = 0, left = 0;
  if (ranks) {
    const std::size_t width = Decomposition::migrant_width(c);
    std::vector<double> leaving;
    for (const auto& mine : leavers) left += mine.size();
    leaving.reserve(left * width);
    for (const auto& mine : leavers)
      for (std::uint32_t i : mine) {
        const double v[3] = {w.previous[3][i], w.previous[4][i], w.previous[5][i]};
        double r[3] = {w.previous[0][i], 0.0, 0.0};
        if constexpr (Dim > 1) r[1] = w.previous[1][i];
        if constexpr (Dim > 2) r[2] = w.previous[2][i];
        if (!walled || (w.cell[i] & kStreamedBit) == 0)  // (met a wall: streamed already)
          for (int a = 0; a < Dim; ++a) r[a] = wrap_periodic(r[a] + v[a] * dt, length[a]);
        Decomposition::pack_migrant(c, p.id[i], v, r, hazard ? w.previous[6][i] : 0.0, leaving);
        w.cell[i] = kRemoved;  // not scattered here
      }
    const std::vector<double> in = dec.migrate_records(c, leaving, n0 - left - gone_all);
    arrived = in.size() / width;
    const std::size_t total = n0 + arrived;
    if (total >= kStreamedBit) throw std::runtime_error("fused_spatial_step: more than 2^31 - 1 particles in one process");
    for (int a = 0; a < 7; ++a)
      if (active[a]) w.previous[a].resize(total);  // not zero-filled: the arrivals are unpacked below
    p.id.resize(total);
    w.cell.resize(total);
    std::uint32_t* last = counts + static_cast<std::size_t>(threads_used - 1) * cells;
    for (std::size_t j = 0; j < arrived; ++j) {
      const std::size_t i = n0 + j;
      double v[3], r[3], residual;
      Decomposition::unpack_migrant(c, in.data() + j * width, p.id[i], v, r, residual);
      for (int a = 0; a < 3; ++a) w.previous[3 + a][i] = v[a];
      for (int a = 0; a < Dim; ++a) w.previous[a][i] = r[a];
      if (hazard) w.previous[6][i] = residual;
      const std::uint32_t k = grid(r[0], r[1], r[2]);
      w.cell[i] = k;
      ++last[k];
    }
    dec.note_particles(total);
  }
  const std::size_t total = n0 + arrived, n = total - left - gone_all;  // indices of the previous arrays; slots
  for (int a = 0; a < 7; ++a)
    if (active[a]) state_arrays[a]->resize(n);
  w.id.resize(n);  // not zero-filled: the in-cell ordering writes every slot of every cell
  if (predict) w.next_cell.resize(n);
  w.perm.resize(n);
  w.stable.resize(n + kKey32Padding);  // order_cell_by_key32(_avx2) reads up to 7 slots past a cell
  w.key32.resize(n + kKey32Padding);
  std::uint32_t* __restrict cell = w.cell.data();
  std::uint32_t* __restrict next_cell = predict ? w.next_cell.data() : nullptr;
  std::uint32_t* __restrict perm = w.perm.data();
  std::uint32_t* __restrict stable = w.stable.data();
  std::int32_t* __restrict key32 = w.key32.data();
  const double* previous[7] = {};
  for (int a = 0; a < 7; ++a)
    if (active[a]) previous[a] = w.previous[a].data();
  double* __restrict x = p.x.data();
  double* __restrict y = Dim > 1 ? p.y.data() : nullptr;
  double* __restrict z = Dim > 2 ? p.z.data() : nullptr;
  double* __restrict vx = p.vx.data();
  double* __restrict vy = p.vy.data();
  double* __restrict vz = p.vz.data();
  double* __restrict hz = hazard ? p.bath_hazard.data() : nullptr;
  const std::uint64_t* __restrict id = p.id.data();
  std::uint64_t* __restrict id_out = w.id.data();
  const GatherArrays arrays{{previous[0], previous[1], previous[2], previous[3], previous[4], previous[5], previous[6]},
                            {x, y, z, vx, vy, vz, hz}};
  // the cell index kernel's arguments for the prediction of the next step's cells (the new
  // arrays after the collisions)
  const detail::StreamCellsArgs next_args = stream_cells_args(grid, {Lx, Ly, Lz}, dt, {x, y, z}, {vx, vy, vz});
  // the next step's cell of slot j: the streaming pass's expression on the state after the
  // collisions (the next step's previous arrays), so the same cell as that pass would give
  auto predict_one = [&](std::size_t j) {
    const double xj = wrap_periodic(x[j] + vx[j] * dt, Lx);
    double yj = 0.0, zj = 0.0;
    if constexpr (Dim > 1) yj = wrap_periodic(y[j] + vy[j] * dt, Ly);
    if constexpr (Dim > 2) zj = wrap_periodic(z[j] + vz[j] * dt, Lz);
    next_cell[j] = grid(xj, yj, zj);
  };
  const std::size_t fresh = n0;  // previous-array indices from here on arrived already streamed
  const bool with_arrivals = arrived > 0 || met_all > 0;
  // per range: an id of the range's particles has a bit above 31 (then the cells are
  // ordered through the 64-bit ids, order_cell_by_id)
  std::vector<unsigned char> wide_ranges(static_cast<std::size_t>(threads_used), 0);
  // The blocks loop's split: thread u takes the blocks [split[u], split[u + 1]) of the block
  // order, a contiguous range as under schedule(static) (its gather's look-ahead stays in its
  // own cache; dynamic chunks were 8 % slower, docs/performance/dsmc1.md), but sized by the
  // shares of the previous step, which follow the threads' measured speeds: on a VM whose two
  // vCPUs run at different speeds (one 20 % slower at times, docs/performance/dsmc1.md) the
  // equal split waits for the slower thread. A block's results do not depend on the thread
  // that takes it (its counters go to per_block[blk], its random words are keyed by cell and
  // step), so neither do the step's.
  const std::size_t nthreads = static_cast<std::size_t>(threads_used);
  if (w.block_share.size() != nthreads) w.block_share.assign(nthreads, 1.0 / static_cast<double>(nthreads));
  std::vector<std::size_t> split(nthreads + 1, 0);
  {
    double cumulative = 0.0;
    for (std::size_t u = 0; u + 1 < nthreads; ++u) {
      cumulative += w.block_share[u];
      split[u + 1] = std::max(split[u], std::min(my_blocks, static_cast<std::size_t>(std::llround(cumulative * static_cast<double>(my_blocks)))));
    }
    split[nthreads] = my_blocks;
  }
  std::vector<double> block_seconds(nthreads, 0.0);
#pragma omp parallel num_threads(threads_used)
  {
    const int threads = omp_get_num_threads(), t = omp_get_thread_num();
#pragma omp single
    counting_sort_offsets(counts, threads_used, cells, start);
    // The ranges and counts of the first region (the last range also holds the arrivals),
    // each scattered by one thread; a loop in case this region got fewer threads.
    for (int u = t; u < threads_used; u += threads) {
      const std::size_t lo = n0 * u / threads_used, hi = u == threads_used - 1 ? total : n0 * (u + 1) / threads_used;
      std::uint32_t* __restrict cnt = counts + static_cast<std::size_t>(u) * cells;
      // scatter: the id travels with the index as a 32-bit key, so the in-cell order reads
      // contiguous keys (four per SSE2 vector, in place: order_cell_by_key32)
      std::uint64_t any_id = 0;
      // (walls: the cell's kStreamedBit moves to the old index; the loop without walls is
      // compiled as it was, without the masks)
      auto scatter = [&](auto with_walls) __attribute__((always_inline)) {
        constexpr std::uint32_t cell_mask = decltype(with_walls)::value ? kIndexMask : kRemoved;
        for (std::size_t i = lo; i < hi; ++i) {
          // Once per line of the scatter's arrays (16 slots), their lines at the leading edge of
          // its writes into L2 (prefetcht2): a particle moves at most `reach` cells, so the new
          // cells about `lead` slots ahead of i get their first particles now, and those lines
          // come from DRAM. DSMC-1 at 1e6: 27.99 -> 27.07 CPU ns per particle-step, faster in 5
          // of 5 interleaved pairs (docs/performance/dsmc1.md, h-dsmc7).
          if ((i & 15) == 0 && n > 0) {
            const std::size_t f = (i + lead) % n;
            __builtin_prefetch(stable + f, 1, 1);
            __builtin_prefetch(key32 + f, 1, 1);
          }
          if (cell[i] == kRemoved) continue;  // MPI: left for another rank; or out of an open face
          const std::uint32_t k = cell[i] & cell_mask;
          const std::uint32_t slot = cnt[k]++;
          stable[slot] = static_cast<std::uint32_t>(i) | (cell[i] & ~cell_mask);
          const std::uint64_t d = id[i];
          any_id |= d;
          key32[slot] = static_cast<std::int32_t>(static_cast<std::uint32_t>(d) ^ 0x80000000u);
        }
      };
      if (walled)
        scatter(std::true_type{});
      else
        scatter(std::false_type{});
      wide_ranges[static_cast<std::size_t>(u)] = (any_id >> 32) != 0;
    }
#pragma omp barrier
    bool wide = false;
    for (int u = 0; u < threads_used; ++u) wide = wide || wide_ranges[static_cast<std::size_t>(u)] != 0;
    // per block of cells: order each cell by id, gather the block from the previous arrays
    // (streaming it on the way) into the new order, then collide in each cell while the
    // block is in L2
    for (int u = t; u < threads_used; u += threads) {  // (a loop in case this region got fewer threads)
      const double began = omp_get_wtime();
      for (std::size_t ordinal = split[static_cast<std::size_t>(u)]; ordinal < split[static_cast<std::size_t>(u) + 1]; ++ordinal) {
        const std::size_t blk = block_order != nullptr ? block_order[ordinal] : first_blk + ordinal;
        GrainCounters counters;
        const std::size_t k0 = blk * kCellBlock, k1 = std::min(cells, (blk + 1) * kCellBlock);
        // What the gather fetches ahead. Plain order: the leading edge of the window, `lead`
        // slots ahead. Tiled: while a block of row y, plane z is gathered, the rows the tile
        // will need two planes on (old cells of plane z + 2; the new start of a cell stands
        // for its old start, they differ by the net flow across a few faces): row y + 1, and
        // for the blocks of the tile's first row also rows y and y - 1, so that the tile's
        // rows -1 .. tile_rows of plane z + 2 are all fetched during plane z; the old ids
        // with them (the ranking of plane z + 2 reads them). (No grain, as on a rank without
        // any: nothing to fetch.)
        WindowFetch window{{}, 0, nullptr};
        if (n == 0) {
        } else if (tiled) {
          window.id = id;
          auto ahead = [&](std::size_t shift) {
            window.offset[window.count++] = (start[(k0 + shift) % cells] + n - start[k0]) % n;
          };
          ahead(2 * plane + nx);
          if ((k0 / nx) % ny % tile_rows == 0) {
            ahead(2 * plane);
            ahead(2 * plane + cells - nx);
          }
        } else {
          window.offset[window.count++] = lead % n;
        }
        if (!wide) {
          if (avx512)
            order_cells_by_key32_avx512(stable, key32, perm, id_out, id, start, k0, k1);
          else if (avx2)
            order_cells_by_key32_avx2(stable, key32, perm, id_out, id, start, k0, k1);
          else
            for (std::size_t k = k0; k < k1; ++k) order_cell_by_key32(stable, key32, perm, id_out, id, start[k], start[k + 1]);
        } else {
          const std::uint32_t index_mask = walled ? kIndexMask : kRemoved;
          for (std::size_t j = start[k0]; j < start[k1]; ++j) {
            perm[j] = stable[j];
            id_out[j] = id[stable[j] & index_mask];
          }
          for (std::size_t k = k0; k < k1; ++k) order_cell_by_id(perm, id_out, id, start[k], start[k + 1]);
        }
        const std::size_t j0 = start[k0], j1 = start[k1];
        if (with_arrivals) {  // MPI ranks, walls: some old indices >= fresh are copied as they are
          if (avx2) {
            if (hazard)
              gather_slots_avx2<Dim, true, true>(arrays, perm, j0, j1, n, window, dt, length, fresh);
            else
              gather_slots_avx2<Dim, false, true>(arrays, perm, j0, j1, n, window, dt, length, fresh);
          } else if (hazard) {
            gather_slots<Dim, true, true>(arrays, perm, j0, j1, n, window, dt, length, fresh);
          } else {
            gather_slots<Dim, false, true>(arrays, perm, j0, j1, n, window, dt, length, fresh);
          }
        } else if (avx2) {
          if (hazard)
            gather_slots_avx2<Dim, true>(arrays, perm, j0, j1, n, window, dt, length);
          else
            gather_slots_avx2<Dim, false>(arrays, perm, j0, j1, n, window, dt, length);
        } else if (hazard) {
          gather_slots<Dim, true>(arrays, perm, j0, j1, n, window, dt, length);
        } else {
          gather_slots<Dim, false>(arrays, perm, j0, j1, n, window, dt, length);
        }
        for (std::size_t k = k0; k < k1; ++k) {
          const std::size_t b0 = start[k], b1 = start[k + 1];
          if (b1 - b0 < 2) continue;
          const double density = cell_partner_density(b1 - b0, weight, cell_volume);
          CellCollisionRng rng(seed, Stream::grain_collisions, k, step);
          collide_cell(p, b0, b1, density, dt, c.grains.mass, law, rng, s.remainder[k], counters, c.exact_bound);
        }
        if (predict) {  // the block's cells for the next step, while its x and v are in cache
          std::size_t j = start[k0];
          const std::size_t jn = start[k1];
          if (simd_cells && avx512) j = detail::predict_cells_avx512<Dim>(next_args, j, jn, next_cell);
          if (simd_cells)
            j = avx2 ? detail::stream_cells_avx2<Dim, false>(next_args, j, jn, next_cell, nullptr, predict_one)
                     : detail::stream_cells_sse2<Dim, false>(next_args, j, jn, next_cell, nullptr, predict_one);
          for (; j < jn; ++j) predict_one(j);
        }
        per_block[blk - first_blk] = counters;
      }
      block_seconds[static_cast<std::size_t>(u)] = omp_get_wtime() - began;
    }
  }
  // the next step's shares: each thread's speed (blocks per second) in this one, half-way
  // from the old shares to the speeds' (damped: one step's timing is noisy), at least a tenth
  // of the equal share; if a thread had no block or no measurable time, half-way back to
  // equal shares instead (so that a small box's rounding cannot leave a thread idle for good)
  if (nthreads > 1) {
    std::vector<double> speed(nthreads, 0.0);
    double total_speed = 0.0;
    bool measured = true;
    for (std::size_t u = 0; u < nthreads; ++u) {
      const double blocks_u = static_cast<double>(split[u + 1] - split[u]);
      measured = measured && blocks_u > 0 && block_seconds[u] > 0.0;
      speed[u] = measured ? blocks_u / block_seconds[u] : 0.0;
      total_speed += speed[u];
    }
    const double equal = 1.0 / static_cast<double>(nthreads);
    std::vector<double> target(nthreads, equal);
    double off = 0.0;  // the largest move a share would make
    for (std::size_t u = 0; u < nthreads; ++u) {
      if (measured && total_speed > 0.0) target[u] = speed[u] / total_speed;
      off = std::max(off, std::abs(target[u] - w.block_share[u]));
    }
    // (a dead band of 2 % of the blocks: equal threads keep their split from step to step,
    // which keeps each one's blocks, and their lines, in its own cache)
    if (off > 0.02) {
      double sum = 0.0;
      for (std::size_t u = 0; u < nthreads; ++u) {
        w.block_share[u] = std::max(0.1 * equal, 0.5 * w.block_share[u] + 0.5 * target[u]);
        sum += w.block_share[u];
      }
      for (double& share : w.block_share) share /= sum;
    }
  }
  p.id.swap(w.id);
  w.cell_fresh = false;
  w.next_cell_step = predict ? s.step + 1 : -1;
  w.next_cell_x = p.x.data();
  w.next_cell_vx = p.vx.data();
}

}  // namespace

void fused_spatial_step(State& s, const Config& c, std::uint64_t seed, std::vector<GrainCounters>& per_block,
                        Decomposition& dec, std::vector<std::size_t>& bounds, std::vector<StreamCounters>& walls) {
  std::visit(
      [&](const auto& law) {
        switch (c.domain.dimensions) {
          case 1: fused_step<1>(s, c, law, seed, per_block, dec, bounds, walls); break;
          case 2: fused_step<2>(s, c, law, seed, per_block, dec, bounds, walls); break;
          default: fused_step<3>(s, c, law, seed, per_block, dec, bounds, walls); break;
        }
      },
      c.restitution);
  // MPI: every rank's blocks in block order, as grain_step combines them
  dec.combine_in_order(per_block, true);
  dec.add_work(per_block);  // load-balance weights
  for (const auto& g : per_block) s.counters.grain.add(g);
}

}  // namespace grainbath::dsmc
