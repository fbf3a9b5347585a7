#pragma once
// Spatial parts of the DSMC step: free streaming with boundaries, sorting into cells,
// background fields at a grain's position.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "dsmc/dsmc.hpp"
#include "dsmc/state.hpp"
#include "operators/background.hpp"
#include "operators/random.hpp"

namespace grainbath::dsmc {

inline constexpr std::uint32_t kRemoved = 0xffffffffu;
// The fused step in a box with walls (src/dsmc/fused.cpp) marks a grain that met a wall in
// the step (streamed already, in place) by this bit of its cell index and of its old index
// in the sort's order; the bits below it are the index.
inline constexpr std::uint32_t kStreamedBit = 0x80000000u, kIndexMask = 0x7fffffffu;

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

// The walled axes of a box (an axis is periodic on both faces or on neither: config.cpp)
// and the one test of whether a free flight crosses a wall: the axis's position after the
// flight, x + v t (the streaming expression, no FMA), lies below 0 or at or above L. The
// separate streaming pass (stream_through_walls) and the fused step's routing
// (src/dsmc/fused.cpp) use this same test, so a grain that crosses no wall in a step ends at
// x + v dt on both paths, bit for bit.
struct WallAxes {
  bool walled[3] = {false, false, false};
  double length[3] = {1.0, 1.0, 1.0};
  int dimensions = 0;
  explicit WallAxes(const Domain& d) : dimensions(d.dimensions) {
    for (int a = 0; a < d.dimensions; ++a) {
      walled[a] = d.faces[2 * a] != Boundary::periodic;
      length[a] = d.length[a];
    }
  }
  bool any() const { return walled[0] || walled[1] || walled[2]; }
  bool crosses(int a, double x_after) const { return walled[a] && (x_after < 0.0 || x_after >= length[a]); }
};

// Diffuse re-emission from a wall at temperature Tw: tangential components Gaussian, the
// normal one from the flux-weighted half-Maxwellian, |v_n| = sqrt(-2 (Tw/m) log U).
inline double diffuse_normal_speed(CounterRng& rng, double sigma) {
  return sigma * std::sqrt(-2.0 * std::log(rng.uniform()));
}

// One grain's free flight over dt in a box with walls: it flies to the first wall it
// crosses (WallAxes::crosses on the remaining time), is placed exactly on it and takes the
// face's rule (specular: the normal velocity reversed; diffuse: re-emitted from a
// Maxwellian wall at sigma_wall^2 = Tw/m, flux-weighted normal component; open: it leaves),
// then flies on for the rest of dt. Periodic axes are wrapped at the end; a walled axis
// keeps a position in [0, L] (a grain that ends on the wall at L stays there: CellGrid puts
// it in the last cell). `rng` is the grain's stream for this step (Stream::wall_collisions,
// its id, the step), so the draws do not depend on the order grains are streamed in.
// The sink receives, in the order they happen, sink.wall(energy gained from a diffuse
// wall) and sink.left(kinetic energy carried out of an open face); it returns false when
// the grain left. Shared by the separate streaming pass and the fused step, so both give
// the same bits and add the same wall energies in the same order.
template <class Sink>
inline bool stream_through_walls(double* const pos[3], double* const vel[3], const Domain& d, const WallAxes& axes,
                                 double dt, double sigma_wall, double mass, CounterRng& rng, Sink&& sink) {
  double remaining = dt;
  for (int guard = 0; guard < 1000 && remaining > 0; ++guard) {
    double t_hit = remaining;
    int axis_hit = -1, face_hit = -1;
    for (int a = 0; a < d.dimensions; ++a) {
      const double v = *vel[a];
      if (v == 0 || !axes.crosses(a, *pos[a] + v * remaining)) continue;
      // the time to the face, within [0, remaining] (the division may round past either end)
      const double t = std::min(remaining, std::max(0.0, ((v < 0 ? 0.0 : d.length[a]) - *pos[a]) / v));
      if (axis_hit < 0 || t < t_hit) {
        t_hit = t;
        axis_hit = a;
        face_hit = v < 0 ? 2 * a : 2 * a + 1;
      }
    }
    for (int a = 0; a < d.dimensions; ++a) *pos[a] += *vel[a] * t_hit;
    remaining -= t_hit;
    if (axis_hit < 0) break;
    *pos[axis_hit] = (face_hit % 2 == 0) ? 0.0 : d.length[axis_hit];  // exactly on the wall
    const Boundary rule = d.faces[face_hit];
    if (rule == Boundary::specular) {
      *vel[axis_hit] = -*vel[axis_hit];
    } else if (rule == Boundary::diffuse) {
      const double e0 = *vel[0] * *vel[0] + *vel[1] * *vel[1] + *vel[2] * *vel[2];
      for (int a = 0; a < 3; ++a) *vel[a] = sigma_wall * rng.normal();
      const double vn = diffuse_normal_speed(rng, sigma_wall);
      *vel[axis_hit] = (face_hit % 2 == 0) ? vn : -vn;
      const double e1 = *vel[0] * *vel[0] + *vel[1] * *vel[1] + *vel[2] * *vel[2];
      sink.wall(0.5 * mass * (e1 - e0));
    } else {  // open: the grain leaves the box
      sink.left(0.5 * mass * (*vel[0] * *vel[0] + *vel[1] * *vel[1] + *vel[2] * *vel[2]));
      return false;
    }
  }
  for (int a = 0; a < d.dimensions; ++a)
    if (!axes.walled[a]) *pos[a] = wrap_periodic(*pos[a], d.length[a]);
  return true;
}

// Streams every particle over dt and applies the face boundaries. Particles leaving through
// open faces are marked in `removed` (their state as it was where they left) and dropped by sort_by_cell.
// Wall exchanges are counted per reduction block ([bounds[b], bounds[b+1]) in particle
// index, src/dsmc/decomposition.hpp) into `partial`, which the caller adds in block order
// (nothing is counted in a fully periodic box).
void stream(State& s, const Config& c, std::uint64_t seed, std::vector<std::uint8_t>& removed,
            const std::vector<std::size_t>& bounds, std::vector<StreamCounters>& partial);

// Orders particles by (cell, id) and fills s.cell_start; drops removed particles.
void sort_by_cell(State& s, const Config& c, std::vector<std::uint8_t>& removed);

// The medium as seen by a grain at (x, y, z) in cell `cell` (Bisi-Spiga: background
// collisions use the local nB, uB, TB). `cell` is read only for a medium given per cell
// ([field] profile = "file"); the analytic profiles use the position.
BackgroundState local_background(const Config& c, double x, double y, double z, std::uint32_t cell);

// <ln TB> over cell k's extent along x (the midpoint rule on 64 sub-intervals), for a
// background that varies along x only (isobaric_sine), at the cell's centre in y and z.
// What the profile exponent fits n_cell against (src/dsmc/output.cpp): a cell's grain count is
// the integral of n ~ TB^-p over the cell, and ln <TB^-p> = -p <ln TB> + O(w^2 Var) while
// ln TB at the centre misses the curvature of ln TB at O(w^2) itself.
double cell_mean_log_background_temperature(const Config& c, std::size_t k);

}  // namespace grainbath::dsmc
