#pragma once
// The linear elastic background operator (Bisi-Spiga eqs. 3, 8, 13): hard-sphere collisions
// of a grain (mass m) with field particles (mass mB) drawn from a Maxwellian of density nB,
// drift uB, temperature TB. Shared by DSMC (a time interval per grain) and EDMD (Poisson
// events in the calendar). Knows nothing of either engine.
//
// Collision rate of a grain of velocity v (scaled units, cross-section 1, Issue #2):
//     nu(v) = (nB / eps) * Integral |v - w| M_B(w) d3w .
// Exact sampling by thinning with a per-grain majorant that uses the partner's speed:
//     |v - w| <= |c| + |c_w|,   c = v - uB,  c_w = w - uB,
// so candidates arrive at rate K (|c| + <|c_w|>), K = nB/eps, with the partner drawn from
// the mixture density (|c| + |c_w|) M_B(w) / (|c| + <|c_w|>), and are accepted with
// probability |v - w| / (|c| + |c_w|) <= 1. No fixed g_max that could be exceeded.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <immintrin.h>
#include <initializer_list>
#include <numbers>

#include "operators/binary_collision.hpp"
#include "operators/random.hpp"
#include "operators/vec3.hpp"

namespace grainbath {

// Background mass from the mass ratio alpha = mB / (m + mB) (Bisi-Spiga eq. 2).
inline double background_mass(double mass_ratio, double grain_mass) {
  return mass_ratio * grain_mass / (1.0 - mass_ratio);
}

// Local state of the medium as a grain sees it. `rate_scale` is nB/eps.
struct BackgroundState {
  double rate_scale = 0.0;   // nB / eps
  Vec3 velocity;             // uB
  double sigma = 1.0;        // sqrt(TB / mB): Maxwellian width per component
  double mean_speed = 0.0;   // <|w - uB|> = sigma sqrt(8/pi)
  double mass_ratio = 0.5;   // alpha

  static BackgroundState make(double density, double knudsen, Vec3 velocity, double temperature,
                              double mass_ratio, double grain_mass) {
    BackgroundState b;
    b.rate_scale = density / knudsen;
    b.velocity = velocity;
    b.sigma = std::sqrt(temperature / background_mass(mass_ratio, grain_mass));
    b.mean_speed = b.sigma * std::sqrt(8.0 / std::numbers::pi);
    b.mass_ratio = mass_ratio;
    return b;
  }
};

// Candidate (majorant) rate for a grain of velocity v.
inline double background_majorant_rate(const Vec3& v, const BackgroundState& b) {
  return b.rate_scale * (norm(v - b.velocity) + b.mean_speed);
}

// v' = v - 2 alpha (g.n) n  (Bisi-Spiga eq. 3). Returns the grain's kinetic-energy change.
inline double elastic_background_collision(Vec3& v, const Vec3& w, const Vec3& n, double alpha,
                                           double grain_mass) {
  const double e0 = norm2(v);
  v -= (2.0 * alpha * dot(v - w, n)) * n;
  return 0.5 * grain_mass * (norm2(v) - e0);
}

// Draws a partner from the majorant mixture and accepts it with |g| / (|c| + |c_w|), for a
// grain with c = v - uB and cmod = |c| already known. On acceptance applies the collision
// and returns true. `energy_gain` accumulates the grain's kinetic-energy change (bath input
// for the energy budget). Normals come from the ziggurat (no logarithm on the fast path).
template <class Rng>
inline bool attempt_background_collision(Vec3& v, const Vec3& c, double cmod, const BackgroundState& b,
                                         double grain_mass, Rng& rng, double& energy_gain) {
  Vec3 cw;
  double cw_mod;
  if (rng.uniform() * (cmod + b.mean_speed) < cmod) {
    cw = b.sigma * Vec3{rng.normal_ziggurat(), rng.normal_ziggurat(), rng.normal_ziggurat()};  // Maxwellian partner
    cw_mod = norm(cw);
  } else {
    // Speed-weighted Maxwellian |c_w| M_B: the speed has density ~ s^3 exp(-s^2 / 2 sigma^2),
    // a chi distribution with 4 degrees of freedom, so s = sigma |z| for z standard normal
    // in 4D; the direction of the first three components of z is isotropic and independent
    // of |z| (the 3D direction is independent of the 3D length and of z4), so
    // c_w = sigma |z| z_(1..3) / |z_(1..3)|.
    const double z1 = rng.normal_ziggurat(), z2 = rng.normal_ziggurat(), z3 = rng.normal_ziggurat();
    const double z4 = rng.normal_ziggurat();
    const double s3 = z1 * z1 + z2 * z2 + z3 * z3, s4 = s3 + z4 * z4;
    cw = (b.sigma * std::sqrt(s4 / s3)) * Vec3{z1, z2, z3};
    cw_mod = b.sigma * std::sqrt(s4);
  }
  const Vec3 g = c - cw;
  const double gmod = norm(g);
  if (rng.uniform() * (cmod + cw_mod) >= gmod) return false;  // null collision
  const Vec3 n = apse_direction((1.0 / gmod) * g, rng.unit_vector());
  energy_gain += elastic_background_collision(v, cw + b.velocity, n, b.mass_ratio, grain_mass);
  return true;
}

template <class Rng>
inline bool attempt_background_collision(Vec3& v, const BackgroundState& b, double grain_mass, Rng& rng,
                                         double& energy_gain) {
  const Vec3 c = v - b.velocity;
  return attempt_background_collision(v, c, norm(c), b, grain_mass, rng, energy_gain);
}

struct BackgroundCounters {
  std::uint64_t candidates = 0;
  std::uint64_t collisions = 0;
  double energy_gain = 0.0;  // kinetic energy given to the grains by the bath
};

// One thinning test of the DSMC bath kernel: the same candidate law and acceptance as
// attempt_background_collision (partner from (|c| + |c_w|) M_B / (|c| + <|c_w|>), accepted
// with |g| / (|c| + |c_w|)), arranged for speed (Issue #7), all exact:
//  - the partner always takes four normals z: the Maxwellian component is sigma z_(1..3),
//    the speed-weighted one sigma |z| z_(1..3) / |z_(1..3)|; one of the two is selected
//    without a branch (the 50/50 branch was mispredicted half the time, which cost more
//    than the fourth normal);
//  - acceptance is tested on squares, u^2 (|c| + |c_w|)^2 < |g|^2 (both sides >= 0), so
//    |g| is taken only for accepted candidates;
//  - with the apse n = (g_hat - r) / |g_hat - r| of apse_direction, (g.n) n = (g - |g| r)/2
//    exactly (g.n = |g| (1 - g_hat.r) / |g_hat - r| and |g_hat - r|^2 = 2 (1 - g_hat.r)),
//    so Bisi-Spiga eq. 3 becomes v' = v - alpha (g - |g| r): no apse normalisation;
//  - c = v - uB and |c| are updated here on acceptance and reused after a rejection.
template <class Rng>
inline bool background_test(Vec3& v, Vec3& c, double& cmod, const BackgroundState& b, double grain_mass, Rng& rng,
                            double& energy_gain) {
  const bool maxwellian = rng.uniform() * (cmod + b.mean_speed) < cmod;
  const double z1 = rng.normal_ziggurat(), z2 = rng.normal_ziggurat(), z3 = rng.normal_ziggurat();
  const double z4 = rng.normal_ziggurat();
  const double s3 = z1 * z1 + z2 * z2 + z3 * z3, s4 = s3 + z4 * z4;
  const double a3 = std::sqrt(s3), a4 = std::sqrt(s4);
  const double scale = maxwellian ? b.sigma : b.sigma * (a4 / a3);
  const double cw_mod = b.sigma * (maxwellian ? a3 : a4);
  const Vec3 g = c - scale * Vec3{z1, z2, z3};
  const double g2 = norm2(g);
  const double u = rng.uniform() * (cmod + cw_mod);
  if (u * u >= g2) return false;  // null collision
  const Vec3 r = rng.unit_vector();
  const double e0 = norm2(v);
  v -= b.mass_ratio * (g - std::sqrt(g2) * r);
  energy_gain += 0.5 * grain_mass * (norm2(v) - e0);
  c = v - b.velocity;
  cmod = norm(c);
  return true;
}

// Evolves one grain's velocity through `duration` of background collisions only (the
// operator-split bath substep of the DSMC), continuing the grain's candidate process from
// `hazard`: the unit-exponential amount of integrated majorant rate left before its next
// candidate. Candidates are the points where the integrated rate Integral K(|c(t)| + <|c_w|>) dt
// reaches successive unit exponentials (time-change of a unit Poisson process), so the
// residual can be carried across substeps, grain-grain collisions and restarts: it is part
// of the grain's state. Exact in distribution; the majorant changes only at accepted events.
template <class Rng>
inline void evolve_in_background(Vec3& v, double& hazard, const BackgroundState& b, double grain_mass,
                                 double duration, Rng& rng, BackgroundCounters& counters) {
  if (b.rate_scale <= 0.0) return;
  Vec3 c = v - b.velocity;
  double cmod = norm(c);
  double left = duration;
  for (;;) {
    const double rate = b.rate_scale * (cmod + b.mean_speed);  // background_majorant_rate
    const double need = rate * left;
    if (hazard >= need) {
      hazard -= need;
      return;
    }
    left = std::max(0.0, left - hazard / rate);
    hazard = rng.exponential_ziggurat();
    ++counters.candidates;
    if (background_test(v, c, cmod, b, grain_mass, rng, counters.energy_gain)) ++counters.collisions;
  }
}

// The same from a fresh unit exponential (no carried residual).
template <class Rng>
inline void evolve_in_background(Vec3& v, const BackgroundState& b, double grain_mass, double duration, Rng& rng,
                                 BackgroundCounters& counters) {
  double hazard = rng.exponential_ziggurat();
  evolve_in_background(v, hazard, b, grain_mass, duration, rng, counters);
}

// ---------------------------------------------------------------------------------------
// The DSMC bath kernel with a fixed random budget per test (Issue #7, docs/dsmc.md D2).
//
// The same candidate process, partner law, acceptance and post-collision rule as
// evolve_in_background / background_test, with the random numbers laid out so that many
// grains can be processed together:
//  - test t (t = 0, 1, ...) of a grain in a substep takes exactly four 64-bit words: two
//    Philox4x32-10 blocks under the seed with counters (id, stream, step, 2t + j)
//    (bath_words; computed for many grains at once in integer SIMD, Philox4x32Lanes::words4),
//    read as eight 32-bit halves (lo, hi of w0 .. w3):
//      w0 lo   one uniform U for both the mixture choice and the acceptance (below),
//      w0 hi, w1 lo, w1 hi, w2 lo   the four ziggurat normals of the partner,
//      w2 hi   the unit exponential of the next candidate (the carried residual),
//      w3      the direction r: z = cos(theta) from the low half, the azimuth from the high
//              half (no rejection);
//    the rare slow paths (a ziggurat wedge or tail, 0.43% per normal, 0.64% per
//    exponential with the 1024-layer ziggurats; 2.3% of tests) draw their further numbers from sequence t + 1 of CounterRng(seed, stream, id, step)
//    (Philox4x64, fourth counter word), so a test's numbers never depend on another
//    test's: still counter-based on (seed, stream; id, step, draw);
//  - resolution (why 32 bits suffice): U is a midpoint of a 2^-32 grid; a normal takes
//    its layer from 10 bits, its sign from 1 and the uniform across the layer from 21 (the
//    midpoints (n + 1/2) 2^-21), the exponential its layer from 10 and the uniform from 22;
//    z and the azimuth are midpoints of 2^-31 and 2^-30 (per quadrant) grids. Each variate
//    is its exact law applied to a uniform rounded to the midpoint of a grid cell. Within
//    a layer the discrete uniform's distribution function is off by at most half a cell,
//    so the variate's is off by at most half a cell summed over the layers' probabilities:
//    2^-22 ~ 2.4e-7 (normal), 2^-23 (exponential), 2^-33 (U) and 2^-32 (z), and in practice
//    far less (the layers' grids differ, so their errors do not add up in sign); a smooth
//    average (a moment, a collision integral) is off by O(cell width^2) ~ 2^-42 relative
//    (midpoint rule). A Kolmogorov-Smirnov test would need ~1e13 draws to see 2.4e-7,
//    a moment ~1e26: far below any statistical error of a run (tests/operators
//    BathKernel.VariatesMatchTheirLaws checks the laws, and
//    BathKernel.FoldedZigguratAndDirectionEqualDirectFormulas pins the grids);
//  - one uniform for two decisions: with t' = U (|c| + <|c_w|>), the Maxwellian component
//    is chosen iff t' < |c|, and given the choice, t'/|c| (Maxwellian) or (t' - |c|)/<|c_w|>
//    (speed-weighted) is again uniform on [0, 1) and independent of the choice, so the
//    acceptance u (|c| + |c_w|) < |g| becomes, on squares and without a division,
//    (t'' (|c| + |c_w|))^2 < |g|^2 d^2 with t'' = t' or t' - |c| and d = |c| or <|c_w|>;
//  - no branch on the acceptance: the collision is computed for every test and applied
//    times 1 or 0 (v + 0 dv = v), and |c| is recomputed after every test.
// bath_evolve_keyed (one grain) and bath_evolve_batch (many grains, tests of different
// grains interleaved) run the same code per test and give bitwise the same velocities,
// residuals and counters (tests/operators).

// Key of a bath substep's random numbers: (seed, stream; grain id, step).
struct BathKey {
  std::uint64_t seed = 0;
  Stream stream = Stream::background_first_half;
  std::uint64_t step = 0;
};

// The variates of one test.
struct BathVariates {
  double u;        // (0, 1): mixture choice and acceptance
  double z[4];     // standard normals
  double e;        // unit exponential (next candidate's residual)
  Vec3 r;          // uniform direction
};

namespace detail {

// The bath kernel's own ziggurats (Marsaglia & Tsang 2000, as ZigguratTable, here with
// 2^kBits layers): more layers make the fast path more likely (the normal's slow path
// 0.43% per draw with 1024 layers instead of 1.5% with 256, the exponential's 0.64% instead
// of 2.2%) at the price of table size (48 KB with the sign folded in: measured faster than
// 512 layers in the kernel alone, 38.3 vs 39.6 ns per test, and the same in the whole run)
// and of two bits of the uniform across the layer (21 instead of 23 for the normal: the
// distribution function's bound goes from 2^-24 to 2^-22, see above). The tables are built at
// program start by ZigguratTable's builder (ZigguratLayers, operators/random.hpp: bisection
// on r so that the equal-area layers close at the mode), for the densities exp(-x^2/2) and
// exp(-x).
using BathZigguratLayers = ZigguratLayers<1 << 10>;
inline const BathZigguratLayers kBathNormalLayers = BathZigguratLayers::build(
    [](long double x) { return std::exp(-0.5L * x * x); }, [](long double y) { return std::sqrt(-2.0L * std::log(y)); },
    [](long double r) { return std::sqrt(std::numbers::pi_v<long double> / 2) * std::erfc(r / std::sqrt(2.0L)); }, 3.0L,
    6.0L);
inline const BathZigguratLayers kBathExponentialLayers = BathZigguratLayers::build(
    [](long double x) { return std::exp(-x); }, [](long double y) { return -std::log(y); },
    [](long double r) { return std::exp(-r); }, 6.0L, 14.0L);

// The fast paths on 32-bit halves h, with the scalings folded into the tables (Issue #7),
// B = kBits. Normal: layer i = bits 0..B-1, sign bit B, uniform u = (n + 1/2) 2^-(31-B)
// with n = the 31 - B bits above; exponential: layer bits 0..B-1, u = (n + 1/2) 2^-(32-B)
// with n = the 32 - B bits above. In both, m = (h >> B or B - 1) | 1 = 2n + 1 is u in units
// of 2^-(32-B) or 2^-(33-B), one exact conversion; the fast path returns u x[i] (with the
// sign) and is taken iff u < ratio[i]. Scaling by a power of two is exact, so
// u x[i] = m (x[i] 2^-(32-B)) after one rounding either way, and u < ratio[i] iff
// m < ratio[i] 2^(32-B); the sign is folded into a table of 2^(B+1) entries indexed by the
// low B + 1 bits (a product with -x is exactly the negated product). The edge and the
// bound sit side by side: one cache line per draw.
struct BathZigguratEntry {
  double x;      // (+-) x[i] 2^-(32-B) (normal) or x[i] 2^-(33-B) (exponential)
  double bound;  // ratio[i] 2^(32-B) or ratio[i] 2^(33-B): fast path iff m < bound
};
struct BathZiggurat {
  static constexpr int B = BathZigguratLayers::kBits, L = BathZigguratLayers::kLayers;
  BathZigguratEntry normal[2 * L];  // index h & (2L - 1): layer (bits 0..B-1), sign (bit B)
  BathZigguratEntry exponential[L];  // index h & (L - 1)
};
inline const BathZiggurat kBathZiggurat = [] {
  constexpr int B = BathZiggurat::B, L = BathZiggurat::L;
  BathZiggurat t{};
  for (int i = 0; i < 2 * L; ++i) {
    const int layer = i & (L - 1);
    const double x = std::ldexp(kBathNormalLayers.x[layer], -(32 - B));
    t.normal[i] = {i & L ? -x : x, std::ldexp(kBathNormalLayers.ratio[layer], 32 - B)};
  }
  for (int i = 0; i < L; ++i)
    t.exponential[i] = {std::ldexp(kBathExponentialLayers.x[i], -(33 - B)),
                        std::ldexp(kBathExponentialLayers.ratio[i], 33 - B)};
  return t;
}();

// Fast paths: the variate, and 1 if the slow path is needed (0 on the fast path).
inline unsigned bath_normal_fast(std::uint32_t h, double& out) {
  const BathZigguratEntry& e = kBathZiggurat.normal[h & (2u * BathZiggurat::L - 1)];
  const double m = static_cast<double>(static_cast<std::int32_t>((h >> BathZiggurat::B) | 1u));
  out = m * e.x;
  return !(m < e.bound);
}
inline unsigned bath_exponential_fast(std::uint32_t h, double& out) {
  const BathZigguratEntry& e = kBathZiggurat.exponential[h & (BathZiggurat::L - 1u)];
  const double m = static_cast<double>(static_cast<std::int32_t>((h >> (BathZiggurat::B - 1)) | 1u));
  out = m * e.x;
  return !(m < e.bound);
}
// The uniform of the mixture choice and the acceptance: (h + 1/2) 2^-32 in (0, 1).
inline double bath_uniform(std::uint32_t h) {
  return (static_cast<double>(static_cast<std::int64_t>(h)) + 0.5) * 0x1.0p-32;
}

// The exact completions when a fast path failed: the wedge of layer i >= 1 at the point
// x = u x[i] (accepted iff a uniform height in the layer falls under the density, else a
// fresh complete draw), or the tail beyond r for layer 0 (normal: Marsaglia 1964, r + a
// with a ~ Exp(r) accepted with exp(-a^2/2); exponential: r + Exp(1) by memorylessness).
// Further numbers from `more` (Philox4x64).
inline double bath_normal_slow(std::uint32_t h, CounterRng& more) {
  const BathZigguratLayers& zt = kBathNormalLayers;
  constexpr int B = BathZigguratLayers::kBits;
  const unsigned i = h & (BathZigguratLayers::kLayers - 1u);
  const double sign = (h & (1u << B)) ? -1.0 : 1.0;
  const double x = (static_cast<double>((h >> B) | 1u) * std::ldexp(1.0, -(32 - B))) * zt.x[i];
  if (i == 0) {
    double a, b;
    do {
      a = -std::log(more.uniform()) / zt.r;
      b = -std::log(more.uniform());
    } while (b + b < a * a);
    return sign * (zt.r + a);
  }
  if (zt.f[i] + more.uniform() * (zt.f[i + 1] - zt.f[i]) < std::exp(-0.5 * x * x)) return sign * x;
  return more.normal_ziggurat();
}
inline double bath_exponential_slow(std::uint32_t h, CounterRng& more) {
  const BathZigguratLayers& zt = kBathExponentialLayers;
  constexpr int B = BathZigguratLayers::kBits;
  const unsigned i = h & (BathZigguratLayers::kLayers - 1u);
  const double x = (static_cast<double>((h >> (B - 1)) | 1u) * std::ldexp(1.0, -(33 - B))) * zt.x[i];
  if (i == 0) return zt.r + more.exponential_ziggurat();
  if (zt.f[i] + more.uniform() * (zt.f[i + 1] - zt.f[i]) < std::exp(-x)) return x;
  return more.exponential_ziggurat();
}

// The 32-bit half k (0-7) of a test's four words: lo, hi of w0, then of w1, ...
inline std::uint32_t bath_half(const std::uint64_t* w, int k) {
  return static_cast<std::uint32_t>(w[k >> 1] >> (32 * (k & 1)));
}

// Exact variates when fast paths failed (rare): `fail` has bit j for normal j (0-3), bit 4
// for the exponential. Only those are redrawn, in this order, with their further numbers
// from sequence t + 1.
[[gnu::noinline]] inline void bath_variates_slow(const std::uint64_t* w, unsigned fail, BathVariates& x,
                                                 const BathKey& key, std::uint64_t id, std::uint64_t t) {
  CounterRng more(key.seed, key.stream, id, key.step, t + 1);
  // over the set bits in order (one loop branch per failed variate, not one per variate)
  for (; fail & 15u; fail &= fail - 1) {
    const int j = std::countr_zero(fail);
    x.z[j] = bath_normal_slow(bath_half(w, 1 + j), more);
  }
  if (fail) x.e = bath_exponential_slow(bath_half(w, 5), more);
}

// bath_variates_slow for grain g of the batch kernel's variate arrays.
[[gnu::noinline]] inline void bath_variates_slow_lane(const std::uint64_t* w, unsigned fail, const BathKey& key,
                                                      std::uint64_t id, std::uint64_t t, std::size_t g, double* z0,
                                                      double* z1, double* z2, double* z3, double* e) {
  BathVariates x{0.0, {z0[g], z1[g], z2[g], z3[g]}, e[g], {}};
  bath_variates_slow(w, fail, x, key, id, t);
  z0[g] = x.z[0], z1[g] = x.z[1], z2[g] = x.z[2], z3[g] = x.z[3];
  e[g] = x.e;
}

// The counters of a grain's test words: Philox4x32-10 under the 64-bit seed, counter
// (id low 32 bits, id high bits | stream << 24, step, 2t + j), j = 0, 1 (Philox4x32Lanes::
// words4: two blocks, four 64-bit words per test). Injective for ids < 2^56, streams < 256
// and steps < 2^32 (checked by the DSMC driver) and tests t < 2^31 per grain and substep.
inline std::uint32_t bath_ctr0(std::uint64_t id) { return static_cast<std::uint32_t>(id); }
inline std::uint32_t bath_ctr1(std::uint64_t id, Stream stream) {
  return static_cast<std::uint32_t>(id >> 32) | static_cast<std::uint32_t>(static_cast<std::uint64_t>(stream) << 24);
}

// The lane code of the batch kernel (operators/background_lanes.inc), compiled once per
// instruction set: two double lanes in SSE2 (baseline x86-64) and four in AVX2, chosen at
// run time by Philox4x32Lanes::have_avx2() (GRAINBATH_SIMD=sse2 forces the baseline).
// Both give bitwise the same results (the same IEEE operations per lane, no FMA; tests/
// operators BathKernel.AvxAndSse2PathsEqualBitwise).
namespace bath_sse2 {
typedef double Lanes __attribute__((vector_size(16)));
typedef long long Mask __attribute__((vector_size(16)));
inline constexpr std::size_t kLanes = 2;
inline Lanes lanes_sqrt(Lanes x) { return _mm_sqrt_pd(x); }
inline unsigned lanes_movemask(Mask m) { return static_cast<unsigned>(_mm_movemask_pd(reinterpret_cast<__m128d>(m))); }
inline Lanes to_lanes(__m128i h) { return _mm_cvtepi32_pd(h); }
inline Mask widen_mask(__m128i h) { return reinterpret_cast<Mask>(_mm_unpacklo_epi32(h, h)); }
// grain 0's words w0 w1 | w2 w3 and grain 1's, interleaved by 32-bit halves:
// (w0 lo 0, w0 lo 1, w0 hi 0, w0 hi 1) and so on; h[k] has half k in its low two int32
inline void word_halves(const std::uint64_t* w, __m128i h[8]) {
  const __m128i* p = reinterpret_cast<const __m128i*>(w);
  const __m128i g0a = _mm_loadu_si128(p), g0b = _mm_loadu_si128(p + 1), g1a = _mm_loadu_si128(p + 2),
                g1b = _mm_loadu_si128(p + 3);
  const __m128i w0 = _mm_unpacklo_epi32(g0a, g1a), w1 = _mm_unpackhi_epi32(g0a, g1a),
                w2 = _mm_unpacklo_epi32(g0b, g1b), w3 = _mm_unpackhi_epi32(g0b, g1b);
  h[0] = w0, h[1] = _mm_srli_si128(w0, 8), h[2] = w1, h[3] = _mm_srli_si128(w1, 8);
  h[4] = w2, h[5] = _mm_srli_si128(w2, 8), h[6] = w3, h[7] = _mm_srli_si128(w3, 8);
}
inline void load_entries(const char* base, const std::uint32_t* offset, Lanes& x, Lanes& bound) {
  const __m128d e0 = _mm_loadu_pd(reinterpret_cast<const double*>(base + offset[0]));
  const __m128d e1 = _mm_loadu_pd(reinterpret_cast<const double*>(base + offset[1]));
  x = _mm_unpacklo_pd(e0, e1);
  bound = _mm_unpackhi_pd(e0, e1);
}
// two lanes: only keep = 2 (lane 1 alone) moves a lane
inline Lanes compact(Lanes x, unsigned keep) {
  const Mask move = Mask{} - static_cast<long long>(keep == 2u);
  const Lanes high = _mm_unpackhi_pd(x, x);
  return reinterpret_cast<Lanes>((reinterpret_cast<Mask>(high) & move) | (reinterpret_cast<Mask>(x) & ~move));
}
inline __m128i compact_ints(__m128i h, unsigned keep) {
  const __m128i move = _mm_set1_epi32(-static_cast<int>(keep == 2u));
  return _mm_or_si128(_mm_and_si128(_mm_srli_si128(h, 4), move), _mm_andnot_si128(move, h));
}
inline __m128i ints_load(const std::uint32_t* p) { return _mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)); }
inline void ints_store(std::uint32_t* p, __m128i h) { _mm_storel_epi64(reinterpret_cast<__m128i*>(p), h); }
inline void id_halves(const std::uint64_t* id, __m128i& lo, __m128i& hi) {
  lo = _mm_shuffle_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(id)), _MM_SHUFFLE(3, 1, 2, 0));
  hi = _mm_srli_si128(lo, 8);
}
#include "operators/background_lanes.inc"
}  // namespace bath_sse2

// The AVX2 copy: every function defined up to the pop is compiled for AVX2 (and explicitly
// without FMA, so that no multiply-add can be contracted whatever the global flags). Only
// called when the CPU has AVX2.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2,no-fma"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2,no-fma")
#endif
namespace bath_avx2 {
typedef double Lanes __attribute__((vector_size(32)));
typedef long long Mask __attribute__((vector_size(32)));
inline constexpr std::size_t kLanes = 4;
inline Lanes lanes_sqrt(Lanes x) { return _mm256_sqrt_pd(x); }
inline unsigned lanes_movemask(Mask m) { return static_cast<unsigned>(_mm256_movemask_pd(reinterpret_cast<__m256d>(m))); }
inline Lanes to_lanes(__m128i h) { return _mm256_cvtepi32_pd(h); }
inline Mask widen_mask(__m128i h) { return reinterpret_cast<Mask>(_mm256_cvtepi32_epi64(h)); }
// the four grains' words as rows (w0 w1 | w2 w3 per grain) transposed by 32-bit halves:
// (w0 lo 0..3 | w2 lo 0..3), (w0 hi 0..3 | w2 hi 0..3), (w1 lo | w3 lo), (w1 hi | w3 hi)
inline void word_halves(const std::uint64_t* w, __m128i h[8]) {
  const __m256i* p = reinterpret_cast<const __m256i*>(w);
  const __m256i r0 = _mm256_loadu_si256(p), r1 = _mm256_loadu_si256(p + 1), r2 = _mm256_loadu_si256(p + 2),
                r3 = _mm256_loadu_si256(p + 3);
  const __m256i t0 = _mm256_unpacklo_epi32(r0, r1), t1 = _mm256_unpackhi_epi32(r0, r1),
                t2 = _mm256_unpacklo_epi32(r2, r3), t3 = _mm256_unpackhi_epi32(r2, r3);
  const __m256i lo02 = _mm256_unpacklo_epi64(t0, t2), hi02 = _mm256_unpackhi_epi64(t0, t2),
                lo13 = _mm256_unpacklo_epi64(t1, t3), hi13 = _mm256_unpackhi_epi64(t1, t3);
  h[0] = _mm256_castsi256_si128(lo02), h[1] = _mm256_castsi256_si128(hi02);
  h[2] = _mm256_castsi256_si128(lo13), h[3] = _mm256_castsi256_si128(hi13);
  h[4] = _mm256_extracti128_si256(lo02, 1), h[5] = _mm256_extracti128_si256(hi02, 1);
  h[6] = _mm256_extracti128_si256(lo13, 1), h[7] = _mm256_extracti128_si256(hi13, 1);
}
inline void load_entries(const char* base, const std::uint32_t* offset, Lanes& x, Lanes& bound) {
  const __m256d e02 = _mm256_insertf128_pd(
      _mm256_castpd128_pd256(_mm_loadu_pd(reinterpret_cast<const double*>(base + offset[0]))),
      _mm_loadu_pd(reinterpret_cast<const double*>(base + offset[2])), 1);
  const __m256d e13 = _mm256_insertf128_pd(
      _mm256_castpd128_pd256(_mm_loadu_pd(reinterpret_cast<const double*>(base + offset[1]))),
      _mm_loadu_pd(reinterpret_cast<const double*>(base + offset[3])), 1);
  x = _mm256_unpacklo_pd(e02, e13);      // (x0, x1 | x2, x3)
  bound = _mm256_unpackhi_pd(e02, e13);  // (b0, b1 | b2, b3)
}
// the permutations that move the lanes set in a 4-bit `keep` to the front, in order: of
// 32-bit elements for doubles (two per lane) and for int32
struct CompactPermutations {
  alignas(32) int doubles[16][8];
  alignas(16) int ints[16][4];
};
inline constexpr CompactPermutations kCompactPermutations = [] {
  CompactPermutations t{};
  for (int keep = 0; keep < 16; ++keep)
    for (int lane = 0, front = 0; lane < 4; ++lane)
      if (keep >> lane & 1) {
        t.doubles[keep][2 * front] = 2 * lane, t.doubles[keep][2 * front + 1] = 2 * lane + 1;
        t.ints[keep][front++] = lane;
      }
  return t;
}();
inline Lanes compact(Lanes x, unsigned keep) {
  const __m256i order = _mm256_load_si256(reinterpret_cast<const __m256i*>(kCompactPermutations.doubles[keep]));
  return _mm256_castsi256_pd(_mm256_permutevar8x32_epi32(_mm256_castpd_si256(x), order));
}
inline __m128i compact_ints(__m128i h, unsigned keep) {
  const __m128i order = _mm_load_si128(reinterpret_cast<const __m128i*>(kCompactPermutations.ints[keep]));
  return _mm_castps_si128(_mm_permutevar_ps(_mm_castsi128_ps(h), order));
}
inline __m128i ints_load(const std::uint32_t* p) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p)); }
inline void ints_store(std::uint32_t* p, __m128i h) { _mm_storeu_si128(reinterpret_cast<__m128i*>(p), h); }
inline void id_halves(const std::uint64_t* id, __m128i& lo, __m128i& hi) {
  const __m256i halves = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(id)),
                                                     _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7));
  lo = _mm256_castsi256_si128(halves);
  hi = _mm256_extracti128_si256(halves, 1);
}
#include "operators/background_lanes.inc"
}  // namespace bath_avx2
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif

// Directions of two grains from words wa and wb (bath_sse2::direction_lanes; the per-grain
// kernel passes one word twice and takes lane 0).
inline void bath_direction_lanes(std::uint64_t wa, std::uint64_t wb, double* rx, double* ry, double* rz) {
  const __m128i w = _mm_set_epi64x(static_cast<long long>(wb), static_cast<long long>(wa));
  const __m128i lo = _mm_shuffle_epi32(w, _MM_SHUFFLE(3, 1, 2, 0));  // (lo a, lo b, hi a, hi b)
  bath_sse2::direction_lanes(lo, _mm_unpackhi_epi64(lo, lo), rx, ry, rz);
}

// The 4 words of test t of grain `id` (the two blocks in one SIMD call; the same bits on
// every path, tests/operators/test_random.cpp).
inline void bath_words(const BathKey& key, std::uint64_t id, std::uint64_t t, std::uint64_t* w) {
  const std::uint32_t c0 = bath_ctr0(id), c1 = bath_ctr1(id, key.stream);
  Philox4x32Lanes::words4(key.seed, &c0, &c1, static_cast<std::uint32_t>(key.step), static_cast<std::uint32_t>(2 * t), 1, w);
}

// The variates of test t of grain `id` from its 4 words.
inline void bath_variates(const std::uint64_t* w, const BathKey& key, std::uint64_t id, std::uint64_t t,
                          BathVariates& x) {
  x.u = bath_uniform(bath_half(w, 0));
  unsigned fail = bath_normal_fast(bath_half(w, 1), x.z[0]);
  fail |= bath_normal_fast(bath_half(w, 2), x.z[1]) << 1;
  fail |= bath_normal_fast(bath_half(w, 3), x.z[2]) << 2;
  fail |= bath_normal_fast(bath_half(w, 4), x.z[3]) << 3;
  fail |= bath_exponential_fast(bath_half(w, 5), x.e) << 4;
  alignas(16) double rx[2], ry[2], rz[2];
  bath_direction_lanes(w[3], w[3], rx, ry, rz);
  x.r = Vec3{rx[0], ry[0], rz[0]};
  if (fail) [[unlikely]]
    bath_variates_slow(w, fail, x, key, id, t);
}

// One thinning test from its variates (law of background_test). Updates v, c = v - uB,
// cmod = |c|; returns whether the candidate was accepted; adds the energy change to gain.
inline bool bath_test(const BathVariates& x, Vec3& v, Vec3& c, double& cmod, const BackgroundState& b,
                      double grain_mass, double& gain) {
  const double tp = x.u * (cmod + b.mean_speed);
  const bool maxwellian = tp < cmod;
  // speed-weighted partner sigma |z_1234| z_123 / |z_123|, Maxwellian sigma z_123: with
  // a = |z_1234| or |z_123|, scale = sigma (a / |z_123|) (exactly sigma for the Maxwellian,
  // a / a = 1) and |c_w| = sigma a
  const double s3 = x.z[0] * x.z[0] + x.z[1] * x.z[1] + x.z[2] * x.z[2], s4 = s3 + x.z[3] * x.z[3];
  const double a3 = std::sqrt(s3), a = std::sqrt(maxwellian ? s3 : s4);
  const double scale = b.sigma * (a / a3);
  const double cw_mod = b.sigma * a;
  const Vec3 g = c - scale * Vec3{x.z[0], x.z[1], x.z[2]};
  const double g2 = norm2(g);
  const double tpp = tp - (maxwellian ? 0.0 : cmod), d = maxwellian ? cmod : b.mean_speed;
  const double lhs = tpp * (cmod + cw_mod);
  const bool accept = lhs * lhs < g2 * (d * d);
  // applied without a branch: dv and de times 1 or 0 (v + 0 dv = v)
  const double on = accept;
  const Vec3 dv = -b.mass_ratio * (g - std::sqrt(g2) * x.r);
  const Vec3 vn = v + dv;
  const double de = 0.5 * grain_mass * (norm2(vn) - norm2(v));
  v += on * dv;
  gain += on * de;
  c = v - b.velocity;
  cmod = norm(c);
  return accept;
}

}  // namespace detail

// One grain through a bath substep of length `duration` with the carried residual `hazard`
// (law of evolve_in_background). `gain` receives the grain's energy change (summed over its
// collisions in order); counters get the candidates and collisions.
inline void bath_evolve_keyed(Vec3& v, double& hazard, const BackgroundState& b, double grain_mass, double duration,
                              const BathKey& key, std::uint64_t id, BackgroundCounters& counters, double& gain) {
  gain = 0.0;
  if (b.rate_scale <= 0.0) return;
  Vec3 c = v - b.velocity;
  double cmod = norm(c);
  double rate = b.rate_scale * (cmod + b.mean_speed);
  double need = rate * duration;
  if (hazard >= need) {
    hazard -= need;
    return;
  }
  double left = std::max(0.0, duration - hazard / rate);
  BathVariates x;
  std::uint64_t w[8];
  for (std::uint64_t t = 0;; ++t) {
    detail::bath_words(key, id, t, w);
    detail::bath_variates(w, key, id, t, x);
    ++counters.candidates;
    counters.collisions += detail::bath_test(x, v, c, cmod, b, grain_mass, gain);
    rate = b.rate_scale * (cmod + b.mean_speed);
    need = rate * left;
    if (x.e >= need) {
      hazard = x.e - need;
      return;
    }
    left = std::max(0.0, left - x.e / rate);
  }
}

// All grains [0, n) of arrays vx, vy, vz, hazard (ids in `id`) through a bath substep in a
// uniform medium: bitwise the results of bath_evolve_keyed per grain, with the energy
// gains added to counters.energy_gain grain by grain in index order. Grains are taken in
// chunks of 256 whose active grains (those with a candidate left) are kept compacted in
// structure-of-arrays scratch; in round t every active grain makes its test t, in passes:
// (1) the round's Philox4x32 words, all grains at once in integer SIMD; (2) the variates of
// each test, a register of grains at a time (ziggurat fast paths, directions in lanes), into
// arrays, the grains needing a slow path listed and done after the pass; (3) the tests a
// register at a time, split in three loops (acceptance, collision, next candidate: shorter
// dependency chains per loop body, so more grains overlap; tests of different grains are
// independent and no branch depends on the acceptance), then the write-back and the
// compaction of the grains that go on. A short last group of lanes computes padding
// (copies of valid lanes) that is not written back. Four lanes in AVX2 where the CPU has
// it, else two in SSE2 (operators/background_lanes.inc): bitwise the same results.
inline void bath_evolve_batch(std::size_t n, const std::uint64_t* id, double* vx, double* vy, double* vz,
                              double* hazard, const BackgroundState& b, double grain_mass, double duration,
                              const BathKey& key, BackgroundCounters& counters) {
  if (Philox4x32Lanes::have_avx2())
    detail::bath_avx2::evolve_batch(n, id, vx, vy, vz, hazard, b, grain_mass, duration, key, counters);
  else
    detail::bath_sse2::evolve_batch(n, id, vx, vy, vz, hazard, b, grain_mass, duration, key, counters);
}

// The same for grains each in its own medium: grain i of [0, n) in media[i] (a background
// that varies in space, DSMC's local_background at the grain's position): bitwise the
// results of bath_evolve_keyed per grain with media[i] (a grain whose medium has rate_scale
// <= 0 keeps its velocity and residual). The grains enter the chunk one by one (each with its
// own rate), the tests run in lanes as above with each lane's medium compacted beside its
// grain.
inline void bath_evolve_batch_local(std::size_t n, const std::uint64_t* id, double* vx, double* vy, double* vz,
                                    double* hazard, const BackgroundState* media, double grain_mass, double duration,
                                    const BathKey& key, BackgroundCounters& counters) {
  if (Philox4x32Lanes::have_avx2())
    detail::bath_avx2::evolve_batch_local(n, id, vx, vy, vz, hazard, media, grain_mass, duration, key, counters);
  else
    detail::bath_sse2::evolve_batch_local(n, id, vx, vy, vz, hazard, media, grain_mass, duration, key, counters);
}

}  // namespace grainbath
