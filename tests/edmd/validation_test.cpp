// Long validation runs (label "long"; ctest --test-dir build-edmd -L long).
#include <gtest/gtest.h>

#include <cmath>

#include "edmd/edmd.hpp"
#include "tests/edmd/config_support.hpp"

using namespace grainbath;
using namespace grainbath::edmd;

TEST(EdmdLong, NoOverlapsAfterAMillionCollisions) {
  for (int dims : {2, 3}) {
    Config c;
    c.dims = dims;
    c.particles = dims == 2 ? 2500 : 2197;
    c.packing_fraction = dims == 2 ? 0.65 : 0.45;
    const auto init = make_initial_state(c, 17);
    Engine eng(make_setup(c, 17), init.positions, init.velocities);
    eng.synchronize();
    const double e0 = eng.kinetic_energy();
    for (int k = 1; k <= 10; ++k) {
      eng.advance(ElasticRestitution{}, kInf, 100000ull * k);
      eng.synchronize();
      ASSERT_GE(eng.min_distance(), 1.0 - 1e-9) << "after " << eng.counters().collisions;
    }
    EXPECT_EQ(eng.counters().collisions, 1000000u);
    EXPECT_NEAR(eng.kinetic_energy() / e0 - 1.0, 0.0, 1e-11);
    EXPECT_TRUE(eng.calendar_valid());
  }
}

TEST(EdmdLong, InelasticDrivenNoOverlapsAfterAMillionCollisions) {
  Config c;
  c.dims = 2;
  c.particles = 1764;
  c.packing_fraction = 0.5;
  c.heating.kind = HeatingKind::white_noise;
  c.heating.kick = 0.62;
  const auto init = make_initial_state(c, 5);
  Engine eng(make_setup(c, 5), init.positions, init.velocities);
  eng.advance(BizonRestitution{0.7, 1.0}, kInf, 1000000);
  eng.synchronize();
  EXPECT_GE(eng.min_distance(), 1.0 - 1e-9);
}

#include <filesystem>
#include <unistd.h>

#include "core/case_file.hpp"
#include "core/summary.hpp"
#include "edmd/theory.hpp"

namespace {
Summary run_long(const std::string& toml, std::uint64_t seed) {
  return grainbath::edmd::testing::run_summary(toml, seed, "edmd_long");
}
}  // namespace

// The EOS to 0.5 % and within 4 standard errors of the accurate references (KR fit for
// disks, Kolafa-Labik-Malijevsky for spheres); CS itself within 0.5 %.
TEST(EdmdLong, EquationOfStateWithinHalfAPercent) {
  struct P {
    int dims;
    double packing;
    int n;
  };
  for (const P p : {P{2, 0.3, 2500}, P{2, 0.6, 2500}, P{3, 0.3, 2197}, P{3, 0.45, 2197}}) {
    const Summary s = run_long("[edmd]\ndimensions = " + std::to_string(p.dims) + "\nparticles = " +
                                   std::to_string(p.n) + "\npacking_fraction = " + std::to_string(p.packing) +
                                   "\nequilibrate = 100\ncollisions = 800\n[sampling]\ninterval = 2.0\n",
                               3);
    const double z = s.number("pressure.Z"), err = s.number("pressure.Z_stderr");
    const double accurate = p.dims == 2 ? theory::z_disk_kr(p.packing) : theory::z_sphere_klm(p.packing);
    const double classic = p.dims == 2 ? theory::z_disk_kr(p.packing) : theory::z_carnahan_starling(p.packing);
    EXPECT_NEAR(z / classic, 1.0, 0.005) << p.dims << " " << p.packing;
    EXPECT_NEAR(z, accurate, 4.0 * err + 0.001 * accurate) << p.dims << " " << p.packing << " err " << err;
    EXPECT_LT(err / z, 0.002);
  }
}
