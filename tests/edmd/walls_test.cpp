// Driving walls (docs/edmd.md "Driving walls"): the wall rule of one collision, the
// flux-weighted energy per hit against a Monte Carlo of its own integral, the closed-form
// balance temperature against the bisection, the steady-state energy balance from the run's
// counters, and the headline: the mean temperature in the dilute near-elastic limit vs the
// energy-balance theory.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include <filesystem>
#include <vector>

#include "core/h5.hpp"
#include "core/run_support.hpp"
#include "edmd/edmd.hpp"
#include "tests/edmd/config_support.hpp"
#include "edmd/profile.hpp"
#include "edmd/theory.hpp"

using namespace grainbath;
using namespace grainbath::edmd;

using grainbath::edmd::testing::config_from;

TEST(DrivingWalls, OneCollisionGivesTheRuleEnergyAndMomentum) {
  EngineSetup s;
  s.dims = 2;
  s.length = {10.0, 10.0, 1.0};
  s.walls = {true, false, false};
  s.wall_driving = {0.3, 0.7};
  s.wall_restitution_side = {0.8, 0.5};
  // grain 0 flies to the low wall (hits x = 0.5 at t = 4.5), grain 1 drifts along y far away
  Engine eng(s, {{5.0, 2.0, 0.5}, {5.0, 7.0, 0.5}}, {{-1.0, 0.0, 0.0}, {0.0, 0.1, 0.0}});
  eng.advance(ElasticRestitution{}, 5.0, ~std::uint64_t{0});
  eng.synchronize();
  // low wall: v' = alpha_low |v| + v_low = 0.8 + 0.3
  EXPECT_DOUBLE_EQ(eng.velocity(0).x, 1.1);
  EXPECT_EQ(eng.counters().wall_hits[0], 1u);
  EXPECT_NEAR(eng.counters().wall_energy[0], 0.5 * (1.1 * 1.1 - 1.0), 1e-15);
  EXPECT_NEAR(eng.counters().wall_momentum[0], 2.1, 1e-15);
  EXPECT_NEAR(eng.position(0).x, 0.5 + 0.5 * 1.1, 1e-12);
  // high wall at x = 9.5 after (9.5 - 0.5)/1.1: v' = -(0.5 * 1.1 + 0.7)
  eng.advance(ElasticRestitution{}, 4.5 + 9.0 / 1.1 + 0.1, ~std::uint64_t{0});
  eng.synchronize();
  EXPECT_DOUBLE_EQ(eng.velocity(0).x, -1.25);
  EXPECT_EQ(eng.counters().wall_hits[1], 1u);
  EXPECT_NEAR(eng.counters().wall_energy[1], 0.5 * (1.25 * 1.25 - 1.1 * 1.1), 1e-15);
  EXPECT_NEAR(eng.counters().wall_momentum[1], 2.35, 1e-15);
  EXPECT_DOUBLE_EQ(eng.velocity(0).y, 0.0);  // smooth walls: tangential velocity untouched
  EXPECT_EQ(eng.counters().energy_lost, 0.0);  // driving walls book into wall_energy only
}

TEST(DrivingWalls, EnergyPerHitMatchesMonteCarloOfTheFluxIntegral) {
  // grains of a Maxwellian at T cross a plane at a rate proportional to |v_x|: the mean
  // energy a wall gives per hit is Sum |v_x| dE(|v_x|) / Sum |v_x| over Maxwellian draws
  const double T = 1.7, v = 0.9, alpha = 0.85;
  CounterRng rng(3, Stream::initial_velocities, 0, 0);
  double sw = 0.0, sa = 0.0, saa = 0.0, saw = 0.0, sww = 0.0;  // w = |v_x| (weight), a = w dE
  const int M = 400000;
  for (int k = 0; k < M; ++k) {
    const double u = std::abs(std::sqrt(T) * rng.normal());
    const double a = u * 0.5 * ((alpha * u + v) * (alpha * u + v) - u * u);
    sw += u, sa += a, saa += a * a, saw += a * u, sww += u * u;
  }
  const double mc = sa / sw;
  // ratio estimator: var(R) = var(a - R w) / (M <w>^2)
  const double var = (saa - 2.0 * mc * saw + mc * mc * sww) / M;
  const double err = std::sqrt(var / M) / (sw / M);
  const double formula = theory::wall_energy_per_hit(v, alpha, T);
  EXPECT_NEAR(mc, formula, 5.0 * err);
  EXPECT_LT(err, 0.01 * std::abs(formula));
  // the "thesis reading" (Maxwell mean of |v_x| in the cross term) is excluded by the MC
  EXPECT_GT(std::abs(mc - theory::wall_energy_per_hit(v, alpha, T, true)), 20.0 * err);
}

TEST(DrivingWalls, BalanceTemperatureMatchesTheClosedForm) {
  // 2D, constant e, dilute form: with s = sqrt(T), per grain and time
  //   wall input (1/L)(s/sqrt(2 pi)) [V2 + sqrt(2 pi) AV s - 2 (1 - A2) s^2]  (bars: two-wall means)
  //   loss (1 - e^2) n g sqrt(pi) s^3
  // => A s^2 - B s - C = 0, A = 2(1 - A2) + sqrt(2) pi (1 - e^2) n g L, B = sqrt(2 pi) AV, C = V2.
  const double nu = 0.08, e = 0.93, L = 37.0;
  const theory::WallDriving w{1.2, 0.4, 0.9, 0.7, L};
  const double n = theory::number_density(2, nu);
  const double V2 = 0.5 * (w.v_low * w.v_low + w.v_high * w.v_high);
  const double AV = 0.5 * (w.alpha_low * w.v_low + w.alpha_high * w.v_high);
  const double A2 = 0.5 * (w.alpha_low * w.alpha_low + w.alpha_high * w.alpha_high);
  for (bool enskog : {false, true}) {
    const double g = enskog ? theory::g_contact_reference(2, nu) : 1.0;
    const double c = enskog ? theory::z_reference(2, nu) : 1.0;  // wall contact density / n
    const double A = 2.0 * (1.0 - A2) + std::sqrt(2.0) * std::numbers::pi * (1.0 - e * e) * n * g * L / c;
    const double B = std::sqrt(2.0 * std::numbers::pi) * AV, C = V2;
    const double s = (B + std::sqrt(B * B + 4.0 * A * C)) / (2.0 * A);
    EXPECT_NEAR(theory::wall_balance_temperature(ConstantRestitution{e}, 2, nu, w, enskog), s * s, 1e-9 * s * s);
  }
}

// Static walls with restitution < 1 book their loss in wall_energy_lost, not in the
// grain-grain energy_lost that loss.gamma compares with Bizon's eqs. 29-31 (and the slab
// loss_rate sums to): elastic grains lose nothing in collisions, so energy_lost stays 0 (the
// earlier engine added the wall losses there: loss.gamma/gamma_e 1.40 instead of 0.99 in
// /tmp/auditB's wallloss case), and the budget closes with both.
TEST(StaticWalls, LossyWallsBookTheirLossApartFromGrainCollisions) {
  Config c = config_from(
      "[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.3\naspect = [0.25, 1.0]\n"
      "[heating]\nmodel = \"white_noise\"\nkick = 0.3\n"
      "[walls]\ndirections = [\"x\"]\nrestitution = 0.5\n");
  ASSERT_FALSE(c.driving_walls());
  const auto init = make_initial_state(c, 3);
  Engine eng(make_setup(c, 3), init.positions, init.velocities);
  const double e0 = eng.kinetic_energy();
  eng.advance(ElasticRestitution{}, kInf, 50 * eng.size());
  eng.synchronize();
  const Counters& f = eng.counters();
  EXPECT_EQ(f.energy_lost, 0.0);
  EXPECT_GT(f.wall_collisions, 1000u);
  EXPECT_GT(f.wall_energy_lost, 0.01 * f.heating_energy);
  EXPECT_NEAR(eng.kinetic_energy() - e0, f.heating_energy - f.energy_lost - f.wall_energy_lost,
              1e-9 * (e0 + f.heating_energy));
  EXPECT_EQ(f.wall_energy[0] + f.wall_energy[1], 0.0);  // driving walls' counter untouched
}

TEST(DrivingWalls, SteadyStateWallInputEqualsCollisionalLoss) {
  Config c = config_from(
      "[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.1\naspect = [1.0, 2.0]\n"
      "[restitution]\nlaw = \"constant\"\ne = 0.9\n"
      "[walls]\ndirections = [\"x\"]\ndriving_speed = 1.0\nrestitution_high = 0.9\n");
  ASSERT_TRUE(c.driving_walls());
  const auto init = make_initial_state(c, 2);
  Engine eng(make_setup(c, 2), init.positions, init.velocities);
  const ConstantRestitution law{0.9};
  const std::size_t N = eng.size();
  eng.advance(law, kInf, 150 * N);
  eng.synchronize();
  const double e0 = eng.kinetic_energy();
  const Counters c0 = eng.counters();
  const double t0 = eng.time();
  std::vector<double> diff;
  Counters prev = c0;
  double loss_total = 0.0;
  for (int k = 0; k < 400; ++k) {
    eng.advance(law, kInf, c0.collisions + (k + 1) * N);
    const Counters& cur = eng.counters();
    const double in = cur.wall_energy[0] + cur.wall_energy[1] - prev.wall_energy[0] - prev.wall_energy[1];
    const double loss = cur.energy_lost - prev.energy_lost;
    diff.push_back(in - loss);
    loss_total += loss;
    prev = cur;
  }
  eng.synchronize();
  const Counters& f = eng.counters();
  const double in = f.wall_energy[0] + f.wall_energy[1] - c0.wall_energy[0] - c0.wall_energy[1];
  const double loss = f.energy_lost - c0.energy_lost;
  // exact bookkeeping: kinetic energy change = wall input - collisional loss
  EXPECT_NEAR(eng.kinetic_energy() - e0, in - loss, 1e-9 * loss);
  // steady state: input = loss within errors (blocked series of per-interval differences)
  const MeanError d = block_average(diff);
  EXPECT_NEAR(d.mean * diff.size(), 0.0, 5.0 * d.stderr_ * diff.size()) << "in " << in << " loss " << loss;
  EXPECT_LT(d.stderr_ * diff.size(), 0.03 * loss_total);  // the check has teeth
  EXPECT_GT(f.wall_hits[0], 1000u);
  EXPECT_GT(f.wall_energy[1] - c0.wall_energy[1], 0.0);
  (void)t0;
}

TEST(DrivingWalls, DiluteNearElasticTemperatureFollowsTheEnergyBalance) {
  // Headline of cases/vibrated-walls in the limit where the balance holds: 400 disks,
  // nu = 0.05, L_x = 40 sigma between the walls (aspect 1:4), e = 0.995, elastic walls,
  // v_dr chosen so that the theory gives T = 1. Measured: T/T_balance = 1.020 +- 0.002
  // (the ~2 % excess is the x-temperature at the walls above the mean, docs/edmd.md).
  // Stated tolerance 4 %; the "thesis reading" of eq. B.1 (T/T_th = 2.5) is excluded.
  const double e = 0.995, nu = 0.05;
  const std::string base =
      "[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.05\naspect = [1.0, 4.0]\n"
      "[restitution]\nlaw = \"constant\"\ne = 0.995\n[walls]\ndirections = [\"x\"]\n";
  const Config probe = config_from(base + "driving_speed = 1.0\n");
  const theory::WallDriving unit{1.0, 1.0, 1.0, 1.0, probe.box().x};
  const double v_dr = 1.0 / std::sqrt(theory::wall_balance_temperature(ConstantRestitution{e}, 2, nu, unit, true));
  Config c = config_from(base + "driving_speed = " + std::to_string(v_dr) + "\n");
  c.wall_driving = {v_dr, v_dr};  // exact value (to_string rounds)
  const theory::WallDriving w{v_dr, v_dr, 1.0, 1.0, c.box().x};
  const double T_bal = theory::wall_balance_temperature(ConstantRestitution{e}, 2, nu, w, true);
  EXPECT_NEAR(T_bal, 1.0, 1e-9);
  const auto init = make_initial_state(c, 1);  // starts at T = 1
  Engine eng(make_setup(c, 1), init.positions, init.velocities);
  const std::size_t N = eng.size();
  const ConstantRestitution law{e};
  eng.advance(law, kInf, 200 * N);
  std::vector<double> Ts;
  for (int k = 0; k < 500; ++k) {
    eng.advance(law, kInf, eng.counters().collisions + 2 * N);
    eng.synchronize();
    Vec3 p;
    for (std::size_t i = 0; i < N; ++i) p += eng.velocity(i);
    Ts.push_back((eng.kinetic_energy() - 0.5 * norm2(p) / N) / N);  // 2D: E/N = T
  }
  const MeanError T = block_average(Ts);
  std::printf("T = %.5f +- %.5f, T_balance = %.5f, ratio %.4f\n", T.mean, T.stderr_, T_bal, T.mean / T_bal);
  EXPECT_NEAR(T.mean / T_bal, 1.0, 0.04) << T.mean << " +- " << T.stderr_;
  EXPECT_LT(T.stderr_, 0.01);
  const double T_thesis = theory::wall_balance_temperature(law, 2, nu, w, false, true);
  EXPECT_GT(T.mean / T_thesis, 2.0);
}

TEST(DrivingWalls, CaseKeysAreStrict) {
  const std::string base = "[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.1\n";
  EXPECT_THROW(config_from(base + "[walls]\ndirections = [\"x\"]\ndriving_sped = 1.0\n"), CaseError);
  EXPECT_THROW(config_from(base + "[walls]\ndirections = [\"x\"]\ndriving_speed = -1.0\n"), CaseError);
  EXPECT_THROW(config_from(base + "[walls]\ndirections = [\"x\", \"y\"]\ndriving_speed = 1.0\n"), CaseError);
  EXPECT_THROW(config_from(base + "[walls]\ndriving_speed = 1.0\n"), CaseError);
  EXPECT_THROW(config_from(base + "[walls]\ndirections = [\"x\"]\ndriving_speed = 1.0\ndriving_speed_low = 2.0\n"),
               CaseError);
  EXPECT_THROW(config_from(base + "[walls]\ndirections = [\"x\"]\nrestitution_low = 0.0\n"), CaseError);
  EXPECT_THROW(config_from(base + "aspect = [1.0]\n"), CaseError);
  EXPECT_THROW(config_from(base + "aspect = [1.0, 400.0]\n"), CaseError);  // an edge below 3 sigma
  EXPECT_THROW(config_from(base + "[profiles]\nslabs = 0\n"), CaseError);
  EXPECT_THROW(config_from(base + "[profiles]\naxis = \"z\"\n"), CaseError);
  const Config ok = config_from(base + "aspect = [1.0, 4.0]\n[walls]\ndirections = [\"x\"]\ndriving_speed_low = 1.0\n"
                                       "restitution_high = 0.8\n[profiles]\nslabs = 10\n");
  EXPECT_DOUBLE_EQ(ok.wall_driving[0], 1.0);
  EXPECT_DOUBLE_EQ(ok.wall_driving[1], 0.0);
  EXPECT_DOUBLE_EQ(ok.wall_restitution_side[0], 1.0);
  EXPECT_DOUBLE_EQ(ok.wall_restitution_side[1], 0.8);
  EXPECT_NEAR(ok.box().y / ok.box().x, 4.0, 1e-12);
  EXPECT_NEAR(ok.box().x * ok.box().y, 400.0 / theory::number_density(2, 0.1), 1e-9);
  EXPECT_EQ(ok.profile_axis, 0);
  EXPECT_TRUE(ok.profiles);
}

TEST(DrivingWalls, SlabEnergyBalanceNeedsTheCollisionalHeatFlux) {
  // Steady channel (no mean flow): the energy equation per slab is dq_x/dx = -loss. With
  // q = q_kin + q_col (Irving-Kirkwood, docs/edmd.md) it closes within errors; the kinetic
  // flux alone misses at this density. Integrated from the first interior slab:
  //   q(x_k) - q(x_1) = -Int_{x_1}^{x_k} loss dx   (trapezoid over slab centres).
  Config c = config_from(
      "[edmd]\ndimensions = 2\nparticles = 900\npacking_fraction = 0.3\n"
      "[restitution]\nlaw = \"constant\"\ne = 0.95\n"
      "[walls]\ndirections = [\"x\"]\ndriving_speed = 1.0\n");
  const auto init = make_initial_state(c, 6);
  Engine eng(make_setup(c, 6), init.positions, init.velocities);
  const ConstantRestitution law{0.95};
  const std::size_t N = eng.size();
  eng.advance(law, kInf, 150 * N);
  SlabProfiles prof;
  const int S = 10;
  prof.init({2, eng.length(), 0, S, false});
  eng.set_collision_hook(&SlabProfiles::collision_hook, &prof);
  std::vector<Vec3> x(N), v(N);
  double t_prev = eng.time();
  for (int k = 0; k < 300; ++k) {
    eng.advance(law, kInf, eng.counters().collisions + N);
    eng.synchronize();
    for (std::size_t i = 0; i < N; ++i) x[i] = eng.position(i), v[i] = eng.velocity(i);
    prof.add_snapshot(x, v);
    prof.end_interval(eng.time() - t_prev);
    t_prev = eng.time();
  }
  const auto r = prof.result();
  const auto& q = r.field("q_x");
  const auto& qk = r.field("q_kin_x");
  const auto& loss = r.field("loss_rate");
  const double w = r.centres[1] - r.centres[0];
  double cum = 0.0, cum_err2 = 0.0, worst_total = 0.0, worst_kin = 0.0, qmax = 0.0;
  for (int k = 2; k < S - 1; ++k) {
    cum += 0.5 * w * (loss.mean[k] + loss.mean[k - 1]);
    cum_err2 += std::pow(0.5 * w, 2) * (std::pow(loss.stderr_[k], 2) + std::pow(loss.stderr_[k - 1], 2));
    const double err = std::sqrt(q.stderr_[k] * q.stderr_[k] + q.stderr_[1] * q.stderr_[1] + cum_err2);
    worst_total = std::max(worst_total, std::abs(q.mean[k] - q.mean[1] + cum) / err);
    worst_kin = std::max(worst_kin, std::abs(qk.mean[k] - qk.mean[1] + cum) / err);
    qmax = std::max(qmax, std::abs(q.mean[k]));
  }
  std::printf("slab energy balance: worst |residual|/sigma total %.2f, kinetic only %.2f\n", worst_total, worst_kin);
  EXPECT_LT(worst_total, 5.0);
  EXPECT_GT(worst_kin, 5.0);  // the collisional heat flux matters at nu = 0.3
  EXPECT_GT(qmax, 10.0 * q.stderr_[1]);  // a real heat flux, not noise
}

// The virial theorem of a closed box, exactly, one run at a time: with G = Σ r_i·v_i (unit
// masses), dG/dt = Σ v_i² + Σ r_i·F_i. Integrated over a run of elastic grains between elastic
// walls, in a cube of side L walled in every direction (centres confined to [σ/2, L − σ/2]):
//   G(t) − G(0) = 2E t + W − (L − 1) M/2 + (L/2) Σ_d ΔP_d,
// W = Σ r_ij·J_ij over the grain collisions (Counters::virial, positive for repulsion), M the
// momentum the walls took (Counters::wall_virial), ΔP_d the change of the total momentum
// along d: the walls of direction d at σ/2 and L − σ/2 took M_low and M_high with
// M_low − M_high = ΔP_d, and Σ x J there is M_low/2 − (L − 1/2) M_high. Every term is a
// sum the engine keeps or a state it reports, so the identity holds to round-off: it fails
// if a wall hit or a collision books a wrong momentum, or a grain leaves the box.
TEST(StaticWalls, VirialTheoremOfAClosedBoxHoldsExactly) {
  for (int dims : {2, 3}) {
    const double L = dims == 2 ? 30.0 : 12.0;
    const int side = dims == 2 ? 20 : 6;
    const double spacing = dims == 2 ? 1.45 : 1.6;
    std::vector<Vec3> r, v;
    CounterRng rng(11, Stream::initial_velocities, 0, 0);
    for (int k = 0; k < (dims == 2 ? 1 : side); ++k)
      for (int j = 0; j < side; ++j)
        for (int i = 0; i < side; ++i) {
          r.push_back({1.0 + spacing * i, 1.0 + spacing * j, dims == 2 ? 0.5 : 1.0 + spacing * k});
          v.push_back({rng.normal(), rng.normal(), dims == 2 ? 0.0 : rng.normal()});
        }
    EngineSetup s;
    s.dims = dims;
    s.length = {L, L, dims == 2 ? 1.0 : L};
    s.walls = {true, true, dims == 3};
    Engine eng(s, r, v);
    auto virial_g = [&] {
      double g = 0.0;
      for (std::size_t i = 0; i < r.size(); ++i) g += dot(eng.position(i), eng.velocity(i));
      return g;
    };
    double E = 0.0;
    for (const Vec3& w : v) E += 0.5 * dot(w, w);
    eng.synchronize();
    const double g0 = virial_g();
    const Vec3 p0 = eng.momentum();
    const double t_end = 40.0;
    eng.advance(ElasticRestitution{}, t_end, ~std::uint64_t{0});
    eng.synchronize();
    const double g1 = virial_g();
    const Vec3 dp = eng.momentum() - p0;
    const Counters& c = eng.counters();
    const double t = eng.time();
    const double walls_term = -(L - 1.0) * c.wall_virial / 2.0 + (L / 2.0) * (dp.x + dp.y + (dims == 3 ? dp.z : 0.0));
    const double rhs = 2.0 * E * t + c.virial + walls_term;
    const double scale = 2.0 * E * t + c.virial + (L - 1.0) * c.wall_virial / 2.0;
    std::printf("dims %d: %llu collisions, %llu wall hits; G(t) - G(0) = %.9f, 2Et + W + walls = %.9f "
                "(2Et %.3f, W %.3f, walls %.3f)\n",
                dims, static_cast<unsigned long long>(c.collisions), static_cast<unsigned long long>(c.wall_collisions),
                g1 - g0, rhs, 2.0 * E * t, c.virial, walls_term);
    EXPECT_GT(c.collisions, 20u * r.size());  // a dense run, not a few free flights
    EXPECT_GT(c.wall_collisions, r.size());
    EXPECT_NEAR(t, t_end, 1e-9);
    EXPECT_NEAR(g1 - g0, rhs, 1e-10 * scale);
  }
}

// pressure.wall, the walls' momentum per unit time and area, against the virial pressure of
// the same run: in a square (cube) of side L walled in every direction the identity above
// gives pressure.wall = pressure.P L/(L - 1) up to its boundary terms, O(sqrt(N) L v / (E t)),
// here ~1e-4 (seeds 1-3 measured within 2.2e-4). A wrong area (one wall per direction, or the
// full box surface in 3D counted twice), a wrong time (the equilibration included) or the
// counters of the wrong phase miss by far more than the 0.2 % allowed.
TEST(StaticWalls, WallPressureIsTheVirialPressureOfTheConfinedVolume) {
  for (int dims : {2, 3}) {
    const int n = dims == 2 ? 400 : 343;
    const double nu = dims == 2 ? 0.35 : 0.25;
    const std::string toml = "[edmd]\ndimensions = " + std::to_string(dims) + "\nparticles = " + std::to_string(n) +
                             "\npacking_fraction = " + std::to_string(nu) +
                             "\nequilibrate = 20\ncollisions = 2000\n[walls]\ndirections = " +
                             (dims == 2 ? "[\"x\", \"y\"]" : "[\"x\", \"y\", \"z\"]") + "\n";
    const Summary s = grainbath::edmd::testing::run_summary(toml, 1, "edmd_wall_pressure");
    const double L = std::pow(n * (dims == 2 ? std::numbers::pi / 4.0 : std::numbers::pi / 6.0) / nu, 1.0 / dims);
    const double expected = s.number("pressure.P") * L / (L - 1.0);
    std::printf("dims %d: pressure.wall %.6f, pressure.P L/(L - 1) %.6f (L = %.4f), ratio %.6f\n", dims,
                s.number("pressure.wall"), expected, L, s.number("pressure.wall") / expected);
    EXPECT_NEAR(s.number("pressure.wall") / expected, 1.0, 2e-3);
  }
  // no walls: no wall pressure
  const Summary open = grainbath::edmd::testing::run_summary(
      "[edmd]\ndimensions = 2\nparticles = 100\npacking_fraction = 0.3\nequilibrate = 5\ncollisions = 20\n", 1,
      "edmd_wall_pressure_open");
  EXPECT_EQ(open.get("pressure.wall"), nullptr);
}

// Mechanical equilibrium of the vibrated channel: in a steady state the normal stress P_xx is
// the same in every slab, and at the walls it is the momentum they take per time and length.
// The slab profiles' P_xx (kinetic + collisional, Irving-Kirkwood: src/edmd/profile.*) over the
// interior slabs against `pressure.wall` (the walls' own counter): two bookkeepings of the same
// momentum flux that share no code. cases/vibrated-walls, main run: ratio 1.00002, interior
// mean error 0.16 %.
TEST(DrivingWalls, WallPressureIsTheNormalStressOfTheChannel) {
  const std::string toml = R"([edmd]
dimensions = 2
particles = 900
packing_fraction = 0.1
temperature = 0.3
equilibrate = 100
collisions = 1500
[restitution]
law = "constant"
e = 0.95
[walls]
directions = ["x"]
driving_speed_low = 1.0
driving_speed_high = 1.0
[sampling]
interval = 2.0
corr_max = 3.0
[profiles]
slabs = 20
)";
  std::vector<double> P, E;
  const Summary s = grainbath::edmd::testing::run_summary(toml, 1, "edmd_wall_stress", [&](const std::filesystem::path& out) {
    H5File h((out / "results.h5").string(), H5File::Mode::read);
    P = h.read_doubles("/profiles/P_xx"), E = h.read_doubles("/profiles/P_xx_stderr");
  });
  ASSERT_EQ(P.size(), 20u);
  double sw = 0.0, swp = 0.0;
  for (std::size_t k = 2; k + 2 < P.size(); ++k) {  // the wall slabs hold the walls' own layer
    ASSERT_GT(E[k], 0.0);
    sw += 1.0 / (E[k] * E[k]), swp += P[k] / (E[k] * E[k]);
  }
  const double mean = swp / sw, se = 1.0 / std::sqrt(sw), wall = s.number("pressure.wall");
  std::printf("P_xx of the interior slabs %.6f +- %.6f, pressure.wall %.6f (ratio %.5f)\n", mean, se, wall, wall / mean);
  EXPECT_NEAR(wall, mean, 5.0 * se);
  EXPECT_LT(se / mean, 0.01);  // a check at the per cent level at least
}
