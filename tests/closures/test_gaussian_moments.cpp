// Non-central chi moments (docs eqs. C2-C4) against independent adaptive quadrature of the
// 3D Gaussian integral in spherical coordinates.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "closures/closures.hpp"
#include "tests/closures/mc.hpp"

using namespace grainbath::closures;
using grainbath::closures::test::integrate2;

namespace {
// E[|x|^k D] for x ~ N(a, I), |a| = A, where D = 1, d/dA or d2/dA2 acting on the density
// (2 pi)^{-3/2} exp(-(r^2 - 2 r A mu + A^2)/2), integrated over r and mu = cos(x, a).
double quad_moment(int k, double A, int derivative) {
  const double R = A + 16.0;
  return integrate2(
      [&](double r, double mu) {
        const double e = std::exp(-0.5 * (r * r - 2.0 * r * A * mu + A * A));
        const double d = r * mu - A;
        const double fac = derivative == 0 ? 1.0 : derivative == 1 ? d : d * d - 1.0;
        return 2.0 * M_PI * std::pow(2.0 * M_PI, -1.5) * r * r * std::pow(r, k) * e * fac;
      },
      0.0, R, 1e-13);
}
}  // namespace

class ChiMoments : public ::testing::TestWithParam<std::tuple<int, double>> {};

TEST_P(ChiMoments, MatchQuadrature) {
  const auto [k, A] = GetParam();
  const RadialMoment m = noncentral_chi_moment(k, A);
  const double q0 = quad_moment(k, A, 0), q1 = quad_moment(k, A, 1), q2 = quad_moment(k, A, 2);
  EXPECT_NEAR(m.value, q0, 1e-10 * q0) << "k=" << k << " A=" << A;
  std::printf("[measure] chi k=%d A=%g: value %.1e d1 %.1e d2 %.1e (relative to m_k)\n", k, A,
              std::abs(m.value - q0) / q0, std::abs(m.d1 - q1) / q0, std::abs(m.d2 - q2) / q0);
  EXPECT_NEAR(m.d1, q1, 1e-10 * q0) << "k=" << k << " A=" << A;
  EXPECT_NEAR(m.d2, q2, 1e-9 * q0) << "k=" << k << " A=" << A;
  if (A > 0.0) {
    EXPECT_NEAR(m.d1_over_A, q1 / A, 1e-9 * q0 / std::max(A, 1e-3));
  }
}

INSTANTIATE_TEST_SUITE_P(Grid, ChiMoments,
                         ::testing::Combine(::testing::Values(1, 3, 5),
                                            ::testing::Values(0.0, 1e-3, 0.3, 0.999, 1.001, 2.0,
                                                              4.5, 9.0)));

TEST(ChiMoments, SeriesAndClosedFormAgreeAtTheSwitch) {
  // Both branches evaluated near A = 1 must agree (the closed form is also used at A=1).
  for (int k : {1, 3, 5, 7}) {
    const RadialMoment below = noncentral_chi_moment(k, std::nextafter(1.0, 0.0));
    const RadialMoment above = noncentral_chi_moment(k, 1.0);
    EXPECT_NEAR(below.value, above.value, 1e-13 * above.value);
    EXPECT_NEAR(below.d1, above.d1, 1e-12 * above.value);
    EXPECT_NEAR(below.d2, above.d2, 1e-11 * above.value);
  }
}

TEST(ChiMoments, OnePassVersionEqualsTheSingleMoments) {
  for (double A : {0.0, 1e-4, 0.3, 0.999, 1.0, 1.7, 4.0, 11.0}) {
    const ChiMoments135 all = noncentral_chi_moments_135(A);
    const RadialMoment* got[3] = {&all.m1, &all.m3, &all.m5};
    for (int q = 0; q < 3; ++q) {
      const RadialMoment ref = noncentral_chi_moment(2 * q + 1, A);
      EXPECT_NEAR(got[q]->value, ref.value, 1e-14 * ref.value) << A;
      EXPECT_NEAR(got[q]->d1, ref.d1, 1e-13 * ref.value) << A;
      EXPECT_NEAR(got[q]->d1_over_A, ref.d1_over_A, 1e-13 * ref.value) << A;
      EXPECT_NEAR(got[q]->d2, ref.d2, 1e-13 * ref.value) << A;
    }
  }
}

TEST(ChiMoments, CentralMomentsAreKnownValues) {
  // E|z| = 2 sqrt(2/pi), E|z|^2 = 3, E|z|^3 = 8 sqrt(2/pi) for z ~ N(0, I_3).
  EXPECT_NEAR(central_chi_moment(1.0), 2.0 * std::sqrt(2.0 / M_PI), 1e-15);
  EXPECT_NEAR(central_chi_moment(2.0), 3.0, 1e-14);
  EXPECT_NEAR(central_chi_moment(3.0), 8.0 * std::sqrt(2.0 / M_PI), 1e-14);
}

TEST(ChiMoments, RejectsBadArguments) {
  EXPECT_THROW(noncentral_chi_moment(2, 1.0), std::invalid_argument);
  EXPECT_THROW(noncentral_chi_moment(1, -1.0), std::invalid_argument);
  EXPECT_THROW(noncentral_chi_moment(1, std::nan("")), std::invalid_argument);
}
