// permute_in_place (src/core/permute.hpp) against the copy it replaces: a_after[k] =
// a_before[order[k]] for every array, on random permutations, with an empty (absent) array
// among them, and its errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

#include "core/permute.hpp"

namespace {

struct Record {  // a 64-byte record like the EDMD engine's kinematic one
  std::array<double, 7> x;
  std::uint64_t tag;
  bool operator==(const Record&) const = default;
};

template <class T>
std::vector<T> permuted_copy(const std::vector<T>& a, const std::vector<std::uint32_t>& order) {
  std::vector<T> out(a.size());
  for (std::size_t k = 0; k < a.size(); ++k) out[k] = a[order[k]];
  return out;
}

std::vector<std::uint32_t> random_permutation(std::size_t n, std::mt19937_64& rng, int kind) {
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  if (kind == 0) std::shuffle(order.begin(), order.end(), rng);  // long cycles
  if (kind == 1)                                                  // local moves, as after a re-sort
    for (std::size_t i = 0; i + 1 < n; ++i)
      if (rng() % 3 == 0) std::swap(order[i], order[std::min(n - 1, i + 1 + rng() % 5)]);
  // kind 2: the identity
  return order;
}

TEST(PermuteInPlace, EqualsTheCopyForEveryArray) {
  std::mt19937_64 rng(20261208);
  for (std::size_t n : {0, 1, 2, 3, 17, 1000, 4096}) {
    for (int kind = 0; kind < 3; ++kind) {
      std::vector<Record> rec(n);
      std::vector<double> t(n);
      std::vector<std::uint32_t> id(n);
      std::vector<double> absent;  // an optional field this run does not carry
      for (std::size_t i = 0; i < n; ++i) {
        for (auto& v : rec[i].x) v = std::uniform_real_distribution<double>(-1, 1)(rng);
        rec[i].tag = rng();
        t[i] = std::uniform_real_distribution<double>(0, 1)(rng);
        id[i] = static_cast<std::uint32_t>(rng());
      }
      std::vector<std::uint32_t> order = random_permutation(n, rng, kind);
      const auto rec_want = permuted_copy(rec, order);
      const auto t_want = permuted_copy(t, order);
      const auto id_want = permuted_copy(id, order);
      grainbath::permute_in_place(order, rec, t, absent, id);
      EXPECT_EQ(rec, rec_want) << "n " << n << " kind " << kind;
      EXPECT_EQ(t, t_want) << "n " << n << " kind " << kind;
      EXPECT_EQ(id, id_want) << "n " << n << " kind " << kind;
      EXPECT_TRUE(absent.empty());
      for (std::size_t k = 0; k < n; ++k) ASSERT_EQ(order[k], k) << "order is left as the identity";
    }
  }
}

TEST(PermuteInPlace, RejectsLengthMismatchAndNonPermutations) {
  std::vector<double> a(4, 1.0), short_one(3, 2.0);
  std::vector<std::uint32_t> order{1, 0, 3, 2};
  EXPECT_THROW(grainbath::permute_in_place(order, a, short_one), std::invalid_argument);
  EXPECT_EQ(a, std::vector<double>(4, 1.0)) << "nothing touched before the length check";
  for (std::vector<std::uint32_t> bad : {std::vector<std::uint32_t>{1, 1, 2, 3}, {1, 2, 1, 0}, {0, 1, 2, 7}}) {
    std::vector<double> b{0, 1, 2, 3};
    EXPECT_THROW(grainbath::permute_in_place(bad, b), std::invalid_argument);
  }
}

}  // namespace
