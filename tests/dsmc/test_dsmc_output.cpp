// The output stage of a DSMC run (src/dsmc/output.cpp, write_results; mutation audit
// docs/reviews/mutation-audit-dsmc-output.md): what it writes from a run's state is checked on
// synthetic states whose answers the test works out itself from their definitions in
// docs/OUTPUT.md — the window means and their blocked errors in the collision clock (T, a2,
// a3, rough grains' Trot/T), the per-cell fields from the grain visits with jackknife errors
// over the batches, the profile exponent as a weighted least-squares line with its slow-mode
// part, the energy keys, the rates, the resolution figures and their warnings, the density-mode
// keys; and the velocity histograms of a short run.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <numbers>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <variant>
#include <vector>

#include <unistd.h>

#include "core/case_file.hpp"
#include "core/h5.hpp"
#include "core/run_context.hpp"
#include "core/run_support.hpp"
#include "core/summary.hpp"
#include "dsmc/dsmc.hpp"
#include "dsmc/mode_fit.hpp"
#include "dsmc/output.hpp"
#include "dsmc/spatial.hpp"
#include "dsmc/state.hpp"
#include "hydro/transport.hpp"
#include "support.hpp"

namespace {

using grainbath::Summary;
namespace dsmc = grainbath::dsmc;

dsmc::Config config_of(const std::string& toml) {
  grainbath::CaseReader reader(toml, "/tmp/test.toml");
  dsmc::Config c = dsmc::read_config(reader);
  reader.finish();
  return c;
}

// A run's state made by hand, written by write_results into a fresh directory.
struct Synthetic {
  dsmc::Config c;
  dsmc::State s;
  dsmc::FinalGrains g;
  dsmc::RunTimes times{2.0, 0.25, 1.5};
  Summary summary;
  std::filesystem::path dir;

  Synthetic(const std::string& toml, const std::string& tag) : c(config_of(toml)) {
    const int nb = c.histogram_bins;
    g.edges.assign(nb + 1, 0.0);
    g.speed_edges.assign(nb + 1, 0.0);
    g.components.assign(3 * nb, 0.0);
    g.speed.assign(nb, 0.0);
    g.count = static_cast<std::uint64_t>(c.particles);
    g.moments.count = static_cast<double>(c.particles);
    g.moments.temperature = 1.0;
    g.hash = "0";
    dir = std::filesystem::temp_directory_path() / ("grainbath-test-output-" + tag + "-" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
  }
  // samples at t_k = k / per_unit (k = 0 .. n - 1); T, a2, a3 filled by the caller
  void series(int n, double per_unit) {
    dsmc::TimeSeries& ts = s.series;
    ts = {};
    for (int k = 0; k < n; ++k) {
      ts.t.push_back(k / per_unit);
      ts.T.push_back(1.0);
      ts.a2.push_back(0.0);
      ts.a3.push_back(0.0);
      for (int i = 0; i < 3; ++i) ts.velocity.push_back(0.0), ts.heat_flux.push_back(0.0);
      for (int i = 0; i < 6; ++i) ts.pressure.push_back(0.0);
      for (auto* v : {&ts.ke, &ts.bath_in, &ts.loss, &ts.wall_in, &ts.removed_out}) v->push_back(0.0);
      ts.count.push_back(static_cast<double>(c.particles));
      ts.bath_collisions.push_back(0);
      ts.grain_collisions.push_back(0);
    }
  }
  void write() {
    grainbath::RunContext ctx;
    ctx.out_dir = dir;
    ctx.quiet = true;
    dsmc::write_results(c, ctx, s, g, times, summary);
  }
  std::vector<double> read(const std::string& name) const {
    grainbath::H5File f((dir / "results.h5").string(), grainbath::H5File::Mode::read);
    return f.read_doubles(name);
  }
  bool has(const std::string& key) const { return summary.get(key) != nullptr; }
  ~Synthetic() { std::filesystem::remove_all(dir); }
};

// AR(1) series x_k = mean + rho (x_(k-1) - mean) + sd sqrt(1 - rho^2) e_k, fixed seed
std::vector<double> ar1(int n, double mean, double sd, double rho, std::uint64_t seed) {
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> e;
  std::vector<double> x(n);
  double y = sd * e(gen);
  for (int k = 0; k < n; ++k) {
    y = rho * y + sd * std::sqrt(1 - rho * rho) * e(gen);
    x[k] = mean + y;
  }
  return x;
}

// Cumulative bath and grain-grain collisions of a series: the grain-grain ones speed up over
// the run, the bath's do not (a clock that is not proportional to the sample index).
void fill_collisions(dsmc::TimeSeries& ts) {
  std::uint64_t bath = 0, grain = 0;
  for (std::size_t k = 1; k < ts.t.size(); ++k) {
    bath += 300 + 50 * (k % 7);
    grain += 100 + 3 * static_cast<std::uint64_t>(k) * static_cast<std::uint64_t>(k) / 10;
    ts.bath_collisions[k] = bath;
    ts.grain_collisions[k] = grain;
  }
}

// The collision clock at each sample: collisions per grain since the first sample, 2 per
// grain-grain collision and 1 per bath collision, per grain present at the sample.
std::vector<double> collision_clock(const dsmc::TimeSeries& ts) {
  std::vector<double> clock(ts.t.size(), 0.0);
  for (std::size_t k = 1; k < ts.t.size(); ++k)
    clock[k] = clock[k - 1] + (static_cast<double>(ts.bath_collisions[k] - ts.bath_collisions[k - 1]) +
                               2.0 * static_cast<double>(ts.grain_collisions[k] - ts.grain_collisions[k - 1])) /
                                  ts.count[k];
  return clock;
}

bool near_rel(double a, double b, double rel) { return std::abs(a - b) <= rel * std::max(std::abs(a), std::abs(b)); }

}  // namespace

// The window statistics (docs/OUTPUT.md temperature.*, a2.*, a3.*): over the samples with
// t >= sampling.steady_from (the sample at steady_from itself included), the plain mean, and the
// blocked error of block_average in the collision clock, "collisions per grain (2 per
// grain-grain collision, 1 per bath collision) since the first sample". The test builds the
// clock from the series' own counters; the grain collisions speed up over the run while the
// bath's do not, so neither the sample index nor a clock that counts a grain-grain collision
// once (or the counts since t = 0 instead of each interval's) block the samples the same way.
TEST(DsmcOutput, WindowStatisticsAreBlockedInTheCollisionClockOfTheSeries) {
  Synthetic x(R"(
[grains]
mass = 2.0
[background]
density = 1.0
temperature = 1.5
knudsen = 0.05
[restitution]
law = "constant"
e = 0.9
[dsmc]
particles = 4000
dt = 0.01
t_end = 2.0
[sampling]
every = 0.01
steady_from = 0.4
)", "window");
  constexpr int n = 201;
  x.series(n, 100.0);
  dsmc::TimeSeries& ts = x.s.series;
  ts.T = ar1(n, 1.2, 0.05, 0.9, 1);
  ts.a2 = ar1(n, 0.05, 0.01, 0.8, 2);
  ts.a3 = ar1(n, -0.01, 0.004, 0.95, 3);
  fill_collisions(ts);
  x.write();
  // the clock and the window, from the definitions
  const std::vector<double> all = collision_clock(ts);
  std::vector<double> Tw, a2w, a3w, clock;
  for (int k = 40; k < n; ++k) Tw.push_back(ts.T[k]), a2w.push_back(ts.a2[k]), a3w.push_back(ts.a3[k]), clock.push_back(all[k]);
  ASSERT_EQ(ts.t[40], 0.4);  // the window's first sample sits on steady_from
  EXPECT_EQ(std::get<std::int64_t>(*x.summary.get("temperature.samples")), 161);
  struct Key { const char* name; const std::vector<double>* w; };
  for (const Key& key : {Key{"temperature", &Tw}, Key{"a2", &a2w}, Key{"a3", &a3w}}) {
    SCOPED_TRACE(key.name);
    double mean = 0;
    for (double v : *key.w) mean += v;
    mean /= static_cast<double>(key.w->size());
    const grainbath::MeanError e = grainbath::block_average(*key.w, clock);
    const std::string k(key.name);
    EXPECT_TRUE(near_rel(x.summary.number(k + ".mean"), mean, 1e-13)) << x.summary.number(k + ".mean") << " vs " << mean;
    EXPECT_TRUE(near_rel(x.summary.number(k + ".stderr"), e.stderr_, 1e-12))
        << x.summary.number(k + ".stderr") << " vs " << e.stderr_;
    // the test can tell the clock from the sample index
    const double by_index = grainbath::block_average(*key.w).stderr_;
    std::printf("%s: blocked error %.6g in the clock, %.6g in the sample index\n", key.name, e.stderr_, by_index);
    if (k == "temperature") {
      EXPECT_FALSE(near_rel(by_index, e.stderr_, 0.01));
    }
  }
}

// rotation.R (docs/OUTPUT.md): Trot/T over the same window, blocked in the same collision
// clock as T and a2; rotation.R_final the last sample's ratio.
TEST(DsmcOutput, RotationRatioIsBlockedInTheCollisionClock) {
  Synthetic x(R"(
[grains]
rotational_temperature = 0.5
[background]
density = 1.0
[restitution]
law = "walton"
e = 0.9
beta0 = -0.5
q = 0.4
[dsmc]
particles = 4000
dt = 0.01
t_end = 2.0
[sampling]
every = 0.01
steady_from = 0.4
)", "rotation");
  constexpr int n = 201;
  x.series(n, 100.0);
  dsmc::TimeSeries& ts = x.s.series;
  ts.T = ar1(n, 1.2, 0.05, 0.9, 4);
  ts.Trot = ar1(n, 0.6, 0.05, 0.95, 5);
  fill_collisions(ts);
  x.write();
  const std::vector<double> all = collision_clock(ts);
  std::vector<double> R, clock;
  for (int k = 40; k < n; ++k) R.push_back(ts.Trot[k] / ts.T[k]), clock.push_back(all[k]);
  double mean = 0;
  for (double r : R) mean += r / static_cast<double>(R.size());
  const grainbath::MeanError e = grainbath::block_average(R, clock);
  EXPECT_TRUE(near_rel(x.summary.number("rotation.R"), mean, 1e-13));
  EXPECT_TRUE(near_rel(x.summary.number("rotation.R_stderr"), e.stderr_, 1e-12))
      << x.summary.number("rotation.R_stderr") << " vs " << e.stderr_;
  EXPECT_DOUBLE_EQ(x.summary.number("rotation.R_final"), ts.Trot.back() / ts.T.back());
  EXPECT_FALSE(near_rel(grainbath::block_average(R).stderr_, e.stderr_, 0.01));
}

// Whether temperature.mean/stderr are written (docs/OUTPUT.md): not for a gas that only cools
// (no medium, no diffuse wall, inelastic), for every other. A diffuse wall on the y faces
// alone heats the gas as well as one on x; a power law with beta = 0 is elastic. And
// theory.homogeneous: false with a diffuse or an open face (the run's table gives no sigma).
TEST(DsmcOutput, TemperatureMeanIsWrittenUnlessTheGasOnlyCools) {
  auto run = [](const std::string& boundaries, const std::string& law, const std::string& tag) {
    const std::string wall = boundaries.find("diffuse") != std::string::npos ? "wall_temperature = 2.0\n" : "";
    auto x = std::make_unique<Synthetic>(R"(
[domain]
dimensions = 2
length = [1.0, 1.0]
cells = [2, 2]
boundaries = )" + boundaries + "\n" + wall + R"(
[background]
density = 0.0
[restitution]
)" + law + R"(
[dsmc]
particles = 1000
dt = 0.01
t_end = 1.0
[sampling]
every = 0.1
steady_from = 0.5
)", tag);
    x->series(11, 10.0);
    x->write();
    return x;
  };
  const std::string inelastic = "law = \"constant\"\ne = 0.9";
  const auto periodic = run("[\"periodic\", \"periodic\"]", inelastic, "cool");
  EXPECT_FALSE(periodic->has("temperature.mean"));
  EXPECT_TRUE(std::get<bool>(*periodic->summary.get("theory.homogeneous")));
  const auto walls_y = run("[\"periodic\", \"diffuse\"]", inelastic, "walls-y");
  EXPECT_TRUE(walls_y->has("temperature.mean"));
  EXPECT_TRUE(walls_y->has("temperature.stderr"));
  EXPECT_FALSE(std::get<bool>(*walls_y->summary.get("theory.homogeneous")));
  const auto walls_x = run("[\"diffuse\", \"periodic\"]", inelastic, "walls-x");
  EXPECT_TRUE(walls_x->has("temperature.mean"));
  const auto power = run("[\"periodic\", \"periodic\"]", "law = \"power\"\nbeta = 0.0\ndelta = 0.2", "power");
  EXPECT_TRUE(power->has("temperature.mean"));
  const auto open = run("[\"periodic\", \"open\"]", inelastic, "open");
  EXPECT_FALSE(open->has("temperature.mean"));
  EXPECT_FALSE(std::get<bool>(*open->summary.get("theory.homogeneous")));
}

// The energy keys (docs/OUTPUT.md): inputs and losses per *initial* grain (grains leave
// through open faces), the budget residual (dKE - inputs + losses + outflow) / max(|KE0|, |each
// term|) — here a residual of 0.5 put in by hand; velocity.final |u - uB|; the collision rate of
// this process's part (a resumed run counts only its own collisions); the resolution figures
// from the sampled grain count and temperature (2 grains per collision).
TEST(DsmcOutput, EnergyRateAndResolutionKeysFollowTheirDefinitions) {
  Synthetic x(R"(
[domain]
dimensions = 1
length = [4.0]
cells = [4]
boundaries = ["diffuse", "open"]
wall_temperature = 2.0
[grains]
mass = 2.0
[background]
density = 1.0
temperature = 1.5
knudsen = 0.05
velocity = [0.2, -0.1, 0.3]
[restitution]
law = "constant"
e = 0.9
[dsmc]
particles = 4000
dt = 0.01
t_end = 1.0
[sampling]
every = 0.1
steady_from = 0.5
)", "energy");
  x.series(11, 10.0);
  dsmc::TimeSeries& ts = x.s.series;
  for (int k = 0; k < 11; ++k) ts.count[k] = 4000.0 - 20.0 * k, ts.T[k] = 1.0 + 0.1 * k;
  x.g.count = 3800;
  x.g.moments.count = 3800;
  x.g.moments.mean_velocity = {0.5, 0.1, -0.2};
  dsmc::RunCounters& rc = x.s.counters;
  rc.bath_energy = 30.0;
  rc.wall_energy = 12.0;
  rc.grain.energy_loss = 25.0;
  rc.removed_energy = 4.0;
  rc.removed = 200;
  rc.bath_collisions = 5000;
  rc.grain.collisions = 7000;
  x.s.initial_kinetic_energy = 6000.0;
  x.g.moments.kinetic_energy = 6000.0 + 30.0 + 12.0 - 25.0 - 4.0 + 0.5;
  x.s.collisions_before_run = 1000;
  x.write();
  const Summary& s = x.summary;
  EXPECT_DOUBLE_EQ(s.number("energy.bath_input_per_grain"), 30.0 / 4000);
  EXPECT_DOUBLE_EQ(s.number("energy.wall_input_per_grain"), 12.0 / 4000);
  EXPECT_DOUBLE_EQ(s.number("energy.inelastic_loss_per_grain"), 25.0 / 4000);
  EXPECT_NEAR(s.number("energy.budget_relative_residual"), 0.5 / 6000, 1e-12);
  EXPECT_DOUBLE_EQ(s.number("velocity.final"), std::sqrt(0.3 * 0.3 + 0.2 * 0.2 + 0.5 * 0.5));
  EXPECT_DOUBLE_EQ(s.number("performance.collisions_per_second"), 11000.0 / 2.0);
  EXPECT_DOUBLE_EQ(s.number("performance.loop_collisions_per_second"), 11000.0 / 1.5);
  // resolution: the mean sampled count (3900) and temperature (1.5), 100 steps
  const double per_step = 2.0 * 7000 / (3900.0 * 100);
  EXPECT_DOUBLE_EQ(s.number("resolution.grain_collisions_per_grain_step"), per_step);
  const double mean_speed = std::sqrt(8 * 1.5 / (std::numbers::pi * 2.0));
  EXPECT_NEAR(s.number("resolution.mean_free_path"), mean_speed / (per_step / 0.01), 1e-12);
  EXPECT_DOUBLE_EQ(s.number("resolution.cell_size"), 1.0);
}

// Resolution (docs/dsmc.md "Time step"): a warning above 0.5 grain-grain collisions per grain
// and step and none below; the largest cell side is what is compared with the mean free path
// and the travel per step; a warning when the mean speed crosses more than one cell per step.
TEST(DsmcOutput, ResolutionWarnsAtItsThresholdsAndTakesTheLargestCell) {
  const dsmc::Config c = config_of(R"(
[domain]
dimensions = 2
length = [1.0, 8.0]
cells = [4, 4]
[restitution]
law = "elastic"
[dsmc]
particles = 1000
dt = 0.01
t_end = 1.0
)");
  // 1000 grains, 100 steps, T = pi m / 8: mean speed 1; collisions per grain step 2 C / 1e5
  const double T = std::numbers::pi / 8;
  auto has = [](const dsmc::Resolution& r, const char* what) {
    for (const auto& w : r.warnings)
      if (w.find(what) != std::string::npos) return true;
    return false;
  };
  const dsmc::Resolution low = dsmc::resolution(c, 20000, 100, 1000.0, T), high = dsmc::resolution(c, 30000, 100, 1000.0, T);
  EXPECT_DOUBLE_EQ(low.collisions_per_grain_step, 0.4);
  EXPECT_DOUBLE_EQ(high.collisions_per_grain_step, 0.6);
  EXPECT_FALSE(has(low, "collisions per step"));
  EXPECT_TRUE(has(high, "collisions per step"));
  EXPECT_DOUBLE_EQ(low.cell_size, 2.0);  // the y side; x: 0.25
  EXPECT_DOUBLE_EQ(low.mean_free_path, 1.0 / (0.4 / 0.01));  // 0.025
  EXPECT_TRUE(has(low, "mean free path"));
  // travel: mean speed 1 x dt over the 2.0 side
  dsmc::Config slow = c, fast = c;
  slow.dt = 1.8, fast.dt = 2.4;
  EXPECT_NEAR(dsmc::resolution(slow, 1, 100, 1000.0, T).travel_per_step, 0.9, 1e-12);
  EXPECT_FALSE(has(dsmc::resolution(slow, 1, 100, 1000.0, T), "cells per step"));
  EXPECT_TRUE(has(dsmc::resolution(fast, 1, 100, 1000.0, T), "cells per step"));
}

namespace {

// Grain visits of a 1D isobaric_sine run's cells, by cell and batch, summed into the
// FieldAccumulator as the sampler does (count, sum v, sum v_i v_j, sum |v|^2 v, sum |v|^2).
// Batch 2 of 5 is empty (a window with fewer samples than batches). The cells' densities
// follow n ~ <TB^-p> times (1 + delta_k), delta_k of standard deviation delta_sd; the batches'
// counts scatter about the cell's by 3 %, the deviations summing to zero over the batches.
struct Visits {
  static constexpr int kBatches = 5, kCells = 16, kEmpty = 2;
  static constexpr std::int64_t kSamplesPerBatch = 3;
  std::vector<std::vector<std::vector<std::array<double, 3>>>> v;  // [cell][batch][visit]
};

const char* kProfileCase = R"(
[domain]
dimensions = 1
length = [2.0]
cells = [16]
[grains]
mass = 2.0
density = 1.0
[background]
mass_ratio = 0.3
density = 1.0
temperature = 1.5
knudsen = 0.05
profile = "isobaric_sine"
amplitude = 0.3
[restitution]
law = "elastic"
[dsmc]
particles = 4000
dt = 0.01
t_end = 1.0
[sampling]
every = 0.05
steady_from = 0.5
field_batches = 5
)";

Visits fill_fields(Synthetic& x, double delta_sd, std::uint64_t seed) {
  const dsmc::Config& c = x.c;
  Visits out;
  out.v.assign(Visits::kCells, std::vector<std::vector<std::array<double, 3>>>(Visits::kBatches));
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> g;
  std::exponential_distribution<double> ex;
  const double weight = c.grains.density * c.domain.volume() / static_cast<double>(c.particles);
  dsmc::FieldAccumulator& fa = x.s.fields;
  constexpr int K = dsmc::FieldAccumulator::kSums;
  fa.batches = Visits::kBatches;
  fa.cells = Visits::kCells;
  fa.sums.assign(static_cast<std::size_t>(Visits::kBatches) * Visits::kCells * K, 0.0);
  fa.batch_samples.assign(Visits::kBatches, Visits::kSamplesPerBatch);
  fa.batch_samples[Visits::kEmpty] = 0;
  fa.taken = 4 * Visits::kSamplesPerBatch;
  fa.window_samples = fa.taken;
  for (int k = 0; k < Visits::kCells; ++k) {
    const double n = std::exp(-0.8 * dsmc::cell_mean_log_background_temperature(c, k)) * (1 + delta_sd * g(gen));
    double eta[4], mean = 0;
    for (double& e : eta) e = 0.03 * g(gen), mean += e / 4;
    for (int b = 0, j = 0; b < Visits::kBatches; ++b) {
      if (b == Visits::kEmpty) continue;
      const double visits = Visits::kSamplesPerBatch * n * (1 + eta[j++] - mean) * c.domain.cell_volume() / weight;
      double* a = fa.sums.data() + (static_cast<std::size_t>(b) * Visits::kCells + k) * K;
      for (long i = 0; i < std::lround(visits); ++i) {
        const double g1 = g(gen), g2 = g(gen);
        const std::array<double, 3> v = {0.3 + 0.01 * k + 0.8 * g1, -0.2 + 0.6 * g2 + 0.3 * g1, 0.5 + 0.7 * (ex(gen) - 1)};
        out.v[k][b].push_back(v);
        const double v2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        const double s[K] = {1, v[0], v[1], v[2], v[0] * v[0], v[1] * v[1], v[2] * v[2], v[0] * v[1], v[0] * v[2],
                             v[1] * v[2], v2 * v[0], v2 * v[1], v2 * v[2], v2};
        for (int q = 0; q < K; ++q) a[q] += s[q];
      }
    }
  }
  x.series(21, 20.0);  // t = 0 ... 1 by 0.05: the window t >= 0.5 lasts 0.5
  return out;
}

// A cell's fields from its visits (all batches but `skip`), from the central moments
// c = v - u (docs/OUTPUT.md /fields: n, u, P_ij = n m <c_i c_j>, T = m <|c|^2>/3,
// q = n (m/2) <|c|^2 c>).
struct Ref {
  double n = 0, T = 0, u[3] = {}, P[6] = {}, q[3] = {};
};
Ref reference(const Visits& vis, int k, int skip, const dsmc::Config& c) {
  const double weight = c.grains.density * c.domain.volume() / static_cast<double>(c.particles), m = c.grains.mass;
  Ref r;
  double count = 0, samples = 0;
  for (int b = 0; b < Visits::kBatches; ++b) {
    if (b == skip || b == Visits::kEmpty) continue;
    samples += Visits::kSamplesPerBatch;
    for (const auto& v : vis.v[k][b]) {
      count += 1;
      for (int i = 0; i < 3; ++i) r.u[i] += v[i];
    }
  }
  for (double& u : r.u) u /= count;
  r.n = count * weight / c.domain.cell_volume() / samples;
  const int ij[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};
  for (int b = 0; b < Visits::kBatches; ++b) {
    if (b == skip || b == Visits::kEmpty) continue;
    for (const auto& v : vis.v[k][b]) {
      const double cc[3] = {v[0] - r.u[0], v[1] - r.u[1], v[2] - r.u[2]};
      const double c2 = cc[0] * cc[0] + cc[1] * cc[1] + cc[2] * cc[2];
      for (int q = 0; q < 6; ++q) r.P[q] += r.n * m * cc[ij[q][0]] * cc[ij[q][1]] / count;
      r.T += m * c2 / 3 / count;
      for (int i = 0; i < 3; ++i) r.q[i] += r.n * 0.5 * m * c2 * cc[i] / count;
    }
  }
  return r;
}

}  // namespace

// The per-cell fields (docs/OUTPUT.md /fields) against the moments of the visits computed
// in the test, with m = 2, a drift in every component, a correlated (P_xy) and skewed (q)
// velocity distribution. The density's jackknife error over equal batches is the standard
// error of the batch densities, sqrt(sum (n_b - n)^2 / (B (B - 1))), B the batches with
// samples (an empty one counts for nothing); the temperature's is the jackknife of the
// leave-one-batch-out temperatures computed from the visits. The background fields are TB and
// nB of the case's profile at the cell centres.
TEST(DsmcOutput, CellFieldsAreTheMomentsOfTheGrainVisits) {
  Synthetic x(kProfileCase, "fields");
  const Visits vis = fill_fields(x, 0.05, 11);
  x.write();
  const dsmc::Config& c = x.c;
  const auto n = x.read("/fields/density"), nerr = x.read("/fields/density_stderr"), T = x.read("/fields/temperature"),
             Terr = x.read("/fields/temperature_stderr"), u = x.read("/fields/velocity"),
             P = x.read("/fields/pressure_tensor"), q = x.read("/fields/heat_flux"), xc = x.read("/fields/x"),
             bgT = x.read("/fields/background_temperature"), bgn = x.read("/fields/background_density");
  ASSERT_EQ(n.size(), 16u);
  for (int k = 0; k < Visits::kCells; ++k) {
    SCOPED_TRACE(k);
    const Ref r = reference(vis, k, -1, c);
    EXPECT_TRUE(near_rel(n[k], r.n, 1e-12)) << n[k] << " vs " << r.n;
    EXPECT_TRUE(near_rel(T[k], r.T, 1e-10)) << T[k] << " vs " << r.T;
    for (int i = 0; i < 3; ++i) EXPECT_TRUE(near_rel(u[3 * k + i], r.u[i], 1e-12)) << i;
    for (int i = 0; i < 6; ++i) EXPECT_NEAR(P[6 * k + i], r.P[i], 1e-10 * std::abs(r.P[0])) << i;
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(q[3 * k + i], r.q[i], 1e-9 * std::abs(r.q[2])) << i;
    // the density's error: the standard error of the batch densities
    std::vector<double> nb;
    for (int b = 0; b < Visits::kBatches; ++b)
      if (b != Visits::kEmpty)
        nb.push_back(static_cast<double>(vis.v[k][b].size()) * c.grains.density * c.domain.volume() /
                     static_cast<double>(c.particles) / c.domain.cell_volume() / Visits::kSamplesPerBatch);
    double nbar = 0, ss = 0;
    for (double v : nb) nbar += v / nb.size();
    for (double v : nb) ss += (v - nbar) * (v - nbar);
    EXPECT_TRUE(near_rel(nerr[k], std::sqrt(ss / (nb.size() * (nb.size() - 1.0))), 1e-10));
    // the temperature's: jackknife of the leave-one-out temperatures
    std::vector<double> left;
    for (int b = 0; b < Visits::kBatches; ++b)
      if (b != Visits::kEmpty) left.push_back(reference(vis, k, b, c).T);
    double lbar = 0, ls = 0;
    for (double v : left) lbar += v / left.size();
    for (double v : left) ls += (v - lbar) * (v - lbar);
    EXPECT_TRUE(near_rel(Terr[k], std::sqrt(ls * (left.size() - 1.0) / left.size()), 1e-8)) << Terr[k];
    // the background at the cell centre
    const double x_c = (k + 0.5) * 2.0 / 16, f = 1 + 0.3 * std::sin(std::numbers::pi * x_c);
    EXPECT_NEAR(xc[k], x_c, 1e-14);
    EXPECT_NEAR(bgT[k], 1.5 * f, 1e-12);
    EXPECT_NEAR(bgn[k], 1.0 / f, 1e-12);
  }
}

// profile.exponent (docs/OUTPUT.md): -p, the slope of the least-squares line of ln n_cell
// against <ln TB>_cell, each cell weighted by 1/sigma^2, sigma = n_err/n; the fit's error
// 1/sqrt(sum w (x - xbar)^2), times sqrt(chi^2/(cells - 2)) when that exceeds 1; the modes'
// part slow_mode_error over the cell centres with the slope's weights w (x - xbar)/sum w (x -
// xbar)^2, the densities relative to their mean, D the kinetic one averaged over the cells
// (nB, TB at the centres) and the window t_end - steady_from; the total sqrt(fit^2 + modes^2).
// Computed here in the centred form from /fields/density and its error. Two sets of cells:
// on the power law exactly (chi^2 far below 1: no scaling) and scattered off it by 5 %
// (chi^2/(cells - 2) well above 1).
TEST(DsmcOutput, ProfileExponentIsTheWeightedLineFitOfTheCells) {
  for (const double delta : {0.0, 0.05}) {
    SCOPED_TRACE(delta);
    Synthetic x(kProfileCase, "profile");
    fill_fields(x, delta, 12);
    x.write();
    const dsmc::Config& c = x.c;
    const auto n = x.read("/fields/density"), nerr = x.read("/fields/density_stderr");
    std::vector<double> X, Y, W;
    for (int k = 0; k < 16; ++k) {
      X.push_back(dsmc::cell_mean_log_background_temperature(c, k));
      Y.push_back(std::log(n[k]));
      W.push_back(1 / ((nerr[k] / n[k]) * (nerr[k] / n[k])));
    }
    double sw = 0, xbar = 0, ybar = 0;
    for (int k = 0; k < 16; ++k) sw += W[k], xbar += W[k] * X[k], ybar += W[k] * Y[k];
    xbar /= sw, ybar /= sw;
    double sxx = 0, sxy = 0;
    for (int k = 0; k < 16; ++k) sxx += W[k] * (X[k] - xbar) * (X[k] - xbar), sxy += W[k] * (X[k] - xbar) * (Y[k] - ybar);
    const double slope = sxy / sxx;
    double chi2 = 0;
    for (int k = 0; k < 16; ++k) chi2 += W[k] * std::pow(Y[k] - ybar - slope * (X[k] - xbar), 2);
    const double red = chi2 / 14;
    if (delta == 0.0) EXPECT_LT(red, 0.1);
    else EXPECT_GT(red, 2.0);
    const double fit = std::sqrt(1 / sxx) * std::sqrt(std::max(1.0, red));
    EXPECT_TRUE(near_rel(x.summary.number("profile.exponent"), -slope, 1e-10)) << x.summary.number("profile.exponent");
    EXPECT_NEAR(x.summary.number("profile.exponent"), 0.8, delta == 0.0 ? 0.01 : 0.2);
    EXPECT_TRUE(near_rel(x.summary.number("profile.exponent_stderr_fit"), fit, 1e-10))
        << x.summary.number("profile.exponent_stderr_fit") << " vs " << fit;
    // the slow modes' part
    std::vector<double> xs, ws, rs;
    double nbar = 0, D = 0;
    for (int k = 0; k < 16; ++k) nbar += n[k] / 16;
    for (int k = 0; k < 16; ++k) {
      const double x_c = (k + 0.5) * 0.125, f = 1 + 0.3 * std::sin(std::numbers::pi * x_c);
      xs.push_back(x_c);
      ws.push_back(W[k] * (X[k] - xbar) / sxx);
      rs.push_back(n[k] / nbar);
      D += grainbath::hydro::diffusion_coefficient_kinetic(0.3, 2.0, 1.0 / f, 1.5 * f, 0.05) / 16;
    }
    const double modes = dsmc::slow_mode_error(xs, ws, rs, 2.0, 0.125, 4000.0, D, 0.5);
    ASSERT_GT(modes, 0.0);
    EXPECT_TRUE(near_rel(x.summary.number("profile.exponent_stderr_modes"), modes, 1e-10))
        << x.summary.number("profile.exponent_stderr_modes") << " vs " << modes;
    EXPECT_TRUE(near_rel(x.summary.number("profile.exponent_stderr"), std::hypot(fit, modes), 1e-10));
  }
}

// The velocity histograms (docs/OUTPUT.md /histogram): densities in units of sqrt(T/m), each
// normalised to 1 over its range (components on [-6, 6], the speed on [0, 6]): their sums times
// the bin widths are the fraction of grains within range, 1 for a Maxwellian but for
// about 2e-9 of them per component.
TEST(DsmcOutput, VelocityHistogramsAreNormalisedDensities) {
  const auto run = grainbath::testing::run_dsmc(grainbath::testing::free_cooling_case(1.0, 4000, 0.01, 0.2, 0.1, 0.0), 5);
  const auto comp = run.series("/histogram/components"), speed = run.series("/histogram/speed"),
             edges = run.series("/histogram/component_edges"), sedges = run.series("/histogram/speed_edges");
  const std::size_t nb = speed.size();
  ASSERT_EQ(comp.size(), 3 * nb);
  ASSERT_EQ(edges.size(), nb + 1);
  EXPECT_DOUBLE_EQ(edges.front(), -6.0);
  EXPECT_DOUBLE_EQ(edges.back(), 6.0);
  EXPECT_DOUBLE_EQ(sedges.front(), 0.0);
  EXPECT_DOUBLE_EQ(sedges.back(), 6.0);
  for (int d = 0; d < 3; ++d) {
    double sum = 0;
    for (std::size_t b = 0; b < nb; ++b) sum += comp[d * nb + b] * (edges[b + 1] - edges[b]);
    EXPECT_NEAR(sum, 1.0, 1e-9) << d;
  }
  double sum = 0;
  for (std::size_t b = 0; b < nb; ++b) sum += speed[b] * (sedges[b + 1] - sedges[b]);
  EXPECT_NEAR(sum, 1.0, 1e-9);
}

// The density-mode keys (docs/OUTPUT.md mode.*): the fit of B exp(-Gamma t) with the noise
// model of the projection 2 |<exp(ikx)>| of N uniform grains, variance 2/N (that of 2 cos kx
// over x uniform, averaged over N), over the case's fit window; the first sample's amplitude.
TEST(DsmcOutput, ModeKeysAreTheFitOfTheSampledAmplitudeWithTheProjectionsNoise) {
  Synthetic x(R"(
[domain]
dimensions = 1
length = [10.0]
cells = [10]
[grains]
profile = "mode"
amplitude = 0.1
[restitution]
law = "elastic"
[dsmc]
particles = 2500
dt = 0.01
t_end = 2.0
[sampling]
every = 0.05
steady_from = 0.0
mode_fit_to = 1.5
)", "mode");
  x.series(41, 20.0);
  std::mt19937_64 gen(21);
  std::normal_distribution<double> e;
  for (double t : x.s.series.t) x.s.series.mode_amplitude.push_back(0.1 * std::exp(-0.7 * t) + 0.028 * e(gen));
  x.write();
  const auto& ts = x.s.series;
  const dsmc::ModeDecayFit f = dsmc::fit_mode_decay(ts.t, ts.mode_amplitude, 2.0 / 2500, 0.0, 1.5);
  ASSERT_TRUE(std::isfinite(f.rate));
  EXPECT_TRUE(near_rel(x.summary.number("mode.decay_rate"), f.rate, 1e-12));
  EXPECT_TRUE(near_rel(x.summary.number("mode.decay_rate_stderr"), f.rate_stderr, 1e-12));
  EXPECT_EQ(std::get<std::int64_t>(*x.summary.get("mode.fit_points")), 31);
  EXPECT_DOUBLE_EQ(x.summary.number("mode.initial_amplitude"), ts.mode_amplitude.front());
}

// ---- fields.xdmf (docs/OUTPUT.md "Cell fields"; the h5/XDMF/commands mutation audit,
// docs/reviews/mutation-audit-h5-xdmf-commands.md): read back as XML by the test, each number
// checked against the case and each data item against the dataset of results.h5 it names.
namespace {

// name -> value of the XML attributes in a tag's text (`a="x" b="y"`)
std::map<std::string, std::string> xml_attributes(const std::string& tag) {
  std::map<std::string, std::string> out;
  static const std::regex attr(R"re(([A-Za-z_]+)="([^"]*)")re");
  for (auto it = std::sregex_iterator(tag.begin(), tag.end(), attr); it != std::sregex_iterator(); ++it)
    out[(*it)[1]] = (*it)[2];
  return out;
}

std::string whole_file(const std::filesystem::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::vector<double> numbers(const std::string& text) {
  std::istringstream in(text);
  std::vector<double> v;
  for (double x; in >> x;) v.push_back(x);
  return v;
}

// The elements of an XML text balance (every opened element closed in order); "" or what is wrong.
std::string unbalanced(const std::string& xml) {
  static const std::regex tag(R"(<(/?)([A-Za-z_][A-Za-z0-9_]*)[^>]*?(/?)>)");
  std::vector<std::string> open;
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), tag); it != std::sregex_iterator(); ++it) {
    const std::string name = (*it)[2];
    if ((*it)[3] == "/") continue;  // <X/>
    if ((*it)[1] == "/") {
      if (open.empty() || open.back() != name) return "</" + name + "> closes " + (open.empty() ? "nothing" : open.back());
      open.pop_back();
    } else {
      open.push_back(name);
    }
  }
  return open.empty() ? "" : "<" + open.back() + "> never closed";
}

// A spatial run's fields written from a field accumulator with one grain visit per cell and
// sample (the XDMF does not depend on the values).
struct XdmfRun : Synthetic {
  explicit XdmfRun(const std::string& toml, const std::string& tag) : Synthetic(toml, tag) {
    dsmc::FieldAccumulator& fa = s.fields;
    constexpr int K = dsmc::FieldAccumulator::kSums;
    fa.batches = 2;
    fa.cells = static_cast<int>(c.domain.cell_count());
    fa.sums.assign(static_cast<std::size_t>(fa.batches) * fa.cells * K, 0.0);
    for (std::size_t k = 0; k < fa.sums.size(); k += K) fa.sums[k] = 2.0;
    fa.batch_samples.assign(fa.batches, 2);
    fa.taken = 4;
    fa.window_samples = 4;
    series(21, 20.0);
  }
};

// Checks OUT/fields.xdmf of a run of `c` against docs/OUTPUT.md and results.h5.
void check_xdmf(const XdmfRun& x) {
  const dsmc::Domain& d = x.c.domain;
  const std::string xml = whole_file(x.dir / "fields.xdmf");
  EXPECT_EQ(unbalanced(xml), "") << xml;
  std::smatch m;
  // 3D CoRectMesh: node counts z y x, one more than the cells along each axis
  ASSERT_TRUE(std::regex_search(xml, m, std::regex(R"(<Topology ([^>]*)/>)"))) << xml;
  auto topo = xml_attributes(m[1]);
  EXPECT_EQ(topo["TopologyType"], "3DCoRectMesh");
  EXPECT_EQ(numbers(topo["Dimensions"]),
            (std::vector<double>{d.cells[2] + 1.0, d.cells[1] + 1.0, d.cells[0] + 1.0}));
  // origin 0 and spacing L/cells, z y x (1 along an unused axis: length 1, one cell)
  ASSERT_TRUE(std::regex_search(
      xml, m, std::regex(R"(<Geometry ([^>]*)>\s*<DataItem ([^>]*)>([^<]*)</DataItem>\s*<DataItem ([^>]*)>([^<]*)</DataItem>\s*</Geometry>)")))
      << xml;
  EXPECT_EQ(xml_attributes(m[1])["GeometryType"], "ORIGIN_DXDYDZ");
  EXPECT_EQ(xml_attributes(m[2])["Format"], "XML");
  EXPECT_EQ(numbers(m[3]), (std::vector<double>{0, 0, 0}));
  const std::vector<double> spacing = numbers(m[5]);
  ASSERT_EQ(spacing.size(), 3u) << m[5];
  for (int axis = 0; axis < 3; ++axis)
    EXPECT_NEAR(spacing[2 - axis], d.length[axis] / d.cells[axis], 1e-12 * d.length[axis]) << "axis " << axis;
  // the attributes: the six scalars and two vectors of docs/OUTPUT.md, each cell data naming a
  // dataset of results.h5 with its shape and 8-byte floats
  std::map<std::string, std::string> listed;
  static const std::regex att(R"(<Attribute ([^>]*)>\s*<DataItem ([^>]*)>([^<]*)</DataItem>\s*</Attribute>)");
  grainbath::H5File f((x.dir / "results.h5").string(), grainbath::H5File::Mode::read);
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), att); it != std::sregex_iterator(); ++it) {
    auto a = xml_attributes((*it)[1]);
    auto item = xml_attributes((*it)[2]);
    const std::string name = a["Name"], text = (*it)[3];
    SCOPED_TRACE(name);
    EXPECT_TRUE(listed.emplace(name, a["AttributeType"]).second) << "listed twice";
    EXPECT_EQ(a["Center"], "Cell");
    EXPECT_EQ(item["Format"], "HDF");
    EXPECT_EQ(item["NumberType"], "Float");
    EXPECT_EQ(item["Precision"], "8");
    // a path relative to the XDMF file: results.h5 beside it
    EXPECT_EQ(text, "results.h5:/fields/" + name);
    std::vector<double> cells = {static_cast<double>(d.cells[2]), static_cast<double>(d.cells[1]),
                                 static_cast<double>(d.cells[0])};
    if (a["AttributeType"] == "Vector") cells.push_back(3);
    EXPECT_EQ(numbers(item["Dimensions"]), cells);
    if (!f.exists("/fields/" + name)) {
      ADD_FAILURE() << "/fields/" << name << " is not in results.h5";
      continue;
    }
    std::vector<hsize_t> dims;
    f.read_doubles("/fields/" + name, &dims);
    EXPECT_EQ(std::vector<double>(dims.begin(), dims.end()), cells);
  }
  EXPECT_EQ(listed, (std::map<std::string, std::string>{{"density", "Scalar"},
                                                        {"density_stderr", "Scalar"},
                                                        {"temperature", "Scalar"},
                                                        {"temperature_stderr", "Scalar"},
                                                        {"background_temperature", "Scalar"},
                                                        {"background_density", "Scalar"},
                                                        {"velocity", "Vector"},
                                                        {"heat_flux", "Vector"}}));
}

const char* kBoxCase = R"(
[domain]
dimensions = 3
length = [2.0, 1.5, 0.75]
cells = [4, 3, 5]
[background]
mass_ratio = 0.5
density = 1.0
temperature = 1.0
knudsen = 0.1
[restitution]
law = "elastic"
[dsmc]
particles = 600
dt = 0.01
t_end = 1.0
[sampling]
every = 0.05
steady_from = 0.5
field_batches = 2
)";

}  // namespace

// fields.xdmf of a 3D box with a different cell count and length along each axis (so that an
// axis order or a count off by one shows), and of the 1D box of kProfileCase (unused axes:
// one cell of length 1, spacing 1).
TEST(DsmcOutput, FieldsXdmfDescribesTheFieldsOfResultsH5OnTheirCells) {
  for (const char* toml : {kBoxCase, kProfileCase}) {
    XdmfRun x(toml, "xdmf");
    x.write();
    SCOPED_TRACE(x.c.domain.dimensions);
    check_xdmf(x);
  }
}

// A fields.xdmf that cannot be written (here a directory in its place) fails the output
// stage with the file named, rather than leaving a run without it and saying nothing.
TEST(DsmcOutput, AnXdmfThatCannotBeWrittenIsAnError) {
  XdmfRun x(kBoxCase, "xdmf-fail");
  std::filesystem::create_directories(x.dir / "fields.xdmf");
  try {
    x.write();
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("fields.xdmf: cannot write the XDMF file"), std::string::npos) << e.what();
  }
}
