// Long tier (label "closures;long"): the three closures against an independent direct
// simulation of the homogeneous kinetic equation (tests/closures/reference_dsmc.hpp):
// steady T# and a2, and a relaxation from a drifting, hot Maxwellian. The Sonine closure must
// be within 1% of (TB - T#) of the simulation (plus 3 standard errors); the figures of all
// three closures are printed for docs/validation/closures.md.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "closures/closures.hpp"
#include "tests/closures/reference_dsmc.hpp"

using namespace grainbath::closures;
using grainbath::closures::test::ReferenceSimulation;

namespace {
Parameters bath(double alpha, double eps, double beta, double delta) {
  Parameters p{};
  p.alpha = alpha;
  p.mass = 1.0;
  p.nB = 1.0;
  p.TB = 1.0;
  p.eps = eps;
  p.n = 1.0;
  p.beta = beta;
  p.delta = delta;
  return p;
}
}  // namespace

class SteadyState : public ::testing::TestWithParam<std::tuple<double, double, double, double>> {};

TEST_P(SteadyState, SonineWithinOnePercentOfTheGap) {
  const auto [alpha, eps, beta, delta] = GetParam();
  const Parameters p = bath(alpha, eps, beta, delta);
  const double TM = equilibrium_temperature(Closure::maxwellian, p);
  const double TG = equilibrium_temperature(Closure::grad, p);
  const SonineEquilibrium S = equilibrium_sonine(p);
  // N = 4000 grains, 5 time units of burn-in, then 600 time units sampled every 0.05 in 20
  // batches (batch means give the standard error; batches are >> the correlation time ~0.5).
  ReferenceSimulation sim(p, 4000, 2024);
  sim.init_maxwellian(p.uB, TM);
  sim.run_until(5.0);
  const int nb = 20, per = 600;
  double bT[nb] = {}, ba[nb] = {};
  for (int b = 0; b < nb; ++b) {
    for (int k = 0; k < per; ++k) {
      sim.run_until(sim.time() + 0.05);
      const auto m = sim.moments();
      bT[b] += m.T / per;
      ba[b] += m.a2 / per;
    }
  }
  double T = 0, a2 = 0, vT = 0, va = 0;
  for (int b = 0; b < nb; ++b) T += bT[b] / nb, a2 += ba[b] / nb;
  for (int b = 0; b < nb; ++b) vT += std::pow(bT[b] - T, 2), va += std::pow(ba[b] - a2, 2);
  const double seT = std::sqrt(vT / (nb * (nb - 1.0))), sea = std::sqrt(va / (nb * (nb - 1.0)));
  const double gap = p.TB - T;
  std::printf("| %.2g | %.2g | %.2g | %.2g | %.5f ± %.5f | %.4f ± %.4f | %+.2f%% | %+.2f%% | %+.2f%% | %.4f |\n", alpha, eps,
              beta, delta, T, seT, a2, sea, 100 * (TM - T) / gap, 100 * (TG - T) / gap, 100 * (S.T - T) / gap, S.a2);
  EXPECT_LT(std::abs(S.T - T), 0.01 * gap + 3 * seT);
  EXPECT_LT(std::abs(S.a2 - a2), 0.06 * std::abs(a2) + 3 * sea);
}

INSTANTIATE_TEST_SUITE_P(Cases, SteadyState,
                         ::testing::Values(std::make_tuple(0.5, 0.5, 0.15, 0.0),
                                           std::make_tuple(0.8, 0.5, 0.2, 0.0),
                                           std::make_tuple(0.2, 0.5, 0.2, 0.0),
                                           std::make_tuple(0.5, 0.5, 0.3, 0.2)));

TEST(Relaxation, ClosuresTrackTheSimulationFromADriftingHotStart) {
  const Parameters p = bath(0.5, 0.5, 0.25, 0.0);
  const double U0 = 1.5, T0 = 2.0;
  std::vector<double> times;
  for (int k = 0; k <= 30; ++k) times.push_back(0.1 * k);
  const int R = 8, N = 20000;
  std::vector<double> T(times.size()), T2(times.size()), u(times.size()), u2(times.size()), a2(times.size());
  for (int r = 0; r < R; ++r) {
    ReferenceSimulation sim(p, N, 500 + r);
    sim.init_maxwellian({U0, 0, 0}, T0);
    for (size_t k = 0; k < times.size(); ++k) {
      sim.run_until(times[k]);
      const auto m = sim.moments();
      T[k] += m.T / R, T2[k] += m.T * m.T / R, u[k] += m.u[0] / R, u2[k] += m.u[0] * m.u[0] / R, a2[k] += m.a2 / R;
    }
  }
  const RelaxationState init{{U0, 0, 0}, T0, 0.0};
  const auto M = relax(Closure::maxwellian, p, init, times);
  const auto G = relax(Closure::grad, p, init, times);
  const auto S = relax(Closure::sonine, p, init, times);
  double worst[3] = {0, 0, 0}, worst_u[3] = {0, 0, 0};
  for (size_t k = 1; k < times.size(); ++k) {
    const double seT = std::sqrt(std::max(0.0, T2[k] - T[k] * T[k]) / (R - 1));
    const double seu = std::sqrt(std::max(0.0, u2[k] - u[k] * u[k]) / (R - 1));
    const double dT[3] = {M[k].T - T[k], G[k].T - T[k], S[k].T - T[k]};
    const double du[3] = {M[k].u[0] - u[k], G[k].u[0] - u[k], S[k].u[0] - u[k]};
    for (int c = 0; c < 3; ++c) {
      worst[c] = std::max(worst[c], std::abs(dT[c]) / (T0 - p.TB));
      worst_u[c] = std::max(worst_u[c], std::abs(du[c]) / U0);
    }
    if (k % 5 == 0)
      std::printf("t=%.1f sim T=%.5f±%.5f u=%.4f±%.4f a2=%.4f | maxw T=%.5f u=%.4f | grad T=%.5f u=%.4f | sonine T=%.5f u=%.4f a2=%.4f\n",
                  times[k], T[k], seT, u[k], seu, a2[k], M[k].T, M[k].u[0], G[k].T, G[k].u[0], S[k].T, S[k].u[0], S[k].a2);
    EXPECT_LT(std::abs(dT[2]), 0.01 * (T0 - p.TB) + 4 * seT) << "t = " << times[k];
    EXPECT_LT(std::abs(du[2]), 0.02 * U0 + 4 * seu) << "t = " << times[k];
  }
  std::printf("max |T_closure - T_sim|/(T0 - TB): maxwellian %.4f grad %.4f sonine %.4f\n", worst[0], worst[1], worst[2]);
  std::printf("max |u_closure - u_sim|/U0:        maxwellian %.4f grad %.4f sonine %.4f\n", worst_u[0], worst_u[1], worst_u[2]);
}
