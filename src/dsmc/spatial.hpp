#pragma once
// Spatial parts of the DSMC step: free streaming with boundaries, sorting into cells,
// background fields at a grain's position.
#include <cstdint>

#include "dsmc/dsmc.hpp"
#include "dsmc/state.hpp"
#include "operators/background.hpp"

namespace grainbath::dsmc {

inline constexpr std::uint32_t kRemoved = 0xffffffffu;

// Cell of a position (x-fastest linear index). Positions are inside the box.
std::uint32_t cell_index(const Domain& d, double x, double y, double z);

// Streams every particle over dt and applies the face boundaries. Particles leaving through
// open faces are marked (id kept, velocity zeroed) in `removed` and dropped by sort_by_cell.
void stream(State& s, const Config& c, std::uint64_t seed, std::vector<std::uint8_t>& removed);

// Orders particles by (cell, id) and fills s.cell_start; drops removed particles.
void sort_by_cell(State& s, const Config& c, std::vector<std::uint8_t>& removed);

// The medium as seen by a grain at (x, y, z) in cell `cell` (Bisi-Spiga: background
// collisions use the local nB, uB, TB).
BackgroundState local_background(const Config& c, double x, double y, double z, std::uint32_t cell);

}  // namespace grainbath::dsmc
