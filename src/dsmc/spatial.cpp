#include "dsmc/spatial.hpp"

#include <omp.h>

#include <algorithm>
#include <stdexcept>
#include <cmath>
#include <limits>
#include <numbers>

#include "dsmc/cell_order.hpp"
#include "operators/random.hpp"

namespace grainbath::dsmc {

std::uint32_t cell_index(const Domain& d, double x, double y, double z) { return CellGrid(d)(x, y, z); }

namespace {

// Fully periodic box: no wall can be hit, so streaming is x += v dt with a wrap, and the
// new cell index is computed in the same pass while the position is in a register (the
// sort then needs no second pass over the positions).
template <int Dim>
void stream_periodic(State& s, const Config& c) {
  Particles& p = s.particles;
  const std::size_t n = p.size();
  const CellGrid grid(c.domain);
  const double dt = c.dt;
  const double Lx = c.domain.length[0], Ly = c.domain.length[1], Lz = c.domain.length[2];
  std::vector<std::uint32_t>& cell = s.sort.cell;
  cell.resize(n);
  double* __restrict x = p.x.data();
  double* __restrict y = Dim > 1 ? p.y.data() : nullptr;
  double* __restrict z = Dim > 2 ? p.z.data() : nullptr;
  const double* __restrict vx = p.vx.data();
  const double* __restrict vy = p.vy.data();
  const double* __restrict vz = p.vz.data();
  std::uint32_t* __restrict out = cell.data();
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) {
    const double xi = wrap_periodic(x[i] + vx[i] * dt, Lx);
    x[i] = xi;
    double yi = 0.0, zi = 0.0;
    if constexpr (Dim > 1) {
      yi = wrap_periodic(y[i] + vy[i] * dt, Ly);
      y[i] = yi;
    }
    if constexpr (Dim > 2) {
      zi = wrap_periodic(z[i] + vz[i] * dt, Lz);
      z[i] = zi;
    }
    out[i] = grid(xi, yi, zi);
  }
  s.sort.cell_fresh = true;
}

}  // namespace

bool fully_periodic(const Domain& d) {
  bool all_periodic = true;
  for (int f = 0; f < 2 * d.dimensions; ++f) all_periodic = all_periodic && d.faces[f] == Boundary::periodic;
  return all_periodic;
}

void stream(State& s, const Config& c, std::uint64_t seed, std::vector<std::uint8_t>& removed,
            const std::vector<std::size_t>& bounds, std::vector<StreamCounters>& partial) {
  Particles& p = s.particles;
  const Domain& d = c.domain;
  const std::size_t n = p.size();
  partial.clear();
  if (fully_periodic(d)) {
    removed.clear();
    switch (d.dimensions) {
      case 1: stream_periodic<1>(s, c); return;
      case 2: stream_periodic<2>(s, c); return;
      default: stream_periodic<3>(s, c); return;
    }
  }
  s.sort.cell_fresh = false;
  removed.assign(n, 0);
  const double dt = c.dt;
  const double sigma_wall = std::sqrt(d.wall_temperature / c.grains.mass);
  const double m = c.grains.mass;
  const WallAxes axes(d);
  const std::uint64_t step = static_cast<std::uint64_t>(s.step);
  const std::size_t blocks = bounds.size() - 1;
  partial.assign(blocks, StreamCounters{});
#pragma omp parallel for schedule(dynamic, 4)
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t lo = bounds[b], hi = bounds[b + 1];
    StreamCounters& cnt = partial[b];
    struct Sink {
      StreamCounters& cnt;
      void wall(double energy) { cnt.wall_energy += energy; }
      void left(double energy) {
        cnt.removed_energy += energy;
        cnt.removed += 1;
      }
    } sink{cnt};
    for (std::size_t i = lo; i < hi; ++i) {
      double* const pos[3] = {&p.x[i], d.dimensions > 1 ? &p.y[i] : nullptr, d.dimensions > 2 ? &p.z[i] : nullptr};
      double* const vel[3] = {&p.vx[i], &p.vy[i], &p.vz[i]};
      // constructing the generator is free: Philox runs only if a diffuse wall draws from it
      CounterRng rng(seed, Stream::wall_collisions, p.id[i], step);
      if (!stream_through_walls(pos, vel, d, axes, dt, sigma_wall, m, rng, sink)) removed[i] = 1;
    }
  }
}

// Counting sort into cell order, then by id inside each cell.
//
// Thread-count independence: the final order is (cell, global id), a function of the state
// alone; how the counting sort splits the work cannot show in it. The counting sort is
// stable (per-thread counts over static chunks, offsets in (cell, thread) order), so each
// cell receives runs that are already in id order, which the in-cell ranking or merge sort
// finishes (src/dsmc/cell_order.hpp). Then every array is gathered through one scratch buffer. Nothing is
// allocated once the scratch has reached its size.
void sort_by_cell(State& s, const Config& c, std::vector<std::uint8_t>& removed) {
  Particles& p = s.particles;
  const Domain& d = c.domain;
  const std::size_t n = p.size();
  const std::size_t cells = d.cell_count();
  if (n >= kRemoved) throw std::runtime_error("sort_by_cell: more than 2^32 - 1 particles in one process");
  SortScratch& w = s.sort;
  if (!w.cell_fresh) {
    w.cell.resize(n);
    const CellGrid grid(d);
    const bool any_removed = removed.size() == n;
#pragma omp parallel for schedule(static)
    for (std::size_t i = 0; i < n; ++i)
      w.cell[i] = (any_removed && removed[i]) ? kRemoved
                                              : grid(p.x[i], d.dimensions > 1 ? p.y[i] : 0.0, d.dimensions > 2 ? p.z[i] : 0.0);
  }
  w.cell_fresh = false;
  const int max_threads = omp_get_max_threads();
  if (w.counts.size() < static_cast<std::size_t>(max_threads) * cells) w.counts.resize(static_cast<std::size_t>(max_threads) * cells);
  w.perm.resize(n);
  s.cell_start.resize(cells + 1);
  std::size_t* start = s.cell_start.data();
  const std::uint32_t* __restrict cell = w.cell.data();
  std::uint32_t* __restrict perm = w.perm.data();
  const std::uint64_t* __restrict id = p.id.data();
  w.id.resize(n);  // not zero-filled: the scatter writes the kept slots, the rest is cut below
  std::uint64_t* __restrict id_out = w.id.data();
#pragma omp parallel
  {
    const int threads = omp_get_num_threads(), t = omp_get_thread_num();
    const std::size_t lo = n * t / threads, hi = n * (t + 1) / threads;
    std::uint32_t* __restrict cnt = w.counts.data() + static_cast<std::size_t>(t) * cells;
    std::fill(cnt, cnt + cells, 0u);
    for (std::size_t i = lo; i < hi; ++i)
      if (cell[i] != kRemoved) ++cnt[cell[i]];
#pragma omp barrier
#pragma omp single
    counting_sort_offsets(w.counts.data(), threads, cells, start);
    // the id travels with the index, so the in-cell sort reads contiguous keys
    for (std::size_t i = lo; i < hi; ++i)
      if (cell[i] != kRemoved) {
        const std::uint32_t slot = cnt[cell[i]]++;
        perm[slot] = static_cast<std::uint32_t>(i);
        id_out[slot] = id[i];
      }
#pragma omp barrier
    // within a cell, order by global id (reproducibility at any thread or rank count)
#pragma omp for schedule(static)
    for (std::size_t k = 0; k < cells; ++k) order_cell_by_id(perm, id_out, id, start[k], start[k + 1]);
  }
  const std::size_t kept = start[cells];
  w.gather.resize(n);  // not zero-filled: apply() writes the kept slots and cuts the array to them
  double* __restrict buf = w.gather.data();
  auto apply = [&](NoFillVector<double>& arr) {
    if (arr.empty()) return;
    const double* __restrict src = arr.data();
#pragma omp parallel for schedule(static)
    for (std::size_t j = 0; j < kept; ++j) buf[j] = src[perm[j]];
    arr.swap(w.gather);
    arr.resize(kept);
    w.gather.resize(n);
    buf = w.gather.data();
  };
  apply(p.vx);
  apply(p.vy);
  apply(p.vz);
  apply(p.x);
  apply(p.y);
  apply(p.z);
  apply(p.bath_hazard);
  // the ids were written in order by the in-cell sort
  p.id.swap(w.id);
  p.id.resize(kept);
}

double cell_mean_log_background_temperature(const Config& c, std::size_t k) {
  const Domain& d = c.domain;
  const std::size_t nx = d.cells[0], ny = d.cells[1];
  const std::size_t ix = k % nx, iy = (k / nx) % ny, iz = k / (nx * ny);
  const double w = d.cell_size(0), y = (iy + 0.5) * d.cell_size(1), z = (iz + 0.5) * d.cell_size(2);
  const double mB = background_mass(c.background.mass_ratio, c.grains.mass);
  constexpr int kPoints = 64;
  double sum = 0.0;
  for (int q = 0; q < kPoints; ++q) {
    const double x = (ix + (q + 0.5) / kPoints) * w;
    const BackgroundState b = local_background(c, x, y, z, static_cast<std::uint32_t>(k));
    sum += std::log(b.sigma * b.sigma * mB);
  }
  return sum / kPoints;
}

BackgroundState local_background(const Config& c, double x, double y, double z, std::uint32_t cell) {
  const BackgroundParameters& b = c.background;
  double nB = b.density, TB = b.temperature;
  Vec3 uB = b.velocity;
  switch (c.field.profile) {
    case BackgroundProfile::uniform:
      break;
    case BackgroundProfile::isobaric_sine: {
      // TB(x) = TB0 (1 + A sin kx), nB TB = nB0 TB0, uB = 0 (steady Euler: uniform pressure)
      const double k = 2.0 * std::numbers::pi * c.field.wavenumber_index / c.domain.length[0];
      const double f = 1.0 + c.field.amplitude * std::sin(k * x);
      TB = b.temperature * f;
      nB = b.density / f;
      uB = {};
      break;
    }
    case BackgroundProfile::shear: {
      const double k = 2.0 * std::numbers::pi * c.field.wavenumber_index / c.domain.length[1];
      uB = {c.field.amplitude * std::sin(k * y), 0.0, 0.0};
      break;
    }
    case BackgroundProfile::file:
      nB = c.field.grid_density[cell];
      TB = c.field.grid_temperature[cell];
      uB = {c.field.grid_velocity[3 * cell], c.field.grid_velocity[3 * cell + 1], c.field.grid_velocity[3 * cell + 2]};
      break;
  }
  (void)z;
  return BackgroundState::make(nB, b.knudsen, uB, TB, b.mass_ratio, c.grains.mass);
}

}  // namespace grainbath::dsmc
