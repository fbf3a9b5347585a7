// The run's own check of dt and the cells (Resolution, src/dsmc/output.hpp; docs/dsmc.md
// "Time step"). The figures it reports are checked against kinetic theory, not against the
// code's formula: in the code's scaled units a grain meets the others at rate n|g|
// (src/dsmc/collide.hpp, collide_cell), and for a Maxwellian <|g|> = sqrt(2) <|v|>, so the
// mean free path <|v|>/(n <|g|>) is 1/(sqrt(2) n) whatever the temperature, and each grain
// takes part in n <|g|> dt = n sqrt(2) sqrt(8T/(pi m)) dt collisions per step.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <variant>

#include "dsmc/output.hpp"
#include "support.hpp"

namespace {

std::string text_of(const grainbath::Summary& s, const std::string& key) {
  const auto* v = s.get(key);
  if (v == nullptr) return "";
  const auto* t = std::get_if<std::string>(v);
  return t ? *t : "";
}

std::string elastic_case(double density, double dt, int particles, double t_end) {
  char b[512];
  std::snprintf(b, sizeof b, R"(
[grains]
density = %.17g
temperature = 1.0
[restitution]
law = "elastic"
[dsmc]
particles = %d
dt = %.17g
t_end = %.17g
[sampling]
every = %.17g
steady_from = 0.0
)",
                density, particles, dt, t_end, t_end / 4);
  return b;
}

}  // namespace

// An elastic Maxwellian gas at n = 2, T = 1: the measured collisions per grain and step and
// the mean free path agree with kinetic theory within 4 standard errors of the collision
// count (Poisson), and a resolved run carries no warning.
TEST(DsmcResolution, MeanFreePathAndCollisionsPerStepFollowKineticTheory) {
  const double n = 2.0, dt = 0.01;
  const int grains = 20000;
  const double t_end = 1.0;
  const auto run = grainbath::testing::run_dsmc(elastic_case(n, dt, grains, t_end), 7, 1, "resolution");
  const double collisions = run.summary.number("counters.grain_collisions");
  const double rel_err = 1.0 / std::sqrt(collisions);  // Poisson
  const double mean_speed = std::sqrt(8.0 / std::numbers::pi);
  const double per_step = n * std::numbers::sqrt2 * mean_speed * dt;
  const double lambda = 1.0 / (std::numbers::sqrt2 * n);
  EXPECT_NEAR(run.summary.number("resolution.grain_collisions_per_grain_step") / per_step, 1.0, 4 * rel_err);
  EXPECT_NEAR(run.summary.number("resolution.mean_free_path") / lambda, 1.0, 4 * rel_err);
  EXPECT_EQ(text_of(run.summary, "resolution.warning_1"), "");
}

// A time step of ~3 collisions per grain warns, naming dt and a dt that resolves it; cells
// wider than the mean free path and a grain crossing several cells per step warn in a
// spatial run; a resolved spatial run does not.
TEST(DsmcResolution, UnresolvedTimeStepAndCellsWarn) {
  const auto coarse = grainbath::testing::run_dsmc(elastic_case(2.0, 1.0, 4000, 4.0), 7, 1, "resolution-dt");
  const std::string w = text_of(coarse.summary, "resolution.warning_1");
  EXPECT_NE(w.find("dsmc.dt = 1:"), std::string::npos) << w;
  EXPECT_NE(w.find("use dt <="), std::string::npos) << w;
  EXPECT_GT(coarse.summary.number("resolution.grain_collisions_per_grain_step"), 3.0);

  auto spatial = [](int cells, double dt) {
    char b[160];
    std::snprintf(b, sizeof b, "[domain]\ndimensions = 1\nlength = [4.0]\ncells = [%d]\nboundaries = [\"periodic\"]\n", cells);
    return std::string(b) + elastic_case(1.0, dt, 4000, 40 * dt);
  };
  // 4 cells of side 1 against lambda = 0.707; dt = 1: 1.6 cell sides per step
  const auto wide = grainbath::testing::run_dsmc(spatial(4, 1.0), 7, 1, "resolution-cells");
  std::string all = text_of(wide.summary, "resolution.warning_1") + "|" + text_of(wide.summary, "resolution.warning_2") +
                    "|" + text_of(wide.summary, "resolution.warning_3");
  EXPECT_NE(all.find("exceeds the grains' mean free path"), std::string::npos) << all;
  EXPECT_NE(all.find("cells per step"), std::string::npos) << all;
  EXPECT_DOUBLE_EQ(wide.summary.number("resolution.cell_size"), 1.0);
  // 40 cells of 0.1 and dt = 0.01: 0.16 cell sides per step, 0.023 collisions per grain
  const auto fine = grainbath::testing::run_dsmc(spatial(40, 0.01), 7, 1, "resolution-fine");
  EXPECT_EQ(text_of(fine.summary, "resolution.warning_1"), "");
  EXPECT_NEAR(fine.summary.number("resolution.travel_per_step_in_cells"), std::sqrt(8.0 / std::numbers::pi) * 0.01 / 0.1,
              1e-9);
}
