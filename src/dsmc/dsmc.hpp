#pragma once
// DSMC of grains in a background medium (Bisi-Spiga kinetic equation, eq. 7):
//   df/dt + v.grad f = (1/eps) J_EL(f) + J_IN(f, f).
// Scaled units: lengths in grain-grain mean free paths (both cross-sections 1), grain mass
// m, temperatures in energy units (k_B = 1), velocities in sqrt(energy/mass), time in
// length/velocity. Homogeneous runs have no [domain] section (one cell, no positions);
// spatial runs have 1-3 dimensional boxes of cells (velocities always 3D).
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
#include "operators/restitution.hpp"

namespace grainbath::dsmc {

enum class Boundary { periodic, specular, diffuse, open };
const char* to_string(Boundary);

struct Domain {
  int dimensions = 0;                       // 0: homogeneous (no positions)
  std::array<double, 3> length{1, 1, 1};    // box lengths (unused axes: 1)
  std::array<int, 3> cells{1, 1, 1};        // cells per axis (unused axes: 1)
  std::array<Boundary, 6> faces{};          // x-lo, x-hi, y-lo, y-hi, z-lo, z-hi
  double wall_temperature = 1.0;            // diffuse walls
  std::size_t cell_count() const { return std::size_t(cells[0]) * cells[1] * cells[2]; }
  double volume() const { return length[0] * length[1] * length[2]; }
  double cell_volume() const { return volume() / static_cast<double>(cell_count()); }
  double cell_size(int axis) const { return length[axis] / cells[axis]; }
};

enum class BackgroundProfile { uniform, isobaric_sine, shear, file };
struct BackgroundField {
  BackgroundProfile profile = BackgroundProfile::uniform;
  double amplitude = 0.0;      // isobaric_sine: A in TB0 (1 + A sin kx); shear: U0 in U0 sin(k y)
  int wavenumber_index = 1;    // k = 2 pi index / length (x for isobaric_sine, y for shear)
  std::string file;            // profile = "file": HDF5 grid with density, temperature, velocity
  std::vector<double> grid_density, grid_temperature, grid_velocity;  // per cell (velocity: 3 per cell)
};

enum class GrainProfile { uniform, mode };

struct GrainParameters {
  double density = 1.0;      // n (mean), grains per unit volume
  double mass = 1.0;         // m
  double temperature = 1.0;  // initial T
  Vec3 drift;                // initial mean velocity
  GrainProfile profile = GrainProfile::uniform;
  double amplitude = 0.0;    // mode: n0 (1 + A cos kx)
  int wavenumber_index = 1;  // k = 2 pi index / length_x
};

// [checkpoint] (core/checkpoint.hpp); `every` is simulated time here.
using grainbath::CheckpointSettings;

struct Config {
  GrainParameters grains;
  BackgroundParameters background;
  BackgroundField field;
  Domain domain;
  RestitutionLaw restitution;
  // [restitution] law = "walton": rough grains with spin, homogeneous runs only (replaces
  // `restitution`; src/dsmc/rough.hpp, docs/rough.md sec. 7)
  std::optional<RoughParameters> rough;
  CheckpointSettings checkpoint;
  std::int64_t particles = 100000;  // simulated grains
  double dt = 0.01;
  double t_end = 10.0;
  std::int64_t steps = 0;           // resolved: ceil(t_end / dt)
  double sample_every = 0.1;
  std::int64_t sample_every_steps = 0;  // resolved
  // the state after `step` steps is sampled: every sample_every_steps and at the end (the
  // driver's samples, the field window, and where the bath halves must not be joined)
  bool sampled_after(std::int64_t step) const { return step % sample_every_steps == 0 || step == steps; }
  double steady_from = 0.0;         // start of the averaging window
  int histogram_bins = 100;
  double histogram_range = 6.0;     // |c| / sqrt(T/m) range of the f(v) histogram
  bool relaxation_theory = true;    // also integrate the closures on the DSMC time grid
  bool sample_fields = true;        // per-cell time-averaged fields (spatial runs)
  int field_batches = 16;           // batches for the per-cell standard errors
  double mode_fit_from = 0.0;       // density-mode decay fit window start
  double mode_fit_to = 0.0;         // ... and end (0: t_end)
  // homogeneous runs: grains per collision group, dealt afresh every step (0: all grains in
  // one cell; src/dsmc/collision_groups.hpp, docs/dsmc.md "Collision groups")
  std::int64_t collision_group = 4096;
  // grain-grain NTC bound: kept above every pair's |g| through the step's collisions (true,
  // `[dsmc] bound = "exact"`), or Bird's start-of-step bound, raised only when a drawn pair
  // exceeds it ("bird"; docs/dsmc.md "Grain-grain collisions")
  bool exact_bound = true;
  std::int64_t rebalance_every = 50;  // MPI: steps between load balances of the cell ranges (0: never)
  bool spatial() const { return domain.dimensions > 0; }
  double wavenumber() const;        // k of the grain mode (2 pi index / Lx)
};

Config read_config(CaseReader& reader);
void run(const Config&, const RunContext& ctx, Summary& summary);
// Dotted keys for `grainbath theory` and the summary's `theory` block.
std::vector<std::pair<std::string, double>> theory_values(const Config&);
const std::vector<ModelDescription>& dsmc_models();

}  // namespace grainbath::dsmc
