#pragma once
// EDMD solver entry points for the CLI ([run] solver = "edmd").
// Units: grain diameter sigma = 1, grain mass m = 1, k_B = 1 (temperatures in energy units),
// time in sigma sqrt(m / energy). Packing fraction nu = n pi/4 (2D), phi = n pi/6 (3D).
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/case_file.hpp"
#include "core/checkpoint.hpp"
#include "core/physics_config.hpp"
#include "core/run_context.hpp"
#include "core/summary.hpp"
#include "edmd/engine.hpp"
#include "operators/restitution.hpp"
#include "operators/walton.hpp"

namespace grainbath::edmd {

struct Config {
  int dims = 3;
  std::int64_t particles = 1000;
  double packing_fraction = 0.3;
  double temperature = 1.0;        // initial temperature (and the elastic one)
  double equilibrate = 50.0;       // collisions per particle before measuring
  double collisions = 200.0;       // collisions per particle measured
  std::string initial = "lattice"; // "lattice" (square / simple cubic)
  double contact_time = 0.0;       // TC-model guard (0: off)
  std::array<bool, 3> walls{false, false, false};
  double wall_restitution = 1.0;
  // driving walls (docs/edmd.md "Driving walls"): index 0 = wall at 0, 1 = wall at L
  std::array<double, 2> wall_driving{0.0, 0.0};
  std::array<double, 2> wall_restitution_side{1.0, 1.0};
  bool driving_walls() const { return wall_driving[0] > 0.0 || wall_driving[1] > 0.0 ||
                                      wall_restitution_side[0] != wall_restitution || wall_restitution_side[1] != wall_restitution; }
  Vec3 aspect{1.0, 1.0, 1.0};      // relative edge lengths of the box (volume fixed by N and packing)
  RestitutionLaw restitution = ElasticRestitution{};
  // [restitution] law = "walton": rough grains with spin (docs/rough.md); replaces
  // `restitution` (which then stays elastic and unused)
  // (q default: 1/2 disks in 2D, 2/5 spheres in 3D)
  using Rough = RoughParameters;
  std::optional<Rough> rough;
  BackgroundParameters background;
  Heating heating;
  // [sampling]
  double sample_interval = 1.0;    // collisions per particle between samples
  double gr_max = 5.0;             // g(r) range, sigma
  double gr_bin = 0.02;
  double corr_max = 0.0;           // velocity correlations range (0: L/2, capped by grid)
  double corr_bin = 0.1;           // Bizon: delta r = sigma/10
  double trajectory_interval = 0.0;  // collisions per particle between H5MD frames (0: none)
  bool free_cooling = false;       // record T(t) against Haff's law
  // [profiles] (docs/edmd.md "Slab profiles")
  bool profiles = false;
  int profile_axis = 0;
  int profile_slabs = 20;
  int tail_bins = 400;             // velocity histograms per slab: bins over [-range, range]
  double tail_range = 12.0;        // in units of sqrt(T) at the start of the measurement
  // [transport] (docs/edmd.md "Transport coefficients"): Bizon Sec. V bookkeeping; the
  // experiment follows [heating] profile (tent: conductivity, shear: viscosity)
  bool transport = false;
  int transport_slabs = 32;
  double transport_fit_inner = 0.2, transport_fit_outer = 0.8;
  // [checkpoint]: `every` in collisions per particle (checkpoints at the next scheduled
  // rebuild, every 10 collisions per particle; docs/edmd.md)
  CheckpointSettings checkpoint;
  // derived
  double box_length() const;       // edge of the cube / square of the same volume
  Vec3 box() const;                // edges (aspect applied); z = 1 in 2D
  std::uint64_t seed = 1;  // set by run() from the RunContext
};

Config read_config(CaseReader& reader);
void run(const Config& config, const RunContext& ctx, Summary& summary);
std::vector<std::pair<std::string, double>> theory_values(const Config& config);
const std::vector<ModelDescription>& edmd_models();

// Initial state (also used by tests and the benchmark): lattice positions, Maxwellian
// velocities at `temperature` with zero total momentum, rescaled to exactly that temperature.
struct InitialState {
  std::vector<Vec3> positions, velocities;
  std::vector<Vec3> omega;  // rough grains only (empty otherwise)
};
InitialState make_initial_state(const Config& config, std::uint64_t seed);
EngineSetup make_setup(const Config& config, std::uint64_t seed);

}  // namespace grainbath::edmd
