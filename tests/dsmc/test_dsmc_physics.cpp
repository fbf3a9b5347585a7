// Issue #2 validation of the homogeneous DSMC (fixed seeds; tolerances from measured
// standard errors). The references are computed here independently of the code under
// test: Monte Carlo of the collision integrals, Haff/van Noije-Ernst, and the root of
// Bisi-Spiga eq. 27 solved here by bisection from its printed form re-derived in
// docs/closures.md (not by the closures library).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>

#include "closures/closures.hpp"
#include "operators/random.hpp"
#include "support.hpp"

using grainbath::testing::run_dsmc;

namespace {

std::string bath_case(double alpha, double beta, double delta, double eps, double T0, double t_end,
                      int particles, double dt, double steady_from, const std::string& drift = "[0.0, 0.0, 0.0]",
                      double every = 0.1) {
  char buf[2048];
  std::snprintf(buf, sizeof buf, R"(
[grains]
density = 1.0
temperature = %.17g
drift = %s
[background]
mass_ratio = %.17g
density = 1.0
temperature = 1.0
knudsen = %.17g
[restitution]
law = "power"
beta = %.17g
delta = %.17g
[dsmc]
particles = %d
dt = %.17g
t_end = %.17g
[sampling]
every = %.17g
steady_from = %.17g
relaxation_theory = false
)",
                T0, drift.c_str(), alpha, eps, beta, delta, particles, dt, t_end, every, steady_from);
  return buf;
}

}  // namespace

// 1. Exact conservation in elastic grain-grain runs without a medium.
TEST(DsmcPhysics, ElasticGrainsConserveMomentumAndEnergy) {
  const auto run = run_dsmc(R"(
[grains]
temperature = 1.5
drift = [0.3, -0.2, 0.1]
[background]
density = 0.0
[restitution]
law = "elastic"
[dsmc]
particles = 5000
dt = 0.02
t_end = 10.0
[sampling]
every = 1.0
steady_from = 5.0
)",
                            11);
  const auto u = run.series("/timeseries/velocity");
  const auto ke = run.series("/timeseries/kinetic_energy_per_grain");
  const std::size_t last = ke.size() - 1;
  // collision count: (1/2) N n <|g|> t_end with <|g|> = sqrt(16 T / (pi m)) (Maxwellian)
  const double expected = 0.5 * 5000 * std::sqrt(16 * 1.5 / std::numbers::pi) * 10.0;
  EXPECT_NEAR(run.summary.number("counters.grain_collisions"), expected, 0.03 * expected);
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(u[3 * last + d], u[d], 1e-13);
  EXPECT_NEAR(ke[last], ke[0], 1e-13 * ke[0]);
  EXPECT_LT(std::abs(run.summary.number("energy.budget_relative_residual")), 1e-12);
}

// 2. beta = 0 with a bath: detailed balance gives T -> TB and a2 -> 0.
class DetailedBalance : public ::testing::TestWithParam<double> {};
TEST_P(DetailedBalance, ElasticGrainsReachTheBathMaxwellian) {
  const double alpha = GetParam();
  const auto run = run_dsmc(bath_case(alpha, 0.0, 0.0, 0.5, 2.0, 40.0, 20000, 0.02, 10.0), 5);
  const double T = run.summary.number("temperature.mean"), Terr = run.summary.number("temperature.stderr");
  const double a2 = run.summary.number("a2.mean"), a2err = run.summary.number("a2.stderr");
  EXPECT_GT(Terr, 0.0);
  EXPECT_LT(Terr, 3e-3);
  EXPECT_NEAR(T, 1.0, 5 * Terr);
  EXPECT_NEAR(a2, 0.0, 5 * a2err);
  // and a3 (docs/closures.md eq. H2), the sixth moment, vanishes as well
  const double a3 = run.summary.number("a3.mean"), a3err = run.summary.number("a3.stderr");
  EXPECT_GT(a3err, 0.0);
  EXPECT_NEAR(a3, 0.0, 5 * a3err);
  // the energy budget closes to round-off in a run with ~1e6 bath collisions
  EXPECT_LT(std::abs(run.summary.number("energy.budget_relative_residual")), 1e-9);
}
INSTANTIATE_TEST_SUITE_P(MassRatios, DetailedBalance, ::testing::Values(0.2, 0.8));

// 3. Initial slopes du/dt, dT/dt from a drifting Maxwellian (u - uB = 1, T = 2) against
//    the collision-moment integrals evaluated here by Monte Carlo over (v, w) pairs with
//    the exact apse averages (density of mu = g_hat.n is 2 mu on [0,1]):
//      background:  d<v>/dt = -alpha K <|g| g>,
//                   d<m v^2/2>/dt = K <|g| (m/2) (-2 alpha v.g + 2 alpha^2 |g|^2)>
//      grains:      dT/dt|_in = -(n/3) <|g| (m/2) (1 - e(g mu)^2) g^2 mu^2>_{g, mu}
//    with v, w independent draws from the two Maxwellians and K = nB/eps.
TEST(DsmcPhysics, InitialSlopesMatchCollisionIntegrals) {
  const double alpha = 0.5, beta = 0.2, delta = 0.2, eps = 1.0, m = 1.0, T0 = 2.0, TB = 1.0, n = 1.0;
  const double K = 1.0 / eps, mB = alpha * m / (1 - alpha);
  // --- reference by Monte Carlo (std::mt19937_64: a different generator from the code's)
  std::mt19937_64 gen(12345);
  std::normal_distribution<double> z(0.0, 1.0);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const int samples = 4'000'000;
  double sdu = 0, sdu2 = 0, se = 0, se2 = 0, sl = 0, sl2 = 0;
  for (int k = 0; k < samples; ++k) {
    const grainbath::Vec3 v{1.0 + std::sqrt(T0 / m) * z(gen), std::sqrt(T0 / m) * z(gen), std::sqrt(T0 / m) * z(gen)};
    const grainbath::Vec3 w{std::sqrt(TB / mB) * z(gen), std::sqrt(TB / mB) * z(gen), std::sqrt(TB / mB) * z(gen)};
    const grainbath::Vec3 g = v - w;
    const double gm = grainbath::norm(g);
    const double du = -alpha * K * gm * g.x;
    const double de = K * gm * 0.5 * m * (-2 * alpha * grainbath::dot(v, g) + 2 * alpha * alpha * gm * gm);
    sdu += du;
    sdu2 += du * du;
    se += de;
    se2 += de * de;
    // grain pair: relative velocity of two grains is Gaussian with variance 2 T0/m
    const double gx = std::sqrt(2 * T0 / m) * z(gen), gy = std::sqrt(2 * T0 / m) * z(gen),
                 gz = std::sqrt(2 * T0 / m) * z(gen);
    const double gg = std::sqrt(gx * gx + gy * gy + gz * gz);
    const double mu = std::sqrt(U(gen));
    const double e = std::max(0.0, 1.0 - 2 * beta * std::pow(gg * mu, delta));
    const double loss = gg * 0.25 * m * (1 - e * e) * gg * gg * mu * mu;  // |g| (m/4)(1-e^2)(g.n)^2
    sl += loss;
    sl2 += loss * loss;
  }
  const double du_ref = sdu / samples, du_ref_err = std::sqrt((sdu2 / samples - du_ref * du_ref) / samples);
  const double dE_ref = se / samples, dE_ref_err = std::sqrt((se2 / samples - dE_ref * dE_ref) / samples);
  const double L = sl / samples, L_err = std::sqrt((sl2 / samples - L * L) / samples);
  // Pairs collide at rate density (1/2) n^2 |g| and each collision dissipates
  // (m/4)(1-e^2)(g.n)^2, so the loss per grain per unit time is (n/2) <|g| (m/4)(1-e^2)(g.n)^2> = (n/2) L.
  // d(3T/2)/dt = d<m v^2/2>/dt - m u du/dt  (u = 1 at t = 0)
  const double u0 = 1.0;
  const double dT_ref = (2.0 / 3.0) * (dE_ref - m * u0 * du_ref - 0.5 * n * L);
  const double dT_ref_err =
      (2.0 / 3.0) * std::sqrt(dE_ref_err * dE_ref_err + du_ref_err * du_ref_err + 0.25 * n * n * L_err * L_err);

  // --- DSMC: replicas, cubic least-squares fit of u(t), T(t) and the cumulative bath input
  //     and inelastic loss per grain over t in [0, 0.2]. A quadratic fit over [0, 0.1] (the
  //     earlier form of this test) is biased by the cubic term: the best quadratic to t^3 on
  //     [0, h] has slope -(3/5) h^2 (continuous; -0.586 h^2 for 21 uniform samples), and with
  //     u(t)'s cubic coefficient of -2.7 to -3.7 (closure model; fit) that moved du/dt by
  //     +0.013 to +0.022, most of the 1.1 % this test used to show. With the cubic the
  //     truncation (quartic term, about 0.2 %) is below one standard error.
  const int replicas = 24;
  std::vector<double> du_fit, dT_fit, in_fit, loss_fit;
  for (int r = 0; r < replicas; ++r) {
    const auto run = run_dsmc(bath_case(alpha, beta, delta, eps, T0, 0.2, 400000, 0.005, 0.1, "[1.0, 0.0, 0.0]", 0.005),
                              1000 + r, 0, "slope");
    const auto t = run.series("/timeseries/t");
    const auto T = run.series("/timeseries/temperature");
    const auto u = run.series("/timeseries/velocity");
    const auto bath_in = run.series("/timeseries/bath_energy_input_per_grain");
    const auto loss = run.series("/timeseries/inelastic_loss_per_grain");
    // least squares y = c0 + c1 t + c2 t^2 + c3 t^3: normal equations solved by Gaussian
    // elimination with partial pivoting (t scaled by its maximum to keep them well conditioned)
    auto fit_slope = [&](auto y_of) {
      const double scale = t.back();
      double A[4][5] = {};
      for (std::size_t k = 0; k < t.size(); ++k) {
        double p[4] = {1, t[k] / scale, 0, 0};
        p[2] = p[1] * p[1];
        p[3] = p[2] * p[1];
        const double y = y_of(k);
        for (int i = 0; i < 4; ++i) {
          for (int j = 0; j < 4; ++j) A[i][j] += p[i] * p[j];
          A[i][4] += p[i] * y;
        }
      }
      for (int col = 0; col < 4; ++col) {
        int piv = col;
        for (int i = col + 1; i < 4; ++i)
          if (std::abs(A[i][col]) > std::abs(A[piv][col])) piv = i;
        for (int j = 0; j < 5; ++j) std::swap(A[col][j], A[piv][j]);
        for (int i = col + 1; i < 4; ++i) {
          const double f = A[i][col] / A[col][col];
          for (int j = col; j < 5; ++j) A[i][j] -= f * A[col][j];
        }
      }
      double c[4];
      for (int i = 3; i >= 0; --i) {
        double sum = A[i][4];
        for (int j = i + 1; j < 4; ++j) sum -= A[i][j] * c[j];
        c[i] = sum / A[i][i];
      }
      return c[1] / scale;
    };
    du_fit.push_back(fit_slope([&](std::size_t k) { return u[3 * k]; }));
    dT_fit.push_back(fit_slope([&](std::size_t k) { return T[k]; }));
    in_fit.push_back(fit_slope([&](std::size_t k) { return bath_in[k]; }));
    loss_fit.push_back(fit_slope([&](std::size_t k) { return loss[k]; }));
  }
  auto mean_err = [](const std::vector<double>& x) {
    double m = 0;
    for (double v : x) m += v;
    m /= x.size();
    double s = 0;
    for (double v : x) s += (v - m) * (v - m);
    return std::pair{m, std::sqrt(s / (x.size() - 1) / x.size())};
  };
  const auto [du, du_err] = mean_err(du_fit);
  const auto [dT, dT_err] = mean_err(dT_fit);
  const auto [in, in_err] = mean_err(in_fit);
  const auto [ls, ls_err] = mean_err(loss_fit);
  const double loss_ref = 0.5 * n * L, loss_ref_err = 0.5 * n * L_err;
  RecordProperty("du_dt_dsmc", std::to_string(du) + " +- " + std::to_string(du_err));
  RecordProperty("du_dt_reference", std::to_string(du_ref));
  RecordProperty("dT_dt_dsmc", std::to_string(dT) + " +- " + std::to_string(dT_err));
  RecordProperty("dT_dt_reference", std::to_string(dT_ref));
  std::printf("du/dt: DSMC %.5f +- %.5f, reference %.5f +- %.5f\n", du, du_err, du_ref, du_ref_err);
  std::printf("dT/dt: DSMC %.5f +- %.5f, reference %.5f +- %.5f\n", dT, dT_err, dT_ref, dT_ref_err);
  std::printf("bath energy input rate: DSMC %.5f +- %.5f, reference %.5f +- %.5f\n", in, in_err, dE_ref, dE_ref_err);
  std::printf("inelastic loss rate: DSMC %.5f +- %.5f, reference %.5f +- %.5f\n", ls, ls_err, loss_ref, loss_ref_err);
  // 4 sigma of the combined standard errors, plus 0.2 % for the fit's quartic truncation
  // (measured below one standard error with 48 replicas)
  EXPECT_NEAR(du, du_ref, 4 * std::hypot(du_err, du_ref_err) + 0.002 * std::abs(du_ref));
  EXPECT_NEAR(dT, dT_ref, 4 * std::hypot(dT_err, dT_ref_err) + 0.002 * std::abs(dT_ref));
  EXPECT_NEAR(in, dE_ref, 4 * std::hypot(in_err, dE_ref_err) + 0.002 * std::abs(dE_ref));
  EXPECT_NEAR(ls, loss_ref, 4 * std::hypot(ls_err, loss_ref_err) + 0.002 * std::abs(loss_ref));
}

// 4. Free cooling: Haff's law with the van Noije-Ernst a2 (d = 3), computed here, and the
//    homogeneous cooling state's a2 and a3 against the second Sonine approximation
//    (closures::hcs_sonine2_linear, docs/closures.md Sec. H) within its truncation allowance
//    (closures::hcs_sonine_linear up to K = 6) plus 4 measured standard deviations of this
//    run's window means (docs/dsmc.md D4).
struct FreeCoolingCase {
  double e;
  // seed-to-seed standard deviations of this run's a2 and a3 window means at these settings
  // (3e6 grains, dt = 0.04, t = 6..20; h-cool, 2026-12-06), measured: e = 0.8, 24 seeds
  // (101-124): a2 0.000193 +- 0.000028, a3 0.000167 +- 0.000025; e = 0.6, 32 seeds (101-132):
  // a2 0.000301 +- 0.000038, a3 0.000332 +- 0.000042
  double sigma_a2, sigma_a3;
};
void PrintTo(const FreeCoolingCase& c, std::ostream* os) { *os << "e = " << c.e; }  // ctest's test list
class FreeCooling : public ::testing::TestWithParam<FreeCoolingCase> {};
TEST_P(FreeCooling, HaffLawAndSecondSonineA2) {
  const double e = GetParam().e, n = 1.0, m = 1.0, T0 = 1.0;
  const double a2_vne = 16 * (1 - e) * (1 - 2 * e * e) / (81 - 17 * e + 30 * e * e * (1 - e));
  const double zeta = 4 * n * (1 - e * e) / (3 * std::sqrt(std::numbers::pi * m)) * (1 + 3 * a2_vne / 16);
  // 3e6 grains: one run's a2 must resolve the vNE discrepancy (0.0015 at e = 0.8) with room
  // to spare (below); dt = 0.04 (0.09 collisions per grain and step at T = 1) gives the a2 of
  // dt = 0.01 (32 seeds of 2e5: -0.01427 +- 0.00011 and -0.01435 +- 0.00013); the window starts
  // at t = 6, ~10 collisions per grain, after the transient from the Maxwellian start: the
  // window mean from t = 6 is 0.00002 +- 0.00001 above the one from t = 8 (24 seeds at these
  // settings), from t = 4 0.00006 +- 0.00002, for one run's scatter 0.00019 either way
  const std::string toml = grainbath::testing::free_cooling_case(e, 3000000, 0.04, 20.0, 0.2, 6.0);
  const auto run = run_dsmc(toml, 77);
  const auto t = run.series("/timeseries/t");
  const auto T = run.series("/timeseries/temperature");
  double worst = 0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    const double x = 1 + 0.5 * zeta * std::sqrt(T0) * t[k];
    worst = std::max(worst, std::abs(T[k] / (T0 / (x * x)) - 1));
  }
  const double a2 = run.summary.number("a2.mean"), a3 = run.summary.number("a3.mean");
  const auto s2 = grainbath::closures::hcs_sonine2_linear(e);
  // truncation allowance: the hull of the linear Sonine series K = 3..6 (docs/closures.md
  // Sec. H.8), which converges at e >= 0.6: a2 at e = 0.8 [-0.014319, -0.014082], e = 0.6
  // [0.020774, 0.021459]; a3 at e = 0.8 [-0.005284, -0.004730], e = 0.6 [-0.007964, -0.007014]
  double lo2 = s2.a2, hi2 = s2.a2, lo3 = s2.a3, hi3 = s2.a3;
  for (int K = 4; K <= 6; ++K) {
    const std::vector<double> aK = grainbath::closures::hcs_sonine_linear(e, K);
    lo2 = std::min(lo2, aK[0]), hi2 = std::max(hi2, aK[0]);
    lo3 = std::min(lo3, aK[1]), hi3 = std::max(hi3, aK[1]);
  }
  const double lo = lo2 - 4 * GetParam().sigma_a2, hi = hi2 + 4 * GetParam().sigma_a2;
  const double lo_a3 = lo3 - 4 * GetParam().sigma_a3, hi_a3 = hi3 + 4 * GetParam().sigma_a3;
  const double d = a2_vne - s2.a2;
  std::printf("e = %.2f: T(t_end) = %.6f, worst |T/T_Haff - 1| = %.4f; a2 = %.5f (vNE %.5f, second Sonine %.5f, "
              "accepted [%.5f, %.5f]; a theory shifted by %.5f is rejected if a2 is in (%.5f, %.5f)); a3 = %.5f "
              "(second Sonine %.5f, accepted [%.5f, %.5f])\n",
              e, T.back(), worst, a2, a2_vne, s2.a2, lo, hi, std::abs(d), hi - std::abs(d), lo + std::abs(d), a3, s2.a3,
              lo_a3, hi_a3);
  EXPECT_LT(T.back(), 0.4 * T0);  // it really cooled
  EXPECT_LT(worst, 0.005);
  EXPECT_GE(a2, lo);
  EXPECT_LE(a2, hi);
  // sharp enough: a theory (or a DSMC) off by the first-Sonine discrepancy, either way, fails.
  // A property of the run: a2 must fall in (hi - |d|, lo + |d|), at e = 0.8 (-0.014815,
  // -0.013586), 2.5 and 3.8 sigma from the replicas' mean -0.014326 (about 0.6 % of seeds would
  // miss it; with the former 2e6 grains (-0.014707, -0.013694), 2.05 and 2.55 sigma from
  // -0.014256: 2.5 %). At e = 0.6 |d| = 0.0031 leaves far more room.
  EXPECT_TRUE(a2 < lo - std::abs(d) || a2 > hi - std::abs(d)) << "a theory lower by |vNE - Sonine2| would pass";
  EXPECT_TRUE(a2 < lo + std::abs(d) || a2 > hi + std::abs(d)) << "a theory higher by |vNE - Sonine2| would pass";
  // a3, the sixth moment (src/dsmc/moments.cpp, eq. H2), likewise; and the first Sonine ansatz
  // (a3 = 0) is rejected by the same 4 sigma (measured a3 -0.00529 +- 0.00017 per run at e = 0.8)
  EXPECT_GE(a3, lo_a3);
  EXPECT_LE(a3, hi_a3);
  EXPECT_LT(a3 + 4 * GetParam().sigma_a3, 0.0) << "a3 = 0 would pass";
}
// e = 0.6, 32 seeds (101-132) at the test's settings: a2 0.000301 +- 0.000038, a3 0.000332 +- 0.000042
INSTANTIATE_TEST_SUITE_P(Restitution, FreeCooling,
                         ::testing::Values(FreeCoolingCase{0.8, 0.000193, 0.000167}, FreeCoolingCase{0.6, 0.000301, 0.000332}),
                         [](const auto& info) { return info.param.e == 0.8 ? "e08" : "e06"; });

// 4b. Free cooling does not depend on the time step (docs/dsmc.md D4, "The time step in free
//     cooling"). Within a step each collision group runs NTC against a bound kept valid
//     through the step: the group's Kac jump process over dt, every candidate on the current
//     velocities, so the Boltzmann evolution has no O(dt) term; dt enters only through how
//     long a group stays together, O(nu dt / N_g). T(t) at dt = 0.5 (about one collision per
//     grain and step at T = 1: 4 steps to t = 2) against dt = 0.025 (80 steps), 8 seeds of
//     5e5 grains each (2 s), within 4 sigma of the measured seed-to-seed scatter (24 seeds of 5e5 per
//     dt, h-dt 2026-12-06: sd of one run's T 0.00034, 0.00038, 0.00040 at t = 0.5, 1, 2, at
//     either dt; the 24-seed means differ by -0.00007 +- 0.00009, -0.00015 +- 0.00011,
//     -0.00012 +- 0.00011). Tolerance 0.13 % of T at t = 2; the O(dt) error once suspected
//     (T(2) 0.05 % lower at dt = 0.04 than at 0.01) would be -0.8 % at dt = 0.5 (checked: the
//     candidates scaled by 1 + 0.04 dt, which makes it, fail here), and a state labelled one
//     step off is 12 % off at t = 0.5.
TEST(DsmcPhysics, FreeCoolingDoesNotDependOnTheTimeStep) {
  const double times[] = {0.5, 1.0, 2.0};
  const double sd_one_run[] = {0.00035, 0.00038, 0.00040};  // measured, 5e5 grains (above)
  const int seeds = 8;
  auto mean_T = [&](double dt) {
    const std::string toml = grainbath::testing::free_cooling_case(0.8, 500000, dt, 2.0, 0.5, 1.0);
    std::vector<double> sum(std::size(times), 0.0);
    for (int seed = 1; seed <= seeds; ++seed) {
      const auto run = run_dsmc(toml, seed, 0, "dt-scan");
      const auto t = run.series("/timeseries/t");
      const auto T = run.series("/timeseries/temperature");
      std::filesystem::remove_all(run.dir);
      for (std::size_t k = 0; k < std::size(times); ++k) {
        std::size_t i = 0;
        while (i < t.size() && std::abs(t[i] - times[k]) > 1e-9) ++i;
        EXPECT_LT(i, t.size()) << "dt = " << dt << ": no sample at t = " << times[k];
        if (i < t.size()) sum[k] += T[i] / seeds;
      }
    }
    return sum;
  };
  const auto coarse = mean_T(0.5), fine = mean_T(0.025);
  for (std::size_t k = 0; k < std::size(times); ++k) {
    const double tol = 4 * sd_one_run[k] * std::sqrt(2.0 / seeds);
    std::printf("t = %.1f: T = %.6f (dt = 0.5), %.6f (dt = 0.025), difference %+.6f (%+.1f sigma), tolerance %.6f\n",
                times[k], coarse[k], fine[k], coarse[k] - fine[k], (coarse[k] - fine[k]) / (tol / 4), tol);
    EXPECT_NEAR(coarse[k], fine[k], tol) << "t = " << times[k];
  }
}

// 5. Steady state with a bath (delta = 0.2) vs the root of Bisi-Spiga eq. 27 (the
//    local-Maxwellian energy balance at u = uB), re-derived here from the collision rule:
//    bath exchange = inelastic loss for Maxwellian grains, both in closed form through the
//    Gaussian moments <|g|^y>, and solved by bisection (independent of closures/).
TEST(DsmcPhysics, SteadyTemperatureNearMaxwellianClosureRoot) {
  const double alpha = 0.5, beta = 0.1, delta = 0.2, eps = 0.1, m = 1.0, TB = 1.0, n = 1.0, nB = 1.0;
  const double mB = alpha * m / (1 - alpha);
  // Maxwellian grains at T, u = uB: relative velocity g Gaussian with variance s^2 = T/m + TB/mB
  // per component. Energy exchange per grain (from the weak form with the apse averages):
  //   K <|g| (m/2)(-2 alpha v.g + 2 alpha^2 g^2)>; with v = uB + c, <|g| c.g> over the joint
  //   Gaussian = (T/m)/s^2 <|g|^3>, and <|g|^3> = 8 sqrt(2/pi) s^3.
  // Inelastic loss per grain for Maxwellian grains (variance 2T/m per component of g):
  //   (n/2) <|g|^3 mu^2 (m/4)(1 - e^2)> with mu density 2 mu, e = 1 - 2 beta (g mu)^delta.
  auto g_moment = [](double y, double var) {  // <|g|^y> for a 3D Gaussian, variance var per component
    return std::pow(2 * var, y / 2) * std::tgamma((y + 3) / 2) / std::tgamma(1.5);
  };
  auto balance = [&](double T) {
    const double s2 = T / m + TB / mB;
    const double g3 = g_moment(3, s2);
    const double exchange = (nB / eps) * 0.5 * m * (-2 * alpha * (T / m) / s2 * g3 + 2 * alpha * alpha * g3);
    // loss: (n/2)(m/4) <|g|^3 mu^2 (1 - e^2)>, 1 - e^2 = 4 b x - 4 b^2 x^2 with x = (g mu)^delta
    // <mu^{2+k} 2 mu> = 2/(4 + k)
    const double var = 2 * T / m;
    const double t1 = 4 * beta * g_moment(3 + delta, var) * 2 / (4 + delta);
    const double t2 = 4 * beta * beta * g_moment(3 + 2 * delta, var) * 2 / (4 + 2 * delta);
    const double loss = (n / 2) * (m / 4) * (t1 - t2);
    return exchange - loss;
  };
  double lo = 0.5, hi = TB;  // balance(lo) > 0 (bath heats), balance(TB) < 0 (only loss)
  ASSERT_GT(balance(lo), 0);
  ASSERT_LT(balance(hi), 0);
  for (int k = 0; k < 200; ++k) {
    const double mid = 0.5 * (lo + hi);
    (balance(mid) > 0 ? lo : hi) = mid;
  }
  const double T_root = 0.5 * (lo + hi);
  const auto run = run_dsmc(bath_case(alpha, beta, delta, eps, TB, 35.0, 80000, 0.01, 3.0), 2026);
  const double T = run.summary.number("temperature.mean"), err = run.summary.number("temperature.stderr");
  const double gap = TB - T_root;
  std::printf("steady T: DSMC %.6f +- %.6f, eq. 27 root %.6f: difference %.2f%% of (TB - T#)\n", T, err, T_root,
              100 * (T - T_root) / gap);
  EXPECT_LT(err, 0.05 * gap / 2);  // the statistics resolve the 5% criterion (2 sigma)
  EXPECT_LT(std::abs(T - T_root), 0.05 * gap);
  // the closures library's root agrees with this independent one
  EXPECT_NEAR(run.summary.number("theory.equilibrium.maxwellian.T"), T_root, 1e-9);
}

// 6. The bath with heavy grains (m = 2.5) and alpha != 1/2: every other bath check of the
//    driver runs at m = 1, where passing the unit mass for the grain's (BackgroundState)
//    is harmless, and the closure checks at alpha = 1/2, where mB = m and alpha <-> 1 - alpha
//    are invisible. Elastic grains started at TB stay Maxwellian at TB and meet the
//    medium at the mean rate K <|v - w|> (K = nB/eps) of two Maxwellians at TB:
//    <|g|> = sqrt(8 TB (1/m + 1/mB) / pi), with mB = alpha m / (1 - alpha) from
//    alpha = mB / (m + mB) (Bisi-Spiga eq. 2); re-derived here, not the code's background_mass.
TEST(DsmcPhysics, BathCollisionRateOfHeavyGrainsIsTheMeanRelativeSpeed) {
  const double m = 2.5, alpha = 0.3, TB = 1.0, nB = 1.0, eps = 0.5, t_end = 4.0;
  const int N = 20000;
  const double mB = alpha * m / (1 - alpha);
  const double mean_g = std::sqrt(8 * TB * (1 / m + 1 / mB) / std::numbers::pi);
  const double expected = N * (nB / eps) * mean_g * t_end;
  // twice: the homogeneous bath (the driver's uniform state) and the per-grain local medium of a
  // spatial run (src/dsmc/spatial.cpp local_background; an isobaric_sine profile of amplitude 0
  // is uniform in law but takes that path): each builds the bath with the grain mass
  for (const char* domain : {"", R"(
[domain]
dimensions = 1
length = [4.0]
cells = [16]
boundaries = ["periodic", "periodic"]
)"}) {
  const bool spatial = *domain != '\0';
  SCOPED_TRACE(spatial ? "spatial run, local medium" : "homogeneous bath");
  char toml[1400];
  std::snprintf(toml, sizeof toml, R"(%s
[grains]
density = 1.0
mass = %.17g
temperature = %.17g
[background]
mass_ratio = %.17g
density = %.17g
temperature = %.17g
knudsen = %.17g
%s
[restitution]
law = "elastic"
[dsmc]
particles = %d
dt = 0.02
t_end = %.17g
[sampling]
every = 0.5
steady_from = 0.5
relaxation_theory = false
)",
                domain, m, TB, alpha, nB, TB, eps, spatial ? "profile = \"isobaric_sine\"" : "", N, t_end);
  // four seeds: the scatter of the count measures its error (a grain's count is not Poisson:
  // fast grains stay fast for a few collisions)
  std::vector<double> ratio;
  double T = 0, Terr = 0;
  for (std::uint64_t seed : {31, 32, 33, 34}) {
    const auto run = run_dsmc(toml, seed, 0, "heavy");
    ratio.push_back(run.summary.number("counters.bath_collisions") / expected);
    T += run.summary.number("temperature.mean") / 4;
    Terr += run.summary.number("temperature.stderr") / 4;
  }
  double mean = 0, var = 0;
  for (double r : ratio) mean += r / ratio.size();
  for (double r : ratio) var += (r - mean) * (r - mean) / (ratio.size() - 1);
  const double sem = std::sqrt(var / ratio.size());
  std::printf("heavy grains in the bath: collisions / N K <|g|> t = %.5f +- %.5f (Poisson alone %.5f), T = %.4f\n", mean,
              sem, 1 / std::sqrt(4 * expected), T);
  // 5 standard errors, the error taken as at least twice the Poisson one (4 seeds give a
  // rough estimate of the scatter)
  EXPECT_NEAR(mean, 1.0, 5 * std::max(sem, 2 / std::sqrt(4 * expected)));
  EXPECT_NEAR(T, TB, 5 * Terr + 1e-3);
  }
}

// Issue #3 validation 3: the closures' relaxation ODEs against the DSMC transient from a
// drifting hot start (u - uB = 1, T = 2; alpha = 0.5, eps = 0.1, beta = 0.2, delta = 0.2).
// Deviations are measured relative to the size of the transient: |u0 - uB| for u and
// (T0 - T#) for T. The DSMC noise (3e-3 in T per sample at 1e5 grains) is part of the
// tolerance.
TEST(DsmcPhysics, RelaxationFollowsTheClosures) {
  const auto run = run_dsmc(R"(
[grains]
temperature = 2.0
drift = [1.0, 0.0, 0.0]
[background]
mass_ratio = 0.5
density = 1.0
temperature = 1.0
knudsen = 0.1
[restitution]
law = "power"
beta = 0.2
delta = 0.2
[dsmc]
particles = 100000
dt = 0.002
t_end = 1.0
[sampling]
every = 0.01
steady_from = 0.5
)",
                            17, 0, "relax");
  const auto T = run.series("/timeseries/temperature");
  const auto u = run.series("/timeseries/velocity");
  const double T_eq = run.summary.number("theory.equilibrium.sonine.T");
  const double scale_T = 2.0 - T_eq;
  for (const char* closure : {"maxwellian", "grad", "sonine"}) {
    const auto Tc = run.series(std::string("/theory/") + closure + "/temperature");
    const auto uc = run.series(std::string("/theory/") + closure + "/velocity");
    double worst_T = 0, worst_u = 0;
    for (std::size_t k = 0; k < T.size(); ++k) {
      worst_T = std::max(worst_T, std::abs(T[k] - Tc[k]) / scale_T);
      worst_u = std::max(worst_u, std::abs(u[3 * k] - uc[3 * k]));
    }
    std::printf("relaxation, %s closure: worst |dT|/(T0 - T#) = %.4f, worst |du|/|u0 - uB| = %.4f\n", closure, worst_T,
                worst_u);
    RecordProperty(std::string(closure) + "_worst_T", std::to_string(worst_T));
    // single-sample noise: u: sqrt(T/(m N)) <= 0.0045; T/(T0 - T#): T sqrt(2/(3N)) / 1.04 <= 0.005.
    // Maxwellian and Sonine closures carry the exact Gaussian friction (docs/closures.md C5):
    // within 5 sigma of one sample everywhere. The Grad closure (linear in the drift about
    // the background Maxwellian) is measured ~7% off in u and T here: bounded, not matched.
    const std::string name = closure;
    if (name == "grad") {
      EXPECT_LT(worst_u, 0.10) << closure;
      EXPECT_LT(worst_T, 0.10) << closure;
    } else {
      EXPECT_LT(worst_u, 0.0225) << closure;
      EXPECT_LT(worst_T, 0.025) << closure;
    }
  }
}
