// Physics checks through the driver (read_config + run), fixed seeds, short runs.
// Tolerances: several standard errors measured by the run itself, plus the reference
// EOS's own accuracy (KR fit / CS: a few 0.1 % in this range).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <random>
#include <utility>

#include "core/case_file.hpp"
#include "core/h5.hpp"
#include "core/run_support.hpp"
#include "core/summary.hpp"
#include "edmd/background2d.hpp"
#include "edmd/edmd.hpp"
#include "tests/edmd/config_support.hpp"
#include "tests/edmd/gr_support.hpp"
#include "edmd/measure.hpp"
#include "edmd/theory.hpp"
#include "operators/random.hpp"

using namespace grainbath;
using namespace grainbath::edmd;

namespace {
Summary run_case(const std::string& toml, std::uint64_t seed = 1) {
  return grainbath::edmd::testing::run_summary(toml, seed, "edmd_test");
}
}  // namespace

struct EosPoint {
  int dims;
  double packing;
  int particles;
};

class EdmdEos : public ::testing::TestWithParam<EosPoint> {};

TEST_P(EdmdEos, ElasticCompressibilityMatchesReference) {
  const auto p = GetParam();
  const std::string toml = "[edmd]\ndimensions = " + std::to_string(p.dims) + "\nparticles = " +
                           std::to_string(p.particles) + "\npacking_fraction = " + std::to_string(p.packing) +
                           "\nequilibrate = 30\ncollisions = 150\n[sampling]\ninterval = 0.5\n";
  const Summary s = run_case(toml, 2);
  const double z = s.number("pressure.Z"), err = s.number("pressure.Z_stderr");
  const double ref = theory::z_reference(p.dims, p.packing);
  EXPECT_GT(err, 0.0);
  EXPECT_LT(err / z, 0.01);
  // 5 sigma plus the reference's own accuracy
  EXPECT_NEAR(z, ref, 5.0 * err + 0.004 * ref) << "dims " << p.dims << " packing " << p.packing;
  EXPECT_NEAR(s.number("temperature.mean"), 1.0, 1e-9);
  EXPECT_NEAR(s.number("conservation.relative_energy_change_elastic"), 0.0, 1e-11);
  EXPECT_GE(s.number("overlap.min_distance"), 1.0 - 1e-9);
}

// g(sigma+) from the histogram: exact for a quadratic g(r) given as the bins' shell averages,
// at any bin width, also with a bin straddling sigma (g = 0 inside the core). The straight
// line through the bin centres used before gives 5.449 instead of 5.7 here (2D, 0.02 bins),
// a quadratic through the centres 5.704 (the bin average of a curved g is not its centre value).
TEST(EdmdContactFit, RecoversAQuadraticFromItsBinAverages) {
  auto g = [](double r) { return r < 1.0 ? 0.0 : 5.7 - 40.0 * (r - 1.0) + 150.0 * (r - 1.0) * (r - 1.0); };
  for (int dims : {2, 3})
    for (double bin : {0.02, 0.03}) {
      // exact bin averages (tests/edmd/gr_support.hpp: Simpson's rule, independent of the
      // fit's closed form)
      const PairStatistics p = grainbath::edmd::testing::pair_statistics_of(g, dims, bin);
      EXPECT_NEAR(p.contact_value(), 5.7, 1e-9) << dims << " " << bin;
    }
}

// The fit on simulated hard disks at nu = 0.65, where g(r) is most curved at contact, against
// g(sigma+) from the virial pressure (Bizon eq. 24: Z = 1 + 2 nu g in 2D, elastic) of the same
// runs. Six seeds; tolerance 5 standard errors of the mean of the six ratios. Measured
// 0.9962 +- 0.0030; the straight line of before gave 0.9680 +- 0.0022 here (fails).
TEST(EdmdContactFit, MatchesTheVirialContactValueAtHighDensity) {
  const std::string toml =
      "[edmd]\ndimensions = 2\nparticles = 1024\npacking_fraction = 0.65\nequilibrate = 100\ncollisions = 300\n"
      "[sampling]\ninterval = 1.0\n";
  std::vector<double> ratio;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const Summary s = run_case(toml, seed);
    ratio.push_back(s.number("g_r.contact_fit") / s.number("pressure.g_contact"));
  }
  const auto [m, se] = grainbath::edmd::testing::mean_se(ratio);
  std::printf("g_r.contact_fit / pressure.g_contact at nu = 0.65: %.5f +- %.5f (6 seeds)\n", m, se);
  EXPECT_GT(se, 0.0);
  EXPECT_NEAR(m, 1.0, 5.0 * se);
}

// g(sigma+) from the collisions (contact_from_collisions) on normal-speed histograms whose
// answer is known: the flux-weighted Gaussian of molecular chaos at T, P_c(u) = (u/2T)
// e^(-u^2/4T), filled with its exact bin probabilities, with the Enskog rate of a given g. With
// e = 1 the approaching and receding pairs each hold g/2; with a constant e the receding ones
// hold g/(2e); with Bizon's e(u) g/2 <1/e>, <1/e> over the Gaussian by Simpson's rule. The
// midpoint sums over 0.02 sqrt(T) bins are within 1e-4 of these.
TEST(EdmdContactFromCollisions, ExactForKnownContactSpeedDistributions) {
  const double T = 1.3, g = 3.1, pair_density = 0.6, w = 0.02 * std::sqrt(T);
  std::vector<std::uint64_t> hist(600);
  std::uint64_t total = 0;
  for (std::size_t b = 0; b < hist.size(); ++b) {
    const double a = b * w, c = a + w;  // CDF of P_c: 1 - exp(-u^2/4T)
    hist[b] = static_cast<std::uint64_t>(std::llround(1e13 * (std::exp(-a * a / (4 * T)) - std::exp(-c * c / (4 * T)))));
    total += hist[b];
  }
  const BizonRestitution bizon{0.7, 1.0};
  // <1/e> over the Gaussian density of approaching speeds, (1/sqrt(pi T)) e^(-u^2/4T), u > 0
  double inv_e = 0.0;
  const int M = 200000;
  const double umax = 40.0 * std::sqrt(T), du = umax / M;
  for (int q = 0; q <= M; ++q) {
    const double u = q * du, wq = q == 0 || q == M ? 1.0 : q % 2 ? 4.0 : 2.0;
    inv_e += wq * std::exp(-u * u / (4 * T)) / std::sqrt(std::numbers::pi * T) / restitution(bizon, u).e;
  }
  inv_e *= du / 3.0;
  for (int dims : {2, 3}) {
    const double omega = (dims == 2 ? 2.0 : 4.0) * pair_density * g * std::sqrt(std::numbers::pi * T);  // Enskog
    const auto elastic = contact_from_collisions(dims, pair_density, omega, hist, w, total, [](double) { return 1.0; });
    EXPECT_NEAR(elastic.inverse_speed / (0.5 * std::sqrt(std::numbers::pi / T)), 1.0, 1e-4);
    EXPECT_NEAR(elastic.g_approaching / (0.5 * g), 1.0, 1e-4) << dims;
    EXPECT_NEAR(elastic.g / g, 1.0, 1e-4) << dims;
    const auto constant = contact_from_collisions(dims, pair_density, omega, hist, w, total, [](double) { return 0.6; });
    EXPECT_NEAR(constant.g_receding / (0.5 * g / 0.6), 1.0, 1e-4) << dims;
    EXPECT_NEAR(constant.g / (0.5 * g * (1.0 + 1.0 / 0.6)), 1.0, 1e-4) << dims;
    const auto b = contact_from_collisions(dims, pair_density, omega, hist, w, total,
                                           [&](double u) { return restitution(bizon, u).e; });
    EXPECT_NEAR(b.g_receding / (0.5 * g * inv_e), 1.0, 1e-4) << dims << " <1/e> = " << inv_e;
    // a constant e = 0.6 law of which the TC guard made a quarter of the collisions (at every
    // speed) elastic: Counters::guard_receding = Sum over those of (1 - 1/0.6)/u
    double correction = 0.0;
    for (std::size_t k = 0; k < hist.size(); ++k)
      correction += 0.25 * static_cast<double>(hist[k]) * (1.0 - 1.0 / 0.6) / ((k + 0.5) * w);
    const auto guarded = contact_from_collisions(dims, pair_density, omega, hist, w, total,
                                                 [](double) { return 0.6; }, correction);
    EXPECT_NEAR(guarded.g_receding / (0.5 * g * (0.75 / 0.6 + 0.25)), 1.0, 1e-4) << dims;
  }
}

// Elastic disks: the collisions' g(sigma+) is the virial one (both exact in the same box).
// 1024 disks, nu = 0.5, 4 seeds x 300 collisions per grain; tolerance 5 standard errors of the
// mean ratio. Measured 1764 disks, 6 seeds x 1000: pressure.g_contact / it = 1.0009 +- 0.0005.
TEST(EdmdContactFromCollisions, EqualsTheVirialContactValueForElasticDisks) {
  const std::string toml =
      "[edmd]\ndimensions = 2\nparticles = 1024\npacking_fraction = 0.5\nequilibrate = 100\ncollisions = 300\n"
      "[sampling]\ninterval = 1.0\n";
  std::vector<double> ratio;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const Summary s = run_case(toml, seed);
    ratio.push_back(s.number("g_r.contact_from_collisions") / s.number("pressure.g_contact"));
    EXPECT_NEAR(s.number("collision.receding_excess"), 1.0, 1e-12);
  }
  const auto [m, se] = grainbath::edmd::testing::mean_se(ratio);
  std::printf("g_r.contact_from_collisions / pressure.g_contact, elastic nu = 0.5: %.5f +- %.5f\n", m, se);
  EXPECT_GT(se, 0.0);
  EXPECT_NEAR(m, 1.0, 5.0 * se);
}

// Driven inelastic disks (Bizon's Boltzmann bath, nu = 0.5, Bizon's e(u) with e_c = 0.7, the
// case cases/bizon-heat-baths/boltzmann): their g(r) falls from ~4.65 at contact to ~3.9 at
// 1.01 sigma, a layer the quadratic over [sigma, 1.1 sigma] (g_r.contact_fit) cannot follow:
// it reads 0.93 of g(sigma+). The collisions' g(sigma+) against a quadratic over
// [sigma, 1.01 sigma] of 0.002 sigma bins, 6 seeds x 500 collisions per grain, tolerance 5
// standard errors of the mean ratio. The old estimator (the quadratic over [sigma, 1.1
// sigma]) in place of that fit lies > 5 standard errors away (checked in the test).
// Measured (8 seeds x 1000, 1764 disks, cases/bizon-heat-baths/contact_check.py): quadratic
// over [sigma, 1.01 sigma] of 0.001 sigma bins / collisions 0.997 +- 0.006 (4 seeds); over
// [sigma, 1.1 sigma] 0.9335 +- 0.0011. This test measures 0.998 +- 0.008 and 0.933 +- 0.002
// (20 s on one core). Until 2026-12-06 it read 1.020 +- 0.007 and 0.941 +- 0.003: its snapshots
// were taken at collision counts, each with the just-collided pair at sigma (removing that
// pair from the same histograms gave 0.9995, a paired shift of +0.0207 +- 0.0007, seeds 1-6).
TEST(EdmdContactFromCollisions, MatchesTheContactLayerOfDrivenInelasticDisks) {
  const int N = 1764;
  const double nu = 0.5;
  CaseReader rd("[edmd]\ndimensions = 2\nparticles = 1764\npacking_fraction = 0.5\n"
                "[restitution]\nlaw = \"bizon\"\ne = 0.7\ncrossover = 1.0\n"
                "[heating]\nmodel = \"boltzmann\"\nrate = 4\ntemperature = 1.15\n",
                "t.toml");
  Config c = read_config(rd);
  rd.finish();
  const BizonRestitution law{0.7, 1.0};
  const double volume = N * std::numbers::pi / (4.0 * nu);
  std::vector<double> narrow, wide;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const auto init = make_initial_state(c, seed);
    Engine eng(make_setup(c, seed), init.positions, init.velocities);
    eng.advance(law, kInf, 100 * N);
    eng.counters() = Counters{};
    eng.counters().vn_histogram.assign(600, 0);
    eng.set_vn_bin_width(0.02);
    const double t0 = eng.time();
    // Snapshots at fixed times, never at a collision count: advance() stopped by a count
    // returns right after that collision, whose pair is then exactly at sigma, one pair too
    // many at contact per snapshot (+1.9 % on this fit, 0.002 sigma bins: the 1.020 of before).
    const double dt = 2.5 * t0 / 100.0;  // about 5N/2 collisions apart, from the equilibration's rate
    PairStatistics p;
    p.init(2, c.box(), {false, false, false}, 1.2, 0.002, 0.1);
    std::vector<Vec3> x(N), v(N);
    for (int s = 0; s < 200; ++s) {  // a snapshot every ~2.5 collisions per grain
      eng.advance(law, t0 + (s + 1) * dt, ~0ull);
      eng.synchronize();
      for (int i = 0; i < N; ++i) x[i] = eng.position(i), v[i] = eng.velocity(i);
      p.add(x, v, 1.0);
    }
    const Counters& f = eng.counters();
    const double omega = 2.0 * f.collisions / (N * (eng.time() - t0));
    const auto cc = contact_from_collisions(2, (N - 1.0) / volume, omega, f.vn_histogram, 0.02, f.collisions,
                                            [&](double u) { return restitution(law, u).e; });
    narrow.push_back(p.contact_value(0.01) / cc.g);
    wide.push_back(p.contact_value(0.1) / cc.g);
  }
  const auto [m, se] = grainbath::edmd::testing::mean_se(narrow);
  const auto [mw, sew] = grainbath::edmd::testing::mean_se(wide);
  std::printf("Boltzmann bath: quadratic fit over [1, 1.01] / collisions' g(sigma+) = %.4f +- %.4f; over [1, 1.1]: "
              "%.4f +- %.4f (6 seeds)\n",
              m, se, mw, sew);
  EXPECT_GT(se, 0.0);
  EXPECT_NEAR(m, 1.0, 5.0 * se);
  EXPECT_GT(std::abs(mw - 1.0), 5.0 * se);  // the quadratic over [sigma, 1.1 sigma] misses the layer
}

// The bath acts at the collision instants (Engine::apply_heating after each collision), so it
// can hit the pair that has just collided: that pair leaves at u' instead of e u, or, u' <= 0,
// collides again at once (a collision whose approach term 1/|u'| no pair spent in the shell).
// The hook replays the bath's counter-based draws (CounterRng(seed, edmd_heating,
// kSystemEntity, collisions)), checked against the engine (every velocity the bath set is
// the one the next collision finds), and sums the change of the collisions' g(sigma+): what
// these pairs add (1/max(u', 0.01): slower pairs outstay a free time ~0.12 in a 0.001 sigma
// bin) minus what the estimator counts (1/(e u); 1/|u'| for a re-collision). Bounds: the hit
// fraction 1 - (1 - 2/N)^k within 5 binomial standard errors; the change below 0.5 % of
// g(sigma+). Measured (seeds 1-4 x 1000 collisions per grain, docs/edmd.md): Boltzmann
// 0.451 +- 0.002 % hit, 32 % of them re-collide, change -0.18 +- 0.01 %; white noise
// 0.226 +- 0.001 %, 6 %, -0.03 +- 0.01 %.
namespace {
struct KickReplay {
  Engine* eng = nullptr;
  std::uint64_t seed = 0;
  bool boltzmann = true;
  int n = 0, rate = 0;
  double bath_temperature = 0.0, kick = 0.0, vn_bin = 0.02;
  BizonRestitution law{0.7, 1.0};
  long collisions = 0, hits = 0, recollisions = 0, checked = 0, mismatched = 0;
  double sum_all = 0.0, change = 0.0;  // sum 1/u + 1/(e u) over all collisions; what the hits change
  std::vector<std::pair<std::uint32_t, Vec3>> set;  // velocities the bath set at the last collision
  static void hook(void* p, const CollisionRecord& rec) { static_cast<KickReplay*>(p)->on(rec); }
  void on(const CollisionRecord& rec) {
    for (const auto& [id, w] : set)
      if (id != rec.id_i && id != rec.id_j) {
        ++checked;
        const Vec3 u = eng->velocity(id);
        mismatched += u.x != w.x || u.y != w.y;
      }
    set.clear();
    const Vec3 k = (1.0 / norm(rec.rij)) * rec.rij;
    Vec3 vi = eng->velocity(rec.id_i), vj = eng->velocity(rec.id_j);
    const double u = 2.0 * dot(rec.impulse, k) - dot(vj - vi, k);  // impulse.k = (1 + e) u / 2
    auto mid = [&](double x) { return (std::floor(x / vn_bin) + 0.5) * vn_bin; };  // as the histogram
    const double um = mid(u), out = 1.0 / (restitution(law, um).e * um);
    ++collisions;
    sum_all += 1.0 / um + out;
    CounterRng rng(seed, Stream::edmd_heating, kSystemEntity, eng->counters().collisions + 1);
    auto pick = [&]() { return static_cast<std::uint32_t>(std::min<double>(n - 1.0, rng.uniform() * n)); };
    auto current = [&](std::uint32_t q) {
      if (q == rec.id_i) return vi;
      if (q == rec.id_j) return vj;
      for (const auto& [id, w] : set)
        if (id == q) return w;
      return eng->velocity(q);
    };
    auto assign = [&](std::uint32_t q, const Vec3& w) {
      std::erase_if(set, [&](const auto& e) { return e.first == q; });
      set.emplace_back(q, w);
      if (q == rec.id_i) vi = w;
      if (q == rec.id_j) vj = w;
    };
    for (int r = 0; r < rate; ++r) {
      if (boltzmann) {
        const std::uint32_t q = pick();
        const double s = std::sqrt(bath_temperature);
        const double a = s * rng.normal();
        const double b = s * rng.normal();
        assign(q, {a, b, 0.0});
      } else {
        const std::uint32_t p = pick();
        std::uint32_t q = pick();
        while (q == p) q = pick();
        const double phi = 2.0 * std::numbers::pi * rng.uniform();
        const Vec3 d{std::cos(phi), std::sin(phi), 0.0};
        const Vec3 wp = current(p) + kick * d, wq = current(q) - kick * d;
        assign(p, wp);
        assign(q, wq);
      }
    }
    const bool hit = std::any_of(set.begin(), set.end(), [&](const auto& e) { return e.first == rec.id_i || e.first == rec.id_j; });
    if (!hit) return;
    ++hits;
    change -= out;
    const double un = dot(vj - vi, k);
    if (un > 0.0) {
      change += 1.0 / std::max(un, 0.01);
    } else {
      ++recollisions;
      change -= 1.0 / mid(-un);
    }
  }
};
}  // namespace

TEST(EdmdContactFromCollisions, BathKicksAtContactChangeItLittle) {
  for (const bool boltzmann : {true, false}) {
    const int N = 1764;
    CaseReader rd(std::string("[edmd]\ndimensions = 2\nparticles = 1764\npacking_fraction = 0.5\n"
                              "[restitution]\nlaw = \"bizon\"\ne = 0.7\ncrossover = 1.0\n") +
                      (boltzmann ? "[heating]\nmodel = \"boltzmann\"\nrate = 4\ntemperature = 1.15\n"
                                 : "[heating]\nmodel = \"white_noise\"\nrate = 1\nkick = 0.62\n"),
                  "t.toml");
    Config c = read_config(rd);
    rd.finish();
    const std::uint64_t seed = 3;
    const auto init = make_initial_state(c, seed);
    Engine eng(make_setup(c, seed), init.positions, init.velocities);
    const BizonRestitution law{0.7, 1.0};
    eng.advance(law, kInf, 20 * N);
    KickReplay k;
    k.eng = &eng, k.seed = seed, k.boltzmann = boltzmann, k.n = N, k.rate = c.heating.rate;
    k.bath_temperature = c.heating.temperature, k.kick = c.heating.kick;
    eng.set_collision_hook(&KickReplay::hook, &k);
    eng.advance(law, kInf, eng.counters().collisions + 150 * N);
    const double p = 1.0 - std::pow(1.0 - 2.0 / N, boltzmann ? 4 : 2), frac = double(k.hits) / k.collisions;
    std::printf("%s: bath hits the colliding pair in %.5f of %ld collisions (1 - (1 - 2/N)^k = %.5f), %ld re-collide; "
                "change of the collisions' g(sigma+) %+.5f; %ld set velocities checked\n",
                boltzmann ? "Boltzmann" : "white noise", frac, k.collisions, p, k.recollisions, k.change / k.sum_all,
                k.checked);
    EXPECT_GT(k.checked, 100000);
    EXPECT_EQ(k.mismatched, 0);  // the replay is the engine's bath
    EXPECT_NEAR(frac, p, 5.0 * std::sqrt(p * (1.0 - p) / k.collisions));
    EXPECT_GT(k.recollisions, 0);
    EXPECT_LT(std::abs(k.change / k.sum_all), 0.005);
  }
}

// The driver's pair snapshots are taken at times, not at collision counts, also with no
// equilibration (edmd.equilibrate = 0: each interval from the mean collision rate of the run so
// far) and at the run's end (stopped by the collision target): a snapshot taken right after a
// collision holds that pair at contact (docs/edmd.md "Contact values"). Bins of 1e-5 sigma make
// the pair visible: at fixed times the two bins at sigma hold 0.5 N (N-1)/V 2 pi 1e-5 g(sigma+)
// = 0.025 pairs per snapshot (400 disks, nu = 0.5, g = 3.1), g ~ 3 in the bin above sigma and
// 0 below; a pair at contact in every snapshot adds ~125 to their sum, which the
// equilibrate = 0 path did before 2026-12-06.
TEST(EdmdContactSampling, PairSnapshotsAreAtFixedTimesWithoutEquilibration) {
  for (const double equilibrate : {0.0, 20.0}) {
    const std::string toml = "[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.5\nequilibrate = " +
                             std::to_string(equilibrate) +
                             "\ncollisions = 1003.3\n[sampling]\ninterval = 0.5\ngr_max = 1.1\ngr_bin = 1e-5\n"
                             "corr_max = 1.1\n";
    const double N = 400.0;
    double at_contact = 0.0, rule_error = 1.0;
    std::size_t samples = 0;
    grainbath::edmd::testing::run_summary(toml, 7, "edmd_gr_times", [&](const std::filesystem::path& out) {
      H5File h((out / "results.h5").string(), H5File::Mode::read);
      const auto r = h.read_doubles("/observables/gr/r"), g = h.read_doubles("/observables/gr/g");
      for (std::size_t b = 0; b < r.size(); ++b)
        if (std::abs(r[b] - 1.0) < 1e-5) at_contact += g[b];  // the bins [1 - 1e-5, 1] and [1, 1 + 1e-5]
      // The sampling times follow their rule (all but the last interval, cut short by the
      // target): equal steps after an equilibration; else step k+1 = 0.5 N t_k / C_k with the
      // collisions C_k to sample k from the collision frequencies 2 dC / (N dt).
      const auto t = h.read_doubles("/timeseries/t"), f = h.read_doubles("/timeseries/collision_frequency");
      samples = t.size();
      double worst = 0.0, C = 0.0;
      for (std::size_t k = 1; k + 2 < t.size(); ++k) {
        C += std::round(0.5 * f[k - 1] * N * (t[k] - t[k - 1]));
        const double step = t[k + 1] - t[k], expected = equilibrate > 0 ? t[2] - t[1] : 0.5 * N * t[k] / C;
        worst = std::max(worst, std::abs(step / expected - 1.0));
      }
      rule_error = worst;
    });
    std::printf("equilibrate = %g: g summed over the two 1e-5 bins at sigma %.2f; %zu samples at their times to %.1e\n",
                equilibrate, at_contact, samples, rule_error);
    EXPECT_GT(samples, 1500u);
    EXPECT_LT(at_contact, 12.0) << "a pair snapshot held the pair that had just collided";
    EXPECT_LT(rule_error, 1e-9) << "samples not at the times of the rule";
  }
  // The run's last sample, stopped by the collision target, is in the time series but in no
  // snapshot average: with sampling.interval = 5 every sample is a pair snapshot, and 12.5
  // collisions per particle end after two sampling intervals (t = 0, two times, the target).
  const std::string last = "[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.5\nequilibrate = 20\n"
                           "collisions = 12.5\n[sampling]\ninterval = 5\n";
  grainbath::edmd::testing::run_summary(last, 7, "edmd_gr_last", [&](const std::filesystem::path& out) {
    H5File h((out / "results.h5").string(), H5File::Mode::read);
    ASSERT_EQ(h.read_doubles("/timeseries/t").size(), 4u);
    EXPECT_EQ(h.read_int_attribute("/observables/gr", "snapshots"), 2);
    EXPECT_EQ(h.read_int_attribute("/observables/velocity_correlation", "snapshots"), 2);
    EXPECT_EQ(h.read_int_attribute("/observables/velocity_distribution", "snapshots"), 2);
  });
}

INSTANTIATE_TEST_SUITE_P(Fast, EdmdEos,
                         ::testing::Values(EosPoint{2, 0.1, 900}, EosPoint{2, 0.4, 900}, EosPoint{2, 0.6, 900},
                                           EosPoint{3, 0.1, 1000}, EosPoint{3, 0.3, 1000}, EosPoint{3, 0.45, 1000}));

TEST(EdmdPhysics, ElasticCollisionRateMatchesEnskogWithinOnePercent) {
  for (int dims : {2, 3}) {
    const double packing = dims == 2 ? 0.3 : 0.25;
    const Summary s = run_case("[edmd]\ndimensions = " + std::to_string(dims) +
                               "\nparticles = 1000\npacking_fraction = " + std::to_string(packing) +
                               "\nequilibrate = 20\ncollisions = 200\n");
    EXPECT_NEAR(s.number("collision.frequency_over_enskog"), 1.0, 0.01) << dims;
    // molecular chaos at collision (Bizon after eq. 33): <v_n>_c = sqrt(pi T), <v_n^2>_c = 4T
    EXPECT_NEAR(s.number("collision.vn_over_sqrt_piT"), 1.0, 0.01) << dims;
    EXPECT_NEAR(s.number("collision.vn2_over_4T"), 1.0, 0.015) << dims;
  }
}

// Elastic grains relaxing in the medium, no grain-grain dissipation: T(t) against the
// closed-form relaxation law theory::background_heating_rate (2D operator of
// background2d.hpp and the shared 3D operator), integrated with RK4.
TEST(EdmdPhysics, BackgroundRelaxationMatchesTheory) {
  for (int dims : {2, 3}) {
    const double K = 0.5, alpha = 0.3, TB = 1.0;
    Config c;
    CaseReader r("[edmd]\ndimensions = " + std::to_string(dims) +
                     "\nparticles = 3000\npacking_fraction = 0.02\ntemperature = 3.0\n"
                     "[background]\ndensity = 0.5\nknudsen = 1.0\ntemperature = 1.0\nmass_ratio = 0.3\n",
                 "t.toml");
    c = read_config(r);
    r.finish();
    const auto init = make_initial_state(c, 21);
    Engine eng(make_setup(c, 21), init.positions, init.velocities);
    double T_theory = 3.0;
    const double dt = 0.05;
    for (int step = 1; step <= 40; ++step) {
      auto f = [&](double T) { return theory::background_heating_rate(dims, T, TB, K, alpha); };
      const double k1 = f(T_theory), k2 = f(T_theory + 0.5 * dt * k1), k3 = f(T_theory + 0.5 * dt * k2),
                   k4 = f(T_theory + dt * k3);
      T_theory += dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4);
      eng.advance(ElasticRestitution{}, step * dt, ~0ull);
    }
    eng.synchronize();
    Vec3 p = eng.momentum();
    const double T = (2.0 * eng.kinetic_energy() - norm2(p) / eng.size()) / (dims * eng.size());
    // statistical error of T with 3000 grains: ~ T sqrt(2/(D N)) ~ 1.5-2 %
    EXPECT_NEAR(T / T_theory, 1.0, 0.05) << dims << " T " << T << " theory " << T_theory;
    EXPECT_GT(eng.counters().background_collisions, 1000u);
  }
}

// K <|v - w|> over the medium's Maxwellian (w ~ N(u_B, s^2) per component) at grain
// velocity v: the exact medium collision rate of a grain (both the 2D and the 3D kernel
// collide at K |g| per unit time). 2D: the Rice mean s sqrt(pi/2) e^{-q/2} [(1 + q) I0(q/2)
// + q I1(q/2)], q = |c|^2/(2 s^2); 3D: s [sqrt(2/pi) e^{-x^2/2} + (x + 1/x) erf(x/sqrt 2)],
// x = |c|/s.
double medium_rate(int dims, const Vec3& c, double K, double s) {
  if (dims == 2) {
    const double q = (c.x * c.x + c.y * c.y) / (2.0 * s * s);
    return K * s * std::sqrt(std::numbers::pi / 2.0) * std::exp(-q / 2.0) *
           ((1.0 + q) * std::cyl_bessel_i(0.0, q / 2.0) + q * std::cyl_bessel_i(1.0, q / 2.0));
  }
  const double x = norm(c) / s;
  if (x < 1e-8) return K * s * std::sqrt(8.0 / std::numbers::pi);
  return K * s * (std::sqrt(2.0 / std::numbers::pi) * std::exp(-0.5 * x * x) + (x + 1.0 / x) * std::erf(x / std::sqrt(2.0)));
}

// Air table in a medium: between events v(t) = v0 + a t, so the medium candidates must follow
// the changing velocity (engine.cpp, draw_background_window). The count of medium collisions
// against the time integral of the exact rate of every grain over snapshots of the velocities
// every 0.02 time units (a Riemann sum whose grid is unrelated to the events, so no bias).
// Candidates drawn at the majorant of the flight's start (the earlier engine) gave 0.77 of
// the rate in 2D (/tmp/auditB: 0.772 +- 0.004). Tolerance: 5 standard errors from 20 batches.
TEST(EdmdPhysics, AirTableMediumCollisionRateFollowsTheVelocities) {
  for (int dims : {2, 3}) {
    const Config c = [&] {
      CaseReader r("[edmd]\ndimensions = " + std::to_string(dims) + "\nparticles = " + (dims == 2 ? "1024" : "1000") +
                       "\npacking_fraction = 0.05\n[heating]\nmodel = \"air_table\"\nacceleration = 2.0\n"
                       "[background]\ndensity = 1.0\nknudsen = 1.0\ntemperature = 0.2\nmass_ratio = 0.5\n",
                   "t.toml");
      Config cfg = read_config(r);
      r.finish();
      return cfg;
    }();
    const auto init = make_initial_state(c, 5);
    Engine eng(make_setup(c, 5), init.positions, init.velocities);
    const double K = 1.0, s = std::sqrt(0.2 / 1.0);  // s^2 = TB / mB, mB = alpha/(1 - alpha) = 1
    const double dt = 0.02;
    const int per_batch = 100, batches = 20;
    eng.advance(ElasticRestitution{}, 2.0, ~0ull);  // leave the lattice start
    std::vector<double> diff;
    double counted = 0.0, expected = 0.0;
    for (int b = 0; b < batches; ++b) {
      const auto n0 = eng.counters().background_collisions;
      double integral = 0.0;
      for (int k = 0; k < per_batch; ++k) {
        eng.synchronize();
        double sum = 0.0;
        for (std::size_t i = 0; i < eng.size(); ++i) sum += medium_rate(dims, eng.velocity(i), K, s);
        integral += sum * dt;
        eng.advance(ElasticRestitution{}, eng.time() + dt, ~0ull);
      }
      const double n = static_cast<double>(eng.counters().background_collisions - n0);
      diff.push_back(n - integral);
      counted += n;
      expected += integral;
    }
    const MeanError d = block_average(diff);
    const double ratio = counted / expected, err = d.stderr_ * batches / expected;
    std::printf("dims %d: medium collisions / exact expectation = %.4f +- %.4f (%.0f collisions)\n", dims, ratio, err,
                counted);
    EXPECT_NEAR(ratio, 1.0, 5.0 * err) << dims;
    EXPECT_LT(err, 0.01) << dims;  // the check has teeth (the old engine: 0.77)
    eng.synchronize();
    EXPECT_GE(eng.min_distance(), 1.0 - 1e-9);
  }
}

// edmd.dsmc_equivalent_grain_density maps the EDMD to the DSMC, whose velocities are 3D: a
// disk case has no DSMC counterpart, so the key is for spheres only.
TEST(EdmdPhysics, DsmcEquivalentDensityOnlyForSpheres) {
  for (int dims : {2, 3}) {
    CaseReader r("[edmd]\ndimensions = " + std::to_string(dims) +
                     "\nparticles = 1000\npacking_fraction = 0.05\n[background]\ndensity = 1.0\n",
                 "t.toml");
    const Config c = read_config(r);
    r.finish();
    bool found = false;
    for (const auto& [key, value] : theory_values(c))
      if (key == "edmd.dsmc_equivalent_grain_density") {
        found = true;
        EXPECT_NEAR(value, std::numbers::pi * theory::number_density(3, 0.05) * theory::g_contact_reference(3, 0.05),
                    1e-12);
      }
    EXPECT_EQ(found, dims == 3) << dims;
  }
}

TEST(EdmdPhysics, SteadyTemperatureInMediumMatchesEnergyBalance) {
  const Summary s = run_case(
      "[edmd]\ndimensions = 3\nparticles = 1000\npacking_fraction = 0.3\nequilibrate = 20\ncollisions = 60\n"
      "[restitution]\nlaw = \"constant\"\ne = 0.9\n"
      "[background]\ndensity = 1.0\nknudsen = 1.0\ntemperature = 1.0\nmass_ratio = 0.5\n");
  // measured (cases/dense-medium, 4096 grains): 1.003 +- 0.003; Maxwellian theory ignores a2
  EXPECT_NEAR(s.number("medium.temperature_over_theory"), 1.0, 0.02 + 5 * s.number("temperature.stderr"));
  EXPECT_NEAR(s.number("conservation.energy_change"), 0.0, 1e-6 * 1000);
}

// The blocked errors carry the DSMC's plateau flag (docs/OUTPUT.md, Lee-Needs-Drummond). In a
// medium T decorrelates within ~2 collisions per particle: 1024 samples reach the plateau
// (4/4 seeds; 14 seeds of cases/dense-medium scatter by 0.91 +- 0.18 of their blocked error).
// White-noise disks at nu = 0.5 relax over ~70 collisions per particle: no plateau (8/8 seeds;
// 12 seeds of cases/bizon-heat-baths/white-noise scatter 2.6 +- 0.6x their blocked T and Z
// errors, docs/edmd.md "Errors of the window means"). Absent flags (before 2026-12-06) fail.
TEST(EdmdPhysics, BlockedErrorsCarryThePlateauFlag) {
  const std::string medium =
      "[edmd]\ndimensions = 3\nparticles = 512\npacking_fraction = 0.3\nequilibrate = 20\ncollisions = 1024\n"
      "[restitution]\nlaw = \"constant\"\ne = 0.9\n"
      "[background]\ndensity = 1.0\nknudsen = 1.0\ntemperature = 1.0\nmass_ratio = 0.5\n";
  const std::string heated =
      "[edmd]\ndimensions = 2\nparticles = 900\npacking_fraction = 0.5\nequilibrate = 30\ncollisions = 256\n"
      "[restitution]\nlaw = \"bizon\"\ne = 0.7\ncrossover = 1.0\n"
      "[heating]\nmodel = \"white_noise\"\nkick = 0.62\n";
  auto flag = [](const Summary& s, const char* key) -> int {
    const Summary::Value* v = s.get(key);
    if (v == nullptr || !std::holds_alternative<bool>(*v)) return -1;  // absent
    return std::get<bool>(*v) ? 1 : 0;
  };
  for (std::uint64_t seed : {1, 2}) {
    const Summary m = run_case(medium, seed), h = run_case(heated, seed);
    EXPECT_EQ(flag(m, "temperature.stderr_plateau"), 1) << "seed " << seed;
    EXPECT_EQ(flag(m, "pressure.Z_stderr_plateau"), 1) << "seed " << seed;
    EXPECT_EQ(flag(h, "temperature.stderr_plateau"), 0) << "seed " << seed;
    EXPECT_EQ(flag(h, "pressure.Z_stderr_plateau"), 0) << "seed " << seed;
  }
}

// pressure.P_stderr (review 4: P had no error) is the blocked error of the per-interval
// pressures n T_k Z_k. Elastic disks keep T fixed to rounding, so it must equal n T Z_stderr;
// in a medium T fluctuates with the virial, and the error must differ from n T Z_stderr
// (it carries T's part) while staying of its size.
TEST(EdmdPhysics, PressureErrorIsTheBlockedErrorOfThePerIntervalPressure) {
  const std::string elastic =
      "[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.4\nequilibrate = 5\ncollisions = 200\n"
      "[restitution]\nlaw = \"elastic\"\n";
  const Summary e = run_case(elastic, 3);
  const double n = theory::number_density(2, 0.4);
  ASSERT_GT(e.number("pressure.Z_stderr"), 0.0);
  EXPECT_NEAR(e.number("pressure.P_stderr"), n * e.number("temperature.mean") * e.number("pressure.Z_stderr"),
              1e-9 * e.number("pressure.P_stderr"));
  EXPECT_NEAR(e.number("pressure.P"), n * e.number("temperature.mean") * e.number("pressure.Z"), 1e-12);
  const std::string medium =
      "[edmd]\ndimensions = 3\nparticles = 512\npacking_fraction = 0.3\nequilibrate = 20\ncollisions = 256\n"
      "[restitution]\nlaw = \"constant\"\ne = 0.9\n"
      "[background]\ndensity = 1.0\nknudsen = 1.0\ntemperature = 1.0\nmass_ratio = 0.5\n";
  const Summary m = run_case(medium, 3);
  const double nm = theory::number_density(3, 0.3), nTZ = nm * m.number("temperature.mean") * m.number("pressure.Z_stderr");
  EXPECT_GT(std::abs(m.number("pressure.P_stderr") / nTZ - 1.0), 1e-3);
  EXPECT_GT(m.number("pressure.P_stderr"), 0.3 * nTZ);
  EXPECT_LT(m.number("pressure.P_stderr"), 5.0 * nTZ);
}

TEST(EdmdPhysics, HeatBathsReproduceBizonTrends) {
  // white noise at nu = 0.5: velocity correlations lower G_s below the CS value and the loss
  // rate below gamma_e (Bizon Figs. 5, 8b); the Boltzmann bath keeps gamma close to gamma_e.
  const std::string base =
      "[edmd]\ndimensions = 2\nparticles = 900\npacking_fraction = 0.5\nequilibrate = 30\ncollisions = 120\n"
      "[restitution]\nlaw = \"bizon\"\ne = 0.7\ncrossover = 1.0\n";
  const Summary w = run_case(base + "[heating]\nmodel = \"white_noise\"\nkick = 0.62\n");
  const Summary b = run_case(base + "[heating]\nmodel = \"boltzmann\"\nrate = 4\ntemperature = 1.15\n");
  const double G_cs = theory::g_contact_disk_cs(0.5) * 0.5;
  EXPECT_LT(w.number("pressure.G_s"), 0.92 * G_cs);
  EXPECT_GT(b.number("pressure.G_s"), 1.0 * G_cs);
  EXPECT_LT(w.number("loss.gamma_over_gamma_e"), 0.95);
  EXPECT_NEAR(b.number("loss.gamma_over_gamma_e"), 1.0, 0.05);
  EXPECT_NEAR(w.number("temperature.mean"), 1.0, 0.15);
  EXPECT_NEAR(w.number("conservation.momentum_change"), 0.0, 1e-9);
}

TEST(EdmdPhysics, TrajectoriesInH5mdLayout) {
  CaseReader r(
      "[edmd]\ndimensions = 2\nparticles = 100\npacking_fraction = 0.3\nequilibrate = 5\ncollisions = 20\n"
      "[sampling]\ntrajectory_interval = 5\n",
      "t.toml");
  Config c = read_config(r);
  r.finish();
  RunContext ctx;
  ctx.out_dir = std::filesystem::temp_directory_path() / ("edmd_traj_" + std::to_string(::getpid()));
  std::filesystem::create_directories(ctx.out_dir);
  ctx.quiet = true;
  Summary s;
  run(c, ctx, s);
  {
    H5File h((ctx.out_dir / "results.h5").string(), H5File::Mode::read);
    std::vector<hsize_t> dims;
    const auto pos = h.read_doubles("/particles/all/position/value", &dims);
    ASSERT_EQ(dims.size(), 3u);
    EXPECT_GE(dims[0], 4u);
    EXPECT_EQ(dims[1], 100u);
    EXPECT_EQ(dims[2], 2u);
    EXPECT_EQ(h.read_doubles("/particles/all/position/time").size(), dims[0]);
    EXPECT_EQ(h.read_doubles("/particles/all/box/edges").size(), 2u);
    EXPECT_TRUE(h.exists("/observables/gr/g"));
  }
  std::filesystem::remove_all(ctx.out_dir);
}

// results.h5 keeps the time series under /timeseries with the time axis t (DSMC's layout);
// the former /series/<name> (/series/time for t) are soft links reading the same data.
// Rough disks, so that rotational_temperature and the model curves at t are covered too.
TEST(EdmdPhysics, TimeSeriesLayoutWithFormerNamesAsLinks) {
  CaseReader r(
      "[edmd]\ndimensions = 2\nparticles = 100\npacking_fraction = 0.2\nrotational_temperature = 0.5\n"
      "equilibrate = 5\ncollisions = 20\n"
      "[restitution]\nlaw = \"walton\"\ne = 0.9\nbeta0 = 0.5\nmu = 0.3\n"
      "[heating]\nmodel = \"white_noise\"\nkick = 0.3\n",
      "t.toml");
  Config c = read_config(r);
  r.finish();
  RunContext ctx;
  ctx.out_dir = std::filesystem::temp_directory_path() / ("edmd_series_" + std::to_string(::getpid()));
  std::filesystem::create_directories(ctx.out_dir);
  ctx.quiet = true;
  Summary s;
  run(c, ctx, s);
  {
    H5File h((ctx.out_dir / "results.h5").string(), H5File::Mode::read);
    const auto t = h.read_doubles("/timeseries/t");
    ASSERT_GE(t.size(), 3u);
    EXPECT_EQ(t.front(), 0.0);
    EXPECT_FALSE(h.read_attribute("/timeseries", "units").empty());
    EXPECT_FALSE(h.exists("/timeseries/time"));
    EXPECT_EQ(h.soft_link_target("/series/time"), "/timeseries/t");
    EXPECT_EQ(h.read_doubles("/series/time"), t);
    const std::size_t n_s = t.size(), intervals = n_s - 1;  // per-sample and per-interval series
    const std::pair<const char*, std::size_t> names[] = {
        {"temperature", n_s},          {"Z", intervals},
        {"loss_rate", intervals},      {"heating_rate", intervals},
        {"background_rate", intervals}, {"collision_frequency", intervals},
        {"rotational_temperature", n_s}};
    for (const auto& [name, n] : names) {
      const std::string now = std::string("/timeseries/") + name, old = std::string("/series/") + name;
      const auto a = h.read_doubles(now);
      EXPECT_EQ(a.size(), n) << now;
      EXPECT_EQ(h.soft_link_target(old), now) << old;
      EXPECT_EQ(h.read_doubles(old), a) << old;
      EXPECT_EQ(h.soft_link_target(now), "") << now << " is a dataset, not a link";
    }
    EXPECT_EQ(h.read_doubles("/theory/rough_model_A/Ttr").size(), t.size());  // at /timeseries/t
  }
  std::filesystem::remove_all(ctx.out_dir);
}

TEST(EdmdPhysics, FreeCoolingFollowsHaffsLaw) {
  // cases/free-cooling-disks at 2500 disks: measured t0 / (Enskog + a2) = 1.02-1.03
  // (velocity correlations slow the cooling slightly); the shape must be Haff's.
  const Summary s = run_case(
      "[edmd]\ndimensions = 2\nparticles = 2500\npacking_fraction = 0.1\nequilibrate = 2\ncollisions = 8\n"
      "[restitution]\nlaw = \"constant\"\ne = 0.9\n[sampling]\ninterval = 0.5\nfree_cooling = true\n");
  EXPECT_NEAR(s.number("haff.ratio"), 1.02, 0.03);
  EXPECT_LT(s.number("haff.final_temperature"), 0.5 * s.number("temperature.initial"));
}

// In free cooling T falls through the window (here 0.68 -> 0.10 over 10 collisions per
// disk), so the theory a window-averaged rate is compared with must be the window average
// of the theory: Enskog's frequency ∝ T^1/2 at <T^1/2>_t^2, the loss rate ∝ T^3/2 at
// <T^3/2>_t^(2/3), collision averages weighted by the rate. At e = 0.9 and nu = 0.05 the
// cooling state is near molecular chaos: 6 seeds gave frequency/Enskog 0.995 (sd 0.007),
// gamma/gamma_e 0.996 (sd 0.004), velocity ratio 0.995 (sd 0.003), <v_n>/sqrt(pi T) 0.996.
// Evaluated at the window mean of T (until 2026-12-05) they read 0.922, 0.961, 1.057, 0.987
// for seed 1. Bound: 0.03 (4 sd of the frequency). No temperature.mean or pressure.P: a
// window mean of a decaying T describes nothing (haff.* does).
TEST(EdmdPhysics, FreeCoolingRatiosAreWindowAveragesOfTheTheory) {
  const Summary s = run_case(
      "[edmd]\ndimensions = 2\nparticles = 2500\npacking_fraction = 0.05\nequilibrate = 2\ncollisions = 10\n"
      "[restitution]\nlaw = \"constant\"\ne = 0.9\n[sampling]\ninterval = 0.5\nfree_cooling = true\n");
  EXPECT_LT(s.number("haff.final_temperature"), 0.2 * s.number("temperature.initial"));
  for (const char* k : {"collision.frequency_over_enskog", "loss.gamma_over_gamma_e", "loss.velocity_ratio",
                        "collision.vn_over_sqrt_piT", "collision.vn2_over_4T"})
    EXPECT_NEAR(s.number(k), 1.0, 0.03) << k;
  EXPECT_EQ(s.get("temperature.mean"), nullptr);
  EXPECT_EQ(s.get("temperature.stderr"), nullptr);
  EXPECT_EQ(s.get("pressure.P"), nullptr);
}

// The normal relative speed u = -g.n of the colliding pairs of an elastic gas in equilibrium
// has the collision-weighted density u/(2T) exp(-u^2/(4T)) (m = 1; the pair's relative
// velocity is Gaussian with variance 2T per component and uncorrelated with the positions,
// so at contact the flux weight u alone shapes it, at any density): <u/sqrt(T)> = sqrt(pi),
// <u^2/T> = 4. A cold gas (T = 0.01) also checks that the bins follow the measured
// temperature (0.02 sqrt(T0) wide); they were 0.02 sqrt(max(1, ...)) = 0.2 sqrt(T) here before.
TEST(EdmdPhysics, NormalSpeedAtCollisionsIsFluxWeightedGaussianInAColdGas) {
  CaseReader r(
      "[edmd]\ndimensions = 3\nparticles = 500\npacking_fraction = 0.2\nequilibrate = 5\ncollisions = 40\n"
      "temperature = 0.01\n",
      "t.toml");
  Config c = read_config(r);
  r.finish();
  RunContext ctx;
  ctx.out_dir = std::filesystem::temp_directory_path() / ("edmd_vn_" + std::to_string(::getpid()));
  std::filesystem::create_directories(ctx.out_dir);
  ctx.quiet = true;
  ctx.seed = 3;
  Summary s;
  run(c, ctx, s);
  std::vector<double> x, d;
  {
    H5File h((ctx.out_dir / "results.h5").string(), H5File::Mode::read);
    x = h.read_doubles("/observables/normal_speed/vn_over_sqrtT");
    d = h.read_doubles("/observables/normal_speed/density");
  }
  std::filesystem::remove_all(ctx.out_dir);
  ASSERT_GE(x.size(), 2u);
  ASSERT_EQ(x.size(), d.size());
  const double dx = x[1] - x[0];
  const double T0 = s.number("temperature.initial"), T = s.number("temperature.mean");
  EXPECT_NEAR(dx, 0.02 * std::sqrt(T0 / T), 1e-12);
  double norm = 0, m1 = 0, m2 = 0;
  for (std::size_t b = 0; b < x.size(); ++b) {
    norm += d[b] * dx;
    m1 += x[b] * d[b] * dx;
    m2 += x[b] * x[b] * d[b] * dx;
  }
  EXPECT_NEAR(norm, 1.0, 1e-12);
  // standard errors from the collision count (sd of u/sqrt(T): sqrt(4 - pi) = 0.93; of
  // u^2/T: sqrt(32 - 16) = 4), times 2 for correlations between a grain's successive collisions
  const double n = s.number("collision.count");
  ASSERT_GT(n, 5000);
  EXPECT_NEAR(m1, std::sqrt(std::numbers::pi), 5 * 2 * 0.93 / std::sqrt(n) + 0.002);
  EXPECT_NEAR(m2, 4.0, 5 * 2 * 4.0 / std::sqrt(n) + 0.002);
}

// Normalisation of g(r) by a sum rule, independent of the contact fit: with the N(N-1)/2 pairs
// as the ideal count, V^-1 int_V g_N dr = 1 exactly in the N-particle box, and the short-range
// part of int (g - 1) dr is (S(0) - 1)/n, so beyond the correlations g_N sits at
// 1 + (1 - S(0))/N, S(0) = 1/(d(nu Z)/d nu) (compressibility equation; Z from the Kolafa-Rottner
// fit, theory::z_reference). 256 disks, nu = 0.5: 1 + 0.92/256 = 1.00360; the N^2 count of
// before would give 1 - 0.0003. Tolerance: 5 standard errors over 6 seeds plus 2e-4 for the
// structure left at 5 sigma ... L/2 (the mean of g - 1 over 5 ... 8.9 sigma is 1.2e-4 below
// its value beyond 10 sigma in 1024-disk runs, 20 seeds, docs/VALIDATION.md).
// Measured (6 seeds x 1000 collisions per grain, 2 s): 0.003507 +- 0.000028 against 0.003593
// (S(0) = 0.0803); the N^2 count would read -0.00042 (fails).
TEST(EdmdPairDistribution, TailObeysTheFiniteSystemSumRule) {
  const double nu = 0.5;
  const int N = 256;
  CaseReader rd("[edmd]\ndimensions = 2\nparticles = " + std::to_string(N) + "\npacking_fraction = 0.5\n", "t.toml");
  Config c = read_config(rd);
  rd.finish();
  const double L = std::sqrt(N * std::numbers::pi / (4.0 * nu));
  std::vector<double> tail;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const auto init = make_initial_state(c, seed);
    Engine eng(make_setup(c, seed), init.positions, init.velocities);
    eng.advance(ElasticRestitution{}, kInf, 100 * N);  // melt the lattice
    PairStatistics p;
    p.init(2, c.box(), {false, false, false}, 0.5 * L, 0.02, 0.1);
    std::vector<Vec3> x(N), v(N);
    for (int s = 0; s < 200; ++s) {  // a snapshot every 5 collisions per grain
      eng.advance(ElasticRestitution{}, kInf, eng.counters().collisions + 5 * N);
      eng.synchronize();
      for (int i = 0; i < N; ++i) x[i] = eng.position(i), v[i] = eng.velocity(i);
      p.add(x, v, 1.0);
    }
    const auto g = p.gr();
    double num = 0.0, den = 0.0;
    for (std::size_t b = 0; b < g.size(); ++b) {
      const double r0 = b * p.gr_bin, r1 = r0 + p.gr_bin;
      if (r0 < 5.0 || r1 > 0.5 * L - 0.1) continue;
      num += g[b] * (r1 * r1 - r0 * r0), den += r1 * r1 - r0 * r0;  // shell-weighted mean
    }
    tail.push_back(num / den - 1.0);
  }
  const auto [m, se] = grainbath::edmd::testing::mean_se(tail);
  const double h = 1e-6;
  const double dnz = ((nu + h) * theory::z_reference(2, nu + h) - (nu - h) * theory::z_reference(2, nu - h)) / (2.0 * h);
  const double expect = (1.0 - 1.0 / dnz) / N;
  std::printf("g tail - 1 over 5 sigma ... L/2: %.6f +- %.6f; (1 - S(0))/N = %.6f (S(0) = %.4f)\n", m, se, expect, 1.0 / dnz);
  EXPECT_GT(se, 0.0);
  EXPECT_NEAR(m, expect, 5.0 * se + 2e-4);
}

// The disk medium operator (src/edmd/background2d.hpp) against its own collision integral,
// evaluated here independently of the operator's thinning, partner mixture and impact
// sampling: for a grain of velocity v, partners w from the 2D Maxwellian of the medium, the
// collision rate K |g| (g = v - w), and the impact parameter b = sin(theta) uniform on
// (-1, 1), so that the normal is n = cos(theta) g_hat + sin(theta) g_perp with
// E[cos^2] = 2/3 and E[cos sin] = 0. With v' = v - 2 alpha (g.n) n (Bisi-Spiga eq. 3):
//   momentum:  d<v>/dt = K <|g| (-2 alpha)(2/3) g>_w,
//   energy:    d<v^2/2>/dt = K <|g| (4/3) alpha (alpha |g|^2 - v.g)>_w,
// both components of the momentum (a one-sided impact parameter would turn the grains
// sideways, a mirror asymmetry invisible to the rate and the energy); the rate against the
// Rice mean (medium_rate above). Plain Monte Carlo with std::mt19937_64 over w.
TEST(EdmdPhysics, DiskMediumOperatorMatchesItsCollisionIntegral) {
  struct Case {
    double alpha, TB, K;
    Vec3 uB, v;
  };
  for (const Case& k : {Case{0.3, 1.0, 2.0, {0.2, -0.1, 0.0}, {1.0, 0.5, 0.0}},
                        Case{0.7, 0.5, 1.0, {0.0, 0.0, 0.0}, {-0.3, 1.6, 0.0}}}) {
    SCOPED_TRACE(k.alpha);
    const BackgroundState b = BackgroundState::make(k.K, 1.0, k.uB, k.TB, k.alpha, 1.0);
    const double s = std::sqrt(k.TB * (1 - k.alpha) / k.alpha);  // sqrt(TB / mB), mB = alpha / (1 - alpha)
    const int trials = 2'000'000;
    CounterRng rng(17, Stream::edmd_collisions, 3, 0);
    const double majorant = background_majorant_rate_2d(k.v, b);
    double hits = 0, dx = 0, dx2 = 0, dy = 0, dy2 = 0, de = 0, de2 = 0;
    for (int t = 0; t < trials; ++t) {
      Vec3 v = k.v;
      double gain = 0;
      if (!attempt_background_collision_2d(v, b, 1.0, rng, gain)) continue;
      ASSERT_EQ(v.z, 0.0);
      hits += 1;
      const Vec3 d = v - k.v;
      dx += d.x, dx2 += d.x * d.x, dy += d.y, dy2 += d.y * d.y, de += gain, de2 += gain * gain;
    }
    auto op = [&](double sum, double sum2) {
      const double m = sum / trials;
      return std::pair{majorant * m, majorant * std::sqrt((sum2 / trials - m * m) / trials)};
    };
    std::mt19937_64 gen(2024);
    std::normal_distribution<double> z(0.0, 1.0);
    double rx = 0, rx2 = 0, ry = 0, ry2 = 0, re = 0, re2 = 0;
    for (int t = 0; t < trials; ++t) {
      const Vec3 w{k.uB.x + s * z(gen), k.uB.y + s * z(gen), 0.0};
      const Vec3 g = k.v - w;
      const double gm = norm(g);
      const double mx = k.K * gm * (-4.0 / 3.0) * k.alpha * g.x, my = k.K * gm * (-4.0 / 3.0) * k.alpha * g.y;
      const double e = k.K * gm * (4.0 / 3.0) * k.alpha * (k.alpha * gm * gm - dot(k.v, g));
      rx += mx, rx2 += mx * mx, ry += my, ry2 += my * my, re += e, re2 += e * e;
    }
    auto ref = [&](double sum, double sum2) {
      const double m = sum / trials;
      return std::pair{m, std::sqrt((sum2 / trials - m * m) / trials)};
    };
    const double f = hits / trials;
    const double rate = majorant * f, rate_err = majorant * std::sqrt(f * (1 - f) / trials);
    EXPECT_NEAR(rate, medium_rate(2, k.v - k.uB, k.K, s), 5 * rate_err) << "rate";
    const char* names[3] = {"momentum x", "momentum y", "energy"};
    const std::pair<double, double> got[3] = {op(dx, dx2), op(dy, dy2), op(de, de2)};
    const std::pair<double, double> want[3] = {ref(rx, rx2), ref(ry, ry2), ref(re, re2)};
    for (int q = 0; q < 3; ++q) {
      std::printf("disk medium, alpha %.1f, %s: operator %.5f +- %.5f, integral %.5f +- %.5f\n", k.alpha, names[q],
                  got[q].first, got[q].second, want[q].first, want[q].second);
      EXPECT_NEAR(got[q].first, want[q].first, 5 * std::hypot(got[q].second, want[q].second)) << names[q];
    }
  }
}
