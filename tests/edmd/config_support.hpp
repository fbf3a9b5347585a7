#pragma once
// An EDMD case given as TOML text, read and checked the way the CLI reads case.toml (every
// key validated, misspelt keys rejected), for the tests in tests/edmd.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <unistd.h>

#include "core/case_file.hpp"
#include "core/summary.hpp"
#include "edmd/edmd.hpp"

namespace grainbath::edmd::testing {

inline Config config_from(const std::string& toml) {
  CaseReader r(toml, "test.toml");
  Config c = read_config(r);
  r.finish();
  return c;
}

// Runs the case as `grainbath run` does, into a scratch directory that is removed afterwards,
// and returns its summary. `tag` and the process id keep the directories of tests that run
// at the same time apart; `inspect`, if given, sees the output directory (results.h5) before
// it is removed.
inline Summary run_summary(const std::string& toml, std::uint64_t seed, const std::string& tag,
                           const std::function<void(const std::filesystem::path&)>& inspect = {}) {
  const Config c = config_from(toml);
  RunContext ctx;
  ctx.out_dir = std::filesystem::temp_directory_path() /
                (tag + "_" + std::to_string(::getpid()) + "_" + std::to_string(seed));
  std::filesystem::create_directories(ctx.out_dir);
  ctx.seed = seed;
  ctx.quiet = true;
  ctx.case_text = toml;
  Summary s;
  run(c, ctx, s);
  if (inspect) inspect(ctx.out_dir);
  std::filesystem::remove_all(ctx.out_dir);
  return s;
}

// Mean and standard error of the mean of independent values (seeds, or blocks long against
// the correlation time): the sample standard deviation over sqrt(n).
struct MeanSe {
  double mean, se;
};
inline MeanSe mean_se(const std::vector<double>& x) {
  double m = 0.0, ss = 0.0;
  for (double v : x) m += v / x.size();
  for (double v : x) ss += (v - m) * (v - m);
  return {m, std::sqrt(ss / (x.size() - 1.0) / x.size())};
}

}  // namespace grainbath::edmd::testing
