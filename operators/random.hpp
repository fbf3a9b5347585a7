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

#include <cmath>
#include <cstdint>
#include <numbers>

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
};

class CounterRng {
 public:
  using Philox = r123::Philox4x64;

  CounterRng(std::uint64_t seed, Stream stream, std::uint64_t entity, std::uint64_t step)
      : key_{{seed, static_cast<std::uint64_t>(stream)}}, ctr_{{entity, step, 0, 0}} {}

  // Uniform on the open interval (0, 1): never 0, so log(u) is always finite.
  double uniform() {
    if (used_ == 4) refill();
    const std::uint64_t w = block_.v[used_++];
    return (static_cast<double>(w >> 11) + 0.5) * 0x1.0p-53;
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

  // Uniform direction on the unit sphere (Marsaglia 1972: a point uniform in the unit disk,
  // s = u^2 + v^2, maps to (2u sqrt(1-s), 2v sqrt(1-s), 1 - 2s)); no trigonometry.
  Vec3 unit_vector() {
    double u, v, s;
    do {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0);
    const double r = 2.0 * std::sqrt(1.0 - s);
    return {u * r, v * r, 1.0 - 2.0 * s};
  }

  double exponential() { return -std::log(uniform()); }

  // 32 random bits: each 64-bit Philox word is split into two halves, both used.
  std::uint32_t bits32() {
    if (have_half_) {
      have_half_ = false;
      return half_;
    }
    if (used_ == 4) refill();
    const std::uint64_t w = block_.v[used_++];
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

}  // namespace grainbath
