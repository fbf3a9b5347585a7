#pragma once
// Collision groups of a homogeneous run (docs/dsmc.md, "Collision groups").
//
// A homogeneous run has no positions: its grains form one collision cell, and Bird's NTC
// draws each candidate pair uniformly among all N grains. At N = 10^6 every candidate then
// reads two grains at random from 24 MB of velocities, two cache misses per candidate
// (free cooling, 10^6 grains: ~590 ns per accepted collision), and the one cell cannot be
// shared between threads. Here the grains are instead dealt into groups of about G grains
// (`[dsmc] collision_group`, default 4096, at least kMinCollisionGroup) afresh every step,
// and NTC runs in each group with the case density, as DSMC runs in the cells of a uniform gas: each grain still meets
// partners at the rate n <|g|>, only from its group of the step. A group is a set of tiles
// of 64 consecutive grains (512 bytes per velocity component) chosen by a random permutation
// of the tiles, keyed (seed, Stream::collision_groups; step): no grain is moved, the group's
// bound pass brings its velocities into cache for its candidates, the groups run in
// parallel, and the partition depends on N, G, the seed and the step alone (the same at any
// thread count, and after a restart).
//
// What it changes: two grains can only collide in a step in which they share a group.
// Energy and momentum still flow through the whole population, since every step deals the
// tiles anew; what remains of the grouping is that the 63 other grains of a tile are in a
// grain's group every step, so 63 / (G - 1) of its collisions (1.5 % at G = 4096) are with
// them, against 63 / (N - 1) in one cell. That is a weak recollision correlation, far below
// the one of spatial DSMC (a grain's ~15 cell mates are its partners every step). The tests
// (tests/dsmc/test_dsmc_collision_groups.cpp) check the deal, the bound and the rounding, the
// relaxation of two temperatures against the Boltzmann rate and one cell, and the tile-mate
// effect where it is largest; scripts/collision-groups-hcs.sh compares the cooling state
// with one cell.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "dsmc/collide.hpp"
#include "operators/random.hpp"

namespace grainbath::dsmc {

inline constexpr std::size_t kGroupTile = 64;  // grains per tile
// The smallest `collision_group` a case may ask for (16 tiles): a grain's 63 tile mates are
// in its group every step, a share 63 / (G - 1) of its partners (6 % here, 1.5 % at the
// default 4096); with one tile per group the groups would be the same 64 grains forever.
inline constexpr std::size_t kMinCollisionGroup = 16 * kGroupTile;

// The grain of slot s of a group made of `tiles` (every tile full but the last): the map
// collide_candidates draws its pairs through.
struct TileSlots {
  const std::uint32_t* tiles;
  std::size_t operator()(std::uint32_t s) const {
    return static_cast<std::size_t>(tiles[s / kGroupTile]) * kGroupTile + s % kGroupTile;
  }
};

// NTC candidates of a group over dt, N_g n g_max dt / 2, rounded up with the probability of
// their fraction (u uniform on (0, 1)): no remainder can be carried by groups that change
// every step, and the expectation is exact.
inline std::uint64_t group_candidates(std::size_t grains, double density, double g_max, double dt, double u) {
  return static_cast<std::uint64_t>(0.5 * static_cast<double>(grains) * density * g_max * dt + u);
}

// The step's partition of N grains into groups of whole tiles.
class CollisionGroups {
 public:
  // Tiles per group for a requested group size (whole tiles, at least one) and the number of
  // groups N grains make: tiles / per_group, so a group holds per_group to 2 per_group - 1 tiles.
  static std::size_t tiles_per_group(std::size_t group_grains) {
    return std::max<std::size_t>(1, (group_grains + kGroupTile / 2) / kGroupTile);
  }
  static std::size_t group_count(std::size_t grains, std::size_t group_grains) {
    return ((grains + kGroupTile - 1) / kGroupTile) / tiles_per_group(group_grains);
  }
  // Whether N grains are dealt into groups of about `group_grains` (0: never, one cell): only
  // if that makes at least two groups.
  static bool apply(std::size_t grains, std::size_t group_grains) {
    return group_grains > 0 && group_count(grains, group_grains) >= 2;
  }

  // Deal the tiles of `grains` grains into groups of round(group_grains / 64) tiles (the
  // last tile may be short; it is put last in its group so that every other tile of a group
  // is full). Reuses its storage: no allocation after the first step.
  void deal(std::size_t grains, std::size_t group_grains, std::uint64_t seed, std::uint64_t step) {
    if (grains == 0) throw std::invalid_argument("CollisionGroups::deal: no grains");
    grains_ = grains;
    const std::size_t tiles = (grains + kGroupTile - 1) / kGroupTile;
    const std::size_t groups = std::max<std::size_t>(1, group_count(grains, group_grains));
    // the largest group, 2 per_group - 1 tiles, must fit the 32-bit slots of collide_candidates
    if ((2 * tiles_per_group(group_grains) - 1) * kGroupTile > 0xffffffffu)
      throw std::length_error("CollisionGroups::deal: groups of more than 2^32 - 1 grains");
    order_.resize(tiles);
    for (std::size_t t = 0; t < tiles; ++t) order_[t] = static_cast<std::uint32_t>(t);
    // Fisher-Yates with exact bounded integers (below_from, src/dsmc/collide.hpp)
    Philox4x32Words rng(seed, Stream::collision_groups, 0, step);
    for (std::size_t t = tiles - 1; t > 0; --t) {
      const std::uint32_t k = below_from(static_cast<std::uint32_t>(rng.bits64()), static_cast<std::uint32_t>(t + 1), rng);
      std::swap(order_[t], order_[k]);
    }
    first_.resize(groups + 1);
    for (std::size_t g = 0; g <= groups; ++g) first_[g] = static_cast<std::uint32_t>(g * tiles / groups);
    if (grains % kGroupTile != 0) {  // the short tile last in its group
      const auto short_tile = static_cast<std::uint32_t>(tiles - 1);
      std::size_t at = 0;
      while (order_[at] != short_tile) ++at;
      std::size_t g = 0;
      while (first_[g + 1] <= at) ++g;
      std::swap(order_[at], order_[first_[g + 1] - 1]);
    }
  }

  std::size_t count() const { return first_.size() - 1; }
  // the tiles of group g and its grain count
  const std::uint32_t* tiles(std::size_t g) const { return order_.data() + first_[g]; }
  TileSlots slots(std::size_t g) const { return TileSlots{tiles(g)}; }
  std::size_t tile_count(std::size_t g) const { return first_[g + 1] - first_[g]; }
  std::size_t grains(std::size_t g) const {
    const std::size_t last = order_[first_[g + 1] - 1];
    const std::size_t last_size = std::min(kGroupTile, grains_ - last * kGroupTile);
    return (tile_count(g) - 1) * kGroupTile + last_size;
  }

 private:
  std::size_t grains_ = 0;
  std::vector<std::uint32_t> order_;  // tiles in the dealt order
  std::vector<std::uint32_t> first_;  // group g: order_[first_[g], first_[g + 1])
};

// The bound on |v_i - v_j| over the group, in one pass: |v_i - v_j| <= |v_i - a| + |v_j - a| for
// any point a, so the two largest |v - a| bound every pair (as pair_speed_bound does for a
// cell with a = the cell's mean). Here a is the mean of the group's first tile: a second
// pass for the group's own mean would read the velocities twice, and the first tile's mean
// lies within ~sigma/8 of it, which loosens the bound by 0.6 % on average at 4096 grains. The next
// tile is prefetched (its 3 x 8 lines), since the tiles are scattered over the arrays.
// (Ahead, Hint: the prefetch distance in tiles and its _MM_HINT level, 0 = none; measured by
// BM_GroupBound in bench/bench_dsmc.cpp.)
template <int Ahead = 1, int Hint = _MM_HINT_T0>
inline double group_pair_speed_bound(const double* vx, const double* vy, const double* vz, const std::uint32_t* tiles,
                                     std::size_t tile_count, std::size_t grains, BoundReference* ref = nullptr) {
  auto tile_size = [&](std::size_t t) { return t + 1 < tile_count ? kGroupTile : grains - (tile_count - 1) * kGroupTile; };
  double ax = 0, ay = 0, az = 0;
  {
    const std::size_t base = static_cast<std::size_t>(tiles[0]) * kGroupTile, n = tile_size(0);
    for (std::size_t i = 0; i < n; ++i) {
      ax += vx[base + i];
      ay += vy[base + i];
      az += vz[base + i];
    }
    ax /= static_cast<double>(n);
    ay /= static_cast<double>(n);
    az /= static_cast<double>(n);
  }
  const __m128d mx = _mm_set1_pd(ax), my = _mm_set1_pd(ay), mz = _mm_set1_pd(az);
  __m128d first2 = _mm_setzero_pd(), second2 = _mm_setzero_pd();  // per lane, the two largest |v - a|^2
  double first = 0, second = 0;
  auto push = [&](double c2) {
    second = std::max(second, std::min(first, c2));
    first = std::max(first, c2);
  };
  for (std::size_t t = 0; t < tile_count; ++t) {
    if (Ahead > 0 && t + Ahead < tile_count) {
      const std::size_t next = static_cast<std::size_t>(tiles[t + Ahead]) * kGroupTile;
      for (std::size_t line = 0; line < kGroupTile; line += 8) {
        _mm_prefetch(reinterpret_cast<const char*>(vx + next + line), static_cast<_mm_hint>(Hint));
        _mm_prefetch(reinterpret_cast<const char*>(vy + next + line), static_cast<_mm_hint>(Hint));
        _mm_prefetch(reinterpret_cast<const char*>(vz + next + line), static_cast<_mm_hint>(Hint));
      }
    }
    const std::size_t base = static_cast<std::size_t>(tiles[t]) * kGroupTile, n = tile_size(t);
    std::size_t i = 0;
    for (; i + 1 < n; i += 2) {
      const __m128d cx = _mm_sub_pd(_mm_loadu_pd(vx + base + i), mx);
      const __m128d cy = _mm_sub_pd(_mm_loadu_pd(vy + base + i), my);
      const __m128d cz = _mm_sub_pd(_mm_loadu_pd(vz + base + i), mz);
      const __m128d c2 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(cx, cx), _mm_mul_pd(cy, cy)), _mm_mul_pd(cz, cz));
      second2 = _mm_max_pd(second2, _mm_min_pd(first2, c2));
      first2 = _mm_max_pd(first2, c2);
    }
    if (i < n) {
      const double cx = vx[base + i] - ax, cy = vy[base + i] - ay, cz = vz[base + i] - az;
      push(cx * cx + cy * cy + cz * cz);
    }
  }
  alignas(16) double f[2], s[2];
  _mm_store_pd(f, first2);
  _mm_store_pd(s, second2);
  for (double c2 : {f[0], s[0], f[1], s[1]}) push(c2);
  if (ref) *ref = {ax, ay, az, first};
  return std::sqrt(first) + std::sqrt(second);
}

// NTC in one collision group over dt (collide_cell's scheme, collide.hpp): candidates
// N_g n g_max dt / 2, rounded up with the probability of the fraction (one uniform from the
// group's generator; no remainder is carried, since the groups change every step), pairs
// uniform among the group's grains through the tile map.
template <class Law>
inline void collide_group(Particles& p, const std::uint32_t* tiles, std::size_t tile_count, std::size_t grains,
                          double density, double dt, double mass, const Law& law, CellCollisionRng& rng,
                          GrainCounters& counters, bool exact_bound) {
  if (grains < 2 || density <= 0.0) return;
  double* vx = p.vx.data();
  double* vy = p.vy.data();
  double* vz = p.vz.data();
  BoundReference ref;
  const double g_max = group_pair_speed_bound(vx, vy, vz, tiles, tile_count, grains, &ref);
  if (g_max <= 0.0) return;
  CellCollisionRng::Cursor draws(rng);
  const std::uint64_t candidates = group_candidates(grains, density, g_max, dt, draws.uniform());
  const auto n32 = static_cast<std::uint32_t>(grains);
  if (exact_bound)
    collide_candidates<true>(vx, vy, vz, TileSlots{tiles}, n32, candidates, g_max, ref, mass, law, draws, counters);
  else
    collide_candidates<false>(vx, vy, vz, TileSlots{tiles}, n32, candidates, g_max, ref, mass, law, draws, counters);
}

}  // namespace grainbath::dsmc
