#pragma once
// Runs an EDMD case given as TOML text through the driver into a temporary directory and
// returns its summary, and the event-free MC's steady R at the same Walton parameters
// (tests/edmd/rough_test.cpp, rough_long_test.cpp).
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "closures/rough.hpp"
#include "core/case_file.hpp"
#include "core/run_context.hpp"
#include "core/summary.hpp"
#include "edmd/edmd.hpp"
#include "tests/rough/driven_mc.hpp"

namespace grainbath::rough_test {

// A driven dilute rough gas: e = 0.95, beta0 = 1, q = 2/5, white-noise kicks of 0.185 per
// collision (as cases/rough-driven); mu >= 1e12 stands for no sliding.
inline std::string driven_rough_case(int dims, int particles, double phi, double temperature, double trot,
                                     double equilibrate, double collisions, double mu) {
  char toml[768];
  std::snprintf(toml, sizeof toml, R"(
[edmd]
dimensions = %d
particles = %d
packing_fraction = %g
temperature = %g
rotational_temperature = %g
equilibrate = %g
collisions = %g
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
                dims, particles, phi, temperature, trot, equilibrate, collisions, std::isfinite(mu) ? mu : 1e12);
  return toml;
}

inline Summary run_edmd_summary(const std::string& toml, std::uint64_t seed, const std::string& tag) {
  namespace fs = std::filesystem;
  CaseReader reader(toml, "/tmp/" + tag + ".toml");
  edmd::Config cfg = edmd::read_config(reader);
  reader.finish();
  RunContext ctx;
  ctx.out_dir = fs::temp_directory_path() / ("grainbath-edmd-" + tag + "-" + std::to_string(::getpid()));
  fs::remove_all(ctx.out_dir);
  fs::create_directories(ctx.out_dir);
  ctx.seed = seed;
  ctx.quiet = true;
  ctx.case_text = toml;
  ctx.resolved = reader.resolved();
  Summary s;
  edmd::run(cfg, ctx, s);
  fs::remove_all(ctx.out_dir);
  return s;
}

struct McSteady {
  double R, R_se, Ttr, R_E;  // R over the window, its error (20 blocks), Ttr, model E's R
};

// The event-free MC (tests/rough/driven_mc.hpp; no positions: exact molecular chaos) at e =
// 0.95, beta0 = 1, q = 2/5 and the given mu, N = 2000, time step dt: 30 time units of
// relaxation from model E's R, then R over `span` (samples every 0.5, 20 blocks). R does not
// depend on G, H (docs/rough.md R11), so G = 1 and H giving Ttr ~ 1. Its 20-block error
// matches the scatter over 24 seeds (1.01 +- 0.15 at mu = 0.5, 1.24 +- 0.18 at mu = inf;
// docs/validation/rough.md). R carries an O(dt) bias: +0.034 dt at mu = 0.5.
inline McSteady mc_steady(double mu, double dt, double span, unsigned long seed) {
  DrivenMcConfig cfg{WaltonRestitution{0.95, 1.0, mu}, 0.4, 1.0, 0.0, 2000, seed};
  closures::rough::Parameters p{0.95, 1.0, std::isfinite(mu) ? mu : 1e300, 0.4, 1.0, 1.0};
  const closures::rough::SteadyState th = closures::rough::steady_state(closures::rough::Model::E, p);
  cfg.H = std::pow(th.Ttr, -1.5);  // steady Ttr near 1 (Ttr ~ H^{2/3})
  DrivenMc mc(cfg, 1.0, th.R);
  while (mc.time() < 30.0) mc.step(dt);
  std::vector<double> tr, rot;
  while (mc.time() < 30.0 + span) {
    for (int k = 0; k < static_cast<int>(0.5 / dt + 0.5); ++k) mc.step(dt);
    tr.push_back(mc.Ttr());
    rot.push_back(mc.Trot());
  }
  const int blocks = 20;
  const std::size_t per = tr.size() / blocks;
  std::vector<double> b;
  double m = 0, sa = 0, sb = 0;
  for (int k = 0; k < blocks; ++k) {
    double x = 0, y = 0;
    for (std::size_t i = k * per; i < (k + 1) * per; ++i) x += tr[i], y += rot[i];
    b.push_back(y / x);
    m += y / x, sa += x, sb += y;
  }
  m /= blocks;
  double v = 0;
  for (double x : b) v += (x - m) * (x - m);
  return {sb / sa, std::sqrt(v / (blocks - 1) / blocks), sa / (per * blocks), th.R};
}

}  // namespace grainbath::rough_test
