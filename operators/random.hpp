#pragma once
// Counter-based random numbers (Random123 Philox4x64-10).
//
// Why counter-based: a draw is a pure function of (seed, stream; entity, step, draw index),
// so the numbers a particle or a cell sees do not depend on how work is split across
// threads or MPI ranks, nor on whether the run was restarted. Nothing to checkpoint but
// the step number.
//
//   key     = (user seed, stream id)            -- stream ids: see enum Stream
//   counter = (entity id, step, block index, 0) -- entity: particle id or cell id
//
// Each Philox call yields four 64-bit words; all four are used (Issue #7: "draw all four
// Philox outputs per call"). Distributions are written here, not taken from <random>,
// because std:: distributions differ between standard libraries.
#include <Random123/philox.h>

#include <emmintrin.h>
#include <immintrin.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <numbers>
#include <string_view>

#include "operators/vec3.hpp"

namespace grainbath {

// Registry of consumers. Each physical process draws from its own stream so that adding
// draws to one never shifts the numbers another sees. Never renumber: that would change
// every result for a given seed.
enum class Stream : std::uint64_t {
  initial_velocities = 1,
  initial_positions = 2,
  background_first_half = 3,   // Strang split: bath over dt/2 before grain collisions
  background_second_half = 4,  // ... and after
  grain_collisions = 5,
  sort_shuffle = 6,
  edmd_heating = 7,
  edmd_collisions = 8,
  edmd_background = 9,
  wall_collisions = 10,
  background_clock = 11,       // initial unit-exponential residual of each grain's bath candidate process
  initial_angular_velocities = 12,  // rough grains (EDMD [edmd] / DSMC [grains] rotational_temperature)
  background_joined_halves = 13,    // the second bath half of step k - 1 and the first of step k as one
                                    // substep over dt (keyed on k; src/dsmc/driver.cpp)
  collision_groups = 14,            // homogeneous DSMC: the step's deal of tiles into collision groups
                                    // (keyed on the step; src/dsmc/collision_groups.hpp)
  ntc_initial_remainder = 15,       // DSMC: each cell's initial fractional NTC candidate (keyed on
                                    // the cell; src/dsmc/driver.cpp, initialise)
};

// Ziggurat tables (Marsaglia & Tsang 2000, "The Ziggurat Method for Generating Random
// Variables", J. Stat. Softw. 5(8)) for the unnormalised densities f(x) = exp(-x^2/2)
// (normal, x >= 0, random sign) and f(x) = exp(-x) (exponential), 256 layers of equal area
// v. Layer 0 is the base: the rectangle [0, r] x [0, f(r)] plus the tail x > r, given the
// virtual width x[0] = v / f(r); layer i >= 1 is [0, x[i]] x [f(x[i]), f(x[i+1])], with
// x[1] = r and x[256] = 0. A draw takes the layer and a uniform point across it from one
// 64-bit word (disjoint bits); below x[i+1] the point is under the curve for certain (the
// fast path, ~99%); otherwise the wedge or the tail is sampled exactly by rejection. The
// method is exact: every accepted point is uniform under the curve.
// r is found here by bisection on the condition that the layers close at the mode
// (x[256] = 0), not copied from a table: the tables are built at program start.
// ZigguratLayers<L> is the table of L layers (the DSMC bath kernel's own ziggurats,
// operators/background.hpp, have 1024); ZigguratTable the 256-layer one of CounterRng.
template <int Layers>
struct ZigguratLayers {
  static constexpr int kLayers = Layers;
  static constexpr int kBits = std::countr_zero(static_cast<unsigned>(Layers));  // layer index bits
  static_assert(Layers == 1 << kBits, "a power of two: the layer is a bit field of the draw");
  double x[kLayers + 1];      // layer edges, x[0] virtual base width, x[kLayers] = 0
  double ratio[kLayers];      // x[i+1] / x[i]: fast-path bound on the uniform
  double f[kLayers + 1];      // f(x[i])
  double r = 0.0;             // start of the tail

  // Density, its inverse and the tail mass beyond r, for both shapes.
  template <class F, class FInv, class Tail>
  static ZigguratLayers build(F f, FInv finv, Tail tail, long double lo, long double hi) {
    ZigguratLayers t{};
    // closing defect: how far above the mode the layers end for a trial r (decreasing in r)
    auto defect = [&](long double r, ZigguratLayers* out) -> long double {
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
    // densities, and the tables are built at the start of every process). Once a and b
    // are neighbours the midpoint rounds to one of them and the bracket no longer moves
    // (defect(a) > 0 >= defect(b) throughout), so this is the fixed point a bisection of
    // any greater number of halvings (ZigguratTable once took 200) ends at.
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

struct ZigguratTable : ZigguratLayers<256> {
  static const ZigguratTable& normal();
  static const ZigguratTable& exponential();
};

// Built once at program start (namespace-scope inline variables: no guard on every draw).
inline const ZigguratTable kNormalZiggurat{ZigguratLayers<256>::build(
    [](long double x) { return std::exp(-0.5L * x * x); }, [](long double y) { return std::sqrt(-2.0L * std::log(y)); },
    [](long double r) { return std::sqrt(std::numbers::pi_v<long double> / 2) * std::erfc(r / std::sqrt(2.0L)); }, 3.0L,
    4.5L)};
inline const ZigguratTable kExponentialZiggurat{ZigguratLayers<256>::build(
    [](long double x) { return std::exp(-x); }, [](long double y) { return -std::log(y); },
    [](long double r) { return std::exp(-r); }, 6.0L, 9.0L)};
inline const ZigguratTable& ZigguratTable::normal() { return kNormalZiggurat; }
inline const ZigguratTable& ZigguratTable::exponential() { return kExponentialZiggurat; }

// Uniform direction on the unit sphere from any generator with uniform() on (0, 1)
// (Marsaglia 1972: a point uniform in the unit disk, s = u^2 + v^2, maps to
// (2u sqrt(1-s), 2v sqrt(1-s), 1 - 2s)); no trigonometry.
// Always inlined: Philox4x32Words::Cursor passes itself here and must stay in registers.
template <class Rng>
[[gnu::always_inline]] inline Vec3 marsaglia_unit_vector(Rng& rng) {
  double u, v, s;
  do {
    u = 2.0 * rng.uniform() - 1.0;
    v = 2.0 * rng.uniform() - 1.0;
    s = u * u + v * v;
  } while (s >= 1.0);
  const double r = 2.0 * std::sqrt(1.0 - s);
  return {u * r, v * r, 1.0 - 2.0 * s};
}

class CounterRng {
 public:
  using Philox = r123::Philox4x64;

  CounterRng(std::uint64_t seed, Stream stream, std::uint64_t entity, std::uint64_t step)
      : key_{{seed, static_cast<std::uint64_t>(stream)}}, ctr_{{entity, step, 0, 0}} {}

  // A further sequence of the same (seed, stream; entity, step): the fourth counter word is
  // `sequence` (the constructor above is sequence 0). The DSMC bath kernel draws its rare
  // slow paths from these (operators/background.hpp).
  CounterRng(std::uint64_t seed, Stream stream, std::uint64_t entity, std::uint64_t step, std::uint64_t sequence)
      : key_{{seed, static_cast<std::uint64_t>(stream)}}, ctr_{{entity, step, 0, sequence}} {}

  // Uniform on the open interval (0, 1): never 0, so log(u) is always finite.
  double uniform() {
    if (used_ == 4) refill();
    const std::uint64_t w = block_.v[used_++];
    return (static_cast<double>(w >> 11) + 0.5) * 0x1.0p-53;
  }

  // Standard normal by the ziggurat (ZigguratTable): one Philox word per draw on the fast
  // path (~99%), no logarithm or square root. Exact. Used by the DSMC kernels.
  double normal_ziggurat() {
    const std::uint64_t w = bits64();
    const unsigned i = w & 0xffu;
    const double u = static_cast<double>(w >> 11) * 0x1.0p-53;  // [0, 1)
    const double x = u * kNormalZiggurat.x[i];
    if (u < kNormalZiggurat.ratio[i]) [[likely]]  // sign from bit 8, without a branch
      return std::bit_cast<double>(std::bit_cast<std::uint64_t>(x) ^ ((w & 0x100u) << 55));
    return normal_ziggurat_edge(i, x, (w & 0x100u) ? -1.0 : 1.0);
  }

  // Standard normal by Marsaglia's polar method (Box-Muller without sin/cos: a point
  // uniform in the unit disk gives the angle); both outputs are used. Exact; on average
  // 2.55 uniforms, one log and one sqrt per pair.
  double normal() {
    if (have_spare_) {
      have_spare_ = false;
      return spare_;
    }
    double u, v, s;
    do {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * f;
    have_spare_ = true;
    return u * f;
  }

  Vec3 normal3() { return {normal(), normal(), normal()}; }

  // Uniform direction on the unit sphere (marsaglia_unit_vector).
  Vec3 unit_vector() { return marsaglia_unit_vector(*this); }

  // Unit exponential by the ziggurat; the tail beyond r is r + Exp(1) (memorylessness).
  // Exact; no logarithm on the fast path.
  double exponential_ziggurat() {
    const std::uint64_t w = bits64();
    const unsigned i = w & 0xffu;
    const double u = static_cast<double>(w >> 11) * 0x1.0p-53;
    const double x = u * kExponentialZiggurat.x[i];
    if (u < kExponentialZiggurat.ratio[i]) [[likely]]
      return x;
    return exponential_ziggurat_edge(i, x);
  }

  // Unit exponential by inversion, -log U.
  double exponential() { return -std::log(uniform()); }

  // 64 random bits (one Philox word).
  std::uint64_t bits64() {
    if (used_ == 4) refill();
    return block_.v[used_++];
  }

  // 32 random bits: each 64-bit Philox word is split into two halves, both used.
  std::uint32_t bits32() {
    if (have_half_) {
      have_half_ = false;
      return half_;
    }
    const std::uint64_t w = bits64();
    half_ = static_cast<std::uint32_t>(w >> 32);
    have_half_ = true;
    return static_cast<std::uint32_t>(w);
  }

  // Integer uniform on [0, range), range >= 1, exactly (Lemire 2019, "Fast random integer
  // generation in an interval": multiply-shift with a rejection that removes the bias of
  // 2^32 mod range; a redraw happens with probability < range / 2^32).
  std::uint32_t below(std::uint32_t range) {
    std::uint64_t m = static_cast<std::uint64_t>(bits32()) * range;
    auto low = static_cast<std::uint32_t>(m);
    if (low < range) {
      const std::uint32_t threshold = (0u - range) % range;
      while (low < threshold) {
        m = static_cast<std::uint64_t>(bits32()) * range;
        low = static_cast<std::uint32_t>(m);
      }
    }
    return static_cast<std::uint32_t>(m >> 32);
  }

  // How many 4-word blocks this generator has consumed (for diagnostics/tests).
  std::uint64_t blocks_used() const { return ctr_.v[2]; }

 private:
  // Ziggurat slow paths (~1% of draws): the wedge of layer i at x, or the tail (i = 0).
  [[gnu::noinline]] double normal_ziggurat_edge(unsigned i, double x, double sign) {
    const ZigguratTable& z = kNormalZiggurat;
    if (i == 0) {
      // tail beyond r (Marsaglia 1964): x = r + a with a ~ Exp(r), accepted with
      // exp(-a^2/2), i.e. 2 b > a^2 with b ~ Exp(1)
      double a, b;
      do {
        a = -std::log(uniform()) / z.r;
        b = -std::log(uniform());
      } while (b + b < a * a);
      return sign * (z.r + a);
    }
    if (z.f[i] + uniform() * (z.f[i + 1] - z.f[i]) < std::exp(-0.5 * x * x)) return sign * x;
    return normal_ziggurat();  // rejected: a fresh draw
  }
  [[gnu::noinline]] double exponential_ziggurat_edge(unsigned i, double x) {
    const ZigguratTable& z = kExponentialZiggurat;
    if (i == 0) return z.r + exponential_ziggurat();  // memoryless tail
    if (z.f[i] + uniform() * (z.f[i + 1] - z.f[i]) < std::exp(-x)) return x;
    return exponential_ziggurat();
  }

  void refill() {
    block_ = Philox{}(ctr_, key_);
    ++ctr_.v[2];
    used_ = 0;
  }

  Philox::key_type key_;
  Philox::ctr_type ctr_;
  Philox::ctr_type block_{};
  int used_ = 4;
  bool have_spare_ = false;
  bool have_half_ = false;
  std::uint32_t half_ = 0;
  double spare_ = 0.0;
};

// ---------------------------------------------------------------------------------------
// Philox4x32-10 (Salmon et al. 2011, the Random123 algorithm) in integer SIMD lanes, for
// kernels that need a fixed number of words per event (the DSMC bath kernel, Issue #7).
// x86-64 has no vector 64x64->128 multiply, so Philox4x64 does not vectorise; Philox4x32's
// 32x32->64 multiplies are exactly PMULUDQ. Each block's four 32-bit words sit in the low
// halves of 64-bit lanes (one lane per block); PMULUDQ ignores the high halves, so the low
// products may carry garbage there until the output is masked. The lane code is written once
// (operators/philox_lanes.inc) and compiled for SSE2 (baseline x86-64, two lanes) and AVX2
// (four lanes); integer arithmetic only, so both give the same bits, which the tests check
// against Random123's scalar r123::Philox4x32 (tests/operators/test_random.cpp).
//
// The block "words8" of (key; c0, c1, c2, base) are the four Philox4x32 blocks with counters
// (c0, c1, c2, base + j), j = 0..3, packed as eight 64-bit words:
//   word j     = out_j[0] | out_j[1] << 32,   word 4 + j = out_j[2] | out_j[3] << 32.
namespace detail {
inline constexpr std::uint32_t kPhiloxM0 = 0xD2511F53u, kPhiloxM1 = 0xCD9E8D57u;  // multipliers
inline constexpr std::uint32_t kPhiloxW0 = 0x9E3779B9u, kPhiloxW1 = 0xBB67AE85u;  // Weyl key bumps

namespace philox_sse2 {
typedef unsigned long long U __attribute__((vector_size(16)));
inline constexpr int kLanes = 2;
inline U mul_lo32(U a, U b) { return reinterpret_cast<U>(_mm_mul_epu32(reinterpret_cast<__m128i>(a), reinterpret_cast<__m128i>(b))); }
// one group per register: lanes (block 0, block 1)
inline void store_words4(std::uint64_t* w, U first, U second) {
  std::memcpy(w, &first, sizeof first);
  std::memcpy(w + 2, &second, sizeof second);
}
#include "operators/philox_lanes.inc"
}  // namespace philox_sse2

// The AVX2 copy: every function up to the pop is compiled for AVX2 (integer instructions
// only). Only called when the CPU has AVX2.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif
namespace philox_avx2 {
typedef unsigned long long U __attribute__((vector_size(32)));
inline constexpr int kLanes = 4;
inline U mul_lo32(U a, U b) {
  return reinterpret_cast<U>(_mm256_mul_epu32(reinterpret_cast<__m256i>(a), reinterpret_cast<__m256i>(b)));
}
// two groups per register: lanes (a block 0, a block 1, b block 0, b block 1), so a's words
// are the low 128 bits of `first` and of `second`, b's the high ones
inline void store_words4(std::uint64_t* w, U first, U second) {
  const __m256i f = reinterpret_cast<__m256i>(first), s = reinterpret_cast<__m256i>(second);
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(w), _mm256_permute2x128_si256(f, s, 0x20));
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(w + 4), _mm256_permute2x128_si256(f, s, 0x31));
}
#include "operators/philox_lanes.inc"
}  // namespace philox_avx2
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif

// The AVX-512 copy (eight lanes, one zmm register), words4 only: half the instructions of the
// AVX2 copy for the same words, which matters where the words are a throughput cost (the DSMC
// bath's words4, 24 % of DSMC-2's time on the Xeon VM of 2026-11-26; the bath kernel 33.9 ->
// 30.8 ns per test, docs/performance/dsmc1.md, h-dsmc10). Integer instructions only, so the
// same bits (test: Philox4x32Lanes.SimdPathsEqualRandom123). Only called when the CPU has
// AVX-512F (Philox4x32Lanes::have_avx512).
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx512f"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx512f")
#endif
namespace philox_avx512 {
typedef unsigned long long U __attribute__((vector_size(64)));
inline constexpr int kLanes = 8;
// (the maskz forms with a full mask: the same instructions, and GCC 12's unmasked forms pass
// _mm512_undefined_epi32(), which -Wuninitialized reports at every use)
inline U mul_lo32(U a, U b) {
  return reinterpret_cast<U>(_mm512_maskz_mul_epu32(0xff, reinterpret_cast<__m512i>(a), reinterpret_cast<__m512i>(b)));
}
// four groups per register: lanes (a 0, a 1, b 0, b 1, c 0, c 1, d 0, d 1), so group g's
// words are the 128-bit quarter g of `first` and then of `second`
inline void store_words4(std::uint64_t* w, U first, U second) {
  const __m512i f = reinterpret_cast<__m512i>(first), s = reinterpret_cast<__m512i>(second);
  const __m512i lo = _mm512_set_epi64(11, 10, 3, 2, 9, 8, 1, 0), hi = _mm512_set_epi64(15, 14, 7, 6, 13, 12, 5, 4);
  _mm512_storeu_si512(w, _mm512_permutex2var_epi64(f, lo, s));
  _mm512_storeu_si512(w + 8, _mm512_permutex2var_epi64(f, hi, s));
}
#define GRAINBATH_PHILOX_LANES_8
#include "operators/philox_lanes.inc"
#undef GRAINBATH_PHILOX_LANES_8
}  // namespace philox_avx512
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
}  // namespace detail

struct Philox4x32Lanes {
  // Scalar reference by Random123 (also the per-grain path): the same eight words.
  // Blocks = 4 gives words8, Blocks = 2 words4 (block j's outputs in words j and Blocks + j).
  template <std::uint32_t Blocks>
  static void blocks_scalar(std::uint64_t key, std::uint32_t c0, std::uint32_t c1, std::uint32_t c2, std::uint32_t base,
                            std::uint64_t* w) {
    const r123::Philox4x32::key_type k{{static_cast<std::uint32_t>(key), static_cast<std::uint32_t>(key >> 32)}};
    for (std::uint32_t j = 0; j < Blocks; ++j) {
      const r123::Philox4x32::ctr_type c{{c0, c1, c2, base + j}};
      const auto o = r123::Philox4x32{}(c, k);
      w[j] = o.v[0] | static_cast<std::uint64_t>(o.v[1]) << 32;
      w[Blocks + j] = o.v[2] | static_cast<std::uint64_t>(o.v[3]) << 32;
    }
  }
  static void words8_scalar(std::uint64_t key, std::uint32_t c0, std::uint32_t c1, std::uint32_t c2,
                            std::uint32_t base, std::uint64_t* w) {
    blocks_scalar<4>(key, c0, c1, c2, base, w);
  }


  // Whether the AVX2 paths run: the CPU has AVX2 and the environment does not ask for the
  // baseline (GRAINBATH_SIMD=sse2, read once; every path gives the same bits, so this only
  // lets tests/simd compare the two paths in one machine and users rule the dispatch out).
  static bool have_avx2() {
    static const bool avx2 = [] {
      const char* simd = std::getenv("GRAINBATH_SIMD");
      if (simd != nullptr && std::string_view(simd) == "sse2") return false;
      __builtin_cpu_init();
      return __builtin_cpu_supports("avx2") != 0;
    }();
    return avx2;
  }
  // Whether the AVX-512 paths run (these words4; in the DSMC fused step also the ranking and
  // the next-cell prediction, and with AVX-512VL the cells' collision bound): the AVX2 paths
  // run, the CPU has AVX-512F, and GRAINBATH_SIMD is not "avx2" (which keeps the AVX2 paths,
  // so that tests compare the two in one machine; the same bits either way).
  static bool have_avx512() {
    static const bool avx512 = [] {
      if (!have_avx2()) return false;
      const char* simd = std::getenv("GRAINBATH_SIMD");
      if (simd != nullptr && std::string_view(simd) == "avx2") return false;
      return __builtin_cpu_supports("avx512f") != 0;
    }();
    return avx512;
  }

  // The block "words4" of (key; c0, c1, c2, base): the two Philox4x32 blocks with counters
  // (c0, c1, c2, base + j), j = 0, 1, packed as four 64-bit words (the layout of words8):
  //   word j = out_j[0] | out_j[1] << 32,   word 2 + j = out_j[2] | out_j[3] << 32.
  // The DSMC bath kernel's test budget since it takes its variates from 32-bit halves.
  static void words4_scalar(std::uint64_t key, std::uint32_t c0, std::uint32_t c1, std::uint32_t c2,
                            std::uint32_t base, std::uint64_t* w) {
    blocks_scalar<2>(key, c0, c1, c2, base, w);
  }


  static void words4(std::uint64_t key, const std::uint32_t* c0, const std::uint32_t* c1, std::uint32_t c2,
                     std::uint32_t base, std::size_t n, std::uint64_t* w) {
    if (have_avx512())
      detail::philox_avx512::words4(key, c0, c1, c2, base, n, w);
    else if (have_avx2())
      detail::philox_avx2::words4(key, c0, c1, c2, base, n, w);
    else
      detail::philox_sse2::words4(key, c0, c1, c2, base, n, w);
  }

  // The fastest path this CPU has (the same bits on every path).
  static void words8(std::uint64_t key, const std::uint32_t* c0, const std::uint32_t* c1, std::uint32_t c2,
                     std::uint32_t base, std::size_t n, std::uint64_t* w) {
    if (have_avx2())
      detail::philox_avx2::words8(key, c0, c1, c2, base, n, w);
    else
      detail::philox_sse2::words8(key, c0, c1, c2, base, n, w);
  }
};

// A counter-based generator of 64-bit words from Philox4x32-10, sixteen words (two groups of
// four blocks) per SIMD call (the words of Philox4x32Lanes::words8), for kernels that draw an unknown but small number of
// words per entity and step: the DSMC grain collisions of one cell (src/dsmc/collide.hpp;
// ~12 words per cell and step in DSMC-1, where the scalar Philox4x64 cost ~45 instructions
// a word and words8 ~15 including the key schedule, Issue #7). Keyed as the bath's test words
// (operators/background.hpp bath_ctr0/bath_ctr1): Philox4x32-10 under the 64-bit seed,
// counter (entity low 32 bits, entity high bits | stream << 24, step, 4 b + j) for the b-th
// group of eight words, j = 0..3. Injective for entities < 2^56, streams < 256, steps < 2^32
// (the DSMC config allows at most 2e9 steps) and fewer than 2^30 groups per (entity, step),
// so a draw is a pure function of (seed, stream; entity, step, draw index) and the same on
// the SSE2 and AVX2 paths (integer arithmetic; tests/operators/test_random.cpp).
// The distributions use the same formulas as CounterRng's.
class Philox4x32Words {
 public:
  Philox4x32Words(std::uint64_t seed, Stream stream, std::uint64_t entity, std::uint64_t step)
      : seed_(seed),
        c0_(static_cast<std::uint32_t>(entity)),
        c1_(static_cast<std::uint32_t>(entity >> 32) | static_cast<std::uint32_t>(static_cast<std::uint64_t>(stream) << 24)),
        c2_(static_cast<std::uint32_t>(step)) {}

  // The words are computed two groups (sixteen words) at a time: a cell draws ~12 words in
  // DSMC-1 (3.97 candidates, 1.69 collisions), and the two groups' rounds are independent
  // chains that overlap (philox_lanes.inc groups<2>), so one call for sixteen words costs
  // less than the two calls for eight that most cells made.
  static constexpr int kWindow = 16;

  // 64 random bits: word `draw` of the sequence, group draw / 8, word draw % 8 of words8.
  std::uint64_t bits64() {
    if (used_ == kWindow) refill();
    return words_[used_++];
  }

  // Uniform on the open interval (0, 1), as CounterRng::uniform.
  double uniform() { return (static_cast<double>(bits64() >> 11) + 0.5) * 0x1.0p-53; }

  // Uniform direction on the unit sphere, as CounterRng::unit_vector (marsaglia_unit_vector).
  Vec3 unit_vector() { return marsaglia_unit_vector(*this); }

  // How many groups of eight words this generator has computed (for tests): two per refill.
  std::uint32_t groups_used() const { return group_; }

  // The same draws for a kernel's hot loop, with the index of the next word in a local
  // variable (a register) instead of the generator's memory: bits64() of the generator
  // stores and reloads `used_` around every word (refill is an out-of-line call that takes
  // `this`), a store-to-load chain per word. A Cursor draws exactly the words the generator
  // would, in the same order, and writes the index back when it goes out of scope; do not
  // draw from the generator itself while a Cursor on it is alive. Everything is inlined, the
  // unit vector included, so the Cursor's address never escapes (collide_cell, dsmc/collide.hpp).
  class Cursor {
   public:
    explicit Cursor(Philox4x32Words& g) : g_(g), used_(g.used_) {}
    ~Cursor() { g_.used_ = used_; }
    Cursor(const Cursor&) = delete;
    Cursor& operator=(const Cursor&) = delete;
    [[gnu::always_inline]] std::uint64_t bits64() {
      if (used_ == kWindow) [[unlikely]] {
        g_.refill();
        used_ = 0;
      }
      return g_.words_[used_++];
    }
    [[gnu::always_inline]] double uniform() { return (static_cast<double>(bits64() >> 11) + 0.5) * 0x1.0p-53; }
    [[gnu::always_inline]] Vec3 unit_vector() { return marsaglia_unit_vector(*this); }

   private:
    Philox4x32Words& g_;
    int used_;
  };

 private:
  // cold (the call is once per sixteen words): GCC moves the call sites out of line and spills
  // fewer of collide_cell's values around them (with Philox4x32Words::Cursor: the hot part of
  // collide_cell 657 -> 461 instructions, its stack stores 118 -> 68; objdump, 2026-11-26)
  [[gnu::noinline, gnu::cold]] void refill() {
    // two groups of eight words, the same bits as words8 with n = 2 (philox_lanes.inc groups():
    // the round keys advanced in a register instead of words8's table, cheaper for few groups)
    // (AVX2, not AVX-512, even where the CPU has it: a zmm copy, both groups in one register,
    // made DSMC-1 slower on the Xeon VM of 2026-11-26, 1 of 8 interleaved pairs faster,
    // +3.4 ns median: docs/performance/dsmc1.md, h-dsmc10)
    if (Philox4x32Lanes::have_avx2())
      detail::philox_avx2::group2(seed_, c0_, c1_, c2_, 4u * group_, words_);
    else
      detail::philox_sse2::group2(seed_, c0_, c1_, c2_, 4u * group_, words_);
    group_ += 2;
    used_ = 0;
  }

  std::uint64_t seed_;
  std::uint32_t c0_, c1_, c2_;
  std::uint32_t group_ = 0;
  int used_ = kWindow;
  std::uint64_t words_[kWindow];
};

}  // namespace grainbath
