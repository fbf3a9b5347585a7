// Long validation runs (label "long"; ctest --test-dir build-edmd -L long).
#include <gtest/gtest.h>

#include <cmath>

#include "edmd/edmd.hpp"

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
