#pragma once
// Everything a DSMC run carries from step to step. A checkpoint is exactly this struct
// (src/dsmc/checkpoint.cpp): with counter-based random numbers keyed on (seed, id, step),
// restoring it and continuing gives results bitwise identical to an uninterrupted run.
#include <cstdint>
#include <vector>

#include "dsmc/collide.hpp"
#include "dsmc/particles.hpp"

namespace grainbath::dsmc {

struct RunCounters {
  std::uint64_t bath_candidates = 0;
  std::uint64_t bath_collisions = 0;
  double bath_energy = 0.0;         // kinetic energy given to the grains by the medium
  GrainCounters grain;              // grain-grain collisions (energy_loss: dissipated)
  std::uint64_t removed = 0;        // particles that left through open faces
  double wall_energy = 0.0;         // kinetic energy given by diffuse walls
  double removed_energy = 0.0;      // kinetic energy carried out through open faces
};

struct TimeSeries {
  std::vector<double> t, T, a2, velocity, pressure, heat_flux, ke, bath_in, loss, wall_in, removed_out;
  std::vector<double> mode_amplitude;   // spatial runs with a density mode: 2 |<exp(ikx)>|
  std::vector<double> count;            // simulated particles
  std::vector<std::uint64_t> bath_collisions, grain_collisions;
  std::vector<double> Trot;             // rough grains: rotational temperature
  std::vector<double> a3;               // third Sonine coefficient (moments.hpp); NaN for the
                                        // samples of a run resumed from a checkpoint without it
};

// Per-cell sums for time-averaged fields, in batches (for standard errors). Per cell and
// batch: count, sum v (3), sum v_i v_j (6: xx yy zz xy xz yz), sum |v|^2 v (3), sum |v|^2.
// The fields are ratios of the window's totals (src/dsmc/output.cpp); the batches serve the
// standard errors only.
//
// Which batch a sample goes to: the window's samples [first_sample, end_sample) of a segment
// are split evenly over its batches, as sample j -> first_batch + (j - first_sample) batches /
// (end_sample - first_sample). A fresh run has one segment (the whole window, [sampling]
// field_batches batches); a --resume with a later dsmc.t_end appends one for the samples
// added, with batches of about the same length, so the samples already taken keep their
// batches and the extension is sampled too (before 2026-12-05 it was not: the fields stopped
// at the first run's t_end).
struct FieldBatchSegment {
  std::int64_t first_sample = 0, end_sample = 0;
  int first_batch = 0, batches = 0;
};

struct FieldAccumulator {
  static constexpr int kSums = 14;
  int batches = 0;
  std::size_t cells = 0;
  std::int64_t window_samples = 0;        // samples expected in the averaging window
  std::int64_t taken = 0;                 // samples taken so far in the window
  std::vector<double> sums;               // [batch][cell][kSums]
  std::vector<std::int64_t> batch_samples;
  std::vector<FieldBatchSegment> segments;  // in sample order, covering [0, window_samples)

  // the batch of the window's sample j (0 <= j < window_samples)
  int batch_of(std::int64_t j) const {
    for (const FieldBatchSegment& g : segments)
      if (j < g.end_sample)
        return g.first_batch + static_cast<int>((j - g.first_sample) * g.batches / (g.end_sample - g.first_sample));
    return batches - 1;  // not reached: the segments cover the window
  }
};

// What a wall did to one grain in a fused step's streaming (src/dsmc/fused.cpp), logged per
// thread in the order it happened and added to the per-block StreamCounters afterwards in
// particle order, as the separate streaming pass adds them: a diffuse wall's energy input
// (left = 0) or the kinetic energy carried out of an open face (left = 1).
struct WallEvent {
  std::uint32_t index;  // the grain's index in the arrays before the step
  std::uint32_t left;
  double energy;
};

// Work arrays of the cell sort (src/dsmc/spatial.cpp), kept between steps so the hot loop
// allocates nothing: 24 bytes per particle (cell index, permutation, one gather buffer,
// the ids in the new order), plus per-thread cell counts.
struct SortScratch {
  std::vector<std::uint32_t> cell;        // cell of each particle (kRemoved: left the box)
  bool cell_fresh = false;                // `cell` was filled by the streaming pass
  std::vector<std::uint32_t> perm;        // new slot -> old index
  NoFillVector<double> gather;            // one array at a time is gathered through this (no zero fill)
  NoFillVector<std::uint64_t> id;         // ids in the new order (swapped with Particles::id; no zero fill)
  std::vector<std::uint32_t> counts;      // [thread][cell] counting-sort offsets
  static constexpr std::size_t bytes_per_particle = 2 * sizeof(std::uint32_t) + sizeof(double) + sizeof(std::uint64_t);
  // fused step (src/dsmc/fused.cpp): the state before the step, swapped out of
  // Particles so that the gather into cell order writes the new arrays while it reads these
  // (replaces `gather`): x, y, z, vx, vy, vz, bath residual
  NoFillVector<double> previous[7];  // (no zero fill: swapped with Particles' arrays)
  // fused step: the stable counting-sort order (new slot -> old index) and the ids as
  // 32-bit keys in that order (id ^ 2^31), from which each cell is put in id order into
  // `perm` and `id` (order_cell_by_key32, src/dsmc/cell_order.hpp)
  std::vector<std::uint32_t> stable;
  std::vector<std::int32_t> key32;
  // fused step without a bath: the cell of every particle after the next streaming,
  // cell(wrap(x + v dt)) of the state the step leaves, computed per block right after its
  // collisions while the block is in cache (so the next step need not read x and v from
  // memory a second time). Valid for the step `next_cell_step` only, and only while the
  // arrays are those the step left (`next_cell_x`, `next_cell_vx`, size): anything else
  // that reorders the particles swaps or resizes them; nothing else changes x or v between
  // two fused steps without a bath (src/dsmc/driver.cpp), and a restart starts with -1.
  std::vector<std::uint32_t> next_cell;
  std::int64_t next_cell_step = -1;
  const double* next_cell_x = nullptr;
  const double* next_cell_vx = nullptr;
  // fused step, large boxes: the blocks in their tiled order (fused.cpp, fused_step), for
  // `block_order_rows` rows per tile and `block_order_plane` cells per z plane; built once
  // (the grid does not change within a run), empty while the plain order is used
  std::vector<std::uint32_t> block_order;
  std::size_t block_order_rows = 0, block_order_plane = 0;
  // fused step, boxes with walls: per thread, the wall events of its grains (WallEvent)
  std::vector<std::vector<WallEvent>> wall_events;
  // fused step: each thread's share of the blocks loop, adapted every step to the threads'
  // measured speeds (fused.cpp, block_split); the results do not depend on it. Not part of a
  // checkpoint: a restart starts from equal shares.
  std::vector<double> block_share;
  static constexpr std::size_t fused_bytes_per_particle = 5 * sizeof(std::uint32_t) + 7 * sizeof(double) + sizeof(std::uint64_t);
};

struct State {
  Particles particles;
  std::int64_t step = 0;
  // runs with a medium: the second bath half-substep of step `step - 1` has not been applied
  // yet (it is joined to the first half of the next step, src/dsmc/driver.cpp); false at
  // every sampled step and at the end of the run
  bool bath_half_pending = false;
  std::vector<double> remainder;          // NTC fractional candidates, per cell
  RunCounters counters;
  TimeSeries series;
  FieldAccumulator fields;
  double initial_kinetic_energy = 0.0;   // rough grains: translational + rotational
  std::vector<double> wx, wy, wz;         // rough grains: spins a*omega (velocity units), as the particles
  // scratch (rebuilt every step, not checkpointed)
  std::vector<std::size_t> cell_start;    // cell c holds [cell_start[c], cell_start[c+1])
  SortScratch sort;                        // buffers of sort_by_cell, kept to avoid allocation
  double particle_steps_run = 0.0;         // particle-steps advanced by this process (performance.*)
  std::uint64_t collisions_before_run = 0; // bath + grain collisions already counted when it started
};

}  // namespace grainbath::dsmc
