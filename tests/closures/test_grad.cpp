// Grad closure (docs Sec. G): the distribution's moments, streaming closure (G4, G5), exchange
// (G7, G8) and loss (G9, G10) against weighted Monte Carlo of the collision rules: grains are
// drawn from the background-temperature Maxwellian M and weighted by the Grad polynomial.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "closures/closures.hpp"
#include "tests/closures/mc.hpp"

using namespace grainbath::closures;
using namespace grainbath::closures::test;

namespace {
Parameters bath(double alpha, double beta = 0.0, double delta = 0.0) {
  Parameters p{};
  p.alpha = alpha;
  p.mass = 0.9;
  p.nB = 1.2;
  p.TB = 0.8;
  p.uB = {-0.1, 0.3, 0.0};
  p.eps = 0.5;
  p.n = 0.6;
  p.beta = beta;
  p.delta = delta;
  return p;
}
// Grad weight of docs eq. G2 for a velocity v.
double grad_weight(const Parameters& p, const std::array<double, 3>& u, double T, const Vec& v) {
  const double thB = p.TB / p.mass;
  const Vec c{v[0] - p.uB[0], v[1] - p.uB[1], v[2] - p.uB[2]};
  const Vec U{u[0] - p.uB[0], u[1] - p.uB[1], u[2] - p.uB[2]};
  return 1.0 + dot(U, c) / thB + grad_kappa(p, u, T) * (dot(c, c) / thB - 3.0);
}
}  // namespace

class GradMC : public ::testing::TestWithParam<std::tuple<double, double, double>> {};

TEST_P(GradMC, MomentsStreamingExchangeAndLossMatchMonteCarlo) {
  const auto [alpha, T_over_TB, drift] = GetParam();
  const Parameters p = bath(alpha, 0.08, 0.2);
  const double T = T_over_TB * p.TB;
  const double s = relative_speed_scale(p, T);  // drift given in units of s
  const std::array<double, 3> u{p.uB[0] + drift * s * 0.6, p.uB[1] - drift * s * 0.8, p.uB[2]};
  const double thB = p.TB / p.mass, thBg = p.TB / background_mass(p), rate = p.nB / p.eps;
  Sampler smp(4242 + static_cast<unsigned>(100 * alpha + 10 * T_over_TB + 1000 * drift));
  Stat w0, wu[3], wT, P[3][3], q[3], mom[3], en, loss;
  const int N = 400000;
  for (int i = 0; i < N; ++i) {
    const Vec v = smp.gaussian(p.uB, thB);
    const double om = grad_weight(p, u, T, v);
    const Vec c{v[0] - u[0], v[1] - u[1], v[2] - u[2]};
    w0.add(om);
    for (int a = 0; a < 3; ++a) wu[a].add(om * v[a]);
    wT.add(om * p.mass * dot(c, c) / 3.0);
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) P[a][b].add(om * p.n * p.mass * c[a] * c[b]);
      q[a].add(om * 0.5 * p.n * p.mass * dot(c, c) * c[a]);
    }
    // background collision (Bisi-Spiga eq. 3)
    const Vec w = smp.gaussian(p.uB, thBg), n = smp.unit();
    const double gn = dot(Vec{v[0] - w[0], v[1] - w[1], v[2] - w[2]}, n);
    Vec cp;
    for (int a = 0; a < 3; ++a) cp[a] = c[a] - 2.0 * p.alpha * gn * n[a];
    for (int a = 0; a < 3; ++a) mom[a].add(om * rate * 2.0 * std::abs(gn) * (cp[a] - c[a]));
    en.add(om * rate * 2.0 * std::abs(gn) * p.mass / 3.0 * (dot(cp, cp) - dot(c, c)));
    // grain-grain collision (Bisi-Spiga eq. 6), partner also Grad-distributed
    const Vec v2 = smp.gaussian(p.uB, thB), n2 = smp.unit();
    const double om2 = grad_weight(p, u, T, v2);
    const double gn2 = dot(Vec{v[0] - v2[0], v[1] - v2[1], v[2] - v2[2]}, n2);
    const double e = 1.0 - 2.0 * p.beta * std::pow(std::abs(gn2), p.delta);
    Vec cs;
    for (int a = 0; a < 3; ++a) cs[a] = c[a] - 0.5 * (1.0 + e) * gn2 * n2[a];
    loss.add(om * om2 * p.n * 2.0 * std::abs(gn2) * p.mass / 3.0 * (dot(cs, cs) - dot(c, c)));
  }
  // The ansatz reproduces n, u, T (docs eq. G2)
  EXPECT_NEAR(w0.mean(), 1.0, 5 * w0.se());
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(wu[a].mean(), u[a], 5 * wu[a].se());
  EXPECT_NEAR(wT.mean(), T, 5 * wT.se());
  const GradStreaming gs = grad_streaming(p, u, T);
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) EXPECT_NEAR(gs.pressure[a][b], P[a][b].mean(), 5 * P[a][b].se() + 1e-12);
    EXPECT_NEAR(gs.heat_flux[a], q[a].mean(), 5 * q[a].se() + 1e-12);
  }
  const Exchange ex = grad_exchange(p, u, T);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(ex.du_dt[a], mom[a].mean(), 5 * mom[a].se() + 1e-12);
  EXPECT_NEAR(ex.dT_dt, en.mean(), 5 * en.se());
  EXPECT_NEAR(grad_loss(p, u, T), loss.mean(), 5 * loss.se());
  std::printf("[measure] grad-vs-MC z: du %.2f dT %.2f loss %.2f q %.2f Pxy %.2f\n",
              (ex.du_dt[0] - mom[0].mean()) / mom[0].se(), (ex.dT_dt - en.mean()) / en.se(),
              (grad_loss(p, u, T) - loss.mean()) / loss.se(), (gs.heat_flux[0] - q[0].mean()) / q[0].se(),
              (gs.pressure[0][1] - P[0][1].mean()) / P[0][1].se());
}

INSTANTIATE_TEST_SUITE_P(Grid, GradMC,
                         ::testing::Combine(::testing::Values(0.25, 0.7), ::testing::Values(0.3, 1.0, 3.0),
                                            ::testing::Values(0.0, 1.5, 3.0)));

// Deterministic check of docs eqs. G7, G8: adaptive quadrature over the grain velocity
// c = v - uB (axisymmetric about U) of the Grad weight times the background average of the
// angular identities (A1); the background average given c uses the non-central chi moments
// (C3, C4), themselves checked against quadrature in closures_gaussian_moments.
TEST(Grad, ExchangeMatchesQuadrature) {
  for (double alpha : {0.25, 0.7})
    for (double T_over_TB : {0.3, 1.0, 3.0})
      for (double drift : {0.0, 1.5, 3.0}) {
        const Parameters p = bath(alpha);
        const double T = T_over_TB * p.TB, s = relative_speed_scale(p, T), Um = drift * s;
        const std::array<double, 3> u{p.uB[0] + Um, p.uB[1], p.uB[2]};
        const double thB = p.TB / p.mass, thBb = p.TB / background_mass(p), sq = std::sqrt(thBb);
        const double kappa = grad_kappa(p, u, T), rate = p.nB / p.eps;
        auto integral = [&](bool energy) {
          return integrate2(
              [&](double rho, double mu) {
                const double cpar = rho * mu;
                const double om = 1 + Um * cpar / thB + kappa * (rho * rho / thB - 3);
                const double dens = 2 * M_PI * std::pow(2 * M_PI * thB, -1.5) * rho * rho * std::exp(-0.5 * rho * rho / thB);
                const double A = rho / sq;
                const RadialMoment m1 = noncentral_chi_moment(1, A), m3 = noncentral_chi_moment(3, A);
                const double F = m1.value + m1.d1_over_A;
                if (!energy) return dens * om * (-p.alpha * thBb * (cpar / sq) * F);  // <dc>.U_hat
                // (v - u) = c - U;  a.(c - U) = (rho^2 - Um cpar)/sq
                const double Eg_vu = thBb * ((rho * rho - Um * cpar) / sq) * F;
                const double Eg3 = thBb * sq * m3.value;
                return dens * om * (p.mass / 3) * (-2 * p.alpha * Eg_vu + 2 * p.alpha * p.alpha * Eg3);
              },
              0.0, 14.0 * std::sqrt(thB), 1e-12);
        };
        const Exchange ex = grad_exchange(p, u, T);
        const double scale = rate * p.alpha * p.mass * std::pow(relative_speed_scale(p, p.TB), 3) * (1 + drift * drift);
        EXPECT_NEAR(ex.du_dt[0], rate * integral(false), 1e-9 * scale) << alpha << " " << T_over_TB << " " << drift;
        EXPECT_NEAR(ex.dT_dt, rate * integral(true), 1e-9 * scale) << alpha << " " << T_over_TB << " " << drift;
        std::printf("[measure] grad-vs-quadrature du %.2e dT %.2e (relative to the scale)\n",
                    std::abs(ex.du_dt[0] - rate * integral(false)) / scale, std::abs(ex.dT_dt - rate * integral(true)) / scale);
      }
}

TEST(Grad, ReducesToMaxwellianAtBackgroundState) {
  // At u = uB, T = TB the Grad distribution is the Maxwellian itself.
  const Parameters p = bath(0.4, 0.05, 0.2);
  const Exchange g = grad_exchange(p, p.uB, p.TB), m = maxwellian_exchange_exact(p, p.uB, p.TB);
  EXPECT_NEAR(g.dT_dt, m.dT_dt, 1e-14);
  EXPECT_NEAR(grad_loss(p, p.uB, p.TB), maxwellian_loss(p, p.TB), 1e-14 * std::abs(maxwellian_loss(p, p.TB)));
  // Linear friction equals the Maxwellian one at T = TB to first order in the drift.
  const std::array<double, 3> u{p.uB[0] + 1e-4, p.uB[1], p.uB[2]};
  EXPECT_NEAR(grad_exchange(p, u, p.TB).du_dt[0], maxwellian_exchange_exact(p, u, p.TB).du_dt[0],
              1e-8 * std::abs(grad_exchange(p, u, p.TB).du_dt[0]));
}
