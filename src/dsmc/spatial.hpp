#pragma once
// Spatial parts of the DSMC step: free streaming with boundaries, sorting into cells,
// background fields at a grain's position.
#include <cmath>
#include <cstdint>

#include "dsmc/dsmc.hpp"
#include "dsmc/state.hpp"
#include "operators/background.hpp"

namespace grainbath::dsmc {

inline constexpr std::uint32_t kRemoved = 0xffffffffu;

// Cell of a position (x-fastest linear index). Positions are inside the box; round-off at
// the upper face is clamped into the last cell.
struct CellGrid {
  double inv_size[3];
  std::uint32_t cells[3];
  explicit CellGrid(const Domain& d) {
    for (int a = 0; a < 3; ++a) {
      cells[a] = static_cast<std::uint32_t>(d.cells[a]);
      inv_size[a] = a < d.dimensions ? d.cells[a] / d.length[a] : 0.0;
    }
  }
  std::uint32_t axis(int a, double x) const {
    const double f = x * inv_size[a];
    if (!(f > 0.0)) return 0;
    const auto k = static_cast<std::uint32_t>(f);
    return k < cells[a] ? k : cells[a] - 1;
  }
  std::uint32_t operator()(double x, double y, double z) const {
    return axis(0, x) + cells[0] * (axis(1, y) + cells[1] * axis(2, z));
  }
};
std::uint32_t cell_index(const Domain& d, double x, double y, double z);

// Periodic image of x in [0, L). Positions move less than a box length per step, so the
// floor is taken only for particles that crossed a face.
inline double wrap_periodic(double x, double L) {
  if (x < 0.0 || x >= L) {
    x -= L * std::floor(x / L);
    if (x >= L) x = 0.0;  // -tiny wraps to L in floating point
  }
  return x;
}

// Energy and particles exchanged with the walls, per reduction block.
struct StreamCounters {
  double wall_energy = 0.0, removed_energy = 0.0;
  std::uint64_t removed = 0;
};
bool fully_periodic(const Domain& d);

// Streams every particle over dt and applies the face boundaries. Particles leaving through
// open faces are marked (id kept, velocity zeroed) in `removed` and dropped by sort_by_cell.
// Wall exchanges are counted per reduction block ([bounds[b], bounds[b+1]) in particle
// index, src/dsmc/decomposition.hpp) into `partial`, which the caller adds in block order
// (nothing is counted in a fully periodic box).
void stream(State& s, const Config& c, std::uint64_t seed, std::vector<std::uint8_t>& removed,
            const std::vector<std::size_t>& bounds, std::vector<StreamCounters>& partial);

// Orders particles by (cell, id) and fills s.cell_start; drops removed particles.
void sort_by_cell(State& s, const Config& c, std::vector<std::uint8_t>& removed);

// The medium as seen by a grain at (x, y, z) in cell `cell` (Bisi-Spiga: background
// collisions use the local nB, uB, TB).
BackgroundState local_background(const Config& c, double x, double y, double z, std::uint32_t cell);

}  // namespace grainbath::dsmc
