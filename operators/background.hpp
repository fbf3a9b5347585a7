#pragma once
// The linear elastic background operator (Bisi-Spiga eqs. 3, 8, 13): hard-sphere collisions
// of a grain (mass m) with field particles (mass mB) drawn from a Maxwellian of density nB,
// drift uB, temperature TB. Shared by DSMC (a time interval per grain) and EDMD (Poisson
// events in the calendar). Knows nothing of either engine.
//
// Collision rate of a grain of velocity v (scaled units, cross-section 1, Issue #2):
//     nu(v) = (nB / eps) * Integral |v - w| M_B(w) d3w .
// Exact sampling by thinning with a per-grain majorant that uses the partner's speed:
//     |v - w| <= |c| + |c_w|,   c = v - uB,  c_w = w - uB,
// so candidates arrive at rate K (|c| + <|c_w|>), K = nB/eps, with the partner drawn from
// the mixture density (|c| + |c_w|) M_B(w) / (|c| + <|c_w|>), and are accepted with
// probability |v - w| / (|c| + |c_w|) <= 1. No fixed g_max that could be exceeded.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

#include "operators/binary_collision.hpp"
#include "operators/vec3.hpp"

namespace grainbath {

// Background mass from the mass ratio alpha = mB / (m + mB) (Bisi-Spiga eq. 2).
inline double background_mass(double mass_ratio, double grain_mass) {
  return mass_ratio * grain_mass / (1.0 - mass_ratio);
}

// Local state of the medium as a grain sees it. `rate_scale` is nB/eps.
struct BackgroundState {
  double rate_scale = 0.0;   // nB / eps
  Vec3 velocity;             // uB
  double sigma = 1.0;        // sqrt(TB / mB): Maxwellian width per component
  double mean_speed = 0.0;   // <|w - uB|> = sigma sqrt(8/pi)
  double mass_ratio = 0.5;   // alpha

  static BackgroundState make(double density, double knudsen, Vec3 velocity, double temperature,
                              double mass_ratio, double grain_mass) {
    BackgroundState b;
    b.rate_scale = density / knudsen;
    b.velocity = velocity;
    b.sigma = std::sqrt(temperature / background_mass(mass_ratio, grain_mass));
    b.mean_speed = b.sigma * std::sqrt(8.0 / std::numbers::pi);
    b.mass_ratio = mass_ratio;
    return b;
  }
};

// Candidate (majorant) rate for a grain of velocity v.
inline double background_majorant_rate(const Vec3& v, const BackgroundState& b) {
  return b.rate_scale * (norm(v - b.velocity) + b.mean_speed);
}

// v' = v - 2 alpha (g.n) n  (Bisi-Spiga eq. 3). Returns the grain's kinetic-energy change.
inline double elastic_background_collision(Vec3& v, const Vec3& w, const Vec3& n, double alpha,
                                           double grain_mass) {
  const double e0 = norm2(v);
  v -= (2.0 * alpha * dot(v - w, n)) * n;
  return 0.5 * grain_mass * (norm2(v) - e0);
}

// Draws a partner from the majorant mixture and accepts it with |g| / (|c| + |c_w|), for a
// grain with c = v - uB and cmod = |c| already known. On acceptance applies the collision
// and returns true. `energy_gain` accumulates the grain's kinetic-energy change (bath input
// for the energy budget). Normals come from the ziggurat (no logarithm on the fast path).
template <class Rng>
inline bool attempt_background_collision(Vec3& v, const Vec3& c, double cmod, const BackgroundState& b,
                                         double grain_mass, Rng& rng, double& energy_gain) {
  Vec3 cw;
  double cw_mod;
  if (rng.uniform() * (cmod + b.mean_speed) < cmod) {
    cw = b.sigma * Vec3{rng.normal_ziggurat(), rng.normal_ziggurat(), rng.normal_ziggurat()};  // Maxwellian partner
    cw_mod = norm(cw);
  } else {
    // Speed-weighted Maxwellian |c_w| M_B: the speed has density ~ s^3 exp(-s^2 / 2 sigma^2),
    // a chi distribution with 4 degrees of freedom, so s = sigma |z| for z standard normal
    // in 4D; the direction of the first three components of z is isotropic and independent
    // of |z| (the 3D direction is independent of the 3D length and of z4), so
    // c_w = sigma |z| z_(1..3) / |z_(1..3)|.
    const double z1 = rng.normal_ziggurat(), z2 = rng.normal_ziggurat(), z3 = rng.normal_ziggurat();
    const double z4 = rng.normal_ziggurat();
    const double s3 = z1 * z1 + z2 * z2 + z3 * z3, s4 = s3 + z4 * z4;
    cw = (b.sigma * std::sqrt(s4 / s3)) * Vec3{z1, z2, z3};
    cw_mod = b.sigma * std::sqrt(s4);
  }
  const Vec3 g = c - cw;
  const double gmod = norm(g);
  if (rng.uniform() * (cmod + cw_mod) >= gmod) return false;  // null collision
  const Vec3 n = apse_direction((1.0 / gmod) * g, rng.unit_vector());
  energy_gain += elastic_background_collision(v, cw + b.velocity, n, b.mass_ratio, grain_mass);
  return true;
}

template <class Rng>
inline bool attempt_background_collision(Vec3& v, const BackgroundState& b, double grain_mass, Rng& rng,
                                         double& energy_gain) {
  const Vec3 c = v - b.velocity;
  return attempt_background_collision(v, c, norm(c), b, grain_mass, rng, energy_gain);
}

struct BackgroundCounters {
  std::uint64_t candidates = 0;
  std::uint64_t collisions = 0;
  double energy_gain = 0.0;  // kinetic energy given to the grains by the bath
};

// One thinning test of the DSMC bath kernel: the same candidate law and acceptance as
// attempt_background_collision (partner from (|c| + |c_w|) M_B / (|c| + <|c_w|>), accepted
// with |g| / (|c| + |c_w|)), arranged for speed (Issue #7), all exact:
//  - the partner always takes four normals z: the Maxwellian component is sigma z_(1..3),
//    the speed-weighted one sigma |z| z_(1..3) / |z_(1..3)|; one of the two is selected
//    without a branch (the 50/50 branch was mispredicted half the time, which cost more
//    than the fourth normal);
//  - acceptance is tested on squares, u^2 (|c| + |c_w|)^2 < |g|^2 (both sides >= 0), so
//    |g| is taken only for accepted candidates;
//  - with the apse n = (g_hat - r) / |g_hat - r| of apse_direction, (g.n) n = (g - |g| r)/2
//    exactly (g.n = |g| (1 - g_hat.r) / |g_hat - r| and |g_hat - r|^2 = 2 (1 - g_hat.r)),
//    so Bisi-Spiga eq. 3 becomes v' = v - alpha (g - |g| r): no apse normalisation;
//  - c = v - uB and |c| are updated here on acceptance and reused after a rejection.
template <class Rng>
inline bool background_test(Vec3& v, Vec3& c, double& cmod, const BackgroundState& b, double grain_mass, Rng& rng,
                            double& energy_gain) {
  const bool maxwellian = rng.uniform() * (cmod + b.mean_speed) < cmod;
  const double z1 = rng.normal_ziggurat(), z2 = rng.normal_ziggurat(), z3 = rng.normal_ziggurat();
  const double z4 = rng.normal_ziggurat();
  const double s3 = z1 * z1 + z2 * z2 + z3 * z3, s4 = s3 + z4 * z4;
  const double a3 = std::sqrt(s3), a4 = std::sqrt(s4);
  const double scale = maxwellian ? b.sigma : b.sigma * (a4 / a3);
  const double cw_mod = b.sigma * (maxwellian ? a3 : a4);
  const Vec3 g = c - scale * Vec3{z1, z2, z3};
  const double g2 = norm2(g);
  const double u = rng.uniform() * (cmod + cw_mod);
  if (u * u >= g2) return false;  // null collision
  const Vec3 r = rng.unit_vector();
  const double e0 = norm2(v);
  v -= b.mass_ratio * (g - std::sqrt(g2) * r);
  energy_gain += 0.5 * grain_mass * (norm2(v) - e0);
  c = v - b.velocity;
  cmod = norm(c);
  return true;
}

// Evolves one grain's velocity through `duration` of background collisions only (the
// operator-split bath substep of the DSMC), continuing the grain's candidate process from
// `hazard`: the unit-exponential amount of integrated majorant rate left before its next
// candidate. Candidates are the points where the integrated rate Integral K(|c(t)| + <|c_w|>) dt
// reaches successive unit exponentials (time-change of a unit Poisson process), so the
// residual can be carried across substeps, grain-grain collisions and restarts: it is part
// of the grain's state. Exact in distribution; the majorant changes only at accepted events.
template <class Rng>
inline void evolve_in_background(Vec3& v, double& hazard, const BackgroundState& b, double grain_mass,
                                 double duration, Rng& rng, BackgroundCounters& counters) {
  if (b.rate_scale <= 0.0) return;
  Vec3 c = v - b.velocity;
  double cmod = norm(c);
  double left = duration;
  for (;;) {
    const double rate = b.rate_scale * (cmod + b.mean_speed);  // background_majorant_rate
    const double need = rate * left;
    if (hazard >= need) {
      hazard -= need;
      return;
    }
    left = std::max(0.0, left - hazard / rate);
    hazard = rng.exponential_ziggurat();
    ++counters.candidates;
    if (background_test(v, c, cmod, b, grain_mass, rng, counters.energy_gain)) ++counters.collisions;
  }
}

// The same from a fresh unit exponential (no carried residual).
template <class Rng>
inline void evolve_in_background(Vec3& v, const BackgroundState& b, double grain_mass, double duration, Rng& rng,
                                 BackgroundCounters& counters) {
  double hazard = rng.exponential_ziggurat();
  evolve_in_background(v, hazard, b, grain_mass, duration, rng, counters);
}

}  // namespace grainbath
