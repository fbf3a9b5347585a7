// Rough grains in homogeneous DSMC (src/dsmc/rough.hpp; docs/rough.md sec. 7).
#include "dsmc/rough.hpp"

#include <cmath>
#include <numbers>

#include "closures/closures.hpp"
#include "closures/rough.hpp"
#include "dsmc/collide.hpp"
#include "dsmc/collision_groups.hpp"
#include "operators/walton.hpp"

namespace grainbath::dsmc {

void initialise_spins(State& s, const Config& c, std::uint64_t seed) {
  const std::size_t n = s.particles.size();
  s.wx.assign(n, 0.0);
  s.wy.assign(n, 0.0);
  s.wz.assign(n, 0.0);
  const double Trot = c.rough->rotational_temperature;
  if (Trot > 0.0) {
    double s2 = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      CounterRng rng(seed, Stream::initial_angular_velocities, s.particles.id[i], 0);
      const Vec3 w = rng.normal3();
      s.wx[i] = w.x, s.wy[i] = w.y, s.wz[i] = w.z;
      s2 += norm2(w);
    }
    // Trot = q m <|s|^2> / 3 exactly
    const double scale = std::sqrt(3.0 * Trot * static_cast<double>(n) / (c.rough->q * c.grains.mass * s2));
    for (std::size_t i = 0; i < n; ++i) s.wx[i] *= scale, s.wy[i] *= scale, s.wz[i] *= scale;
  }
  s.initial_kinetic_energy += rotational_energy(s, c);
}

double rotational_energy(const State& s, const Config& c) {
  double s2 = 0.0;
  for (std::size_t i = 0; i < s.wx.size(); ++i) s2 += s.wx[i] * s.wx[i] + s.wy[i] * s.wy[i] + s.wz[i] * s.wz[i];
  return 0.5 * c.rough->q * c.grains.mass * s2;  // sum I |omega|^2 / 2 = q m |s|^2 / 2
}

double rotational_temperature(const State& s, const Config& c) {
  return 2.0 * rotational_energy(s, c) / (3.0 * static_cast<double>(s.wx.size()));
}

namespace {
// The NTC candidate loop of rough grains: `candidates` ordered pairs of distinct slots of
// [0, n32), accepted with |g| / g_max, Walton's rule at each accepted pair; `slot` maps a drawn
// slot to its grain (the identity for the one cell, the tiles for a collision group).
template <class Slot>
void rough_candidates(State& s, const Config& c, Slot slot, std::uint32_t n32, std::uint64_t candidates, double g_max,
                      const BoundReference& ref, CounterRng& rng, GrainCounters& counters) {
  Particles& p = s.particles;
  const RoughParameters& r = *c.rough;
  BoundGuard guard(ref, g_max);  // Walton's rule can speed grains up too (spin into translation)
  const bool exact = c.exact_bound;  // false: Bird's scheme as before 2026-12-05 (collide_candidates)
  for (std::uint64_t k = 0; k < candidates; ++k) {
    const std::uint32_t si = rng.below(n32);
    std::uint32_t sj = rng.below(n32 - 1);
    if (sj >= si) ++sj;
    const std::size_t i = slot(si), j = slot(sj);
    Vec3 v = p.velocity(i), w = p.velocity(j);
    const double gmod = norm(v - w);
    ++counters.candidates;
    if (gmod > g_max) {  // exact: a safety net, as in collide_candidates (collide.hpp); Bird: raise
      if (exact) {
        raise_bound(gmod, k, candidates, g_max, guard, rng, counters);
      } else {
        ++counters.bound_exceeded;
        g_max = gmod;
      }
    } else if (rng.uniform() * g_max >= gmod) {
      continue;
    }
    // n from i to j with g.n >= 0 (Walton's convention, docs/rough.md W1)
    const Vec3 n = apse_direction((1.0 / gmod) * (v - w), rng.unit_vector());
    Vec3 si_spin{s.wx[i], s.wy[i], s.wz[i]}, sj_spin{s.wx[j], s.wy[j], s.wz[j]};
    counters.energy_loss += walton_collision(v, w, si_spin, sj_spin, n, 1.0, r.q, r.law, c.grains.mass).energy_lost;
    p.set_velocity(i, v);
    p.set_velocity(j, w);
    s.wx[i] = si_spin.x, s.wy[i] = si_spin.y, s.wz[i] = si_spin.z;
    s.wx[j] = sj_spin.x, s.wy[j] = sj_spin.y, s.wz[j] = sj_spin.z;
    ++counters.collisions;
    // keep g_max a bound of every pair (BoundGuard, collide.hpp); after the store, unlike the
    // smooth grains' loop: Walton's rule can make the pair's own |g'| exceed |g|
    if (exact && guard.may_exceed(v, w)) {
      guard.cover(v, w);
      const double m2 = max_pair_speed2_with(p.vx.data(), p.vy.data(), p.vz.data(), slot, n32, v, w);
      if (m2 > g_max * g_max) raise_bound(std::sqrt(m2), k, candidates, g_max, guard, rng, counters);
    }
  }
}
}  // namespace

void rough_grain_step(State& s, const Config& c, std::uint64_t seed, CollisionGroups& groups,
                      std::vector<GrainCounters>& per_group) {
  Particles& p = s.particles;
  const std::size_t count = p.size();
  const double density = c.grains.density;
  if (count < 2 || density <= 0.0) return;
  const auto step = static_cast<std::uint64_t>(s.step);
  if (CollisionGroups::apply(count, static_cast<std::size_t>(c.collision_group))) {
    // collision groups (src/dsmc/collision_groups.hpp), as for smooth grains: each group's
    // own generator (seed, Stream::grain_collisions; group, step) and counters, summed in group
    // order; candidates rounded up with the probability of their fraction
    groups.deal(count, static_cast<std::size_t>(c.collision_group), seed, step);
    const std::size_t n_groups = groups.count();
    per_group.assign(n_groups, GrainCounters{});
#pragma omp parallel for schedule(static)
    for (std::size_t g = 0; g < n_groups; ++g) {
      const std::uint32_t* tiles = groups.tiles(g);
      const std::size_t grains = groups.grains(g);
      BoundReference ref;
      const double g_max =
          group_pair_speed_bound(p.vx.data(), p.vy.data(), p.vz.data(), tiles, groups.tile_count(g), grains, &ref);
      if (g_max <= 0.0) continue;
      CounterRng rng(seed, Stream::grain_collisions, g, step);
      const std::uint64_t candidates = group_candidates(grains, density, g_max, c.dt, rng.uniform());
      GrainCounters cnt;
      rough_candidates(s, c, TileSlots{tiles}, static_cast<std::uint32_t>(grains), candidates, g_max, ref, rng, cnt);
      per_group[g] = cnt;
    }
    for (const auto& g : per_group) s.counters.grain.add(g);
    return;
  }
  // one cell (collision_group = 0 or too few grains): the scheme before collision groups, draw for draw
  CounterRng rng(seed, Stream::grain_collisions, 0, step);
  BoundReference ref;
  double g_max = relative_speed_bound(p, 0, count, &ref);
  if (g_max <= 0.0) return;
  // NTC as in collide_cell (collide.hpp): candidates N n g_max dt / 2 + carried fraction
  const double expected = 0.5 * static_cast<double>(count) * density * g_max * c.dt + s.remainder[0];
  const auto candidates = static_cast<std::uint64_t>(expected);
  s.remainder[0] = expected - static_cast<double>(candidates);
  rough_candidates(s, c, [](std::uint32_t sl) { return static_cast<std::size_t>(sl); }, static_cast<std::uint32_t>(count),
                   candidates, g_max, ref, rng, s.counters.grain);
}

closures::rough::Parameters rough_parameters(const Config& c) {
  closures::rough::Parameters p = closures::rough::parameters_of(c.rough->law, c.rough->q, 3);
  p.G = 4.0 * c.grains.density / std::sqrt(std::numbers::pi * c.grains.mass);  // nu = n <|g|> (R1 with cross-section 1)
  return p;
}

std::vector<std::pair<std::string, double>> rough_theory_values(const Config& c) {
  std::vector<std::pair<std::string, double>> out;
  if (c.background.present()) return out;
  const auto series = rough_model_series(c, {0.0, c.t_end}, c.grains.temperature, c.rough->rotational_temperature);
  for (const auto& [name, values] : series) {
    const std::size_t slash = name.find('/');
    out.emplace_back("rough." + name.substr(0, slash) + "." + name.substr(slash + 1) + "_at_t_end", values.back());
  }
  return out;
}

std::vector<std::pair<std::string, std::vector<double>>> rough_model_series(const Config& c, const std::vector<double>& t,
                                                                            double Ttr0, double Trot0) {
  std::vector<std::pair<std::string, std::vector<double>>> out;
  const closures::rough::Parameters p = rough_parameters(c);
  for (auto m : {closures::rough::Model::A, closures::rough::Model::B, closures::rough::Model::C,
                 closures::rough::Model::D, closures::rough::Model::E}) {
    std::vector<closures::rough::Sample> samples;
    try {
      samples = closures::rough::integrate(m, p, Ttr0, Trot0, t);
    } catch (const closures::ClosureError&) {
      continue;  // e.g. a state the model cannot start from: no curve rather than a failed run
    }
    std::vector<double> a, b;
    for (const auto& x : samples) a.push_back(x.Ttr), b.push_back(x.Trot);
    const std::string name = std::string("rough_model_") + closures::rough::to_string(m);
    out.emplace_back(name + "/Ttr", std::move(a));
    out.emplace_back(name + "/Trot", std::move(b));
  }
  return out;
}

}  // namespace grainbath::dsmc
