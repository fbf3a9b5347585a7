// src/core/state_hash.hpp: the fingerprint `state.hash` of summary.json must (1) not depend on
// the order in which particles are stored (cell order, rank order), (2) change with any single
// bit of any value, the id, the number of particles or the order of a particle's fields.
#include "src/core/state_hash.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <numeric>
#include <random>
#include <set>
#include <vector>

namespace {

using grainbath::StateHash;

struct Toy {
  std::vector<std::uint64_t> id;
  std::vector<std::vector<double>> values;  // per particle: x, y, z, vx, vy, vz
};

Toy make_state(std::size_t n, unsigned seed) {
  std::mt19937_64 g(seed);
  std::normal_distribution<double> normal;
  Toy s;
  for (std::size_t i = 0; i < n; ++i) {
    s.id.push_back(1000 + 7 * i);
    std::vector<double> v(6);
    for (double& x : v) x = normal(g);
    s.values.push_back(v);
  }
  return s;
}

std::uint64_t hash_in_order(const Toy& s, const std::vector<std::size_t>& order) {
  StateHash h;
  for (const std::size_t i : order) h.add(s.id[i], s.values[i]);
  return h.value();
}

std::vector<std::size_t> identity(std::size_t n) {
  std::vector<std::size_t> o(n);
  std::iota(o.begin(), o.end(), std::size_t{0});
  return o;
}

TEST(StateHash, IndependentOfStorageOrder) {
  const Toy s = make_state(500, 1);
  const std::uint64_t ref = hash_in_order(s, identity(500));
  std::mt19937_64 g(2);
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<std::size_t> o = identity(500);
    std::shuffle(o.begin(), o.end(), g);
    EXPECT_EQ(hash_in_order(s, o), ref);
  }
}

TEST(StateHash, EverySingleBitFlipChangesIt) {
  // every bit of every value of a few particles, and every bit of their ids: 64 x 7 x 20
  // single-bit mutations, all distinct from the reference and from each other
  const Toy s = make_state(200, 3);
  const std::uint64_t ref = hash_in_order(s, identity(200));
  std::set<std::uint64_t> seen{ref};
  std::size_t mutations = 0;
  for (std::size_t i = 0; i < 200; i += 10) {
    for (std::size_t f = 0; f <= 6; ++f)
      for (int bit = 0; bit < 64; ++bit) {
        Toy t = s;
        if (f == 6)
          t.id[i] ^= std::uint64_t{1} << bit;
        else
          t.values[i][f] = std::bit_cast<double>(std::bit_cast<std::uint64_t>(t.values[i][f]) ^ (std::uint64_t{1} << bit));
        const std::uint64_t h = hash_in_order(t, identity(200));
        EXPECT_NE(h, ref) << "particle " << i << " field " << f << " bit " << bit;
        seen.insert(h);
        ++mutations;
      }
  }
  EXPECT_EQ(seen.size(), mutations + 1);
}

TEST(StateHash, SeesSignOfZeroFieldOrderAndCount) {
  const Toy s = make_state(50, 4);
  const std::uint64_t ref = hash_in_order(s, identity(50));
  Toy zero = s;
  zero.values[7][2] = 0.0;
  Toy negzero = s;
  negzero.values[7][2] = -0.0;
  EXPECT_NE(hash_in_order(zero, identity(50)), hash_in_order(negzero, identity(50)));
  Toy swapped = s;  // two fields of one particle exchanged: same multiset of bits
  std::swap(swapped.values[3][0], swapped.values[3][4]);
  EXPECT_NE(hash_in_order(swapped, identity(50)), ref);
  Toy swapped_ids = s;  // two particles exchange ids: the same values, different attribution
  std::swap(swapped_ids.id[1], swapped_ids.id[2]);
  EXPECT_NE(hash_in_order(swapped_ids, identity(50)), ref);
  std::vector<std::size_t> dup = identity(50);  // one particle counted twice
  dup.push_back(9);
  EXPECT_NE(hash_in_order(s, dup), ref);
  std::vector<std::size_t> fewer = identity(49);
  EXPECT_NE(hash_in_order(s, fewer), ref);
}

TEST(StateHash, HexIsSixteenDigitsOfTheValue) {
  StateHash h;
  const double v[2] = {1.0, -2.5};
  h.add(42, v);
  const std::string x = h.hex();
  ASSERT_EQ(x.size(), 16u);
  EXPECT_EQ(std::stoull(x, nullptr, 16), h.value());
  EXPECT_EQ(StateHash{}.hex().size(), 16u);  // the empty state has a fingerprint too
}

}  // namespace
