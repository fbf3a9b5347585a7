#pragma once
// Velocity moments of the grain population (Issue #2 sampling list). Sums are taken in
// fixed blocks and combined in block order, so the result does not depend on the number
// of threads.
#include <array>
#include <cstddef>
#include <vector>

#include "dsmc/particles.hpp"

namespace grainbath::dsmc {

struct Moments {
  double count = 0;                 // number of particles
  Vec3 mean_velocity;               // u
  double temperature = 0;           // T = m <|c|^2> / 3
  double a2 = 0;                    // <c^4> / (15 (T/m)^2) - 1
  double a3 = 0;                    // 1 + 3 a2 - <c^6> / (105 (T/m)^3) (docs/closures.md eq. H2)
  std::array<double, 6> pressure{}; // P_ij / n = m <c_i c_j>: xx yy zz xy xz yz
  Vec3 heat_flux;                   // q / n = (m/2) <|c|^2 c>
  double kinetic_energy = 0;        // total (1/2) m sum |v|^2 (simulated particles)
};

// Moments of particles [begin, end), velocities relative to their own mean.
Moments measure_moments(const Particles& p, std::size_t begin, std::size_t end, double mass);

// The two passes behind measure_moments, per block [bounds[b], bounds[b+1]) of particle
// indices, for callers that hold only some of the blocks (MPI ranks: each rank sums its
// own blocks, the partials of all ranks are then added in global block order, so the
// moments are the same at any rank count; src/dsmc/decomposition.hpp). measure_moments is
// these with blocks of 4096 particles.
struct RawMomentSums {
  double count = 0;  // particles in the block (an integer, exact in a double)
  double v[3] = {0, 0, 0};
  double e = 0;      // sum |v|^2
};
struct CentralMomentSums {
  double c2 = 0, c4 = 0, c6 = 0;
  double p[6] = {0, 0, 0, 0, 0, 0};
  double q[3] = {0, 0, 0};
};
void raw_moment_sums(const Particles& p, const std::vector<std::size_t>& bounds, std::vector<RawMomentSums>& out);
// The sums of one block continued with particles [lo, hi): a block split between ranks is
// summed by its ranks in turn, each going on from the sums of the ones before, which adds
// in the same order as one process (raw_moment_sums and central_moment_sums are these).
void add_raw_moment_sums(const Particles& p, std::size_t lo, std::size_t hi, RawMomentSums& s);
void add_central_moment_sums(const Particles& p, std::size_t lo, std::size_t hi, const Vec3& mean_velocity,
                             CentralMomentSums& s);
void central_moment_sums(const Particles& p, const std::vector<std::size_t>& bounds, const Vec3& mean_velocity,
                         std::vector<CentralMomentSums>& out);
// From the partials of every block, in block order: count, mean velocity and kinetic
// energy (first pass) ...
Moments moments_from_raw(const std::vector<RawMomentSums>& raw, double mass);
// ... then temperature, a2, a3, pressure and heat flux (second pass) into m.
void finish_moments(const std::vector<CentralMomentSums>& central, double mass, Moments& m);

}  // namespace grainbath::dsmc
