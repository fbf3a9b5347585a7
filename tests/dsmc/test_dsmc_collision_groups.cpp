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
#include "tests/dsmc/microcanonical.hpp"

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
// and close above it: within 10 % for the group with the planted head-on pair, whose |g| the
// two largest deviations match. A Maxwellian group's bound is at most twice its largest |g|
// (the reference point, the first tile's mean, lies in the group's convex hull, so every
// |v - a| is at most the largest |g|) and measured 1.072 +- 0.035 times it (240 groups of
// 4096 from 60 deals, largest 1.20): those groups are held to 1.35. (Until the collision-groups
// audit every group was held to 1.1, which 19 % of Maxwellian groups exceed: the test passed
// for this seed's deal and failed for four of the five other deals the audit's mutations made.)
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
    EXPECT_LT(bound, (g == with_short ? 1.1 : 1.35) * worst);
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

// Mutation audit (docs/reviews/mutation-audit-collision-groups.md): the deal's law, the bound
// wherever the fastest grains sit, every grain a partner, and the deal's edge cases.

// Every tile, the short one included, falls in a group with probability (the group's tiles) /
// (all tiles), as under a uniformly random permutation: 33 tiles (the last one short) in groups
// of 16 and 17, over 1e5 steps, each tile's count in the first group binomial with p = 16/33.
// A shuffle that can never leave a tile where it was, or that never swaps the first two
// places, or a short tile moved across the wrong group boundary, changes single tiles'
// probabilities by about 1/33 (10 to 20 standard errors here).
TEST(CollisionGroups, EveryTileFallsInEachGroupInProportionToItsSize) {
  const std::size_t tiles = 33, n = tiles * kGroupTile - 27, steps = 100000;
  CollisionGroups deal;
  std::vector<double> in_first(tiles, 0.0);
  for (std::size_t step = 0; step < steps; ++step) {
    deal.deal(n, 16 * kGroupTile, 7, step);
    ASSERT_EQ(deal.count(), 2u);
    ASSERT_EQ(deal.tile_count(0), 16u);
    for (std::size_t t = 0; t < deal.tile_count(0); ++t) in_first[deal.tiles(0)[t]] += 1;
  }
  const double p = 16.0 / 33.0, var = static_cast<double>(steps) * p * (1 - p);
  double chi2 = 0, worst = 0;
  for (std::size_t t = 0; t < tiles; ++t) {
    const double z = (in_first[t] - static_cast<double>(steps) * p) / std::sqrt(var);
    chi2 += z * z;
    worst = std::max(worst, std::abs(z));
  }
  const double dof = 32;  // the counts add up to 16 tiles a step
  std::printf("tiles in the first group: chi2 = %.1f for %g degrees of freedom, largest |z| %.2f (short tile %.2f)\n",
              chi2, dof, worst, (in_first[tiles - 1] - static_cast<double>(steps) * p) / std::sqrt(var));
  EXPECT_LT(chi2, dof + 6 * std::sqrt(2 * dof));
  EXPECT_LT(worst, 4.5);
  // and the deal is a function of the seed too: another seed, another deal at the same step
  CollisionGroups a, b;
  a.deal(100000, 4096, 5, 17);
  b.deal(100000, 4096, 6, 17);
  bool other = false;
  for (std::size_t g = 0; g < a.count(); ++g)
    for (std::size_t t = 0; t < a.tile_count(g); ++t) other = other || a.tiles(g)[t] != b.tiles(g)[t];
  EXPECT_TRUE(other);
}

// The bound of a group holds wherever its two fastest grains sit: in one SIMD lane, in the
// other, one in each, in the last slot of a full tile, in the scalar tail of the short tile, in
// the first tile (whose mean is the reference point), in a gas drifting at 37 thermal speeds.
// The pair is planted head-on, so its
// |g| is the group's largest; the bound must cover it and stay within 5 % of it. The reference
// the bound reports (BoundGuard's centre and largest deviation) must cover every grain.
TEST(CollisionGroups, BoundHoldsWhereverTheFastestPairSits) {
  const std::size_t n = 2 * 4096 + 37;  // 129 tiles, the last of 37 grains (odd: a scalar tail)
  CollisionGroups deal;
  deal.deal(n, 4096, 13, 2);
  std::size_t g = 0;
  while (deal.grains(g) % kGroupTile == 0) ++g;  // the group with the short tile
  const std::size_t size = deal.grains(g), tail = size - 1;
  ASSERT_EQ(size % 2, 1u);
  // slot pairs (slot of the faster grain, slot of the slower)
  const std::size_t pairs[][2] = {{0, 2},          {2, 0},           {1, 3},        {3, 1},
                                  {10, 11},        {11, 10},         {63, 127},     {127, 63},
                                  {130, 64 + 63},  {tail, tail - 1}, {tail - 1, tail}, {tail, 5},
                                  {6, tail},       {tail - 2, 200},  {201, tail - 2}};
  const Vec3 e = (1.0 / norm(Vec3{0.6, -0.3, 0.74})) * Vec3{0.6, -0.3, 0.74};
  for (const auto& pr : pairs) {
    Particles p = maxwellian(n, 21, [](std::size_t) { return 1.0; }, Vec3{30.0, -20.0, 10.0});
    const std::size_t a = slot_index(deal, g, pr[0]), b = slot_index(deal, g, pr[1]);
    p.set_velocity(a, Vec3{30.0, -20.0, 10.0} + 7.0 * e);
    p.set_velocity(b, Vec3{30.0, -20.0, 10.0} - 6.5 * e);
    const double planted = norm(p.velocity(a) - p.velocity(b));
    BoundReference ref;
    const double bound = group_pair_speed_bound(p.vx.data(), p.vy.data(), p.vz.data(), deal.tiles(g),
                                                deal.tile_count(g), size, &ref);
    EXPECT_GE(bound, planted) << "slots " << pr[0] << ", " << pr[1];
    EXPECT_LT(bound, 1.05 * planted) << "slots " << pr[0] << ", " << pr[1];
    double deviation2 = 0;
    for (std::size_t s = 0; s < size; ++s)
      deviation2 = std::max(deviation2, norm2(p.velocity(slot_index(deal, g, s)) - Vec3{ref.ax, ref.ay, ref.az}));
    EXPECT_GE(ref.max_deviation2, deviation2) << "slots " << pr[0] << ", " << pr[1];
    EXPECT_LE(bound, 2 * std::sqrt(ref.max_deviation2) * (1 + 1e-12));
  }
}

// Every grain is a partner: with the short tile always last in its group, its last grain is
// always a group's last slot. Elastic grains at T = 1, n = 1, over 40 steps of 0.25 (about 22
// collisions a grain; that none occurs has probability 3e-10 a grain): every velocity has
// changed.
TEST(CollisionGroups, EveryGrainCollides) {
  const std::size_t n = 2 * 4096 + 37;
  Particles p = maxwellian(n, 8, [](std::size_t) { return 1.0; });
  const std::vector<Vec3> start = [&] {
    std::vector<Vec3> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = p.velocity(i);
    return v;
  }();
  auto same = [&](std::size_t i) {
    const Vec3 v = p.velocity(i);
    return v.x == start[i].x && v.y == start[i].y && v.z == start[i].z;
  };
  CollisionGroups deal;
  GrainCounters counters;
  const ElasticRestitution law{};
  for (std::size_t step = 0; step < 40; ++step) {
    deal.deal(n, 4096, 8, step);
    for (std::size_t g = 0; g < deal.count(); ++g) {
      CellCollisionRng rng(8, Stream::grain_collisions, g, step);
      collide_group(p, deal.tiles(g), deal.tile_count(g), deal.grains(g), 1.0, 0.25, 1.0, law, rng, counters, true);
    }
  }
  std::size_t unchanged = 0;
  for (std::size_t i = 0; i < n; ++i) unchanged += same(i) ? 1 : 0;
  std::printf("%llu collisions of %zu grains; %zu never collided\n",
              static_cast<unsigned long long>(counters.collisions), n, unchanged);
  EXPECT_EQ(unchanged, 0u);
  EXPECT_FALSE(same(n - 1)) << "the short tile's last grain";
}

// The deal on its own (the driver deals only where apply() holds): fewer tiles than two
// groups make one group of all of them; no grains is refused; so is a group size whose largest
// group (2 per_group - 1 tiles) could hold more than the 2^32 - 1 grains of the pair draw's
// 32-bit slots, and 2^31 grains is not.
TEST(CollisionGroups, SmallAndOversizedDealsAreOneGroupOrRefused) {
  CollisionGroups deal;
  for (const std::size_t n : {1u, 63u, 64u, 1000u, 127u * 64}) {
    deal.deal(n, 4096, 3, 1);
    ASSERT_EQ(deal.count(), 1u) << n;
    EXPECT_EQ(deal.grains(0), n);
    std::vector<int> seen(n, 0);
    for (std::size_t s = 0; s < n; ++s) ++seen.at(slot_index(deal, 0, s));
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(seen[i], 1) << "grain " << i << " of " << n;
  }
  EXPECT_THROW(deal.deal(0, 4096, 3, 1), std::invalid_argument);
  EXPECT_NO_THROW(deal.deal(1000, std::size_t{1} << 31, 3, 1));
  EXPECT_THROW(deal.deal(1000, (std::size_t{1} << 31) + 64, 3, 1), std::length_error);
  EXPECT_THROW(deal.deal(1000, std::size_t{3} << 30, 3, 1), std::length_error);
}

// The group size is the whole number of tiles nearest the request (groups of "about G
// grains"): within half a tile of G for every G a case may ask for up to 20000, and so the
// mean group of a large deal is within half a tile of G too.
TEST(CollisionGroups, GroupsAreTheWholeTilesNearestTheRequest) {
  for (std::size_t request = kMinCollisionGroup; request <= 20000; ++request) {
    const std::size_t size = CollisionGroups::tiles_per_group(request) * kGroupTile;
    ASSERT_LE(size > request ? size - request : request - size, kGroupTile / 2) << "collision_group = " << request;
  }
  const std::size_t n = 1 << 22;  // 65536 tiles: the groups' sizes differ by at most a tile
  for (const std::size_t request : {1025u, 4100u, 4127u, 4129u, 6000u}) {
    const double mean = static_cast<double>(n) / static_cast<double>(CollisionGroups::group_count(n, request));
    EXPECT_LE(std::abs(mean - static_cast<double>(request)), 32.0 + 1.0) << "collision_group = " << request;
  }
}

// NTC in a group: the candidates are ordered pairs of distinct grains drawn uniformly, so each
// grain is in a candidate with probability 2 / N_g; for it to be offered partners at the rate
// n g_max of the case density (and so collide at n <|g|>), a group needs N_g n g_max dt / 2
// candidates a step on average. The count is that number rounded down or up, up with the
// probability of its fraction: averaged over u on a fine grid it is exact, and it is never
// more than one away.
TEST(CollisionGroups, CandidatesGiveEachGrainTheCaseDensitysRate) {
  struct Case {
    std::size_t grains;
    double density, g_max, dt;
  };
  for (const Case& c : {Case{1024, 1.0, 5.3, 0.01}, Case{4097, 0.37, 7.1, 0.003}, Case{5000, 2.5, 0.9, 0.2}}) {
    // per grain: candidates x (2 / N_g) / dt = n g_max
    const double per_grain_rate_target = c.density * c.g_max;
    const int grid = 10000;
    double mean = 0;
    std::uint64_t lo = ~std::uint64_t{0}, hi = 0;
    for (int k = 0; k < grid; ++k) {
      const std::uint64_t m = group_candidates(c.grains, c.density, c.g_max, c.dt, (k + 0.5) / grid);
      mean += static_cast<double>(m) / grid;
      lo = std::min(lo, m);
      hi = std::max(hi, m);
    }
    const double rate = mean * 2.0 / static_cast<double>(c.grains) / c.dt;
    EXPECT_NEAR(rate / per_grain_rate_target, 1.0, 5e-5) << "N_g = " << c.grains;
    EXPECT_LE(hi - lo, 1u);
  }
}

// The deal's key, pinned as docs/dsmc.md and the header give it: Fisher-Yates from the last
// place down, each place's partner an exact bounded integer (below_from) of the words of
// Philox4x32Words(seed, Stream::collision_groups, 0, step), the groups the consecutive runs
// of g * tiles / groups places. The deal is part of a run's bits (a restart or another
// thread count continues it exactly), and its words must not be those of a group's collision
// generator (seed, Stream::grain_collisions; group, step). A whole number of tiles: no short
// tile to move. (The law of the deal is checked above without this reference.)
TEST(CollisionGroups, DealIsTheFisherYatesShuffleOfItsOwnStream) {
  const std::size_t tiles = 200, n = tiles * kGroupTile;
  CollisionGroups deal;
  for (const std::uint64_t seed : {5u, 6u})
    for (const std::uint64_t step : {0u, 17u, 4000000000u}) {
      deal.deal(n, 4096, seed, step);
      std::vector<std::uint32_t> order(tiles);
      for (std::size_t t = 0; t < tiles; ++t) order[t] = static_cast<std::uint32_t>(t);
      Philox4x32Words words(seed, Stream::collision_groups, 0, step);
      for (std::size_t t = tiles - 1; t > 0; --t)
        std::swap(order[t], order[below_from(static_cast<std::uint32_t>(words.bits64()),
                                             static_cast<std::uint32_t>(t + 1), words)]);
      ASSERT_EQ(deal.count(), 3u);
      std::size_t at = 0;
      for (std::size_t g = 0; g < deal.count(); ++g) {
        EXPECT_EQ(deal.tile_count(g), (g + 1) * tiles / 3 - g * tiles / 3);
        for (std::size_t t = 0; t < deal.tile_count(g); ++t, ++at)
          ASSERT_EQ(deal.tiles(g)[t], order[at]) << "seed " << seed << " step " << step << " place " << at;
      }
    }
}

// The exact NTC bound in a group (`[dsmc] bound = "exact"`, the default; src/dsmc/collide.hpp,
// BoundGuard): a group of 3 elastic grains (one short tile) at dt = 2, about 2.3 collisions a
// grain and step, whose collisions often make a pair faster than the step's bound. Its
// collision rate must be the microcanonical (n / (N - 1)) <sum over pairs |g|> of an isolated
// cell of N grains with zero momentum (as NtcBound.ExactBoundKeepsThePairRateAtCoarseSteps for a
// cell, by the same Monte Carlo); Bird's start-of-step bound falls 5 standard errors below it
// there, and does here.
TEST(CollisionGroups, ExactBoundKeepsThePairRateOfAGroupAtCoarseSteps) {
  const std::size_t n = 3;
  // (n / (N - 1)) <sum |g|> over the uniform distribution on the energy sphere, by Monte Carlo
  double sum_g = 0.0, sum_g_se = 0.0;
  grainbath::dsmc::testing::microcanonical_pair_speed_sum(n, 400000, sum_g, sum_g_se);
  const double expected = sum_g / static_cast<double>(n - 1), expected_se = sum_g_se / static_cast<double>(n - 1);
  auto rate = [&](bool exact, double& se) {
    Particles p;
    p.resize(n, false);
    CounterRng init(5, Stream::initial_velocities, n, 1);
    std::vector<Vec3> v(n);
    for (Vec3& u : v) u = {init.normal(), init.normal(), init.normal()};
    grainbath::dsmc::testing::to_sphere(v);
    for (std::size_t i = 0; i < n; ++i) {
      p.set_velocity(i, v[i]);
      p.id[i] = i;
    }
    const std::uint32_t tiles[] = {0};
    const ElasticRestitution law{};
    GrainCounters counters;
    const double dt = 2.0;
    const int batches = 25, per_batch = 8000;
    std::vector<double> rates;
    std::uint64_t before = 0;
    for (int step = 0; step < batches * per_batch; ++step) {
      CellCollisionRng rng(3, Stream::grain_collisions, 0, static_cast<std::uint64_t>(step));
      collide_group(p, tiles, 1, n, 1.0, dt, 1.0, law, rng, counters, exact);
      if ((step + 1) % per_batch == 0) {
        rates.push_back(static_cast<double>(counters.collisions - before) / (per_batch * dt));
        before = counters.collisions;
      }
    }
    double mean = 0, var = 0;
    for (double x : rates) mean += x / batches;
    for (double x : rates) var += (x - mean) * (x - mean) / (batches - 1);
    se = std::sqrt(var / batches);
    return mean;
  };
  double se_exact, se_bird;
  const double exact = rate(true, se_exact), bird = rate(false, se_bird);
  std::printf("group of 3, dt 2: rate exact %.5f +- %.5f, Bird %.5f +- %.5f; microcanonical %.5f +- %.5f\n", exact,
              se_exact, bird, se_bird, expected, expected_se);
  EXPECT_NEAR(exact, expected, 5 * std::hypot(se_exact, expected_se));
  EXPECT_LT(bird, expected - 5 * std::hypot(se_bird, expected_se));
}
