#pragma once
// Small Monte Carlo helpers for the closures tests: a fixed-seed sampler of the collision
// rules of Bisi-Spiga eqs. 3 and 6, written from the rules themselves (no closure formula).
#include <array>
#include <cmath>
#include <random>

#include "tests/support/stat.hpp"

namespace grainbath::closures::test {

using Vec = std::array<double, 3>;
inline double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Running mean and standard error of a (weighted) estimator.
using Stat = test_support::Stat;

struct Sampler {
  std::mt19937_64 rng;
  std::normal_distribution<double> normal{0.0, 1.0};
  explicit Sampler(unsigned long seed) : rng(seed) {}
  Vec gaussian(const Vec& mean, double var) {
    const double s = std::sqrt(var);
    return {mean[0] + s * normal(rng), mean[1] + s * normal(rng), mean[2] + s * normal(rng)};
  }
  Vec unit() {  // uniform on S^2
    for (;;) {
      Vec z{normal(rng), normal(rng), normal(rng)};
      const double r = std::sqrt(dot(z, z));
      if (r > 1e-12) return {z[0] / r, z[1] / r, z[2] / r};
    }
  }
};

}  // namespace grainbath::closures::test

#include <gsl/gsl_errno.h>
#include <gsl/gsl_integration.h>

#include <functional>

namespace grainbath::closures::test {

// Adaptive 1D quadrature (GSL QAG, 61-point rule) of f on [a, b] to the given relative error.
inline double integrate(const std::function<double(double)>& f, double a, double b,
                        double rel = 1e-12) {
  struct Ctx {
    const std::function<double(double)>* f;
  } ctx{&f};
  gsl_function F{[](double x, void* p) { return (*static_cast<Ctx*>(p)->f)(x); }, &ctx};
  gsl_integration_workspace* ws = gsl_integration_workspace_alloc(2000);
  double result = 0.0, err = 0.0;
  gsl_error_handler_t* old = gsl_set_error_handler_off();
  gsl_integration_qag(&F, a, b, 0.0, rel, 2000, GSL_INTEG_GAUSS61, ws, &result, &err);
  gsl_set_error_handler(old);
  gsl_integration_workspace_free(ws);
  return result;
}

// Nested adaptive quadrature over r in [r0, r1] and mu in [-1, 1].
inline double integrate2(const std::function<double(double, double)>& f, double r0, double r1,
                         double rel = 1e-11) {
  return integrate([&](double r) { return integrate([&](double mu) { return f(r, mu); }, -1.0, 1.0, rel); },
                   r0, r1, rel);
}

}  // namespace grainbath::closures::test
