// The NTC bound of the grain-grain collisions (src/dsmc/collide.hpp, BoundGuard; docs/dsmc.md
// "Grain-grain collisions"): with `[dsmc] bound = "exact"` the step's bound stays above every
// pair's |g| through the step's collisions, so each pair collides at exactly (n / (N - 1)) |g|
// at any time step; Bird's start-of-step bound ("bird") under-samples the pairs that a
// collision made faster than it.
//
// Reference, independent of the DSMC: the microcanonical pair rate of an isolated cell
// (tests/dsmc/microcanonical.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "dsmc/collide.hpp"
#include "operators/random.hpp"
#include "tests/dsmc/microcanonical.hpp"

namespace {

using namespace grainbath;
using namespace grainbath::dsmc;
using namespace grainbath::dsmc::testing;

struct Rate {
  double value = 0.0, se = 0.0;  // collisions per unit time in the cell, batch-means error
  std::uint64_t raised = 0;
};

// One cell of n elastic grains at density 1 stepped with dt until t_end; the collision rate
// with its standard error from 25 batches of equal length.
Rate cell_rate(std::size_t n, double dt, double t_end, bool exact) {
  Particles p;
  p.resize(n, false);
  CounterRng init(5, Stream::initial_velocities, n, 1);
  std::vector<Vec3> v(n);
  for (Vec3& u : v) u = {init.normal(), init.normal(), init.normal()};
  to_sphere(v);
  for (std::size_t i = 0; i < n; ++i) {
    p.set_velocity(i, v[i]);
    p.id[i] = i;
  }
  const ElasticRestitution law{};
  GrainCounters counters;
  double remainder = 0.0;
  const auto steps = static_cast<std::uint64_t>(t_end / dt);
  const int batches = 25;
  const std::uint64_t per_batch = steps / batches;
  std::vector<double> rates;
  std::uint64_t before = 0;
  for (std::uint64_t step = 0; step < per_batch * batches; ++step) {
    CellCollisionRng rng(3, Stream::grain_collisions, 0, step);
    collide_cell(p, 0, n, 1.0, dt, 1.0, law, rng, remainder, counters, exact);
    if ((step + 1) % per_batch == 0) {
      rates.push_back(static_cast<double>(counters.collisions - before) / (static_cast<double>(per_batch) * dt));
      before = counters.collisions;
    }
  }
  Rate r;
  for (double x : rates) r.value += x / batches;
  double var = 0.0;
  for (double x : rates) var += (x - r.value) * (x - r.value) / (batches - 1);
  r.se = std::sqrt(var / batches);
  r.raised = counters.bound_exceeded;
  return r;
}

TEST(NtcBound, ExactBoundKeepsThePairRateAtCoarseSteps) {
  // 3 grains per cell, dt = 2 (about 2.3 collisions per grain and step): the collisions of a
  // step often make a pair faster than the start-of-step bound (found 1e5 times here)
  for (std::size_t n : {3u, 5u}) {
    double sum_g = 0.0, sum_g_se = 0.0;
    microcanonical_pair_speed_sum(n, 400000, sum_g, sum_g_se);
    const double expected = sum_g / static_cast<double>(n - 1), expected_se = sum_g_se / static_cast<double>(n - 1);
    const double dt = n == 3 ? 2.0 : 1.0;
    const Rate exact = cell_rate(n, dt, 4e5, true), bird = cell_rate(n, dt, 4e5, false);
    const double tol_exact = 5.0 * std::hypot(exact.se, expected_se), tol_bird = 5.0 * std::hypot(bird.se, expected_se);
    std::printf("N %zu dt %g: rate exact %.5f +- %.5f (bound raised %llu times), Bird %.5f +- %.5f; "
                "microcanonical (n/(N-1)) <sum |g|> %.5f +- %.5f\n",
                n, dt, exact.value, exact.se, static_cast<unsigned long long>(exact.raised), bird.value, bird.se,
                expected, expected_se);
    EXPECT_GT(exact.raised, 1000u);  // the guard was exercised
    EXPECT_NEAR(exact.value, expected, tol_exact) << "N " << n;
    // the same criterion sees Bird's bias: the check can fail
    EXPECT_LT(bird.value, expected - tol_bird) << "N " << n;
  }
}

TEST(NtcBound, DsmcOneStepsAgreeWithEitherBound) {
  // DSMC-1's occupancy and step (16 grains, 0.1 collisions per grain and step): Bird's bias is
  // far below what 1.8e6 collisions resolve, and both schemes give the microcanonical rate
  const std::size_t n = 16;
  double sum_g = 0.0, sum_g_se = 0.0;
  microcanonical_pair_speed_sum(n, 100000, sum_g, sum_g_se);
  const double expected = sum_g / static_cast<double>(n - 1), expected_se = sum_g_se / static_cast<double>(n - 1);
  for (bool exact : {true, false}) {
    const Rate r = cell_rate(n, 0.088, 1e5, exact);
    std::printf("N 16 dt 0.088 %s: %.4f +- %.4f, bound raised %llu times (expected %.4f +- %.4f)\n",
                exact ? "exact" : "Bird", r.value, r.se, static_cast<unsigned long long>(r.raised), expected,
                expected_se);
    EXPECT_NEAR(r.value, expected, 5.0 * std::hypot(r.se, expected_se));
  }
}

TEST(NtcBound, CandidatesAfterARaiseKeepTheExpectedCount) {
  // remaining * g_new / g_old in expectation, the fraction rounded up with its probability
  CounterRng rng(7, Stream::grain_collisions, 0, 0);
  const int draws = 200000;
  double sum = 0.0;
  std::uint64_t low = ~0ull, high = 0;
  for (int k = 0; k < draws; ++k) {
    const std::uint64_t c = candidates_after_raise(10, 1.0, 1.37, rng);
    sum += static_cast<double>(c);
    low = std::min(low, c);
    high = std::max(high, c);
  }
  const double mean = sum / draws, se = std::sqrt(0.7 * 0.3 / draws);  // Bernoulli(0.7) on top of 13
  EXPECT_NEAR(mean, 13.7, 5.0 * se);
  EXPECT_EQ(low, 13u);
  EXPECT_EQ(high, 14u);
  EXPECT_EQ(candidates_after_raise(0, 1.0, 2.0, rng), 0u);  // none left: none added, nothing drawn
}

}  // namespace
