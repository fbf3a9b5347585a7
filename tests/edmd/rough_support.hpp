#pragma once
// Runs an EDMD case given as TOML text through the driver into a temporary directory and
// returns its summary (tests/edmd/rough_test.cpp, rough_long_test.cpp).
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "core/case_file.hpp"
#include "core/run_context.hpp"
#include "core/summary.hpp"
#include "edmd/edmd.hpp"

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

}  // namespace grainbath::rough_test
