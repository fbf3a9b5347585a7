// Driven rough spheres in 3D (label "long", about 1.5 min): the EDMD steady Trot/Ttr against
// the 3D mean-field models (closures/rough, docs/rough.md R15-R16), which elsewhere are only
// checked through their right-hand sides. Dilute (phi = 0.05, N = 4096), e = 0.95, beta0 = 1,
// q = 2/5, white-noise kicks 0.185 per collision. Tolerance: 4 SE + 5 % of model E, the
// Gaussian-closure allowance of the 2D driven MC test (tests/rough/test_driven_mc.cpp;
// docs/validation/rough.md). Models B, C, D are printed: in 3D the allowance does not
// separate them all from E (measured: C is 4 % above the EDMD at mu = 0.5, D 2 % below at 0.1).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

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
