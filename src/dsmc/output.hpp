#pragma once
#include <string>
#include <vector>

#include "core/run_context.hpp"
#include "core/summary.hpp"
#include "dsmc/dsmc.hpp"
#include "dsmc/moments.hpp"
#include "dsmc/state.hpp"

namespace grainbath::dsmc {

class Decomposition;

// What results.h5 and summary.json take from the grains themselves (no per-grain array is
// written): the final moments, the velocity histograms and the state hash. Collective:
// every rank works on its own grains and only sums travel (moments in blocks of the global
// order, counts and the hash's 64-bit sums, exact in any order), so that the numbers are
// those of one process holding every grain, and rank 0 needs none of the others' grains.
struct FinalGrains {
  Moments moments;                       // measure_moments of the whole population
  std::vector<double> edges, speed_edges;
  std::vector<double> components, speed; // normalised histograms
  std::uint64_t count = 0;
  std::string hash;                      // summary.json state.hash
};
FinalGrains final_grains(const Config& c, const State& s, const Decomposition& dec);

// Wall-clock seconds of a run's parts (summary.json performance.*, docs/OUTPUT.md): the whole
// run, and the step loop alone (every step with its in-loop sampling, progress line and
// checkpoints; not the set-up before the first step nor the final reduction), which is what
// LAMMPS and SPARTA report as "Loop time" and what their per-step figures are based on.
struct RunTimes {
  double wall = 0.0;   // from the start of the run to the end of the final reduction
  double setup = 0.0;  // initialisation or checkpoint read, distribution, first sort, first sample
  double loop = 0.0;   // the steps
};

// Whether dt and the cells resolve what they must (docs/dsmc.md "Time step"; Bird 1994,
// Sec. 11.1): the bath substeps are exact in distribution, so dt need only resolve the
// grain-grain collisions and the streaming, and a cell should be smaller than the grains'
// mean free path. Measured from the run itself: `grain_collisions` over `steps` steps of
// `grains` grains at mean temperature `temperature`.
struct Resolution {
  double collisions_per_grain_step = 0.0;  // grain-grain collisions each grain takes part in per step
  double mean_speed = 0.0;                 // sqrt(8 T / (pi m)): the mean speed of a Maxwellian
  double mean_free_path = 0.0;             // mean_speed / collision rate per grain (0: no collision)
  double cell_size = 0.0;                  // the largest cell side (0: homogeneous)
  double travel_per_step = 0.0;            // mean_speed dt, in cell sides (0: homogeneous)
  std::vector<std::string> warnings;       // one sentence each, with the figures and a remedy
};
Resolution resolution(const Config& c, std::uint64_t grain_collisions, std::int64_t steps, double grains,
                      double temperature);

// Statistics over the steady window, histograms, per-cell fields (+ XDMF), density-mode
// and profile fits, theory; writes OUT/results.h5 and fills the summary (docs/OUTPUT.md).
// `s`: everything but the grains (Decomposition::gather_cells; s.particles is not read).
void write_results(const Config& c, const RunContext& ctx, const State& s, const FinalGrains& grains,
                   const RunTimes& times, Summary& summary);

}  // namespace grainbath::dsmc
