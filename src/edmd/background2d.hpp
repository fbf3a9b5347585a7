#pragma once
// The background-medium collision for hard DISKS in a 2D Maxwellian bath.
//
// operators/background.hpp is the 3D operator (Bisi-Spiga eqs. 3, 8, 13): partner drawn from
// a 3D Maxwellian, apse direction from the 3D hard-sphere kernel |g.n|/(2 pi |g|) on the
// sphere. For disks moving in a plane that operator cannot be reused as is: it would give
// the grains a z velocity, its mean relative speed is the 3D one, and the 2D hard-disk kernel
// is not the 3D one (in 2D the impact parameter b is uniform on [-sigma, sigma]: the post-
// collision relative velocity is NOT isotropic, the scattering angle chi has density
// sin(chi/2)/2). This header is the same construction one dimension down, with the same
// thinning idea and the same acceptance rule, reusing the shared elastic rule
// elastic_background_collision() (Bisi-Spiga eq. 3) from operators/:
//
//   rate(v) = K Integral |v - w| M_B^{2D}(w) d2w,       K = nB / eps (rate per unit speed)
//   majorant  K (|c| + <|c_w|>),  <|c_w|> = s sqrt(pi/2),  s = sqrt(TB / mB),
//   partner from (|c| + |c_w|) M_B / (|c| + <|c_w|>): with prob |c|/(|c|+<|c_w|>) a plain 2D
//   Maxwellian, else speed-weighted: density ~ s^2 exp(-s^2/2 sigma^2) ds, i.e. the norm of a
//   3D standard normal times sigma, uniform in-plane direction;
//   accept with |g| / (|c| + |c_w|); n = cos(theta) g_hat + sin(theta) g_perp, sin(theta) = b
//   uniform in (-1, 1).
#include <cmath>
#include <numbers>

#include "operators/background.hpp"

namespace grainbath::edmd {

inline double background_mean_speed_2d(const BackgroundState& b) {
  return b.sigma * std::sqrt(std::numbers::pi / 2.0);
}

inline double background_majorant_rate_2d(const Vec3& v, const BackgroundState& b) {
  const Vec3 c = v - b.velocity;
  return b.rate_scale * (std::sqrt(c.x * c.x + c.y * c.y) + background_mean_speed_2d(b));
}

template <class Rng>
inline bool attempt_background_collision_2d(Vec3& v, const BackgroundState& b, double grain_mass,
                                            Rng& rng, double& energy_gain) {
  Vec3 c = v - b.velocity;
  c.z = 0.0;
  const double cmod = norm(c);
  const double mean = background_mean_speed_2d(b);
  Vec3 cw;
  if (rng.uniform() * (cmod + mean) < cmod) {
    cw = {b.sigma * rng.normal(), b.sigma * rng.normal(), 0.0};
  } else {
    const double s = b.sigma * norm(rng.normal3());  // chi with 3 degrees of freedom
    const double phi = 2.0 * std::numbers::pi * rng.uniform();
    cw = {s * std::cos(phi), s * std::sin(phi), 0.0};
  }
  const Vec3 g = c - cw;
  const double gmod = norm(g);
  if (rng.uniform() * (cmod + norm(cw)) >= gmod) return false;  // null collision
  const Vec3 gh = (1.0 / gmod) * g;
  const Vec3 gp{-gh.y, gh.x, 0.0};
  const double sb = 2.0 * rng.uniform() - 1.0;  // impact parameter / sigma
  const Vec3 n = std::sqrt(1.0 - sb * sb) * gh + sb * gp;
  Vec3 w = cw + b.velocity;
  w.z = 0.0;
  energy_gain += elastic_background_collision(v, w, n, b.mass_ratio, grain_mass);
  v.z = 0.0;
  return true;
}

}  // namespace grainbath::edmd
