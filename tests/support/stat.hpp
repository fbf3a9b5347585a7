#pragma once
// Running mean and standard error of the mean of independent samples, for the Monte Carlo
// checks of the collision operators (tests/closures/mc.hpp, tests/rough/mc_rough.hpp): their
// tolerances are several of these standard errors.
#include <algorithm>
#include <cmath>

namespace grainbath::test_support {

struct Stat {
  double sum = 0.0, sum2 = 0.0;
  long n = 0;
  void add(double x) {
    sum += x;
    sum2 += x * x;
    ++n;
  }
  double mean() const { return sum / n; }
  double se() const {
    const double m = mean();
    return std::sqrt(std::max(0.0, sum2 / n - m * m) / (n - 1));
  }
};

}  // namespace grainbath::test_support
