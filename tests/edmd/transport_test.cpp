// Bizon Sec. V transport bookkeeping (src/edmd/transport.*) and the Enskog references
// (src/edmd/theory.hpp): Monte Carlo of the Enskog collisional-transfer integrals, the
// forcing profiles of eqs. 34-36, exact slab energy and momentum balances, the forcing's
// power and body force against snapshot estimators.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "edmd/edmd.hpp"
#include "edmd/theory.hpp"
#include "edmd/transport.hpp"
#include "operators/random.hpp"
#include "transport_helpers.hpp"

using namespace grainbath;
using namespace grainbath::edmd;

namespace {
using namespace grainbath::edmd::testing;
// Monte Carlo estimates of the four Enskog coefficients (docs/edmd.md "Transport
// coefficients"), with T = n = sigma = chi = 1 and v1, v2 standard Maxwellians, k uniform on
// the unit sphere; only collisions with g.k > 0 contribute. Returns the per-sample values
// whose means give, after the stated prefactors, x_eta, c_eta, x_lambda, c_lambda.
struct EnskogMC {
  MeanErr x_eta, c_eta, x_lam, c_lam;
};
EnskogMC enskog_mc(int d, std::size_t samples) {
  const double Sd = d == 2 ? 2.0 * std::numbers::pi : 4.0 * std::numbers::pi;
  const double vd = d == 2 ? std::numbers::pi / 4.0 : std::numbers::pi / 6.0;  // packing per unit density
  const double eta0 = theory::dilute_viscosity(d, 1.0), lam0 = theory::dilute_conductivity(d, 1.0);
  std::vector<double> a(samples), b(samples), c(samples), e(samples), qk(samples);
  for (std::size_t s = 0; s < samples; ++s) {
    CounterRng rng(7, Stream::edmd_heating, s, 0);
    Vec3 k;
    if (d == 2) {
      const double p = 2.0 * std::numbers::pi * rng.uniform();
      k = {std::cos(p), std::sin(p), 0.0};
    } else {
      k = rng.unit_vector();
    }
    Vec3 v1 = rng.normal3(), v2 = rng.normal3();
    if (d == 2) v1.z = v2.z = 0.0;
    const Vec3 g = v1 - v2, V = 0.5 * (v1 + v2);
    const double gk = dot(g, k), Vk = dot(V, k);
    const double on = gk > 0.0 ? 1.0 : 0.0;
    // shear u_x = gamma y: local Maxwellians at r -+ k/2 -> first order -gamma k_y g_x/2
    a[s] = on * k.y * k.y * k.x * gk * gk * g.x;
    // Sonine perturbation of the shear state, c_x c_y, transferred at contact
    b[s] = on * k.y * k.x * gk * gk * (v1.x * v1.y + v2.x * v2.y);
    // temperature gradient along y: d ln f / dT = v^2/2 - d/2 at T = 1; energy moved to 2 = (g.k)(V.k)
    auto h = [&](const Vec3& v) { return 0.5 * norm2(v) - 0.5 * d; };
    c[s] = on * k.y * k.y * gk * gk * Vk * (h(v2) - h(v1));
    // heat-flux Sonine perturbation S(v) v_y, S = v^2/2 - (d+2)/2
    auto S = [&](const Vec3& v) { return 0.5 * norm2(v) - 0.5 * (d + 2.0); };
    e[s] = on * k.y * gk * gk * Vk * (S(v1) * v1.y + S(v2) * v2.y);
    qk[s] = S(v1) * v1.y * v1.y * 0.5 * norm2(v1);  // kinetic heat flux of the same perturbation
  }
  auto scaled = [](MeanErr m, double f) { return MeanErr{m.mean * f, m.err * std::abs(f)}; };
  EnskogMC r;
  // eta_c = (S_d / 4) E[a]; c = eta_c / (eta0 vd^2)
  r.c_eta = scaled(mean_err(a), Sd / 4.0 / (eta0 * vd * vd));
  // P^c / P^k = (S_d / 2) E[b] (T = 1); x = that / vd
  r.x_eta = scaled(mean_err(b), Sd / 2.0 / vd);
  // lambda_c = -(S_d / 4) E[c]
  r.c_lam = scaled(mean_err(c), -Sd / 4.0 / (lam0 * vd * vd));
  const double q = mean_err(qk).mean;  // exact value (d+2)/2 * ... known to 1e-3; its error enters below
  r.x_lam = scaled(mean_err(e), Sd / 2.0 / (q * vd));
  const double rel_q = mean_err(qk).err / std::abs(q);
  r.x_lam.err = std::hypot(r.x_lam.err, std::abs(r.x_lam.mean) * rel_q);
  return r;
}

const std::string kTent = air_table_case(400, 0.5, 0.05, 0.5, "profile = \"tent\"\n");
const std::string kShear = air_table_case(400, 0.5, 0.05, 0.5, "profile = \"shear\"\ncomponent = \"x\"\nbias = 0.5\n");
}  // namespace

TEST(EnskogTransport, CoefficientsMatchMonteCarloOfTheCollisionIntegrals) {
  for (int d : {2, 3}) {
    const EnskogMC mc = enskog_mc(d, 2000000);
    const auto ve = theory::enskog_viscosity_coefficients(d);
    const auto ce = theory::enskog_conductivity_coefficients(d);
    std::printf("D = %d: x_eta %.4f +- %.4f (%.4f), c_eta %.4f +- %.4f (%.4f), x_lam %.4f +- %.4f (%.4f), c_lam %.4f +- %.4f (%.4f)\n",
                d, mc.x_eta.mean, mc.x_eta.err, ve.x, mc.c_eta.mean, mc.c_eta.err, ve.c, mc.x_lam.mean, mc.x_lam.err, ce.x,
                mc.c_lam.mean, mc.c_lam.err, ce.c);
    EXPECT_NEAR(mc.x_eta.mean, ve.x, 5.0 * mc.x_eta.err) << d;
    EXPECT_NEAR(mc.c_eta.mean, ve.c, 5.0 * mc.c_eta.err) << d;
    EXPECT_NEAR(mc.x_lam.mean, ce.x, 5.0 * mc.x_lam.err) << d;
    EXPECT_NEAR(mc.c_lam.mean, ce.c, 5.0 * mc.c_lam.err) << d;
  }
}

TEST(EnskogTransport, ReducesToChapmanCowlingAndGass) {
  // 3D first Sonine (Chapman & Cowling ch. 16, b n = 4 phi):
  //   eta/eta0 = 1/chi + 0.8 bn + (4/25)(1 + 12/pi) (bn)^2 chi,
  //   lam/lam0 = 1/chi + 1.2 bn + (9/25)(1 + 32/(9 pi)) (bn)^2 chi,
  // eta0 = (5/16) sqrt(T/pi), lam0 = (75/64) sqrt(T/pi); 2D dilute (Gass 1971):
  // eta0 = sqrt(T/pi)/2, lam0 = 2 sqrt(T/pi).
  const double pi = std::numbers::pi, T = 2.3;
  EXPECT_NEAR(theory::dilute_viscosity(3, T), 5.0 / 16.0 * std::sqrt(T / pi), 1e-14);
  EXPECT_NEAR(theory::dilute_conductivity(3, T), 75.0 / 64.0 * std::sqrt(T / pi), 1e-14);
  EXPECT_NEAR(theory::dilute_viscosity(2, T), 0.5 * std::sqrt(T / pi), 1e-14);
  EXPECT_NEAR(theory::dilute_conductivity(2, T), 2.0 * std::sqrt(T / pi), 1e-14);
  for (double phi : {0.1, 0.3, 0.45}) {
    const double chi = theory::g_contact_sphere_cs(phi), bn = 4.0 * phi;
    const double eta = 1.0 / chi + 0.8 * bn + 4.0 / 25.0 * (1.0 + 12.0 / pi) * bn * bn * chi;
    const double lam = 1.0 / chi + 1.2 * bn + 9.0 / 25.0 * (1.0 + 32.0 / (9.0 * pi)) * bn * bn * chi;
    EXPECT_NEAR(theory::enskog_viscosity(3, phi, chi, T) / theory::dilute_viscosity(3, T), eta, 1e-12 * eta);
    EXPECT_NEAR(theory::enskog_conductivity(3, phi, chi, T) / theory::dilute_conductivity(3, T), lam, 1e-12 * lam);
  }
}

TEST(TransportForcing, ProfilesOfEquations34To36AtConstruction) {
  // tent: every pair leader (even id) gets |a| = a0 (1 - |y - L/2|/(L/2)) from its own
  // position; its partner the opposite vector
  Config c = config_from(kTent);
  const std::size_t N = static_cast<std::size_t>(c.particles);
  const InitialState init = make_initial_state(c, 3);
  Engine eng(make_setup(c, 3), init.positions, init.velocities);
  const double L = c.box().y, a0 = c.heating.acceleration;
  for (std::size_t i = 0; i + 1 < N; i += 2) {
    const double y = eng.position(i).y;
    EXPECT_NEAR(norm(eng.acceleration(i)), a0 * (1.0 - std::abs(y - 0.5 * L) / (0.5 * L)), 1e-12);
    EXPECT_NEAR(norm(eng.acceleration(i) + eng.acceleration(i + 1)), 0.0, 1e-15);
  }
  // shear: (a - a0 bias sin(2 pi y/L) e_x)/a0 standard Gaussian components (mean 0, var 1)
  Config s = config_from(kShear);
  Engine es(make_setup(s, 3), init.positions, init.velocities);
  std::vector<double> px, py, px2, py2;
  for (std::size_t i = 0; i + 1 < N; i += 2) {
    const Vec3 a = es.acceleration(i);
    const double y = es.position(i).y;
    const double bx = a.x / a0 - s.heating.bias * std::sin(2.0 * std::numbers::pi * y / L);
    px.push_back(bx), py.push_back(a.y / a0), px2.push_back(bx * bx), py2.push_back(a.y * a.y / (a0 * a0));
    EXPECT_EQ(a.z, 0.0);
  }
  for (const auto* v : {&px, &py}) {
    const MeanErr m = mean_err(*v);
    EXPECT_NEAR(m.mean, 0.0, 5.0 * m.err);
  }
  for (const auto* v : {&px2, &py2}) {
    const MeanErr m = mean_err(*v);
    EXPECT_NEAR(m.mean, 1.0, 5.0 * m.err);
  }
}

TEST(TransportBookkeeping, SlabBalancesCloseToRoundOff) {
  // tent forcing: storage = work + sink + flux in - flux out per slab (energy), and the same
  // for momentum along the axis; the slab sums give the engine's own counters.
  SmallRun run;
  run.c = config_from(kTent);
  run_small(run, 20.0, 20, 1.0, [](const Engine&) {});
  const TransportBlock tot = run.tr.total();
  const auto f = transport_fields(run.tr, tot);
  auto get = [&](const std::string& n) -> const std::vector<double>& {
    for (const auto& x : f)
      if (x.name == n) return x.mean;
    throw std::out_of_range(n);
  };
  double wmax = 0.0, work = 0.0, sink = 0.0, imp = 0.0;
  for (int k = 0; k < 16; ++k) {
    wmax = std::max(wmax, std::abs(get("work_rate")[k]));
    work += tot.slab[k * SlabTransport::kSlab + 0];
    sink += tot.slab[k * SlabTransport::kSlab + 2];
    imp += tot.slab[k * SlabTransport::kSlab + 19];
  }
  for (int k = 0; k < 16; ++k) {
    EXPECT_LT(std::abs(get("energy_residual")[k]), 1e-9 * wmax) << k;
    EXPECT_LT(std::abs(get("momentum_residual_z")[k]), 1e-9 * wmax) << k;
    EXPECT_LT(std::abs(get("momentum_residual")[k]), 1e-9 * wmax) << k;
  }
  EXPECT_NEAR(work, run.heating_energy[1] - run.heating_energy[0], 1e-9 * std::abs(work));
  EXPECT_NEAR(sink, -(run.energy_lost[1] - run.energy_lost[0]), 1e-9 * std::abs(sink));
  EXPECT_NEAR(imp, 0.0, 1e-9 * std::abs(work));  // paired opposite accelerations: zero net force
  // the energy flux integrated from plane 0 equals the measured flux at every plane
  for (int k = 0; k < 16; ++k)
    EXPECT_NEAR(get("energy_flux_balance")[k], get("energy_flux")[k], 1e-9 * wmax * run.c.box().y) << k;
  // the forcing heats the middle: energy flows away from z = L/2 (positive above, negative below)
  EXPECT_GT(get("energy_flux")[12], 0.0);
  EXPECT_LT(get("energy_flux")[4], 0.0);
}

TEST(TransportBookkeeping, ShearMomentumBalanceAndBodyForce) {
  // shear forcing: P_xy divergence = body force per slab exactly; the body force equals a
  // snapshot estimate of Sum_{i in slab} a_x,i (time average of the instantaneous force)
  SmallRun run;
  run.c = config_from(kShear);
  const int S = 16;
  std::vector<std::vector<double>> force(S);  // per slab, per sample
  std::vector<std::vector<double>> power(S);
  const std::size_t N = static_cast<std::size_t>(run.c.particles);
  const double L = run.c.box().y, w = L / S;
  run_small(run, 20.0, 200, 0.25, [&](const Engine& eng) {
    std::vector<double> fs(S, 0.0), ps(S, 0.0);
    for (std::size_t i = 0; i < N; ++i) {
      double y = eng.position(i).y;
      y -= L * std::floor(y / L);
      const int k = std::min(S - 1, static_cast<int>(y / w));
      fs[k] += eng.acceleration(i).x;
      ps[k] += dot(eng.acceleration(i), eng.velocity(i));
    }
    for (int k = 0; k < S; ++k) force[k].push_back(fs[k]), power[k].push_back(ps[k]);
  });
  const TransportResult r = transport_result(run.tr);
  const auto& mr = r.field("momentum_residual").mean;
  const auto& fd = r.field("forcing_density");
  const auto& wr = r.field("work_rate");
  double fmax = 0.0;
  for (int k = 0; k < S; ++k) fmax = std::max(fmax, std::abs(fd.mean[k]));
  const double V = w * run.c.box().x;
  int sig_force = 0;
  for (int k = 0; k < S; ++k) {
    EXPECT_LT(std::abs(mr[k]), 1e-9 * fmax) << k;
    // snapshot estimators (batch means over 10 batches of 20 samples)
    auto batch = [&](const std::vector<double>& x) {
      std::vector<double> b;
      for (std::size_t s = 0; s + 20 <= x.size(); s += 20) {
        double m = 0.0;
        for (std::size_t q = s; q < s + 20; ++q) m += x[q];
        b.push_back(m / 20.0 / V);
      }
      return mean_err(b);
    };
    const MeanErr fsnap = batch(force[k]), psnap = batch(power[k]);
    const double ef = std::hypot(fsnap.err, fd.stderr_[k]), ep = std::hypot(psnap.err, wr.stderr_[k]);
    EXPECT_NEAR(fd.mean[k], fsnap.mean, 5.0 * ef) << k;
    EXPECT_NEAR(wr.mean[k], psnap.mean, 5.0 * ep) << k;
    if (std::abs(fd.mean[k]) > 3.0 * fd.stderr_[k]) ++sig_force;
  }
  // the shear stress two ways: the slab's volume average (kinetic part + collisional virial
  // split along the segments) against the mean of its two faces' momentum flux (crossings +
  // collisional transfer through the planes). Both see the same trajectories, so their
  // jackknife errors (about 15 % of the amplitude per slab) say nothing about their
  // difference: compare the forced mode cos(2 pi y/L) of the two profiles instead. The face
  // mean of a cos profile exceeds the slab average by 1 - sin(x)/x, x = pi/16: 0.6 %.
  const auto& Ps = r.field("P_cz_slab");
  const auto& Pp = r.field("P_cz");
  double mode_slab = 0.0, mode_face = 0.0;
  for (int k = 0; k < S; ++k) {
    const double c = std::cos(2.0 * std::numbers::pi * (k + 0.5) / S);
    mode_slab += Ps.mean[k] * c;
    mode_face += 0.5 * (Pp.mean[k] + Pp.mean[(k + 1) % S]) * c;
  }
  std::printf("forced mode of P_xy: slab volume average %.5g, plane faces %.5g\n", mode_slab, mode_face);
  EXPECT_GT(std::abs(mode_face), 0.0);
  // measured 1.024 (the two differ by the storage term over a finite run); dropping the
  // kinetic part gives 0.77, 80 % of the collisional virial 0.87 (mutations checked)
  EXPECT_NEAR(mode_slab / mode_face, 1.0, 0.04);
  // the bias is resolved: the body force follows sin(2 pi y/L) (positive in the lower half)
  EXPECT_GT(fd.mean[4], 0.0);
  EXPECT_LT(fd.mean[12], 0.0);
  EXPECT_GE(sig_force, 4);
}

TEST(TransportBookkeeping, PlaneFluxesAgreeWithTheSlabProfiles) {
  // two independent code paths for the same fluxes: plane crossings + collisional transfer
  // through planes (SlabTransport) against snapshot moments + Irving-Kirkwood segments
  // averaged over each slab (SlabProfiles). The slab average of a plane flux is the mean of
  // its two faces up to the curvature of the profile (O(w^2) relative, w = L/16 here).
  SmallRun run;
  run.c = config_from(kTent);
  SlabProfiles prof;
  prof.init({2, run.c.box(), 1, 16, true});
  run_small(run, 20.0, 300, 0.2, [](const Engine&) {}, &prof);
  const TransportResult t = transport_result(run.tr);
  const ProfileResult p = prof.result();
  const auto& F = t.field("energy_flux");
  const auto& Pz = t.field("P_zz");
  const auto& T = t.field("T");
  for (int k = 0; k < 16; ++k) {
    const int kp = (k + 1) % 16;
    const double f = 0.5 * (F.mean[k] + F.mean[kp]);
    const double ef = std::hypot(0.5 * std::hypot(F.stderr_[k], F.stderr_[kp]), p.field("q_y").stderr_[k]);
    EXPECT_NEAR(f, p.field("q_y").mean[k], 5.0 * ef + 0.05 * std::abs(f)) << k;
    const double pz = 0.5 * (Pz.mean[k] + Pz.mean[kp]);
    EXPECT_NEAR(pz, p.field("P_yy").mean[k], 5.0 * std::hypot(Pz.stderr_[k], p.field("P_yy").stderr_[k]) + 0.01 * pz) << k;
    // time average (exact, trajectories) vs snapshot average of the temperature
    EXPECT_NEAR(T.mean[k], p.field("T").mean[k], 5.0 * std::hypot(T.stderr_[k], p.field("T").stderr_[k])) << k;
    // volume-averaged pressure tensor of the slab (time-integrated kinetic part + collisional
    // virial split along the segments) against the profiles' snapshot kinetic part + their
    // own Irving-Kirkwood segments: component c = x, axis z = y
    for (const auto& [mine, theirs] : {std::pair{"P_cc_slab", "P_xx"}, {"P_zz_slab", "P_yy"}, {"P_cz_slab", "P_xy"}}) {
      const auto& a = t.field(mine);
      const auto& b = p.field(theirs);
      EXPECT_NEAR(a.mean[k], b.mean[k], 5.0 * std::hypot(a.stderr_[k], b.stderr_[k]) + 0.01 * std::abs(pz))
          << mine << " slab " << k;
    }
  }
  // box averages: the two estimators differ by time vs snapshot averaging of the kinetic
  // part only, which averages out over the slabs (measured 0.1-0.2 %); a 5 % error in the
  // collisional virial moves them by about 3.5 % (checked by mutation)
  for (const auto& [mine, theirs] : {std::pair{"P_cc_slab", "P_xx"}, {"P_zz_slab", "P_yy"}}) {
    double sa = 0.0, sb = 0.0;
    for (int k = 0; k < 16; ++k) sa += t.field(mine).mean[k], sb += p.field(theirs).mean[k];
    std::printf("box average %s %.6g, profiles %s %.6g\n", mine, sa / 16, theirs, sb / 16);
    EXPECT_NEAR(sa, sb, 0.01 * std::abs(sb)) << mine;
  }
  // the box average of P_zz from the slabs' virial equals the planes' mean momentum flux
  // (two measurements of one mean; they differ by the storage term over the run only)
  double sz = 0.0, sp = 0.0, ez = 0.0;
  const auto& Ps = t.field("P_zz_slab");
  for (int k = 0; k < 16; ++k) sz += Ps.mean[k] / 16, sp += Pz.mean[k] / 16, ez = std::max(ez, Ps.stderr_[k]);
  EXPECT_NEAR(sz, sp, 0.01 * sp + 3.0 * ez);
}

TEST(TransportForcing, PowerMatchesTheRedrawClosedForm) {
  // Closed form of the air-table power: a grain's acceleration a is redrawn (direction
  // independent of its velocity) as a Poisson process of rate lambda per grain, so
  // E[a.v] = |a|^2 E[age] = |a|^2 / lambda when collisions rarely intervene between redraws
  // (correction O(omega/lambda), here ~1 %). Sum |a_i|^2 from snapshots; the work from the
  // slab bookkeeping. Tolerance: 5 sigma of the batch means + 2 % model error.
  SmallRun run;
  run.c = config_from(air_table_case(400, 0.1, 0.05, 0.5, "profile = \"tent\"\n"));
  run.c.heating.rate = 100;
  std::vector<double> a2;
  const std::size_t N = static_cast<std::size_t>(run.c.particles);
  run_small(run, 5.0, 200, 0.1, [&](const Engine& eng) {
    double s = 0.0;
    for (std::size_t i = 0; i < N; ++i) s += norm2(eng.acceleration(i));
    a2.push_back(s);
  });
  // power per block of sampling intervals (batch means)
  std::vector<double> pb;
  for (const auto& b : run.tr.blocks()) {
    double w = 0.0;
    for (int k = 0; k < 16; ++k) w += b.slab[k * SlabTransport::kSlab + 0];
    pb.push_back(w / b.time);
  }
  const MeanErr P = mean_err(pb);
  // redraws happen at collision instants: a grain is touched at a given instant when one of
  // the `rate` picks is it or its partner (probability 2/N each), several picks count once
  const double touched = 1.0 - std::pow(1.0 - 2.0 / N, run.c.heating.rate);
  const double lambda = touched * (run.collisions[1] - run.collisions[0]) / (run.time[1] - run.time[0]);
  const MeanErr A2 = mean_err(a2);  // successive snapshots are 0.1 collision apart: nearly independent redraws
  const double closed = A2.mean / lambda;
  std::printf("power %.5g +- %.2g, Sum|a|^2/lambda %.5g +- %.2g (lambda %.4g per grain and time)\n", P.mean, P.err, closed,
              A2.err / lambda, lambda);
  EXPECT_NEAR(P.mean / closed, 1.0, 0.02 + 5.0 * std::hypot(A2.err / A2.mean, P.err / P.mean));
}

namespace {
// Two transport bookkeepings on one engine: both see every free flight and collision.
struct MoveHookPair {
  SlabTransport* a;
  SlabTransport* b;
  static void call(void* self, std::uint32_t id, const Vec3& r0, const Vec3& v0, const Vec3& r1, const Vec3& v1,
                   const Vec3& acc, double dt) {
    auto* p = static_cast<MoveHookPair*>(self);
    p->a->add_move(id, r0, v0, r1, v1, acc, dt);
    p->b->add_move(id, r0, v0, r1, v1, acc, dt);
  }
};
// The forced-mode viscosity -(Sum_k P_k cos kz_k)/(Sum_k (du/dz)_k cos kz_k) of one summed
// block (what transport_scalars reports as mu_mode).
double mu_mode_of(const SlabTransport& t, const TransportBlock& b) {
  const auto f = transport_fields(t, b);
  const std::vector<double>* P = nullptr;
  const std::vector<double>* du = nullptr;
  for (const auto& x : f) {
    if (x.name == "P_cz") P = &x.mean;
    if (x.name == "dudz") du = &x.mean;
  }
  const int S = t.setup().slabs;
  double Pc = 0.0, Gc = 0.0;
  for (int k = 0; k < S; ++k) {
    const double c = std::cos(2.0 * std::numbers::pi * k / S);
    Pc += (*P)[k] * c, Gc += (*du)[k] * c;
  }
  return -Pc / Gc;
}
TransportBlock without(const TransportBlock& tot, const TransportBlock& b) {
  TransportBlock m = tot;
  m.time -= b.time;
  for (std::size_t q = 0; q < m.slab.size(); ++q) m.slab[q] -= b.slab[q];
  for (std::size_t q = 0; q < m.plane.size(); ++q) m.plane[q] -= b.plane[q];
  return m;
}
}  // namespace

TEST(TransportViscosity, ForcedModeDoesNotDependOnTheSlabCount) {
  // One trajectory booked through 8 and through 32 slabs at once. P_cz is exact at each plane
  // (the 8 planes are every 4th of the 32), so an unbiased du/dz gives the same forced-mode mu.
  // The difference of adjacent slab means of u = U sin kz over w is U k cos(kz) sinc^2(pi/S)
  // (docs/edmd.md "Transport coefficients"); uncorrected, mu_8/mu_32 = sinc^2(pi/32)/sinc^2(pi/8)
  // = 1.0496. Tolerance: 5 jackknife standard errors of the ratio over the blocks (same
  // blocks for both: the errors are correlated, so the ratio's own error is the one to use).
  // Measured (400 disks, 512 intervals of about one collision per grain, 8 s): 0.9930 +- 0.0040;
  // with the uncorrected du/dz of before 1.0423 +- 0.0042 (fails).
  const Config c = config_from(kShear);
  const std::size_t N = static_cast<std::size_t>(c.particles);
  const InitialState init = make_initial_state(c, 3);
  Engine eng(make_setup(c, 3), init.positions, init.velocities);
  const auto law = std::get<BizonRestitution>(c.restitution);
  eng.advance(law, kInf, static_cast<std::uint64_t>(50.0 * N));
  eng.synchronize();
  const double dt = 1.0 * N / (2.0 * eng.counters().collisions / eng.time()) * 2.0;  // about 1 collision per grain
  SlabTransport t8, t32;
  t8.init({2, c.box(), c.heating.profile_axis, c.heating.bias_component, 8}, N);
  t32.init({2, c.box(), c.heating.profile_axis, c.heating.bias_component, 32}, N);
  std::vector<Vec3> x(N), v(N);
  for (std::size_t i = 0; i < N; ++i) x[i] = eng.position(i), v[i] = eng.velocity(i);
  t8.begin(x, v);
  t32.begin(x, v);
  MoveHookPair moves{&t8, &t32};
  CollisionHookPair colls{&SlabTransport::collision_hook, &t8, &SlabTransport::collision_hook, &t32};
  eng.set_move_hook(&MoveHookPair::call, &moves);
  eng.set_collision_hook(&CollisionHookPair::call, &colls);
  double t_prev = eng.time();
  for (int s = 0; s < 512; ++s) {
    eng.advance(law, t_prev + dt, UINT64_MAX);
    eng.synchronize();
    for (std::size_t i = 0; i < N; ++i) v[i] = eng.velocity(i);
    t8.end_interval(eng.time() - t_prev, v);
    t32.end_interval(eng.time() - t_prev, v);
    t_prev = eng.time();
  }
  const auto& b8 = t8.blocks();
  const auto& b32 = t32.blocks();
  ASSERT_EQ(b8.size(), b32.size());
  ASSERT_GE(b8.size(), 16u);
  const TransportBlock tot8 = t8.total(), tot32 = t32.total();
  const double ratio = mu_mode_of(t8, tot8) / mu_mode_of(t32, tot32);
  std::vector<double> loo;
  for (std::size_t q = 0; q < b8.size(); ++q)
    loo.push_back(mu_mode_of(t8, without(tot8, b8[q])) / mu_mode_of(t32, without(tot32, b32[q])));
  const double B = static_cast<double>(loo.size());
  double avg = 0.0, ss = 0.0;
  for (double l : loo) avg += l / B;
  for (double l : loo) ss += (l - avg) * (l - avg);
  const double err = std::sqrt((B - 1.0) / B * ss);
  // the test's projection is the summary's mu_mode
  double mu32 = 0.0, mu32_fit = 0.0, mu8_fit = 0.0;
  TransportAnalysis an;
  an.kind = TransportAnalysis::viscosity;
  for (const auto& sc : transport_scalars(t32, an)) {
    if (sc.name == "mu_mode") mu32 = sc.value;
    if (sc.name == "mu") mu32_fit = sc.value;
  }
  for (const auto& sc : transport_scalars(t8, an))
    if (sc.name == "mu") mu8_fit = sc.value;
  EXPECT_NEAR(mu32, mu_mode_of(t32, tot32), 1e-12 * std::abs(mu32));
  std::printf("mu_mode: S = 32 %.5g, S = 8 / S = 32 = %.5f +- %.5f (uncorrected would be 1.0496); slope fit ratio %.5f\n",
              mu32, ratio, err, mu8_fit / mu32_fit);
  EXPECT_GT(err, 0.0);
  EXPECT_NEAR(ratio, 1.0, 5.0 * err);
}

namespace {
// A block of slab sums holding exactly the slab averages of n(z) and of e(z) = n(z) T(z)
// (composite Simpson, 400 panels per slab: 1e-13 relative) with no mean flow, and at each
// plane the energy flux -kappa_Enskog(nu(z_p), T(z_p)) T'(z_p) of a fluid obeying Enskog
// exactly: the analysis must return kappa_ratio = 1 if it evaluates T, T' and nu at the plane.
// Profile of cases/bizon-conductivity/nu0.5-a30 (fitted to its slabs: T_max/T_min = 80,
// packing 0.84 at the cold face, 0.23 at the forcing peak), c(z) = (1 + cos(2 pi (z - L/2)/L))/2:
//   T = T_min exp(a c), n = n_face exp(-b c), a = ln 80, b = ln(0.84/0.23).
struct ConductivityProfile {
  double L = 52.6, T_min = 0.15, a = std::log(80.0), n_face = 0.84 * 4.0 / std::numbers::pi, b = std::log(0.84 / 0.23);
  double c(double z) const { return 0.5 * (1.0 + std::cos(2.0 * std::numbers::pi * (z - 0.5 * L) / L)); }
  double dc(double z) const { return -std::numbers::pi / L * std::sin(2.0 * std::numbers::pi * (z - 0.5 * L) / L); }
  double T(double z) const { return T_min * std::exp(a * c(z)); }
  double dT(double z) const { return a * dc(z) * T(z); }
  double n(double z) const { return n_face * std::exp(-b * c(z)); }
};
struct ConductivityCheck {
  double T_rel = 0, dT_rel = 0, nu_abs = 0, ratio_fit_mean = 0, ratio_plane = 0;  // largest errors
};
ConductivityCheck check_profile(const ConductivityProfile& p, int S) {
  SlabTransport t;
  t.init({2, Vec3{p.L, p.L, 1.0}, 1, 0, S}, 1);
  const double w = t.slab_width(), A = t.cross_section(), V = A * w;
  TransportBlock b{1.0, std::vector<double>(S * SlabTransport::kSlab, 0.0), std::vector<double>(S * SlabTransport::kPlane, 0.0)};
  for (int k = 0; k < S; ++k) {
    const int m = 400;
    double sn = 0.0, se = 0.0;
    for (int i = 0; i <= m; ++i) {
      const double z = k * w + w * i / m, wt = (i == 0 || i == m) ? 1.0 : (i % 2 ? 4.0 : 2.0);
      sn += wt * p.n(z), se += wt * p.n(z) * p.T(z);
    }
    const double nbar = sn / (3.0 * m), ebar = se / (3.0 * m);
    double* s = &b.slab[static_cast<std::size_t>(k) * SlabTransport::kSlab];
    s[3] = nbar * V;                     // Int N dt over time 1
    s[7] = s[11] = ebar * V;             // Int Sum v_x^2 dt = Int Sum v_y^2 dt: T_k = ebar / nbar
    const double z = k * w, nu = p.n(z) * std::numbers::pi / 4.0;
    const double F = -theory::enskog_conductivity(2, nu, theory::g_contact_disk_cs(nu), p.T(z)) * p.dT(z);
    b.plane[static_cast<std::size_t>(k) * SlabTransport::kPlane] = F * A;  // kinetic flux through plane k
  }
  const auto f = transport_fields(t, b);
  auto get = [&](const char* name) {
    for (const auto& x : f)
      if (x.name == name) return x.mean;
    throw std::logic_error(name);
  };
  const auto Tp = get("T_plane"), g = get("dTdz"), pp = get("packing_plane"), kr = get("kappa_ratio");
  ConductivityCheck r;
  double dTmax = 0.0, sum = 0.0, m = 0.0;
  for (int k = 0; k < S; ++k) dTmax = std::max(dTmax, std::abs(p.dT(k * w)));
  for (int k = 0; k < S; ++k) {
    const double z = k * w;
    r.T_rel = std::max(r.T_rel, std::abs(Tp[k] / p.T(z) - 1.0));
    r.dT_rel = std::max(r.dT_rel, std::abs(g[k] - p.dT(z)) / dTmax);
    r.nu_abs = std::max(r.nu_abs, std::abs(pp[k] - p.n(z) * std::numbers::pi / 4.0));
    const double d = std::abs(z - 0.5 * p.L) / (0.5 * p.L);
    if (d < 0.2 || d > 0.8) continue;  // the summary's default fit planes
    sum += kr[k], m += 1.0;
    r.ratio_plane = std::max(r.ratio_plane, std::abs(kr[k] - 1.0));
  }
  r.ratio_fit_mean = std::abs(sum / m - 1.0);
  return r;
}
}  // namespace

TEST(TransportConductivity, PlaneValuesFromSlabAveragesOfARealisticProfile) {
  // T_plane, dTdz and packing_plane are point values at the plane, reconstructed from the
  // slab averages of n and e = n T (docs/edmd.md "Transport coefficients"). Reference: the
  // profile's own values at the planes (closed form) and cell averages by quadrature, not the
  // stencils. Largest errors at S = 32, computed independently (numpy, Gauss-Legendre;
  // cases/bizon-conductivity/gradient_bias.py's estimators) for this profile:
  //   four-slab stencils: T 4.2e-4, T' 4.2e-4 of max|T'|, nu 7.7e-5, kappa_ratio over the
  //   fit planes 1.9e-4 (mean), 5.1e-4 (one plane);
  //   two-slab means of before: 2.8e-2, 1.4e-2, 3.5e-3, 1.7e-2, 2.8e-2 (fail every bound).
  // Bounds: 2.5x the fourth-order values. Halving w must cut the errors by ~16 (O(w^4)).
  const ConductivityProfile p;
  const ConductivityCheck c32 = check_profile(p, 32), c64 = check_profile(p, 64);
  std::printf("S = 32: T %.2e, dT %.2e, nu %.2e, kappa_ratio fit mean %.2e, plane %.2e; S = 64: T %.2e, dT %.2e\n",
              c32.T_rel, c32.dT_rel, c32.nu_abs, c32.ratio_fit_mean, c32.ratio_plane, c64.T_rel, c64.dT_rel);
  EXPECT_LT(c32.T_rel, 1.05e-3);
  EXPECT_LT(c32.dT_rel, 1.05e-3);
  EXPECT_LT(c32.nu_abs, 2e-4);
  EXPECT_LT(c32.ratio_fit_mean, 5e-4);
  EXPECT_LT(c32.ratio_plane, 1.3e-3);
  EXPECT_GT(c32.T_rel / c64.T_rel, 12.0);
  EXPECT_GT(c32.dT_rel / c64.dT_rel, 12.0);
}

// Where the four-slab stencil has nothing to work with (an empty slab in it, or outer slabs so
// much denser than the inner two that its n is not positive), a plane keeps the two-slab
// forms: finite wherever its own two slabs are occupied, not NaN or a negative density.
TEST(TransportConductivity, PlanesBesideAnEmptySlabKeepTheTwoSlabForms) {
  const int S = 12;
  SlabTransport t;
  t.init({2, Vec3{24.0, 24.0, 1.0}, 1, 0, S}, 1);
  const double w = t.slab_width(), V = t.cross_section() * w;
  TransportBlock b{1.0, std::vector<double>(S * SlabTransport::kSlab, 0.0), std::vector<double>(S * SlabTransport::kPlane, 0.0)};
  std::vector<double> n(S), T(S);
  for (int k = 0; k < S; ++k) n[k] = 0.3 + 0.02 * k, T[k] = 1.0 + 0.1 * k;
  n[6] = 0.0;   // slab 6 empty: planes 5 and 8 have it as an outer slab
  n[2] = 4.0;   // plane 4's stencil: 7 (n3 + n4) - (n5 + n2) < 0
  n[3] = n[4] = 0.01;
  for (int k = 0; k < S; ++k) {
    double* s = &b.slab[static_cast<std::size_t>(k) * SlabTransport::kSlab];
    s[3] = n[k] * V;
    s[7] = s[11] = n[k] * T[k] * V;
    b.plane[static_cast<std::size_t>(k) * SlabTransport::kPlane] = -1.0;
  }
  const auto f = transport_fields(t, b);
  auto get = [&](const char* name) {
    for (const auto& x : f)
      if (x.name == name) return x.mean;
    throw std::logic_error(name);
  };
  const auto Tp = get("T_plane"), g = get("dTdz"), pp = get("packing_plane");
  for (int k : {5, 8, 4}) {  // 5, 8: the empty slab is outer; 4: the stencil's n < 0
    const int km = k - 1;
    EXPECT_NEAR(Tp[k], 0.5 * (T[k] + T[km]), 1e-12) << k;
    EXPECT_NEAR(g[k], (T[k] - T[km]) / w, 1e-12) << k;
    EXPECT_TRUE(std::isfinite(pp[k]) && pp[k] > 0.0) << k;
  }
  for (int k : {10, 11}) {  // four occupied, smooth slabs: the stencil
    const auto st = [&](const std::vector<double>& a) {
      return (7.0 * (a[k] + a[k - 1]) - (a[(k + 1) % S] + a[k - 2])) / 12.0;
    };
    std::vector<double> e(S);
    for (int j = 0; j < S; ++j) e[j] = n[j] * T[j];
    EXPECT_NEAR(Tp[k], st(e) / st(n), 1e-12) << k;
  }
}
