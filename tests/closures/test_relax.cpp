// Homogeneous relaxation ODEs: exact solution of the elastic Grad system (docs eq. G13),
// agreement with an independent fixed-step RK4 of the same right-hand side, and approach to
// the collision equilibrium for all three closures.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "closures/closures.hpp"
#include "closures/root_finding.hpp"

using namespace grainbath::closures;

namespace {
Parameters base(double beta) {
  Parameters p{};
  p.alpha = 0.35;
  p.mass = 1.0;
  p.nB = 1.0;
  p.TB = 1.0;
  p.uB = {0.2, 0.0, 0.0};
  p.eps = 0.2;
  p.n = 1.0;
  p.beta = beta;
  p.delta = 0.0;
  return p;
}
}  // namespace

TEST(Relax, ElasticGradMatchesClosedFormSolution) {
  const Parameters p = base(0.0);
  const RelaxationState init{{1.0, -0.4, 0.3}, 2.5, 0.0};
  std::vector<double> times;
  for (int i = 0; i <= 20; ++i) times.push_back(0.05 * i);
  const auto out = relax(Closure::grad, p, init, times);
  const double s0 = relative_speed_scale(p, p.TB);
  const double g0 = (8.0 / 3.0) * std::sqrt(2.0 / M_PI) * p.alpha * p.nB / p.eps * s0, k = 2 * g0;
  double U02 = 0;
  for (int a = 0; a < 3; ++a) U02 += std::pow(init.u[a] - p.uB[a], 2);
  for (size_t i = 0; i < times.size(); ++i) {
    const double t = times[i];
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(out[i].u[a], p.uB[a] + (init.u[a] - p.uB[a]) * std::exp(-g0 * t), 1e-9);
    // docs eq. G13
    const double T = p.TB + (init.T - p.TB) * std::exp(-k * (1 - p.alpha) * t) +
                     p.mass * U02 / 3 * (std::exp(-k * (1 - p.alpha) * t) - std::exp(-k * t));
    EXPECT_NEAR(out[i].T, T, 1e-9 * T);
  }
}

TEST(Relax, MaxwellianMatchesIndependentRK4) {
  const Parameters p = base(0.1);
  const RelaxationState init{{2.0, 0.5, 0.0}, 0.4, 0.0};
  const std::vector<double> times{0.0, 0.1, 0.3, 1.0};
  const auto out = relax(Closure::maxwellian, p, init, times);
  // classical RK4 with dt = 1e-4 on the same sources
  RelaxationState y = init;
  auto add = [](RelaxationState s, const MomentSources& d, double h) {
    for (int a = 0; a < 3; ++a) s.u[a] += h * d.du_dt[a];
    s.T += h * d.dT_dt;
    return s;
  };
  const double dt = 1e-4;
  size_t next = 1;
  for (int step = 1; step <= 10000 && next < times.size(); ++step) {
    const MomentSources k1 = maxwellian_sources(p, y);
    const MomentSources k2 = maxwellian_sources(p, add(y, k1, dt / 2));
    const MomentSources k3 = maxwellian_sources(p, add(y, k2, dt / 2));
    const MomentSources k4 = maxwellian_sources(p, add(y, k3, dt));
    for (int a = 0; a < 3; ++a) y.u[a] += dt / 6 * (k1.du_dt[a] + 2 * k2.du_dt[a] + 2 * k3.du_dt[a] + k4.du_dt[a]);
    y.T += dt / 6 * (k1.dT_dt + 2 * k2.dT_dt + 2 * k3.dT_dt + k4.dT_dt);
    if (std::abs(step * dt - times[next]) < 1e-9) {
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(out[next].u[a], y.u[a], 1e-9);
      EXPECT_NEAR(out[next].T, y.T, 1e-9);
      ++next;
    }
  }
  EXPECT_EQ(next, times.size());
}

TEST(Relax, AllClosuresApproachTheirEquilibrium) {
  const Parameters p = base(0.1);
  const RelaxationState init{{1.5, 0.0, 0.0}, 2.0, 0.1};
  for (Closure c : {Closure::maxwellian, Closure::grad, Closure::sonine}) {
    const auto out = relax(c, p, init, {0.0, 30.0});
    EXPECT_EQ(out[0].T, init.T);
    EXPECT_NEAR(out[1].u[0], p.uB[0], 1e-8) << to_string(c);
    EXPECT_NEAR(out[1].T, equilibrium_temperature(c, p), 1e-8) << to_string(c);
    if (c == Closure::sonine) {
      EXPECT_NEAR(out[1].a2, equilibrium_a2_sonine(p), 1e-8);
    }
  }
}

// relax() integrates the Sonine system with BDF (finite-difference Jacobian) and the others
// with rk8pd; both integrators must give the same trajectories.
TEST(Relax, StiffAndExplicitIntegratorsAgree) {
  Parameters p = base(0.15);
  p.delta = 0.2;
  const RelaxationState init{{1.2, -0.3, 0.0}, 1.8, 0.05};
  const std::vector<double> times{0.0, 0.05, 0.2, 0.7, 2.0, 6.0};
  for (Closure c : {Closure::maxwellian, Closure::sonine}) {
    const auto a = relax_integrator(c, p, init, times, true);
    const auto b = relax_integrator(c, p, init, times, false);
    for (size_t k = 0; k < times.size(); ++k) {
      EXPECT_NEAR(a[k].T, b[k].T, 1e-7 * b[k].T) << to_string(c) << " t=" << times[k];
      EXPECT_NEAR(a[k].u[0], b[k].u[0], 1e-7) << to_string(c) << " t=" << times[k];
      EXPECT_NEAR(a[k].a2, b[k].a2, 1e-7) << to_string(c) << " t=" << times[k];
    }
  }
}

TEST(Relax, RejectsDecreasingTimes) {
  const Parameters p = base(0.1);
  EXPECT_THROW(relax(Closure::maxwellian, p, {{0, 0, 0}, 1.0, 0.0}, {1.0, 0.5}), ClosureError);
}

TEST(Relax, RefusesAStartWhereThePowerLawGoesNegative) {
  Parameters p = base(0.05);
  p.delta = 1.0;  // e < 0 once |g.n| > 10: P = 1e-11 at T = TB = 1, 4 % of collisions at T = 8
  EXPECT_NO_THROW(relax(Closure::maxwellian, p, {{0, 0, 0}, 0.5, 0.0}, {0.0, 0.1}));
  try {
    relax(Closure::maxwellian, p, {{0, 0, 0}, 8.0, 0.0}, {0.0, 0.1});
    ADD_FAILURE() << "expected ClosureError";
  } catch (const ClosureError& e) {
    EXPECT_NE(std::string(e.what()).find("restitution.beta"), std::string::npos) << e.what();
  }
}
