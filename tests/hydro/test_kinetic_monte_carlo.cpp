// Independent check of the kinetic (Sonine-Galerkin) tracer coefficients by Monte Carlo of the
// grain's velocity jump process in a homogeneous bath (nB = TB = m = eps = 1): the collision
// rule of the conventions (rate nB |v-w| M_B(w), apse density |g.n|/(2 pi |g|),
// v' = v - 2 alpha (g.n) n) is simulated exactly, and
//   D  = lim (MSD(t2) - MSD(t1)) / (2 (t2 - t1))            (Einstein, per dimension)
//   K1 = E[ S1(x0) v_x(0) (x(t) - x(0)) ],  K0 = E[ v_x(0) (x(t) - x(0)) ]   (Green-Kubo)
// give Dhat and p = 1 - K1/K0 (docs/hydro.md eqs. H11-H13). Nothing from the Galerkin code is used.
#include "hydro/hydro.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <numbers>

using namespace grainbath::hydro;
constexpr double kPi = std::numbers::pi;

namespace {

// splitmix64-seeded xoshiro256** (self-written: reproducible across standard libraries).
struct Rng {
  std::uint64_t s[4];
  explicit Rng(std::uint64_t seed) {
    for (auto& x : s) {
      seed += 0x9E3779B97F4A7C15ULL;
      std::uint64_t z = seed;
      z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
      z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
      x = z ^ (z >> 31);
    }
  }
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t next() {
    const std::uint64_t r = rotl(s[1] * 5, 7) * 9, t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return r;
  }
  double uniform() { return (static_cast<double>(next() >> 11) + 0.5) * 0x1.0p-53; }
  double normal() {  // Box-Muller (one of the pair)
    return std::sqrt(-2.0 * std::log(uniform())) * std::cos(2.0 * kPi * uniform());
  }
  void unit_vector(double* e) {
    const double c = 2.0 * uniform() - 1.0, ph = 2.0 * kPi * uniform(), s_ = std::sqrt(1.0 - c * c);
    e[0] = s_ * std::cos(ph);
    e[1] = s_ * std::sin(ph);
    e[2] = c;
  }
};

struct McResult {
  double D, D_se, p, p_se;
};

McResult simulate(double alpha, int particles, double t1, double t2, std::uint64_t seed) {
  const double mB = alpha / (1.0 - alpha), sw = std::sqrt(1.0 / mB);  // background thermal speed
  const double mean_w = sw * std::sqrt(8.0 / kPi);                     // <|w|>
  Rng rng(seed);
  double sum1 = 0, sumsq = 0;  // Einstein: increments of the MSD between t1 and t2
  double k0 = 0, k1 = 0, k00 = 0, k11 = 0, k01 = 0;  // Green-Kubo moments
  for (int i = 0; i < particles; ++i) {
    double v[3] = {rng.normal(), rng.normal(), rng.normal()}, x[3] = {0, 0, 0}, x1[3] = {0, 0, 0};
    const double v0[3] = {v[0], v[1], v[2]};
    const double S1 = 2.5 - 0.5 * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    double t = 0.0;
    bool have1 = false;
    while (true) {
      const double vn = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
      // Candidate partners at rate (|v| + |w|) M_B(w): exact majorant of |v - w|.
      const double lam = vn + mean_w;
      const double tau = -std::log(rng.uniform()) / lam;
      const double tn = t + tau;
      if (!have1 && tn >= t1) {
        for (int a = 0; a < 3; ++a) x1[a] = x[a] + v[a] * (t1 - t);
        have1 = true;
      }
      if (tn >= t2) {
        for (int a = 0; a < 3; ++a) x[a] += v[a] * (t2 - t);
        break;
      }
      for (int a = 0; a < 3; ++a) x[a] += v[a] * tau;
      t = tn;
      double w[3];
      if (rng.uniform() * lam < vn) {
        for (double& c : w) c = sw * rng.normal();  // w ~ M_B
      } else {  // w ~ |w| M_B(w) / <|w|>: |w|^2/(2 sw^2) ~ Gamma(2)
        const double r = sw * std::sqrt(-2.0 * std::log(rng.uniform() * rng.uniform()));
        rng.unit_vector(w);
        for (double& c : w) c *= r;
      }
      const double g[3] = {v[0] - w[0], v[1] - w[1], v[2] - w[2]};
      const double gn = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
      const double wn = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
      if (rng.uniform() * (vn + wn) >= gn) continue;  // thinning: accept with |g|/(|v|+|w|)
      // Apse vector: cos(angle to g) has density 2|c| on [0,1] (sign irrelevant for v').
      const double c = std::sqrt(rng.uniform()), sn = std::sqrt(1.0 - c * c), ph = 2.0 * kPi * rng.uniform();
      double gh[3] = {g[0] / gn, g[1] / gn, g[2] / gn}, e1[3], e2[3];
      const double tv[3] = {std::abs(gh[0]) < 0.9 ? 1.0 : 0.0, std::abs(gh[0]) < 0.9 ? 0.0 : 1.0, 0.0};
      e1[0] = gh[1] * tv[2] - gh[2] * tv[1];
      e1[1] = gh[2] * tv[0] - gh[0] * tv[2];
      e1[2] = gh[0] * tv[1] - gh[1] * tv[0];
      const double ne = std::sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
      for (double& q : e1) q /= ne;
      e2[0] = gh[1] * e1[2] - gh[2] * e1[1];
      e2[1] = gh[2] * e1[0] - gh[0] * e1[2];
      e2[2] = gh[0] * e1[1] - gh[1] * e1[0];
      double n[3];
      for (int a = 0; a < 3; ++a) n[a] = c * gh[a] + sn * (std::cos(ph) * e1[a] + std::sin(ph) * e2[a]);
      const double gdn = g[0] * n[0] + g[1] * n[1] + g[2] * n[2];
      for (int a = 0; a < 3; ++a) v[a] -= 2.0 * alpha * gdn * n[a];
    }
    // Einstein increment (per particle, averaged over the 3 dimensions).
    const double inc = ((x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) - (x1[0] * x1[0] + x1[1] * x1[1] + x1[2] * x1[2])) /
                       (3.0 * 2.0 * (t2 - t1));
    sum1 += inc;
    sumsq += inc * inc;
    // Green-Kubo at t1 (the velocity correlation has decayed by then).
    const double a0 = (v0[0] * x1[0] + v0[1] * x1[1] + v0[2] * x1[2]) / 3.0;
    const double a1 = S1 * a0;
    k0 += a0;
    k1 += a1;
    k00 += a0 * a0;
    k11 += a1 * a1;
    k01 += a0 * a1;
  }
  const double M = particles;
  McResult r;
  r.D = sum1 / M;
  r.D_se = std::sqrt((sumsq / M - r.D * r.D) / M);
  const double m0 = k0 / M, m1 = k1 / M;
  const double v00 = (k00 / M - m0 * m0) / M, v11 = (k11 / M - m1 * m1) / M, v01 = (k01 / M - m0 * m1) / M;
  r.p = 1.0 - m1 / m0;
  // Delta method for the ratio m1/m0.
  const double R = m1 / m0;
  r.p_se = std::abs(R) * std::sqrt(v11 / (m1 * m1) + v00 / (m0 * m0) - 2.0 * v01 / (m0 * m1));
  return r;
}

}  // namespace

void check_against_galerkin(double alpha, int particles, double t1, double t2) {
  const McResult mc = simulate(alpha, particles, t1, t2, 4242 + static_cast<std::uint64_t>(alpha * 100));
  const KineticTransport kin = kinetic_transport(alpha);
  const double Dpaper = paper_coefficients(alpha, 1.0, 1.0).Dhat;
  std::printf("  alpha=%.2f MC: Dhat = %.5f +- %.5f, p = %.4f +- %.4f | Galerkin: Dhat = %.5f, p = %.4f | paper: %.5f, 1\n",
              alpha, mc.D, mc.D_se, mc.p, mc.p_se, kin.Dhat, kin.p, Dpaper);
  EXPECT_LT(std::abs(mc.D - kin.Dhat), 4.0 * mc.D_se) << alpha;
  EXPECT_GT(std::abs(mc.D - Dpaper), 4.0 * mc.D_se) << alpha;  // resolves the Sonine correction
  EXPECT_LT(std::abs(mc.p - kin.p), 4.0 * mc.p_se) << alpha;
  EXPECT_GT(std::abs(mc.p - 1.0), 4.0 * mc.p_se) << alpha;
}

// Default tier (~2-3 s): alpha = 0.7, where kinetic and paper D differ by 4.9 %.
TEST(HydroKineticMonteCarlo, TracerCoefficientsMatchGalerkin) { check_against_galerkin(0.7, 100000, 15.0, 60.0); }

// Long tier (label "long", ~10-25 s): alpha = 0.5 (1.9 % correction) and 0.85.
TEST(HydroKineticMonteCarloLong, TracerCoefficientsMatchGalerkin) {
  check_against_galerkin(0.5, 150000, 20.0, 80.0);
  check_against_galerkin(0.85, 150000, 20.0, 80.0);
}
