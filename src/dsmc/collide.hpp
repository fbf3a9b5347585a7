#pragma once
// DSMC collision kernels. Written once, templated on the restitution law (selected by name
// once per step with std::visit, never inside the loop): no virtual call, no allocation,
// no std:: distribution object in the hot loops.
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "dsmc/particles.hpp"
#include "operators/background.hpp"
#include "operators/binary_collision.hpp"
#include "operators/random.hpp"
#include "operators/restitution.hpp"

namespace grainbath::dsmc {

struct GrainCounters {
  std::uint64_t candidates = 0;
  std::uint64_t collisions = 0;
  std::uint64_t clamped = 0;         // power law gave e < 0: clamped to 0
  std::uint64_t bound_exceeded = 0;  // a candidate had g > g_max (bound raised)
  double energy_loss = 0.0;          // kinetic energy dissipated
  void add(const GrainCounters& o) {
    candidates += o.candidates;
    collisions += o.collisions;
    clamped += o.clamped;
    bound_exceeded += o.bound_exceeded;
    energy_loss += o.energy_loss;
  }
};

// Upper bound on |v_i - v_j| in a cell: |c_i - c_j| <= |c_i| + |c_j| <= 2 max|c| with c
// relative to the cell mean. Exact at the start of the substep; post-collision speeds can
// exceed it (|c'| <= 2 max|c|), hence the exceedance check in collide_cell.
inline double relative_speed_bound(const Particles& p, std::size_t begin, std::size_t end) {
  const double inv = 1.0 / static_cast<double>(end - begin);
  double mx = 0, my = 0, mz = 0;
  for (std::size_t i = begin; i < end; ++i) {
    mx += p.vx[i];
    my += p.vy[i];
    mz += p.vz[i];
  }
  mx *= inv;
  my *= inv;
  mz *= inv;
  double c2max = 0;
  for (std::size_t i = begin; i < end; ++i) {
    const double cx = p.vx[i] - mx, cy = p.vy[i] - my, cz = p.vz[i] - mz;
    c2max = std::max(c2max, cx * cx + cy * cy + cz * cz);
  }
  return 2.0 * std::sqrt(c2max);
}

// Grain-grain collisions among the particles [begin, end) of one cell over a time dt
// (Bird's no-time-counter scheme). Each grain meets the others at rate n |g| (Issue #2
// scaled units): with N simulated grains standing for density n, a pair collides at rate
// (n / (N - 1)) |g|, so each grain sees exactly n <|g|> over its N - 1 partners. Candidates
// per step: N (N - 1)/2 * n/(N - 1) * g_max dt = N n g_max dt / 2, accepted with |g|/g_max.
// `remainder` carries the fractional candidate across steps (part of the checkpoint).
template <class Law>
inline void collide_cell(Particles& p, std::size_t begin, std::size_t end, double density, double dt,
                         double mass, const Law& law, CounterRng& rng, double& remainder,
                         GrainCounters& counters) {
  const std::size_t count = end - begin;
  if (count < 2 || density <= 0.0) return;
  if (count > 0xffffffffu) throw std::length_error("collide_cell: more than 2^32 - 1 grains in one cell");
  double g_max = relative_speed_bound(p, begin, end);
  if (g_max <= 0.0) return;
  const double expected = 0.5 * static_cast<double>(count) * density * g_max * dt + remainder;
  const auto candidates = static_cast<std::uint64_t>(expected);
  remainder = expected - static_cast<double>(candidates);
  // an ordered pair of distinct grains, uniformly: i from [0, N), j from the other N - 1
  // (exact integer draws from 32-bit halves of the Philox words, CounterRng::below)
  const auto n32 = static_cast<std::uint32_t>(count);
  double* __restrict vx = p.vx.data() + begin;
  double* __restrict vy = p.vy.data() + begin;
  double* __restrict vz = p.vz.data() + begin;
  for (std::uint64_t k = 0; k < candidates; ++k) {
    const std::uint32_t i = rng.below(n32);
    std::uint32_t j = rng.below(n32 - 1);
    if (j >= i) ++j;
    Vec3 v{vx[i], vy[i], vz[i]}, w{vx[j], vy[j], vz[j]};
    const Vec3 g = v - w;
    const double g2 = norm2(g);
    ++counters.candidates;
    if (g2 > g_max * g_max) {  // bound exceeded: accept, and raise the bound for the rest of the step
      ++counters.bound_exceeded;
      g_max = std::sqrt(g2);
    } else {
      // accept with |g| / g_max, compared on squares (both sides >= 0): no square root for
      // the rejected candidates
      const double u = rng.uniform() * g_max;
      if (u * u >= g2) continue;
    }
    const double gmod = std::sqrt(g2);
    const Vec3 n = apse_direction((1.0 / gmod) * g, rng.unit_vector());
    const RestitutionOutcome r = restitution(law, dot(g, n));
    counters.clamped += r.clamped;
    counters.energy_loss += inelastic_collision(v, w, n, r.e, mass);
    vx[i] = v.x;
    vy[i] = v.y;
    vz[i] = v.z;
    vx[j] = w.x;
    vy[j] = w.y;
    vz[j] = w.z;
    ++counters.collisions;
  }
}

}  // namespace grainbath::dsmc
