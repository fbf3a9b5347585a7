#pragma once
// EDMD checkpoints (issue #8): the engine state at a rebuild point (EngineState) and the
// driver's loop state (RunState: phase, measurement accumulators, time series) in one HDF5
// file, through the shared machinery of core/checkpoint.hpp (temporary name, checked close,
// rename, previous kept, checksum, fallback to the previous checkpoint with a warning).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/run_context.hpp"
#include "edmd/engine.hpp"
#include "edmd/measure.hpp"
#include "edmd/profile.hpp"
#include "edmd/transport.hpp"

namespace grainbath::edmd {

// Time series of the measuring phase, one entry per sample interval (temperature and time
// also at the start).
struct Series {
  std::vector<double> time, temperature, z, energy_lost, heating, background, collisions;
  std::vector<double> rotational_temperature;  // rough grains: Trot at the sample times (incl. the start)
};

// Everything the EDMD driver carries across its event loop. A field added here must be
// added to the checkpoint (checkpoint.cpp, arrays_of); a static_assert there checks sizes.
struct RunState {
  enum Phase : std::uint64_t { equilibrating = 0, measuring = 1 };
  std::uint64_t phase = equilibrating;
  std::uint64_t eq_chunk = 1;  // equilibrating: the chunk being run (1..20)
  // set when the equilibration ends
  double rate_eq = 0.0;        // collisions per unit time during the equilibration (0: none)
  double t0 = 0.0;             // engine time at the start of the measurements
  double T0 = 0.0;             // temperature at the end of the equilibration
  double e_initial = 0.0;      // kinetic energy at the start of the measurements
  Vec3 p_initial;              // momentum at the start of the measurements
  Counters c_eq;               // engine counters of the equilibration
  // measuring: state at the last sample
  Counters prev;
  double t_prev = 0.0, T_prev = 0.0;
  std::int64_t sample_no = 0;
  std::uint64_t next_traj = 0;  // collision count of the next trajectory frame
  Series series;
  std::vector<double> traj_pos, traj_time;
  std::vector<std::int64_t> traj_step;
  PairStatistics pairs;
  VelocityHistogram vhist;
  // driving walls: per-interval wall input and collisional loss (energy per time)
  std::vector<double> wall_in_series, loss_series;
  // [profiles]: slab fields (layout from the case; vmax of the tails set when measuring starts)
  SlabProfiles profiles;
  SlabVelocityHistograms tails;
  // [transport] (Bizon Sec. V): slab balances and fluxes; init()-ed from the case before a
  // resume (transport_on), begun when the measurements start
  bool transport_on = false;
  SlabTransport transport;
  double engine_seconds = 0.0;  // wall time spent in the event loop (performance only)
};

// Writes OUT.checkpoints/checkpoint-<total collisions>.h5. `engine` must be at a rebuild point.
void write_checkpoint(const std::filesystem::path& dir, const Engine& engine, const RunState& run,
                      const RunContext& ctx);

// Loads the newest valid checkpoint of `dir` into `engine` (built from the same case) and
// `run` (whose pairs / vhist must be initialised from the case: their bin layout is
// checked). Returns false if there is none; `warning` lists checkpoints skipped as corrupt.
// Throws std::invalid_argument if the case changed in anything but edmd.collisions,
// [checkpoint] and run.threads. `saved_collisions`, if given, receives the edmd.collisions the
// loaded checkpoint was written with (its /parameters; empty if unreadable), for messages.
bool read_newest_checkpoint(const std::filesystem::path& dir, const RunContext& ctx, Engine& engine, RunState& run,
                            std::string& warning, std::string* saved_collisions = nullptr);

// The names of a checkpoint's arrays in list order (with the [transport] arrays or without):
// the order of the file's checksum (core/checkpoint.hpp, Fnv1a), for tests that rewrite a
// checkpoint and reseal it (tests/edmd/restart_test.cpp, tests/checkpoint_tamper.hpp).
std::vector<std::string> checkpoint_array_names(bool transport);

}  // namespace grainbath::edmd
