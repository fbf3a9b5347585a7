// DSMC benchmarks (Issue #7), timed over whole runs of the real driver:
//   DSMC-1  periodic 3D box of elastic hard spheres, no bath, 40^3 cells x 16 particles
//           (1,024,000), dt giving 0.1 collisions per particle per step, 200 steps
//           -- the configuration of SPARTA's standard collision benchmark;
//   DSMC-2  homogeneous bath, alpha = 0.5, eps = 0.01, delta = 0.2, 1e6 grains.
//   DSMC-1L the same box at 86^3 cells x 16 = 10,176,896 particles (the N = 1e7 figure), 50 steps.
// Counters: ns per particle-step (wall and CPU), collisions per second, background-collision
// tests per second and ns per test (wall and CPU), bytes per particle of the storage layout, and the peak
// RSS of the process (getrusage; run one benchmark per process for its own peak).
// Run: build/bench/bench_dsmc --benchmark_filter=DSMC1_SpartaBox/1 (see docs/PERFORMANCE.md)
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <unistd.h>

#include <filesystem>

#include "core/case_file.hpp"
#include "core/run_context.hpp"
#include "core/summary.hpp"
#include "dsmc/collision_groups.hpp"
#include "dsmc/dsmc.hpp"
#include "dsmc/state.hpp"
#include "operators/background.hpp"

namespace {

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double peak_rss_bytes() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return 1024.0 * static_cast<double>(u.ru_maxrss);  // Linux: kilobytes
}

double g_cpu_seconds = 0.0;  // CPU time (all threads) of the last run_case

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
  const double cpu0 = cpu_seconds();
  grainbath::dsmc::run(cfg, ctx, s);
  g_cpu_seconds = cpu_seconds() - cpu0;
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

void report(benchmark::State& state, const grainbath::Summary& s, double particle_steps, double particles, int dims,
            bool bath = false, double steps = 0.0) {
  const double wall = s.number("performance.wall_seconds");
  state.SetIterationTime(wall);
  state.counters["ns_per_particle_step"] = 1e9 * wall / particle_steps;
  state.counters["cpu_ns_per_particle_step"] = 1e9 * g_cpu_seconds / particle_steps;
  // the step loop alone (performance.loop_seconds: no set-up, no final reduction), the time
  // SPARTA's and LAMMPS's per-step figures ("Loop time") are based on
  const double loop = s.number("performance.loop_seconds");
  state.counters["loop_ns_per_particle_step"] = 1e9 * loop / particle_steps;
  state.counters["state_bytes_per_particle"] = static_cast<double>(grainbath::dsmc::Particles::bytes_per_particle(dims, bath));
  if (dims > 0)
    state.counters["sort_scratch_bytes_per_particle"] = static_cast<double>(grainbath::dsmc::SortScratch::bytes_per_particle);
  state.counters["peak_rss_MiB"] = peak_rss_bytes() / (1024.0 * 1024.0);
  state.counters["peak_rss_bytes_per_particle"] = peak_rss_bytes() / particles;
  state.counters["collisions_per_s"] = s.number("counters.grain_collisions") / wall;
  state.counters["bath_tests_per_s"] = s.number("counters.bath_candidates") / wall;
  const double tests = s.number("counters.bath_candidates");
  if (tests > 0) {
    state.counters["ns_per_bath_test"] = 1e9 * wall / tests;
    state.counters["loop_ns_per_bath_test"] = 1e9 * loop / tests;
    state.counters["cpu_ns_per_bath_test"] = 1e9 * g_cpu_seconds / tests;
    // Issue #7 metric is per test; per accepted collision and per step are what a run costs
    // (tests per collision = 1 / acceptance of the thinning, docs/performance/bath.md)
    const double collisions = s.number("counters.bath_collisions");
    if (collisions > 0) state.counters["cpu_ns_per_bath_collision"] = 1e9 * g_cpu_seconds / collisions;
    if (steps > 0) state.counters["cpu_ms_per_step"] = 1e3 * g_cpu_seconds / steps;
  }
  state.counters["collisions_per_particle_step"] = s.number("counters.grain_collisions") / particle_steps;
}

void BM_DSMC1_SpartaBox(benchmark::State& state) {
  for (auto _ : state) report(state, run_case(kDsmc1, static_cast<int>(state.range(0))), 1024000.0 * 200, 1024000.0, 3);
}
BENCHMARK(BM_DSMC1_SpartaBox)->Arg(1)->Arg(2)->UseManualTime()->Iterations(1)->Unit(benchmark::kSecond);

// DSMC-1 with Bird's start-of-step bound (`[dsmc] bound = "bird"`, SPARTA's scheme: its
// majorant is raised only when a drawn pair exceeds it) instead of the default exact bound
// (docs/dsmc.md, "Grain-grain collisions"): the algorithm-for-algorithm comparison, and what
// the exact bound costs.
void BM_DSMC1_SpartaBox_Bird(benchmark::State& state) {
  std::string toml = kDsmc1;
  toml.replace(toml.find("[dsmc]\n"), 7, "[dsmc]\nbound = \"bird\"\n");
  for (auto _ : state) report(state, run_case(toml, static_cast<int>(state.range(0))), 1024000.0 * 200, 1024000.0, 3);
}
BENCHMARK(BM_DSMC1_SpartaBox_Bird)->Arg(1)->Arg(2)->UseManualTime()->Iterations(1)->Unit(benchmark::kSecond);

// DSMC-1 between walls: the same box with diffuse walls at x = 0, L (at the grains'
// temperature) and specular walls at y = 0, L, periodic in z. Boxes with walls take the fused
// step since 2026-12-05 (src/dsmc/fused.cpp: the grains that meet a wall fly by
// stream_through_walls in the streaming pass); GRAINBATH_DSMC_UNFUSED=1 gives the separate
// passes, bitwise the same results, for the comparison (docs/PERFORMANCE.md).
void BM_DSMC1_WalledBox(benchmark::State& state) {
  std::string toml = kDsmc1;
  toml.replace(toml.find("[grains]\n"), 9, "boundaries = [\"diffuse\", \"specular\", \"periodic\"]\n[grains]\n");
  for (auto _ : state) report(state, run_case(toml, static_cast<int>(state.range(0))), 1024000.0 * 200, 1024000.0, 3);
}
BENCHMARK(BM_DSMC1_WalledBox)->Arg(1)->Arg(2)->UseManualTime()->Iterations(1)->Unit(benchmark::kSecond);

// DSMC-1 at N = 1e7: 86^3 cells of 0.25 (the same cell size, density and dt), 50 steps.
const char* kDsmc1Large = R"(
[domain]
dimensions = 3
length = [21.5, 21.5, 21.5]
cells = [86, 86, 86]
[grains]
temperature = 1.0
[background]
density = 0.0
[restitution]
law = "elastic"
[dsmc]
particles = 10176896
dt = 0.08862
t_end = 4.431
[sampling]
every = 4.431
steady_from = 0.0
relaxation_theory = false
fields = false
)";

void BM_DSMC1_SpartaBox_1e7(benchmark::State& state) {
  for (auto _ : state)
    report(state, run_case(kDsmc1Large, static_cast<int>(state.range(0))), 10176896.0 * 50, 10176896.0, 3);
}
BENCHMARK(BM_DSMC1_SpartaBox_1e7)->Arg(1)->Arg(2)->UseManualTime()->Iterations(1)->Unit(benchmark::kSecond);

void BM_DSMC2_HomogeneousBath(benchmark::State& state) {
  for (auto _ : state) report(state, run_case(kDsmc2, static_cast<int>(state.range(0))), 1e6 * 20, 1e6, 0, true, 20);
}
BENCHMARK(BM_DSMC2_HomogeneousBath)->Arg(1)->Arg(2)->UseManualTime()->Iterations(1)->Unit(benchmark::kSecond);

// The bath kernel alone (Issue #7, DSMC-2; docs/performance/bath.md): 20,000 grains of the
// DSMC-2 medium (alpha = 0.5, eps = 0.01, TB = 1, grains Maxwellian at T = 1) through
// `steps` x 2 substeps of 0.005, by the per-grain kernel of the previous driver
// (evolve_in_background with CounterRng, kernel 0) or the interleaved one (bath_evolve_batch,
// kernel 1). Third argument 1 (interleaved kernel only): one substep of 0.01 per step, as the
// driver runs the bath between two samples (the second half of a step joined to the first
// half of the next, src/dsmc/driver.cpp); the same process in law, so the tests per step are
// the same within the noise and the per-test times compare directly:
//   build/bench/bench_dsmc --benchmark_filter='DSMC2_BathKernel/1/10/' --benchmark_repetitions=5 --benchmark_enable_random_interleaving=true
// For deterministic counts per test, run under valgrind at steps 10 and 1 and
// divide the difference of the totals by the difference of the tests (counter `tests`):
//   valgrind --tool=cachegrind --branch-sim=yes build/bench/bench_dsmc --benchmark_filter='DSMC2_BathKernel/1/10/0'
void BM_DSMC2_BathKernel(benchmark::State& state) {
  using namespace grainbath;
  const int kernel = static_cast<int>(state.range(0)), steps = static_cast<int>(state.range(1));
  const bool joined = state.range(2) != 0;
  const std::size_t n = 20000;
  const BackgroundState b = BackgroundState::make(1.0, 0.01, {0, 0, 0}, 1.0, 0.5, 1.0);
  std::vector<double> vx(n), vy(n), vz(n), hz(n);
  std::vector<std::uint64_t> id(n);
  for (std::size_t i = 0; i < n; ++i) {
    CounterRng r(1, Stream::initial_velocities, i, 0);
    vx[i] = r.normal();
    vy[i] = r.normal();
    vz[i] = r.normal();
    id[i] = i;
    hz[i] = CounterRng(1, Stream::background_clock, i, 0).exponential_ziggurat();
  }
  BackgroundCounters cnt;
  const double cpu0 = cpu_seconds();
  for (auto _ : state) {
    for (int s = 0; s < (joined ? steps : 2 * steps); ++s) {
      const Stream st = joined ? Stream::background_joined_halves
                               : (s % 2 ? Stream::background_second_half : Stream::background_first_half);
      const auto step = static_cast<std::uint64_t>(joined ? s : s / 2);
      const double duration = joined ? 0.01 : 0.005;
      if (kernel == 0) {
        for (std::size_t i = 0; i < n; ++i) {
          CounterRng rng(1, st, id[i], step);
          Vec3 v{vx[i], vy[i], vz[i]};
          evolve_in_background(v, hz[i], b, 1.0, duration, rng, cnt);
          vx[i] = v.x, vy[i] = v.y, vz[i] = v.z;
        }
      } else {
        for (std::size_t lo = 0; lo < n; lo += 4096)
          bath_evolve_batch(std::min<std::size_t>(4096, n - lo), id.data() + lo, vx.data() + lo, vy.data() + lo,
                            vz.data() + lo, hz.data() + lo, b, 1.0, duration, BathKey{1, st, step}, cnt);
      }
    }
  }
  state.counters["tests"] = static_cast<double>(cnt.candidates);
  state.counters["cpu_ns_per_bath_test"] = 1e9 * (cpu_seconds() - cpu0) / static_cast<double>(cnt.candidates);
  state.counters["acceptance"] = static_cast<double>(cnt.collisions) / static_cast<double>(cnt.candidates);
}
BENCHMARK(BM_DSMC2_BathKernel)
    ->Args({0, 10, 0})
    ->Args({0, 1, 0})
    ->Args({1, 10, 0})
    ->Args({1, 1, 0})
    ->Args({1, 10, 1})
    ->Args({1, 1, 1})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

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

// The bound pass of the collision groups (src/dsmc/collision_groups.hpp), alone: 10^6
// Maxwellian grains (2^20, 24 MB of velocities, out of cache), dealt into groups of 4096,
// the bound of every group; per grain. Arguments: the tile permutation (0: tiles in order, the
// streaming floor; 1: the step's deal) and the prefetch (0: none; 1: one tile ahead into L1,
// the engine's; 2: two tiles ahead into L2; 3: two ahead into L1). A new deal every
// iteration (step), as a run has. 2026-11-26 21:40 UTC, medians of 5 interleaved: in order
// 1.07 ns per grain (22 GB/s); dealt 2.13 (none), 1.74 (1), 2.11 (2), 1.74 (3); also 1 ahead
// into L2 2.06, 4 ahead into L1 1.77; tiles of 128 and 256 grains (a scratch build) 1.78 and
// 1.90 dealt: the 64-grain tiles and one tile ahead into L1 were kept.
//   build/bench/bench_dsmc --benchmark_filter=BM_GroupBound --benchmark_repetitions=5 --benchmark_enable_random_interleaving=true
// groups of 64 tiles: `tiles` the dealt order (or the identity), group g its tiles [64 g, 64 g + 64)
template <int Ahead, int Hint>
double all_group_bounds(const std::vector<double>& vx, const std::vector<double>& vy, const std::vector<double>& vz,
                        const std::vector<std::uint32_t>& tiles) {
  constexpr std::size_t per_group = 4096 / grainbath::dsmc::kGroupTile;
  double sum = 0;
  for (std::size_t first = 0; first + per_group <= tiles.size(); first += per_group)
    sum += grainbath::dsmc::group_pair_speed_bound<Ahead, Hint>(vx.data(), vy.data(), vz.data(), tiles.data() + first,
                                                                 per_group, 4096);
  return sum;
}
void BM_GroupBound(benchmark::State& state) {
  using namespace grainbath;
  const bool shuffled = state.range(0) != 0;
  const int prefetch = static_cast<int>(state.range(1));
  const std::size_t n = 1 << 20;  // 16384 full tiles, 256 groups of 4096
  std::vector<double> vx(n), vy(n), vz(n);
  for (std::size_t i = 0; i < n; ++i) {
    CounterRng r(1, Stream::initial_velocities, i, 0);
    vx[i] = r.normal();
    vy[i] = r.normal();
    vz[i] = r.normal();
  }
  dsmc::CollisionGroups deal;
  std::vector<std::uint32_t> tiles(n / dsmc::kGroupTile);
  std::uint64_t step = 0;
  double sink = 0;
  for (auto _ : state) {
    state.PauseTiming();
    if (shuffled) {  // the step's deal (groups of 64 tiles: n is a whole number of groups)
      deal.deal(n, 4096, 7, step++);
      for (std::size_t g = 0, k = 0; g < deal.count(); ++g)
        for (std::size_t t = 0; t < deal.tile_count(g); ++t) tiles[k++] = deal.tiles(g)[t];
    } else {
      for (std::size_t t = 0; t < tiles.size(); ++t) tiles[t] = static_cast<std::uint32_t>(t);
    }
    state.ResumeTiming();
    switch (prefetch) {
      case 0: sink += all_group_bounds<0, _MM_HINT_T0>(vx, vy, vz, tiles); break;
      case 1: sink += all_group_bounds<1, _MM_HINT_T0>(vx, vy, vz, tiles); break;
      case 2: sink += all_group_bounds<2, _MM_HINT_T2>(vx, vy, vz, tiles); break;
      default: sink += all_group_bounds<2, _MM_HINT_T0>(vx, vy, vz, tiles); break;
    }
  }
  benchmark::DoNotOptimize(sink);
  state.counters["ns_per_grain"] =
      benchmark::Counter(static_cast<double>(n) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_GroupBound)->ArgsProduct({{0, 1}, {0, 1, 2, 3}})->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
