#pragma once
#include "core/run_context.hpp"
#include "core/summary.hpp"
#include "dsmc/dsmc.hpp"
#include "dsmc/state.hpp"

namespace grainbath::dsmc {

// Statistics over the steady window, histograms, per-cell fields (+ XDMF), density-mode
// and profile fits, theory; writes OUT/results.h5 and fills the summary (docs/OUTPUT.md).
void write_results(const Config& c, const RunContext& ctx, const State& s, double wall_seconds, Summary& summary);

}  // namespace grainbath::dsmc
