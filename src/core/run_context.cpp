#include "core/run_context.hpp"

#include "core/h5.hpp"

namespace grainbath {

void write_provenance(H5File& file, const RunContext& ctx, const std::string& solver) {
  file.attribute("/", "grainbath_version", std::string(GRAINBATH_VERSION));
  file.attribute("/", "solver", solver);
  file.attribute("/", "seed", std::to_string(ctx.seed));
  file.write_string("/case/case.toml", ctx.case_text);
  for (const auto& [key, value] : ctx.resolved) file.attribute("/parameters", key, value);
}

}  // namespace grainbath
