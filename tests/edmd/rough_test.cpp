// Rough grains in the EDMD engine (issue #6, docs/rough.md sec. 6; validation rows in
// docs/validation/rough.md):
//  * every grain-grain collision, measured in the engine (one collision per advance(), all
//    grains synchronised before and after): total linear momentum, each grain's angular
//    momentum about the contact point (hence the pair's total angular momentum), the normal
//    and tangential contact-velocity rule (g_n' = -e g_n, g_t' = -beta g_t with beta = beta0
//    when sticking and the Coulomb value when sliding), the Coulomb bound, and the energy
//    lost by the pair (translational + rotational, from the velocities) against eq. W5 and the
//    engine's own energy_lost counter; 2D disks (spin along z) and 3D spheres;
//  * the steady Trot/Ttr of a driven dilute gas (phi = 0.05, N = 2025) against the event-free
//    Monte Carlo of tests/rough/driven_mc.hpp at the same e, beta0, mu, q (tight), with model E
//    (closures/rough) printed as the reference.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "closures/rough.hpp"
#include "core/case_file.hpp"
#include "core/run_context.hpp"
#include "core/summary.hpp"
#include "edmd/edmd.hpp"
#include "tests/edmd/rough_support.hpp"
#include "tests/rough/driven_mc.hpp"

using namespace grainbath;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Vec3 minimum_image(Vec3 d, const Vec3& L, int dims) {
  d.x -= L.x * std::round(d.x / L.x);
  d.y -= L.y * std::round(d.y / L.y);
  if (dims == 3) d.z -= L.z * std::round(d.z / L.z);
  return d;
}

struct CollisionStats {
  int sticking = 0, sliding = 0;
  double max_momentum = 0, max_angular = 0, max_energy = 0, max_counter = 0, max_normal = 0, max_tangential = 0;
  double max_coulomb_excess = 0, max_sliding_equality = 0;
};

// Runs `collisions` collisions one at a time and checks each one (see the file comment).
CollisionStats check_collisions(int dims, double e, double beta0, double mu, double q, int collisions) {
  edmd::Config c;
  c.dims = dims;
  c.particles = dims == 2 ? 400 : 512;
  c.packing_fraction = dims == 2 ? 0.2 : 0.15;
  c.temperature = 1.0;
  c.rough = edmd::Config::Rough{WaltonRestitution{e, beta0, mu}, q, 1.0};  // Trot = Ttr = 1 at the start
  c.contact_time = 0.0;  // no TC guard: every collision must follow Walton exactly
  const edmd::InitialState init = edmd::make_initial_state(c, 5);
  edmd::Engine eng(edmd::make_setup(c, 5), init.positions, init.velocities);
  eng.set_angular_velocities(init.omega);
  const WaltonRestitution law{e, beta0, mu};
  const std::size_t N = eng.size();
  const double a = 0.5, I = eng.moment_of_inertia();
  EXPECT_DOUBLE_EQ(I, q * a * a);
  std::vector<Vec3> v(N), w(N);
  for (std::size_t i = 0; i < N; ++i) v[i] = eng.velocity(i), w[i] = eng.angular_velocity(i);
  CollisionStats st;
  for (int k = 0; k < collisions; ++k) {
    const double lost0 = eng.counters().energy_lost;
    eng.advance(law, kInf, eng.counters().collisions + 1);
    eng.synchronize();
    Vec3 P0, P1;
    std::vector<std::size_t> changed;
    for (std::size_t i = 0; i < N; ++i) {
      const Vec3 vi = eng.velocity(i), wi = eng.angular_velocity(i);
      P0 += v[i];
      P1 += vi;
      if (norm2(vi - v[i]) > 0.0 || norm2(wi - w[i]) > 0.0) changed.push_back(i);
      if (dims == 2) {
        EXPECT_EQ(vi.z, 0.0);
        EXPECT_EQ(wi.x, 0.0);
        EXPECT_EQ(wi.y, 0.0);
      }
    }
    if (changed.size() != 2) {
      ADD_FAILURE() << "collision " << k << " changed " << changed.size() << " grains";
      break;
    }
    const std::size_t i = changed[0], j = changed[1];
    const Vec3 rij = minimum_image(eng.position(j) - eng.position(i), eng.length(), dims);
    EXPECT_NEAR(norm(rij), 1.0, 1e-9);
    const Vec3 n = (1.0 / norm(rij)) * rij;
    const Vec3 vi1 = eng.velocity(i), vj1 = eng.velocity(j), wi1 = eng.angular_velocity(i), wj1 = eng.angular_velocity(j);
    const double scale_v = std::sqrt(norm2(v[i]) + norm2(v[j])) + 1.0;
    st.max_momentum = std::max(st.max_momentum, norm(P1 - P0) / (scale_v * std::sqrt(double(N))));
    // angular momentum of each grain about the contact point c = r_i + a n = r_j - a n
    // (m = 1): I w + (r - c) x v; the impulse acts at c, so it is conserved grain by grain
    auto L = [&](const Vec3& wv, const Vec3& vv, double side) { return I * wv + cross(side * a * n, vv); };
    const double dLi = norm(L(wi1, vi1, -1.0) - L(w[i], v[i], -1.0));
    const double dLj = norm(L(wj1, vj1, 1.0) - L(w[j], v[j], 1.0));
    st.max_angular = std::max(st.max_angular, std::max(dLi, dLj) / scale_v);
    // contact velocities before and after (eq. W1)
    const Vec3 g0 = v[i] - v[j] + a * cross(w[i] + w[j], n), g1 = vi1 - vj1 + a * cross(wi1 + wj1, n);
    const double gn0 = dot(g0, n), gn1 = dot(g1, n);
    const Vec3 gt0 = g0 - gn0 * n, gt1 = g1 - gn1 * n;
    EXPECT_GT(gn0, 0.0);
    st.max_normal = std::max(st.max_normal, std::abs(gn1 + e * gn0) / scale_v);
    // which regime: Coulomb bound on the sticking impulse (eq. W4), decided here from the
    // contact velocities alone
    const double eta0 = q * (1.0 + beta0) / (2.0 * (1.0 + q)), eta_n = 0.5 * (1.0 + e);
    const bool slides = eta0 * norm(gt0) > mu * eta_n * gn0;
    const double beta = slides ? -1.0 + mu * (1.0 + e) * (1.0 + 1.0 / q) * gn0 / norm(gt0) : beta0;
    (slides ? st.sliding : st.sticking)++;
    st.max_tangential = std::max(st.max_tangential, norm(gt1 + beta * gt0) / scale_v);
    // impulse on j: normal and tangential parts, Coulomb |dp_t| <= mu |dp_n|
    const Vec3 dp = vj1 - v[j];
    const double dpn = dot(dp, n), dpt = norm(dp - dpn * n);
    st.max_coulomb_excess = std::max(st.max_coulomb_excess, (dpt - mu * std::abs(dpn)) / scale_v);
    if (slides) st.max_sliding_equality = std::max(st.max_sliding_equality, std::abs(dpt - mu * std::abs(dpn)) / scale_v);
    // energy lost by the pair: measured from the velocities, the engine's counter, eq. W5
    auto energy = [&](const Vec3& vv, const Vec3& ww) { return 0.5 * norm2(vv) + 0.5 * I * norm2(ww); };
    const double lost = energy(v[i], w[i]) + energy(v[j], w[j]) - energy(vi1, wi1) - energy(vj1, wj1);
    const double w5 = 0.25 * ((1.0 - e * e) * gn0 * gn0 + q / (1.0 + q) * (1.0 - beta * beta) * norm2(gt0));
    const double escale = energy(v[i], w[i]) + energy(v[j], w[j]) + 1.0;
    st.max_energy = std::max(st.max_energy, std::abs(lost - w5) / escale);
    // the counter is a running sum: its increment carries the round-off of the total
    st.max_counter = std::max(st.max_counter, std::abs((eng.counters().energy_lost - lost0) - lost) / (escale + lost0));
    v[i] = vi1, v[j] = vj1, w[i] = wi1, w[j] = wj1;
  }
  return st;
}

void expect_exact(const CollisionStats& s, int collisions, bool expect_both_regimes) {
  std::printf("[measure] sticking %d, sliding %d; max relative deviations: momentum %.2g, angular momentum "
              "about the contact %.2g, g_n' + e g_n %.2g, g_t' + beta g_t %.2g, energy vs W5 %.2g, engine "
              "counter %.2g, Coulomb excess %.2g, sliding |dp_t| - mu |dp_n| %.2g\n",
              s.sticking, s.sliding, s.max_momentum, s.max_angular, s.max_normal, s.max_tangential, s.max_energy,
              s.max_counter, s.max_coulomb_excess, s.max_sliding_equality);
  EXPECT_EQ(s.sticking + s.sliding, collisions);
  if (expect_both_regimes) {
    EXPECT_GT(s.sticking, collisions / 10);
    EXPECT_GT(s.sliding, collisions / 10);
  }
  EXPECT_LT(s.max_momentum, 1e-13);
  EXPECT_LT(s.max_angular, 1e-13);
  EXPECT_LT(s.max_normal, 1e-13);
  EXPECT_LT(s.max_tangential, 1e-13);
  EXPECT_LT(s.max_energy, 1e-13);
  EXPECT_LT(s.max_counter, 1e-13);
  EXPECT_LT(s.max_coulomb_excess, 1e-13);
  EXPECT_LT(s.max_sliding_equality, 1e-13);
}

}  // namespace

// mu = 0.3 with Trot = Ttr: about half the impacts slide (docs/rough.md R10), so both
// branches of eq. W4 are exercised in the engine.
TEST(RoughEdmd, DisksConserveMomentaAndLoseWaltonEnergyAtEveryCollision) {
  expect_exact(check_collisions(2, 0.8, 0.6, 0.3, 0.5, 3000), 3000, true);
}
TEST(RoughEdmd, SpheresConserveMomentaAndLoseWaltonEnergyAtEveryCollision) {
  expect_exact(check_collisions(3, 0.7, 0.9, 0.3, 0.4, 3000), 3000, true);
}
// mu = inf, beta0 = 1, e = 1: perfectly rough and elastic, no energy lost at all
TEST(RoughEdmd, PerfectlyRoughElasticGrainsLoseNothing) {
  const CollisionStats s = check_collisions(2, 1.0, 1.0, kInf, 0.5, 1000);
  expect_exact(s, 1000, false);
  EXPECT_EQ(s.sliding, 0);
}

namespace {

struct Steady {
  double R, R_se, Ttr, R_E;
};

// The EDMD through the driver (summary.json keys), white-noise driving as in
// cases/rough-driven (kick 0.185 per collision), Trot = 0.6 Ttr at the start.
Steady edmd_steady(double mu, double collisions) {
  const std::string toml = rough_test::driven_rough_case(2, 2025, 0.05, 1.0, 0.6, 30, collisions, mu);
  const Summary s = rough_test::run_edmd_summary(toml, 11, "rough");
  auto get = [&](const char* k) { return std::get<double>(*s.get(k)); };
  return {get("rotation.R"), get("rotation.R_stderr"), get("rotation.Ttr_mean"), get("theory.model_E.R")};
}

}  // namespace

class RoughEdmdSteady : public ::testing::TestWithParam<double> {};

// Tolerance: 4 combined standard errors (EDMD blocked over the second half of its samples,
// MC 20 blocks), no model allowance: both simulate the same Walton gas under molecular chaos
// (phi = 0.05), so the comparison is exact up to statistics and the finite-density
// corrections, which are below the errors here (docs/validation/rough.md).
TEST_P(RoughEdmdSteady, RatioMatchesEventFreeMonteCarlo) {
  const double mu = GetParam();
  const Steady md = edmd_steady(mu, 150.0);
  const rough_test::McSteady mc = rough_test::mc_steady(mu, 0.02, 300.0, 23);
  std::printf("[measure] mu=%g: R_EDMD = %.4f +- %.4f, R_MC = %.4f +- %.4f, model E %.4f (EDMD/E - 1 = %+.2f%%, "
              "MC/E - 1 = %+.2f%%)\n",
              mu, md.R, md.R_se, mc.R, mc.R_se, md.R_E, 100 * (md.R / md.R_E - 1), 100 * (mc.R / mc.R_E - 1));
  EXPECT_LT(md.R_se, 0.01 * md.R) << "EDMD run too short to test anything";
  EXPECT_NEAR(md.R, mc.R, 4.0 * std::hypot(md.R_se, mc.R_se));
  EXPECT_NEAR(md.R_E, mc.R_E, 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Mu, RoughEdmdSteady, ::testing::Values(0.5, kInf));

// beta0 = -1 (no tangential impulse) with spinless grains is the smooth rule: the rough
// instantiation of the event loop must then follow the constant-e run bitwise.
TEST(RoughEdmd, SmoothLimitFollowsTheConstantRestitutionRunBitwise) {
  edmd::Config c;
  c.dims = 3;
  c.particles = 512;
  c.packing_fraction = 0.2;
  const edmd::InitialState init = edmd::make_initial_state(c, 9);
  edmd::Engine smooth(edmd::make_setup(c, 9), init.positions, init.velocities);
  edmd::Engine rough(edmd::make_setup(c, 9), init.positions, init.velocities);
  smooth.advance(ConstantRestitution{0.8}, kInf, 20000);
  rough.advance(WaltonRestitution{0.8, -1.0, 0.5}, kInf, 20000);
  smooth.synchronize();
  rough.synchronize();
  ASSERT_EQ(smooth.counters().collisions, rough.counters().collisions);
  EXPECT_EQ(smooth.time(), rough.time());
  EXPECT_EQ(smooth.counters().energy_lost, rough.counters().energy_lost);
  for (std::size_t i = 0; i < smooth.size(); ++i) {
    ASSERT_EQ(norm2(smooth.velocity(i) - rough.velocity(i)), 0.0) << i;
    ASSERT_EQ(norm2(smooth.position(i) - rough.position(i)), 0.0) << i;
    ASSERT_EQ(norm2(rough.angular_velocity(i)), 0.0) << i;
  }
}

// Case-file errors name the key: a Walton law without beta0, spins without a rough law.
TEST(RoughEdmd, CaseErrorsNameTheKey) {
  auto problems = [](const char* toml) {
    CaseReader reader(toml, "/tmp/rough_bad.toml");
    std::string all;
    try {
      edmd::read_config(reader);
      reader.finish();
    } catch (const CaseError& e) {
      for (const auto& p : e.problems()) all += p.to_string() + "\n";
    }
    return all;
  };
  const std::string a = problems("[edmd]\ndimensions = 2\npacking_fraction = 0.1\n[restitution]\nlaw = \"walton\"\ne = 0.9\n");
  EXPECT_NE(a.find("restitution.beta0"), std::string::npos) << a;
  const std::string b = problems(
      "[edmd]\ndimensions = 2\npacking_fraction = 0.1\nrotational_temperature = 1.0\n[restitution]\nlaw = \"constant\"\ne = 0.9\n");
  EXPECT_NE(b.find("edmd.rotational_temperature"), std::string::npos) << b;
  EXPECT_NE(b.find("walton"), std::string::npos) << b;
  const std::string c = problems(
      "[edmd]\ndimensions = 2\npacking_fraction = 0.1\n[restitution]\nlaw = \"walton\"\ne = 0.9\nbeta0 = 2.0\nq = -1\n");
  EXPECT_NE(c.find("restitution.beta0"), std::string::npos) << c;
  EXPECT_NE(c.find("restitution.q"), std::string::npos) << c;
}
