#pragma once
// DSMC collision kernels. Written once, templated on the restitution law (selected by name
// once per step with std::visit, never inside the loop): no virtual call, no allocation,
// no std:: distribution object in the hot loops.
#include <emmintrin.h>
#include <immintrin.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <type_traits>
#include <algorithm>

#include "dsmc/particles.hpp"
#include "operators/background.hpp"
#include "operators/binary_collision.hpp"
#include "operators/random.hpp"
#include "operators/restitution.hpp"

namespace grainbath::dsmc {

struct GrainCounters {
  std::uint64_t candidates = 0;
  std::uint64_t collisions = 0;
  std::uint64_t clamped = 0;         // power law gave e < 0: clamped to 0
  // times a pair became faster than the step's bound g_max: the bound was raised and the
  // candidates still to come rescaled (BoundGuard; summary counters.majorant_exceeded)
  std::uint64_t bound_exceeded = 0;
  double energy_loss = 0.0;          // kinetic energy dissipated
  void add(const GrainCounters& o) {
    candidates += o.candidates;
    collisions += o.collisions;
    clamped += o.clamped;
    bound_exceeded += o.bound_exceeded;
    energy_loss += o.energy_loss;
  }
};

// What a pair-speed bound was computed from: a reference point a (any point serves:
// |v_i - v_j| <= |v_i - a| + |v_j - a|) and the largest |v - a|^2 over the grains. The
// candidate loop keeps the bound valid after each collision from these (BoundGuard below).
struct BoundReference {
  double ax = 0.0, ay = 0.0, az = 0.0;
  double max_deviation2 = 0.0;
};

// Upper bound on |v_i - v_j| in a cell: |c_i - c_j| <= |c_i| + |c_j| <= 2 max|c| with c
// relative to the cell mean. Exact at the start of the substep; post-collision speeds can
// exceed it (|c'| <= 2 max|c|), hence the BoundGuard of the candidate loops.
inline double relative_speed_bound(const Particles& p, std::size_t begin, std::size_t end,
                                   BoundReference* ref = nullptr) {
  const double inv = 1.0 / static_cast<double>(end - begin);
  double mx = 0, my = 0, mz = 0;
  for (std::size_t i = begin; i < end; ++i) {
    mx += p.vx[i];
    my += p.vy[i];
    mz += p.vz[i];
  }
  mx *= inv;
  my *= inv;
  mz *= inv;
  double c2max = 0;
  for (std::size_t i = begin; i < end; ++i) {
    const double cx = p.vx[i] - mx, cy = p.vy[i] - my, cz = p.vz[i] - mz;
    c2max = std::max(c2max, cx * cx + cy * cy + cz * cz);
  }
  if (ref) *ref = {mx, my, mz, c2max};
  return 2.0 * std::sqrt(c2max);
}

// Upper bound on |v_i - v_j| over the distinct pairs of a cell, tighter than
// relative_speed_bound: |c_i - c_j| <= |c_i| + |c_j| <= c_(1) + c_(2), the two largest |c|
// relative to the cell mean (equal when two grains move head-on at the two largest speeds).
// The NTC acceptance |g| / g_max rises by the ratio 2 c_(1) / (c_(1) + c_(2)), ~8 % fewer
// candidates at 16 grains per cell, same collision statistics (Bird 1994, sec. 11.1: any
// bound >= max |g| gives the exact rate). Post-collision speeds can exceed it, hence the
// BoundGuard of the candidate loop. The mean is summed in two interleaved partial sums,
// even and odd slots (fixed order, so the bound is a function of the cell's velocities alone).
inline double pair_speed_bound(const double* __restrict vx, const double* __restrict vy, const double* __restrict vz,
                               std::size_t count, BoundReference* ref = nullptr) {
  // two particles per SSE2 vector: lane 0 the even, lane 1 the odd slots (the two partial
  // sums above); the top two |c|^2 are kept per lane, then merged (max and min are exact,
  // so the bound does not depend on how the values are split)
  __m128d sx = _mm_setzero_pd(), sy = _mm_setzero_pd(), sz = _mm_setzero_pd();
  std::size_t i = 0;
  for (; i + 1 < count; i += 2) {
    sx = _mm_add_pd(sx, _mm_loadu_pd(vx + i));
    sy = _mm_add_pd(sy, _mm_loadu_pd(vy + i));
    sz = _mm_add_pd(sz, _mm_loadu_pd(vz + i));
  }
  alignas(16) double lx[2], ly[2], lz[2];
  _mm_store_pd(lx, sx);
  _mm_store_pd(ly, sy);
  _mm_store_pd(lz, sz);
  if (i < count) {
    lx[0] += vx[i];
    ly[0] += vy[i];
    lz[0] += vz[i];
  }
  const double inv = 1.0 / static_cast<double>(count);
  const double mx = (lx[0] + lx[1]) * inv, my = (ly[0] + ly[1]) * inv, mz = (lz[0] + lz[1]) * inv;
  const __m128d mx2 = _mm_set1_pd(mx), my2 = _mm_set1_pd(my), mz2 = _mm_set1_pd(mz);
  __m128d first2 = _mm_setzero_pd(), second2 = _mm_setzero_pd();  // per lane, the two largest |c|^2
  std::size_t k = 0;
  for (; k + 1 < count; k += 2) {
    const __m128d cx = _mm_sub_pd(_mm_loadu_pd(vx + k), mx2);
    const __m128d cy = _mm_sub_pd(_mm_loadu_pd(vy + k), my2);
    const __m128d cz = _mm_sub_pd(_mm_loadu_pd(vz + k), mz2);
    const __m128d c2 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(cx, cx), _mm_mul_pd(cy, cy)), _mm_mul_pd(cz, cz));
    second2 = _mm_max_pd(second2, _mm_min_pd(first2, c2));
    first2 = _mm_max_pd(first2, c2);
  }
  alignas(16) double f[2], g[2];
  _mm_store_pd(f, first2);
  _mm_store_pd(g, second2);
  double first = 0, second = 0;
  auto push = [&](double c2) {
    second = std::max(second, std::min(first, c2));
    first = std::max(first, c2);
  };
  push(f[0]);
  push(g[0]);
  push(f[1]);
  push(g[1]);
  if (k < count) {
    const double cx = vx[k] - mx, cy = vy[k] - my, cz = vz[k] - mz;
    push(cx * cx + cy * cy + cz * cz);
  }
  if (ref) *ref = {mx, my, mz, first};
  return std::sqrt(first) + std::sqrt(second);
}

namespace detail {
// pair_speed_bound for cells of 2..24 grains without a data-dependent branch, where the CPU has
// AVX-512F and VL (128- and 256-bit registers only). The SSE2 bound's loops run count / 2
// times and its tails depend on count's parity: a cell's count (Poisson around 16 in DSMC-1)
// decides three or four branches per cell that the predictor cannot know. Here every loop
// runs its full length with masked loads (the lanes past the cell load zero, and fault-free
// past the arrays' ends): the same sums in the same order, twelve pairs (a pair past the cell
// adds +0.0, which changes no sum: a sum that starts at +0.0 is never -0.0), and the top two
// |c|^2 of the same values plus zeros (masked lanes give c = 0; both maxima start at +0.0, and
// the two largest of a multiset do not depend on the order they are taken in, so the result
// is the SSE2 bound's bit for bit for finite velocities). No FMA: each product is rounded
// before its sum, as in the SSE2 code (rounded() below). Cells above 24 grains (2.6 % at a
// mean of 16) take the SSE2 bound. DSMC-1 at 1e6: ~0.4-0.65 ms of ~33 ms per step faster
// (steps alternating between the two bounds in one process, 4 x 99 pairs, 61-80 of 99
// faster; docs/performance/dsmc1.md, h-dsmc11), where splitting the SSE2 loop's dependent
// max chain in two had made no difference: the branches, not the chains, cost.
//
// An opaque copy of a product: GCC contracts a * b + c into an FMA wherever the target has
// FMA, which AVX-512F implies ("no-fma" beside "avx512f" does not switch it off: GCC 12 still
// emitted vfmadd here, and the bound differed in the last bit).
[[gnu::target("avx512f,avx512vl"), gnu::always_inline]] inline __m256d rounded(__m256d x) {
  __asm__("" : "+v"(x));
  return x;
}
[[gnu::target("avx512f,avx512vl")]] inline double pair_speed_bound_24(const double* __restrict vx,
                                                                            const double* __restrict vy,
                                                                            const double* __restrict vz, std::size_t count,
                                                                            BoundReference* ref = nullptr) {
  const std::uint32_t valid = (std::uint32_t{1} << count) - 1;  // bit s: slot s of the cell
  __m128d sx = _mm_setzero_pd(), sy = _mm_setzero_pd(), sz = _mm_setzero_pd();
  for (int q = 0; q < 12; ++q) {  // pair q: lane 0 the even slot 2q, lane 1 the odd slot 2q + 1
    const auto m = static_cast<__mmask8>(valid >> (2 * q));
    sx = _mm_add_pd(sx, _mm_maskz_loadu_pd(m, vx + 2 * q));
    sy = _mm_add_pd(sy, _mm_maskz_loadu_pd(m, vy + 2 * q));
    sz = _mm_add_pd(sz, _mm_maskz_loadu_pd(m, vz + 2 * q));
  }
  const double inv = 1.0 / static_cast<double>(count);
  const double mx = (_mm_cvtsd_f64(sx) + _mm_cvtsd_f64(_mm_unpackhi_pd(sx, sx))) * inv;
  const double my = (_mm_cvtsd_f64(sy) + _mm_cvtsd_f64(_mm_unpackhi_pd(sy, sy))) * inv;
  const double mz = (_mm_cvtsd_f64(sz) + _mm_cvtsd_f64(_mm_unpackhi_pd(sz, sz))) * inv;
  const __m256d mx4 = _mm256_set1_pd(mx), my4 = _mm256_set1_pd(my), mz4 = _mm256_set1_pd(mz);
  __m256d first4 = _mm256_setzero_pd(), second4 = _mm256_setzero_pd();  // per lane, the two largest |c|^2
  for (int q = 0; q < 6; ++q) {  // slots 4q .. 4q + 3
    const auto m = static_cast<__mmask8>(valid >> (4 * q));
    const __m256d cx = _mm256_maskz_sub_pd(m, _mm256_maskz_loadu_pd(m, vx + 4 * q), mx4);
    const __m256d cy = _mm256_maskz_sub_pd(m, _mm256_maskz_loadu_pd(m, vy + 4 * q), my4);
    const __m256d cz = _mm256_maskz_sub_pd(m, _mm256_maskz_loadu_pd(m, vz + 4 * q), mz4);
    const __m256d c2 = _mm256_add_pd(_mm256_add_pd(rounded(_mm256_mul_pd(cx, cx)), rounded(_mm256_mul_pd(cy, cy))),
                                     rounded(_mm256_mul_pd(cz, cz)));
    second4 = _mm256_max_pd(second4, _mm256_min_pd(first4, c2));
    first4 = _mm256_max_pd(first4, c2);
  }
  // the two largest of the lanes' pairs: halves, then lanes (max and min are exact)
  const __m128d f_lo = _mm256_castpd256_pd128(first4), f_hi = _mm256_extractf128_pd(first4, 1);
  const __m128d s_lo = _mm256_castpd256_pd128(second4), s_hi = _mm256_extractf128_pd(second4, 1);
  const __m128d f2 = _mm_max_pd(f_lo, f_hi);
  const __m128d s2 = _mm_max_pd(_mm_max_pd(s_lo, s_hi), _mm_min_pd(f_lo, f_hi));
  const __m128d f2h = _mm_unpackhi_pd(f2, f2), s2h = _mm_unpackhi_pd(s2, s2);
  const double first = _mm_cvtsd_f64(_mm_max_sd(f2, f2h));
  const double second = _mm_cvtsd_f64(_mm_max_sd(_mm_max_sd(s2, s2h), _mm_min_sd(f2, f2h)));
  if (ref) *ref = {mx, my, mz, first};
  return std::sqrt(first) + std::sqrt(second);
}

// Whether pair_speed_bound_24 runs: AVX-512F and VL, and the AVX-512 paths not ruled out
// (Philox4x32Lanes::have_avx512: GRAINBATH_SIMD=avx2 or sse2 keeps the SSE2 bound; the same bits).
inline bool have_masked_bound() {
  static const bool yes = Philox4x32Lanes::have_avx512() && __builtin_cpu_supports("avx512vl") != 0;
  return yes;
}
}  // namespace detail

// Integer uniform on [0, range), range >= 1, exactly, from 32 random bits (Lemire 2019,
// "Fast random integer generation in an interval": multiply-shift, with a rejection that
// removes the bias of 2^32 mod range). A rejected value (probability < range / 2^32) is
// replaced by the low half of a fresh word. The candidate pair takes both halves of one word
// this way, without CounterRng::bits32's per-draw bookkeeping of the spare half. `Rng` is
// CounterRng or Philox4x32Words (anything with bits64()).
template <class Rng>
inline std::uint32_t below_from(std::uint32_t bits, std::uint32_t range, Rng& rng) {
  std::uint64_t m = static_cast<std::uint64_t>(bits) * range;
  if (static_cast<std::uint32_t>(m) < range) [[unlikely]] {
    const std::uint32_t threshold = (0u - range) % range;
    while (static_cast<std::uint32_t>(m) < threshold)
      m = static_cast<std::uint64_t>(static_cast<std::uint32_t>(rng.bits64())) * range;
  }
  return static_cast<std::uint32_t>(m >> 32);
}

// The generator of a cell's collision words: Philox4x32-10 sixteen words per SIMD call
// (operators/random.hpp), keyed (seed, Stream::grain_collisions; cell, step, draw). A cell
// draws ~0.75 words per grain and step in DSMC-1 (two per candidate, ~2.5 per collision for
// the direction); the scalar Philox4x64 of CounterRng cost ~45 instructions a word
// (docs/performance/dsmc1.md).
using CellCollisionRng = Philox4x32Words;

// The restitution laws that read the normal impact speed (elastic and constant e do not:
// no square root for them).
template <class Law>
inline constexpr bool uses_normal_speed = !std::is_same_v<Law, ElasticRestitution> && !std::is_same_v<Law, ConstantRestitution>;

// Candidates still to come after a step's bound was raised from g_old to g_new. The step's
// candidate count was N n g_old dt / 2: each candidate stands for an equal slice of dt at the
// bound g_old. The `remaining` slices, tested at g_new from now on (acceptance |g| / g_new),
// need remaining * g_new / g_old candidates to keep every pair's rate (n / (N - 1)) |g|;
// without them the rest of the step is under-sampled by g_old / g_new. The fraction is
// rounded up with its probability (one uniform, drawn only where the bound was raised:
// other steps draw what they drew).
template <class Rng>
inline std::uint64_t candidates_after_raise(std::uint64_t remaining, double g_old, double g_new, Rng& rng) {
  if (remaining == 0) return 0;
  const double expected = static_cast<double>(remaining) * (g_new / g_old);
  auto whole = static_cast<std::uint64_t>(expected);
  if (rng.uniform() < expected - static_cast<double>(whole)) ++whole;
  return whole;
}

// Keeps a step's pair-speed bound g_max above every pair's |g| while the step's collisions
// change velocities. NTC gives each pair its exact rate (n / (N - 1)) |g| only while
// g_max >= |g| for every pair (Bird 1994, sec. 11.1), and a collision can make a pair faster
// than the start-of-step bound (|c'| <= 2 max|c|). Found only when drawn as a candidate, such
// a pair has been under-sampled since the collision that made it (every candidate slot gave
// it probability 1 instead of |g| / g_max > 1): with 3 grains per cell and one mean free
// time per step that left 0.27 % too few collisions, 0.54 % before the remaining candidates
// were also rescaled (docs/dsmc.md, "Grain-grain collisions"). So every collision is
// checked at once: a pair with grain i is at most |v_i - a| + D apart, D an upper bound of
// |v - a| over the grains (the bound's largest deviation, raised as collisions exceed it);
// only where that may exceed g_max (about a quarter of the collisions at 16 grains per cell) are
// the pairs of the two grains computed exactly (max_pair_speed2_with, O(N)), and the bound is
// raised if one of them exceeds it. A step without such a pair draws what it drew before.
class BoundGuard {
 public:
  BoundGuard(const BoundReference& r, double g_max)
      : a_{r.ax, r.ay, r.az}, deviation_(std::sqrt(r.max_deviation2)) {
    raised(g_max);
  }
  // After a collision left two grains at v and w: whether a pair with either may exceed
  // g_max, i.e. |v - a| > slack with slack = g_max - D. The test alone (two norms, one
  // compare) runs at every collision; where it is false both grains lie within slack <= D
  // of a (g_max <= 2 D: every pair is within 2 D), so D needs no update.
  bool may_exceed(const Vec3& v, const Vec3& w) const {
    return std::max(norm2(v - a_), norm2(w - a_)) > threshold2_;
  }
  // where may_exceed held: D raised to cover the two grains (before the exact check)
  void cover(const Vec3& v, const Vec3& w) {
    const double d2 = std::max(norm2(v - a_), norm2(w - a_));
    if (d2 > deviation_ * deviation_) deviation_ = std::sqrt(d2);
    raised(g_max_);
  }
  // g_max changed (or D did). g_max is taken 1e-12 short, so that a pair within rounding of
  // the bound is computed exactly rather than let through; a negative slack checks every
  // collision (threshold -1).
  void raised(double g_max) {
    g_max_ = g_max;
    const double slack = g_max * (1.0 - 1e-12) - deviation_;
    threshold2_ = slack >= 0.0 ? slack * slack : -1.0;
  }

 private:
  Vec3 a_;
  double deviation_;
  double g_max_ = 0.0, threshold2_ = 0.0;
};

// Raise a step's bound g_max to g_new > g_max after candidate k (of `candidates`, which grows
// by candidates_after_raise), counted, and tell the guard.
template <class Rng>
inline void raise_bound(double g_new, std::uint64_t k, std::uint64_t& candidates, double& g_max, BoundGuard& guard,
                        Rng& rng, GrainCounters& counters) {
  ++counters.bound_exceeded;
  candidates = k + 1 + candidates_after_raise(candidates - k - 1, g_max, g_new, rng);
  g_max = g_new;
  guard.raised(g_max);
}

// The slot map of a cell: its grains are the contiguous range the arrays start at.
struct CellSlots {
  std::size_t operator()(std::uint32_t slot) const { return slot; }
};

// max over the n32 grains k of |v - v_k|^2 and |w - v_k|^2 (v and w: the velocities two grains
// leave a collision with), each as a candidate computes it: norm2 of the difference,
// ((dx dx + dy dy) + dz dz), the same bits in either order. A cell's contiguous grains two
// at a time in SSE2 lanes (the same correctly rounded operations per lane), in two maxima.
template <class Slot>
[[gnu::always_inline]] inline double max_pair_speed2_with(const double* vx, const double* vy, const double* vz,
                                                          Slot slot, std::uint32_t n32, const Vec3& v, const Vec3& w) {
  double m = 0.0;
  std::uint32_t s = 0;
  if constexpr (std::is_same_v<Slot, CellSlots>) {
    const __m128d ax = _mm_set1_pd(v.x), ay = _mm_set1_pd(v.y), az = _mm_set1_pd(v.z);
    const __m128d bx = _mm_set1_pd(w.x), by = _mm_set1_pd(w.y), bz = _mm_set1_pd(w.z);
    __m128d mv = _mm_setzero_pd(), mw = _mm_setzero_pd();
    for (; s + 1 < n32; s += 2) {
      const __m128d ux = _mm_loadu_pd(vx + s), uy = _mm_loadu_pd(vy + s), uz = _mm_loadu_pd(vz + s);
      const __m128d px = _mm_sub_pd(ax, ux), py = _mm_sub_pd(ay, uy), pz = _mm_sub_pd(az, uz);
      const __m128d qx = _mm_sub_pd(bx, ux), qy = _mm_sub_pd(by, uy), qz = _mm_sub_pd(bz, uz);
      mv = _mm_max_pd(mv, _mm_add_pd(_mm_add_pd(_mm_mul_pd(px, px), _mm_mul_pd(py, py)), _mm_mul_pd(pz, pz)));
      mw = _mm_max_pd(mw, _mm_add_pd(_mm_add_pd(_mm_mul_pd(qx, qx), _mm_mul_pd(qy, qy)), _mm_mul_pd(qz, qz)));
    }
    const __m128d both = _mm_max_pd(mv, mw);
    m = std::max(_mm_cvtsd_f64(both), _mm_cvtsd_f64(_mm_unpackhi_pd(both, both)));
  }
  for (; s < n32; ++s) {
    const std::size_t k = slot(s);
    const Vec3 u{vx[k], vy[k], vz[k]};
    m = std::max(m, std::max(norm2(v - u), norm2(w - u)));
  }
  return m;
}

// The NTC candidate loop shared by a cell (collide_cell) and a collision group of a homogeneous
// run (collide_group, src/dsmc/collision_groups.hpp): `candidates` ordered pairs of distinct
// slots drawn uniformly from [0, n32), each accepted with |g| / g_max; `slot` maps a drawn slot
// to the index of its grain in vx, vy, vz (the identity for a cell's contiguous range). `ref`:
// what g_max was computed from (BoundGuard); `candidates` grows where the bound is raised.
// Exact = false: Bird's scheme (`[dsmc] bound = "bird"`, the code before 2026-12-05 draw for
// draw): no guard; a drawn pair above g_max is accepted and g_max raised for the rest of the
// step, the candidates not rescaled.
template <bool Exact, class Law, class Draws, class Slot>
[[gnu::always_inline]] inline void collide_candidates(double* vx, double* vy,
                                                      double* vz, Slot slot, std::uint32_t n32,
                                                      std::uint64_t candidates, double g_max,
                                                      const BoundReference& ref, double mass,
                                                      const Law& law, Draws& draws, GrainCounters& counters) {
  BoundGuard guard(ref, g_max);
  (void)guard;
  for (std::uint64_t k = 0; k < candidates; ++k) {
    const std::uint64_t word = draws.bits64();
    const std::uint32_t si = below_from(static_cast<std::uint32_t>(word), n32, draws);
    std::uint32_t sj = below_from(static_cast<std::uint32_t>(word >> 32), n32 - 1, draws);
    if (sj >= si) ++sj;
    const std::size_t i = slot(si), j = slot(sj);
    Vec3 v{vx[i], vy[i], vz[i]}, w{vx[j], vy[j], vz[j]};
    const Vec3 g = v - w;
    const double g2 = norm2(g);
    ++counters.candidates;
    if (g2 > g_max * g_max) {  // exact: not reached (BoundGuard), a safety net; Bird: raise
      if constexpr (Exact) {
        raise_bound(std::sqrt(g2), k, candidates, g_max, guard, draws, counters);
      } else {
        ++counters.bound_exceeded;
        g_max = std::sqrt(g2);
      }
    } else {
      // accept with |g| / g_max, compared on squares (both sides >= 0): no square root for
      // the rejected candidates
      const double u = draws.uniform() * g_max;
      if (u * u >= g2) continue;
    }
    // The apse n = (g_hat - r) / |g_hat - r| with r uniform on the sphere has the hard-sphere
    // density |g.n| / (2 pi |g|) (apse_direction, operators/binary_collision.hpp); its
    // normal relative velocity is (g.n) n = (g - |g| r) / 2, so the collision (Bisi-Spiga
    // eq. 6: dv = (1 + e)/2 (g.n) n) needs neither n nor its normalisation: one square root
    // per collision instead of three, no division. Elastic: g' = |g| r, isotropic.
    const Vec3 r = draws.unit_vector();
    const Vec3 normal_g = 0.5 * (g - std::sqrt(g2) * r);  // (g.n) n
    const double gn2 = norm2(normal_g);                   // (g.n)^2
    const RestitutionOutcome out = restitution(law, uses_normal_speed<Law> ? std::sqrt(gn2) : 0.0);
    counters.clamped += out.clamped;
    const Vec3 dv = (0.5 * (1.0 + out.e)) * normal_g;
    v -= dv;
    w += dv;
    counters.energy_loss += 0.25 * mass * (1.0 - out.e * out.e) * gn2;  // (m/4)(1 - e^2)(g.n)^2
    // Keep g_max above every pair's |g| (BoundGuard): the pairs of the two grains, computed
    // where the guard's cheap test says they may exceed it, raise it if one does. Computed
    // before the two grains are stored, so their own entries still hold v and w: the pair
    // itself, |v' - w'| <= |g| <= g_max, is then not compared (it cannot exceed the bound, but
    // its rounded value could by an ulp and raise it for nothing), and |v' - v|, |w' - w|
    // (= |dv|), |v' - w|, |w' - v| (= |g - dv|) are at most |g| too.
    bool raise = false;
    double m2 = 0.0;
    if constexpr (Exact) {
      if (guard.may_exceed(v, w)) {
        guard.cover(v, w);
        m2 = max_pair_speed2_with(vx, vy, vz, slot, n32, v, w);
        raise = m2 > g_max * g_max;
      }
    }
    vx[i] = v.x;
    vy[i] = v.y;
    vz[i] = v.z;
    vx[j] = w.x;
    vy[j] = w.y;
    vz[j] = w.z;
    ++counters.collisions;
    if (raise) raise_bound(std::sqrt(m2), k, candidates, g_max, guard, draws, counters);
  }
}

// The density `collide_cell` takes for a cell of a spatial run holding `count` simulated
// grains, each standing for `weight` grains, in a cell of volume `cell_volume`: that of a
// grain's N - 1 partners, (N - 1) weight / V_c, so that a pair collides at weight/V_c |g|.
// The occupation N fluctuates (Poisson in an ideal gas), and a grain finds on average
// <N(N - 1)>/<N> = <N> partners' worth of density: its rate averages to n <|g|>, Boltzmann's.
// The cell's own density N weight / V_c (used before 2026-12-05) counts the grain itself
// and gives n (1 + 1/<N>) <|g|>; its bath equilibrium was measured colder by 0.039/<N>, the
// shift of n -> n (1 + 1/<N>) (docs/dsmc.md "Grain-grain collisions";
// DsmcSpatial.CellCollisionRateIsBoltzmannsAtFewGrainsPerCell).
inline double cell_partner_density(std::size_t count, double weight, double cell_volume) {
  return count < 2 ? 0.0 : static_cast<double>(count - 1) * weight / cell_volume;
}

// Grain-grain collisions among the particles [begin, end) of one cell over a time dt
// (Bird's no-time-counter scheme). Each grain meets the others at rate n |g| (Issue #2
// scaled units): with N simulated grains standing for density n, a pair collides at rate
// (n / (N - 1)) |g|, so each grain sees exactly n <|g|> over its N - 1 partners. Candidates
// per step: N (N - 1)/2 * n/(N - 1) * g_max dt = N n g_max dt / 2, accepted with |g|/g_max.
// `remainder` carries the fractional candidate across steps (part of the checkpoint).
// The random words come from `rng`, one generator per (cell, step): CellCollisionRng below
// in every caller (fused step, separate passes, MPI, homogeneous runs), so that the fused
// and the separate-pass paths draw the same numbers.
template <class Law, class Rng>
inline void collide_cell(Particles& p, std::size_t begin, std::size_t end, double density, double dt,
                         double mass, const Law& law, Rng& rng, double& remainder,
                         GrainCounters& counters, bool exact_bound) {
  const std::size_t count = end - begin;
  if (count < 2 || density <= 0.0) return;
  if (count > 0xffffffffu) throw std::length_error("collide_cell: more than 2^32 - 1 grains in one cell");
  double* __restrict vx = p.vx.data() + begin;
  double* __restrict vy = p.vy.data() + begin;
  double* __restrict vz = p.vz.data() + begin;
  // the same bound either way (detail::pair_speed_bound_24)
  BoundReference ref;
  double g_max = count <= 24 && detail::have_masked_bound() ? detail::pair_speed_bound_24(vx, vy, vz, count, &ref)
                                                            : pair_speed_bound(vx, vy, vz, count, &ref);
  if (g_max <= 0.0) return;
  const double expected = 0.5 * static_cast<double>(count) * density * g_max * dt + remainder;
  const auto candidates = static_cast<std::uint64_t>(expected);
  remainder = expected - static_cast<double>(candidates);
  // an ordered pair of distinct grains, uniformly: i from [0, N), j from the other N - 1,
  // from the low and high halves of one Philox word (below_from: exact)
  const auto n32 = static_cast<std::uint32_t>(count);
  // Philox4x32Words: draw through a Cursor (the word index in a register, the same words)
  auto words = [&]() -> decltype(auto) {
    if constexpr (requires { typename Rng::Cursor; })
      return typename Rng::Cursor(rng);
    else
      return (rng);
  };
  decltype(auto) draws = words();
  if (exact_bound)
    collide_candidates<true>(vx, vy, vz, CellSlots{}, n32, candidates, g_max, ref, mass, law, draws, counters);
  else
    collide_candidates<false>(vx, vy, vz, CellSlots{}, n32, candidates, g_max, ref, mass, law, draws, counters);
}

}  // namespace grainbath::dsmc
