#include "dsmc/fused.hpp"

#include <omp.h>

#include <algorithm>
#include <cstdlib>
#include <stdexcept>

#include "dsmc/cell_order.hpp"
#include "dsmc/spatial.hpp"
#include "operators/random.hpp"

namespace grainbath::dsmc {

bool fused_step_applies(const Config& c) {
  if (!c.spatial()) return false;
  for (int f = 0; f < 2 * c.domain.dimensions; ++f)
    if (c.domain.faces[f] != Boundary::periodic) return false;
  return std::getenv("GRAINBATH_DSMC_UNFUSED") == nullptr;
}

namespace {

constexpr std::size_t kPrefetch = 48;

template <int Dim, class Law>
void fused_step(State& s, const Config& c, const Law& law, std::uint64_t seed, std::vector<GrainCounters>& per_block,
                std::size_t kCellBlock) {
  Particles& p = s.particles;
  const std::size_t n = p.size(), cells = c.domain.cell_count();
  if (n >= kRemoved) throw std::runtime_error("fused_periodic_step: more than 2^32 - 1 particles in one process");
  SortScratch& w = s.sort;
  std::vector<double>().swap(w.gather);  // not used here
  w.records.resize(n);
  w.id.resize(n);
  w.cell.resize(n);
  w.perm.resize(n);
  const bool hazard = !p.bath_hazard.empty();
  const int max_threads = omp_get_max_threads();
  if (w.counts.size() < static_cast<std::size_t>(max_threads) * cells) w.counts.resize(static_cast<std::size_t>(max_threads) * cells);
  s.cell_start.resize(cells + 1);
  const std::size_t blocks = (cells + kCellBlock - 1) / kCellBlock;
  per_block.assign(blocks, GrainCounters{});

  const CellGrid grid(c.domain);
  const double dt = c.dt, Lx = c.domain.length[0], Ly = c.domain.length[1], Lz = c.domain.length[2];
  // as in the driver's grain_step: the cell's simulated density
  const double weight = c.grains.density * c.domain.volume() / static_cast<double>(c.particles);
  const double cell_volume = c.domain.cell_volume();
  const auto step = static_cast<std::uint64_t>(s.step);
  std::size_t* start = s.cell_start.data();
  SortScratch::Record* __restrict rec = w.records.data();
  std::uint32_t* __restrict cell = w.cell.data();
  std::uint32_t* __restrict perm = w.perm.data();
  std::uint32_t* counts = w.counts.data();
  double* __restrict x = p.x.data();
  double* __restrict y = Dim > 1 ? p.y.data() : nullptr;
  double* __restrict z = Dim > 2 ? p.z.data() : nullptr;
  double* __restrict vx = p.vx.data();
  double* __restrict vy = p.vy.data();
  double* __restrict vz = p.vz.data();
  double* __restrict hz = hazard ? p.bath_hazard.data() : nullptr;
  const std::uint64_t* __restrict id = p.id.data();
  std::uint64_t* __restrict id_out = w.id.data();
#pragma omp parallel
  {
    const int threads = omp_get_num_threads(), t = omp_get_thread_num();
    const std::size_t lo = n * t / threads, hi = n * (t + 1) / threads;
    std::uint32_t* __restrict cnt = counts + static_cast<std::size_t>(t) * cells;
    std::fill(cnt, cnt + cells, 0u);
    // stream, wrap, cell index and count in one pass; the streamed state goes to the records
    for (std::size_t i = lo; i < hi; ++i) {
      double* r = rec[i].v;
      const double xi = wrap_periodic(x[i] + vx[i] * dt, Lx);
      double yi = 0.0, zi = 0.0;
      r[0] = xi;
      if constexpr (Dim > 1) r[1] = yi = wrap_periodic(y[i] + vy[i] * dt, Ly);
      if constexpr (Dim > 2) r[2] = zi = wrap_periodic(z[i] + vz[i] * dt, Lz);
      r[Dim] = vx[i];
      r[Dim + 1] = vy[i];
      r[Dim + 2] = vz[i];
      if (hazard) r[Dim + 3] = hz[i];
      const std::uint32_t k = grid(xi, yi, zi);
      cell[i] = k;
      ++cnt[k];
    }
#pragma omp barrier
#pragma omp single
    counting_sort_offsets(counts, threads, cells, start);
    // scatter: the id travels with the index, so the in-cell order reads contiguous keys
    for (std::size_t i = lo; i < hi; ++i) {
      const std::uint32_t slot = cnt[cell[i]]++;
      perm[slot] = static_cast<std::uint32_t>(i);
      id_out[slot] = id[i];
    }
#pragma omp barrier
    // per block of cells: order each cell by id, gather the block from the records into the
    // state arrays in the new order, then collide in each cell while the block is in L2
#pragma omp for schedule(static)
    for (std::size_t blk = 0; blk < blocks; ++blk) {
      GrainCounters counters;
      const std::size_t k0 = blk * kCellBlock, k1 = std::min(cells, (blk + 1) * kCellBlock);
      for (std::size_t k = k0; k < k1; ++k) order_cell_by_id(perm, id_out, id, start[k], start[k + 1]);
      const std::size_t j1 = start[k1];
      for (std::size_t j = start[k0]; j < j1; ++j) {
        // the records are read in an irregular order the hardware prefetcher cannot follow;
        // perm says which line comes next, so ask for it kPrefetch particles ahead
        if (j + kPrefetch < n) __builtin_prefetch(&rec[perm[j + kPrefetch]]);
        const double* r = rec[perm[j]].v;
        x[j] = r[0];
        if constexpr (Dim > 1) y[j] = r[1];
        if constexpr (Dim > 2) z[j] = r[2];
        vx[j] = r[Dim];
        vy[j] = r[Dim + 1];
        vz[j] = r[Dim + 2];
        if (hazard) hz[j] = r[Dim + 3];
      }
      for (std::size_t k = k0; k < k1; ++k) {
        const std::size_t b0 = start[k], b1 = start[k + 1];
        if (b1 - b0 < 2) continue;
        const double density = static_cast<double>(b1 - b0) * weight / cell_volume;
        CounterRng rng(seed, Stream::grain_collisions, k, step);
        collide_cell(p, b0, b1, density, dt, c.grains.mass, law, rng, s.remainder[k], counters);
      }
      per_block[blk] = counters;
    }
  }
  p.id.swap(w.id);
  w.cell_fresh = false;
}

}  // namespace

void fused_periodic_step(State& s, const Config& c, std::uint64_t seed, std::vector<GrainCounters>& per_block,
                         std::size_t block_cells) {
  std::visit(
      [&](const auto& law) {
        switch (c.domain.dimensions) {
          case 1: fused_step<1>(s, c, law, seed, per_block, block_cells); break;
          case 2: fused_step<2>(s, c, law, seed, per_block, block_cells); break;
          default: fused_step<3>(s, c, law, seed, per_block, block_cells); break;
        }
      },
      c.restitution);
  for (const auto& g : per_block) s.counters.grain.add(g);
}

}  // namespace grainbath::dsmc
