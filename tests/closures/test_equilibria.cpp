// Collision equilibria and their eps-expansion (Bisi-Spiga eqs. 27-29, docs eqs. C11-C15, G11,
// G12), limits (beta = 0, Brownian alpha -> 0) and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "closures/closures.hpp"

using namespace grainbath::closures;

namespace {
Parameters base(double eps = 0.05, double beta = 0.1, double delta = 0.2) {
  Parameters p{};
  p.alpha = 0.3;
  p.mass = 1.2;
  p.nB = 1.0;
  p.TB = 1.4;
  p.uB = {0.1, 0.0, -0.3};
  p.eps = eps;
  p.n = 0.8;
  p.beta = beta;
  p.delta = delta;
  return p;
}

// Bisi-Spiga eq. 27 as re-derived (docs eq. C11), written out independently of the library:
// [(1-a)TB + a T]^{1/2} (TB - T) = eps n/nB beta [2^d G(d/2+2)(T/m)^{d/2}
//                                   - beta 2^{2d} G(d+2) (T/m)^d] T^{3/2} / (sqrt(2a) (1-a))
double eq27(const Parameters& p, double T) {
  const double a = p.alpha, d = p.delta, th = T / p.mass;
  const double lhs = std::sqrt((1 - a) * p.TB + a * T) * (p.TB - T);
  const double br = std::pow(2.0, d) * std::tgamma(d / 2 + 2) * std::pow(th, d / 2) -
                    p.beta * std::pow(2.0, 2 * d) * std::tgamma(d + 2) * std::pow(th, d);
  return lhs - p.eps * p.n / p.nB * p.beta * br * std::pow(T, 1.5) / (std::sqrt(2 * a) * (1 - a));
}
double bisect(const Parameters& p, double lo, double hi) {
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    ((eq27(p, mid) > 0) == (eq27(p, lo) > 0) ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}
}  // namespace

TEST(Equilibrium, MaxwellianRootSolvesPrintedEq27) {
  for (double eps : {0.01, 0.1, 0.5})
    for (double delta : {0.0, 0.2, 1.0}) {
      const Parameters p = base(eps, delta == 1.0 ? 0.02 : 0.1, delta);
      const double T = equilibrium_temperature(Closure::maxwellian, p);
      const double Tref = bisect(p, 1e-6, p.TB);
      EXPECT_NEAR(T, Tref, 1e-12 * Tref) << "eps=" << eps << " delta=" << delta;
      EXPECT_LT(T, p.TB);
    }
}

TEST(Equilibrium, GradRootZeroesItsEnergyBalance) {
  for (double eps : {0.01, 0.1, 0.5}) {
    const Parameters p = base(eps);
    const double T = equilibrium_temperature(Closure::grad, p);
    const RelaxationState st{p.uB, T, 0.0};
    const double scale = std::abs(grad_loss(p, p.uB, T));
    EXPECT_LT(std::abs(grad_sources(p, st).dT_dt), 1e-12 * scale);
    // and it is a sign change of the balance, not a tangency
    EXPECT_GT(grad_sources(p, {p.uB, T * (1 - 1e-9), 0.0}).dT_dt, 0.0);
    EXPECT_LT(grad_sources(p, {p.uB, T * (1 + 1e-9), 0.0}).dT_dt, 0.0);
  }
}

TEST(Equilibrium, ElasticGrainsGiveBackgroundTemperatureExactly) {
  const Parameters p = base(0.2, 0.0, 0.2);
  EXPECT_EQ(equilibrium_temperature(Closure::maxwellian, p), p.TB);
  EXPECT_EQ(equilibrium_temperature(Closure::grad, p), p.TB);
  EXPECT_EQ(equilibrium_temperature(Closure::sonine, p), p.TB);
  EXPECT_EQ(equilibrium_a2_sonine(p), 0.0);
  const Expansion e = expansion(p);
  EXPECT_EQ(e.T1, 0.0);
  EXPECT_EQ(e.T2_maxwellian, 0.0);
  EXPECT_EQ(e.T2_grad, 0.0);
}

// Bisi-Spiga eqs. 28, 29 as re-derived (docs eqs. C14, C15), written out here.
TEST(Expansion, CoefficientsMatchPrintedClosedForms) {
  for (double delta : {0.0, 0.2, 0.7}) {
    const Parameters p = base(0.1, 0.08, delta);
    const Expansion e = expansion(p);
    const double a = p.alpha, d = p.delta, thB = p.TB / p.mass;
    const double c1 = std::pow(2.0, d) * std::tgamma(d / 2 + 2) * std::pow(thB, d / 2);
    const double c2 = p.beta * std::pow(2.0, 2 * d) * std::tgamma(d + 2) * std::pow(thB, d);
    const double pref = p.n / p.nB * p.beta / (std::sqrt(2 * a) * (1 - a));
    const double T1 = -p.TB * pref * (c1 - c2);                                         // eq. 28
    const double T2 = -T1 * pref * (c1 * (d + 3 - a) / 2 - c2 * (2 * d + 3 - a) / 2);    // eq. 29
    EXPECT_NEAR(e.T0, p.TB, 0.0);
    EXPECT_NEAR(e.T1, T1, 1e-13 * std::abs(T1));
    EXPECT_NEAR(e.T2_maxwellian, T2, 1e-12 * std::abs(T2));
    // Grad: the exchange coefficient is frozen at s(TB), which removes the -a/2 terms' partner:
    // T2_grad - T2_maxwellian = alpha T1^2 / (2 TB)  (docs eq. G12)
    EXPECT_NEAR(e.T2_grad - e.T2_maxwellian, a * T1 * T1 / (2 * p.TB), 1e-12 * std::abs(T2));
  }
}

// Validation item 2: error after one term ~ eps^2, after two ~ eps^3 (slope over a decade).
TEST(Expansion, ErrorScalesAsEpsSquaredThenCubed) {
  for (Closure c : {Closure::maxwellian, Closure::grad})
    for (double delta : {0.0, 0.2}) {
      double sx = 0, sy1 = 0, sy2 = 0, sxx = 0, sxy1 = 0, sxy2 = 0;
      const int K = 9;
      for (int k = 0; k < K; ++k) {
        const double eps = 0.01 * std::pow(10.0, k / double(K - 1));  // 0.01 .. 0.1
        const Parameters p = base(eps, 0.1, delta);
        const double T = equilibrium_temperature(c, p);
        const Expansion e = expansion(p);
        const double T2 = c == Closure::grad ? e.T2_grad : e.T2_maxwellian;
        const double x = std::log(eps), y1 = std::log(std::abs(T - e.T0 - eps * e.T1)),
                     y2 = std::log(std::abs(T - e.T0 - eps * e.T1 - eps * eps * T2));
        sx += x, sy1 += y1, sy2 += y2, sxx += x * x, sxy1 += x * y1, sxy2 += x * y2;
      }
      const double slope1 = (K * sxy1 - sx * sy1) / (K * sxx - sx * sx);
      const double slope2 = (K * sxy2 - sx * sy2) / (K * sxx - sx * sx);
      std::printf("%s delta=%.1f: slope after T1 %.4f, after T2 %.4f\n", to_string(c), delta, slope1, slope2);
      EXPECT_NEAR(slope1, 2.0, 0.05);
      EXPECT_NEAR(slope2, 3.0, 0.1);
    }
}

// Validation item 4: alpha -> 0, delta = 0 is a heavy grain in a light gas: Epstein friction
// gamma = (4/3) (nB/eps) (mB/m) sqrt(8 TB/(pi mB)) (specular, unit cross-section), energy
// relaxation 2 gamma (TB - T) (Fokker-Planck bath), and the Haff cooling of a Gaussian gas
// dT/dt = -2 omega0 gamma0 T, omega0 = 4 n sqrt(T/(pi m)), gamma0 = (1-e^2)/6.
TEST(Limits, BrownianThermalBath) {
  Parameters p{};
  p.alpha = 1e-7;
  p.mass = 1.0;
  p.nB = 2000.0;
  p.TB = 1.0;
  p.eps = 1.0;
  p.n = 1.0;
  p.beta = 0.1;  // e = 0.8
  p.delta = 0.0;
  const double mB = background_mass(p);
  const double gamma = (4.0 / 3.0) * p.nB / p.eps * (mB / p.mass) * std::sqrt(8 * p.TB / (M_PI * mB));
  const std::array<double, 3> u{1e-3, 0, 0};
  EXPECT_NEAR(-maxwellian_exchange_exact(p, u, p.TB).du_dt[0] / 1e-3, gamma, 1e-6 * gamma);
  EXPECT_NEAR(maxwellian_exchange_exact(p, p.uB, 0.5).dT_dt, 2 * gamma * 0.5, 1e-6 * gamma);
  const double e = 1 - 2 * p.beta;
  auto balance = [&](double T) {
    return 2 * gamma * (p.TB - T) - 2 * 4 * p.n * std::sqrt(T / (M_PI * p.mass)) * (1 - e * e) / 6 * T;
  };
  double lo = 1e-6, hi = p.TB;
  for (int i = 0; i < 200; ++i) ((balance(0.5 * (lo + hi)) > 0) ? lo : hi) = 0.5 * (lo + hi);
  const double T = equilibrium_temperature(Closure::maxwellian, p);
  std::printf("Brownian limit: T# = %.12f, thermal-bath root %.12f\n", T, lo);
  EXPECT_NEAR(T, lo, 1e-6 * lo);
  EXPECT_LT(T, 0.95 * p.TB);  // a non-trivial balance
  EXPECT_NEAR(equilibrium_temperature(Closure::grad, p), lo, 2e-3 * (p.TB - lo));
}

// e = 1 - 2 beta = 0 (delta = 0, beta = 1/2): perfectly inelastic grains are a valid law (the
// power law is never negative), so the closures must not refuse it; the Maxwellian T# still
// solves eq. 27 (mutation audit 2026-12-06, docs/reviews/mutation-audit-closures-hydro.md).
TEST(Equilibrium, PerfectlyInelasticGrainsAreAccepted) {
  const Parameters p = base(0.05, 0.5, 0.0);
  EXPECT_EQ(negative_restitution_probability(p, p.TB), 0.0);
  double T = 0.0;
  ASSERT_NO_THROW(T = equilibrium_temperature(Closure::maxwellian, p));
  EXPECT_NEAR(T, bisect(p, 1e-6, p.TB), 1e-12 * T);
  EXPECT_NO_THROW(equilibrium_temperature(Closure::grad, p));
  EXPECT_NO_THROW(relax(Closure::maxwellian, p, {p.uB, 2.0 * p.TB, 0.0}, {0.1}));
  // just beyond, e < 0 for every collision: refused
  EXPECT_THROW(equilibrium_temperature(Closure::maxwellian, base(0.05, 0.5000001, 0.0)), ClosureError);
}

TEST(BadInput, ThrowsWithAMessageNamingTheParameter) {
  auto message = [](const Parameters& p) {
    try {
      equilibrium_temperature(Closure::maxwellian, p);
    } catch (const ClosureError& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  Parameters p = base();
  p.alpha = 1.0;
  EXPECT_NE(message(p).find("alpha"), std::string::npos) << message(p);
  p = base();
  p.TB = std::nan("");
  EXPECT_NE(message(p).find("TB"), std::string::npos) << message(p);
  p = base(0.1, 0.6, 0.0);  // constant e = -0.2
  EXPECT_NE(message(p).find("restitution.beta"), std::string::npos) << message(p);
  p = base(0.1, 0.4, 1.0);  // e < 0 once |g.n| > 1.25: common at T ~ 1.4
  EXPECT_NE(message(p).find("restitution.beta"), std::string::npos) << message(p);
  EXPECT_THROW(theory_values(p), std::invalid_argument);
  EXPECT_THROW(expansion(Parameters{0.3, 1.0, 1.0, 1.0, {}, -1.0, 1.0}), ClosureError);
  // A mild power law passes and reports a tiny e < 0 probability.
  p = base(0.1, 0.05, 0.2);
  EXPECT_NO_THROW(equilibrium_temperature(Closure::maxwellian, p));
  EXPECT_LT(negative_restitution_probability(p, p.TB), 1e-3);
}

TEST(TheoryValues, ContainsTheDocumentedKeysAndConsistentValues) {
  const Parameters p = base(0.1, 0.1, 0.2);
  const auto v = theory_values(p);
  auto get = [&](const std::string& k) {
    for (const auto& [key, val] : v)
      if (key == k) return val;
    ADD_FAILURE() << "missing key " << k;
    return std::nan("");
  };
  EXPECT_EQ(get("equilibrium.maxwellian.T"), equilibrium_temperature(Closure::maxwellian, p));
  EXPECT_EQ(get("equilibrium.grad.T"), equilibrium_temperature(Closure::grad, p));
  EXPECT_EQ(get("expansion.T0"), p.TB);
  EXPECT_EQ(get("expansion.T1"), expansion(p).T1);
  EXPECT_EQ(get("expansion.T2_maxwellian"), expansion(p).T2_maxwellian);
  EXPECT_EQ(get("expansion.T2_grad"), expansion(p).T2_grad);
  EXPECT_TRUE(std::isfinite(get("equilibrium.sonine.T")));
  EXPECT_TRUE(std::isfinite(get("equilibrium.sonine.a2")));
}

// The keys built from T# (mutation audit 2026-12-06, docs/reviews/mutation-audit-closures-hydro.md):
// rates.momentum is the linear friction rate at T#, -(du/dt)/(u - uB) of the exact exchange
// (docs eq. C5, validated against quadrature in test_exchange.cpp) at a tiny drift; the
// e < 0 probability is the one at T# (docs/OUTPUT.md), not at TB; and each second-order key
// approximates its own closure's T# with an O(eps^3) error (halving eps divides it by ~8,
// while the other closure's T2 would leave an eps^2 error, ratio ~4).
TEST(TheoryValues, DerivedKeysAreEvaluatedAtTheirClosuresEquilibrium) {
  auto key = [](const std::vector<std::pair<std::string, double>>& v, const std::string& k) {
    for (const auto& [name, val] : v)
      if (name == k) return val;
    ADD_FAILURE() << "missing key " << k;
    return std::nan("");
  };
  {
    const Parameters p = base(0.5, 0.08, 1.0);  // strong cooling: T# well below TB
    const auto v = theory_values(p);
    const double TM = key(v, "equilibrium.maxwellian.T");
    ASSERT_LT(TM, 0.97 * p.TB);
    const double dU = 1e-6;
    const std::array<double, 3> u{p.uB[0] + dU, p.uB[1], p.uB[2]};
    const double rate = -maxwellian_exchange_exact(p, u, TM).du_dt[0] / dU;
    std::printf("rates.momentum %.10f, -du/dt/U at T# %.10f, at TB %.10f\n", key(v, "rates.momentum"), rate,
                -maxwellian_exchange_exact(p, u, p.TB).du_dt[0] / dU);
    EXPECT_NEAR(key(v, "rates.momentum"), rate, 1e-8 * rate);
    // docs eq. C12 written out: among collisions of Maxwellian grains at T the normal speed q has
    // the density (m/2T) q exp(-m q^2/(4T)); e < 0 for q > (2 beta)^(-1/delta)
    const double qs = std::pow(2.0 * p.beta, -1.0 / p.delta);
    const double P = std::exp(-qs * qs * p.mass / (4.0 * TM));
    std::printf("P(e<0) key %.6e, at T# %.6e, at TB %.6e\n", key(v, "diagnostics.negative_restitution_probability"),
                P, std::exp(-qs * qs * p.mass / (4.0 * p.TB)));
    EXPECT_NEAR(key(v, "diagnostics.negative_restitution_probability"), P, 1e-12 * P);
  }
  for (const char* c : {"maxwellian", "grad"}) {
    double err[2];
    for (int i = 0; i < 2; ++i) {
      const auto v = theory_values(base(i == 0 ? 0.02 : 0.01, 0.1, 0.2));
      err[i] = std::abs(key(v, std::string("expansion.second_order_") + c + ".T") -
                        key(v, std::string("equilibrium.") + c + ".T"));
    }
    std::printf("%s: second-order key error %.3e (eps 0.02), %.3e (eps 0.01), ratio %.2f\n", c, err[0], err[1],
                err[0] / err[1]);
    EXPECT_NEAR(err[0] / err[1], 8.0, 0.8) << c;
  }
}
