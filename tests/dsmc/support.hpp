#pragma once
// Runs a DSMC case given as TOML text into a fresh temporary directory.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <string>
#include <unistd.h>

#include <gtest/gtest.h>

#include "core/case_file.hpp"
#include "core/h5.hpp"
#include "core/run_context.hpp"
#include "core/summary.hpp"
#include "dsmc/dsmc.hpp"

namespace grainbath::testing {

struct CaseRun {
  Summary summary;
  std::filesystem::path dir;
  std::vector<double> series(const std::string& name) const {
    H5File f((dir / "results.h5").string(), H5File::Mode::read);
    return f.read_doubles(name);
  }
};

inline CaseRun run_dsmc(const std::string& toml, std::uint64_t seed, int threads = 0,
                        const std::string& tag = "run", const std::filesystem::path& checkpoint_dir = {},
                        bool resume = false) {
  CaseReader reader(toml, "/tmp/test.toml");
  reader.accept("run", "solver");
  dsmc::Config cfg = dsmc::read_config(reader);
  reader.finish();
  CaseRun out;
  out.dir = std::filesystem::temp_directory_path() /
            ("grainbath-test-" + tag + "-" + std::to_string(::getpid()) + "-" + std::to_string(seed) + "-" +
             std::to_string(threads));
  std::filesystem::remove_all(out.dir);
  std::filesystem::create_directories(out.dir);
  RunContext ctx;
  ctx.out_dir = out.dir;
  ctx.seed = seed;
  ctx.threads = threads;
  ctx.quiet = true;
  ctx.case_text = toml;
  ctx.resolved = reader.resolved();
  ctx.checkpoint_dir = checkpoint_dir;
  ctx.resume = resume;
  dsmc::run(cfg, ctx, out.summary);
  return out;
}

// A number as TOML text, the shortest that reads back as the same double.
inline std::string toml_number(double x) {
  char b[32];
  const auto r = std::to_chars(b, b + sizeof b, x);
  std::string s(b, r.ptr);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";  // a float, not an integer
  return s;
}

// The physics of cases/free-cooling (homogeneous, no medium, constant restitution e, n = 1,
// T(0) = 1) with a run's size, step and sampling.
inline std::string free_cooling_case(double e, long particles, double dt, double t_end, double every,
                                     double steady_from) {
  return "[grains]\ndensity = 1.0\ntemperature = 1.0\n[background]\ndensity = 0.0\n[restitution]\n"
         "law = \"constant\"\ne = " + toml_number(e) + "\n[dsmc]\nparticles = " + std::to_string(particles) +
         "\ndt = " + toml_number(dt) + "\nt_end = " + toml_number(t_end) + "\n[sampling]\nevery = " +
         toml_number(every) + "\nsteady_from = " + toml_number(steady_from) + "\n";
}

// Every /fields dataset of two runs equal to 1e-12 (relative above 1): runs of one
// trajectory whose fields are summed in different groupings (batches, a resume).
inline void expect_same_fields(const CaseRun& a, const CaseRun& b) {
  for (const char* name : {"/fields/density", "/fields/temperature", "/fields/velocity", "/fields/pressure_tensor",
                           "/fields/heat_flux"}) {
    const std::vector<double> x = a.series(name), y = b.series(name);
    ASSERT_EQ(x.size(), y.size()) << name;
    for (std::size_t i = 0; i < x.size(); ++i)
      ASSERT_NEAR(x[i], y[i], 1e-12 * std::max(1.0, std::abs(y[i]))) << name << " [" << i << "]";
  }
}

}  // namespace grainbath::testing
