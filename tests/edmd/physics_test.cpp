// Physics checks through the driver (read_config + run), fixed seeds, short runs.
// Tolerances: several standard errors measured by the run itself, plus the reference
// EOS's own accuracy (KR fit / CS: a few 0.1 % in this range).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/case_file.hpp"
#include "core/summary.hpp"
#include "edmd/edmd.hpp"
#include "edmd/theory.hpp"

using namespace grainbath;
using namespace grainbath::edmd;

namespace {
Summary run_case(const std::string& toml, std::uint64_t seed = 1) {
  CaseReader r(toml, "test.toml");
  Config c = read_config(r);
  r.finish();
  RunContext ctx;
  ctx.out_dir = std::filesystem::temp_directory_path() / ("edmd_test_" + std::to_string(::getpid()) + "_" + std::to_string(seed));
  std::filesystem::create_directories(ctx.out_dir);
  ctx.seed = seed;
  ctx.quiet = true;
  ctx.case_text = toml;
  Summary s;
  run(c, ctx, s);
  std::filesystem::remove_all(ctx.out_dir);
  return s;
}
}  // namespace

struct EosPoint {
  int dims;
  double packing;
  int particles;
};

class EdmdEos : public ::testing::TestWithParam<EosPoint> {};

TEST_P(EdmdEos, ElasticCompressibilityMatchesReference) {
  const auto p = GetParam();
  const std::string toml = "[edmd]\ndimensions = " + std::to_string(p.dims) + "\nparticles = " +
                           std::to_string(p.particles) + "\npacking_fraction = " + std::to_string(p.packing) +
                           "\nequilibrate = 30\ncollisions = 150\n[sampling]\ninterval = 0.5\n";
  const Summary s = run_case(toml, 2);
  const double z = s.number("pressure.Z"), err = s.number("pressure.Z_stderr");
  const double ref = theory::z_reference(p.dims, p.packing);
  EXPECT_GT(err, 0.0);
  EXPECT_LT(err / z, 0.01);
  // 5 sigma plus the reference's own accuracy
  EXPECT_NEAR(z, ref, 5.0 * err + 0.004 * ref) << "dims " << p.dims << " packing " << p.packing;
  EXPECT_NEAR(s.number("temperature.mean"), 1.0, 1e-9);
  EXPECT_NEAR(s.number("conservation.relative_energy_change_elastic"), 0.0, 1e-11);
  EXPECT_GE(s.number("overlap.min_distance"), 1.0 - 1e-9);
}

INSTANTIATE_TEST_SUITE_P(Fast, EdmdEos,
                         ::testing::Values(EosPoint{2, 0.1, 900}, EosPoint{2, 0.4, 900}, EosPoint{2, 0.6, 900},
                                           EosPoint{3, 0.1, 1000}, EosPoint{3, 0.3, 1000}, EosPoint{3, 0.45, 1000}));

TEST(EdmdPhysics, ElasticCollisionRateMatchesEnskogWithinOnePercent) {
  for (int dims : {2, 3}) {
    const double packing = dims == 2 ? 0.3 : 0.25;
    const Summary s = run_case("[edmd]\ndimensions = " + std::to_string(dims) +
                               "\nparticles = 1000\npacking_fraction = " + std::to_string(packing) +
                               "\nequilibrate = 20\ncollisions = 200\n");
    EXPECT_NEAR(s.number("collision.frequency_over_enskog"), 1.0, 0.01) << dims;
    // molecular chaos at collision (Bizon after eq. 33): <v_n>_c = sqrt(pi T), <v_n^2>_c = 4T
    EXPECT_NEAR(s.number("collision.vn_over_sqrt_piT"), 1.0, 0.01) << dims;
    EXPECT_NEAR(s.number("collision.vn2_over_4T"), 1.0, 0.015) << dims;
  }
}
