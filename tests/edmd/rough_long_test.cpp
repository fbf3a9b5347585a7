// Driven rough spheres in 3D (label "long", about 1.5 min), and the 2D dilute limit against
// the event-free MC (below, about 6 min CPU): the EDMD steady Trot/Ttr against
// the 3D mean-field models (closures/rough, docs/rough.md R15-R16), which elsewhere are only
// checked through their right-hand sides. Dilute (phi = 0.05, N = 4096), e = 0.95, beta0 = 1,
// q = 2/5, white-noise kicks 0.185 per collision. Tolerance: 4 SE + 5 % of model E, the
// Gaussian-closure allowance of the 2D driven MC test (tests/rough/test_driven_mc.cpp;
// docs/validation/rough.md). Models B, C, D are printed: in 3D the allowance does not
// separate them all from E (measured: C is 4 % above the EDMD at mu = 0.5, D 2 % below at 0.1).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <utility>
#include <vector>

#include "tests/edmd/rough_support.hpp"

using namespace grainbath;

class RoughEdmd3D : public ::testing::TestWithParam<double> {};

TEST_P(RoughEdmd3D, SteadyRatioMatchesModelE) {
  const double mu = GetParam();
  const std::string toml = rough_test::driven_rough_case(3, 4096, 0.05, 0.35, 0.2, 40, 300, mu);
  const Summary s = rough_test::run_edmd_summary(toml, 5, "rough3d");
  auto get = [&](const std::string& k) { return std::get<double>(*s.get(k)); };
  const double R = get("rotation.R"), se = get("rotation.R_stderr"), RE = get("theory.model_E.R");
  std::printf("[measure] 3D mu=%g: R_EDMD = %.4f +- %.4f, model E %.4f (%+.2f%%), B %.4f, C %.4f, D %.4f; Ttr %.4f "
              "(model E %.4f)\n",
              mu, R, se, RE, 100 * (R / RE - 1), get("theory.model_B.R"), get("theory.model_C.R"), get("theory.model_D.R"),
              get("rotation.Ttr_mean"), get("theory.model_E.Ttr"));
  EXPECT_LT(se, 0.01 * R);
  EXPECT_NEAR(R, RE, 4.0 * se + 0.05 * RE);
}

INSTANTIATE_TEST_SUITE_P(Mu, RoughEdmd3D, ::testing::Values(0.1, 0.5, 1e12));

// The dilute limit, 2D (about 6 min CPU; 11 min wall on the loaded 2-core machine): the EDMD's steady R at mu = 0.5 (N = 2025,
// the default-tier RoughEdmdSteady case) at phi = 0.02, 0.05, 0.1, 16 seeds each, extrapolated
// linearly to phi = 0, against the event-free MC (exact molecular chaos, no positions)
// extrapolated linearly to dt = 0 from dt = 0.01, 0.02, 0.04, 0.1, 24 seeds each. Measured
// 2026-12-06: EDMD 0.5888 +- 0.0010 (slope -0.075 +- 0.016 per unit phi: the velocity
// correlations of a finite density lower R), MC 0.5872 +- 0.0003 (+0.034 dt): 1.6 combined SE
// apart. The default-tier test compares single runs at phi = 0.05, dt = 0.02, where both biases
// are below its errors. Tolerance: 4 combined SE of the two extrapolations, and the EDMD's
// phi slope must be negative by 2 SE (the finite-density effect the dilute limit removes).
namespace {
struct Line {
  double intercept, intercept_se, slope, slope_se;
};
// weighted least squares y = a + b x with the errors of the means
Line fit_line(const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& se) {
  double S = 0, Sx = 0, Sy = 0, Sxx = 0, Sxy = 0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    const double w = 1.0 / (se[k] * se[k]);
    S += w, Sx += w * x[k], Sy += w * y[k], Sxx += w * x[k] * x[k], Sxy += w * x[k] * y[k];
  }
  const double det = S * Sxx - Sx * Sx;
  return {(Sxx * Sy - Sx * Sxy) / det, std::sqrt(Sxx / det), (S * Sxy - Sx * Sy) / det, std::sqrt(S / det)};
}
// mean and standard error of the mean
std::pair<double, double> mean_se(const std::vector<double>& v) {
  double m = 0, s2 = 0;
  for (double x : v) m += x / v.size();
  for (double x : v) s2 += (x - m) * (x - m) / (v.size() - 1);
  return {m, std::sqrt(s2 / v.size())};
}
}  // namespace

TEST(RoughEdmdDiluteLimit, SteadyRatioExtrapolatesToTheEventFreeMonteCarlo) {
  const double mu = 0.5;
  std::vector<double> phis{0.02, 0.05, 0.1}, md_mean, md_se;
  for (double phi : phis) {
    std::vector<double> R;
    for (std::uint64_t seed = 1; seed <= 16; ++seed) {
      const std::string toml = rough_test::driven_rough_case(2, 2025, phi, 1.0, 0.6, 30, 150, mu);
      R.push_back(std::get<double>(*rough_test::run_edmd_summary(toml, seed, "rough-dilute").get("rotation.R")));
    }
    const auto [m, se] = mean_se(R);
    md_mean.push_back(m), md_se.push_back(se);
    std::printf("[measure] EDMD phi = %g: R = %.5f +- %.5f (16 seeds)\n", phi, m, se);
  }
  std::vector<double> dts{0.01, 0.02, 0.04, 0.1}, mc_mean, mc_se;
  for (double dt : dts) {
    std::vector<double> R;
    for (unsigned long seed = 1; seed <= 24; ++seed) R.push_back(rough_test::mc_steady(mu, dt, 300.0, seed).R);
    const auto [m, se] = mean_se(R);
    mc_mean.push_back(m), mc_se.push_back(se);
    std::printf("[measure] MC dt = %g: R = %.5f +- %.5f (24 seeds)\n", dt, m, se);
  }
  const Line md = fit_line(phis, md_mean, md_se), mc = fit_line(dts, mc_mean, mc_se);
  std::printf("[measure] R(phi -> 0) = %.5f +- %.5f (slope %.4f +- %.4f), MC R(dt -> 0) = %.5f +- %.5f (slope %.4f "
              "+- %.4f)\n",
              md.intercept, md.intercept_se, md.slope, md.slope_se, mc.intercept, mc.intercept_se, mc.slope, mc.slope_se);
  EXPECT_NEAR(md.intercept, mc.intercept, 4.0 * std::hypot(md.intercept_se, mc.intercept_se));
  EXPECT_LT(md.slope, -2.0 * md.slope_se);
}
