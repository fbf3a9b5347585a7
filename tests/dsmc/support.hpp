#pragma once
// Runs a DSMC case given as TOML text into a fresh temporary directory.
#include <filesystem>
#include <string>
#include <unistd.h>

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

}  // namespace grainbath::testing
