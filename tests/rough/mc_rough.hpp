#pragma once
// Monte Carlo of Walton collisions over Gaussian velocities, collision-rate weighted, written
// from the collision rule (operators/walton.hpp) and the Enskog collision rate, not from any
// closure formula (docs/rough.md sec. 3). 2D: planar translation, spin along z.
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "tests/support/stat.hpp"

#include "operators/walton.hpp"

namespace grainbath::rough_test {

using Stat = test_support::Stat;  // running mean and standard error

// Self-normalised weighted mean sum(w y)/sum(w) with its delta-method standard error (for
// averages over the collision-weighted distribution, where the weight's own noise cancels).
struct RatioStat {
  double sy = 0.0, sw = 0.0, syy = 0.0, sww = 0.0, syw = 0.0;
  long n = 0;
  void add(double w, double y) {  // y: the quantity, w: its weight
    const double wy = w * y;
    sy += wy, sw += w, syy += wy * wy, sww += w * w, syw += wy * w;
    ++n;
  }
  double mean() const { return sy / sw; }
  double se() const {
    const double r = mean(), mw = sw / n;
    const double var = (syy - 2.0 * r * syw + r * r * sww) / n;  // E[(wy - r w)^2]
    return std::sqrt(std::max(0.0, var) / (n - 1)) / mw;
  }
};

// How the tangential restitution of a sampled collision is chosen.
enum class Rule {
  walton,       // Walton's rule, impact angle of the contact velocity g (model E)
  translation,  // Walton's beta(gamma) with the angle of v12 alone, rotation neglected (model D)
};

struct McResult {
  Stat dTtr, dTrot;      // collision parts of dTtr/dt and dTrot/dt
  RatioStat eta_g, eta2_g;  // collision-weighted <eta>, <eta^2> with the angle of g
  RatioStat eta_v, eta2_v;  // ... with the angle of v12 (rotation neglected)
  RatioStat sliding;        // collision-weighted fraction of sliding contacts
};

// dim = 2: pairs with v ~ N(0, Ttr/m) per planar component and w_z ~ N(0, Trot/I),
// I = q m a^2; dim = 3: three components of each. Fixed normal n = x (the gas is isotropic).
// A pair meets at rate proportional to (g.n)_+, so with nu = G sqrt(Ttr) collisions per
// particle per unit time and E[(v12.n)_+] = sqrt(Ttr/(pi m)),
//   dE/dt per particle = (nu/2) E[(g.n)_+ dE] / E[(g.n)_+]   (two particles per collision)
// and Ttr = (2/d) E_tr, Trot = (2/d_rot) E_rot per particle (d_rot = 1 in 2D, 3 in 3D).
inline McResult monte_carlo(const WaltonRestitution& law, double q, double G, double Ttr,
                            double Trot, Rule rule, long samples, unsigned long seed,
                            int dim = 2) {
  const double m = 1.0, a = 0.5, I = q * m * a * a;
  const double nu = G * std::sqrt(Ttr);
  const double norm_rate = std::sqrt(Ttr / (std::numbers::pi * m));
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> N(0.0, 1.0);
  const double sv = std::sqrt(Ttr / m), sw = std::sqrt(Trot / I);
  const Vec3 n{1.0, 0.0, 0.0};
  McResult r;
  const double d_tr = dim, d_rot = dim == 3 ? 3.0 : 1.0;
  for (long i = 0; i < samples; ++i) {
    Vec3 v1{sv * N(rng), sv * N(rng), 0.0}, v2{sv * N(rng), sv * N(rng), 0.0};
    Vec3 w1{0.0, 0.0, sw * N(rng)}, w2{0.0, 0.0, sw * N(rng)};
    if (dim == 3) {
      v1.z = sv * N(rng);
      v2.z = sv * N(rng);
      w1.x = sw * N(rng);
      w1.y = sw * N(rng);
      w2.x = sw * N(rng);
      w2.y = sw * N(rng);
    }
    const double gn = dot(v1 - v2, n);
    if (gn <= 0.0) {
      r.dTtr.add(0.0);
      r.dTrot.add(0.0);
      r.eta_g.add(0.0, 0.0);
      r.eta2_g.add(0.0, 0.0);
      r.eta_v.add(0.0, 0.0);
      r.eta2_v.add(0.0, 0.0);
      r.sliding.add(0.0, 0.0);
      continue;
    }
    const double wgt = gn / norm_rate;
    const Vec3 g = v1 - v2 + a * cross(w1 + w2, n);
    const double gt_g = std::hypot(g.y, g.z), gt_v = std::hypot(v1.y - v2.y, v1.z - v2.z);
    bool slide_g = false, slide_v = false;
    const double beta_g = walton_beta(law, q, gn, gt_g, &slide_g);
    const double beta_v = walton_beta(law, q, gn, gt_v, &slide_v);
    const double eta_g = q * (1.0 + beta_g) / (2.0 * (1.0 + q));
    const double eta_v = q * (1.0 + beta_v) / (2.0 * (1.0 + q));
    const double Etr0 = 0.5 * m * (norm2(v1) + norm2(v2)), Erot0 = 0.5 * I * (norm2(w1) + norm2(w2));
    if (rule == Rule::walton) {
      walton_collision(v1, v2, w1, w2, n, a, q, law, m);
    } else {  // model D's rule: beta from the translational impact angle, applied as constant
      const WaltonRestitution fixed{law.e, beta_v, std::numeric_limits<double>::infinity()};
      walton_collision(v1, v2, w1, w2, n, a, q, fixed, m);
    }
    const double dEtr = 0.5 * m * (norm2(v1) + norm2(v2)) - Etr0;
    const double dErot = 0.5 * I * (norm2(w1) + norm2(w2)) - Erot0;
    r.dTtr.add(2.0 / d_tr * 0.5 * nu * wgt * dEtr);
    r.dTrot.add(2.0 / d_rot * 0.5 * nu * wgt * dErot);
    r.eta_g.add(wgt, eta_g);
    r.eta2_g.add(wgt, eta_g * eta_g);
    r.eta_v.add(wgt, eta_v);
    r.eta2_v.add(wgt, eta_v * eta_v);
    r.sliding.add(wgt, slide_g ? 1.0 : 0.0);
  }
  return r;
}

}  // namespace grainbath::rough_test
