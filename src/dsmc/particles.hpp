#pragma once
// DSMC particle storage: structure of arrays, one entry per simulated grain, with a stable
// global id that keys its random-number stream (operators/random.hpp). Positions are
// present only for spatial runs. Kept in cell order by the spatial driver.
#include <cstdint>
#include <vector>

#include "core/no_fill_vector.hpp"
#include "operators/vec3.hpp"

namespace grainbath::dsmc {

struct Particles {
  // resize() does not zero-fill (core/no_fill_vector.hpp): whoever grows them writes them
  NoFillVector<double> vx, vy, vz;
  NoFillVector<double> x, y, z;  // empty for homogeneous runs
  NoFillVector<std::uint64_t> id;
  // runs with a medium: the unit-exponential residual of each grain's background candidate
  // process, carried from one bath substep to the next (operators/background.hpp)
  NoFillVector<double> bath_hazard;

  std::size_t size() const { return id.size(); }
  // Stored state per particle: velocities (3 doubles), positions (one per dimension; none
  // for homogeneous runs), the id, and with a medium the bath residual. 56 bytes in 3D.
  static constexpr std::size_t bytes_per_particle(int dimensions, bool bath = false) {
    return (3 + static_cast<std::size_t>(dimensions) + (bath ? 1 : 0)) * sizeof(double) + sizeof(std::uint64_t);
  }
  Vec3 velocity(std::size_t i) const { return {vx[i], vy[i], vz[i]}; }
  void set_velocity(std::size_t i, const Vec3& v) {
    vx[i] = v.x;
    vy[i] = v.y;
    vz[i] = v.z;
  }
  void resize(std::size_t n, bool with_positions) {
    vx.resize(n);
    vy.resize(n);
    vz.resize(n);
    id.resize(n);
    if (with_positions) {
      x.resize(n);
      y.resize(n);
      z.resize(n);
    }
  }
};

}  // namespace grainbath::dsmc
