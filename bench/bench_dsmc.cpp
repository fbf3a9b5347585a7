// DSMC benchmarks (Issue #7), timed over whole runs of the real driver:
//   DSMC-1  periodic 3D box of elastic hard spheres, no bath, 40^3 cells x 16 particles
//           (1,024,000), dt giving 0.1 collisions per particle per step, 200 steps
//           -- the configuration of SPARTA's standard collision benchmark;
//   DSMC-2  homogeneous bath, alpha = 0.5, eps = 0.01, delta = 0.2, 1e6 grains.
// Counters: ns per particle-step, collisions per second, background-collision tests per
// second and ns per test. Run: build/bench/bench_dsmc --benchmark_repetitions=3
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <filesystem>

#include "core/case_file.hpp"
#include "core/run_context.hpp"
#include "core/summary.hpp"
#include "dsmc/dsmc.hpp"

namespace {

grainbath::Summary run_case(const std::string& toml, int threads) {
  grainbath::CaseReader reader(toml, "bench.toml");
  auto cfg = grainbath::dsmc::read_config(reader);
  reader.finish();
  grainbath::RunContext ctx;
  ctx.out_dir = std::filesystem::temp_directory_path() / ("grainbath-bench-" + std::to_string(::getpid()));
  std::filesystem::create_directories(ctx.out_dir);
  ctx.seed = 1;
  ctx.threads = threads;
  ctx.quiet = true;
  ctx.case_text = toml;
  grainbath::Summary s;
  grainbath::dsmc::run(cfg, ctx, s);
  std::filesystem::remove_all(ctx.out_dir);
  return s;
}

// 0.1 collision events per particle per step: pair rate per particle (1/2) n <g>,
// <g> = sqrt(16 T / (pi m)) = 2.2568 at T = m = n = 1  ->  dt = 0.1 / 1.1284 = 0.08862.
const char* kDsmc1 = R"(
[domain]
dimensions = 3
length = [10.0, 10.0, 10.0]
cells = [40, 40, 40]
[grains]
temperature = 1.0
[background]
density = 0.0
[restitution]
law = "elastic"
[dsmc]
particles = 1024000
dt = 0.08862
t_end = 17.724
[sampling]
every = 17.724
steady_from = 0.0
relaxation_theory = false
fields = false
)";

const char* kDsmc2 = R"(
[grains]
temperature = 1.0
[background]
mass_ratio = 0.5
density = 1.0
temperature = 1.0
knudsen = 0.01
[restitution]
law = "power"
beta = 0.1
delta = 0.2
[dsmc]
particles = 1000000
dt = 0.01
t_end = 0.2
[sampling]
every = 0.2
steady_from = 0.0
relaxation_theory = false
)";

void report(benchmark::State& state, const grainbath::Summary& s, double particle_steps) {
  const double wall = s.number("performance.wall_seconds");
  state.SetIterationTime(wall);
  state.counters["ns_per_particle_step"] = 1e9 * wall / particle_steps;
  state.counters["collisions_per_s"] = s.number("counters.grain_collisions") / wall;
  state.counters["bath_tests_per_s"] = s.number("counters.bath_candidates") / wall;
  const double tests = s.number("counters.bath_candidates");
  if (tests > 0) state.counters["ns_per_bath_test"] = 1e9 * wall / tests;
  state.counters["collisions_per_particle_step"] = s.number("counters.grain_collisions") / particle_steps;
}

void BM_DSMC1_SpartaBox(benchmark::State& state) {
  for (auto _ : state) report(state, run_case(kDsmc1, static_cast<int>(state.range(0))), 1024000.0 * 200);
}
BENCHMARK(BM_DSMC1_SpartaBox)->Arg(1)->Arg(2)->UseManualTime()->Iterations(1)->Unit(benchmark::kSecond);

void BM_DSMC2_HomogeneousBath(benchmark::State& state) {
  for (auto _ : state) report(state, run_case(kDsmc2, static_cast<int>(state.range(0))), 1e6 * 20);
}
BENCHMARK(BM_DSMC2_HomogeneousBath)->Arg(1)->Arg(2)->UseManualTime()->Iterations(1)->Unit(benchmark::kSecond);

// STREAM-style triad a = b + s c over 3 x 32 MiB arrays: the single-core memory bandwidth
// the DSMC figures are measured against (Issue #7: "the distance to the hardware limit").
void BM_StreamTriad(benchmark::State& state) {
  const std::size_t n = 4u << 20;  // 4 Mi doubles = 32 MiB per array, far beyond L3
  std::vector<double> a(n, 0.0), b(n, 1.0), c(n, 2.0);
  const double s = 3.0;
  for (auto _ : state) {
    for (std::size_t i = 0; i < n; ++i) a[i] = b[i] + s * c[i];
    benchmark::DoNotOptimize(a.data());
    benchmark::ClobberMemory();
  }
  // 24 bytes moved per element (two reads, one write; write-allocate not counted, as STREAM)
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(n) * 24);
}
BENCHMARK(BM_StreamTriad)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
