#pragma once
// Velocity moments of the grain population (Issue #2 sampling list). Sums are taken in
// fixed blocks and combined in block order, so the result does not depend on the number
// of threads.
#include <array>
#include <cstddef>

#include "dsmc/particles.hpp"

namespace grainbath::dsmc {

struct Moments {
  double count = 0;                 // number of particles
  Vec3 mean_velocity;               // u
  double temperature = 0;           // T = m <|c|^2> / 3
  double a2 = 0;                    // <c^4> / (15 (T/m)^2) - 1
  std::array<double, 6> pressure{}; // P_ij / n = m <c_i c_j>: xx yy zz xy xz yz
  Vec3 heat_flux;                   // q / n = (m/2) <|c|^2 c>
  double kinetic_energy = 0;        // total (1/2) m sum |v|^2 (simulated particles)
};

// Moments of particles [begin, end), velocities relative to their own mean.
Moments measure_moments(const Particles& p, std::size_t begin, std::size_t end, double mass);

}  // namespace grainbath::dsmc
