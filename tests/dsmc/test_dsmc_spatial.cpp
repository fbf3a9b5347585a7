// Spatial DSMC (Issue #4): particle number under each boundary rule, diffuse and open walls
// against the kinetic theory of effusion, advection with the
// background drift, and the density-mode decay rate at small eps against the kinetic
// (Sonine-Galerkin) diffusion coefficient of hydro/.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include <hdf5.h>

#include "core/h5.hpp"
#include "dsmc/spatial.hpp"
#include "hydro/hydro.hpp"
#include "support.hpp"

using grainbath::testing::run_dsmc;

namespace {
std::string box(const std::string& boundaries, const std::string& extra = "") {
  // a wall temperature only with a diffuse face: without one the reader rejects it as unused
  const std::string wall = boundaries.find("diffuse") != std::string::npos ? "wall_temperature = 2.0\n" : "";
  return R"(
[domain]
dimensions = 2
length = [1.0, 1.0]
cells = [8, 8]
boundaries = )" + boundaries + "\n" + wall + R"(
[grains]
temperature = 1.0
[background]
density = 0.0
[restitution]
law = "constant"
e = 0.9
[dsmc]
particles = 6000
dt = 0.01
t_end = 2.0
[sampling]
every = 0.1
steady_from = 1.0
)" + extra;
}
}  // namespace

TEST(DsmcSpatial, ParticleNumberUnderEachBoundaryRule) {
  for (const char* b : {R"(["periodic"])", R"(["specular"])", R"(["diffuse"])", R"(["periodic", "diffuse"])"}) {
    const auto run = run_dsmc(box(b), 3, 0, "bnd");
    const auto count = run.series("/timeseries/particles");
    for (double c : count) ASSERT_EQ(c, 6000.0) << b;
    EXPECT_LT(std::abs(run.summary.number("energy.budget_relative_residual")), 1e-10) << b;
  }
  // diffuse walls at T = 2 heat the cooling grains: the wall energy input is positive
  const auto hot = run_dsmc(box(R"(["diffuse"])"), 3, 0, "hot");
  EXPECT_GT(hot.summary.number("energy.wall_input_per_grain"), 0.0);
  // open faces: particles leave, and every one is counted
  const auto open = run_dsmc(box(R"(["open", "periodic"])"), 3, 0, "open");
  const double left = open.summary.number("counters.particles_removed");
  EXPECT_GT(left, 1000.0);
  EXPECT_EQ(open.summary.number("counters.particles_final") + left, 6000.0);
  EXPECT_LT(std::abs(open.summary.number("energy.budget_relative_residual")), 1e-10);
}

// /timeseries carries a `units` attribute (docs/OUTPUT.md): it names every dataset of the group
// (until 2026-12-06 it left out a2, a3, the pressure tensor, the heat flux and the counts)
TEST(DsmcSpatial, TimeseriesUnitsNameEveryDataset) {
  const auto run = run_dsmc(box(R"(["open", "diffuse"])"), 3, 0, "units");
  const std::string file = (run.dir / "results.h5").string();
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  std::vector<std::string> names;
  const hid_t g = H5Gopen2(f, "/timeseries", H5P_DEFAULT);
  ASSERT_GE(g, 0);
  H5G_info_t info;
  H5Gget_info(g, &info);
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    char name[256] = {};
    H5Lget_name_by_idx(g, ".", H5_INDEX_NAME, H5_ITER_INC, i, name, sizeof name, H5P_DEFAULT);
    names.emplace_back(name);
  }
  H5Gclose(g);
  H5Fclose(f);
  ASSERT_GE(names.size(), 15u);
  const std::string units = grainbath::H5File(file, grainbath::H5File::Mode::read).read_attribute("/timeseries", "units");
  for (const auto& n : names) {
    const bool per_grain = n.ends_with("_per_grain");
    EXPECT_TRUE(per_grain || units.find(n + ":") != std::string::npos || units.find(n + ",") != std::string::npos)
        << "/timeseries/" << n << " has no unit in: " << units;
  }
  EXPECT_NE(units.find("*_per_grain: energy per initial grain"), std::string::npos) << units;
}

TEST(DsmcSpatial, GrainsAdvectWithTheBackgroundDrift) {
  const auto run = run_dsmc(R"(
[domain]
dimensions = 1
length = [2.0]
cells = [20]
[grains]
temperature = 1.0
profile = "mode"
amplitude = 0.2
[background]
mass_ratio = 0.5
density = 1.0
temperature = 1.0
velocity = [0.7, 0.0, -0.3]
knudsen = 0.1
[restitution]
law = "elastic"
[dsmc]
particles = 40000
dt = 0.01
t_end = 2.0
[sampling]
every = 0.05
steady_from = 1.0
)",
                            8, 0, "drift");
  const auto t = run.series("/timeseries/t");
  const auto u = run.series("/timeseries/velocity");
  // after a few momentum relaxation times the mean grain velocity is uB (Bisi-Spiga eq. 32)
  double ux = 0, uz = 0;
  int k = 0;
  for (std::size_t i = 0; i < t.size(); ++i)
    if (t[i] >= 1.0) {
      ux += u[3 * i];
      uz += u[3 * i + 2];
      ++k;
    }
  // thermal noise of the mean of 40000 velocities: sqrt(T/m/N) = 0.005
  EXPECT_NEAR(ux / k, 0.7, 0.02);
  EXPECT_NEAR(uz / k, -0.3, 0.02);
}

// At small eps the mode decays at D k^2 with the kinetic D (elastic grains: T = TB, so the
// density dependence of T# that shifts the rate at O(eps^2) is absent). kε = 0.126. The
// error bar comes from independent replicas (the fit's own error ignores that the mode's
// thermal fluctuations are correlated over the decay time itself).
TEST(DsmcSpatial, ModeDecayRateMatchesKineticDiffusionAtSmallEps) {
  const double eps = 0.05, alpha = 0.5, L = 2.5;
  const char* toml = R"(
[domain]
dimensions = 1
length = [2.5]
cells = [25]
[grains]
temperature = 1.0
profile = "mode"
amplitude = 0.3
[background]
mass_ratio = 0.5
density = 1.0
temperature = 1.0
knudsen = 0.05
[restitution]
law = "elastic"
[dsmc]
particles = 30000
dt = 0.004
t_end = 5.0
[sampling]
every = 0.04
steady_from = 0.0
mode_fit_from = 0.2
fields = false
)";
  std::vector<double> rates;
  for (int r = 0; r < 4; ++r) rates.push_back(run_dsmc(toml, 100 + r, 0, "mode").summary.number("mode.decay_rate"));
  double mean = 0, var = 0;
  for (double x : rates) mean += x;
  mean /= rates.size();
  for (double x : rates) var += (x - mean) * (x - mean);
  const double err = std::sqrt(var / (rates.size() - 1) / rates.size());
  const double k = 2 * std::numbers::pi / L;
  const double D = grainbath::hydro::diffusion_coefficient_kinetic(alpha, 1.0, 1.0, 1.0, eps);
  const double Dp = grainbath::hydro::diffusion_coefficient_paper(alpha, 1.0, 1.0, 1.0, eps);
  std::printf("mode decay: DSMC %.5f +- %.5f (4 replicas), kinetic D k^2 = %.5f, paper %.5f\n", mean, err, D * k * k,
              Dp * k * k);
  EXPECT_GT(err, 0.0);
  // power guard, not the physics check: the replica standard error must be small enough for
  // the 4-sigma comparison below to mean something. With 4 replicas the sample SD is a chi
  // variable with 3 degrees of freedom (99.5th percentile 2.07 sigma); the standard error
  // measured with two different draws was 2.6 % and 4.1 % of the rate, so the guard sits at 6.5 %.
  EXPECT_LT(err, 0.065 * mean);
  EXPECT_NEAR(mean, D * k * k, 4 * err);
}

namespace {
// Writes `text` to dir/case.toml and runs it from there (so that a relative file name in it
// resolves in dir), the output in dir/tag.
grainbath::testing::CaseRun run_case_in(const std::filesystem::path& dir, const std::string& text,
                                        const std::string& tag, std::uint64_t seed) {
  std::ofstream(dir / "case.toml") << text;
  grainbath::CaseReader reader = grainbath::CaseReader::from_directory(dir.string());
  auto cfg = grainbath::dsmc::read_config(reader);
  reader.finish();
  grainbath::testing::CaseRun out;
  out.dir = dir / tag;
  std::filesystem::create_directories(out.dir);
  grainbath::RunContext ctx;
  ctx.out_dir = out.dir;
  ctx.seed = seed;
  ctx.quiet = true;
  grainbath::dsmc::run(cfg, ctx, out.summary);
  return out;
}
}  // namespace

// Background fields from an HDF5 grid: a grid holding the uniform values reproduces the
// uniform run bitwise; a grid of the wrong shape or without a dataset is a case error
// naming [background] file.
TEST(DsmcSpatial, BackgroundFromFile) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("grainbath-bgfile-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  auto write_grid = [&](const std::string& name, std::size_t cells, bool with_velocity) {
    grainbath::H5File f((dir / name).string(), grainbath::H5File::Mode::create);
    f.write("density", std::vector<double>(cells, 1.5));
    f.write("temperature", std::vector<double>(cells, 0.8));
    if (with_velocity) {
      std::vector<double> v(3 * cells, 0.0);
      // all three components, so that the grid's y and z cannot be exchanged unseen
      for (std::size_t k = 0; k < cells; ++k) v[3 * k] = 0.25, v[3 * k + 1] = 0.125, v[3 * k + 2] = -0.0625;
      f.write("velocity", v);
    }
  };
  write_grid("good.h5", 8, true);
  write_grid("short.h5", 5, true);
  write_grid("novelocity.h5", 8, false);
  auto toml = [&](const std::string& background) {
    return R"(
[domain]
dimensions = 1
length = [2.0]
cells = [8]
[grains]
temperature = 1.0
[background]
mass_ratio = 0.4
knudsen = 0.2
)" + background + R"(
[restitution]
law = "constant"
e = 0.9
[dsmc]
particles = 4000
dt = 0.01
t_end = 0.5
[sampling]
every = 0.1
steady_from = 0.2
)";
  };
  auto run_in_dir = [&](const std::string& text, const std::string& tag) { return run_case_in(dir, text, tag, 3); };
  const auto uniform =
      run_in_dir(toml("density = 1.5\ntemperature = 0.8\nvelocity = [0.25, 0.125, -0.0625]"), "uniform");
  const auto from_file = run_in_dir(toml("profile = \"file\"\nfile = \"good.h5\""), "file");
  EXPECT_EQ(uniform.series("/timeseries/temperature"), from_file.series("/timeseries/temperature"));
  EXPECT_EQ(uniform.series("/timeseries/velocity"), from_file.series("/timeseries/velocity"));
  for (const char* bad : {"short.h5", "novelocity.h5", "missing.h5"}) {
    std::ofstream(dir / "case.toml") << toml(std::string("profile = \"file\"\nfile = \"") + bad + "\"");
    grainbath::CaseReader reader = grainbath::CaseReader::from_directory(dir.string());
    try {
      grainbath::dsmc::read_config(reader);
      reader.finish();
      ADD_FAILURE() << bad << " was accepted";
    } catch (const grainbath::CaseError& e) {
      EXPECT_NE(std::string(e.what()).find("background.file"), std::string::npos) << e.what();
    }
  }
  fs::remove_all(dir);
}

namespace {
// The shear cases below: a 2D box of 16 cells along y, elastic grains, a strong coupling
// (eps = 0.05); `medium` is the [background] lines that give uB.
std::string shear_case(const std::string& medium) {
  return R"(
[domain]
dimensions = 2
length = [0.5, 2.0]
cells = [1, 16]
[grains]
temperature = 1.0
[background]
mass_ratio = 0.5
knudsen = 0.05
)" + medium + R"(
[restitution]
law = "elastic"
[dsmc]
particles = 32000
dt = 0.005
t_end = 2.0
[sampling]
every = 0.02
steady_from = 0.5
field_batches = 8
)";
}

// The amplitude of sin(2 pi y / L) in the grains' mean x velocity of the 16 cells (least
// squares at the cell centres; /fields/velocity is [z][y][x][3]).
double fitted_shear_amplitude(const std::vector<double>& u) {
  double proj = 0, norm2 = 0;
  for (int j = 0; j < 16; ++j) {
    const double s = std::sin(2 * std::numbers::pi * (j + 0.5) / 16);
    proj += u[3 * j] * s;
    norm2 += s * s;
  }
  return proj / norm2;
}
}  // namespace

// Steady shear background uB = (U0 sin(k y), 0, 0): at small eps the grains' mean velocity
// follows it cell by cell (momentum relaxation rate ~ 1/eps beats the grains' own viscosity).
TEST(DsmcSpatial, GrainsFollowTheShearBackground) {
  const auto run = run_dsmc(shear_case("density = 1.0\ntemperature = 1.0\nprofile = \"shear\"\namplitude = 0.5\n"
                                       "wavenumber_index = 1"),
                            41, 0, "shear");
  const double amplitude = fitted_shear_amplitude(run.series("/fields/velocity"));
  std::printf("shear: fitted grain amplitude %.4f (background 0.5)\n", amplitude);
  // noise per cell ~ sqrt(T/(m * 2000 grains * 75 samples)) / sqrt(8 batches) ~ 3e-3
  EXPECT_NEAR(amplitude, 0.5, 0.025);
}

// The same shear, given per cell by a file ([background] profile = "file": uB at the cell
// centres): the bath substep must look up each grain's own cell. Read with any one cell's
// medium for every grain, the drift would be uniform and its sine amplitude zero.
TEST(DsmcSpatial, GrainsFollowTheShearOfAFileMediumCellByCell) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("grainbath-bgshear-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  {
    grainbath::H5File f((dir / "shear.h5").string(), grainbath::H5File::Mode::create);
    f.write("density", std::vector<double>(16, 1.0));
    f.write("temperature", std::vector<double>(16, 1.0));
    std::vector<double> v(3 * 16, 0.0);
    for (int j = 0; j < 16; ++j) v[3 * j] = 0.5 * std::sin(2 * std::numbers::pi * (j + 0.5) / 16);
    f.write("velocity", v);
  }
  const auto run = run_case_in(dir, shear_case("profile = \"file\"\nfile = \"shear.h5\""), "out", 41);
  const double amplitude = fitted_shear_amplitude(run.series("/fields/velocity"));
  std::printf("file shear: fitted grain amplitude %.4f (background 0.5 at the cell centres)\n", amplitude);
  // the noise as in GrainsFollowTheShearBackground (~3e-3); the medium constant over a cell
  // (against the sine of the analytic profile) moves the amplitude by less than 1 %
  EXPECT_NEAR(amplitude, 0.5, 0.025);
  fs::remove_all(dir);
}

// Diffuse walls against the kinetic theory of a wall in contact with a Maxwellian gas
// (independent of the wall routine's own formulas). A grain is re-emitted from a wall at Tw
// with a flux-weighted normal component (|v_n| Rayleigh, <v_n^2> = 2 Tw/m) and Gaussian
// tangential components, so it leaves with mean kinetic energy 2 Tw; grains of a Maxwellian
// gas at T reach a wall with mean energy 2 T (flux-weighted by |v_x|), at a rate of
// n sqrt(T / (2 pi m)) per unit area.
namespace {
std::string maxwellian_slab(double t_end, int particles, const char* mass, const char* sampling,
                         const char* faces = "boundaries = [\"diffuse\"]\nwall_temperature = 1.0\n") {
  return std::string(R"(
[domain]
dimensions = 1
length = [1.0]
cells = [8]
)") + faces + R"(
[grains]
temperature = 2.0
mass = )" + mass + R"(
[restitution]
law = "elastic"
[dsmc]
particles = )" + std::to_string(particles) + R"(
dt = 0.01
t_end = )" + std::to_string(t_end) + R"(
[sampling]
)" + sampling;
}

struct SeedMean {
  double mean = 0.0, sem = 0.0;
};
SeedMean over_seeds(const std::vector<double>& v) {
  double m = 0.0, q = 0.0;
  for (double x : v) m += x;
  m /= static_cast<double>(v.size());
  for (double x : v) q += (x - m) * (x - m);
  return {m, std::sqrt(q / static_cast<double>(v.size() - 1) / static_cast<double>(v.size()))};
}
}  // namespace

// One step of a uniform Maxwellian slab (T0 = 2, m = 2) between diffuse walls at Tw = 1: the
// fraction of grains that reach one of the two walls within dt is 2 (dt / L) sqrt(T0 / (2 pi
// m)), each bringing 2 (Tw - T0) on average, so the wall input per grain is
// 4 (dt / L) sqrt(T0 / (2 pi m)) (Tw - T0) = -0.015958. Measured over 8 seeds of 200,000
// grains (2026-12-05: -0.01611 +- 0.00031); a half-normal instead of a flux-weighted normal
// component gives 2.5 / 2 of it (checked: -0.02011 +- 0.00030 fails), a missing factor of
// m in the emitted speed or in the energy the wrong value.
TEST(DsmcWalls, FirstStepWallEnergyMatchesTheEffusionFlux) {
  std::vector<double> input;
  for (int seed = 1; seed <= 8; ++seed)
    input.push_back(run_dsmc(maxwellian_slab(0.01, 200000, "2.0", "every = 0.01\nsteady_from = 0.0\n"), seed, 0, "effusion").summary.number("energy.wall_input_per_grain"));
  const SeedMean e = over_seeds(input);
  const double expected = 4.0 * 0.01 * std::sqrt(2.0 / (2.0 * std::numbers::pi * 2.0)) * (1.0 - 2.0);
  std::printf("wall input per grain in the first step: %.6f +- %.6f (8 seeds), effusion theory %.6f\n", e.mean, e.sem,
              expected);
  EXPECT_LT(e.sem, 0.03 * std::abs(expected));  // the test resolves a few per cent
  EXPECT_NEAR(e.mean, expected, 5.0 * e.sem);
}

// A gas of elastic grains between two diffuse walls at Tw relaxes to the equilibrium at Tw
// (the walls' emission is the wall Maxwellian's flux, so detailed balance holds at T = Tw
// only; a half-normal emission settles at 0.75 Tw: checked, 0.7489 +- 0.0013 fails). Start
// at T0 = 2 Tw, average T over t = 5 .. 15 (about ten wall crossings per grain), 6 seeds of
// 20,000 grains: the seed mean within 5 standard errors of Tw (2026-12-05: 0.99991 +-
// 0.00076). The standard error is taken between seeds: the run's own temperature.stderr
// treats the correlated samples as nearly independent and is ~1.5 times too small here.
TEST(DsmcWalls, DiffuseWallsThermaliseTheGasAtTheWallTemperature) {
  std::vector<double> temperature;
  for (int seed = 1; seed <= 6; ++seed)
    temperature.push_back(run_dsmc(maxwellian_slab(15.0, 20000, "1.0", "every = 0.05\nsteady_from = 5.0\n"), seed, 0, "thermalise").summary.number("temperature.mean"));
  const SeedMean t = over_seeds(temperature);
  std::printf("steady temperature between diffuse walls at Tw = 1: %.5f +- %.5f (6 seeds)\n", t.mean, t.sem);
  EXPECT_LT(t.sem, 0.003);
  EXPECT_NEAR(t.mean, 1.0, 5.0 * t.sem);
}

// Open faces let out the effusion flux: in one step of a uniform Maxwellian slab (T0 = 2,
// m = 2, L = 1, dt = 0.01) a fraction 2 (dt / L) sqrt(T0 / (2 pi m)) = 0.0079788 of the
// grains leaves through the two faces, 1595.8 of 200,000. 8 seeds (2026-12-05: 1611.4 +-
// 12.2, +1.3 standard errors).
TEST(DsmcWalls, OpenFacesLetOutTheEffusionFlux) {
  std::vector<double> removed;
  for (int seed = 1; seed <= 8; ++seed)
    removed.push_back(run_dsmc(maxwellian_slab(0.01, 200000, "2.0", "every = 0.01\nsteady_from = 0.0\n",
                                            "boundaries = [\"open\"]\n"),
                               seed, 0, "open-effusion")
                          .summary.number("counters.particles_removed"));
  const SeedMean r = over_seeds(removed);
  const double expected = 200000.0 * 2.0 * 0.01 * std::sqrt(2.0 / (2.0 * std::numbers::pi * 2.0));
  std::printf("grains out of two open faces in the first step: %.1f +- %.1f (8 seeds), effusion theory %.1f\n", r.mean,
              r.sem, expected);
  EXPECT_LT(r.sem, 0.03 * expected);
  EXPECT_NEAR(r.mean, expected, 5.0 * r.sem);
}

// The grain-grain collision rate in cells with few grains (src/dsmc/collide.hpp,
// cell_partner_density). An elastic gas in equilibrium at n = 1, T = 1 (no medium) in a
// periodic 1D box of 20000 grains, at 2, 4 and 16 grains per cell on average: Boltzmann's
// rate per grain is n <|g|> with <|g|> = 4 sqrt(T/(pi m)) for a Maxwellian, so the run must
// count (1/2) N n <|g|> t collisions, times (N - 1)/N (the partners of a grain among a fixed
// population dealt over the cells), whatever the cell occupation. The count is a sum of
// rare independent events: its standard error is about its square root (0.3 %), and the
// tolerance is 5 of those. Counting the grain itself in its cell's density (the code before
// 2026-12-05) gives (1 + 1/<N>) times as many: +50 %, +25 %, +6 % here (checked: fails).
TEST(DsmcSpatial, CellCollisionRateIsBoltzmannsAtFewGrainsPerCell) {
  constexpr int kParticles = 20000;
  constexpr double kTime = 5.0;
  for (int per_cell : {2, 4, 16}) {
    const int cells = kParticles / per_cell;
    const std::string toml = R"(
[domain]
dimensions = 1
length = [100.0]
cells = [)" + std::to_string(cells) + R"(]
[grains]
density = 1.0
temperature = 1.0
[restitution]
law = "elastic"
[dsmc]
particles = 20000
dt = 0.01
t_end = 5.0
[sampling]
every = 1.0
steady_from = 0.0
)";
    SCOPED_TRACE(toml);
    const auto run = run_dsmc(toml, 41 + per_cell);
    const double mean_relative_speed = 4.0 * std::sqrt(1.0 / std::numbers::pi);
    const double expected = 0.5 * kParticles * 1.0 * mean_relative_speed * kTime * (kParticles - 1.0) / kParticles;
    const double counted = run.summary.number("counters.grain_collisions");
    std::printf("%2d grains per cell: %.0f collisions, Boltzmann %.0f (%+.2f sigma)\n", per_cell, counted, expected,
                (counted - expected) / std::sqrt(expected));
    EXPECT_NEAR(counted, expected, 5.0 * std::sqrt(expected));
    // elastic: the energy is kept exactly, so the gas stays at T = 1
    EXPECT_LT(std::abs(run.summary.number("energy.budget_relative_residual")), 1e-12);
  }
}

// The per-cell fields are ratios of the window's totals (src/dsmc/output.cpp), so the number
// of batches, which serves only the standard errors, cannot change them. Before 2026-12-05
// each batch subtracted its own mean velocity and the fields averaged the batches' ratios,
// a bias of about -T g / M per batch of M grain visits (an elastic gas at T = 1 and 2 grains
// per cell, 401 samples: the cells' temperature averaged 0.955 with 2 batches, 0.772 with the
// default 16 and 0.538 with 64; this test fails on that code). The cells' temperatures then average to the gas's T = 1 (kept
// exactly: elastic, no medium) less the window estimate's own bias, -T g/M_window: 0.951 here
// (M_window = 82 visits, so g ~ 4 samples of correlated velocity in a cell); the tolerance
// takes 0.93-1.
TEST(DsmcSpatial, FieldsDoNotDependOnTheNumberOfBatches) {
  auto run = [](int batches) {
    return run_dsmc(R"(
[domain]
dimensions = 1
length = [500.0]
cells = [1000]
[grains]
density = 1.0
temperature = 1.0
[restitution]
law = "elastic"
[dsmc]
particles = 2000
dt = 0.05
t_end = 10.0
[sampling]
every = 0.25
steady_from = 0.0
field_batches = )" + std::to_string(batches) + "\n",
                    7, 0, "batches-" + std::to_string(batches));
  };
  const auto few = run(2), many = run(32);
  grainbath::testing::expect_same_fields(few, many);
  const std::vector<double> T = many.series("/fields/temperature"), Terr = many.series("/fields/temperature_stderr");
  double mean = 0;
  for (double x : T) mean += x;
  mean /= static_cast<double>(T.size());
  std::printf("cells' temperature: mean %.4f over %zu cells (gas: T = 1)\n", mean, T.size());
  EXPECT_NEAR(mean, 0.965, 0.035);
  for (std::size_t i = 0; i < Terr.size(); ++i) EXPECT_GT(Terr[i], 0.0) << i;  // jackknife over 32 batches
}

// The profile exponent fits ln n_cell against <ln TB> over each cell (src/dsmc/output.cpp),
// not ln TB at the cell's centre: for n ~ TB^-p exactly, cell-averaged, the centre value gives
// p 0.0013 too low with cases/thermal-gradient's 32 cells (A = 0.3, p = 0.819), the cell mean
// of ln TB 4e-5 (computed by quadrature). Here: the cell mean against an independent
// 20001-point trapezoid of ln(TB0 (1 + A sin kx)), and its distance from the centre value,
// so that the test fails if the centre value is used. TB is sigma^2 mB with the medium's mass
// (mass_ratio 0.3: at 1/2, mB = m and ln(sigma^2 m) would pass unseen; mutation S12 of
// docs/reviews/mutation-audit-dsmc-fused-spatial.md).
TEST(DsmcSpatial, CellMeanOfLogBackgroundTemperature) {
  grainbath::CaseReader reader(R"(
[domain]
dimensions = 1
length = [2.0]
cells = [32]
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
particles = 1000
)", "/tmp/test.toml");
  const grainbath::dsmc::Config c = grainbath::dsmc::read_config(reader);
  reader.finish();
  const double w = 2.0 / 32, k = std::numbers::pi;
  double largest_gap = 0;
  for (std::size_t cell = 0; cell < 32; ++cell) {
    constexpr int M = 20000;
    double integral = 0;
    for (int q = 0; q <= M; ++q) {
      const double x = cell * w + w * q / M;
      integral += (q == 0 || q == M ? 0.5 : 1.0) * std::log(1.5 * (1.0 + 0.3 * std::sin(k * x)));
    }
    integral /= M;
    const double mean = grainbath::dsmc::cell_mean_log_background_temperature(c, cell);
    EXPECT_NEAR(mean, integral, 1e-6) << cell;  // the midpoint rule's error, w^2/(24 * 64^2) (ln TB)'' < 3e-7
    largest_gap = std::max(largest_gap, std::abs(mean - std::log(1.5 * (1.0 + 0.3 * std::sin(k * (cell + 0.5) * w)))));
  }
  EXPECT_GT(largest_gap, 1e-4);  // the centre value is not what is fitted
}
