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
#include <cstdint>
#include <cstring>
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

// Two lanes of doubles (GCC vector extension, one SSE2 register on baseline x86-64): the
// element-wise IEEE operations are those of the scalar code, so each lane gets bitwise the
// scalar result.
typedef double BathLanes __attribute__((vector_size(16)));
typedef long long BathMask __attribute__((vector_size(16)));

inline BathLanes bath_sqrt(BathLanes x) { return _mm_sqrt_pd(x); }
inline BathLanes bath_select(BathMask m, BathLanes a, BathLanes b) {
  return reinterpret_cast<BathLanes>((reinterpret_cast<BathMask>(a) & m) | (reinterpret_cast<BathMask>(b) & ~m));
}
inline BathLanes bath_load(const double* p) {
  BathLanes x;
  std::memcpy(&x, p, sizeof x);
  return x;
}
inline void bath_store(double* p, BathLanes x) { std::memcpy(p, &x, sizeof x); }

// Uniform directions of two grains (lane 0 from word wa, lane 1 from wb), without rejection
// (Archimedes: z = cos(theta) uniform on (-1, 1) and an independent uniform azimuth phi give
// a uniform direction): z from the low 32 bits read as a signed integer, (k + 1/2) 2^-31
// (odd multiples of 2^-32, symmetric about 0, |z| < 1); phi = q pi/2 + a with the quadrant
// q from bits 62-63 and a = (j - 2^29 + 1/2) (pi/2) 2^-30 in (-pi/4, pi/4) from bits 32-61.
// cos a and sin a by their Taylor series to a^16 and a^15 (polynomials in a^2): the truncation
// is below (pi/4)^17/17! = 5e-17, so each is within a few ulp of the true value; the
// rotation by q quarter turns is exact (swap and sign flips):
//   (cos phi, sin phi) = (c, s), (-s, c), (-c, -s), (s, -c) for q = 0, 1, 2, 3.
// r = (rho cos phi, rho sin phi, z) with rho = sqrt((1 - z)(1 + z)) (1 - z, 1 + z exact).
// Plain IEEE operations in SSE2 lanes (no FMA, no libm): the same bits on every x86-64,
// and bath_evolve_keyed calls this very function (lane 0) so both kernels agree bitwise.
inline void bath_direction_lanes(std::uint64_t wa, std::uint64_t wb, double* rx, double* ry, double* rz) {
  const __m128i w = _mm_set_epi64x(static_cast<long long>(wb), static_cast<long long>(wa));
  // low halves (z) and high halves (azimuth) of the two words as int32 pairs
  const __m128i lo = _mm_shuffle_epi32(w, _MM_SHUFFLE(3, 1, 2, 0));   // (lo a, lo b, hi a, hi b)
  const __m128i hi = _mm_unpackhi_epi64(lo, lo);
  const BathLanes half = {0.5, 0.5}, one = {1.0, 1.0};
  const BathLanes z = (_mm_cvtepi32_pd(lo) + half) * 0x1.0p-31;
  const __m128i j = _mm_sub_epi32(_mm_and_si128(hi, _mm_set1_epi32(0x3fffffff)), _mm_set1_epi32(1 << 29));
  const BathLanes a = (_mm_cvtepi32_pd(j) + half) * (std::numbers::pi * 0x1.0p-31);
  const BathLanes t = a * a;
  // Estrin's scheme in t (pairs of terms, then t^2, t^4): a dependency chain of 6
  // operations instead of 16 by Horner's rule, so the variates pass keeps more grains in
  // flight; every term is added in the same fixed order on every machine
  const BathLanes t2 = t * t, t4 = t2 * t2;
  const BathLanes sp = ((-1.0 / 6 + t * (1.0 / 120)) + t2 * (-1.0 / 5040 + t * (1.0 / 362880))) +
                       t4 * ((-1.0 / 39916800 + t * (1.0 / 6227020800.0)) + t2 * (-1.0 / 1307674368000.0));
  const BathLanes cp = ((-1.0 / 2 + t * (1.0 / 24)) + t2 * (-1.0 / 720 + t * (1.0 / 40320))) +
                       t4 * ((-1.0 / 3628800 + t * (1.0 / 479001600)) + t2 * (-1.0 / 87178291200.0 + t * (1.0 / 20922789888000.0)));
  const BathLanes s = a + (a * t) * sp;
  const BathLanes c = one + t * cp;
  // q odd: swap; x negated for q = 1, 2 (bit 62 xor bit 63), y for q = 2, 3 (bit 63)
  const BathMask odd = reinterpret_cast<BathMask>(_mm_shuffle_epi32(_mm_srai_epi32(_mm_slli_epi32(w, 1), 31), _MM_SHUFFLE(3, 3, 1, 1)));
  const BathMask sign = {static_cast<long long>(0x8000000000000000ull), static_cast<long long>(0x8000000000000000ull)};
  const BathMask wm = reinterpret_cast<BathMask>(w);
  const BathMask neg_x = (wm ^ (wm << 1)) & sign, neg_y = wm & sign;
  const BathLanes x = reinterpret_cast<BathLanes>(reinterpret_cast<BathMask>(bath_select(odd, s, c)) ^ neg_x);
  const BathLanes y = reinterpret_cast<BathLanes>(reinterpret_cast<BathMask>(bath_select(odd, c, s)) ^ neg_y);
  const BathLanes rho = bath_sqrt((one - z) * (one + z));
  bath_store(rx, rho * x);
  bath_store(ry, rho * y);
  bath_store(rz, z);
}

// The bath kernel's own ziggurats (Marsaglia & Tsang 2000, as ZigguratTable, here with
// 2^kBits layers): more layers make the fast path more likely (the normal's slow path
// 0.43% per draw with 1024 layers instead of 1.5% with 256, the exponential's 0.64% instead
// of 2.2%) at the price of table size (48 KB with the sign folded in: measured faster than
// 512 layers in the kernel alone, 38.3 vs 39.6 ns per test, and the same in the whole run)
// and of two bits of the uniform across the layer (21 instead of 23 for the normal: the
// distribution function's bound goes from 2^-24 to 2^-22, see above). The tables are built at
// program start from the same closure condition as ZigguratTable (bisection on r so that
// the equal-area layers close at the mode), for the densities exp(-x^2/2) and exp(-x).
struct BathZigguratLayers {
  static constexpr int kBits = 10, kLayers = 1 << kBits;
  double x[kLayers + 1];  // layer edges, x[0] virtual base width v / f(r), x[1] = r, x[kLayers] = 0
  double ratio[kLayers];  // x[i+1] / x[i]
  double f[kLayers + 1];  // f(x[i])
  double r = 0.0;         // start of the tail

  template <class F, class FInv, class Tail>
  static BathZigguratLayers build(F f, FInv finv, Tail tail, long double lo, long double hi) {
    BathZigguratLayers t{};
    auto defect = [&](long double r, BathZigguratLayers* out) -> long double {
      const long double v = r * f(r) + tail(r);
      long double x = r;
      if (out) {
        out->x[0] = static_cast<double>(v / f(r));
        out->x[1] = static_cast<double>(r);
      }
      for (int i = 1; i < kLayers - 1; ++i) {
        const long double y = v / x + f(x);
        if (y >= 1.0L) return 1.0L + (kLayers - i);  // closed too early: r too small
        x = finv(y);
        if (out) out->x[i + 1] = static_cast<double>(x);
      }
      return v / x + f(x) - 1.0L;
    };
    // bisection to the last bit of long double (~66 halvings; each costs kLayers inverse
    // densities, and the tables are built at the start of every process)
    long double a = lo, b = hi;
    for (;;) {
      const long double m = 0.5L * (a + b);
      if (!(a < m && m < b)) break;
      (defect(m, nullptr) > 0 ? a : b) = m;
    }
    t.r = static_cast<double>(b);
    defect(b, &t);
    t.x[kLayers] = 0.0;
    for (int i = 0; i <= kLayers; ++i) t.f[i] = static_cast<double>(f(static_cast<long double>(t.x[i])));
    for (int i = 0; i < kLayers; ++i) t.ratio[i] = t.x[i + 1] / t.x[i];
    return t;
  }
};
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

namespace detail {

// bath_test for two grains at once (lanes), in three parts run as three passes over the
// active grains: this one (the partner and the acceptance), bath_collide_lanes (the
// collision, applied times `on`) and bath_next_lanes (the next candidate's bookkeeping of
// bath_evolve_keyed). The same operations in the same order as bath_test and
// bath_evolve_keyed for each lane, so bitwise the same results; the independent lanes'
// square roots and divisions overlap. Out: g = c - c_w, |g|^2 and on = 1 (accepted) or 0.
inline void bath_test_lanes(BathLanes u, BathLanes z0, BathLanes z1, BathLanes z2, BathLanes z3, BathLanes vx,
                            BathLanes vy, BathLanes vz, BathLanes cmod, BathLanes& gx, BathLanes& gy, BathLanes& gz,
                            BathLanes& g2, BathLanes& on, const BackgroundState& b) {
  const BathLanes zero = {0.0, 0.0};
  const BathLanes cx = vx - b.velocity.x, cy = vy - b.velocity.y, cz = vz - b.velocity.z;
  const BathLanes tp = u * (cmod + b.mean_speed);
  const BathMask maxw = tp < cmod;
  const BathLanes s3 = z0 * z0 + z1 * z1 + z2 * z2, s4 = s3 + z3 * z3;
  const BathLanes a3 = bath_sqrt(s3), a = bath_sqrt(bath_select(maxw, s3, s4));
  const BathLanes scale = b.sigma * (a / a3);
  gx = cx - z0 * scale, gy = cy - z1 * scale, gz = cz - z2 * scale;
  g2 = gx * gx + gy * gy + gz * gz;
  const BathLanes cw_mod = b.sigma * a;
  const BathLanes tpp = tp - bath_select(maxw, zero, cmod), d = bath_select(maxw, cmod, zero + b.mean_speed);
  const BathLanes lhs = tpp * (cmod + cw_mod);
  on = bath_select(lhs * lhs < g2 * (d * d), zero + 1.0, zero);
}

// The collision of bath_test_lanes' candidates, applied times `on` (1 or 0): v' = v - alpha
// (g - |g| r), and the energy change. Separate passes (Issue #7): one test is a chain of
// about 150 cycles of dependent square roots and divisions, and with the whole test in one
// loop body only about two iterations fit in the out-of-order window; three shorter loops
// (acceptance, collision, next candidate) overlap more grains.
inline void bath_collide_lanes(BathLanes gx, BathLanes gy, BathLanes gz, BathLanes g2, BathLanes on, BathLanes rx,
                               BathLanes ry, BathLanes rz, BathLanes& vx, BathLanes& vy, BathLanes& vz,
                               BathLanes& gain, const BackgroundState& b, double grain_mass) {
  const BathLanes gm = bath_sqrt(g2);
  const BathLanes dvx = (gx - rx * gm) * -b.mass_ratio, dvy = (gy - ry * gm) * -b.mass_ratio,
                  dvz = (gz - rz * gm) * -b.mass_ratio;
  const BathLanes nx = vx + dvx, ny = vy + dvy, nz = vz + dvz;
  const BathLanes de = 0.5 * grain_mass * ((nx * nx + ny * ny + nz * nz) - (vx * vx + vy * vy + vz * vz));
  vx += dvx * on;
  vy += dvy * on;
  vz += dvz * on;
  gain += de * on;
}

// The bookkeeping of the next candidate after bath_test_lanes (bath_evolve_keyed per lane):
// |c| of the new velocity, and the residual `hazard`, the remaining time `left` and `more`
// (1 if the grain has a further candidate in this substep, else 0) from the exponential e.
inline void bath_next_lanes(BathLanes e, BathLanes vx, BathLanes vy, BathLanes vz, BathLanes& cmod, BathLanes& hazard,
                            BathLanes& left, BathLanes& more, const BackgroundState& b) {
  const BathLanes zero = {0.0, 0.0};
  const BathLanes ex = vx - b.velocity.x, ey = vy - b.velocity.y, ez = vz - b.velocity.z;
  cmod = bath_sqrt(ex * ex + ey * ey + ez * ez);
  // next candidate (bath_evolve_keyed): done if the new residual covers the rest
  const BathLanes rate = b.rate_scale * (cmod + b.mean_speed);
  const BathLanes need = rate * left;
  const BathMask done = e >= need;
  hazard = bath_select(done, e - need, e);
  more = bath_select(done, zero, zero + 1.0);
  const BathLanes rest = left - e / rate;
  left = bath_select(zero < rest, rest, zero);
}


}  // namespace detail

// All grains [0, n) of arrays vx, vy, vz, hazard (ids in `id`) through a bath substep in a
// uniform medium: bitwise the results of bath_evolve_keyed per grain, with the energy
// gains added to counters.energy_gain grain by grain in index order. Grains are taken in
// chunks of 256 whose active grains (those with a candidate left) are kept compacted in
// structure-of-arrays scratch; in round t every active grain makes its test t, in passes:
// (1) the round's Philox4x32 words, all grains at once in integer SIMD; (2) the variates of
// each test, two grains at a time (ziggurat fast paths, directions in SSE2 lanes), into
// arrays, the grains needing a slow path listed and done after the pass; (3) the tests two
// lanes at a time, split in three loops (acceptance, collision, next candidate: shorter
// dependency chains per loop body, so more grains overlap; tests of different grains are
// independent and no branch depends on the acceptance), then the write-back and the
// compaction of the grains that go on. A short last group of lanes computes padding
// (copies of valid lanes) that is not written back.
inline void bath_evolve_batch(std::size_t n, const std::uint64_t* id, double* vx, double* vy, double* vz,
                              double* hazard, const BackgroundState& b, double grain_mass, double duration,
                              const BathKey& key, BackgroundCounters& counters) {
  if (b.rate_scale <= 0.0) return;
  constexpr std::size_t kChunk = 256, L = 2;
  std::uint32_t index[kChunk], ctr0[kChunk], ctr1[kChunk], slow[kChunk + 2];
  alignas(64) std::uint64_t words[4 * (kChunk + 1)];
  // active-grain state and this round's variates, padded to whole lane groups
  alignas(64) double avx[kChunk + L], avy[kChunk + L], avz[kChunk + L], acm[kChunk + L], aleft[kChunk + L],
      again[kChunk + L], ahz[kChunk + L], aon[kChunk + L], amore[kChunk + L];
  alignas(64) double xu[kChunk + L], xz0[kChunk + L], xz1[kChunk + L], xz2[kChunk + L], xz3[kChunk + L],
      xe[kChunk + L], xrx[kChunk + L], xry[kChunk + L], xrz[kChunk + L];
  double gain[kChunk];
  std::uint64_t candidates = 0, collisions = 0;
  for (std::size_t lo = 0; lo < n; lo += kChunk) {
    const std::size_t m = std::min(kChunk, n - lo);
    std::size_t na = 0;
    // which grains have a candidate in this substep: two grains per SSE2 register (the
    // operations of bath_evolve_keyed per lane), an odd last grain in scalar code
    auto enter = [&](std::size_t k, double cmod, double h, double need, double left, bool run) {
      const std::size_t i = lo + k;
      hazard[i] = run ? h : h - need;
      gain[k] = 0.0;
      index[na] = static_cast<std::uint32_t>(k);
      ctr0[na] = detail::bath_ctr0(id[i]);
      ctr1[na] = detail::bath_ctr1(id[i], key.stream);
      avx[na] = vx[i];
      avy[na] = vy[i];
      avz[na] = vz[i];
      acm[na] = cmod;
      again[na] = 0.0;
      aleft[na] = left;
      na += run;
    };
    std::size_t k = 0;
    for (; k + 2 <= m; k += 2) {
      using detail::BathLanes;
      const std::size_t i = lo + k;
      const BathLanes zero = {0.0, 0.0};
      const BathLanes cx = detail::bath_load(vx + i) - b.velocity.x, cy = detail::bath_load(vy + i) - b.velocity.y,
                      cz = detail::bath_load(vz + i) - b.velocity.z;
      const BathLanes cmod = detail::bath_sqrt(cx * cx + cy * cy + cz * cz);
      const BathLanes rate = b.rate_scale * (cmod + b.mean_speed);
      const BathLanes need = rate * duration;
      const BathLanes h = detail::bath_load(hazard + i);
      const BathLanes rest = duration - h / rate;
      const BathLanes left = detail::bath_select(zero < rest, rest, zero);
      const int run = _mm_movemask_pd(h < need);
      enter(k, cmod[0], h[0], need[0], left[0], run & 1);
      enter(k + 1, cmod[1], h[1], need[1], left[1], run >> 1);
    }
    if (k < m) {
      const std::size_t i = lo + k;
      const double cmod = norm(Vec3{vx[i], vy[i], vz[i]} - b.velocity);
      const double rate = b.rate_scale * (cmod + b.mean_speed);
      const double need = rate * duration;
      const double h = hazard[i];
      enter(k, cmod, h, need, std::max(0.0, duration - h / rate), h < need);
    }
    for (std::uint64_t t = 0; na > 0; ++t) {
      candidates += na;
      // (1) words
      Philox4x32Lanes::words4(key.seed, ctr0, ctr1, static_cast<std::uint32_t>(key.step), static_cast<std::uint32_t>(2 * t),
                              na, words);
      // (2) variates, two grains at a time: the ziggurat fast paths (scalar: table loads),
      // the directions in SSE2 lanes; the rare slow path per grain. An odd last grain is
      // paired with a copy of its words (padding, not used).
      if (na % 2 != 0) std::memcpy(words + 4 * na, words + 4 * (na - 1), 4 * sizeof(std::uint64_t));
      std::size_t nslow = 0;
      for (std::size_t a = 0; a < na; a += 2) {
        using detail::bath_half;
        const std::uint64_t* wa = words + 4 * a;
        const std::uint64_t* wb = wa + 4;
        std::uint32_t fa, fb;
        xu[a] = detail::bath_uniform(bath_half(wa, 0));
        xu[a + 1] = detail::bath_uniform(bath_half(wb, 0));
        fa = detail::bath_normal_fast(bath_half(wa, 1), xz0[a]);
        fb = detail::bath_normal_fast(bath_half(wb, 1), xz0[a + 1]);
        fa |= detail::bath_normal_fast(bath_half(wa, 2), xz1[a]) << 1;
        fb |= detail::bath_normal_fast(bath_half(wb, 2), xz1[a + 1]) << 1;
        fa |= detail::bath_normal_fast(bath_half(wa, 3), xz2[a]) << 2;
        fb |= detail::bath_normal_fast(bath_half(wb, 3), xz2[a + 1]) << 2;
        fa |= detail::bath_normal_fast(bath_half(wa, 4), xz3[a]) << 3;
        fb |= detail::bath_normal_fast(bath_half(wb, 4), xz3[a + 1]) << 3;
        fa |= detail::bath_exponential_fast(bath_half(wa, 5), xe[a]) << 4;
        fb |= detail::bath_exponential_fast(bath_half(wb, 5), xe[a + 1]) << 4;
        detail::bath_direction_lanes(wa[3], wb[3], xrx + a, xry + a, xrz + a);
        // grains needing a slow path are listed without a branch and done after the pass
        // (a branch here was mispredicted on most of the tests that take one)
        slow[nslow] = static_cast<std::uint32_t>(a) | fa << 16;
        nslow += fa != 0;
        slow[nslow] = static_cast<std::uint32_t>(a + 1) | fb << 16;
        nslow += (fb != 0) & (a + 1 < na);
      }
      for (std::size_t q = 0; q < nslow; ++q) {
        const std::size_t g = slow[q] & 0xffffu;
        detail::bath_variates_slow_lane(words + 4 * g, slow[q] >> 16, key, id[lo + index[g]], t, g, xz0, xz1, xz2, xz3, xe);
      }
      // padding lanes: copies of the last active grain
      for (std::size_t a = na; a % L != 0; ++a) {
        for (double* p : {avx, avy, avz, acm, aleft, again, xu, xz0, xz1, xz2, xz3, xe, xrx, xry, xrz}) p[a] = p[na - 1];
      }
      // (3) tests
      for (std::size_t a = 0; a < na; a += L) {
        using detail::bath_load;
        detail::BathLanes gx, gy, gz, g2, on;
        detail::bath_test_lanes(bath_load(xu + a), bath_load(xz0 + a), bath_load(xz1 + a), bath_load(xz2 + a),
                                bath_load(xz3 + a), bath_load(avx + a), bath_load(avy + a), bath_load(avz + a),
                                bath_load(acm + a), gx, gy, gz, g2, on, b);
        // the partner's normals are not needed any more: their arrays take g
        detail::bath_store(xz0 + a, gx);
        detail::bath_store(xz1 + a, gy);
        detail::bath_store(xz2 + a, gz);
        detail::bath_store(xz3 + a, g2);
        detail::bath_store(aon + a, on);
      }
      for (std::size_t a = 0; a < na; a += L) {
        using detail::bath_load;
        detail::BathLanes lvx = bath_load(avx + a), lvy = bath_load(avy + a), lvz = bath_load(avz + a),
                          lg = bath_load(again + a);
        detail::bath_collide_lanes(bath_load(xz0 + a), bath_load(xz1 + a), bath_load(xz2 + a), bath_load(xz3 + a),
                                   bath_load(aon + a), bath_load(xrx + a), bath_load(xry + a), bath_load(xrz + a), lvx,
                                   lvy, lvz, lg, b, grain_mass);
        detail::bath_store(avx + a, lvx);
        detail::bath_store(avy + a, lvy);
        detail::bath_store(avz + a, lvz);
        detail::bath_store(again + a, lg);
      }
      for (std::size_t a = 0; a < na; a += L) {
        using detail::bath_load;
        detail::BathLanes lcm, lleft = bath_load(aleft + a), hz, more;
        detail::bath_next_lanes(bath_load(xe + a), bath_load(avx + a), bath_load(avy + a), bath_load(avz + a), lcm, hz,
                                lleft, more, b);
        detail::bath_store(acm + a, lcm);
        detail::bath_store(aleft + a, lleft);
        detail::bath_store(ahz + a, hz);
        detail::bath_store(amore + a, more);
      }
      // write back, and keep the grains that go on
      std::size_t nn = 0;
      for (std::size_t a = 0; a < na; ++a) {
        const std::size_t k = index[a], i = lo + k;
        vx[i] = avx[a];
        vy[i] = avy[a];
        vz[i] = avz[a];
        hazard[i] = ahz[a];
        gain[k] = again[a];
        collisions += static_cast<std::uint64_t>(aon[a]);
        index[nn] = index[a];
        ctr0[nn] = ctr0[a];
        ctr1[nn] = ctr1[a];
        avx[nn] = avx[a];
        avy[nn] = avy[a];
        avz[nn] = avz[a];
        acm[nn] = acm[a];
        again[nn] = again[a];
        aleft[nn] = aleft[a];
        nn += static_cast<std::size_t>(amore[a]);
      }
      na = nn;
    }
    for (std::size_t k = 0; k < m; ++k) counters.energy_gain += gain[k];
  }
  counters.candidates += candidates;
  counters.collisions += collisions;
}

}  // namespace grainbath
