#pragma once
// The reference of the NTC-bound tests (test_dsmc_ntc_bound.cpp for a cell,
// test_dsmc_collision_groups.cpp for a group): an isolated cell of N elastic grains with zero
// total momentum keeps its energy and momentum, and the pair-exchange dynamics leaves the
// uniform (microcanonical) distribution on that sphere invariant, so its mean collision rate is
// (n / (N - 1)) <sum over pairs |g_ij|> over that distribution, computed here by Monte Carlo
// over Gaussian velocities with the momentum removed and the energy rescaled (which samples
// the uniform distribution on the sphere exactly).
#include <cmath>
#include <cstddef>
#include <vector>

#include "operators/vec3.hpp"
#include "operators/random.hpp"

namespace grainbath::dsmc::testing {

// N velocities with zero total momentum and sum |v|^2 = 3 (N - 1) (temperature 1), in place
inline void to_sphere(std::vector<Vec3>& v) {
  Vec3 mean;
  for (const Vec3& u : v) mean += u;
  mean = (1.0 / static_cast<double>(v.size())) * mean;
  double e = 0.0;
  for (Vec3& u : v) {
    u -= mean;
    e += norm2(u);
  }
  const double s = std::sqrt(3.0 * static_cast<double>(v.size() - 1) / e);
  for (Vec3& u : v) u *= s;
}

inline double pair_speed_sum(const std::vector<Vec3>& v) {
  double sum = 0.0;
  for (std::size_t i = 0; i < v.size(); ++i)
    for (std::size_t j = i + 1; j < v.size(); ++j) sum += norm(v[i] - v[j]);
  return sum;
}

// <sum over pairs |g|> on the sphere of n grains, and its standard error (fixed seed)
inline void microcanonical_pair_speed_sum(std::size_t n, int samples, double& mean, double& se) {
  CounterRng rng(11, Stream::initial_velocities, n, 0);
  std::vector<Vec3> v(n);
  double s1 = 0.0, s2 = 0.0;
  for (int k = 0; k < samples; ++k) {
    for (Vec3& u : v) u = {rng.normal(), rng.normal(), rng.normal()};
    to_sphere(v);
    const double x = pair_speed_sum(v);
    s1 += x;
    s2 += x * x;
  }
  mean = s1 / samples;
  se = std::sqrt((s2 / samples - mean * mean) / samples);
}

}  // namespace grainbath::dsmc::testing
