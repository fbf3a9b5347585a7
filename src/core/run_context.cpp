#include "core/run_context.hpp"

#include "core/h5.hpp"

namespace grainbath {

void write_provenance(H5File& file, const RunContext& ctx, const std::string& solver) {
  file.attribute("/", "grainbath_version", std::string(GRAINBATH_VERSION));
  file.attribute("/", "solver", solver);
  file.attribute("/", "seed", std::to_string(ctx.seed));
  file.write_string("/case/case.toml", ctx.case_text);
  // run.threads decides only the speed (summary.json performance.threads says what was used):
  // left out, so that results.h5 is a function of case and seed alone, byte for byte (cmp)
  for (const auto& [key, value] : ctx.resolved)
    if (key != "run.threads") file.attribute("/parameters", key, value);
}

}  // namespace grainbath
