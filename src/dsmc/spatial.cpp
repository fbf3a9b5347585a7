#include "dsmc/spatial.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "operators/random.hpp"

namespace grainbath::dsmc {

std::uint32_t cell_index(const Domain& d, double x, double y, double z) {
  const double pos[3] = {x, y, z};
  std::uint32_t idx[3] = {0, 0, 0};
  for (int a = 0; a < d.dimensions; ++a) {
    const double f = pos[a] / d.length[a] * d.cells[a];
    idx[a] = static_cast<std::uint32_t>(std::clamp(static_cast<long>(f), 0L, static_cast<long>(d.cells[a] - 1)));
  }
  return idx[0] + static_cast<std::uint32_t>(d.cells[0]) * (idx[1] + static_cast<std::uint32_t>(d.cells[1]) * idx[2]);
}

namespace {

// Diffuse re-emission from a wall at temperature Tw: tangential components Gaussian, the
// normal one from the flux-weighted half-Maxwellian, |v_n| = sqrt(-2 (Tw/m) log U).
double diffuse_normal_speed(CounterRng& rng, double sigma) { return sigma * std::sqrt(-2.0 * std::log(rng.uniform())); }

}  // namespace

void stream(State& s, const Config& c, std::uint64_t seed, std::vector<std::uint8_t>& removed) {
  Particles& p = s.particles;
  const Domain& d = c.domain;
  const std::size_t n = p.size();
  removed.assign(n, 0);
  const double dt = c.dt;
  const double sigma_wall = std::sqrt(d.wall_temperature / c.grains.mass);
  const double m = c.grains.mass;
  const std::uint64_t step = static_cast<std::uint64_t>(s.step);
  constexpr std::size_t kBlock = 4096;
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  std::vector<double> wall_e(blocks, 0.0), removed_e(blocks, 0.0);
  std::vector<std::uint64_t> removed_n(blocks, 0);
#pragma omp parallel for schedule(static)
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t lo = b * kBlock, hi = std::min(n, lo + kBlock);
    for (std::size_t i = lo; i < hi; ++i) {
      double* pos[3] = {&p.x[i], d.dimensions > 1 ? &p.y[i] : nullptr, d.dimensions > 2 ? &p.z[i] : nullptr};
      double* vel[3] = {&p.vx[i], &p.vy[i], &p.vz[i]};
      // constructing the generator is free: Philox runs only if a diffuse wall draws from it
      CounterRng rng(seed, Stream::wall_collisions, p.id[i], step);
      double remaining = dt;
      // advance; on a wall hit (non-periodic face) stop at the wall, apply the rule, continue
      for (int guard = 0; guard < 1000 && remaining > 0; ++guard) {
        double t_hit = remaining;
        int axis_hit = -1, face_hit = -1;
        for (int a = 0; a < d.dimensions; ++a) {
          const double v = *vel[a];
          if (v == 0) continue;
          const double L = d.length[a];
          const double x = *pos[a];
          const int face = v < 0 ? 2 * a : 2 * a + 1;
          if (d.faces[face] == Boundary::periodic) continue;
          const double t = v < 0 ? (0.0 - x) / v : (L - x) / v;
          if (t < t_hit) {
            t_hit = std::max(0.0, t);
            axis_hit = a;
            face_hit = face;
          }
        }
        for (int a = 0; a < d.dimensions; ++a) *pos[a] += *vel[a] * t_hit;
        remaining -= t_hit;
        if (axis_hit < 0) break;
        // place exactly on the wall
        *pos[axis_hit] = (face_hit % 2 == 0) ? 0.0 : d.length[axis_hit];
        const Boundary rule = d.faces[face_hit];
        if (rule == Boundary::specular) {
          *vel[axis_hit] = -*vel[axis_hit];
        } else if (rule == Boundary::diffuse) {
          const double e0 = p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] + p.vz[i] * p.vz[i];
          for (int a = 0; a < 3; ++a) *vel[a] = sigma_wall * rng.normal();
          const double vn = diffuse_normal_speed(rng, sigma_wall);
          *vel[axis_hit] = (face_hit % 2 == 0) ? vn : -vn;
          const double e1 = p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] + p.vz[i] * p.vz[i];
          wall_e[i / kBlock] += 0.5 * m * (e1 - e0);
        } else {  // open: leave the box
          removed[i] = 1;
          removed_e[i / kBlock] += 0.5 * m * (p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] + p.vz[i] * p.vz[i]);
          removed_n[i / kBlock] += 1;
          remaining = 0;
          break;
        }
      }
      // periodic wrap
      for (int a = 0; a < d.dimensions; ++a) {
        const double L = d.length[a];
        double& x = *pos[a];
        if (x < 0.0 || x >= L) {
          x -= L * std::floor(x / L);
          if (x >= L) x = 0.0;  // -tiny wraps to L in floating point
        }
      }
    }
  }
  for (std::size_t b = 0; b < blocks; ++b) {
    s.counters.wall_energy += wall_e[b];
    s.counters.removed_energy += removed_e[b];
    s.counters.removed += removed_n[b];
  }
}

void sort_by_cell(State& s, const Config& c, std::vector<std::uint8_t>& removed) {
  Particles& p = s.particles;
  const Domain& d = c.domain;
  const std::size_t n = p.size();
  const std::size_t cells = d.cell_count();
  std::vector<std::uint32_t> cell(n);
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i)
    cell[i] = (removed.size() == n && removed[i])
                  ? kRemoved
                  : cell_index(d, p.x[i], d.dimensions > 1 ? p.y[i] : 0.0, d.dimensions > 2 ? p.z[i] : 0.0);
  std::vector<std::size_t> start(cells + 1, 0);
  for (std::size_t i = 0; i < n; ++i)
    if (cell[i] != kRemoved) ++start[cell[i] + 1];
  for (std::size_t k = 0; k < cells; ++k) start[k + 1] += start[k];
  const std::size_t kept = start[cells];
  std::vector<std::size_t> perm(kept), fill(start.begin(), start.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    if (cell[i] != kRemoved) perm[fill[cell[i]]++] = i;
  // within a cell, order by global id (reproducibility at any thread or rank count);
  // segments are nearly sorted already, so insertion sort is linear in practice
#pragma omp parallel for schedule(dynamic, 256)
  for (std::size_t k = 0; k < cells; ++k) {
    for (std::size_t a = start[k] + 1; a < start[k + 1]; ++a) {
      const std::size_t v = perm[a];
      std::size_t b = a;
      while (b > start[k] && p.id[perm[b - 1]] > p.id[v]) {
        perm[b] = perm[b - 1];
        --b;
      }
      perm[b] = v;
    }
  }
  auto apply = [&](auto& arr) {
    using T = typename std::decay_t<decltype(arr)>::value_type;
    if (arr.empty()) return;
    std::vector<T> out(kept);
    for (std::size_t j = 0; j < kept; ++j) out[j] = arr[perm[j]];
    arr.swap(out);
  };
  apply(p.vx);
  apply(p.vy);
  apply(p.vz);
  apply(p.x);
  apply(p.y);
  apply(p.z);
  apply(p.id);
  s.cell_start = std::move(start);
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
