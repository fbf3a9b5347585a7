#pragma once
// Walton's rough-particle collision rule (Walton & Braun 1986; thesis seed 000 eqs. 2.4,
// 2.5 and chapter 10; Herbst et al. 2005): normal restitution e, tangential restitution
// beta0 for sticking contacts, Coulomb friction mu for sliding ones. Equal masses m, equal
// radii a, moment of inertia I = q m a^2 (q = 1/2 disks, q = 2/5 spheres). Header-only,
// shared by EDMD and homogeneous DSMC; docs/rough.md derives every formula (labels W1-W5).
//
// Conventions (docs/rough.md eq. W1): n is the unit normal from particle 1 to particle 2,
// the particles touch at r1 + a n = r2 - a n, and the relative velocity of the contact
// points is
//     g = v1 - v2 + a (w1 + w2) x n,      g_n = g.n > 0 when approaching,
//     g_t = g - g_n n                     (tangential part; rotation enters only here).
// The rule (eq. W2): g_n' = -e g_n, g_t' = -beta g_t, with linear momentum conserved and the
// angular momentum of each particle about the contact point conserved. Solving for the
// impulse dp on particle 1 (eq. W3):
//     v1' = v1 - eta_n g_n n - eta_t g_t,   v2' = v2 + eta_n g_n n + eta_t g_t,
//     w1' = w1 - (eta_t / (q a)) n x g_t,   w2' = w2 - (eta_t / (q a)) n x g_t,
//     eta_n = (1 + e)/2,  eta_t = q (1 + beta) / (2 (1 + q)).
// Coulomb limit (eq. W4): |dp_t| <= mu |dp_n|, i.e. eta_t |g_t| <= mu eta_n g_n. With the
// impact angle gamma, tan(gamma) = |g_t| / g_n, the contact sticks (beta = beta0) when
//     tan(gamma) <= tan(gamma0) = mu (1 + e)(1 + q) / (q (1 + beta0)),
// and slides otherwise with the Coulomb-limited value (eta_t = mu eta_n / tan(gamma))
//     beta(gamma) = -1 + mu (1 + e)(1 + 1/q) / tan(gamma).
// Energy lost by the pair (eq. W5, holds for sticking and sliding alike):
//     dE = (m/4) [ (1 - e^2) g_n^2 + q/(1+q) (1 - beta^2) |g_t|^2 ].
#include <cmath>
#include <limits>
#include <string_view>

#include "operators/vec3.hpp"

namespace grainbath {

inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// Walton's three material parameters. mu = +inf (or any mu with tan(gamma0) beyond every
// impact) means no sliding: the rule reduces to constant tangential restitution beta0.
// beta0 = -1 is the smooth limit (no tangential impulse); beta0 = +1 perfectly rough.
struct WaltonRestitution {
  static constexpr std::string_view name = "walton";
  double e = 1.0;      // normal restitution, [0, 1]
  double beta0 = -1.0; // maximal tangential restitution, [-1, 1]
  double mu = std::numeric_limits<double>::infinity();  // Coulomb friction, >= 0
  // The normal part as a restitution law (operators/restitution.hpp interface), so engines
  // and theory code written for e(g_n) see the constant normal restitution.
  double raw(double) const { return e; }
};

struct WaltonOutcome {
  double energy_lost;  // eq. W5, >= 0
  double beta;         // tangential restitution applied
  bool sliding;        // Coulomb-limited contact
};

// Tangential restitution for normal and tangential contact speeds g_n > 0, |g_t| (eq. W4):
// beta0 when sticking, the Coulomb-limited value when sliding.
inline double walton_beta(const WaltonRestitution& w, double q, double gn, double gt_abs,
                          bool* sliding = nullptr) {
  const double eta0 = q * (1.0 + w.beta0) / (2.0 * (1.0 + q));
  const double eta_n = 0.5 * (1.0 + w.e);
  // sticking iff eta0 |g_t| <= mu eta_n g_n (written without division: gt = 0 sticks)
  const bool slide = std::isfinite(w.mu) && eta0 * gt_abs > w.mu * eta_n * gn;
  if (sliding) *sliding = slide;
  if (!slide) return w.beta0;
  return -1.0 + w.mu * (1.0 + w.e) * (1.0 + 1.0 / q) * gn / gt_abs;
}

// Applies the collision to an approaching pair (g_n > 0 is the caller's condition; for
// g_n <= 0 nothing happens and zero is returned). v, w are translational and angular
// velocities (2D: v.z = 0 and w along z), n the unit normal from 1 to 2, a the radius,
// q = I/(m a^2). Returns the energy lost (eq. W5) and the contact type.
inline WaltonOutcome walton_collision(Vec3& v1, Vec3& v2, Vec3& w1, Vec3& w2, const Vec3& n,
                                      double a, double q, const WaltonRestitution& law,
                                      double mass = 1.0) {
  const Vec3 g = v1 - v2 + a * cross(w1 + w2, n);  // eq. W1
  const double gn = dot(g, n);
  if (gn <= 0.0) return {0.0, law.beta0, false};
  const Vec3 gt = g - gn * n;
  const double gt2 = norm2(gt);
  bool slide = false;
  const double beta = walton_beta(law, q, gn, std::sqrt(gt2), &slide);
  const double eta_n = 0.5 * (1.0 + law.e);
  const double eta_t = q * (1.0 + beta) / (2.0 * (1.0 + q));
  const Vec3 dv = eta_n * gn * n + eta_t * gt;  // eq. W3
  v1 -= dv;
  v2 += dv;
  const Vec3 dw = (eta_t / (q * a)) * cross(n, gt);
  w1 -= dw;
  w2 -= dw;
  const double lost =
      0.25 * mass * ((1.0 - law.e * law.e) * gn * gn + q / (1.0 + q) * (1.0 - beta * beta) * gt2);
  return {lost, beta, slide};
}

}  // namespace grainbath
