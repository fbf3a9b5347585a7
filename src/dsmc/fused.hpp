#pragma once
// The DSMC step of a fully periodic box in one parallel region (Issue #7 performance):
// streaming, cell index and counting-sort counts in one pass over the particles, the
// scatter, then per cell the order by id, the gather into the new order and the grain-grain
// collisions while the cell is in L1. The same particle order, random streams and counter
// sums as stream + sort_by_cell + the per-cell collisions, hence bitwise the same results.
#include <cstdint>
#include <vector>

#include "dsmc/collide.hpp"
#include "dsmc/dsmc.hpp"
#include "dsmc/state.hpp"

namespace grainbath::dsmc {

// True for spatial runs whose faces are all periodic, unless the environment variable
// GRAINBATH_DSMC_UNFUSED is set (the separate passes, for comparisons and tests).
bool fused_step_applies(const Config& c);

// Streams over dt, orders by (cell, id), fills s.cell_start and collides in every cell;
// `per_block` receives the counters of each block of `block_cells` cells (summed in block
// order: the decomposition's reduction blocks, fixed by the case, so the sums are the same
// at any thread or rank count).
void fused_periodic_step(State& s, const Config& c, std::uint64_t seed, std::vector<GrainCounters>& per_block,
                         std::size_t block_cells);

}  // namespace grainbath::dsmc
