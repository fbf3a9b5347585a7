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
#include <benchmark/benchmark.h>

#include <sys/mman.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <numbers>
#include <memory>
#include <numeric>
#include <random>
#include <vector>

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

}  // namespace

BENCHMARK_MAIN();
