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
#include <cmath>
#include <cstdint>
#include <ctime>
#include <algorithm>
#include <vector>

#include "edmd/edmd.hpp"
#include "edmd/event_calendar.hpp"
#include "edmd/measure.hpp"

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

// The event calendar alone, with the engine's update pattern and sizes: N entries with
// exponential delays (mean 1 per entry, the engine's bucket width mean delay / (2 N)); per
// event the minimum is popped and re-scheduled, and so is a partner a few slots away (a
// collision partner is a spatial neighbour, near in the Morton-sorted slots). Measures what
// the calendar's own memory traffic costs per event at N = 1e4 and 1e6, to separate it from
// the rest of the engine's slowdown (docs/PERFORMANCE.md, "EDMD at N = 10^6").
void calendar_events(benchmark::State& state, std::uint32_t n, double width) {
  std::uint64_t x = 0x9e3779b97f4a7c15ull;
  auto exp1 = [&x] {  // splitmix64 -> Exp(1)
    std::uint64_t z = (x += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return -std::log((static_cast<double>(z >> 11) + 0.5) * 0x1.0p-53);
  };
  EventCalendar cal;
  cal.reset(n, 0.0, width);
  for (std::uint32_t i = 0; i < n; ++i) cal.update(i, exp1());
  auto event = [&] {
    const std::uint32_t i = cal.top();
    const double t = cal.top_key();
    cal.update(i, t + exp1());
    const std::uint32_t j = (i + 1 + static_cast<std::uint32_t>(x & 7)) % n;
    cal.update(j, t + exp1());
  };
  for (std::uint64_t e = 0; e < 5ull * n; ++e) event();  // past the first re-base
  const std::uint64_t chunk = 200000;
  for (auto _ : state)
    for (std::uint64_t e = 0; e < chunk; ++e) event();
  state.counters["events_per_second"] =
      benchmark::Counter(static_cast<double>(chunk) * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
void BM_Calendar(benchmark::State& state) {
  const auto n = static_cast<std::uint32_t>(state.range(0));
  calendar_events(state, n, 0.5 / n);  // the engine's width: mean delay / (2 N)
}
// The same at N = 1e6 with the bucket width w / N, w = range(0) / 4 (the engine's: w = 0.5).
void BM_CalendarWidth(benchmark::State& state) {
  const std::uint32_t n = 1000000;
  calendar_events(state, n, static_cast<double>(state.range(0)) / 4.0 / n);
}

// PairStatistics::add on a snapshot of 10^6 disks at nu = 0.5 (melted by 1 collision per
// disk), with the defaults of a run at that size: g(r) and the velocity correlations to
// r = 10 sigma, bins 0.02 and 0.1. range(0): 0 = the AVX2 pair loop where the CPU has it,
// 1 = the scalar loop (the same sums bit for bit). The pair loop uses the OpenMP threads:
// OMP_NUM_THREADS=1 for the one-core figures of docs/performance/edmd.md. Counter: pairs_per_second
// (candidate pairs in range, i.e. snapshot pairs within rmax).
void BM_PairStatistics(benchmark::State& state) {
  Config c;
  c.dims = 2;
  c.particles = 1000000;
  c.packing_fraction = 0.5;
  const auto init = make_initial_state(c, 1);
  Engine eng(make_setup(c, 1), init.positions, init.velocities);
  eng.advance(ElasticRestitution{}, kInf, static_cast<std::uint64_t>(c.particles));
  eng.synchronize();
  std::vector<Vec3> x(eng.size()), v(eng.size());
  for (std::size_t id = 0; id < eng.size(); ++id) x[id] = eng.position(id), v[id] = eng.velocity(id);
  const auto kernel = state.range(0) == 0 ? PairStatistics::PairKernel::automatic : PairStatistics::PairKernel::scalar;
  double pairs = 0.0;
  for (auto _ : state) {
    PairStatistics stats;
    stats.init(2, eng.length(), {false, false, false}, 10.0, 0.02, 0.1);
    stats.add(x, v, 1.0, kernel);
    for (double g : stats.gr_counts) pairs += g;
  }
  state.counters["pairs_per_second"] = benchmark::Counter(pairs, benchmark::Counter::kIsRate);
}

}  // namespace

BENCHMARK_CAPTURE(BM_Edmd, spheres_phi0.30, 3, 0.30)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Edmd, spheres_phi0.45, 3, 0.45)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Edmd, disks_nu0.50, 2, 0.50)->Arg(10000)->Arg(1000000)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_CAPTURE(BM_Edmd, disks_nu0.70, 2, 0.70)->Arg(10000)->Arg(1000000)->Unit(benchmark::kMillisecond)->MinTime(2.0);

BENCHMARK(BM_Calendar)->Arg(10000)->Arg(1000000)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_PairStatistics)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_CalendarWidth)->Arg(2)->Arg(4)->Arg(8)->Arg(16)->Arg(32)->Unit(benchmark::kMillisecond)->MinTime(2.0);

// The calendar's deferred links (EventCalendar::update, EngineSetup::calendar_defer) off and
// on, timed side by side in one process: two engines from the same start, advanced in
// alternating chunks of 200k collisions (which one goes first swaps every round), CPU time
// per chunk. On the shared 2-core VM the rate of one binary drifts by +-15 % between
// processes, more than the effect; chunks a fraction of a second apart see the same machine
// (docs/performance/edmd.md, 2026-11-26 afternoon). Arguments: N, packing x 100, dims,
// rounds. Both engines must process the same events (the order does not depend on the
// deferral): the event counts are compared at the end.
double thread_cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}
void BM_EdmdDeferAB(benchmark::State& state) {
  Config c;
  c.particles = state.range(0);
  c.packing_fraction = static_cast<double>(state.range(1)) / 100.0;
  c.dims = static_cast<int>(state.range(2));
  const int rounds = static_cast<int>(state.range(3));
  const auto init = make_initial_state(c, 1);
  EngineSetup setup = make_setup(c, 1);
  setup.calendar_defer = 0;
  Engine off(setup, init.positions, init.velocities);
  setup.calendar_defer = 1;
  Engine on(setup, init.positions, init.velocities);
  const std::uint64_t n = static_cast<std::uint64_t>(c.particles);
  off.advance(ElasticRestitution{}, kInf, 5 * n);  // melt the lattice
  on.advance(ElasticRestitution{}, kInf, 5 * n);
  const std::uint64_t chunk = 200000;
  std::uint64_t target = off.counters().collisions;
  std::vector<double> t_off, t_on;
  for (auto _ : state) {
    for (int r = 0; r < rounds; ++r) {
      target += chunk;
      for (int k = 0; k < 2; ++k) {
        const bool run_on = (k == 0) == (r % 2 == 1);
        Engine& e = run_on ? on : off;
        const double t0 = thread_cpu_seconds();
        e.advance(ElasticRestitution{}, kInf, target);
        (run_on ? t_on : t_off).push_back(thread_cpu_seconds() - t0);
      }
    }
  }
  if (off.counters().events != on.counters().events) state.SkipWithError("the two engines processed different events");
  double s_off = 0.0, s_on = 0.0;
  int faster = 0;
  for (std::size_t r = 0; r < t_off.size(); ++r) s_off += t_off[r], s_on += t_on[r], faster += t_on[r] < t_off[r];
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  const double d = static_cast<double>(chunk);
  state.counters["off_collisions_per_second"] = d * static_cast<double>(t_off.size()) / s_off;
  state.counters["on_collisions_per_second"] = d * static_cast<double>(t_on.size()) / s_on;
  state.counters["off_median_chunk_rate"] = d / median(t_off);
  state.counters["on_median_chunk_rate"] = d / median(t_on);
  state.counters["rounds_on_faster"] = faster;
}
BENCHMARK(BM_EdmdDeferAB)
    ->Args({1000000, 50, 2, 20})
    ->Args({1000000, 70, 2, 20})
    ->Args({100000, 30, 3, 20})
    ->Args({10000, 50, 2, 20})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
