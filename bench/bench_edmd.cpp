// EDMD-1 (issue #7): collisions per second per core (single thread), elastic grains, the
// lattice start melted by 5 collisions per particle before timing; hard spheres
// phi = 0.3, 0.45 at N = 1e4, 1e5 and hard disks nu = 0.5, 0.7 at N = 1e4, 1e6.
// Counters: collisions_per_second (per CPU second: Google Benchmark's rate),
// collisions_per_wall_second, events_per_collision, peak_rss_MiB (the process's peak
// resident set: run one configuration per process, as scripts/bench-edmd.sh does, for a
// per-configuration figure), bytes_per_particle (peak RSS / N, including the
// executable and libraries). Results and the exact commands: docs/performance/edmd.md.
//   build/bench/bench_edmd --benchmark_filter='spheres_phi0.30/100000' --benchmark_repetitions=3
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <chrono>

#include "edmd/edmd.hpp"

using namespace grainbath;
using namespace grainbath::edmd;

namespace {

double peak_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

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
  const std::uint64_t events0 = eng.counters().events;
  std::uint64_t done = 0;
  double wall = 0.0;
  for (auto _ : state) {
    target += chunk;
    const auto t0 = std::chrono::steady_clock::now();
    eng.advance(ElasticRestitution{}, kInf, target);
    wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    done += chunk;
  }
  state.counters["collisions_per_second"] = benchmark::Counter(static_cast<double>(done), benchmark::Counter::kIsRate);
  state.counters["collisions_per_wall_second"] = wall > 0 ? static_cast<double>(done) / wall : 0.0;
  state.counters["events_per_collision"] =
      static_cast<double>(eng.counters().events - events0) / static_cast<double>(done);
  const double rss = peak_rss_mib();
  state.counters["peak_rss_MiB"] = rss;
  state.counters["bytes_per_particle"] = rss * 1024.0 * 1024.0 / static_cast<double>(n);
}

}  // namespace

BENCHMARK_CAPTURE(BM_Edmd, spheres_phi0.30, 3, 0.30)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Edmd, spheres_phi0.45, 3, 0.45)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Edmd, disks_nu0.50, 2, 0.50)->Arg(10000)->Arg(1000000)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Edmd, disks_nu0.70, 2, 0.70)->Arg(10000)->Arg(1000000)->Unit(benchmark::kMillisecond)->MinTime(2.0);

BENCHMARK_MAIN();
