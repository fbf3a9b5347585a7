// Grain-grain collision rule and apse sampling, checked against the target densities and
// exact conservation laws (not against the formulas the code uses).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "operators/binary_collision.hpp"
#include "operators/random.hpp"
#include "operators/restitution.hpp"

using namespace grainbath;

// The apse density |g.n| / (2 pi |g|) on the sphere, folded onto g.n >= 0, gives
// mu = g_hat.n the density 2 mu on [0, 1] and a uniform azimuth about g.
TEST(ApseDirection, MatchesTargetDensity) {
  CounterRng r(11, Stream::grain_collisions, 0, 0);
  const Vec3 g_hat = (1.0 / std::sqrt(14.0)) * Vec3{1, 2, 3};
  // an orthonormal pair perpendicular to g_hat for the azimuth
  Vec3 e1 = Vec3{2, -1, 0};
  e1 = (1.0 / norm(e1)) * e1;
  const Vec3 e2{g_hat.y * e1.z - g_hat.z * e1.y, g_hat.z * e1.x - g_hat.x * e1.z, g_hat.x * e1.y - g_hat.y * e1.x};
  const int n = 1'000'000, bins = 20;
  std::vector<double> hist(bins, 0.0);
  double cos_phi = 0, sin_phi = 0;
  for (int k = 0; k < n; ++k) {
    const Vec3 a = apse_direction(g_hat, r.unit_vector());
    ASSERT_NEAR(norm(a), 1.0, 1e-12);
    const double mu = dot(a, g_hat);
    ASSERT_GE(mu, 0.0);
    hist[std::min(bins - 1, static_cast<int>(mu * bins))] += 1;
    const double px = dot(a, e1), py = dot(a, e2), pr = std::hypot(px, py);
    if (pr > 0) {
      cos_phi += px / pr;
      sin_phi += py / pr;
    }
  }
  // chi-square against P(bin) = mu_hi^2 - mu_lo^2
  double chi2 = 0;
  for (int b = 0; b < bins; ++b) {
    const double lo = double(b) / bins, hi = double(b + 1) / bins;
    const double expected = n * (hi * hi - lo * lo);
    chi2 += (hist[b] - expected) * (hist[b] - expected) / expected;
  }
  EXPECT_LT(chi2, 45.0);  // 19 dof: P(chi2 > 45) ~ 7e-4
  EXPECT_NEAR(cos_phi / n, 0.0, 5 * std::sqrt(0.5 / n));
  EXPECT_NEAR(sin_phi / n, 0.0, 5 * std::sqrt(0.5 / n));
}

TEST(InelasticCollision, ConservesMomentumAndLosesTheRightEnergy) {
  CounterRng r(3, Stream::grain_collisions, 0, 0);
  for (int k = 0; k < 1000; ++k) {
    Vec3 v = r.normal3(), w = r.normal3();
    const Vec3 v0 = v, w0 = w;
    const Vec3 g0 = v - w;
    const Vec3 n = apse_direction((1.0 / norm(g0)) * g0, r.unit_vector());
    const double e = r.uniform();
    const double lost = inelastic_collision(v, w, n, e, 2.0);
    const Vec3 p0 = v0 + w0, p1 = v + w;
    EXPECT_NEAR(p1.x, p0.x, 1e-14);
    EXPECT_NEAR(p1.y, p0.y, 1e-14);
    EXPECT_NEAR(p1.z, p0.z, 1e-14);
    const double ke0 = norm2(v0) + norm2(w0), ke1 = norm2(v) + norm2(w);  // mass 2: (1/2) 2 |v|^2
    EXPECT_NEAR(ke0 - ke1, lost, 1e-12 * ke0);
    // normal relative velocity reversed and scaled by e; tangential kept
    const Vec3 g1 = v - w;
    EXPECT_NEAR(dot(g1, n), -e * dot(g0, n), 1e-12);
    const Vec3 t0 = g0 - dot(g0, n) * n, t1 = g1 - dot(g1, n) * n;
    EXPECT_NEAR(norm(t1 - t0), 0.0, 1e-12);
  }
}

TEST(InelasticCollision, ElasticConservesEnergyToRoundOff) {
  CounterRng r(4, Stream::grain_collisions, 0, 0);
  Vec3 v{1.0, 0.5, -0.25}, w{-0.3, 0.2, 0.9};
  const double ke0 = norm2(v) + norm2(w);
  for (int k = 0; k < 100000; ++k) {
    const Vec3 g = v - w;
    inelastic_collision(v, w, apse_direction((1.0 / norm(g)) * g, r.unit_vector()), 1.0, 1.0);
  }
  EXPECT_NEAR(norm2(v) + norm2(w), ke0, 1e-11 * ke0);
}

TEST(Restitution, LawsAndClamp) {
  PowerLawRestitution p{0.1, 0.2};
  EXPECT_NEAR(restitution(p, 2.0).e, 1 - 0.2 * std::pow(2.0, 0.2), 1e-15);
  EXPECT_FALSE(restitution(p, 2.0).clamped);
  const auto big = restitution(p, 1e6);  // 1 - 0.2 * 1e6^0.2 = 1 - 3.17 < 0
  EXPECT_TRUE(big.clamped);
  EXPECT_EQ(big.e, 0.0);
  EXPECT_DOUBLE_EQ(restitution(PowerLawRestitution{0.1, 0.0}, 5.0).e, 0.8);
  EXPECT_DOUBLE_EQ(restitution(ConstantRestitution{0.7}, 5.0).e, 0.7);
  EXPECT_DOUBLE_EQ(restitution(ElasticRestitution{}, 5.0).e, 1.0);
  BizonRestitution b{0.7, 2.0};
  EXPECT_DOUBLE_EQ(restitution(b, 3.0).e, 0.7);
  EXPECT_NEAR(restitution(b, 2.0 - 1e-12).e, 0.7, 1e-9);  // continuous at v0
  EXPECT_NEAR(restitution(b, 1.0).e, 1 - 0.3 * std::pow(0.5, 0.75), 1e-15);
  EXPECT_EQ(restitution_name(RestitutionLaw{b}), "bizon");
}
