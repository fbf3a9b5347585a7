#pragma once
// Shared helpers of the transport tests (tests/edmd/transport_test.cpp, transport_long_test.cpp).
#include <cmath>
#include <string>
#include <vector>

#include "edmd/edmd.hpp"
#include "edmd/profile.hpp"
#include "edmd/transport.hpp"
#include "tests/edmd/config_support.hpp"

namespace grainbath::edmd::testing {

inline double comp(const Vec3& v, int d) { return d == 0 ? v.x : d == 1 ? v.y : v.z; }

// 2D disks with Bizon's restitution (eq. 18, e_c = 0.7, v0 = 1) driven by the air table with
// a Sec. V profile; `profile_keys` are the [heating] lines of the profile.
inline std::string air_table_case(int particles, double packing, double temperature, double a0,
                                  const std::string& profile_keys) {
  return "[edmd]\ndimensions = 2\nparticles = " + std::to_string(particles) + "\npacking_fraction = " +
         std::to_string(packing) + "\ntemperature = " + std::to_string(temperature) +
         "\n[restitution]\nlaw = \"bizon\"\ne = 0.7\ncrossover = 1.0\n[heating]\nmodel = \"air_table\"\nrate = 1\n"
         "acceleration = " + std::to_string(a0) + "\naxis = \"y\"\n" + profile_keys;
}

struct MeanErr {
  double mean = 0.0, err = 0.0;
};
MeanErr mean_err(const std::vector<double>& x) {
  double s = 0.0, s2 = 0.0;
  for (double y : x) s += y, s2 += y * y;
  const double n = static_cast<double>(x.size());
  const double m = s / n;
  return {m, std::sqrt(std::max(0.0, s2 / n - m * m) / (n - 1.0))};
}

// A small air-table run with the transport bookkeeping on; `each` sees the engine at every
// synchronised sampling time (before the interval is closed).
struct SmallRun {
  Config c;
  SlabTransport tr;
  int slabs = 16;
  std::vector<double> heating_energy, energy_lost, collisions, time;  // engine counters at begin and end
};
template <class Each>
void run_small(SmallRun& run, double equilibrate, int samples, double coll_per_sample, Each each,
               SlabProfiles* profiles = nullptr) {
  const Config& c = run.c;
  const std::size_t N = static_cast<std::size_t>(c.particles);
  const InitialState init = make_initial_state(c, 3);
  Engine eng(make_setup(c, 3), init.positions, init.velocities);
  const auto law = std::get<BizonRestitution>(c.restitution);
  eng.advance(law, kInf, static_cast<std::uint64_t>(equilibrate * N));
  eng.synchronize();
  const double t_eq = eng.time();
  const double dt = coll_per_sample * N / (2.0 * eng.counters().collisions / t_eq) * 2.0;
  const int comp_ = c.heating.profile == ForcingProfile::shear ? c.heating.bias_component : 0;
  run.tr.init({c.dims, c.box(), c.heating.profile_axis, comp_, run.slabs}, N);
  std::vector<Vec3> x(N), v(N);
  for (std::size_t i = 0; i < N; ++i) x[i] = eng.position(i), v[i] = eng.velocity(i);
  run.tr.begin(x, v);
  eng.set_move_hook(&SlabTransport::move_hook, &run.tr);
  CollisionHookPair both{&SlabTransport::collision_hook, &run.tr, &SlabProfiles::collision_hook, profiles};
  if (profiles) eng.set_collision_hook(&CollisionHookPair::call, &both);
  else eng.set_collision_hook(&SlabTransport::collision_hook, &run.tr);
  run.heating_energy.push_back(eng.counters().heating_energy);
  run.energy_lost.push_back(eng.counters().energy_lost);
  run.collisions.push_back(static_cast<double>(eng.counters().collisions));
  run.time.push_back(eng.time());
  double t_prev = eng.time();
  for (int s = 0; s < samples; ++s) {
    eng.advance(law, t_prev + dt, UINT64_MAX);
    eng.synchronize();
    for (std::size_t i = 0; i < N; ++i) v[i] = eng.velocity(i);
    each(eng);
    run.tr.end_interval(eng.time() - t_prev, v);
    if (profiles) {
      for (std::size_t i = 0; i < N; ++i) x[i] = eng.position(i);
      profiles->add_snapshot(x, v);
      profiles->end_interval(eng.time() - t_prev);
    }
    t_prev = eng.time();
  }
  run.heating_energy.push_back(eng.counters().heating_energy);
  run.energy_lost.push_back(eng.counters().energy_lost);
  run.collisions.push_back(static_cast<double>(eng.counters().collisions));
  run.time.push_back(eng.time());
}


}  // namespace grainbath::edmd::testing
