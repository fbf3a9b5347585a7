#pragma once
// DSMC of grains in a background medium (Bisi-Spiga kinetic equation, eq. 7):
//   df/dt + v.grad f = (1/eps) J_EL(f) + J_IN(f, f).
// Scaled units: lengths in grain-grain mean free paths (both cross-sections 1), grain mass
// m, temperatures in energy units (k_B = 1), velocities in sqrt(energy/mass), time in
// length/velocity.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/case_file.hpp"
#include "core/physics_config.hpp"
#include "core/run_context.hpp"
#include "core/summary.hpp"
#include "operators/restitution.hpp"

namespace grainbath::dsmc {

struct GrainParameters {
  double density = 1.0;      // n, grains per unit volume
  double mass = 1.0;         // m
  double temperature = 1.0;  // initial T
  Vec3 drift;                // initial mean velocity
};

struct Config {
  GrainParameters grains;
  BackgroundParameters background;
  RestitutionLaw restitution;
  std::int64_t particles = 100000;  // simulated grains
  double dt = 0.01;
  double t_end = 10.0;
  std::int64_t steps = 0;           // resolved: ceil(t_end / dt)
  double sample_every = 0.1;
  std::int64_t sample_every_steps = 0;  // resolved
  double steady_from = 0.0;         // start of the averaging window
  int histogram_bins = 100;
  double histogram_range = 6.0;     // |c| / sqrt(T/m) range of the f(v) histogram
  bool relaxation_theory = false;   // also integrate the closures on the DSMC time grid
};

Config read_config(CaseReader& reader);
void run(const Config&, const RunContext& ctx, Summary& summary);
// Dotted keys for `grainbath theory` and the summary's `theory` block.
std::vector<std::pair<std::string, double>> theory_values(const Config&);

}  // namespace grainbath::dsmc
