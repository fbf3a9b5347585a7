// Driven rough spheres in 3D (label "long", about 1.5 min): the EDMD steady Trot/Ttr against
// the 3D mean-field models (closures/rough, docs/rough.md R15-R16), which elsewhere are only
// checked through their right-hand sides. Dilute (phi = 0.05, N = 4096), e = 0.95, beta0 = 1,
// q = 2/5, white-noise kicks 0.185 per collision. Tolerance: 4 SE + 5 % of model E, the
// Gaussian-closure allowance of the 2D driven MC test (tests/rough/test_driven_mc.cpp;
// docs/validation/rough.md). Models B, C, D are printed: in 3D the allowance does not
// separate them all from E (measured: C is 4 % above the EDMD at mu = 0.5, D 2 % below at 0.1).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "core/case_file.hpp"
#include "core/run_context.hpp"
#include "core/summary.hpp"
#include "edmd/edmd.hpp"

namespace fs = std::filesystem;
using namespace grainbath;

class RoughEdmd3D : public ::testing::TestWithParam<double> {};

TEST_P(RoughEdmd3D, SteadyRatioMatchesModelE) {
  const double mu = GetParam();
  char toml[768];
  std::snprintf(toml, sizeof toml, R"(
[edmd]
dimensions = 3
particles = 4096
packing_fraction = 0.05
temperature = 0.35
rotational_temperature = 0.2
equilibrate = 40
collisions = 300
[restitution]
law = "walton"
e = 0.95
beta0 = 1.0
mu = %g
q = 0.4
[heating]
model = "white_noise"
kick = 0.185
[sampling]
interval = 0.5
)",
                mu);
  CaseReader reader(toml, "/tmp/rough3d.toml");
  edmd::Config cfg = edmd::read_config(reader);
  reader.finish();
  RunContext ctx;
  ctx.out_dir = fs::temp_directory_path() / ("grainbath-edmd-rough3d-" + std::to_string(::getpid()));
  fs::remove_all(ctx.out_dir);
  fs::create_directories(ctx.out_dir);
  ctx.seed = 5;
  ctx.quiet = true;
  ctx.case_text = toml;
  ctx.resolved = reader.resolved();
  Summary s;
  edmd::run(cfg, ctx, s);
  fs::remove_all(ctx.out_dir);
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
