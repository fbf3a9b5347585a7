// Sonine closure (docs Sec. S): quadrature collision terms against a weighted Monte Carlo of
// the collision rules (grains drawn from the Maxwellian at T and weighted by 1 + a2 S2),
// reduction to the Maxwellian closure at a2 = 0, elastic invariants, and the equilibrium
// (including the white-noise limit of van Noije and Ernst).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "closures/closures.hpp"
#include "tests/closures/mc.hpp"

using namespace grainbath::closures;
using namespace grainbath::closures::test;

namespace {
Parameters bath(double alpha, double beta, double delta) {
  Parameters p{};
  p.alpha = alpha;
  p.mass = 1.1;
  p.nB = 0.9;
  p.TB = 1.2;
  p.uB = {0.1, 0.2, -0.1};
  p.eps = 0.3;
  p.n = 0.7;
  p.beta = beta;
  p.delta = delta;
  return p;
}
double S2(double x) { return 0.5 * x * x - 2.5 * x + 1.875; }
}  // namespace

TEST(Sonine, ReducesToMaxwellianClosureAtZeroA2) {
  for (double delta : {0.0, 0.2, 1.0}) {
    Parameters p = bath(0.4, delta == 1.0 ? 0.02 : 0.1, delta);
    for (double alpha : {0.15, 0.4, 0.85}) {
    p.alpha = alpha;
    for (double T : {0.36, 1.2, 3.6})  // T/TB = 0.3, 1, 3
      for (double drift : {0.0, 0.1, 0.7, 1.5, 3.0}) {  // |U| in units of s
        const double sd = drift * relative_speed_scale(p, T) / std::sqrt(1.25);
        const std::array<double, 3> u{p.uB[0] + sd, p.uB[1], p.uB[2] - 0.5 * sd};
        const SonineMoments bg = sonine_background(p, u, T, 0.0);
        const Exchange ex = maxwellian_exchange_exact(p, u, T);
        const double scale = p.nB / p.eps * p.alpha * std::pow(relative_speed_scale(p, T), 3) * p.mass;
        for (int a = 0; a < 3; ++a) EXPECT_NEAR(bg.du_dt[a], ex.du_dt[a], 1e-12 * scale) << alpha << " " << T << " " << drift;
        EXPECT_NEAR(p.mass * bg.dc2_dt / 3.0, ex.dT_dt, 1e-12 * scale);
      }
    }
    for (double T : {0.4, 1.2})
      EXPECT_NEAR(p.mass * sonine_grain_grain(p, T, 0.0).dc2_dt / 3.0, maxwellian_loss(p, T),
                  1e-11 * std::abs(maxwellian_loss(p, T)));
  }
}

TEST(Sonine, ElasticGrainCollisionsConserveEnergyAndKeepTheMaxwellian) {
  const Parameters p = bath(0.4, 0.0, 0.0);
  EXPECT_NEAR(sonine_grain_grain(p, 1.0, 0.2).dc2_dt, 0.0, 1e-13);
  EXPECT_NEAR(sonine_grain_grain(p, 1.0, 0.0).dc4_dt, 0.0, 1e-13);
  EXPECT_LT(sonine_grain_grain(p, 1.0, 0.2).dc4_dt, 0.0);  // elastic collisions relax a2 > 0
  EXPECT_GT(sonine_grain_grain(p, 1.0, -0.2).dc4_dt, 0.0);
  // the background at T = TB, u = uB keeps the Maxwellian (J_EL(M) = 0)
  const SonineMoments bg = sonine_background(p, p.uB, p.TB, 0.0);
  EXPECT_NEAR(bg.dc2_dt, 0.0, 1e-12);
  EXPECT_NEAR(bg.dc4_dt, 0.0, 1e-12);
}

class SonineMC : public ::testing::TestWithParam<std::tuple<double, double, double, double>> {};

// Background rule (Bisi-Spiga eq. 3) and grain-grain power-law rule (eq. 6), sampled directly.
TEST_P(SonineMC, CollisionTermsMatchWeightedMonteCarlo) {
  const auto [alpha, T_over_TB, drift_s, a2] = GetParam();
  const Parameters p = bath(alpha, 0.12, 0.2);
  const double T = T_over_TB * p.TB, th = T / p.mass, thB = p.TB / background_mass(p);
  const double s = relative_speed_scale(p, T);
  const std::array<double, 3> u{p.uB[0] + 0.6 * drift_s * s, p.uB[1] + 0.8 * drift_s * s, p.uB[2]};
  const double rate = p.nB / p.eps;
  Sampler smp(99 + static_cast<unsigned>(1000 * alpha + 100 * T_over_TB + 10 * drift_s + 1000 * a2));
  Stat mom[3], b2, b4, g2, g4;
  for (int i = 0; i < 400000; ++i) {
    const Vec v = smp.gaussian(u, th);
    const Vec c{v[0] - u[0], v[1] - u[1], v[2] - u[2]};
    const double W = 1.0 + a2 * S2(dot(c, c) / (2 * th));
    const Vec w = smp.gaussian(p.uB, thB), n = smp.unit();
    const double gn = dot(Vec{v[0] - w[0], v[1] - w[1], v[2] - w[2]}, n);
    Vec cp;
    for (int a = 0; a < 3; ++a) cp[a] = c[a] - 2 * p.alpha * gn * n[a];
    const double wt = W * rate * 2 * std::abs(gn);
    for (int a = 0; a < 3; ++a) mom[a].add(wt * (cp[a] - c[a]));
    b2.add(wt * (dot(cp, cp) - dot(c, c)));
    b4.add(wt * (dot(cp, cp) * dot(cp, cp) - dot(c, c) * dot(c, c)));
    // grain-grain
    const Vec v2 = smp.gaussian(u, th), n2 = smp.unit();
    const Vec c2{v2[0] - u[0], v2[1] - u[1], v2[2] - u[2]};
    const double W2 = 1.0 + a2 * S2(dot(c2, c2) / (2 * th));
    const double gn2 = dot(Vec{v[0] - v2[0], v[1] - v2[1], v[2] - v2[2]}, n2);
    const double e = 1.0 - 2.0 * p.beta * std::pow(std::abs(gn2), p.delta);
    Vec cs;
    for (int a = 0; a < 3; ++a) cs[a] = c[a] - 0.5 * (1 + e) * gn2 * n2[a];
    const double wt2 = W * W2 * p.n * 2 * std::abs(gn2);
    g2.add(wt2 * (dot(cs, cs) - dot(c, c)));
    g4.add(wt2 * (dot(cs, cs) * dot(cs, cs) - dot(c, c) * dot(c, c)));
  }
  const SonineMoments bg = sonine_background(p, u, T, a2);
  const SonineMoments gg = sonine_grain_grain(p, T, a2);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(bg.du_dt[a], mom[a].mean(), 5 * mom[a].se() + 1e-12);
  EXPECT_NEAR(bg.dc2_dt, b2.mean(), 5 * b2.se());
  EXPECT_NEAR(bg.dc4_dt, b4.mean(), 5 * b4.se());
  EXPECT_NEAR(gg.dc2_dt, g2.mean(), 5 * g2.se());
  EXPECT_NEAR(gg.dc4_dt, g4.mean(), 5 * g4.se());
  std::printf("[measure] sonine-vs-MC z: du %.2f bg c2 %.2f bg c4 %.2f gg c2 %.2f gg c4 %.2f (rel. SE bg c4 %.1e, gg c4 %.1e)\n",
              (bg.du_dt[0] - mom[0].mean()) / mom[0].se(), (bg.dc2_dt - b2.mean()) / b2.se(),
              (bg.dc4_dt - b4.mean()) / b4.se(), (gg.dc2_dt - g2.mean()) / g2.se(), (gg.dc4_dt - g4.mean()) / g4.se(),
              b4.se() / std::abs(b4.mean()), g4.se() / std::abs(g4.mean()));
}

INSTANTIATE_TEST_SUITE_P(Grid, SonineMC,
                         ::testing::Combine(::testing::Values(0.3, 0.75), ::testing::Values(0.3, 1.5, 3.0),
                                            ::testing::Values(0.0, 1.2, 3.0), ::testing::Values(-0.15, 0.2)));

TEST(Sonine, GrainGrainPowerLawMatchesMonteCarloForSeveralDelta) {
  for (double delta : {0.0, 1.0 / 5.0, 0.5}) {
    const Parameters p = bath(0.5, delta == 0.5 ? 0.06 : 0.15, delta);
    const double T = 0.9, th = T / p.mass, a2 = 0.1;
    Sampler smp(7 + static_cast<unsigned>(100 * delta));
    Stat g2, g4;
    for (int i = 0; i < 400000; ++i) {
      const Vec c = smp.gaussian({0, 0, 0}, th), c2 = smp.gaussian({0, 0, 0}, th), n = smp.unit();
      const double W = (1 + a2 * S2(dot(c, c) / (2 * th))) * (1 + a2 * S2(dot(c2, c2) / (2 * th)));
      const double gn = dot(Vec{c[0] - c2[0], c[1] - c2[1], c[2] - c2[2]}, n);
      const double e = 1.0 - 2.0 * p.beta * std::pow(std::abs(gn), delta);
      Vec cs;
      for (int a = 0; a < 3; ++a) cs[a] = c[a] - 0.5 * (1 + e) * gn * n[a];
      g2.add(W * p.n * 2 * std::abs(gn) * (dot(cs, cs) - dot(c, c)));
      g4.add(W * p.n * 2 * std::abs(gn) * (dot(cs, cs) * dot(cs, cs) - dot(c, c) * dot(c, c)));
    }
    const SonineMoments gg = sonine_grain_grain(p, T, a2);
    EXPECT_NEAR(gg.dc2_dt, g2.mean(), 5 * g2.se()) << "delta " << delta;
    EXPECT_NEAR(gg.dc4_dt, g4.mean(), 5 * g4.se()) << "delta " << delta;
  }
}

TEST(Sonine, EquilibriumZeroesAllSources) {
  const Parameters p = bath(0.4, 0.1, 0.2);
  const SonineEquilibrium eq = equilibrium_sonine(p);
  const MomentSources m = sonine_sources(p, {p.uB, eq.T, eq.a2});
  const double loss = std::abs(maxwellian_loss(p, eq.T));
  EXPECT_LT(std::abs(m.dT_dt), 1e-11 * loss);
  EXPECT_LT(std::abs(m.da2_dt), 1e-11 * loss / eq.T);
  const double TM = equilibrium_temperature(Closure::maxwellian, p);
  std::printf("sonine T# = %.10f a2 = %.6f; maxwellian T# = %.10f; shift/(TB-T#) = %.4f\n", eq.T,
              eq.a2, TM, (eq.T - TM) / (p.TB - TM));
  EXPECT_LT(std::abs(eq.T - TM), 0.1 * (p.TB - TM));
}

// alpha -> 0 with T# << TB: the background acts as friction (shape preserving) plus white noise;
// the steady a2 then approaches the van Noije-Ernst white-noise value
// a2 = 16 (1-e)(1-2e^2) / (73 + 56 d - 24 d e - 105 e + 30 (1-e) e^2), d = 3 (linear in a2,
// so agreement is to O(a2^2) and O(T#/TB)).
TEST(Sonine, WhiteNoiseLimitReproducesVanNoijeErnst) {
  for (double e : {0.3, 0.5, 0.9}) {
    Parameters p{};
    p.alpha = 1e-7;
    p.mass = 1.0;
    p.TB = 1.0;
    p.n = 1.0;
    p.eps = 1.0;
    p.beta = (1 - e) / 2;
    p.delta = 0.0;
    // choose nB so that T# ~ 0.005 TB: 2 gamma TB ~ (4/3)(1-e^2) n T^{3/2}/sqrt(pi)
    const double Tt = 0.005, gamma_per_nB = (8.0 / 3.0) * std::sqrt(2.0 / M_PI) * std::sqrt(p.alpha);
    p.nB = (4.0 / 3.0) * (1 - e * e) * std::pow(Tt, 1.5) / std::sqrt(M_PI) / (2 * gamma_per_nB);
    const SonineEquilibrium eq = equilibrium_sonine(p);
    const double a2vne = 16 * (1 - e) * (1 - 2 * e * e) / (73 + 56 * 3 - 24 * 3 * e - 105 * e + 30 * (1 - e) * e * e);
    std::printf("e=%.2f: T#/TB = %.4f, a2 = %.5f, van Noije-Ernst %.5f\n", e, eq.T, eq.a2, a2vne);
    // measured within 0.3 % (docs/closures.md); 1 % + 2e-5 catches an error above about 1 % in the
    // fourth-moment terms (the former 10 % + 2e-4 did not)
    EXPECT_NEAR(eq.a2, a2vne, 1e-2 * std::abs(a2vne) + 2e-5);
  }
}

TEST(Sonine, StrongDissipationGivesLargeA2OrAClearRefusal) {
  Parameters p = bath(0.8, 0.1, 0.0);
  p.TB = 1.0, p.n = 1.0, p.nB = 1.0, p.eps = 5.0;
  const SonineEquilibrium eq = equilibrium_sonine(p);  // a2 beyond the first bracket
  EXPECT_GT(eq.a2, 0.1);
  const MomentSources m = sonine_sources(p, {p.uB, eq.T, eq.a2});
  EXPECT_LT(std::abs(m.da2_dt), 1e-10);
  EXPECT_LT(std::abs(m.dT_dt), 1e-10);
  p.eps = 50.0;
  p.beta = 0.3;  // the fourth cumulant then grows without bound
  try {
    equilibrium_sonine(p);
    ADD_FAILURE() << "expected ClosureError";
  } catch (const ClosureError& e) {
    EXPECT_NE(std::string(e.what()).find("no steady state"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("restitution.beta"), std::string::npos) << e.what();
  }
  const auto v = theory_values(p);  // the seed closures are still reported
  bool has_sonine = false, has_maxwellian = false;
  double available = -1;
  for (const auto& [k, x] : v) {
    has_sonine |= (k == "equilibrium.sonine.T");
    has_maxwellian |= (k == "equilibrium.maxwellian.T");
    if (k == "diagnostics.sonine_available") available = x;
  }
  EXPECT_FALSE(has_sonine);
  EXPECT_TRUE(has_maxwellian);
  EXPECT_EQ(available, 0.0);
}

// Constant restitution (delta = 0, e = 1 - 2 beta): the Sonine closure's grain-grain moments
// are the HCS collision moments of the same f = M [1 + a2 S2] (docs eq. H6: a separate
// quadrature in other coordinates, checked against the closed forms of Brilliantov and
// Poeschel in test_hcs.cpp), up to the units: with v_T^2 = 2T/m,
//   d<c^2>/dt (a2) / d<c^2>/dt (0) = mu_2(a2)/mu_2(0),  d<c^4>/dt (a2) / (v_T^2 d<c^2>/dt (0)) = mu_4(a2)/mu_2(0).
// Large |a2| makes the a2^2 terms count (mutation audit 2026-12-06,
// docs/reviews/mutation-audit-closures-hydro.md).
TEST(Sonine, GrainGrainMomentsAreTheHcsCollisionMomentsForConstantRestitution) {
  for (double e : {0.3, 0.8}) {
    Parameters p = bath(0.4, 0.5 * (1.0 - e), 0.0);
    const double T = 1.3, vT2 = 2.0 * T / p.mass;
    const double g0 = sonine_grain_grain(p, T, 0.0).dc2_dt, mu20 = hcs_collision_moment(2, e, 0.0, 0.0);
    for (double a2 : {-0.4, 0.3, 0.7}) {
      const SonineMoments s = sonine_grain_grain(p, T, a2);
      const double r2 = hcs_collision_moment(2, e, a2, 0.0) / mu20, r4 = hcs_collision_moment(4, e, a2, 0.0) / mu20;
      std::printf("e=%.1f a2=%+.1f: c2 ratio %.12f (HCS %.12f), c4 ratio %.12f (HCS %.12f)\n", e, a2, s.dc2_dt / g0, r2,
                  s.dc4_dt / (vT2 * g0), r4);
      EXPECT_NEAR(s.dc2_dt / g0, r2, 1e-10 * std::abs(r2)) << "e=" << e << " a2=" << a2;
      EXPECT_NEAR(s.dc4_dt / (vT2 * g0), r4, 1e-10 * std::abs(r4)) << "e=" << e << " a2=" << a2;
    }
  }
}

// Brownian limit (alpha -> 0, a heavy grain in a light gas): the bath acts as an
// Ornstein-Uhlenbeck (Fokker-Planck) process, which keeps a Gaussian Gaussian while its
// temperature relaxes, so a Maxwellian start (a2 = 0) at T != TB must give da2/dt = 0 to O(alpha)
// while dT/dt = 2 gamma (TB - T) is not small (mutation audit 2026-12-06,
// docs/reviews/mutation-audit-closures-hydro.md: this sees the -2 (1 + a2) dT/dt / T of the
// chain rule a2 = <c^4>/(15 theta^2) - 1, which vanishes in every steady state).
TEST(Sonine, BrownianBathKeepsAGaussianGaussian) {
  Parameters p = bath(1e-6, 0.0, 0.0);  // elastic grains: grain-grain collisions keep the Maxwellian too
  p.nB = 1e3;
  for (double T : {0.3 * p.TB, 2.5 * p.TB}) {
    const MomentSources m = sonine_sources(p, {p.uB, T, 0.0});
    std::printf("Brownian bath, T/TB = %.1f: dT/dt / T = %.6e, da2/dt = %.3e\n", T / p.TB, m.dT_dt / T, m.da2_dt);
    EXPECT_GT(std::abs(m.dT_dt / T), 1e-3);
    EXPECT_LT(std::abs(m.da2_dt), 1e-3 * std::abs(m.dT_dt / T)) << "T/TB=" << T / p.TB;
  }
}
