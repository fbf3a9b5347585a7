// The background operator against independent evaluations of its own collision integral:
//  - the collision rate nu(v) = K Integral |v - w| M_B(w) d3w by GSL quadrature of the
//    angle-averaged |v - w| (closed form) over the Maxwellian radial density;
//  - the momentum and energy exchange rates by plain Monte Carlo over Maxwellian partners
//    with the apse averages E[(g.n) n] = g/2, E[(g.n)^2] = |g|^2/2 (apse density
//    |g.n|/(2 pi |g|)), independent of the code's thinning and apse sampling;
//  - detailed balance: many collisions relax a grain population to a Maxwellian at TB.
#include <gsl/gsl_integration.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <functional>
#include <cstdio>
#include <vector>
#include <numbers>

#include "operators/background.hpp"
#include "operators/random.hpp"

using namespace grainbath;
using detail::BathZigguratLayers;
using detail::kBathExponentialLayers;
using detail::kBathNormalLayers;

namespace {

double rate_by_quadrature(double c, double sigma, double K) {
  struct P {
    double c, sigma;
  } p{c, sigma};
  gsl_function F;
  F.function = [](double w, void* vp) {
    const P& q = *static_cast<P*>(vp);
    const double m = std::pow(2 * std::numbers::pi * q.sigma * q.sigma, -1.5) * std::exp(-w * w / (2 * q.sigma * q.sigma));
    double avg;  // angle average of |c - w|
    if (w < 1e-12) avg = q.c;
    else if (q.c < 1e-12) avg = w;
    else avg = (std::pow(q.c + w, 3) - std::pow(std::abs(q.c - w), 3)) / (6 * q.c * w);
    return 4 * std::numbers::pi * w * w * m * avg;
  };
  F.params = &p;
  gsl_integration_workspace* ws = gsl_integration_workspace_alloc(1000);
  double result, err;
  gsl_integration_qagiu(&F, 0.0, 1e-13, 1e-12, 1000, ws, &result, &err);
  gsl_integration_workspace_free(ws);
  return K * result;
}

struct Case {
  double alpha, TB, nB, eps, m;
  Vec3 uB, v;
};

}  // namespace

class BackgroundIntegral : public ::testing::TestWithParam<Case> {};

TEST_P(BackgroundIntegral, RateMomentumAndEnergyExchange) {
  const Case k = GetParam();
  const BackgroundState b = BackgroundState::make(k.nB, k.eps, k.uB, k.TB, k.alpha, k.m);
  const double K = k.nB / k.eps;
  const int trials = 2'000'000;

  // operator: repeated thinning attempts from the same grain velocity, by the general
  // attempt (EDMD) and by the DSMC bath kernel's test (background_test), each checked
  // against the same independent references
  // and by the fixed-budget kernel's test (bath_variates + bath_test, test t of one grain)
  for (const int kernel : {0, 1, 2}) {
  const bool dsmc_kernel = kernel == 1;
  SCOPED_TRACE(kernel == 2   ? "bath_test (fixed-budget DSMC kernel)"
               : dsmc_kernel ? "background_test (DSMC kernel)"
                             : "attempt_background_collision");
  CounterRng rng(99, Stream::background_first_half, 0, 0);
  const BathKey key{99, Stream::background_first_half, 5};
  const double majorant = background_majorant_rate(k.v, b);
  double acc = 0, dvx = 0, dvy = 0, dvz = 0, de = 0, de2 = 0, dvx2 = 0;
  for (int t = 0; t < trials; ++t) {
    Vec3 v = k.v;
    double gain = 0;
    Vec3 c = k.v - k.uB;
    double cmod = norm(c);
    bool hit;
    if (kernel == 2) {
      std::uint64_t w[8];
      BathVariates x;
      detail::bath_words(key, 17, static_cast<std::uint64_t>(t), w);
      detail::bath_variates(w, key, 17, static_cast<std::uint64_t>(t), x);
      hit = detail::bath_test(x, v, c, cmod, b, k.m, gain);
    } else {
      hit = dsmc_kernel ? background_test(v, c, cmod, b, k.m, rng, gain)
                        : attempt_background_collision(v, b, k.m, rng, gain);
    }
    if (kernel != 0 && hit) {
      EXPECT_EQ(c.x, v.x - k.uB.x);  // the kernel keeps c = v - uB and |c| current
      EXPECT_DOUBLE_EQ(cmod, norm(v - k.uB));
    }
    if (hit) {
      acc += 1;
      const Vec3 d = v - k.v;
      dvx += d.x;
      dvy += d.y;
      dvz += d.z;
      dvx2 += d.x * d.x;
      de += gain;
      de2 += gain * gain;
    }
  }
  const double f = acc / trials;
  const double rate_op = majorant * f, rate_err = majorant * std::sqrt(f * (1 - f) / trials);
  const double rate_ref = rate_by_quadrature(norm(k.v - k.uB), b.sigma, K);
  EXPECT_NEAR(rate_op, rate_ref, 5 * rate_err) << "rate";

  // reference: plain Monte Carlo over Maxwellian partners with exact apse averages
  CounterRng ref(7, Stream::initial_velocities, 0, 0);
  const int ref_trials = 2'000'000;
  double mx = 0, mx2 = 0, my = 0, mz = 0, en = 0, en2 = 0;
  for (int t = 0; t < ref_trials; ++t) {
    const Vec3 w = k.uB + b.sigma * ref.normal3();
    const Vec3 g = k.v - w;
    const double gm = norm(g);
    const Vec3 dv = (-k.alpha * K * gm) * g;  // K |g| (-2 alpha) E[(g.n) n]
    const double e = K * gm * 0.5 * k.m * (-2 * k.alpha * dot(k.v, g) + 2 * k.alpha * k.alpha * gm * gm);
    mx += dv.x;
    mx2 += dv.x * dv.x;
    my += dv.y;
    mz += dv.z;
    en += e;
    en2 += e * e;
  }
  const double mom_ref = mx / ref_trials, mom_ref_err = std::sqrt((mx2 / ref_trials - mom_ref * mom_ref) / ref_trials);
  const double mom_op = majorant * dvx / trials,
               mom_op_err = majorant * std::sqrt((dvx2 / trials - (dvx / trials) * (dvx / trials)) / trials);
  EXPECT_NEAR(mom_op, mom_ref, 5 * std::hypot(mom_op_err, mom_ref_err)) << "momentum exchange (x)";
  const double en_ref = en / ref_trials, en_ref_err = std::sqrt((en2 / ref_trials - en_ref * en_ref) / ref_trials);
  const double en_op = majorant * de / trials,
               en_op_err = majorant * std::sqrt((de2 / trials - (de / trials) * (de / trials)) / trials);
  EXPECT_NEAR(en_op, en_ref, 5 * std::hypot(en_op_err, en_ref_err)) << "energy exchange";
  (void)my;
  (void)mz;
  (void)dvy;
  (void)dvz;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Cases, BackgroundIntegral,
    ::testing::Values(Case{0.5, 1.0, 1.0, 1.0, 1.0, {0, 0, 0}, {1.0, 0.0, 0.0}},
                      Case{0.2, 1.0, 2.0, 0.1, 1.0, {0.3, 0, 0}, {2.5, -1.0, 0.5}},
                      Case{0.8, 2.0, 1.0, 0.5, 2.0, {0, 0, 1}, {-0.5, 0.2, 3.0}},
                      Case{0.5, 0.5, 1.0, 1.0, 1.0, {0, 0, 0}, {0.0, 0.0, 0.0}}));

// Detailed balance: the linear elastic operator's equilibrium is a Maxwellian at (uB, TB)
// with the grain mass (Bisi-Spiga eq. 15), whatever the initial velocities.
TEST(BackgroundEvolution, RelaxesToBackgroundMaxwellian) {
  const double alpha = 0.3, TB = 1.7, m = 1.0;
  const Vec3 uB{0.5, 0, -0.2};
  const BackgroundState b = BackgroundState::make(1.0, 1.0, uB, TB, alpha, m);
  const int grains = 200'000;
  double sx = 0, s2 = 0, s4 = 0;
  BackgroundCounters counters;
  for (int i = 0; i < grains; ++i) {
    CounterRng rng(1, Stream::background_first_half, i, 0);
    Vec3 v{3.0, 0.0, 0.0};  // far from equilibrium
    evolve_in_background(v, b, m, 30.0, rng, counters);
    const Vec3 c = v - uB;
    sx += c.x;
    s2 += norm2(c);
    s4 += norm2(c) * norm2(c);
  }
  const double th = TB / m;
  EXPECT_NEAR(sx / grains, 0.0, 5 * std::sqrt(th / grains));
  EXPECT_NEAR(m * s2 / grains / 3, TB, 5 * TB * std::sqrt(2.0 / 3 / grains));
  // <c^4> = 15 th^2 for a Maxwellian; relative std of c^4 is sqrt(945/225 - 1)
  EXPECT_NEAR(s4 / grains / (15 * th * th), 1.0, 5 * std::sqrt(945.0 / 225 - 1) / std::sqrt(grains));
  EXPECT_GT(counters.collisions, 20u * grains);
  EXPECT_LE(counters.collisions, counters.candidates);
}

// The carried residual (evolve_in_background with a per-grain hazard): grains drawn from
// the stationary Maxwellian at (uB, TB) and evolved through many short substeps, the
// unit-exponential residual carried from one to the next, must see candidates at the mean
// majorant rate K (<|c|> + <|c_w|>) and collisions at the mean true rate K <|g|>, with
// <|c|> = sqrt(8 TB / (pi m)), <|c_w|> = sqrt(8 TB / (pi mB)) and <|g|> = sqrt(8 TB (1/m +
// 1/mB) / pi) for two Maxwellians at TB (textbook mean speeds, not the code's majorant), and
// stay at TB. A residual that is not reduced by the hazard of an event-free substep, or
// is reset to a non-exponential value, shifts the candidate count.
TEST(BackgroundEvolution, CarriedResidualKeepsTheRatesAcrossSubsteps) {
  const double alpha = 0.4, TB = 1.3, m = 1.0, K = 5.0;
  const BackgroundState b = BackgroundState::make(K, 1.0, {0.2, 0.0, 0.0}, TB, alpha, m);
  const double mB = background_mass(alpha, m);
  const int grains = 100'000, substeps = 16;
  const double T = 0.8, dt = T / substeps;
  BackgroundCounters counters;
  double s2 = 0;
  std::vector<double> cand(grains);
  for (int i = 0; i < grains; ++i) {
    CounterRng init(3, Stream::initial_velocities, i, 0);
    Vec3 v = b.velocity + std::sqrt(TB / m) * init.normal3();
    double hazard = init.exponential();
    const std::uint64_t before = counters.candidates;
    for (int s = 0; s < substeps; ++s) {
      CounterRng rng(3, s % 2 ? Stream::background_second_half : Stream::background_first_half, i, s / 2);
      evolve_in_background(v, hazard, b, m, dt, rng, counters);
    }
    cand[i] = static_cast<double>(counters.candidates - before);
    s2 += norm2(v - b.velocity);
  }
  const double mean_c = std::sqrt(8 * TB / (std::numbers::pi * m)), mean_w = std::sqrt(8 * TB / (std::numbers::pi * mB));
  const double mean_g = std::sqrt(8 * TB * (1 / m + 1 / mB) / std::numbers::pi);
  double cm = 0, cv = 0;
  for (double x : cand) cm += x;
  cm /= grains;
  for (double x : cand) cv += (x - cm) * (x - cm);
  cv /= grains - 1;
  std::printf("carried residual: candidates per grain %.5f +- %.5f (expected %.5f), collisions %.5f (expected %.5f)\n", cm,
              std::sqrt(cv / grains), K * (mean_c + mean_w) * T, static_cast<double>(counters.collisions) / grains,
              K * mean_g * T);
  EXPECT_NEAR(cm, K * (mean_c + mean_w) * T, 5 * std::sqrt(cv / grains));
  // collisions: a Poisson count per grain at most as variable as the candidates
  EXPECT_NEAR(static_cast<double>(counters.collisions) / grains, K * mean_g * T, 5 * std::sqrt(cv / grains));
  EXPECT_NEAR(m * s2 / grains / 3, TB, 5 * TB * std::sqrt(2.0 / 3 / grains));
}

// The fixed-budget kernel (bath_evolve_keyed per grain, bath_evolve_batch over arrays):
// detailed balance as above, from one far-from-equilibrium velocity, through many substeps
// with the carried residual.
TEST(BathKernel, RelaxesToBackgroundMaxwellian) {
  const double alpha = 0.3, TB = 1.7, m = 1.0;
  const Vec3 uB{0.5, 0, -0.2};
  const BackgroundState b = BackgroundState::make(1.0, 1.0, uB, TB, alpha, m);
  const std::size_t grains = 200'000;
  std::vector<double> vx(grains, 3.0), vy(grains, 0.0), vz(grains, 0.0), hz(grains);
  std::vector<std::uint64_t> id(grains);
  for (std::size_t i = 0; i < grains; ++i) {
    id[i] = i;
    hz[i] = CounterRng(1, Stream::background_clock, i, 0).exponential_ziggurat();
  }
  BackgroundCounters counters;
  for (int s = 0; s < 20; ++s)  // 20 substeps of 1.5: t = 30 as above
    bath_evolve_batch(grains, id.data(), vx.data(), vy.data(), vz.data(), hz.data(), b, m, 1.5,
                      BathKey{1, Stream::background_first_half, static_cast<std::uint64_t>(s)}, counters);
  double sx = 0, s2 = 0, s4 = 0;
  for (std::size_t i = 0; i < grains; ++i) {
    const Vec3 c = Vec3{vx[i], vy[i], vz[i]} - uB;
    sx += c.x;
    s2 += norm2(c);
    s4 += norm2(c) * norm2(c);
  }
  const double th = TB / m, n = static_cast<double>(grains);
  EXPECT_NEAR(sx / n, 0.0, 5 * std::sqrt(th / n));
  EXPECT_NEAR(m * s2 / n / 3, TB, 5 * TB * std::sqrt(2.0 / 3 / n));
  EXPECT_NEAR(s4 / n / (15 * th * th), 1.0, 5 * std::sqrt(945.0 / 225 - 1) / std::sqrt(n));
  EXPECT_GT(counters.collisions, 20u * grains);
  EXPECT_LE(counters.collisions, counters.candidates);
}

// The carried-residual rates (as CarriedResidualKeepsTheRatesAcrossSubsteps) for the
// fixed-budget kernel, run by bath_evolve_batch: candidates at K (<|c|> + <|c_w|>), collisions
// at K <|g|>, temperature kept at TB.
TEST(BathKernel, CarriedResidualKeepsTheRatesAcrossSubsteps) {
  const double alpha = 0.4, TB = 1.3, m = 1.0, K = 5.0;
  const BackgroundState b = BackgroundState::make(K, 1.0, {0.2, 0.0, 0.0}, TB, alpha, m);
  const double mB = background_mass(alpha, m);
  const std::size_t grains = 100'000;
  const int substeps = 16;
  const double T = 0.8, dt = T / substeps;
  std::vector<double> vx(grains), vy(grains), vz(grains), hz(grains);
  std::vector<std::uint64_t> id(grains);
  for (std::size_t i = 0; i < grains; ++i) {
    CounterRng init(3, Stream::initial_velocities, i, 0);
    const Vec3 v = b.velocity + std::sqrt(TB / m) * init.normal3();
    vx[i] = v.x;
    vy[i] = v.y;
    vz[i] = v.z;
    hz[i] = init.exponential();
    id[i] = i;
  }
  // candidates per grain, one grain at a time through the same substeps (bath_evolve_keyed)
  std::vector<double> cand(grains);
  BackgroundCounters counters;
  for (std::size_t i = 0; i < grains; i += 1000) {
    for (int s = 0; s < substeps; ++s) {
      const BathKey key{3, s % 2 ? Stream::background_second_half : Stream::background_first_half,
                        static_cast<std::uint64_t>(s / 2)};
      bath_evolve_batch(1000, id.data() + i, vx.data() + i, vy.data() + i, vz.data() + i, hz.data() + i, b, m, dt, key,
                        counters);
    }
  }
  // per-grain candidate variance from a second, keyed run of a subset
  const std::size_t sub = 20'000;
  double cm = 0, cv = 0;
  for (std::size_t i = 0; i < sub; ++i) {
    CounterRng init(3, Stream::initial_velocities, i, 0);
    Vec3 v = b.velocity + std::sqrt(TB / m) * init.normal3();
    double hazard = init.exponential();
    BackgroundCounters one;
    for (int s = 0; s < substeps; ++s) {
      const BathKey key{3, s % 2 ? Stream::background_second_half : Stream::background_first_half,
                        static_cast<std::uint64_t>(s / 2)};
      double gain;
      bath_evolve_keyed(v, hazard, b, m, dt, key, i, one, gain);
    }
    cand[i] = static_cast<double>(one.candidates);
    cm += cand[i];
  }
  cm /= sub;
  for (std::size_t i = 0; i < sub; ++i) cv += (cand[i] - cm) * (cand[i] - cm);
  cv /= sub - 1;
  const double n = static_cast<double>(grains);
  const double mean_c = std::sqrt(8 * TB / (std::numbers::pi * m)), mean_w = std::sqrt(8 * TB / (std::numbers::pi * mB));
  const double mean_g = std::sqrt(8 * TB * (1 / m + 1 / mB) / std::numbers::pi);
  const double per_grain = static_cast<double>(counters.candidates) / n;
  std::printf("bath kernel: candidates per grain %.5f +- %.5f (expected %.5f), collisions %.5f (expected %.5f)\n",
              per_grain, std::sqrt(cv / n), K * (mean_c + mean_w) * T, static_cast<double>(counters.collisions) / n,
              K * mean_g * T);
  EXPECT_NEAR(per_grain, K * (mean_c + mean_w) * T, 5 * std::sqrt(cv / n));
  EXPECT_NEAR(static_cast<double>(counters.collisions) / n, K * mean_g * T, 5 * std::sqrt(cv / n));
  double s2 = 0;
  for (std::size_t i = 0; i < grains; ++i) s2 += norm2(Vec3{vx[i], vy[i], vz[i]} - b.velocity);
  EXPECT_NEAR(m * s2 / n / 3, TB, 5 * TB * std::sqrt(2.0 / 3 / n));
}

// Two bath substeps of dt/2 (the residual carried) and one of dt are the same process in law:
// the driver joins the second half of a step to the first half of the next
// (src/dsmc/driver.cpp, Stream::background_joined_halves). Grains all start at one velocity
// far from the bath (so the law after dt depends on how many collisions happened and when),
// about two collisions each over dt; the two ways are run with independent streams and the
// means of vx, |v|^2, |v|^4, the residual and the candidate and collision counts per grain
// must agree within 5 combined standard errors (measured from the samples).
TEST(BathKernel, TwoHalfSubstepsAndOneWholeAgreeInLaw) {
  const double alpha = 0.4, TB = 1.0, m = 1.0, K = 1.0, dt = 0.8;
  const BackgroundState b = BackgroundState::make(K, 1.0, {0.3, 0.0, 0.0}, TB, alpha, m);
  const std::size_t grains = 200'000;
  struct Run {
    std::vector<double> vx, vy, vz, hz, cand, coll;
  };
  auto run = [&](bool joined) {
    Run r;
    r.vx.assign(grains, 1.8);
    r.vy.assign(grains, -0.4);
    r.vz.assign(grains, 0.2);
    r.hz.resize(grains);
    r.cand.resize(grains);
    r.coll.resize(grains);
    for (std::size_t i = 0; i < grains; ++i) r.hz[i] = CounterRng(5, Stream::background_clock, i, 0).exponential();
    for (std::size_t i = 0; i < grains; ++i) {  // one grain at a time, for its own counts
      BackgroundCounters one;
      for (int h = 0; h < (joined ? 1 : 2); ++h) {
        const BathKey key{5, joined ? Stream::background_joined_halves
                                    : (h ? Stream::background_second_half : Stream::background_first_half),
                          0};
        const std::uint64_t gid = i;
        bath_evolve_batch(1, &gid, &r.vx[i], &r.vy[i], &r.vz[i], &r.hz[i], b, m, joined ? dt : 0.5 * dt, key, one);
      }
      r.cand[i] = static_cast<double>(one.candidates);
      r.coll[i] = static_cast<double>(one.collisions);
    }
    return r;
  };
  const Run halves = run(false), whole = run(true);
  auto mean_err = [&](auto f, const Run& r) {
    double s = 0, s2 = 0;
    for (std::size_t i = 0; i < grains; ++i) {
      const double x = f(r, i);
      s += x;
      s2 += x * x;
    }
    const double n = static_cast<double>(grains), mu = s / n;
    return std::pair{mu, std::sqrt((s2 / n - mu * mu) / (n - 1))};
  };
  auto sq = [](const Run& r, std::size_t i) { return r.vx[i] * r.vx[i] + r.vy[i] * r.vy[i] + r.vz[i] * r.vz[i]; };
  const std::pair<const char*, std::function<double(const Run&, std::size_t)>> observables[] = {
      {"vx", [](const Run& r, std::size_t i) { return r.vx[i]; }},
      {"|v|^2", sq},
      {"|v|^4", [&](const Run& r, std::size_t i) { return sq(r, i) * sq(r, i); }},
      {"residual", [](const Run& r, std::size_t i) { return r.hz[i]; }},
      {"candidates", [](const Run& r, std::size_t i) { return r.cand[i]; }},
      {"collisions", [](const Run& r, std::size_t i) { return r.coll[i]; }}};
  for (const auto& [name, f] : observables) {
    const auto [a, ea] = mean_err(f, halves);
    const auto [w, ew] = mean_err(f, whole);
    std::printf("joined halves: %-10s two halves %.5f +- %.5f, one substep %.5f +- %.5f\n", name, a, ea, w, ew);
    EXPECT_NEAR(a, w, 5 * std::hypot(ea, ew)) << name;
  }
  // the start is far from the bath: the comparison is not between two equilibria
  EXPECT_LT(mean_err(observables[0].second, halves).first, 1.6);
  EXPECT_GT(mean_err(observables[0].second, halves).first, 0.5);
  EXPECT_GT(mean_err(observables[5].second, halves).first, 1.0);
}

// The batch kernel's instruction-set paths (operators/background_lanes.inc: two lanes in
// SSE2, four in AVX2), called directly; the AVX2 one only where the CPU has it.
namespace {
using BatchPath = void (*)(std::size_t, const std::uint64_t*, double*, double*, double*, double*,
                           const BackgroundState&, double, double, const BathKey&, BackgroundCounters&);
struct NamedBatchPath {
  const char* name;
  BatchPath run;
};
std::vector<NamedBatchPath> batch_paths() {
  std::vector<NamedBatchPath> paths{{"sse2", detail::bath_sse2::evolve_batch}};
  if (__builtin_cpu_supports("avx2")) paths.push_back({"avx2", detail::bath_avx2::evolve_batch});
  return paths;
}
}  // namespace

// The interleaved kernel is the per-grain kernel: bitwise the same velocities, residuals and
// counters (energy summed grain by grain in order), for block sizes that are not multiples
// of the lane count (2 or 4) or the chunk, ids that are not 0..n-1, a residual that runs out
// immediately, a grain at rest in the bath frame, and many tests per grain; on every
// instruction-set path of the batch kernel.
TEST(BathKernel, InterleavedEqualsPerGrainBitwise) {
  const BackgroundState b = BackgroundState::make(2.0, 0.05, {0.1, -0.3, 0.2}, 1.4, 0.6, 1.3);
  for (const NamedBatchPath& path : batch_paths())
  for (const std::size_t n : {1u, 2u, 3u, 5u, 6u, 7u, 255u, 257u, 258u, 1031u}) {
    SCOPED_TRACE(path.name);
    SCOPED_TRACE(n);
    std::vector<double> vx(n), vy(n), vz(n), hz(n);
    std::vector<std::uint64_t> id(n);
    for (std::size_t i = 0; i < n; ++i) {
      CounterRng r(11, Stream::initial_velocities, i, 0);
      vx[i] = 2 * r.normal();
      vy[i] = r.normal();
      vz[i] = r.normal();
      hz[i] = i % 7 == 3 ? 1e3 : r.exponential();
      id[i] = 1000003 * i + (std::uint64_t{1} << 40);
    }
    vx[n / 2] = b.velocity.x, vy[n / 2] = b.velocity.y, vz[n / 2] = b.velocity.z;
    auto kx = vx, ky = vy, kz = vz, kh = hz;
    BackgroundCounters batch, keyed;
    for (int s = 0; s < 3; ++s) {
      const BathKey key{11, Stream::background_second_half, static_cast<std::uint64_t>(s)};
      path.run(n, id.data(), vx.data(), vy.data(), vz.data(), hz.data(), b, 1.3, 0.2, key, batch);
      for (std::size_t i = 0; i < n; ++i) {
        Vec3 v{kx[i], ky[i], kz[i]};
        double gain;
        bath_evolve_keyed(v, kh[i], b, 1.3, 0.2, key, id[i], keyed, gain);
        keyed.energy_gain += gain;
        kx[i] = v.x, ky[i] = v.y, kz[i] = v.z;
      }
    }
    EXPECT_GT(keyed.candidates, 20 * n);
    EXPECT_EQ(batch.candidates, keyed.candidates);
    EXPECT_EQ(batch.collisions, keyed.collisions);
    EXPECT_EQ(batch.energy_gain, keyed.energy_gain);
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_EQ(vx[i], kx[i]) << i;
      ASSERT_EQ(vy[i], ky[i]) << i;
      ASSERT_EQ(vz[i], kz[i]) << i;
      ASSERT_EQ(hz[i], kh[i]) << i;
    }
  }
}

// Two runs of the bath kernels ended bitwise alike: the same counters (the energy sum to the
// last bit) and, grain by grain, the same vx, vy, vz and residual.
using GrainArrays = std::array<const std::vector<double>*, 4>;
void expect_same_bits(const BackgroundCounters& got, const GrainArrays& got_grains, const BackgroundCounters& want,
                      const GrainArrays& want_grains) {
  EXPECT_EQ(got.candidates, want.candidates);
  EXPECT_EQ(got.collisions, want.collisions);
  EXPECT_EQ(std::bit_cast<std::uint64_t>(got.energy_gain), std::bit_cast<std::uint64_t>(want.energy_gain));
  const char* names[4] = {"vx", "vy", "vz", "residual"};
  for (std::size_t a = 0; a < 4; ++a)
    for (std::size_t i = 0; i < want_grains[a]->size(); ++i)
      ASSERT_EQ(std::bit_cast<std::uint64_t>((*got_grains[a])[i]), std::bit_cast<std::uint64_t>((*want_grains[a])[i]))
          << names[a] << " of grain " << i;
}

// Grains each in its own medium (bath_evolve_batch_local, a background varying in space) are
// the per-grain kernel with each grain's BackgroundState: bitwise the same velocities,
// residuals and counters, on every instruction-set path. The media differ in every field
// (density and Knudsen number, drift, temperature, mass ratio), one in ten has no background
// (rate_scale 0: the grain keeps its velocity and residual), neighbours are very hot and
// very cold media (different numbers of tests, so the compaction moves each lane's medium),
// and a grain at rest in its medium's frame. Fails if a lane takes another grain's medium
// (the compaction or the padding of the medium arrays) or a uniform field.
using LocalBatchPath = void (*)(std::size_t, const std::uint64_t*, double*, double*, double*, double*,
                                const BackgroundState*, double, double, const BathKey&, BackgroundCounters&);
TEST(BathKernel, LocalMediaEqualPerGrainBitwise) {
  std::vector<std::pair<const char*, LocalBatchPath>> paths{{"sse2", detail::bath_sse2::evolve_batch_local}};
  if (__builtin_cpu_supports("avx2")) paths.emplace_back("avx2", detail::bath_avx2::evolve_batch_local);
  paths.emplace_back("dispatched", bath_evolve_batch_local);
  for (const auto& [name, run] : paths)
    for (const std::size_t n : {1u, 2u, 3u, 5u, 7u, 255u, 257u, 1031u}) {
      SCOPED_TRACE(name);
      SCOPED_TRACE(n);
      std::vector<double> vx(n), vy(n), vz(n), hz(n);
      std::vector<std::uint64_t> id(n);
      std::vector<BackgroundState> media(n);
      for (std::size_t i = 0; i < n; ++i) {
        CounterRng r(17, Stream::initial_velocities, i, 0);
        const double hot = i % 2 == 0 ? 3.0 : 0.2;  // neighbours in very different media
        media[i] = BackgroundState::make(i % 10 == 4 ? 0.0 : 0.5 + r.uniform(), 0.02 + 0.1 * r.uniform(),
                                         {0.5 * r.normal(), 0.5 * r.normal(), 0.5 * r.normal()}, hot * (0.5 + r.uniform()),
                                         0.2 + 0.6 * r.uniform(), 1.3);
        vx[i] = 2 * r.normal();
        vy[i] = r.normal();
        vz[i] = r.normal();
        hz[i] = i % 7 == 3 ? 1e3 : r.exponential();
        id[i] = 1000003 * i + (std::uint64_t{1} << 40);
      }
      vx[n / 2] = media[n / 2].velocity.x, vy[n / 2] = media[n / 2].velocity.y, vz[n / 2] = media[n / 2].velocity.z;
      auto kx = vx, ky = vy, kz = vz, kh = hz;
      BackgroundCounters batch, keyed;
      for (int s = 0; s < 3; ++s) {
        const BathKey key{17, Stream::background_first_half, static_cast<std::uint64_t>(s)};
        run(n, id.data(), vx.data(), vy.data(), vz.data(), hz.data(), media.data(), 1.3, 0.2, key, batch);
        for (std::size_t i = 0; i < n; ++i) {
          Vec3 v{kx[i], ky[i], kz[i]};
          double gain;
          bath_evolve_keyed(v, kh[i], media[i], 1.3, 0.2, key, id[i], keyed, gain);
          keyed.energy_gain += gain;
          kx[i] = v.x, ky[i] = v.y, kz[i] = v.z;
        }
      }
      EXPECT_GT(keyed.candidates, 10 * n);
      expect_same_bits(batch, {&vx, &vy, &vz, &hz}, keyed, {&kx, &ky, &kz, &kh});
    }
}

// The lane compaction of the batch kernel's active grains (compact, compact_ints): for
// every mask, the marked lanes come first, in order, bitwise (doubles and int32), on both
// paths.
// (memory in, memory out: 256-bit vectors stay inside the AVX2 function)
using CompactInMemory = void (*)(const double*, const std::int32_t*, unsigned, double*, std::int32_t*);
void compact_sse2(const double* x, const std::int32_t* ints, unsigned keep, double* out, std::int32_t* out_ints) {
  using namespace detail::bath_sse2;
  lanes_store(out, compact(lanes_load(x), keep));
  _mm_storeu_si128(reinterpret_cast<__m128i*>(out_ints),
                   compact_ints(_mm_loadu_si128(reinterpret_cast<const __m128i*>(ints)), keep));
}
[[gnu::target("avx2")]] void compact_avx2(const double* x, const std::int32_t* ints, unsigned keep, double* out,
                                          std::int32_t* out_ints) {
  using namespace detail::bath_avx2;
  lanes_store(out, compact(lanes_load(x), keep));
  _mm_storeu_si128(reinterpret_cast<__m128i*>(out_ints),
                   compact_ints(_mm_loadu_si128(reinterpret_cast<const __m128i*>(ints)), keep));
}
void check_compaction(CompactInMemory run, std::size_t lanes) {
  for (unsigned keep = 0; keep < (1u << lanes); ++keep) {
    SCOPED_TRACE(keep);
    const std::int32_t ints[4] = {11, -22, 33, -44};
    double x[4], got[4];
    std::int32_t got_ints[4];
    for (std::size_t j = 0; j < 4; ++j) x[j] = std::ldexp(1.0 + static_cast<double>(j) / 8, -1000 + 7 * static_cast<int>(j));
    run(x, ints, keep, got, got_ints);
    std::size_t front = 0;
    for (std::size_t j = 0; j < lanes; ++j)
      if (keep >> j & 1) {
        EXPECT_EQ(std::bit_cast<std::uint64_t>(got[front]), std::bit_cast<std::uint64_t>(x[j]));
        EXPECT_EQ(got_ints[front], ints[j]);
        ++front;
      }
  }
}
TEST(BathKernel, CompactionKeepsMarkedLanesInOrder) {
  check_compaction(compact_sse2, 2);
  if (!__builtin_cpu_supports("avx2")) GTEST_SKIP() << "this CPU has no AVX2: only the SSE2 path exists";
  check_compaction(compact_avx2, 4);
}

// The AVX2 path (four lanes) against the SSE2 path (two lanes) and the scalar code of the
// per-grain kernel, bitwise: the variates (uniform, ziggurat fast values and slow-path
// flags, directions) of 2^16 random words and of the quadrant, z and layer edges in every
// half and lane position; and the batch kernel over 20,001 grains (odd, not a multiple of 4
// or of the chunk) in a drifting medium through 6 substeps, with hot grains (many tests
// each) and slow ones.
TEST(BathKernel, AvxAndSse2PathsEqualBitwise) {
  if (!__builtin_cpu_supports("avx2")) GTEST_SKIP() << "this CPU has no AVX2: only the SSE2 path exists";
  std::vector<std::uint64_t> words;
  for (const std::uint64_t hi : {0x00000000u, 0x3fffffffu, 0x40000000u, 0x7fffffffu, 0x80000000u, 0xbfffffffu,
                                 0xc0000000u, 0xffffffffu, 0x20000000u, 0x1fffffffu, 0x000007ffu, 0xfffff800u})
    for (const std::uint64_t lo : {0x00000000u, 0x7fffffffu, 0x80000000u, 0xffffffffu, 0x12345678u, 0x000003ffu})
      words.push_back(hi << 32 | lo);
  const std::size_t edges = words.size();
  for (std::size_t k = 0; k < edges; ++k)  // every edge word at every word position of a test
    for (std::size_t pos = 0; pos < 4; ++pos) words.push_back(pos == 0 ? words[k] : std::rotl(words[k], 17 * int(pos)));
  CounterRng r(5, Stream::initial_velocities, 1, 0);
  while (words.size() % 16 != 0 || words.size() < (1u << 16)) words.push_back(r.bits64());
  auto bits = [](double x) { return std::bit_cast<std::uint64_t>(x); };
  for (std::size_t k = 0; k < words.size(); k += 16) {  // four grains' test words
    alignas(32) double avx[9][4], sse[9][4];
    unsigned avx_fail[5], sse_fail[5][2];
    {
      using namespace detail::bath_avx2;
      __m128i h[8];
      word_halves(words.data() + k, h);
      uniform_lanes(h[0], avx[0]);
      for (int v = 0; v < 4; ++v)
        avx_fail[v] = ziggurat_lanes(h[1 + v], detail::kBathZiggurat.normal, 2 * detail::BathZiggurat::L - 1, detail::BathZiggurat::B, avx[1 + v]);
      avx_fail[4] = ziggurat_lanes(h[5], detail::kBathZiggurat.exponential, detail::BathZiggurat::L - 1, detail::BathZiggurat::B - 1, avx[5]);
      direction_lanes(h[6], h[7], avx[6], avx[7], avx[8]);
    }
    for (int pair = 0; pair < 2; ++pair) {
      using namespace detail::bath_sse2;
      __m128i h[8];
      word_halves(words.data() + k + 8 * pair, h);
      uniform_lanes(h[0], sse[0] + 2 * pair);
      for (int v = 0; v < 4; ++v)
        sse_fail[v][pair] = ziggurat_lanes(h[1 + v], detail::kBathZiggurat.normal, 2 * detail::BathZiggurat::L - 1, detail::BathZiggurat::B, sse[1 + v] + 2 * pair);
      sse_fail[4][pair] = ziggurat_lanes(h[5], detail::kBathZiggurat.exponential, detail::BathZiggurat::L - 1, detail::BathZiggurat::B - 1, sse[5] + 2 * pair);
      direction_lanes(h[6], h[7], sse[6] + 2 * pair, sse[7] + 2 * pair, sse[8] + 2 * pair);
    }
    for (int v = 0; v < 5; ++v) ASSERT_EQ(avx_fail[v], sse_fail[v][0] | sse_fail[v][1] << 2) << v;
    for (int j = 0; j < 4; ++j) {
      const std::uint64_t* w = words.data() + k + 4 * j;
      for (int v = 0; v < 9; ++v) ASSERT_EQ(bits(avx[v][j]), bits(sse[v][j])) << v << " " << std::hex << w[0];
      // and the scalar code of bath_variates (the per-grain kernel)
      ASSERT_EQ(bits(avx[0][j]), bits(detail::bath_uniform(detail::bath_half(w, 0))));
      for (int v = 0; v < 5; ++v) {
        double fast;
        const unsigned slow = v < 4 ? detail::bath_normal_fast(detail::bath_half(w, 1 + v), fast)
                                    : detail::bath_exponential_fast(detail::bath_half(w, 5), fast);
        ASSERT_EQ((avx_fail[v] >> j) & 1u, slow) << v;
        ASSERT_EQ(bits(avx[1 + v][j]), bits(fast)) << v << " " << std::hex << w[0];
      }
      alignas(16) double rx[2], ry[2], rz[2];
      detail::bath_direction_lanes(w[3], w[3], rx, ry, rz);
      ASSERT_EQ(bits(avx[6][j]), bits(rx[0])) << std::hex << w[3];
      ASSERT_EQ(bits(avx[7][j]), bits(ry[0])) << std::hex << w[3];
      ASSERT_EQ(bits(avx[8][j]), bits(rz[0])) << std::hex << w[3];
    }
  }
  const BackgroundState b = BackgroundState::make(1.0, 0.01, {0.3, 0.0, -0.1}, 1.0, 0.5, 1.0);
  const std::size_t n = 20001;
  std::vector<double> vx(n), vy(n), vz(n), hz(n);
  std::vector<std::uint64_t> id(n);
  for (std::size_t i = 0; i < n; ++i) {
    CounterRng g(3, Stream::initial_velocities, i, 0);
    const double s = i % 3 == 0 ? 4.0 : 0.5;
    vx[i] = s * g.normal(), vy[i] = s * g.normal(), vz[i] = s * g.normal();
    hz[i] = g.exponential();
    id[i] = 7 * i + 3;
  }
  auto ax = vx, ay = vy, az = vz, ah = hz;
  BackgroundCounters sse2, avx2;
  for (int s = 0; s < 6; ++s) {
    const BathKey key{3, s % 2 ? Stream::background_second_half : Stream::background_first_half,
                      static_cast<std::uint64_t>(s / 2)};
    detail::bath_sse2::evolve_batch(n, id.data(), vx.data(), vy.data(), vz.data(), hz.data(), b, 1.0, 0.005, key, sse2);
    detail::bath_avx2::evolve_batch(n, id.data(), ax.data(), ay.data(), az.data(), ah.data(), b, 1.0, 0.005, key, avx2);
  }
  EXPECT_GT(sse2.candidates, 5 * n);
  expect_same_bits(avx2, {&ax, &ay, &az, &ah}, sse2, {&vx, &vy, &vz, &hz});
}

// The bath kernel's own ziggurat tables (2^B layers) close: every layer has the base
// layer's area (the bisection for r found the closing ziggurat), their total exceeds the
// area under the curve by the wedges (under 1%), and r lies beyond the 256-layer r of
// Marsaglia & Tsang. Prints the slow-path probabilities (1 - the mean of the ratios).
TEST(BathKernel, ZigguratTablesCloseWithEqualLayerAreas) {
  const BathZigguratLayers& zn = kBathNormalLayers;
  const BathZigguratLayers& ze = kBathExponentialLayers;
  constexpr int L = BathZigguratLayers::kLayers;
  const double vn = zn.r * std::exp(-0.5 * zn.r * zn.r) + std::sqrt(std::numbers::pi / 2) * std::erfc(zn.r / std::sqrt(2.0));
  const double ve = (ze.r + 1.0) * std::exp(-ze.r);
  // the L layers cover the area under the curve and the wedges above it (rejected)
  EXPECT_GT(vn * L, std::sqrt(std::numbers::pi / 2));
  EXPECT_LT(vn * L, 1.01 * std::sqrt(std::numbers::pi / 2));
  EXPECT_GT(ve * L, 1.0);
  EXPECT_LT(ve * L, 1.01);
  for (int i = 1; i < L; ++i) {
    ASSERT_NEAR(zn.x[i] * (zn.f[i + 1] - zn.f[i]), vn, 1e-12 * vn) << i;
    ASSERT_NEAR(ze.x[i] * (ze.f[i + 1] - ze.f[i]), ve, 1e-12 * ve) << i;
    ASSERT_LT(zn.x[i + 1], zn.x[i]);
    ASSERT_LT(ze.x[i + 1], ze.x[i]);
  }
  EXPECT_EQ(zn.x[L], 0.0);
  EXPECT_NEAR(zn.x[0] * std::exp(-0.5 * zn.r * zn.r), vn, 1e-14);
  EXPECT_GT(zn.r, 3.6541528853610088);
  EXPECT_GT(ze.r, 7.69711747013104972);
  double fast_n = 0, fast_e = 0;
  for (int i = 0; i < L; ++i) fast_n += zn.ratio[i] / L, fast_e += ze.ratio[i] / L;
  std::printf("bath ziggurat, %d layers: r = %.6f (normal), %.6f (exponential); slow path %.3f%%, %.3f%%\n", L, zn.r,
              ze.r, 100 * (1 - fast_n), 100 * (1 - fast_e));
}

// The batch kernel's variates from 32-bit halves, bit for bit against direct formulas:
// the folded ziggurat fast paths (kBathZiggurat: sign and the 2^-(32-B) / 2^-(33-B) grid
// inside the table) against u x[i] with u = (n + 1/2) 2^-(31-B) (normal, sign from bit B)
// or (n + 1/2) 2^-(32-B) (exponential) and the decision u < ratio[i] on the layers' own
// arrays, including every layer with both signs, n = 0 and the largest n; the
// no-rejection direction against z = (k + 1/2) 2^-31 (bitwise) and (rho cos phi, rho sin
// phi) by libm in long double (within 1e-15), the quadrants' swaps and signs included;
// lane 1 equals lane 0 bitwise.
TEST(BathKernel, FoldedZigguratAndDirectionEqualDirectFormulas) {
  auto bits = [](double x) { return std::bit_cast<std::uint64_t>(x); };
  const BathZigguratLayers& zn = kBathNormalLayers;
  const BathZigguratLayers& ze = kBathExponentialLayers;
  constexpr int B = BathZigguratLayers::kBits;
  constexpr std::uint32_t L = BathZigguratLayers::kLayers;
  std::vector<std::uint32_t> halves;
  CounterRng r(3, Stream::background_first_half, 9, 1);
  for (int i = 0; i < 400000; ++i) halves.push_back(static_cast<std::uint32_t>(r.bits64()));
  for (std::uint32_t low = 0; low < 2 * L; ++low)  // every layer and sign
    for (const std::uint32_t hi : {0u, 1u, (1u << (31 - B)) - 1, 1u << (30 - B)}) halves.push_back(hi << (B + 1) | low);
  for (std::uint32_t low = 0; low < L; ++low)
    for (const std::uint32_t hi : {0u, (1u << (32 - B)) - 1}) halves.push_back(hi << B | low);
  std::size_t slow_normal = 0, slow_exp = 0;
  for (const std::uint32_t h : halves) {
    const unsigned i = h & (L - 1);
    const double u = (static_cast<double>(h >> (B + 1)) + 0.5) * std::ldexp(1.0, -(31 - B));
    const double ref = (h & L ? -1.0 : 1.0) * (u * zn.x[i]);
    double got;
    ASSERT_EQ(detail::bath_normal_fast(h, got), u < zn.ratio[i] ? 0u : 1u) << h;
    ASSERT_EQ(bits(got), bits(ref)) << h;
    slow_normal += !(u < zn.ratio[i]);
    const double ue = (static_cast<double>(h >> B) + 0.5) * std::ldexp(1.0, -(32 - B));
    ASSERT_EQ(detail::bath_exponential_fast(h, got), ue < ze.ratio[i] ? 0u : 1u) << h;
    ASSERT_EQ(bits(got), bits(ue * ze.x[i])) << h;
    slow_exp += !(ue < ze.ratio[i]);
  }
  // both outcomes of every decision occurred (slow paths well under 1% to about 1%)
  EXPECT_GT(slow_normal, 500u);
  EXPECT_GT(slow_exp, 500u);
  // the resolution the comments state (operators/background.hpp, "resolution"): 1024
  // layers, the normal's uniform on the 2^21 midpoints (n + 1/2) 2^-21, the exponential's
  // on the 2^22 midpoints (n + 1/2) 2^-22: the first and last points of every layer
  ASSERT_EQ(B, 10);
  for (std::uint32_t i = 0; i < L; ++i) {
    double got;
    detail::bath_normal_fast(i, got);
    ASSERT_EQ(got, std::ldexp(zn.x[i], -22)) << i;
    detail::bath_normal_fast(0xffffffffu << (B + 1) | L | i, got);
    ASSERT_EQ(got, -(std::ldexp(1.0, 22) - 1) * std::ldexp(zn.x[i], -22)) << i;
    detail::bath_exponential_fast(i, got);
    ASSERT_EQ(got, std::ldexp(ze.x[i], -23)) << i;
    detail::bath_exponential_fast(0xffffffffu << B | i, got);
    ASSERT_EQ(got, (std::ldexp(1.0, 23) - 1) * std::ldexp(ze.x[i], -23)) << i;
  }

  std::vector<std::uint64_t> words;
  for (int i = 0; i < 200000; ++i) words.push_back(r.bits64());
  for (const std::uint64_t q : {0u, 1u, 2u, 3u})  // quadrant edges, z extremes
    for (const std::uint64_t j : {std::uint64_t{0}, std::uint64_t{0x3fffffff}, std::uint64_t{1} << 29})
      for (const std::uint64_t lo : {std::uint64_t{0}, std::uint64_t{0x7fffffff}, std::uint64_t{0x80000000}})
        words.push_back(q << 62 | j << 32 | lo);
  double worst = 0, worst_norm = 0;
  for (std::size_t k = 0; k + 2 <= words.size(); k += 2) {
    alignas(16) double rx[2], ry[2], rz[2], sx[2], sy[2], sz[2];
    detail::bath_direction_lanes(words[k], words[k + 1], rx, ry, rz);
    detail::bath_direction_lanes(words[k + 1], words[k + 1], sx, sy, sz);
    ASSERT_EQ(bits(rx[1]), bits(sx[0]));
    ASSERT_EQ(bits(ry[1]), bits(sy[0]));
    ASSERT_EQ(bits(rz[1]), bits(sz[0]));
    for (int l = 0; l < 2; ++l) {
      const std::uint64_t w = words[k + l];
      const double z = (static_cast<double>(static_cast<std::int32_t>(static_cast<std::uint32_t>(w))) + 0.5) * 0x1.0p-31;
      ASSERT_EQ(bits(rz[l]), bits(z)) << w;
      const long double pi = std::numbers::pi_v<long double>;
      const long double a = (static_cast<long double>(static_cast<std::int64_t>((w >> 32) & 0x3fffffff)) - 0x1.0p29L + 0.5L) *
                            (pi / 2) * 0x1.0p-30L;
      const long double phi = static_cast<long double>(w >> 62) * (pi / 2) + a;
      const long double rho = std::sqrt(1.0L - static_cast<long double>(z) * z);
      worst = std::max({worst, static_cast<double>(std::abs(rx[l] - rho * std::cos(phi))),
                        static_cast<double>(std::abs(ry[l] - rho * std::sin(phi)))});
      worst_norm = std::max(worst_norm, std::abs(rx[l] * rx[l] + ry[l] * ry[l] + rz[l] * rz[l] - 1.0));
    }
  }
  std::printf("bath direction: largest error against libm %.2e, largest | |r|^2 - 1 | %.2e\n", worst, worst_norm);
  EXPECT_LT(worst, 1e-15);
  EXPECT_LT(worst_norm, 2e-15);
}

namespace {
double normal_cdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }
// Wilson-Hilferty upper quantile of chi-square with k degrees of freedom at z sigma.
double chi2_quantile(double k, double z) {
  const double a = 2.0 / (9.0 * k);
  return k * std::pow(1.0 - a + z * std::sqrt(a), 3.0);
}
}  // namespace

// The laws of the bath kernel's variates (bath_words + bath_variates, slow paths included),
// from 32-bit halves: a million tests of one grain. Each test has a limit at about 5
// standard errors (p ~ 1e-4 for the chi-squares, 3.72 sigma of Wilson-Hilferty):
//  - U: mean 1/2, chi-square over 64 equal bins;
//  - the four normals: moments 1, 2, 4, 6 (pooled), each position's variance, the
//    correlation of normals from the two halves of one word and of two words, the sign,
//    and a chi-square over the layer edges in |x| plus the tail (exact probabilities);
//  - the exponential: mean, second moment, chi-square over its layer edges plus the tail;
//  - the direction: chi-square over 8 bands of z x 16 sectors of azimuth (equal areas),
//    <x>, <y>, <z> = 0, <x^2> = <z^2> = 1/3, <xy> = 0.
TEST(BathKernel, VariatesMatchTheirLaws) {
  const BathKey key{2024, Stream::background_second_half, 7};
  const int n = 1'000'000;
  const BathZigguratLayers& zn = kBathNormalLayers;
  const BathZigguratLayers& ze = kBathExponentialLayers;
  std::vector<double> nedges, eedges;
  for (int i = BathZigguratLayers::kLayers - 1; i >= 1; --i) nedges.push_back(zn.x[i]), eedges.push_back(ze.x[i]);
  std::vector<double> nh(nedges.size() + 1, 0.0), eh(eedges.size() + 1, 0.0), uh(64, 0.0), dh(8 * 16, 0.0);
  double u1 = 0, z1 = 0, z2 = 0, z4 = 0, z6 = 0, pos = 0, zz01 = 0, zz12 = 0, e1 = 0, e2 = 0;
  double zj2[4] = {0, 0, 0, 0}, rx1 = 0, ry1 = 0, rz1 = 0, rx2 = 0, rz2 = 0, rxy = 0;
  std::uint64_t w[4];
  BathVariates x;
  for (int t = 0; t < n; ++t) {
    detail::bath_words(key, 31337, static_cast<std::uint64_t>(t), w);
    detail::bath_variates(w, key, 31337, static_cast<std::uint64_t>(t), x);
    ASSERT_GT(x.u, 0.0);
    ASSERT_LT(x.u, 1.0);
    u1 += x.u;
    uh[static_cast<int>(x.u * 64)] += 1;
    for (int j = 0; j < 4; ++j) {
      const double v = x.z[j], v2 = v * v;
      z1 += v, z2 += v2, z4 += v2 * v2, z6 += v2 * v2 * v2, zj2[j] += v2, pos += v > 0;
      nh[std::upper_bound(nedges.begin(), nedges.end(), std::abs(v)) - nedges.begin()] += 1;
    }
    zz01 += x.z[0] * x.z[1];  // z0 (w0 high half) and z1 (w1 low half): different words
    zz12 += x.z[1] * x.z[2];  // the two halves of w1
    ASSERT_GE(x.e, 0.0);
    e1 += x.e, e2 += x.e * x.e;
    eh[std::upper_bound(eedges.begin(), eedges.end(), x.e) - eedges.begin()] += 1;
    rx1 += x.r.x, ry1 += x.r.y, rz1 += x.r.z, rx2 += x.r.x * x.r.x, rz2 += x.r.z * x.r.z, rxy += x.r.x * x.r.y;
    const double phi = std::atan2(x.r.y, x.r.x) + std::numbers::pi;  // [0, 2 pi]
    const int band = std::min(7, static_cast<int>((x.r.z + 1.0) * 4));
    const int sector = std::min(15, static_cast<int>(phi / (2 * std::numbers::pi) * 16));
    dh[16 * band + sector] += 1;
  }
  const double N = n, N4 = 4.0 * n;
  EXPECT_NEAR(u1 / N, 0.5, 5 * std::sqrt(1.0 / 12 / N));
  EXPECT_NEAR(z1 / N4, 0.0, 5 * std::sqrt(1.0 / N4));
  EXPECT_NEAR(z2 / N4, 1.0, 5 * std::sqrt(2.0 / N4));
  EXPECT_NEAR(z4 / N4, 3.0, 5 * std::sqrt(96.0 / N4));
  EXPECT_NEAR(z6 / N4, 15.0, 5 * std::sqrt(10170.0 / N4));
  EXPECT_NEAR(pos / N4, 0.5, 5 * std::sqrt(0.25 / N4));
  for (int j = 0; j < 4; ++j) EXPECT_NEAR(zj2[j] / N, 1.0, 5 * std::sqrt(2.0 / N)) << "normal " << j;
  EXPECT_NEAR(zz01 / N, 0.0, 5 * std::sqrt(1.0 / N));
  EXPECT_NEAR(zz12 / N, 0.0, 5 * std::sqrt(1.0 / N));
  EXPECT_NEAR(e1 / N, 1.0, 5 * std::sqrt(1.0 / N));
  EXPECT_NEAR(e2 / N, 2.0, 5 * std::sqrt(20.0 / N));  // Var(e^2) = 24 - 4
  EXPECT_NEAR(rx1 / N, 0.0, 5 * std::sqrt(1.0 / 3 / N));
  EXPECT_NEAR(ry1 / N, 0.0, 5 * std::sqrt(1.0 / 3 / N));
  EXPECT_NEAR(rz1 / N, 0.0, 5 * std::sqrt(1.0 / 3 / N));
  EXPECT_NEAR(rx2 / N, 1.0 / 3, 5 * std::sqrt(4.0 / 45 / N));  // Var(x^2) = 1/5 - 1/9
  EXPECT_NEAR(rz2 / N, 1.0 / 3, 5 * std::sqrt(4.0 / 45 / N));
  EXPECT_NEAR(rxy / N, 0.0, 5 * std::sqrt(1.0 / 15 / N));  // E[x^2 y^2] = 1/15
  auto chi2 = [](const std::vector<double>& h, auto prob) {
    double c = 0, total = 0;
    for (double v : h) total += v;
    for (std::size_t b = 0; b < h.size(); ++b) {
      const double e = total * prob(b);
      c += (h[b] - e) * (h[b] - e) / e;
    }
    return c;
  };
  const double cu = chi2(uh, [](std::size_t) { return 1.0 / 64; });
  const double cd = chi2(dh, [](std::size_t) { return 1.0 / 128; });
  const double cn = chi2(nh, [&](std::size_t b) {
    const double lo = b == 0 ? 0.0 : nedges[b - 1];
    return 2.0 * ((b < nedges.size() ? normal_cdf(nedges[b]) : 1.0) - normal_cdf(lo));
  });
  const double ce = chi2(eh, [&](std::size_t b) {
    const double lo = b == 0 ? 0.0 : eedges[b - 1];
    return std::exp(-lo) - (b < eedges.size() ? std::exp(-eedges[b]) : 0.0);
  });
  std::printf("bath variates: chi2 U %.1f (63 dof), normal %.1f (%zu), exponential %.1f (%zu), direction %.1f (127)\n",
              cu, cn, nh.size() - 1, ce, eh.size() - 1, cd);
  EXPECT_LT(cu, chi2_quantile(63, 3.72));
  EXPECT_LT(cd, chi2_quantile(127, 3.72));
  EXPECT_LT(cn, chi2_quantile(static_cast<double>(nh.size() - 1), 3.72));
  EXPECT_LT(ce, chi2_quantile(static_cast<double>(eh.size() - 1), 3.72));
}

namespace {
// Simpson's rule on [a, b] with n (even) intervals.
template <class F>
double simpson(F f, double a, double b, int n) {
  const double h = (b - a) / n;
  double s = f(a) + f(b);
  for (int k = 1; k < n; ++k) s += (k % 2 ? 4.0 : 2.0) * f(a + k * h);
  return s * h / 3;
}
}  // namespace

// The bath kernel's slow paths, which the variates' laws above exercise too rarely (0.43%
// and 0.64% of draws) to see an error in them: driven directly with halves that fail the
// fast path. In a wedge of layer i >= 1 (u x[i] beyond x[i+1]) the point is kept with
// probability (area under the density in the wedge) / (wedge rectangle): by quadrature,
// against the kept fraction of 200,000 wedge points (a kept point returns +-u x[i] itself,
// a rejected one a fresh draw), within 5 binomial standard errors; for layers near the
// tail, in the middle and near the mode, both signs. In the base layer beyond r the
// normal's tail must have the mean excess phi(r)/Q(r) - r and the exponential's r + Exp(1)
// the mean excess 1 (5 standard errors, the excess's standard deviation bounded by its mean).
TEST(BathKernel, SlowPathsKeepWedgeAndTailLaws) {
  const BathZigguratLayers& zn = kBathNormalLayers;
  const BathZigguratLayers& ze = kBathExponentialLayers;
  constexpr int B = BathZigguratLayers::kBits;
  constexpr std::uint32_t L = BathZigguratLayers::kLayers;
  const BathKey key{5, Stream::background_first_half, 1};
  CounterRng pick(8, Stream::initial_positions, 0, 0);
  const int n = 200'000;
  for (const bool normal : {true, false}) {
    const BathZigguratLayers& z = normal ? zn : ze;
    auto f = [normal](double x) { return normal ? std::exp(-0.5 * x * x) : std::exp(-x); };
    const int ubits = normal ? 31 - B : 32 - B;  // bits of u above the layer (and sign)
    for (const std::uint32_t i : {1u, 2u, 17u, 300u, 700u, L - 2, L - 1}) {
      SCOPED_TRACE(std::to_string(i) + (normal ? " normal" : " exponential"));
      // the wedge: u in [ratio[i], 1), i.e. n from ceil(ratio 2^ubits - 1/2) to 2^ubits - 1
      const double lo_n = std::ceil(z.ratio[i] * std::ldexp(1.0, ubits) - 0.5);
      const double span = std::ldexp(1.0, ubits) - lo_n;
      double kept = 0;
      for (int k = 0; k < n; ++k) {
        const auto nn = static_cast<std::uint32_t>(lo_n + std::floor(pick.uniform() * span));
        const std::uint32_t sign = normal ? static_cast<std::uint32_t>(k & 1) << B : 0u;
        const std::uint32_t h = nn << (normal ? B + 1 : B) | sign | i;
        double fast;
        const unsigned slow = normal ? detail::bath_normal_fast(h, fast) : detail::bath_exponential_fast(h, fast);
        ASSERT_EQ(slow, 1u) << h;
        CounterRng more(key.seed, key.stream, 1000 + i, key.step, static_cast<std::uint64_t>(k));
        const double x = normal ? detail::bath_normal_slow(h, more) : detail::bath_exponential_slow(h, more);
        kept += x == fast;
      }
      const double x0 = z.x[i + 1], x1 = z.x[i];
      const double under = simpson([&](double x) { return f(x) - z.f[i]; }, x0, x1, 2000);
      const double p = under / ((x1 - x0) * (z.f[i + 1] - z.f[i]));
      EXPECT_NEAR(kept / n, p, 5 * std::sqrt(p * (1 - p) / n) + 1e-9) << "kept fraction of the wedge";
    }
    // the base layer beyond r: u x[0] >= r
    const double lo_n = std::ceil(z.ratio[0] * std::ldexp(1.0, ubits) - 0.5);
    const double span = std::ldexp(1.0, ubits) - lo_n;
    double excess = 0;
    for (int k = 0; k < n; ++k) {
      const auto nn = static_cast<std::uint32_t>(lo_n + std::floor(pick.uniform() * span));
      const std::uint32_t h = nn << (normal ? B + 1 : B);
      double fast;
      ASSERT_EQ(normal ? detail::bath_normal_fast(h, fast) : detail::bath_exponential_fast(h, fast), 1u);
      CounterRng more(key.seed, key.stream, 7, key.step, static_cast<std::uint64_t>(k));
      const double x = normal ? detail::bath_normal_slow(h, more) : detail::bath_exponential_slow(h, more);
      ASSERT_GT(x, z.r);
      excess += x - z.r;
    }
    const double q = 0.5 * std::erfc(zn.r / std::sqrt(2.0));
    const double expected = normal ? std::exp(-0.5 * zn.r * zn.r) / std::sqrt(2 * std::numbers::pi) / q - zn.r : 1.0;
    std::printf("bath %s tail: mean excess %.5f (exact %.5f)\n", normal ? "normal" : "exponential", excess / n, expected);
    EXPECT_NEAR(excess / n, expected, 5 * expected / std::sqrt(n));
  }
}
