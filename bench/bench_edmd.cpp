// EDMD throughput: collisions per second per core (single thread), elastic grains,
// equilibrated for 5 collisions per particle before timing. Results: docs/performance/edmd.md.
//   build-edmd/bench/bench_edmd --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include "edmd/edmd.hpp"

using namespace grainbath;
using namespace grainbath::edmd;

namespace {
void BM_Edmd(benchmark::State& state, int dims, double packing) {
  Config c;
  c.dims = dims;
  c.particles = state.range(0);
  c.packing_fraction = packing;
  const auto init = make_initial_state(c, 1);
  Engine eng(make_setup(c, 1), init.positions, init.velocities);
  const std::uint64_t n = static_cast<std::uint64_t>(c.particles);
  eng.advance(ElasticRestitution{}, kInf, 5 * n);  // melt the lattice
  const std::uint64_t chunk = 200000;
  std::uint64_t target = eng.counters().collisions;
  std::uint64_t done = 0;
  for (auto _ : state) {
    target += chunk;
    eng.advance(ElasticRestitution{}, kInf, target);
    done += chunk;
  }
  state.counters["collisions_per_second"] = benchmark::Counter(static_cast<double>(done), benchmark::Counter::kIsRate);
  state.counters["events_per_collision"] =
      static_cast<double>(eng.counters().events) / static_cast<double>(eng.counters().collisions);
}
}  // namespace

BENCHMARK_CAPTURE(BM_Edmd, disks_nu0.50, 2, 0.50)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Edmd, spheres_phi0.30, 3, 0.30)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Edmd, spheres_phi0.45, 3, 0.45)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->MinTime(2.0);

BENCHMARK_MAIN();
