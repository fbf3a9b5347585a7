// Reproducibility by construction: the same case and seed give bitwise identical results,
// whatever the thread count; another seed gives different numbers.
#include <gtest/gtest.h>

#include <cstdlib>

#include "dsmc/fused.hpp"
#include "support.hpp"

using grainbath::testing::run_dsmc;

namespace {
const char* kCase = R"(
[grains]
temperature = 1.3
drift = [0.5, 0.0, 0.0]
[background]
mass_ratio = 0.4
density = 1.0
temperature = 1.0
knudsen = 0.2
[restitution]
law = "power"
beta = 0.15
delta = 0.2
[dsmc]
particles = 30000
dt = 0.01
t_end = 1.0
[sampling]
every = 0.1
steady_from = 0.5
)";

// spatial cases: a periodic 3D box (the fused step) or another domain, with a bath and
// inelastic grains
const char* kPeriodicBox3d = R"(
[domain]
dimensions = 3
length = [2.0, 2.0, 2.0]
cells = [8, 8, 8]
)";
// inelastic grains and the run: with a medium (kSpatialRest) or without one, drifting
// (kSpatialRestWithoutBath: the fused step then predicts the next step's cells)
const std::string kSpatialRun = R"(
[restitution]
law = "constant"
e = 0.8
[dsmc]
particles = 20000
dt = 0.02
t_end = 0.6
[sampling]
every = 0.1
steady_from = 0.3
)";
const std::string kSpatialRest = R"(
[grains]
temperature = 1.3
[background]
mass_ratio = 0.4
density = 1.0
temperature = 1.0
knudsen = 0.5
)" + kSpatialRun;
const std::string kSpatialRestWithoutBath = R"(
[grains]
temperature = 1.3
drift = [0.3, -0.2, 0.1]
)" + kSpatialRun;

std::vector<std::string> physics_keys(const grainbath::Summary& s) {
  std::vector<std::string> keys;
  for (const auto& [k, v] : s.entries())
    if (k.rfind("performance.", 0) != 0) keys.push_back(k);
  return keys;
}
}  // namespace

TEST(DsmcReproducibility, SameSeedSameNumbersAcrossThreadCounts) {
  const auto one = run_dsmc(kCase, 9, 1, "repro1");
  const auto two = run_dsmc(kCase, 9, 2, "repro2");
  const auto again = run_dsmc(kCase, 9, 2, "repro3");
  for (const auto& k : physics_keys(one.summary)) {
    ASSERT_NE(two.summary.get(k), nullptr) << k;
    EXPECT_EQ(*one.summary.get(k), *two.summary.get(k)) << k;
    EXPECT_EQ(*two.summary.get(k), *again.summary.get(k)) << k;
  }
  for (const char* name : {"/timeseries/temperature", "/timeseries/a2", "/timeseries/velocity",
                           "/timeseries/pressure_tensor", "/histogram/components"}) {
    EXPECT_EQ(one.series(name), two.series(name)) << name;
  }
}

// Spatial runs: the counting sort splits its work by thread, the final (cell, id) order
// must not show it. A periodic 3D box (streaming and cell index fused) and a 2D box with
// diffuse and open faces (the general wall path), with a bath and inelastic grains.
TEST(DsmcReproducibility, SpatialSameNumbersAcrossThreadCounts) {
  for (const char* domain : {kPeriodicBox3d,
                             R"(
[domain]
dimensions = 2
length = [2.0, 1.0]
cells = [10, 5]
boundaries = ["open", "diffuse"]
wall_temperature = 1.5
)"}) {
    const std::string toml = std::string(domain) + kSpatialRest;
    const auto one = run_dsmc(toml, 5, 1, "srepro1");
    const auto two = run_dsmc(toml, 5, 2, "srepro2");
    for (const auto& k : physics_keys(one.summary)) {
      ASSERT_NE(two.summary.get(k), nullptr) << k;
      EXPECT_EQ(*one.summary.get(k), *two.summary.get(k)) << k;
    }
    for (const char* name : {"/timeseries/temperature", "/timeseries/velocity", "/timeseries/particles"})
      EXPECT_EQ(one.series(name), two.series(name)) << name;
    EXPECT_GT(one.summary.number("counters.grain_collisions"), 0.0);
  }
}

// A 1D density mode in few, full cells (2000 grains each: the merge sort of the in-cell
// order, src/dsmc/cell_order.hpp, and the mode projection summed per block in parallel):
// the same state, mode amplitude and fields at 1 and 2 threads.
TEST(DsmcReproducibility, DensityModeInFullCellsAcrossThreadCounts) {
  const char* toml = R"(
[domain]
dimensions = 1
length = [2.0]
cells = [10]
boundaries = ["periodic"]
[grains]
density = 1.0
temperature = 1.0
profile = "mode"
amplitude = 0.3
wavenumber_index = 1
[background]
mass_ratio = 0.5
density = 1.0
temperature = 1.0
knudsen = 0.1
[restitution]
law = "power"
beta = 0.2
delta = 0.2
[dsmc]
particles = 20000
dt = 0.01
t_end = 0.3
[sampling]
every = 0.02
steady_from = 0.0
)";
  const auto one = run_dsmc(toml, 4, 1, "mrepro1");
  const auto two = run_dsmc(toml, 4, 2, "mrepro2");
  for (const auto& k : physics_keys(one.summary)) {
    ASSERT_NE(two.summary.get(k), nullptr) << k;
    EXPECT_EQ(*one.summary.get(k), *two.summary.get(k)) << k;
  }
  for (const char* name : {"/mode/amplitude", "/timeseries/temperature", "/timeseries/velocity"})
    EXPECT_EQ(one.series(name), two.series(name)) << name;
  EXPECT_EQ(one.series("/mode/amplitude").size(), 16u);
  EXPECT_GT(one.summary.number("counters.grain_collisions"), 0.0);
}

// The case fused at 1 and 2 threads and as separate passes (GRAINBATH_DSMC_UNFUSED): the same
// physics keys (state.hash included) and time series, bitwise. Returns the separate run.
namespace {
// fully periodic boxes in 3, 2 and 1 dimensions: all take the fused step
const char* const kPeriodicDomains[] = {kPeriodicBox3d, R"(
[domain]
dimensions = 2
length = [2.0, 1.0]
cells = [10, 5]
)",
                                        R"(
[domain]
dimensions = 1
length = [2.0]
cells = [16]
)"};

grainbath::testing::CaseRun expect_fused_equals_separate(const std::string& toml, std::uint64_t seed,
                                                         const std::string& tag) {
  const auto fused1 = run_dsmc(toml, seed, 1, tag + "1");
  const auto fused2 = run_dsmc(toml, seed, 2, tag + "2");
  ::setenv("GRAINBATH_DSMC_UNFUSED", "1", 1);
  auto separate = run_dsmc(toml, seed, 1, tag + "-separate");
  ::unsetenv("GRAINBATH_DSMC_UNFUSED");
  for (const auto& k : physics_keys(separate.summary)) {
    EXPECT_NE(fused1.summary.get(k), nullptr) << k;
    if (fused1.summary.get(k) == nullptr || fused2.summary.get(k) == nullptr) continue;
    EXPECT_EQ(*fused1.summary.get(k), *separate.summary.get(k)) << k;
    EXPECT_EQ(*fused2.summary.get(k), *separate.summary.get(k)) << k;
  }
  for (const char* name : {"/timeseries/temperature", "/timeseries/velocity", "/timeseries/pressure_tensor"}) {
    EXPECT_EQ(fused1.series(name), separate.series(name)) << name;
    EXPECT_EQ(fused2.series(name), separate.series(name)) << name;
  }
  return separate;
}
}  // namespace

// A fully periodic box takes the fused stream-sort-collide step (src/dsmc/fused.cpp); it
// must give bitwise the results of the separate passes (stream, sort_by_cell, per-cell
// collisions), which GRAINBATH_DSMC_UNFUSED selects, at 1 and 2 threads, in 3, 2 and 1
// dimensions; with a bath (the residual is gathered with the particles) and inelastic grains.
TEST(DsmcReproducibility, FusedPeriodicStepEqualsSeparatePasses) {
  for (const char* domain : kPeriodicDomains) {
    SCOPED_TRACE(domain);
    const std::string toml = std::string(domain) + kSpatialRest;
    const auto separate = expect_fused_equals_separate(toml, 5, "fused");
    EXPECT_GT(separate.summary.number("counters.grain_collisions"), 0.0);
    EXPECT_GT(separate.summary.number("counters.bath_collisions"), 0.0);
  }
}

// Without a medium the fused step predicts the next step's cells at the end of each step,
// from the state after the collisions (SortScratch::next_cell), and the next step only counts
// them: every step after the first runs on predicted cells. The results must still be those
// of the separate passes, at 1 and 2 threads (the blocks, hence the slots whose cells a
// thread predicts, are split differently from the next step's streaming ranges), in 3, 2
// and 1 dimensions, elastic and inelastic.
TEST(DsmcReproducibility, FusedStepWithoutBathEqualsSeparatePasses) {
  const char* rest = R"(
[grains]
temperature = 1.3
drift = [0.3, -0.2, 0.1]
[dsmc]
particles = 20000
dt = 0.02
t_end = 0.6
[sampling]
every = 0.1
steady_from = 0.3
)";
  for (const char* law : {"[restitution]\nlaw = \"constant\"\ne = 0.8\n", "[restitution]\nlaw = \"elastic\"\n"}) {
    for (const char* domain : kPeriodicDomains) {
      SCOPED_TRACE(std::string(domain) + law);
      const std::string toml = std::string(domain) + rest + law;
      const auto separate = expect_fused_equals_separate(toml, 7, "nbfused");
      EXPECT_GT(separate.summary.number("counters.grain_collisions"), 0.0);
      EXPECT_EQ(separate.summary.number("counters.bath_collisions"), 0.0);
    }
  }
}

// Boxes with walls take the fused step too: a grain whose flight crosses a wall flies by
// stream_through_walls in the streaming pass, in place, and the gather copies it
// (src/dsmc/fused.cpp). The results must be bitwise those of the separate passes (the wall
// energies and removed counts included, which the fused step adds per block in particle
// order), at 1 and 2 threads, in 3, 2 and 1 dimensions with specular, diffuse and open faces
// beside periodic axes, with a bath and without one.
TEST(DsmcReproducibility, FusedStepWithWallsEqualsSeparatePasses) {
  // the periodic boxes' geometry (kPeriodicDomains, in order) with walls
  const char* const walls[] = {
      "boundaries = [\"diffuse\", \"diffuse\", \"periodic\", \"periodic\", \"open\", \"specular\"]\n"
      "wall_temperature = 1.5\n",
      "boundaries = [\"specular\", \"specular\", \"open\", \"diffuse\"]\nwall_temperature = 0.7\n",
      "boundaries = [\"diffuse\", \"open\"]\n"};
  for (const std::string& rest : {kSpatialRest, kSpatialRestWithoutBath}) {
    for (int d = 0; d < 3; ++d) {
      const std::string toml = std::string(kPeriodicDomains[d]) + walls[d] + rest;
      SCOPED_TRACE(toml);
      const auto separate = expect_fused_equals_separate(toml, 13, "walled");
      EXPECT_GT(separate.summary.number("counters.grain_collisions"), 0.0);
      EXPECT_GT(separate.summary.number("counters.particles_removed"), 0.0);
      EXPECT_NE(separate.summary.number("energy.wall_input_per_grain"), 0.0);
    }
  }
}

// Large 3-D boxes take the fused step's blocks in tiles of rows along y, each swept through
// all z planes (fused.cpp, fused_tile_rows: the plain order for DSMC-1 at 1e6, 11-row tiles at
// 1e7), for the cache; the block order must change no number. GRAINBATH_DSMC_TILE_ROWS forces
// tiles of 1, 2 and 4 rows in a small box of 7 x 6 x 5 cells (blocks of 4 cells straddle the
// rows; the last tile is shorter for 4): the results must be bitwise those of the separate
// passes, at 1 and 2 threads, without a medium (predicted cells) and with a bath (the
// residual gathered too). Fails if the tiled order skips or repeats a block (checked).
TEST(DsmcReproducibility, FusedStepInTiledBlockOrderEqualsSeparatePasses) {
  EXPECT_EQ(grainbath::dsmc::detail::fused_tile_rows(1024000, {40, 40, 40}), 40u);
  EXPECT_EQ(grainbath::dsmc::detail::fused_tile_rows(10176896, {86, 86, 86}), 11u);
  const char* box = R"(
[domain]
dimensions = 3
length = [1.75, 1.5, 1.25]
cells = [7, 6, 5]
)";
  for (const char* rows : {"1", "2", "4"}) {
    ::setenv("GRAINBATH_DSMC_TILE_ROWS", rows, 1);
    for (const std::string& rest : {kSpatialRestWithoutBath, kSpatialRest}) {
      SCOPED_TRACE(std::string("tile rows ") + rows + rest);
      const auto separate = expect_fused_equals_separate(std::string(box) + rest, 11, std::string("tiled") + rows);
      EXPECT_GT(separate.summary.number("counters.grain_collisions"), 0.0);
    }
    ::unsetenv("GRAINBATH_DSMC_TILE_ROWS");
  }
}

// Which runs take the fused step (fused_step_applies): spatial ones, except where a grain's
// cell index could reach the kStreamedBit that marks grains that met a wall (a walled grid of
// 2^31 cells or more) or an old index could (2^31 grains or more): those take the separate
// passes instead of stopping. A case file cannot ask for either today (read_config: at most
// 2e9 grains, at least 2 per cell), so the sizes are set on a read configuration, as a
// program using the library or a later limit could; nothing is allocated.
TEST(DsmcReproducibility, FusedStepAppliesBelowTheStreamedBitOnly) {
  using grainbath::dsmc::Boundary;
  const auto read = [](const std::string& toml) {
    grainbath::CaseReader reader(toml, "/tmp/test.toml");
    reader.accept("run", "solver");
    auto cfg = grainbath::dsmc::read_config(reader);
    reader.finish();
    return cfg;
  };
  ASSERT_EQ(std::getenv("GRAINBATH_DSMC_UNFUSED"), nullptr);
  EXPECT_FALSE(grainbath::dsmc::fused_step_applies(read(kCase)));  // homogeneous: never
  const auto periodic = read(std::string(kPeriodicBox3d) + kSpatialRest);
  ASSERT_TRUE(grainbath::dsmc::fused_step_applies(periodic));
  // grains: 2^31 - 1 fused, 2^31 not
  auto c = periodic;
  c.particles = 2147483647;
  EXPECT_TRUE(grainbath::dsmc::fused_step_applies(c));
  c.particles = 2147483648;
  EXPECT_FALSE(grainbath::dsmc::fused_step_applies(c));
  // cells: 2^31 of them fused in a periodic box (no grain is ever marked), not with a wall;
  // 2^31 - 2^20 cells fused with a wall
  c = periodic;
  c.domain.cells = {2048, 1024, 1024};
  EXPECT_TRUE(grainbath::dsmc::fused_step_applies(c));
  c.domain.faces[4] = Boundary::specular;
  EXPECT_FALSE(grainbath::dsmc::fused_step_applies(c));
  c.domain.cells = {2047, 1024, 1024};
  EXPECT_TRUE(grainbath::dsmc::fused_step_applies(c));
  // and the environment's switch to the separate passes
  ::setenv("GRAINBATH_DSMC_UNFUSED", "1", 1);
  EXPECT_FALSE(grainbath::dsmc::fused_step_applies(periodic));
  ::unsetenv("GRAINBATH_DSMC_UNFUSED");
}

TEST(DsmcReproducibility, DifferentSeedDifferentNumbers) {
  const auto a = run_dsmc(kCase, 9, 0, "seedA");
  const auto b = run_dsmc(kCase, 10, 0, "seedB");
  EXPECT_NE(a.summary.number("temperature.final"), b.summary.number("temperature.final"));
}

// Every run is a benchmark: summary.json carries the wall time, particle-steps per second
// and collisions per second of this process, consistent with the run's own counters.
TEST(DsmcPerformance, SummaryReportsRates) {
  const auto run = run_dsmc(kCase, 9, 1, "perf");
  const auto& s = run.summary;
  const double wall = s.number("performance.wall_seconds");
  ASSERT_GT(wall, 0.0);
  // 30000 particles, 100 steps
  EXPECT_NEAR(s.number("performance.particle_steps_per_second") * wall, 30000.0 * 100, 1e-6 * 30000.0 * 100);
  const double collisions = s.number("counters.bath_collisions") + s.number("counters.grain_collisions");
  ASSERT_GT(collisions, 0.0);
  EXPECT_NEAR(s.number("performance.collisions_per_second") * wall, collisions, 1e-9 * collisions);
  EXPECT_EQ(s.number("performance.threads"), 1.0);
  // the step loop and the set-up before it are parts of the run (RunTimes), and the loop's
  // rates are the same counts over the loop's time
  const double setup = s.number("performance.setup_seconds"), loop = s.number("performance.loop_seconds");
  EXPECT_GT(setup, 0.0);
  EXPECT_GT(loop, 0.0);
  EXPECT_LE(setup + loop, wall);
  EXPECT_NEAR(s.number("performance.loop_particle_steps_per_second") * loop, 30000.0 * 100, 1e-6 * 30000.0 * 100);
  EXPECT_NEAR(s.number("performance.loop_collisions_per_second") * loop, collisions, 1e-9 * collisions);
}
