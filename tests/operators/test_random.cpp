// Counter-based RNG: reproducible, independent streams, correct first moments.
#include <gtest/gtest.h>

#include <cmath>

#include "operators/random.hpp"

using namespace grainbath;

TEST(CounterRng, SameKeyAndCounterGiveSameNumbers) {
  CounterRng a(42, Stream::grain_collisions, 7, 3), b(42, Stream::grain_collisions, 7, 3);
  for (int k = 0; k < 100; ++k) ASSERT_EQ(a.uniform(), b.uniform());
}

TEST(CounterRng, DifferentStreamsEntitiesStepsDiffer) {
  CounterRng a(42, Stream::grain_collisions, 7, 3);
  CounterRng b(42, Stream::background_first_half, 7, 3);
  CounterRng c(42, Stream::grain_collisions, 8, 3);
  CounterRng d(42, Stream::grain_collisions, 7, 4);
  CounterRng e(43, Stream::grain_collisions, 7, 3);
  const double x = a.uniform();
  EXPECT_NE(x, b.uniform());
  EXPECT_NE(x, c.uniform());
  EXPECT_NE(x, d.uniform());
  EXPECT_NE(x, e.uniform());
}

TEST(CounterRng, UsesAllFourWordsPerBlock) {
  CounterRng a(1, Stream::grain_collisions, 0, 0);
  for (int k = 0; k < 8; ++k) a.uniform();
  EXPECT_EQ(a.blocks_used(), 2u);
}

TEST(CounterRng, UniformAndNormalMoments) {
  CounterRng r(2024, Stream::initial_velocities, 1, 0);
  const int n = 1'000'000;
  double su = 0, su2 = 0, sn = 0, sn2 = 0, sn4 = 0;
  double umin = 1, umax = 0;
  for (int k = 0; k < n; ++k) {
    const double u = r.uniform();
    su += u;
    su2 += u * u;
    umin = std::min(umin, u);
    umax = std::max(umax, u);
    const double z = r.normal();
    sn += z;
    sn2 += z * z;
    sn4 += z * z * z * z;
  }
  EXPECT_GT(umin, 0.0);
  EXPECT_LT(umax, 1.0);
  // standard errors: uniform mean sqrt(1/12/n); normal mean 1/sqrt(n); <z^2> sqrt(2/n); <z^4> sqrt(96/n)
  EXPECT_NEAR(su / n, 0.5, 5 * std::sqrt(1.0 / 12 / n));
  EXPECT_NEAR(su2 / n, 1.0 / 3, 5 * std::sqrt(4.0 / 45 / n));
  EXPECT_NEAR(sn / n, 0.0, 5 / std::sqrt(n));
  EXPECT_NEAR(sn2 / n, 1.0, 5 * std::sqrt(2.0 / n));
  EXPECT_NEAR(sn4 / n, 3.0, 5 * std::sqrt(96.0 / n));
}

TEST(CounterRng, UnitVectorIsIsotropic) {
  CounterRng r(5, Stream::initial_positions, 0, 0);
  const int n = 400'000;
  double sx = 0, sz2 = 0, len_err = 0;
  for (int k = 0; k < n; ++k) {
    const Vec3 u = r.unit_vector();
    sx += u.x;
    sz2 += u.z * u.z;
    len_err = std::max(len_err, std::abs(norm(u) - 1.0));
  }
  EXPECT_LT(len_err, 1e-14);
  EXPECT_NEAR(sx / n, 0.0, 5 * std::sqrt(1.0 / 3 / n));
  EXPECT_NEAR(sz2 / n, 1.0 / 3, 5 * std::sqrt(4.0 / 45 / n));
}
