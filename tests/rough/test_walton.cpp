// Walton collision rule (operators/walton.hpp; docs/rough.md eqs. W1-W5): conservation laws,
// the restitution of the contact velocity, the energy-loss formula for sticking and sliding,
// the Coulomb bound, and the smooth / no-sliding limits.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include "operators/binary_collision.hpp"
#include "operators/walton.hpp"

namespace grainbath {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Pair {
  Vec3 v1, v2, w1, w2, n;
};

// Random approaching pair; dim2 = planar velocities with spin along z.
Pair random_pair(std::mt19937_64& rng, bool dim2, double wscale = 1.0) {
  std::normal_distribution<double> N(0.0, 1.0);
  for (;;) {
    Pair p;
    if (dim2) {
      p.v1 = {N(rng), N(rng), 0.0};
      p.v2 = {N(rng), N(rng), 0.0};
      p.w1 = {0.0, 0.0, wscale * N(rng)};
      p.w2 = {0.0, 0.0, wscale * N(rng)};
      const double phi = std::uniform_real_distribution<double>(0.0, 2.0 * M_PI)(rng);
      p.n = {std::cos(phi), std::sin(phi), 0.0};
    } else {
      p.v1 = {N(rng), N(rng), N(rng)};
      p.v2 = {N(rng), N(rng), N(rng)};
      p.w1 = {wscale * N(rng), wscale * N(rng), wscale * N(rng)};
      p.w2 = {wscale * N(rng), wscale * N(rng), wscale * N(rng)};
      Vec3 z{N(rng), N(rng), N(rng)};
      p.n = (1.0 / norm(z)) * z;
    }
    if (dot(p.v1 - p.v2, p.n) > 0.0) return p;
  }
}

double kinetic(const Pair& p, double m, double I) {
  return 0.5 * m * (norm2(p.v1) + norm2(p.v2)) + 0.5 * I * (norm2(p.w1) + norm2(p.w2));
}
Vec3 contact_velocity(const Pair& p, double a) { return p.v1 - p.v2 + a * cross(p.w1 + p.w2, p.n); }

struct Case {
  double e, beta0, mu, q;
  bool dim2;
};

class WaltonRule : public ::testing::TestWithParam<Case> {};

TEST_P(WaltonRule, ConservesMomentaRestoresContactVelocityAndLosesW5) {
  const Case c = GetParam();
  const double m = 1.7, a = 0.6, I = c.q * m * a * a;
  const WaltonRestitution law{c.e, c.beta0, c.mu};
  std::mt19937_64 rng(12345);
  int n_slide = 0, n_stick = 0;
  double max_p = 0.0, max_L = 0.0, max_E = 0.0;  // largest relative errors, for the record
  for (int it = 0; it < 20000; ++it) {
    Pair p = random_pair(rng, c.dim2, 1.0 + (it % 3));
    const Pair before = p;
    const Vec3 g = contact_velocity(p, a);
    const double gn = dot(g, p.n);
    const Vec3 gt = g - gn * p.n;
    const WaltonOutcome out = walton_collision(p.v1, p.v2, p.w1, p.w2, p.n, a, c.q, law, m);
    (out.sliding ? n_slide : n_stick)++;
    // linear momentum (exact to round-off)
    const Vec3 dP = (p.v1 + p.v2) - (before.v1 + before.v2);
    EXPECT_LT(norm(dP), 1e-13 * (1.0 + norm(before.v1) + norm(before.v2)));
    max_p = std::max(max_p, norm(dP) / (1.0 + norm(before.v1) + norm(before.v2)));
    // angular momentum of each particle about the contact point c = r1 + a n = r2 - a n:
    // L1 = I w1 + m (r1 - c) x v1 = I w1 - m a n x v1,  L2 = I w2 + m a n x v2
    auto L1 = [&](const Pair& s) { return I * s.w1 - (m * a) * cross(s.n, s.v1); };
    auto L2 = [&](const Pair& s) { return I * s.w2 + (m * a) * cross(s.n, s.v2); };
    EXPECT_LT(norm(L1(p) - L1(before)), 1e-13 * (1.0 + norm(L1(before))));
    EXPECT_LT(norm(L2(p) - L2(before)), 1e-13 * (1.0 + norm(L2(before))));
    max_L = std::max({max_L, norm(L1(p) - L1(before)) / (1.0 + norm(L1(before))),
                      norm(L2(p) - L2(before)) / (1.0 + norm(L2(before)))});
    // contact velocity after: g_n' = -e g_n, g_t' = -beta g_t (eq. W2)
    const Vec3 g2 = contact_velocity(p, a);
    EXPECT_NEAR(dot(g2, p.n), -c.e * gn, 1e-12 * (1.0 + gn));
    const Vec3 gt2 = g2 - dot(g2, p.n) * p.n;
    EXPECT_LT(norm(gt2 + out.beta * gt), 1e-12 * (1.0 + norm(gt)));
    // energy: the returned loss is the kinetic-energy difference and eq. W5
    const double lost = kinetic(before, m, I) - kinetic(p, m, I);
    EXPECT_NEAR(out.energy_lost, lost, 1e-12 * (1.0 + kinetic(before, m, I)));
    const double w5 = 0.25 * m *
                      ((1.0 - c.e * c.e) * gn * gn +
                       c.q / (1.0 + c.q) * (1.0 - out.beta * out.beta) * norm2(gt));
    EXPECT_NEAR(out.energy_lost, w5, 1e-12 * (1.0 + w5));
    max_E = std::max({max_E, std::abs(out.energy_lost - lost) / (1.0 + kinetic(before, m, I)),
                      std::abs(out.energy_lost - w5) / (1.0 + w5)});
    EXPECT_GE(out.energy_lost, -1e-14);
    // Coulomb bound on the impulse (eq. W4): |dp_t| <= mu |dp_n|, with equality when sliding
    const Vec3 dp = m * (p.v1 - before.v1);
    const double dpn = std::abs(dot(dp, p.n));
    const double dpt = norm(dp - dot(dp, p.n) * p.n);
    if (std::isfinite(c.mu)) {
      EXPECT_LE(dpt, c.mu * dpn * (1.0 + 1e-12) + 1e-14);
      if (out.sliding) {
        EXPECT_NEAR(dpt, c.mu * dpn, 1e-12 * (1.0 + dpn));
        EXPECT_LE(out.beta, c.beta0 + 1e-14);
        EXPECT_GE(out.beta, -1.0 - 1e-14);
      }
    }
    if (!out.sliding) {
      EXPECT_EQ(out.beta, c.beta0);
      // sticking: the beta0 impulse would not exceed the Coulomb bound
      if (std::isfinite(c.mu)) {
        EXPECT_LE(dpt, c.mu * dpn * (1.0 + 1e-12) + 1e-14);
      }
    }
  }
  std::printf("[measure] e=%g beta0=%g mu=%g q=%g %dD: sliding %d / 20000; max rel. error "
              "momentum %.1e, contact angular momentum %.1e, energy (vs kinetic diff. and W5) %.1e\n",
              c.e, c.beta0, c.mu, c.q, c.dim2 ? 2 : 3, n_slide, max_p, max_L, max_E);
  if (std::isfinite(c.mu) && c.mu > 0.0 && c.mu < 1.0 && c.beta0 > -1.0) {
    EXPECT_GT(n_slide, 1000) << "the case should exercise sliding";
    EXPECT_GT(n_stick, 1000) << "the case should exercise sticking";
  }
}

INSTANTIATE_TEST_SUITE_P(
    Cases, WaltonRule,
    ::testing::Values(Case{0.9, 0.6, 0.3, 0.5, true}, Case{0.95, 1.0, 0.5, 0.4, true},
                      Case{0.7, 0.2, 0.1, 0.4, false}, Case{0.8, 1.0, kInf, 0.4, false},
                      Case{1.0, 1.0, kInf, 0.5, true}, Case{0.9, -1.0, 0.3, 0.5, false},
                      Case{0.5, 0.8, 0.0, 0.5, true}));

// The sliding decision by impact angle: tan(gamma0) = mu (1+e)(1+q) / (q (1+beta0)) (eq. W4).
TEST(WaltonRule, StickingSlidingBoundaryIsTheImpactAngle) {
  const WaltonRestitution law{0.8, 0.6, 0.25};
  const double q = 0.5;
  const double tan_g0 = law.mu * (1.0 + law.e) * (1.0 + q) / (q * (1.0 + law.beta0));
  bool slide = true;
  EXPECT_EQ(walton_beta(law, q, 1.0, tan_g0 * (1.0 - 1e-9), &slide), law.beta0);
  EXPECT_FALSE(slide);
  const double b = walton_beta(law, q, 1.0, tan_g0 * (1.0 + 1e-9), &slide);
  EXPECT_TRUE(slide);
  EXPECT_NEAR(b, law.beta0, 1e-8);  // continuous at the boundary
  // deep in sliding: beta = -1 + mu (1+e)(1+1/q) g_n/|g_t|
  EXPECT_NEAR(walton_beta(law, q, 1.0, 10.0 * tan_g0, &slide),
              -1.0 + law.mu * (1.0 + law.e) * (1.0 + 1.0 / q) / (10.0 * tan_g0), 1e-14);
  // head-on (g_t = 0) always sticks
  EXPECT_EQ(walton_beta(law, q, 1.0, 0.0, &slide), law.beta0);
  EXPECT_FALSE(slide);
}

// beta0 = -1 is the smooth limit: spins untouched, translation as the smooth hard-sphere rule.
TEST(WaltonRule, SmoothLimitIsTheSmoothRule) {
  std::mt19937_64 rng(7);
  for (int it = 0; it < 1000; ++it) {
    Pair p = random_pair(rng, false);
    Pair s = p;
    const auto out = walton_collision(p.v1, p.v2, p.w1, p.w2, p.n, 0.5, 0.4,
                                      WaltonRestitution{0.85, -1.0, kInf}, 1.0);
    const double lost = inelastic_collision(s.v1, s.v2, s.n, 0.85, 1.0);
    EXPECT_LT(norm(p.v1 - s.v1) + norm(p.v2 - s.v2), 1e-14 * (1.0 + norm(s.v1) + norm(s.v2)));
    EXPECT_EQ(p.w1.x, s.w1.x);
    EXPECT_EQ(p.w2.z, s.w2.z);
    EXPECT_NEAR(out.energy_lost, lost, 1e-14 * (1.0 + lost));
  }
}

// A very large mu never slides and reproduces constant tangential restitution; beta0 = 1 with
// e = 1 conserves energy exactly.
TEST(WaltonRule, LargeFrictionIsConstantTangentialRestitution) {
  std::mt19937_64 rng(99);
  for (int it = 0; it < 1000; ++it) {
    Pair p = random_pair(rng, true, 3.0), s = p;
    const auto a = walton_collision(p.v1, p.v2, p.w1, p.w2, p.n, 0.5, 0.5,
                                    WaltonRestitution{0.9, 0.4, 1e12}, 1.0);
    const auto b = walton_collision(s.v1, s.v2, s.w1, s.w2, s.n, 0.5, 0.5,
                                    WaltonRestitution{0.9, 0.4, kInf}, 1.0);
    EXPECT_FALSE(a.sliding);
    EXPECT_EQ(a.beta, 0.4);
    EXPECT_NEAR(a.energy_lost, b.energy_lost, 1e-14 * (1.0 + b.energy_lost));
    EXPECT_LT(norm(p.w1 - s.w1) + norm(p.v1 - s.v1), 1e-14 * (1.0 + norm(s.w1) + norm(s.v1)));
    Pair r = random_pair(rng, false, 2.0);
    const auto el = walton_collision(r.v1, r.v2, r.w1, r.w2, r.n, 0.5, 0.4,
                                     WaltonRestitution{1.0, 1.0, kInf}, 1.0);
    EXPECT_NEAR(el.energy_lost, 0.0, 1e-13);
  }
}

// Receding pairs are left alone.
TEST(WaltonRule, RecedingPairUntouched) {
  Vec3 v1{-1, 0, 0}, v2{1, 0, 0}, w1{0, 0, 2}, w2{0, 0, -1};
  const auto out = walton_collision(v1, v2, w1, w2, Vec3{1, 0, 0}, 0.5, 0.5,
                                    WaltonRestitution{0.5, 1.0, 0.1}, 1.0);
  EXPECT_EQ(out.energy_lost, 0.0);
  EXPECT_EQ(v1.x, -1.0);
  EXPECT_EQ(w1.z, 2.0);
}

}  // namespace
}  // namespace grainbath
