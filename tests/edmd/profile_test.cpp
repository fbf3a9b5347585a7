// Slab profiles (src/edmd/profile.*): exact bookkeeping of the collisional momentum and
// energy fluxes, the kinetic moment algebra, and the elastic-equilibrium checks (uniform
// pressure equal to the virial pressure of Bizon eq. 24, zero heat flux and shear stress).
#include <gtest/gtest.h>

#include <cmath>

#include "edmd/edmd.hpp"
#include "tests/edmd/config_support.hpp"
#include "edmd/profile.hpp"
#include "edmd/theory.hpp"

using namespace grainbath;
using namespace grainbath::edmd;

using grainbath::edmd::testing::config_from;

namespace {

// Independent tally of the same collisions: totals of J_a r_b, of the energy changes and
// of the direction of the impulse.
struct Tally {
  SlabProfiles* profiles = nullptr;
  double Jr[9] = {};
  double dE = 0.0;
  double max_nonradial = 0.0;  // |J x r| / |J|: the impulse of smooth grains is along r
  static void hook(void* self, const CollisionRecord& c) {
    auto* t = static_cast<Tally*>(self);
    const double J[3] = {c.impulse.x, c.impulse.y, c.impulse.z}, r[3] = {c.rij.x, c.rij.y, c.rij.z};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) t->Jr[a * 3 + b] += J[a] * r[b];
    t->dE += c.dEi + c.dEj;
    const Vec3 cr{c.impulse.y * c.rij.z - c.impulse.z * c.rij.y, c.impulse.z * c.rij.x - c.impulse.x * c.rij.z,
                  c.impulse.x * c.rij.y - c.impulse.y * c.rij.x};
    t->max_nonradial = std::max(t->max_nonradial, norm(cr) / std::max(norm(c.impulse), 1e-300));
    t->profiles->add_collision(c);
  }
};
}  // namespace

TEST(SlabProfiles, SegmentIsSharedOverTheSlabsItCrosses) {
  SlabProfiles p;
  p.init({2, {10.0, 4.0, 1.0}, 0, 20, true});  // slabs of width 0.5 along x
  CollisionRecord c;
  c.ri = {0.9, 1.0, 0.5};
  c.rij = {0.8, 0.6, 0.0};  // x from 0.9 to 1.7: slabs 1 (0.1), 2 (0.5), 3 (0.2)
  c.impulse = {0.8, 0.6, 0.0};
  p.add_collision(c);
  const auto& coll = p.accumulators().open.coll;
  auto Jxx = [&](int k) { return coll[static_cast<std::size_t>(k) * SlabProfiles::kColl + 0]; };
  EXPECT_NEAR(Jxx(1), 0.64 * 0.1 / 0.8, 1e-14);
  EXPECT_NEAR(Jxx(2), 0.64 * 0.5 / 0.8, 1e-14);
  EXPECT_NEAR(Jxx(3), 0.64 * 0.2 / 0.8, 1e-14);
  // across the periodic boundary: x from 9.8 to 10.4 -> slab 19 (0.2) and slab 0 (0.4)
  SlabProfiles q;
  q.init({2, {10.0, 4.0, 1.0}, 0, 20, true});
  c.ri = {9.8, 1.0, 0.5};
  c.rij = {0.6, 0.8, 0.0};
  c.impulse = {0.6, 0.8, 0.0};
  q.add_collision(c);
  const auto& qc = q.accumulators().open.coll;
  EXPECT_NEAR(qc[19 * SlabProfiles::kColl + 0], 0.36 * 0.2 / 0.6, 1e-14);
  EXPECT_NEAR(qc[0 * SlabProfiles::kColl + 0], 0.36 * 0.4 / 0.6, 1e-14);
  // parallel to the slabs: all in the slab of r_i
  SlabProfiles w;
  w.init({2, {10.0, 4.0, 1.0}, 0, 20, true});
  c.ri = {3.3, 1.0, 0.5};
  c.rij = {0.0, 1.0, 0.0};
  c.impulse = {0.0, 2.0, 0.0};
  w.add_collision(c);
  EXPECT_DOUBLE_EQ(w.accumulators().open.coll[6 * SlabProfiles::kColl + 4], 2.0);
}

TEST(SlabProfiles, KineticMomentsMatchDirectSums) {
  // one slab, arbitrary velocities with a mean flow: P_kin and q_kin from the raw-moment
  // expansion against the direct sums over peculiar velocities
  SlabProfiles p;
  p.init({3, {4.0, 4.0, 4.0}, 2, 1, true});
  std::vector<Vec3> x, v;
  CounterRng rng(5, Stream::initial_velocities, 0, 0);
  for (int i = 0; i < 50; ++i) {
    x.push_back({1.0, 1.0, 4.0 * rng.uniform()});
    v.push_back(Vec3{0.3, -0.7, 1.1} + Vec3{rng.normal(), rng.normal() * 2.0, std::pow(rng.uniform(), 3) * 4.0});
  }
  p.add_snapshot(x, v);
  p.end_interval(1.0);
  const auto r = p.result();
  Vec3 u;
  for (const auto& w : v) u += w;
  u = (1.0 / v.size()) * u;
  double Pxz = 0.0, qz = 0.0, qx = 0.0, Tyy = 0.0;
  for (const auto& w : v) {
    const Vec3 c = w - u;
    Pxz += c.x * c.z;
    Tyy += c.y * c.y;
    qz += 0.5 * norm2(c) * c.z;
    qx += 0.5 * norm2(c) * c.x;
  }
  const double V = 64.0;
  EXPECT_NEAR(r.field("P_kin_xz").mean[0], Pxz / V, 1e-12);
  EXPECT_NEAR(r.field("T_y").mean[0], Tyy / v.size(), 1e-12);
  EXPECT_NEAR(r.field("q_kin_z").mean[0], qz / V, 1e-12);
  EXPECT_NEAR(r.field("q_kin_x").mean[0], qx / V, 1e-12);
  EXPECT_NEAR(r.field("density").mean[0], 50.0 / V, 1e-14);
}

TEST(SlabProfiles, ElasticEquilibriumPressureEqualsVirialAndHeatFluxVanishes) {
  // 2D elastic disks, nu = 0.4, periodic; slabs along x
  Config c = config_from("[edmd]\ndimensions = 2\nparticles = 576\npacking_fraction = 0.4\n");
  const auto init = make_initial_state(c, 21);
  Engine eng(make_setup(c, 21), init.positions, init.velocities);
  const std::size_t N = eng.size();
  eng.advance(ElasticRestitution{}, kInf, 20 * N);
  eng.rebuild();
  eng.counters() = Counters{};
  SlabProfiles prof;
  prof.init({2, eng.length(), 0, 8, true});
  Tally tally;
  tally.profiles = &prof;
  eng.set_collision_hook(&Tally::hook, &tally);
  std::vector<Vec3> x(N), v(N);
  const double t0 = eng.time();
  double t_prev = t0, ke_sum = 0.0;
  const int samples = 1600;
  const double dt = 0.25;  // about 1 collision per particle at T = 1
  for (int s = 1; s <= samples; ++s) {
    eng.advance(ElasticRestitution{}, t0 + s * dt, ~std::uint64_t{0});
    eng.synchronize();
    for (std::size_t i = 0; i < N; ++i) x[i] = eng.position(i), v[i] = eng.velocity(i), ke_sum += norm2(v[i]);
    prof.add_snapshot(x, v);
    prof.end_interval(eng.time() - t_prev);
    t_prev = eng.time();
  }
  const double t_run = eng.time() - t0;
  const double V = eng.length().x * eng.length().y;
  const auto r = prof.result();
  const int S = 8;
  // exact bookkeeping: slab sums of the collisional tensor = the independent tally of
  // Sum J_a r_b; its trace = Bizon's virial sum (sigma k.dv); kinetic trace = Sum v^2
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) {
      double s = 0.0;
      const std::string name = std::string("P_col_") + "xy"[a] + "xy"[b];
      for (int k = 0; k < S; ++k) s += r.field(name).mean[k] * r.slab_volume * t_run;
      EXPECT_NEAR(s, tally.Jr[a * 3 + b], 1e-9 * std::abs(tally.Jr[0])) << name;
    }
  EXPECT_NEAR(tally.Jr[0] + tally.Jr[4], eng.counters().virial, 1e-8 * eng.counters().virial);
  EXPECT_LT(tally.max_nonradial, 1e-9);
  EXPECT_EQ(prof.accumulators().collisions, eng.counters().collisions);
  // kinetic trace: slab sums of P_kin (peculiar velocities) plus the slab flow n u^2 give Sum v^2
  double ke_slabs = 0.0, pbar = 0.0, pbar_err2 = 0.0;
  for (int k = 0; k < S; ++k) {
    const double n = r.field("density").mean[k], ux = r.field("u_x").mean[k], uy = r.field("u_y").mean[k];
    ke_slabs += (2.0 * r.field("p_kin").mean[k] + n * (ux * ux + uy * uy)) * r.slab_volume * samples;
    pbar += r.field("p").mean[k] / S;
    pbar_err2 += std::pow(r.field("p").stderr_[k] / S, 2);
  }
  EXPECT_NEAR(ke_slabs, ke_sum, 1e-10 * ke_sum);
  const double T = ke_sum / (2.0 * N * samples);
  const double p_virial = (N * T + eng.counters().virial / (2.0 * t_run)) / V;  // Bizon eq. 24
  // differs from the virial pressure only by the slab flows Sum n u^2 (zero total momentum)
  EXPECT_NEAR(pbar, p_virial, 5.0 * std::sqrt(pbar_err2));
  // within errors: every slab's pressure is the virial pressure, shear stress and heat flux vanish
  const double Z = p_virial / (N / V * T);
  EXPECT_NEAR(Z, theory::z_reference(2, 0.4), 0.03 * Z);  // EOS sanity (short run)
  for (int k = 0; k < S; ++k) {
    const auto& p = r.field("p");
    EXPECT_NEAR(p.mean[k], p_virial, 5.0 * p.stderr_[k] + 1e-12) << k;
    EXPECT_GT(p.stderr_[k], 0.0);
    EXPECT_LT(p.stderr_[k], 0.02 * p_virial);  // the check has teeth
    for (const char* name : {"P_xy", "q_x", "q_y", "q_col_x", "q_kin_x"}) {
      const auto& f = r.field(name);
      EXPECT_NEAR(f.mean[k], 0.0, 5.0 * f.stderr_[k]) << name << " slab " << k;
    }
    // the normal stress through the slab faces must be the same in every slab (momentum
    // balance in a steady state); kinetic and collisional parts both present
    EXPECT_GT(r.field("P_col_xx").mean[k], 0.3 * r.field("P_kin_xx").mean[k]);
  }
}

TEST(SlabProfiles, InelasticSinkBooksTheCollisionalLoss) {
  Config c = config_from(
      "[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.3\n"
      "[restitution]\nlaw = \"bizon\"\ne = 0.8\ncrossover = 1.0\n"
      "[heating]\nmodel = \"white_noise\"\nkick = 0.5\n");
  const auto init = make_initial_state(c, 4);
  Engine eng(make_setup(c, 4), init.positions, init.velocities);
  SlabProfiles prof;
  prof.init({2, eng.length(), 1, 10, true});
  Tally tally;
  tally.profiles = &prof;
  eng.set_collision_hook(&Tally::hook, &tally);
  const double t0 = eng.time();
  eng.advance(BizonRestitution{0.8, 1.0}, kInf, 40000);
  eng.synchronize();
  std::vector<Vec3> x(eng.size()), v(eng.size());
  for (std::size_t i = 0; i < eng.size(); ++i) x[i] = eng.position(i), v[i] = eng.velocity(i);
  prof.add_snapshot(x, v);
  const double t = eng.time() - t0;
  prof.end_interval(t);
  const auto r = prof.result();
  double loss = 0.0;
  for (double l : r.field("loss_rate").mean) loss += l * r.slab_volume * t;
  EXPECT_NEAR(loss, eng.counters().energy_lost, 1e-9 * eng.counters().energy_lost);
  EXPECT_NEAR(-tally.dE, eng.counters().energy_lost, 1e-9 * eng.counters().energy_lost);
}
