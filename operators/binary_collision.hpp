#pragma once
// Grain-grain hard-sphere collision rules, shared by DSMC and EDMD.
#include <cmath>

#include "operators/vec3.hpp"

namespace grainbath {

// Apse direction with density |g.n| / (2 pi |g|) on the unit sphere (Bisi-Spiga eq. 13
// kernel), drawn from one uniform direction r: for elastic hard spheres the post-collision
// relative velocity g' = g - 2 (g.n) n is isotropic, so n is parallel to g - g' =
// |g| (g_hat - r). Returns n with g.n >= 0. No basis construction, no rejection.
// Verified against the target density in tests/operators.
inline Vec3 apse_direction(const Vec3& g_hat, const Vec3& r) {
  Vec3 d = g_hat - r;
  const double len2 = norm2(d);
  if (len2 < 1e-300) return g_hat;  // r == g_hat: head-on, measure zero
  return (1.0 / std::sqrt(len2)) * d;
}

// Bisi-Spiga eq. 6 (equal masses): the normal relative velocity is reversed and scaled by
// e, the tangential one and the centre-of-mass velocity are kept. Returns the kinetic
// energy lost, (m/4)(1 - e^2)(g.n)^2, for the energy budget.
inline double inelastic_collision(Vec3& v, Vec3& w, const Vec3& n, double e, double mass) {
  const double gn = dot(v - w, n);
  const Vec3 dv = (0.5 * (1.0 + e) * gn) * n;
  v -= dv;
  w += dv;
  return 0.25 * mass * (1.0 - e * e) * gn * gn;
}

}  // namespace grainbath
