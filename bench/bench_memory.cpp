// Memory latency of this machine, the hardware floor beside the EDMD figures (Issue #7:
// "the distance to the hardware limit", docs/PERFORMANCE.md "EDMD scaling").
//
// An event-driven step at large N reads the records of ~20-40 neighbours at random places in
// memory; once the records no longer fit in the caches each one is a miss whose cost is the
// load-to-use latency of the level that holds it, divided by how many misses the core can keep
// in flight at once. This benchmark measures both ends of that range for working sets from
// L2-resident to DRAM-resident:
//   * BM_PointerChase/<KiB>/1: one dependent chain (each load's address is the previous
//     load's value), so no two misses overlap: the full latency per load;
//   * BM_PointerChase/<KiB>/8: eight independent chains advanced in turn: up to eight misses
//     in flight, the best a well-prefetched random access pattern can reach;
//   * the third argument 1: the same on transparent huge pages (2 MiB).
// Nodes are 64-byte cache lines linked in one random cycle (Sattolo's algorithm), so the
// hardware prefetchers cannot predict the next line. Reported: time per load (the counter ns_per_load, printed with its SI prefix, e.g. 180n = 180 ns).
//   * BM_PrefetchedChain/<distance>/<level>/<extra>: what a software prefetch buys on this
//     machine (docs/performance/edmd.md, 2026-11-26 06:45): a dependent chain of loads over
//     256 MiB (huge pages) whose addresses are known in advance, each requested <distance>
//     steps earlier with __builtin_prefetch locality <level> (3 = prefetcht0 into L1, 1 =
//     prefetcht2 into L2; distance 0: no hint), while each step also makes <extra>
//     independent random demand loads, as the EDMD event loop does around its chain.
//     Reported: time per step (time_per_step).
//   * BM_GatherLayout/<layout>/<side>/<avx2>: the gather of the DSMC fused step
//     (src/dsmc/fused.cpp, gather_slots) for three memory layouts of the particles, and a
//     plain copy as the floor (docs/performance/dsmc1.md, 2026-11-26 night; see the comment
//     above the benchmark).
//     Reported: time per particle (time_per_particle).
//   * BM_ScatterIds/<layout>/<side>: the fused step's scatter reading the ids from an id
//     array (layout 0) or from 64-byte records (layout 1): what records cost that pass.
//   * BM_ScatterGather/<design>/<side>: the scatter and then the gather, for the SoA and two
//     record designs.
#include <benchmark/benchmark.h>

#include <immintrin.h>
#include <sys/mman.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <map>
#include <numbers>
#include <memory>
#include <numeric>
#include <random>
#include <vector>

#include "dsmc/spatial.hpp"

namespace {

struct alignas(64) Node {
  std::uint32_t next;
  std::uint32_t pad[15];
};

// The nodes in memory aligned to 2 MiB; with huge = true the kernel is asked for transparent
// huge pages (madvise; this machine's THP mode is "madvise"), so the TLB covers 2 MiB per
// entry instead of 4 KiB and a random load at DRAM-sized working sets no longer also walks
// the page tables.
struct FreeDeleter {
  void operator()(Node* p) const { std::free(p); }
};
using NodeBuffer = std::unique_ptr<Node[], FreeDeleter>;

NodeBuffer random_cycle(std::size_t n, std::uint64_t seed, bool huge) {
  // Sattolo: a uniformly random cyclic permutation, one cycle through all n nodes
  std::vector<std::uint32_t> perm(n);
  std::iota(perm.begin(), perm.end(), 0u);
  std::mt19937_64 g(seed);
  for (std::size_t i = n - 1; i > 0; --i) {
    std::uniform_int_distribution<std::size_t> pick(0, i - 1);
    std::swap(perm[i], perm[pick(g)]);
  }
  constexpr std::size_t kAlign = 2u << 20;
  const std::size_t bytes = (n * sizeof(Node) + kAlign - 1) / kAlign * kAlign;
  NodeBuffer nodes(static_cast<Node*>(std::aligned_alloc(kAlign, bytes)));
  if (!nodes) throw std::bad_alloc();
  // advice only: ignored where THP is off; the 4 KiB variant opts out explicitly, so that a
  // machine whose THP mode is "always" still measures both
  madvise(nodes.get(), bytes, huge ? MADV_HUGEPAGE : MADV_NOHUGEPAGE);
  for (std::size_t i = 0; i < n; ++i) nodes[i].next = perm[i];
  return nodes;
}

void BM_PointerChase(benchmark::State& state) {
  const std::size_t kib = static_cast<std::size_t>(state.range(0));
  const int chains = static_cast<int>(state.range(1));
  const bool huge = state.range(2) != 0;
  const std::size_t n = kib * 1024 / sizeof(Node);
  const NodeBuffer nodes = random_cycle(n, 12345, huge);
  constexpr int kMaxChains = 8;
  std::uint32_t at[kMaxChains];
  for (int c = 0; c < kMaxChains; ++c) at[c] = static_cast<std::uint32_t>((n / kMaxChains) * c);
  constexpr std::int64_t kLoadsPerChain = 1 << 20;
  for (auto _ : state) {
    if (chains == 1) {
      std::uint32_t p = at[0];
      for (std::int64_t k = 0; k < kLoadsPerChain; ++k) p = nodes[p].next;
      at[0] = p;
    } else {
      for (std::int64_t k = 0; k < kLoadsPerChain; ++k)
        for (int c = 0; c < kMaxChains; ++c) at[c] = nodes[at[c]].next;
    }
    benchmark::DoNotOptimize(at);
  }
  const double loads = static_cast<double>(state.iterations()) * static_cast<double>(kLoadsPerChain) * chains;
  state.counters["time_per_load"] = benchmark::Counter(loads, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["working_set_MiB"] = static_cast<double>(n * sizeof(Node)) / (1 << 20);
}
// 256 KiB (L2), 1 MiB (the L2 size), 8 MiB, 32 MiB (the L3 size), 128 MiB and 512 MiB (DRAM)
BENCHMARK(BM_PointerChase)
    ->ArgsProduct({{256, 1024, 8 * 1024, 32 * 1024, 128 * 1024, 512 * 1024}, {1, 8}, {0, 1}})
    ->Unit(benchmark::kMillisecond);

// 256 MiB of lines on huge pages whose first word is 0, read at random places by the two
// benchmarks below (the cycle's links are not used; the seed only fixes its layout)
constexpr std::size_t kRandomLines = (std::size_t{256} << 20) / sizeof(Node);
NodeBuffer zeroed_lines(std::uint64_t seed) {
  NodeBuffer nodes = random_cycle(kRandomLines, seed, true);
  for (std::size_t i = 0; i < kRandomLines; ++i) nodes[i].pad[0] = 0;
  return nodes;
}

// Random line indices into those lines (the last line left out: the dependent loads add
// a 0 or 1 that the CPU cannot know in advance)
struct RandomLines {
  std::mt19937_64 g;
  std::uniform_int_distribution<std::uint32_t> line{0, static_cast<std::uint32_t>(kRandomLines - 2)};
  explicit RandomLines(std::uint64_t seed) : g(seed) {}
  std::vector<std::uint32_t> draw(std::size_t n) {
    std::vector<std::uint32_t> v(n);
    for (auto& x : v) x = line(g);
    return v;
  }
};

void BM_PrefetchedChain(benchmark::State& state) {
  const int distance = static_cast<int>(state.range(0));
  const int level = static_cast<int>(state.range(1));
  const int extra = static_cast<int>(state.range(2));
  constexpr std::size_t kSteps = std::size_t{1} << 20;
  constexpr int kMaxExtra = 16;
  const NodeBuffer nodes = zeroed_lines(777);
  RandomLines pick(4242);
  const std::vector<std::uint32_t> chain = pick.draw(kSteps + 64), others = pick.draw(kSteps * kMaxExtra);
  for (auto _ : state) {
    std::uint32_t carry = 0, sink = 0;
    for (std::size_t k = 0; k < kSteps; ++k) {
      if (distance > 0) {
        const Node* ahead = &nodes[chain[k + static_cast<std::size_t>(distance)]];
        if (level == 3) __builtin_prefetch(ahead, 0, 3);
        else __builtin_prefetch(ahead, 0, 1);
      }
      for (int q = 0; q < extra; ++q) sink += nodes[others[k * kMaxExtra + static_cast<std::size_t>(q)]].pad[0];
      carry = nodes[chain[k] + (carry & 1u)].pad[0];  // depends on the previous step (always 0)
    }
    benchmark::DoNotOptimize(carry);
    benchmark::DoNotOptimize(sink);
  }
  state.counters["time_per_step"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * static_cast<double>(kSteps),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_PrefetchedChain)
    ->Args({0, 3, 0})
    ->ArgsProduct({{4, 32}, {3, 1}, {0, 16}})
    ->Args({0, 3, 16})
    ->Unit(benchmark::kMillisecond);

// Do lines loaded a moment ago stay in the core's caches? (docs/performance/edmd.md,
// 2026-11-26 exact event batches: the event loop still waited on lines it had just loaded.)
// Per step: 8 random lines A over 256 MiB (huge pages) are loaded together, then <gap>
// other random lines together, then (reread = 1) the 8 lines A again; each group's
// addresses depend on the previous group's values (always 0, unknown to the CPU), so the
// three groups run one after the other. time_per_step(reread 1) - time_per_step(reread 0)
// is what the second reading of A costs: a few ns if A is still in L1/L2, about one DRAM
// latency if it was evicted by the gap's lines.
void BM_ReuseAfterTouch(benchmark::State& state) {
  const int gap = static_cast<int>(state.range(0));
  const bool reread = state.range(1) != 0;
  constexpr std::size_t kSteps = std::size_t{1} << 16;
  constexpr int kTouched = 8;
  const NodeBuffer nodes = zeroed_lines(99);
  RandomLines pick(2468);
  const std::vector<std::uint32_t> touched = pick.draw(kSteps * kTouched),
                                   others = pick.draw(kSteps * static_cast<std::size_t>(gap) + 1);
  for (auto _ : state) {
    std::uint32_t carry = 0;
    for (std::size_t k = 0; k < kSteps; ++k) {
      const std::uint32_t* a = &touched[k * kTouched];
      std::uint32_t sa = 0;
      for (int q = 0; q < kTouched; ++q) sa += nodes[a[q] + (carry & 1u)].pad[0];
      std::uint32_t sg = 0;
      const std::uint32_t* o = &others[k * static_cast<std::size_t>(gap)];
      for (int q = 0; q < gap; ++q) sg += nodes[o[q] + (sa & 1u)].pad[0];
      carry = sa + sg;
      if (reread) {
        std::uint32_t sr = 0;
        for (int q = 0; q < kTouched; ++q) sr += nodes[a[q] + (carry & 1u)].pad[0];
        carry += sr;
      }
    }
    benchmark::DoNotOptimize(carry);
  }
  state.counters["time_per_step"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * static_cast<double>(kSteps),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_ReuseAfterTouch)->ArgsProduct({{0, 16, 64, 256, 512, 1024, 2048}, {0, 1}})->Unit(benchmark::kMillisecond);

// What a disk collision's neighbour scans cost in memory, for two layouts of the candidates
// (docs/performance/edmd.md, 2026-11-26 afternoon: how much a redesign of the event loop's
// data could save at N = 10^6). Disks at area fraction 0.5 in square cells of side sigma
// (0.64 disks per cell, at most 4), as the engine keeps them; per event a cell drawn at
// random and a partner cell beside it, and the 3 x 3 blocks around both scanned, every
// candidate's record read (position, velocity, local time, counter) into a pair test. Each
// event's cell index depends on the previous event's result (always +0), so events run one
// after the other as the calendar makes them.
//   layout 0, "rows + records": the engine's layout: per cell a row of 5 uint32 (count and up
//     to 4 member ids; a 3-cell run of a block row is 60 contiguous bytes), and 64-byte
//     records by id, ids numbered in Morton order of the cells (the engine's order after a
//     rebuild): a scan loads the rows, then the members' records (two dependent levels);
//   layout 1, "records in the cells": per cell 256 bytes holding the count and up to 4
//     48-byte disk records (x, y, vx, vy, t, counter): one level, the 3 cells of a block row
//     contiguous (768 bytes);
//   layouts 2 and 3: layout 0 with the ids numbered in random order (no sort at all) and in
//     row-major order of the cells (a block row's records contiguous, the rows a grid row
//     apart).
// Third argument: how many events ahead the cells of coming events are requested
// (__builtin_prefetch into L1; 0: none), as a calendar that knows its next events could:
// layout 0, 2, 3 request the rows of event e + 2 * ahead and the members' records of event
// e + ahead (whose rows were requested `ahead` events earlier); layout 1 the cells of event
// e + ahead. Memory on huge pages (madvise), as the engine's. Reported: time per event (two
// scans).
struct DiskRecord64 {
  double x, y, z, t, vx, vy, vz;
  std::uint64_t counter;
};
struct DiskRecord48 {
  double x, y, vx, vy, t;
  std::uint64_t counter;
};
struct alignas(64) CellRecords {
  std::uint32_t count, pad;
  DiskRecord48 slot[4];
  std::uint64_t pad_end[7];
};
static_assert(sizeof(CellRecords) == 256, "four cache lines per cell");

template <class T>
struct HugeArray {
  std::unique_ptr<T[], void (*)(T*)> p{nullptr, [](T* q) { std::free(q); }};
  explicit HugeArray(std::size_t n) {
    constexpr std::size_t kAlign = 2u << 20;
    const std::size_t bytes = (n * sizeof(T) + kAlign - 1) / kAlign * kAlign;
    p.reset(static_cast<T*>(std::aligned_alloc(kAlign, bytes)));
    if (!p) throw std::bad_alloc();
    madvise(p.get(), bytes, MADV_HUGEPAGE);
    std::memset(static_cast<void*>(p.get()), 0, bytes);
  }
  T& operator[](std::size_t i) const { return p[i]; }
};

std::uint64_t morton2(std::uint32_t x, std::uint32_t y) {
  std::uint64_t m = 0;
  for (int b = 0; b < 16; ++b) m |= (std::uint64_t{x} >> b & 1u) << (2 * b) | (std::uint64_t{y} >> b & 1u) << (2 * b + 1);
  return m;
}

// a collision-like test of two records: enough arithmetic that the compiler keeps every load
inline double pair_test(double xi, double yi, double vxi, double vyi, double ti, double xj, double yj, double vxj,
                        double vyj, double tj, std::uint64_t counter) {
  const double dx = (xj + vxj * (ti - tj)) - xi, dy = (yj + vyj * (ti - tj)) - yi, dvx = vxj - vxi, dvy = vyj - vyi;
  const double b = dx * dvx + dy * dvy;
  return (dx * dx + dy * dy - 1.0) / (1.0 + b * b) + static_cast<double>(counter & 1u);
}

void BM_DiskNeighbourScan(benchmark::State& state) {
  const int layout = static_cast<int>(state.range(0));
  const std::size_t n_target = static_cast<std::size_t>(state.range(1));
  const std::size_t ahead = static_cast<std::size_t>(state.range(2));
  // cells of side sigma at area fraction 0.5: n / (pi/4) cells in all
  const auto side = static_cast<std::uint32_t>(std::lround(std::sqrt(static_cast<double>(n_target) / (0.5 / (std::numbers::pi / 4)))));
  const std::size_t cells = std::size_t{side} * side;
  std::mt19937_64 g(1357);
  // occupancy: each disk into a random cell with room (the engine's cells hold up to 4)
  std::vector<std::uint8_t> count(cells, 0);
  std::size_t n = 0;
  std::uniform_int_distribution<std::size_t> any_cell(0, cells - 1);
  while (n < n_target) {
    const std::size_t c = any_cell(g);
    if (count[c] < 4) ++count[c], ++n;
  }
  // ids in Morton order of the cells
  std::vector<std::uint32_t> order(cells);
  std::iota(order.begin(), order.end(), 0u);
  if (layout == 0 || layout == 1)
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
      return morton2(a % side, a / side) < morton2(b % side, b / side);
    });
  std::vector<std::uint32_t> id_of_rank(n);  // layout 2: ids handed out in random order
  std::iota(id_of_rank.begin(), id_of_rank.end(), 0u);
  if (layout == 2) std::shuffle(id_of_rank.begin(), id_of_rank.end(), g);
  HugeArray<std::uint32_t> rows(cells * 5);
  HugeArray<DiskRecord64> records(n);
  HugeArray<CellRecords> in_cells(layout == 1 ? cells : 1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::uint32_t next_id = 0;
  for (const std::uint32_t c : order) {
    rows[5 * std::size_t{c}] = count[c];
    if (layout == 1) in_cells[c].count = count[c];
    for (std::uint32_t q = 0; q < count[c]; ++q) {
      const std::uint32_t id = id_of_rank[next_id++];
      rows[5 * std::size_t{c} + 1 + q] = id;
      const DiskRecord64 r{(c % side) + u(g), (c / side) + u(g), 0.0, u(g), u(g) - 0.5, u(g) - 0.5, 0.0, id};
      records[id] = r;
      if (layout == 1) in_cells[c].slot[q] = DiskRecord48{r.x, r.y, r.vx, r.vy, r.t, r.counter};
    }
  }
  constexpr std::size_t kEvents = std::size_t{1} << 16;
  std::vector<std::uint32_t> event_cell(kEvents + 2 * 64);  // (room for the look-ahead)
  std::uniform_int_distribution<std::uint32_t> interior(1, side - 3);  // both blocks inside the grid
  for (auto& c : event_cell) c = interior(g) * side + interior(g);
  auto scan_rows = [&](std::uint32_t centre, double xi, double yi, double& best) {
    for (int dy = -1; dy <= 1; ++dy) {
      const std::uint32_t* row = &rows[5 * (std::size_t{centre} + static_cast<std::size_t>(dy) * side - 1)];
      for (int k = 0; k < 3; ++k, row += 5)
        for (std::uint32_t q = 0; q < row[0]; ++q) {
          const DiskRecord64& r = records[row[1 + q]];
          best = std::min(best, pair_test(xi, yi, 0.1, 0.2, 0.0, r.x, r.y, r.vx, r.vy, r.t, r.counter));
        }
    }
  };
  auto scan_cells = [&](std::uint32_t centre, double xi, double yi, double& best) {
    for (int dy = -1; dy <= 1; ++dy) {
      const CellRecords* cell = &in_cells[std::size_t{centre} + static_cast<std::size_t>(dy) * side - 1];
      for (int k = 0; k < 3; ++k, ++cell)
        for (std::uint32_t q = 0; q < cell->count; ++q) {
          const DiskRecord48& r = cell->slot[q];
          best = std::min(best, pair_test(xi, yi, 0.1, 0.2, 0.0, r.x, r.y, r.vx, r.vy, r.t, r.counter));
        }
    }
  };
  // the 3 x 4 cells of an event's two blocks: rows of 4 cells starting at centre - 1 + dy side
  auto request_rows = [&](std::uint32_t centre) {
    for (int dy = -1; dy <= 1; ++dy) {
      const std::uint32_t* row = &rows[5 * (std::size_t{centre} + static_cast<std::size_t>(dy) * side - 1)];
      __builtin_prefetch(row);
      __builtin_prefetch(row + 19);
    }
  };
  auto request_records = [&](std::uint32_t centre) {
    for (int dy = -1; dy <= 1; ++dy) {
      const std::uint32_t* row = &rows[5 * (std::size_t{centre} + static_cast<std::size_t>(dy) * side - 1)];
      for (int k = 0; k < 4; ++k, row += 5)
        for (std::uint32_t q = 0; q < row[0]; ++q) __builtin_prefetch(&records[row[1 + q]]);
    }
  };
  auto request_cells = [&](std::uint32_t centre) {
    for (int dy = -1; dy <= 1; ++dy) {
      const CellRecords* cell = &in_cells[std::size_t{centre} + static_cast<std::size_t>(dy) * side - 1];
      for (int k = 0; k < 4; ++k) __builtin_prefetch(cell + k);
    }
  };
  double sink = 0;
  for (auto _ : state) {
    std::uint32_t carry = 0;
    for (std::size_t e = 0; e < kEvents; ++e) {
      if (ahead > 0) {
        if (layout == 1) {
          request_cells(event_cell[e + ahead]);
        } else {
          request_rows(event_cell[e + 2 * ahead]);
          request_records(event_cell[e + ahead]);
        }
      }
      const std::uint32_t c = event_cell[e] + (carry & 1u), partner = c + 1;
      const double xi = c % side + 0.5, yi = static_cast<double>(c / side) + 0.5;
      double best = 1e300;
      if (layout != 1) {
        scan_rows(c, xi, yi, best);
        scan_rows(partner, xi + 1.0, yi, best);
      } else {
        scan_cells(c, xi, yi, best);
        scan_cells(partner, xi + 1.0, yi, best);
      }
      sink += best;
      // pair_test >= -1, so this is always 0, but the compiler cannot know it: the next
      // event's cell depends on this event's loads (a constant 0 would let it overlap events)
      carry = best < -2.0 ? 1u : 0u;
    }
  }
  benchmark::DoNotOptimize(sink);
  state.counters["time_per_event"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * static_cast<double>(kEvents),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["disks"] = static_cast<double>(n);
}
BENCHMARK(BM_DiskNeighbourScan)->ArgsProduct({{0, 1, 2, 3}, {10000, 1000000}, {0}})->ArgsProduct({{0, 1}, {1000000}, {1, 2, 4, 8}})->Unit(benchmark::kMillisecond);


// What a record layout would save the gather of the DSMC fused step (issue #7, DSMC-1;
// docs/performance/dsmc1.md, 2026-11-26 night). After streaming, the fused step reorders the
// particles into (new cell, id) order: slot j of the new arrays receives the particle at old
// index perm[j], its position streamed x + v dt and wrapped into the periodic box on the way
// (src/dsmc/fused.cpp, gather_slots / gather_slots_avx2). perf charges about a third of a
// DSMC-1 step to it. Set-up as DSMC-1 (bench/bench_dsmc.cpp kDsmc1): a periodic cube of
// side^3 cells of side 0.25, 16 particles per cell on average at uniform random positions,
// velocities N(0, 1) per component, dt = 0.08862; side 40: 1,024,000 particles, side 86:
// 10,176,896. The particles start in cell order, ids ascending within each cell (as the
// engine keeps them); perm is the (cell, id) order after one step x + v dt. One iteration
// gathers all slots, block by block in the engine's block order (blocks of 64 cells; plain
// order at side 40, the tiled order of fused_step at side 86), single thread, no
// collisions between the blocks (so an upper bound of what the layout changes in the step).
// The layouts (first argument), all giving the same values (checked bit for bit against a
// plain reference gather before timing; SkipWithError on a mismatch):
//   0 "SoA": the engine's layout, six double arrays and the 8-byte ids (which the engine
//     moves in its ranking; here in the same loop), 56 B per particle, each old particle in
//     seven lines;
//   1 "records": one 64-byte record per particle {x, y, z, vx, vy, vz, id, spare}
//     (alignas(64)), each old particle in one line;
//   2 "blocks of 8" (AoSoA): 512 B per 8 particles, 8 x, 8 y, ... 8 id, 8 spare (the spare
//     line never touched), each old particle in seven lines of one 512-byte block;
//   3 "copy": memcpy of the seven SoA arrays (56 B per particle), the floor of a pass that
//     reads and writes these bytes;
//   4 "records + ids": the records of layout 1 for x and v, the ids in an array of their own
//     (gathered and prefetched as the SoA's id array): two lines per old particle. The
//     design that keeps the scatter's id reads at 8 B (BM_ScatterIds below).
// The prefetches are those of gather_slots_avx2 (the engine's path on this VM), the same
// lines for every layout: per slot the lines of the particle kAhead = 16 slots ahead
// (prefetcht0); per 8 slots the engine's window (WindowFetch: plain order `lead` slots
// ahead, tiled order the rows two planes on) and the new arrays' lines kStoreAhead = 256
// slots ahead (both prefetcht2: one line of each array, or 8 records, or the seven used
// lines of one block). The
// window always includes the ids here (the engine fetches them only in the tiled order, for
// its ranking). Third argument 0: scalar loops for all layouts (the same expression,
// wrap_periodic); 1: AVX2 loops for layouts 0, 1 and 4 (below), by target attributes (project
// flags, no -march). Memory from aligned_alloc without madvise, as the engine's vectors.
// Second argument: side, 40 (1e6) or 86 (1e7), or 8 (8,192 particles, ~1 MB in and out:
// the whole gather in L2, what the loop costs without waiting for memory). Reported: time
// per particle (time_per_particle, s with SI prefix, e.g. 9.5n = 9.5 ns); the machine's
// memory speed drifts between minutes, so only interleaved repetitions in one process
// compare (the whole set: ~4 minutes, ~3.5 GB of memory):
//   build/bench/bench_memory --benchmark_filter=BM_GatherLayout --benchmark_repetitions=15
//     --benchmark_enable_random_interleaving=true --benchmark_display_aggregates_only=true
constexpr double kGatherCell = 0.25, kGatherDt = 0.08862;
constexpr std::size_t kGatherAhead = 16, kGatherStoreAhead = 256, kGatherBlockCells = 64;

struct alignas(64) GatherRecord {
  double x, y, z, vx, vy, vz;
  std::uint64_t id;
  double spare;
};
static_assert(sizeof(GatherRecord) == 64, "one line per particle");
struct alignas(64) GatherBlock8 {
  double x[8], y[8], z[8], vx[8], vy[8], vz[8];
  std::uint64_t id[8];
  double spare[8];
};
static_assert(sizeof(GatherBlock8) == 512, "eight lines per 8 particles");

// n elements of T on 64-byte boundaries, zeroed (pages touched before timing), 4 KiB pages
// as the engine's std::vector (this machine's THP mode is "madvise")
template <class T>
struct PlainArray {
  std::unique_ptr<T[], void (*)(T*)> p{nullptr, [](T* q) { std::free(q); }};
  explicit PlainArray(std::size_t n = 0) {
    const std::size_t bytes = std::max<std::size_t>(64, (n * sizeof(T) + 63) / 64 * 64);
    p.reset(static_cast<T*>(std::aligned_alloc(64, bytes)));
    if (!p) throw std::bad_alloc();
    std::memset(static_cast<void*>(p.get()), 0, bytes);
  }
  T* get() const { return p.get(); }
};

// x, y, z, vx, vy, vz (as doubles) and the ids
struct GatherSoa {
  PlainArray<double> a[6];
  PlainArray<std::uint64_t> id;
  explicit GatherSoa(std::size_t n)
      : a{PlainArray<double>(n), PlainArray<double>(n), PlainArray<double>(n), PlainArray<double>(n),
          PlainArray<double>(n), PlainArray<double>(n)},
        id(n) {}
};

// The seven arrays of a GatherSoa as restrict pointers (x y z vx vy vz, id), and a request
// for the lines of slot f in all of them (locality and read/write as __builtin_prefetch's,
// compile-time constants).
struct GatherSoaView {
  double* __restrict a[6];
  std::uint64_t* __restrict id;
  explicit GatherSoaView(const GatherSoa& s)
      : a{s.a[0].get(), s.a[1].get(), s.a[2].get(), s.a[3].get(), s.a[4].get(), s.a[5].get()}, id(s.id.get()) {}
  template <int kWrite, int kLocality>
  [[gnu::always_inline]] void fetch(std::size_t f) const {
    for (int k = 0; k < 6; ++k) __builtin_prefetch(a[k] + f, kWrite, kLocality);
    __builtin_prefetch(id + f, kWrite, kLocality);
  }
};

// the positions streamed as the engine's gather does (gather_slots' expression)
inline double gather_stream(double x, double v, double L) { return grainbath::dsmc::wrap_periodic(x + v * kGatherDt, L); }

struct GatherWindow {
  std::size_t offset[3];
  int count;
};

// One DSMC-1-like state and its permutation, built once per side and shared by the layouts.
struct GatherCase {
  std::size_t side, cells, n;
  double length;
  GatherSoa from;
  GatherSoa expected;  // the plain gather's result
  std::vector<std::uint32_t> perm;
  std::vector<std::size_t> start;  // the new cells' first slots
  std::vector<std::uint32_t> block_order;
  std::vector<GatherWindow> window;  // per block
  std::vector<std::uint32_t> new_cell;  // per old index: its cell after the step (BM_ScatterIds)
  std::size_t lead = 0;                 // fused_step's `lead`
  PlainArray<GatherRecord> records;
  PlainArray<GatherBlock8> blocks;

  static std::size_t particles(std::size_t side) { return 16 * side * side * side; }
  explicit GatherCase(std::size_t s)
      : side(s), cells(s * s * s), n(particles(s)), length(static_cast<double>(s) * kGatherCell), from(n), expected(n),
        records(n), blocks((n + 7) / 8) {
    const double inv = 1.0 / kGatherCell;
    auto axis = [&](double x) {  // CellGrid::axis
      const double f = x * inv;
      if (!(f > 0.0)) return std::size_t{0};
      const auto k = static_cast<std::size_t>(f);
      return k < side ? k : side - 1;
    };
    auto cell_of = [&](double x, double y, double z) { return axis(x) + side * (axis(y) + side * axis(z)); };
    // particles in generation order (the id), then counted into cell order: ids ascend within a cell
    std::mt19937_64 g(20261126);
    std::uniform_real_distribution<double> u(0.0, length);
    std::normal_distribution<double> normal(0.0, 1.0);
    std::vector<double> r(6 * n);
    std::vector<std::size_t> cell(n), count(cells + 1, 0);
    for (std::size_t i = 0; i < n; ++i) {
      for (int a = 0; a < 3; ++a) r[6 * i + a] = u(g);
      for (int a = 3; a < 6; ++a) r[6 * i + a] = normal(g);
      cell[i] = cell_of(r[6 * i], r[6 * i + 1], r[6 * i + 2]);
      ++count[cell[i] + 1];
    }
    std::partial_sum(count.begin(), count.end(), count.begin());
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t slot = count[cell[i]]++;
      for (int a = 0; a < 6; ++a) from.a[a].get()[slot] = r[6 * i + a];
      from.id.get()[slot] = i;
    }
    // the new order: (cell after x + v dt, id)
    std::vector<std::size_t> fill(cells + 1, 0);
    for (std::size_t i = 0; i < n; ++i) {
      double q[3];
      for (int a = 0; a < 3; ++a) q[a] = gather_stream(from.a[a].get()[i], from.a[3 + a].get()[i], length);
      cell[i] = cell_of(q[0], q[1], q[2]);
      new_cell.push_back(static_cast<std::uint32_t>(cell[i]));
      ++fill[cell[i] + 1];
    }
    std::partial_sum(fill.begin(), fill.end(), fill.begin());
    start = fill;
    perm.resize(n);
    for (std::size_t i = 0; i < n; ++i) perm[fill[cell[i]]++] = static_cast<std::uint32_t>(i);
    const std::uint64_t* id = from.id.get();
    for (std::size_t k = 0; k < cells; ++k)
      std::sort(perm.begin() + static_cast<std::ptrdiff_t>(start[k]), perm.begin() + static_cast<std::ptrdiff_t>(start[k + 1]),
                [&](std::uint32_t a, std::uint32_t b) { return id[a] < id[b]; });
    // the reference: the plain gather
    for (std::size_t j = 0; j < n; ++j) {
      const std::uint32_t i = perm[j];
      for (int a = 0; a < 3; ++a) expected.a[a].get()[j] = gather_stream(from.a[a].get()[i], from.a[3 + a].get()[i], length);
      for (int a = 3; a < 6; ++a) expected.a[a].get()[j] = from.a[a].get()[i];
      expected.id.get()[j] = id[i];
    }
    // the other layouts of the same state
    for (std::size_t i = 0; i < n; ++i) {
      records.get()[i] = GatherRecord{from.a[0].get()[i], from.a[1].get()[i], from.a[2].get()[i], from.a[3].get()[i],
                                      from.a[4].get()[i], from.a[5].get()[i], id[i], 0.0};
      GatherBlock8& b = blocks.get()[i / 8];
      const std::size_t q = i % 8;
      b.x[q] = from.a[0].get()[i], b.y[q] = from.a[1].get()[i], b.z[q] = from.a[2].get()[i];
      b.vx[q] = from.a[3].get()[i], b.vy[q] = from.a[4].get()[i], b.vz[q] = from.a[5].get()[i];
      b.id[q] = id[i];
    }
    // the engine's block order and window (fused_step, detail::fused_tile_rows)
    const std::size_t blocks_n = (cells + kGatherBlockCells - 1) / kGatherBlockCells, nx = side, ny = side, nz = side,
                      plane = nx * ny;
    const double row_bytes = 56.0 * static_cast<double>(n) / static_cast<double>(cells) * static_cast<double>(nx);
    std::size_t tile_rows = ny;
    if (row_bytes * static_cast<double>(ny) > 4.0 * 1024 * 1024) {
      const auto window_rows = static_cast<std::size_t>(3.0 * 1024 * 1024 / (3.0 * row_bytes));
      tile_rows = std::min(ny, window_rows > 4 ? window_rows - 2 : std::size_t{2});
    }
    const bool tiled = tile_rows < ny;
    std::vector<std::pair<std::size_t, std::uint32_t>> keyed(blocks_n);
    for (std::size_t b = 0; b < blocks_n; ++b) {
      const std::size_t k = b * kGatherBlockCells, ix = k % nx, iy = (k / nx) % ny, iz = k / plane;
      keyed[b] = {tiled ? (((iy / tile_rows) * nz + iz) * ny + iy) * nx + ix : k, static_cast<std::uint32_t>(b)};
    }
    std::sort(keyed.begin(), keyed.end());
    for (const auto& kb : keyed) block_order.push_back(kb.second);
    const std::size_t reach = 1 + nx * (1 + ny);
    lead = (reach * n + cells - 1) / cells + 64;
    window.resize(blocks_n);
    for (std::size_t b = 0; b < blocks_n; ++b) {
      GatherWindow& w = window[b];
      w.count = 0;
      const std::size_t k0 = b * kGatherBlockCells;
      if (!tiled) {
        w.offset[w.count++] = lead % n;
        continue;
      }
      auto ahead = [&](std::size_t shift) { w.offset[w.count++] = (start[(k0 + shift) % cells] + n - start[k0]) % n; };
      ahead(2 * plane + nx);
      if ((k0 / nx) % ny % tile_rows == 0) {
        ahead(2 * plane);
        ahead(2 * plane + cells - nx);
      }
    }
  }
};

GatherCase& gather_case(std::size_t side) {
  static std::map<std::size_t, std::unique_ptr<GatherCase>> cases;
  std::unique_ptr<GatherCase>& c = cases[side];
  if (!c) c = std::make_unique<GatherCase>(side);
  return *c;
}


// The scalar gathers' common loop (gather_slots' scheme): per chunk of 8 slots the window
// ahead (fetch_window(f), f the slot index modulo n) and the new lines ahead
// (fetch_store(j)); per slot the particle kGatherAhead slots ahead (fetch_slot(old index));
// then copy(j, old index). The last kGatherAhead slots of the block have no slot requests.
template <class FetchWindow, class FetchStore, class FetchSlot, class Copy>
[[gnu::always_inline]] inline void gather_sweep(const std::uint32_t* __restrict perm, std::size_t j0, std::size_t j1,
                                                std::size_t n, const GatherWindow& window, FetchWindow fetch_window,
                                                FetchStore fetch_store, FetchSlot fetch_slot, Copy copy) {
  const std::size_t jp = j1 - j0 > kGatherAhead ? j1 - kGatherAhead : j0;
  for (std::size_t j = j0; j < j1;) {
    const std::size_t e = std::min(j1, (j | 7) + 1);
    if ((j & 7) == 0) {
      for (int w = 0; w < window.count; ++w) {
        std::size_t f = j + window.offset[w];
        if (f >= n) f -= n;
        fetch_window(f);
      }
      fetch_store(j);
    }
    for (const std::size_t ep = std::min(e, jp); j < ep; ++j) {
      fetch_slot(perm[j + kGatherAhead]);
      copy(j, perm[j]);
    }
    for (; j < e; ++j) copy(j, perm[j]);
  }
}

// Layout 0: gather_slots_avx2's scheme in scalar code, the ids in the same loop.
void gather_soa(const GatherSoa& from, GatherSoa& to, const std::uint32_t* __restrict perm, std::size_t j0, std::size_t j1,
                std::size_t n, const GatherWindow& window, double L) {
  const double* __restrict ox = from.a[0].get();
  const double* __restrict oy = from.a[1].get();
  const double* __restrict oz = from.a[2].get();
  const double* __restrict ovx = from.a[3].get();
  const double* __restrict ovy = from.a[4].get();
  const double* __restrict ovz = from.a[5].get();
  const std::uint64_t* __restrict oid = from.id.get();
  double* __restrict x = to.a[0].get();
  double* __restrict y = to.a[1].get();
  double* __restrict z = to.a[2].get();
  double* __restrict vx = to.a[3].get();
  double* __restrict vy = to.a[4].get();
  double* __restrict vz = to.a[5].get();
  std::uint64_t* __restrict id = to.id.get();
  const GatherSoaView src(from), dst(to);
  auto copy = [=](std::size_t j, std::uint32_t i) __attribute__((always_inline)) {
    x[j] = gather_stream(ox[i], ovx[i], L);
    y[j] = gather_stream(oy[i], ovy[i], L);
    z[j] = gather_stream(oz[i], ovz[i], L);
    vx[j] = ovx[i];
    vy[j] = ovy[i];
    vz[j] = ovz[i];
    id[j] = oid[i];
  };
  gather_sweep(
      perm, j0, j1, n, window, [&](std::size_t f) __attribute__((always_inline)) { src.fetch<0, 1>(f); },
      [&](std::size_t j) __attribute__((always_inline)) {
        if (j + kGatherStoreAhead < n) dst.fetch<1, 1>(j + kGatherStoreAhead);
      },
      [&](std::uint32_t f) __attribute__((always_inline)) { src.fetch<0, 3>(f); }, copy);
}

// Layout 1: the same loop over 64-byte records (one line per particle; the window and the
// stores ahead: the 8 records of 8 slots). Layout 4 (kIds): the ids also in an array of
// their own, gathered from oid into id_out with the same prefetches as the SoA's id array.
template <bool kIds>
void gather_records(const GatherRecord* __restrict from, GatherRecord* __restrict to, const std::uint32_t* __restrict perm,
                    std::size_t j0, std::size_t j1, std::size_t n, const GatherWindow& window, double L,
                    const std::uint64_t* __restrict oid, std::uint64_t* __restrict id_out) {
  auto copy = [=](std::size_t j, std::uint32_t i) __attribute__((always_inline)) {
    const GatherRecord& r = from[i];
    GatherRecord& o = to[j];
    o.x = gather_stream(r.x, r.vx, L);
    o.y = gather_stream(r.y, r.vy, L);
    o.z = gather_stream(r.z, r.vz, L);
    o.vx = r.vx;
    o.vy = r.vy;
    o.vz = r.vz;
    o.id = r.id;
    o.spare = r.spare;
    if constexpr (kIds) id_out[j] = oid[i];
  };
  gather_sweep(
      perm, j0, j1, n, window,
      [&](std::size_t f) __attribute__((always_inline)) {
        const std::size_t f8 = f & ~std::size_t{7};  // the 8 records of the SoA lines at f
        for (std::size_t q = 0; q < 8 && f8 + q < n; ++q) __builtin_prefetch(from + f8 + q, 0, 1);
        if constexpr (kIds) __builtin_prefetch(oid + f, 0, 1);
      },
      [&](std::size_t j) __attribute__((always_inline)) {
        if (j + kGatherStoreAhead + 8 > n) return;
        for (std::size_t q = 0; q < 8; ++q) __builtin_prefetch(to + j + kGatherStoreAhead + q, 1, 1);
        if constexpr (kIds) __builtin_prefetch(id_out + j + kGatherStoreAhead, 1, 1);
      },
      [&](std::uint32_t f) __attribute__((always_inline)) {
        __builtin_prefetch(from + f);
        if constexpr (kIds) __builtin_prefetch(oid + f);
      },
      copy);
}

// Layout 2: blocks of 8 particles (the particle i in lane i % 8 of block i / 8; seven lines
// of one block per particle, the spare line unused).
void gather_blocks(const GatherBlock8* __restrict from, GatherBlock8* __restrict to, const std::uint32_t* __restrict perm,
                   std::size_t j0, std::size_t j1, std::size_t n, const GatherWindow& window, double L) {
  auto copy = [=](std::size_t j, std::uint32_t i) __attribute__((always_inline)) {
    const GatherBlock8& r = from[i / 8];
    GatherBlock8& o = to[j / 8];
    const std::size_t p = i % 8, q = j % 8;
    o.x[q] = gather_stream(r.x[p], r.vx[p], L);
    o.y[q] = gather_stream(r.y[p], r.vy[p], L);
    o.z[q] = gather_stream(r.z[p], r.vz[p], L);
    o.vx[q] = r.vx[p];
    o.vy[q] = r.vy[p];
    o.vz[q] = r.vz[p];
    o.id[q] = r.id[p];
  };
  auto fetch = [](const GatherBlock8* b, int rw, int level) __attribute__((always_inline)) {
    const char* c = reinterpret_cast<const char*>(b);
    if (rw == 0 && level == 3)
      for (int k = 0; k < 7; ++k) __builtin_prefetch(c + 64 * k, 0, 3);
    else if (rw == 0)
      for (int k = 0; k < 7; ++k) __builtin_prefetch(c + 64 * k, 0, 1);
    else
      for (int k = 0; k < 7; ++k) __builtin_prefetch(c + 64 * k, 1, 1);
  };
  gather_sweep(
      perm, j0, j1, n, window, [&](std::size_t f) __attribute__((always_inline)) { fetch(from + f / 8, 0, 1); },
      [&](std::size_t j) __attribute__((always_inline)) {
        if (j + kGatherStoreAhead < n) fetch(to + (j + kGatherStoreAhead) / 8, 1, 1);
      },
      [&](std::uint32_t f) __attribute__((always_inline)) { fetch(from + f / 8, 0, 3); }, copy);
}

// The AVX2 gathers (third argument 1; where the CPU has AVX2, else skipped): layout 0 as
// gather_slots_avx2, four slots at a time, each array's four old values loaded one by one
// into a vector, x + v dt and the test 0 <= x < L in vectors, the new arrays stored four
// slots at a time; layout 1 one record per vector operation, {x, y, z, vx} + {vx, vy, vz, 0}
// dt with lane 3 taken back from the record, both halves stored as they come. The same
// prefetches as the scalar loops, issued per group of four slots. Only correctly rounded
// operations (no FMA: target avx2 does not enable it), so the scalar loops' values.
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d gather_lanes(const double* __restrict a, std::uint32_t i0,
                                                                        std::uint32_t i1, std::uint32_t i2, std::uint32_t i3) {
  return _mm256_set_pd(a[i3], a[i2], a[i1], a[i0]);
}
// wrap_periodic of the lanes flagged in `outside` (fused.hpp, detail::wrap_periodic_avx2)
[[gnu::target("avx2"), gnu::always_inline]] inline __m256d gather_wrap(__m256d x, __m256d L, __m256d outside) {
  const __m256d wrapped = _mm256_sub_pd(x, _mm256_mul_pd(L, _mm256_floor_pd(_mm256_div_pd(x, L))));
  return _mm256_blendv_pd(x, _mm256_andnot_pd(_mm256_cmp_pd(wrapped, L, _CMP_GE_OQ), wrapped), outside);
}

[[gnu::target("avx2")]] void gather_soa_avx2(const GatherSoa& from, GatherSoa& to, const std::uint32_t* __restrict perm,
                                             std::size_t j0, std::size_t j1, std::size_t n, const GatherWindow& window,
                                             double L) {
  const GatherSoaView src(from), dst(to);
  const std::uint64_t* __restrict oid = src.id;
  std::uint64_t* __restrict id = dst.id;
  const double* const from_pos[3] = {src.a[0], src.a[1], src.a[2]};
  const double* const from_vel[3] = {src.a[3], src.a[4], src.a[5]};
  double* const to_pos[3] = {dst.a[0], dst.a[1], dst.a[2]};
  double* const to_vel[3] = {dst.a[3], dst.a[4], dst.a[5]};
  const __m256d dt4 = _mm256_set1_pd(kGatherDt), zero = _mm256_setzero_pd(), L4 = _mm256_set1_pd(L);
  std::size_t j = j0;
  for (; j + 4 <= j1; j += 4) {
    const std::size_t c8 = (j + 7) & ~std::size_t{7};
    if (c8 < j + 4) {
      for (int w = 0; w < window.count; ++w) {
        std::size_t f = c8 + window.offset[w];
        if (f >= n) f -= n;
        src.fetch<0, 1>(f);
      }
      if (c8 + kGatherStoreAhead < n) dst.fetch<1, 1>(c8 + kGatherStoreAhead);
    }
    for (std::size_t q = 0; q < 4 && j + q + kGatherAhead < j1; ++q) src.fetch<0, 3>(perm[j + q + kGatherAhead]);
    const std::uint32_t i0 = perm[j], i1 = perm[j + 1], i2 = perm[j + 2], i3 = perm[j + 3];
    for (int a = 0; a < 3; ++a) {
      const __m256d v = gather_lanes(from_vel[a], i0, i1, i2, i3);
      _mm256_storeu_pd(to_vel[a] + j, v);
      const __m256d p = _mm256_add_pd(gather_lanes(from_pos[a], i0, i1, i2, i3), _mm256_mul_pd(v, dt4));
      const __m256d outside = _mm256_or_pd(_mm256_cmp_pd(p, zero, _CMP_LT_OQ), _mm256_cmp_pd(p, L4, _CMP_GE_OQ));
      if (_mm256_movemask_pd(outside) == 0) [[likely]]
        _mm256_storeu_pd(to_pos[a] + j, p);
      else
        _mm256_storeu_pd(to_pos[a] + j, gather_wrap(p, L4, outside));
    }
    id[j] = oid[i0];
    id[j + 1] = oid[i1];
    id[j + 2] = oid[i2];
    id[j + 3] = oid[i3];
  }
  // the last 0-3 slots of the block by the scalar loop (no window left to request)
  if (j < j1) gather_soa(from, to, perm, j, j1, n, GatherWindow{{0, 0, 0}, 0}, L);
}

// one record: {x, y, z, vx} + {vx, vy, vz, 0} dt, lane 3 taken back (a lambda would not
// inherit the target)
[[gnu::target("avx2"), gnu::always_inline]] inline void gather_record_avx2(const GatherRecord* __restrict from,
                                                                           GatherRecord* __restrict to, std::uint32_t i,
                                                                           std::size_t j, __m256d dt4, __m256d L4) {
  const double* r = &from[i].x;
  double* o = &to[j].x;
  const __m256d zero = _mm256_setzero_pd();
  // v: vx vy vz 0 (the id's bits as a double are subnormal: multiplied, they cost a
  // microcode assist, ~50 ns per record here)
  const __m256d lo = _mm256_load_pd(r), hi = _mm256_load_pd(r + 4), v = _mm256_blend_pd(_mm256_loadu_pd(r + 3), zero, 0x8);
  const __m256d p = _mm256_blend_pd(_mm256_add_pd(lo, _mm256_mul_pd(v, dt4)), lo, 0x8);     // x' y' z' vx
  const __m256d outside = _mm256_or_pd(_mm256_cmp_pd(p, zero, _CMP_LT_OQ), _mm256_cmp_pd(p, L4, _CMP_GE_OQ));
  if ((_mm256_movemask_pd(outside) & 7) == 0) [[likely]]
    _mm256_store_pd(o, p);
  else
    _mm256_store_pd(o, gather_wrap(p, L4, _mm256_blend_pd(outside, zero, 0x8)));
  _mm256_store_pd(o + 4, hi);
}

template <bool kIds>
[[gnu::target("avx2")]] void gather_records_avx2(const GatherRecord* __restrict from, GatherRecord* __restrict to,
                                                 const std::uint32_t* __restrict perm, std::size_t j0, std::size_t j1,
                                                 std::size_t n, const GatherWindow& window, double L,
                                                 const std::uint64_t* __restrict oid, std::uint64_t* __restrict id_out) {
  const __m256d dt4 = _mm256_set1_pd(kGatherDt), L4 = _mm256_set1_pd(L);
  std::size_t j = j0;
  for (; j + 4 <= j1; j += 4) {
    const std::size_t c8 = (j + 7) & ~std::size_t{7};
    if (c8 < j + 4) {
      for (int w = 0; w < window.count; ++w) {
        std::size_t f = c8 + window.offset[w];
        if (f >= n) f -= n;
        const std::size_t f8 = f & ~std::size_t{7};
        for (std::size_t q = 0; q < 8 && f8 + q < n; ++q) __builtin_prefetch(from + f8 + q, 0, 1);
        if constexpr (kIds) __builtin_prefetch(oid + f, 0, 1);
      }
      if (c8 + kGatherStoreAhead + 8 <= n) {
        for (std::size_t q = 0; q < 8; ++q) __builtin_prefetch(to + c8 + kGatherStoreAhead + q, 1, 1);
        if constexpr (kIds) __builtin_prefetch(id_out + c8 + kGatherStoreAhead, 1, 1);
      }
    }
    for (std::size_t q = 0; q < 4 && j + q + kGatherAhead < j1; ++q) {
      __builtin_prefetch(from + perm[j + q + kGatherAhead]);
      if constexpr (kIds) __builtin_prefetch(oid + perm[j + q + kGatherAhead]);
    }
    for (std::size_t q = 0; q < 4; ++q) {
      gather_record_avx2(from, to, perm[j + q], j + q, dt4, L4);
      if constexpr (kIds) id_out[j + q] = oid[perm[j + q]];
    }
  }
  for (; j < j1; ++j) {
    gather_record_avx2(from, to, perm[j], j, dt4, L4);
    if constexpr (kIds) id_out[j] = oid[perm[j]];
  }
}


// The scatter's keys are the ids of the grains it placed (the engine's key: low 32 bits of
// the id with the sign bit flipped).
bool keys_match_ids(const GatherCase& c, const std::uint32_t* stable, const std::int32_t* key32) {
  for (std::size_t j = 0; j < c.n; ++j)
    if (key32[j] != static_cast<std::int32_t>(static_cast<std::uint32_t>(c.from.id.get()[stable[j]]) ^ 0x80000000u))
      return false;
  return true;
}

// Times one sweep per iteration; reported: time per particle.
template <class Sweep>
void time_sweeps(benchmark::State& state, Sweep&& sweep, std::size_t n) {
  for (auto _ : state) {
    sweep();
    benchmark::ClobberMemory();
  }
  state.counters["time_per_particle"] = benchmark::Counter(static_cast<double>(state.iterations()) * static_cast<double>(n),
                                                           benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_GatherLayout(benchmark::State& state) {
  const int layout = static_cast<int>(state.range(0));
  GatherCase& c = gather_case(static_cast<std::size_t>(state.range(1)));
  const bool avx2 = state.range(2) != 0;
  if (avx2 && !__builtin_cpu_supports("avx2")) {
    state.SkipWithError("BM_GatherLayout: no AVX2 on this CPU");
    return;
  }
  const std::size_t n = c.n, n8 = (n + 7) / 8;
  GatherSoa to_soa(layout == 0 || layout == 3 ? n : 0);
  PlainArray<GatherRecord> to_records(layout == 1 || layout == 4 ? n : 0);
  PlainArray<std::uint64_t> to_ids(layout == 4 ? n : 0);
  const std::uint64_t* from_ids = c.from.id.get();
  PlainArray<GatherBlock8> to_blocks(layout == 2 ? n8 : 0);
  const std::uint32_t* perm = c.perm.data();
  auto sweep = [&]() {
    if (layout == 3) {
      for (int a = 0; a < 6; ++a) std::memcpy(to_soa.a[a].get(), c.from.a[a].get(), n * sizeof(double));
      std::memcpy(to_soa.id.get(), c.from.id.get(), n * sizeof(std::uint64_t));
      return;
    }
    for (const std::uint32_t b : c.block_order) {
      const std::size_t k0 = std::size_t{b} * kGatherBlockCells, k1 = std::min(c.cells, k0 + kGatherBlockCells);
      const std::size_t j0 = c.start[k0], j1 = c.start[k1];
      if (layout == 0 && avx2) gather_soa_avx2(c.from, to_soa, perm, j0, j1, n, c.window[b], c.length);
      if (layout == 0 && !avx2) gather_soa(c.from, to_soa, perm, j0, j1, n, c.window[b], c.length);
      const GatherWindow& w = c.window[b];
      GatherRecord* const out = to_records.get();
      if (layout == 1 && avx2) gather_records_avx2<false>(c.records.get(), out, perm, j0, j1, n, w, c.length, nullptr, nullptr);
      if (layout == 1 && !avx2) gather_records<false>(c.records.get(), out, perm, j0, j1, n, w, c.length, nullptr, nullptr);
      if (layout == 4 && avx2) gather_records_avx2<true>(c.records.get(), out, perm, j0, j1, n, w, c.length, from_ids, to_ids.get());
      if (layout == 4 && !avx2) gather_records<true>(c.records.get(), out, perm, j0, j1, n, w, c.length, from_ids, to_ids.get());
      if (layout == 2) gather_blocks(c.blocks.get(), to_blocks.get(), perm, j0, j1, n, c.window[b], c.length);
    }
  };
  // one sweep before timing, its result compared bit for bit with the plain gather's
  sweep();
  bool same = true;
  for (std::size_t j = 0; j < n && layout != 3; ++j) {
    double v[6];
    std::uint64_t id = 0;
    if (layout == 0) {
      for (int a = 0; a < 6; ++a) v[a] = to_soa.a[a].get()[j];
      id = to_soa.id.get()[j];
    } else if (layout == 1 || layout == 4) {
      const GatherRecord& r = to_records.get()[j];
      v[0] = r.x, v[1] = r.y, v[2] = r.z, v[3] = r.vx, v[4] = r.vy, v[5] = r.vz, id = layout == 1 ? r.id : to_ids.get()[j];
    } else {
      const GatherBlock8& r = to_blocks.get()[j / 8];
      const std::size_t q = j % 8;
      v[0] = r.x[q], v[1] = r.y[q], v[2] = r.z[q], v[3] = r.vx[q], v[4] = r.vy[q], v[5] = r.vz[q], id = r.id[q];
    }
    for (int a = 0; a < 6; ++a) same = same && std::memcmp(&v[a], &c.expected.a[a].get()[j], sizeof(double)) == 0;
    same = same && id == c.expected.id.get()[j];
  }
  if (!same) {
    state.SkipWithError("BM_GatherLayout: the gather differs from the reference");
    return;
  }
  time_sweeps(state, sweep, n);
  state.counters["particles"] = static_cast<double>(n);
}
BENCHMARK(BM_GatherLayout)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {8, 40, 86}, {0}})
    ->ArgsProduct({{0, 1, 4}, {8, 40, 86}, {1}})
    ->Unit(benchmark::kMillisecond);

// What a record layout would cost the fused step's scatter (the pass before the gather,
// src/dsmc/fused.cpp fused_step: per old index i in order, its slot in its new cell, the
// index into `stable` and the id's low 32 bits into `key32`, the lines of both `lead` slots
// ahead requested into L2 once per 16 slots). It reads the previous ids in old order: 8 B
// per particle from the id array (layout 0), but a whole 64-byte record per particle if the
// ids live in the records (layout 1). The new cells are known (the prediction of the
// previous step, as in DSMC-1). The same set-up and second argument as BM_GatherLayout; both
// layouts checked against the ids before timing. Reported: time per particle.
template <int Layout>
void scatter_ids(const GatherCase& c, std::uint32_t* __restrict stable, std::int32_t* __restrict key32,
                 std::size_t* __restrict cnt, std::uint64_t& any) {
  const std::uint32_t* __restrict cell = c.new_cell.data();
  const std::uint64_t* __restrict id = c.from.id.get();
  const GatherRecord* __restrict rec = c.records.get();
  const std::size_t n = c.n;
  std::copy(c.start.begin(), c.start.end() - 1, cnt);
  std::uint64_t any_id = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if ((i & 15) == 0) {
      const std::size_t f = (i + c.lead) % n;
      __builtin_prefetch(stable + f, 1, 1);
      __builtin_prefetch(key32 + f, 1, 1);
    }
    const std::size_t slot = cnt[cell[i]]++;
    stable[slot] = static_cast<std::uint32_t>(i);
    const std::uint64_t d = Layout == 0 ? id[i] : rec[i].id;
    any_id |= d;
    key32[slot] = static_cast<std::int32_t>(static_cast<std::uint32_t>(d) ^ 0x80000000u);
  }
  any |= any_id;
}

void BM_ScatterIds(benchmark::State& state) {
  const int layout = static_cast<int>(state.range(0));
  const GatherCase& c = gather_case(static_cast<std::size_t>(state.range(1)));
  PlainArray<std::uint32_t> stable(c.n);
  PlainArray<std::int32_t> key32(c.n);
  std::vector<std::size_t> cnt(c.cells);
  std::uint64_t any = 0;
  auto sweep = [&]() {
    if (layout == 0) scatter_ids<0>(c, stable.get(), key32.get(), cnt.data(), any);
    else scatter_ids<1>(c, stable.get(), key32.get(), cnt.data(), any);
  };
  sweep();
  if (!keys_match_ids(c, stable.get(), key32.get())) {
    state.SkipWithError("BM_ScatterIds: the keys differ from the ids");
    return;
  }
  time_sweeps(state, sweep, c.n);
  benchmark::DoNotOptimize(any);
}
BENCHMARK(BM_ScatterIds)->ArgsProduct({{0, 1}, {8, 40, 86}})->Unit(benchmark::kMillisecond);

// The scatter and then the gather, as the fused step runs them (the whole scatter first,
// then the blocks), AVX2 gathers: what each design costs both passes together, including
// whatever the scatter's reading of the records leaves in the caches for the gather.
// Design (first argument) 0: SoA (ids from the id array; BM_GatherLayout layout 0);
// 1: records with the ids in them (the scatter reads the records; layout 1); 4: records and
// an id array (the scatter reads the id array; layout 4). Second argument: side. Outputs
// checked as in the two benchmarks above (key32 against the ids; the gather's values
// against the reference). Reported: time per particle for both passes.
void BM_ScatterGather(benchmark::State& state) {
  const int design = static_cast<int>(state.range(0));
  GatherCase& c = gather_case(static_cast<std::size_t>(state.range(1)));
  if (!__builtin_cpu_supports("avx2")) {
    state.SkipWithError("BM_ScatterGather: no AVX2 on this CPU");
    return;
  }
  const std::size_t n = c.n;
  PlainArray<std::uint32_t> stable(n);
  PlainArray<std::int32_t> key32(n);
  std::vector<std::size_t> cnt(c.cells);
  GatherSoa to_soa(design == 0 ? n : 0);
  PlainArray<GatherRecord> to_records(design != 0 ? n : 0);
  PlainArray<std::uint64_t> to_ids(design == 4 ? n : 0);
  std::uint64_t any = 0;
  const std::uint32_t* perm = c.perm.data();
  auto sweep = [&]() {
    if (design == 1) scatter_ids<1>(c, stable.get(), key32.get(), cnt.data(), any);
    else scatter_ids<0>(c, stable.get(), key32.get(), cnt.data(), any);
    for (const std::uint32_t b : c.block_order) {
      const std::size_t k0 = std::size_t{b} * kGatherBlockCells, k1 = std::min(c.cells, k0 + kGatherBlockCells);
      const std::size_t j0 = c.start[k0], j1 = c.start[k1];
      const GatherWindow& w = c.window[b];
      if (design == 0) gather_soa_avx2(c.from, to_soa, perm, j0, j1, n, w, c.length);
      if (design == 1) gather_records_avx2<false>(c.records.get(), to_records.get(), perm, j0, j1, n, w, c.length, nullptr, nullptr);
      if (design == 4)
        gather_records_avx2<true>(c.records.get(), to_records.get(), perm, j0, j1, n, w, c.length, c.from.id.get(), to_ids.get());
    }
  };
  sweep();
  bool same = keys_match_ids(c, stable.get(), key32.get());
  for (std::size_t j = 0; j < n; ++j) {
    if (design == 0) {
      for (int a = 0; a < 6; ++a) same = same && std::memcmp(&to_soa.a[a].get()[j], &c.expected.a[a].get()[j], sizeof(double)) == 0;
      same = same && to_soa.id.get()[j] == c.expected.id.get()[j];
    } else {
      const GatherRecord& r = to_records.get()[j];
      const double v[6] = {r.x, r.y, r.z, r.vx, r.vy, r.vz};
      for (int a = 0; a < 6; ++a) same = same && std::memcmp(&v[a], &c.expected.a[a].get()[j], sizeof(double)) == 0;
      same = same && (design == 1 ? r.id : to_ids.get()[j]) == c.expected.id.get()[j];
    }
  }
  if (!same) {
    state.SkipWithError("BM_ScatterGather: the output differs from the reference");
    return;
  }
  time_sweeps(state, sweep, n);
  benchmark::DoNotOptimize(any);
}
BENCHMARK(BM_ScatterGather)->ArgsProduct({{0, 1, 4}, {40, 86}})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
