// Collision groups of homogeneous DSMC runs (src/dsmc/collision_groups.hpp; docs/dsmc.md,
// "Collision groups"): the deal is a partition of the grains, redrawn every step with every
// pair of tiles equally likely to share a group; the group bound holds for every pair; and
// grouped collisions relax two temperatures at the rate of the Boltzmann integral, the same
// as one cell.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include "dsmc/collision_groups.hpp"
#include "support.hpp"

using namespace grainbath;
using namespace grainbath::dsmc;

namespace {

std::size_t slot_index(const CollisionGroups& deal, std::size_t g, std::size_t s) {
  return deal.slots(g)(static_cast<std::uint32_t>(s));
}

// N grains, grain i Maxwellian at temperature temperature(i) (mass 1) about `drift`
template <class Temperature>
Particles maxwellian(std::size_t n, std::uint64_t seed, Temperature temperature, Vec3 drift = {}) {
  Particles p;
  p.resize(n, false);
  for (std::size_t i = 0; i < n; ++i) {
    CounterRng rng(seed, Stream::initial_velocities, i, 0);
    const double s = std::sqrt(temperature(i));
    p.id[i] = i;
    p.set_velocity(i, Vec3{drift.x + s * rng.normal(), drift.y + s * rng.normal(), drift.z + s * rng.normal()});
  }
  return p;
}

}  // namespace

TEST(CollisionGroups, DealIsAPartitionWithTheShortTileLast) {
  for (const std::size_t n : {8192u, 12345u, 100000u, 100037u}) {
    CollisionGroups deal;
    deal.deal(n, 4096, 5, 17);
    std::vector<int> seen(n, 0);
    std::size_t total = 0;
    for (std::size_t g = 0; g < deal.count(); ++g) {
      const std::size_t size = deal.grains(g);
      total += size;
      // whole tiles but the short one, which is last in its group
      for (std::size_t t = 0; t + 1 < deal.tile_count(g); ++t)
        ASSERT_LT((deal.tiles(g)[t] + 1) * kGroupTile, n + 1) << "a short tile not last, n = " << n;
      for (std::size_t s = 0; s < size; ++s) {
        const std::size_t i = slot_index(deal, g, s);
        ASSERT_LT(i, n);
        ++seen[i];
      }
    }
    EXPECT_EQ(total, n);
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(seen[i], 1) << "grain " << i << ", n = " << n;
    EXPECT_GE(deal.count(), 2u);
  }
  // a function of (seed, step): the same deal again, another at the next step
  CollisionGroups a, b, c;
  a.deal(100000, 4096, 5, 17);
  b.deal(100000, 4096, 5, 17);
  c.deal(100000, 4096, 5, 18);
  bool same = true, other = false;
  for (std::size_t g = 0; g < a.count(); ++g)
    for (std::size_t t = 0; t < a.tile_count(g); ++t) {
      same = same && a.tiles(g)[t] == b.tiles(g)[t];
      other = other || a.tiles(g)[t] != c.tiles(g)[t];
    }
  EXPECT_TRUE(same);
  EXPECT_TRUE(other);
  // two groups need two groups' worth of tiles: 128 tiles of 64 (the last may be short)
  EXPECT_FALSE(CollisionGroups::apply(127 * 64, 4096));
  EXPECT_TRUE(CollisionGroups::apply(127 * 64 + 1, 4096));
  EXPECT_FALSE(CollisionGroups::apply(129 * 64, 4128));  // 65 tiles per group: 129 / 65 = 1 group
  EXPECT_EQ(CollisionGroups::group_count(100000, 4096), 24u);
  EXPECT_FALSE(CollisionGroups::apply(1000000, 0));
}

// Over many steps, tile 0 shares its group with every other tile equally often (chi-square
// over the 255 others). A deal that is not redrawn each step gives counts of 0 or `steps`.
TEST(CollisionGroups, EveryPairOfTilesSharesAGroupEquallyOften) {
  const std::size_t tiles = 256, n = tiles * kGroupTile, group = 16 * kGroupTile, steps = 4000;
  std::vector<double> shared(tiles, 0.0);
  CollisionGroups deal;
  for (std::size_t step = 0; step < steps; ++step) {
    deal.deal(n, group, 11, step);
    for (std::size_t g = 0; g < deal.count(); ++g) {
      bool has0 = false;
      for (std::size_t t = 0; t < deal.tile_count(g); ++t) has0 = has0 || deal.tiles(g)[t] == 0;
      if (!has0) continue;
      for (std::size_t t = 0; t < deal.tile_count(g); ++t) shared[deal.tiles(g)[t]] += 1;
    }
  }
  EXPECT_EQ(shared[0], static_cast<double>(steps));
  const double expected = static_cast<double>(steps) * 15.0 / 255.0;  // 15 of the 255 other tiles per step
  double chi2 = 0;
  for (std::size_t t = 1; t < tiles; ++t) chi2 += (shared[t] - expected) * (shared[t] - expected) / expected;
  const double dof = 254;
  std::printf("tile co-occurrence: chi2 = %.1f for %g degrees of freedom\n", chi2, dof);
  // each count is binomial(steps, 15/255), not Poisson: chi2 / (1 - p) ~ chi-square(254)
  EXPECT_LT(chi2 / (1 - 15.0 / 255.0), dof + 6 * std::sqrt(2 * dof));
}

// The bound of each group is at least the largest |v_i - v_j| over its pairs (by brute force),
// and at most 10 % above it.
TEST(CollisionGroups, BoundHoldsForEveryPairAndIsTight) {
  const std::size_t n = 4 * 4096 + 101;  // a short tile of 37 grains: the scalar tail of the bound
  Particles p = maxwellian(n, 3, [](std::size_t) { return 1.0; }, Vec3{0.7, -0.4, 0.2});
  CollisionGroups deal;
  deal.deal(n, 4096, 9, 0);
  // the two fastest grains of the group with the short tile: its last grain (the scalar
  // tail) and a grain in the second SIMD lane of another tile, moving head-on
  std::size_t with_short = 0;
  for (std::size_t g = 0; g < deal.count(); ++g)
    if (deal.grains(g) % kGroupTile != 0) with_short = g;
  ASSERT_NE(deal.grains(with_short) % 2, 0u);
  p.set_velocity(slot_index(deal, with_short, deal.grains(with_short) - 1), Vec3{9.0, 0.0, 0.0});
  p.set_velocity(slot_index(deal, with_short, 1), Vec3{-8.0, 0.5, 0.0});
  for (std::size_t g = 0; g < deal.count(); ++g) {
    const double bound =
        group_pair_speed_bound(p.vx.data(), p.vy.data(), p.vz.data(), deal.tiles(g), deal.tile_count(g), deal.grains(g));
    double worst2 = 0;
    for (std::size_t a = 0; a < deal.grains(g); ++a)
      for (std::size_t b = a + 1; b < deal.grains(g); ++b) {
        const Vec3 d = p.velocity(slot_index(deal, g, a)) - p.velocity(slot_index(deal, g, b));
        worst2 = std::max(worst2, norm2(d));
      }
    const double worst = std::sqrt(worst2);
    std::printf("group %zu (%zu grains): bound %.4f, largest |g| %.4f\n", g, deal.grains(g), bound, worst);
    EXPECT_GE(bound, worst);
    EXPECT_LT(bound, 1.1 * worst);
  }
}

// Two temperatures relax by the Boltzmann integral. Grains of even id start at T_a = 2, odd
// at T_b = 0.5 (mass 1, density n = 1, elastic). For two Maxwellians of equal mass the energy
// a grain of species a gains per collision with b is -(m/4)(v^2 - w^2), and averaging |g| times
// that over the two Maxwellians (v = (T_a/S) g + u, S = T_a + T_b) gives
//   dT_a/dt = -(2/3) n_b sqrt(8 S / (pi m)) (T_a - T_b),
// so D = T_a - T_b decays as exp(-lambda t), lambda = (2/3) n sqrt(8 S / (pi m)) with n_b = n/2
// (derived here; the species stay close to Maxwellian over the 0.1 time units compared).
// The grouped scheme is compared with that rate and with one cell, over 6 seeds each.
namespace {
// species a: even ids (interleaved) or the first half of the arrays (contiguous: whole tiles)
double relaxed_fraction(std::size_t group, bool contiguous, std::uint64_t seed, std::size_t steps, double dt,
                        double& lambda_t) {
  const bool grouped = group > 0;
  const std::size_t n = 1 << 18;
  auto hot = [&](std::size_t i) { return contiguous ? i < n / 2 : i % 2 == 0; };
  Particles p = maxwellian(n, seed, [&](std::size_t i) { return hot(i) ? 2.0 : 0.5; });
  auto temperatures = [&](double& ta, double& tb) {
    double sa = 0, sb = 0;
    for (std::size_t i = 0; i < n; ++i) (hot(i) ? sa : sb) += norm2(p.velocity(i));
    ta = sa / (3.0 * (n / 2));
    tb = sb / (3.0 * (n / 2));
  };
  double ta0, tb0;
  temperatures(ta0, tb0);
  const ElasticRestitution law{};
  CollisionGroups deal;
  GrainCounters counters;
  double remainder = 0;
  for (std::size_t step = 0; step < steps; ++step) {
    if (grouped) {
      deal.deal(n, group, seed, step);
      for (std::size_t g = 0; g < deal.count(); ++g) {
        CellCollisionRng rng(seed, Stream::grain_collisions, g, step);
        collide_group(p, deal.tiles(g), deal.tile_count(g), deal.grains(g), 1.0, dt, 1.0, law, rng, counters, true);
      }
    } else {
      CellCollisionRng rng(seed, Stream::grain_collisions, 0, step);
      collide_cell(p, 0, n, 1.0, dt, 1.0, law, rng, remainder, counters, true);
    }
  }
  double ta, tb;
  temperatures(ta, tb);
  lambda_t = (2.0 / 3.0) * std::sqrt(8.0 * (ta0 + tb0) / std::numbers::pi) * dt * static_cast<double>(steps);
  return (ta - tb) / (ta0 - tb0);
}
}  // namespace

TEST(CollisionGroups, TwoTemperaturesRelaxAtTheBoltzmannRateAsInOneCell) {
  const int seeds = 6;
  double mean[2] = {0, 0}, sq[2] = {0, 0}, lambda_t = 0;
  for (int grouped = 0; grouped < 2; ++grouped)
    for (int k = 0; k < seeds; ++k) {
      const double f = relaxed_fraction(grouped == 1 ? 4096 : 0, false, 100 + k, 10, 0.01, lambda_t);
      mean[grouped] += f / seeds;
      sq[grouped] += f * f / seeds;
    }
  double se[2];
  for (int g = 0; g < 2; ++g) se[g] = std::sqrt((sq[g] - mean[g] * mean[g]) * seeds / (seeds - 1) / seeds);
  const double theory = std::exp(-lambda_t);
  std::printf("D(0.1)/D(0): one cell %.5f +- %.5f, groups %.5f +- %.5f, Boltzmann (two Maxwellians) %.5f\n", mean[0],
              se[0], mean[1], se[1], theory);
  EXPECT_NEAR(mean[1], mean[0], 4 * std::hypot(se[0], se[1]));
  for (int g = 0; g < 2; ++g) EXPECT_NEAR(mean[g], theory, 4 * se[g]);
}

// The trace the grouping leaves, measured: with the hot species in the first half of the
// arrays (whole tiles), a grain's 63 tile mates are always of its own species and in its
// group, so of its G - 1 partners only (G - 64)/2 are of the other species instead of half:
// the relaxation rate is (G - 64)/(G - 1) of one cell's (0.877 at G = 512, small so that the
// effect is large). The ratio of the decay rates ln(D/D0) is compared with that.
TEST(CollisionGroups, TileMatesSlowTheRelaxationOfContiguousHalvesAsPredicted) {
  const int seeds = 4;
  const std::size_t group = 512;
  double rate[2] = {0, 0}, sq[2] = {0, 0}, lambda_t = 0;
  for (int grouped = 0; grouped < 2; ++grouped)
    for (int k = 0; k < seeds; ++k) {
      const double r = -std::log(relaxed_fraction(grouped == 1 ? group : 0, true, 200 + k, 10, 0.01, lambda_t));
      rate[grouped] += r / seeds;
      sq[grouped] += r * r / seeds;
    }
  double se[2];
  for (int g = 0; g < 2; ++g) se[g] = std::sqrt((sq[g] - rate[g] * rate[g]) * seeds / (seeds - 1) / seeds);
  const double ratio = rate[1] / rate[0], ratio_se = ratio * std::hypot(se[0] / rate[0], se[1] / rate[1]);
  const double predicted = static_cast<double>(group - 64) / static_cast<double>(group - 1);
  std::printf("contiguous halves, G = %zu: decay rate ratio groups / one cell %.4f +- %.4f, predicted %.4f\n", group,
              ratio, ratio_se, predicted);
  EXPECT_NEAR(ratio, predicted, 4 * ratio_se);
  EXPECT_LT(ratio, 0.95);  // the effect is there (a deal that ignored tiles would give 1)
}

// Stochastic rounding of the candidates: with dt so small that a group expects ~0.4
// candidates per step, truncation would give none; the collision count of an elastic gas at
// T = 1 must be N n <|g|> t / 2, <|g|> = 4 sqrt(T/(pi m)), within its Poisson error.
TEST(CollisionGroups, FractionalCandidatesAreRoundedWithoutBias) {
  const std::size_t n = 8192, steps = 40000;
  const double dt = 3e-5;
  Particles p = maxwellian(n, 5, [](std::size_t) { return 1.0; });
  CollisionGroups deal;
  GrainCounters counters;
  const ElasticRestitution law{};
  for (std::size_t step = 0; step < steps; ++step) {
    deal.deal(n, 4096, 5, step);
    ASSERT_EQ(deal.count(), 2u);
    for (std::size_t g = 0; g < deal.count(); ++g) {
      CellCollisionRng rng(5, Stream::grain_collisions, g, step);
      collide_group(p, deal.tiles(g), deal.tile_count(g), deal.grains(g), 1.0, dt, 1.0, law, rng, counters, true);
    }
  }
  const double expected = 0.5 * n * 4.0 / std::sqrt(std::numbers::pi) * dt * steps;
  const double per_group_step = static_cast<double>(counters.candidates) / (2.0 * steps);
  std::printf("candidates per group and step %.3f; collisions %llu, expected %.1f +- %.1f\n", per_group_step,
              static_cast<unsigned long long>(counters.collisions), expected, std::sqrt(expected));
  EXPECT_LT(per_group_step, 1.0);
  EXPECT_NEAR(static_cast<double>(counters.collisions), expected, 4 * std::sqrt(expected));
}

// summary.json says how the grains collided: 20,000 grains make 313 tiles, 4 groups of 4096
// (78 tiles each and one of 79); collision_group = 0 is one cell.
TEST(CollisionGroups, SummaryCountsTheGroups) {
  const std::string head = R"(
[grains]
temperature = 1.0
[background]
density = 0.0
[restitution]
law = "constant"
e = 0.9
[dsmc]
particles = 20000
dt = 0.01
t_end = 0.05
)";
  const auto grouped = grainbath::testing::run_dsmc(head, 3, 1, "groups-summary");
  EXPECT_EQ(grouped.summary.number("counters.collision_groups"), 4.0);
  const auto one_cell = grainbath::testing::run_dsmc(head + "collision_group = 0\n", 3, 1, "groups-summary-0");
  EXPECT_EQ(one_cell.summary.number("counters.collision_groups"), 0.0);
}
