#pragma once
// A 64-bit fingerprint of a final particle state, written to summary.json as `state.hash`.
//
// Why: the reproducibility checks (1 vs 2 threads, 1 vs 2 MPI ranks, SIMD vs baseline paths,
// restart vs straight run) compare summary.json and results.h5, whose statistics can miss a
// change of one ulp in a position (docs/PERFORMANCE.md, "Reproducible"). The fingerprint sees
// every bit of the values the caller offers: DSMC offers every stored per-particle value
// (positions, velocities, bath residual, spins; src/dsmc/output.cpp), EDMD the positions,
// velocities and spins (not the engine's internal event bookkeeping; src/edmd/driver.cpp).
//
// It is a sum over particles (mod 2^64) of a per-particle hash of (id, the IEEE bit patterns of
// its values), so it does not depend on the storage order (cell order, rank order after a
// gather) but changes with any bit of any value: each particle's hash is a chain of the
// splitmix64 finaliser (Steele, Lea and Flood, OOPSLA 2014), a bijection with full avalanche,
// so two states differing in one bit give unrelated sums. -0.0 and +0.0 hash differently, as
// they are different bits. Not cryptographic; a collision of two different states has
// probability ~2^-64.
#include <bit>
#include <cstdint>
#include <cstdio>
#include <span>
#include <string>

namespace grainbath {

constexpr std::uint64_t splitmix64_mix(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// Accumulates particles one at a time; the fields of a particle must be offered in the same
// order every time (the caller fixes it: x, y, z, vx, vy, vz, ...).
class StateHash {
 public:
  // one particle: its stable id and its stored values
  void add(std::uint64_t id, std::span<const double> values) {
    std::uint64_t h = splitmix64_mix(id + 0x9e3779b97f4a7c15ULL);
    for (const double v : values) h = splitmix64_mix(h ^ std::bit_cast<std::uint64_t>(v));
    sum_ += h;  // wrapping: order-independent
    ++count_;
  }
  // Hashes of disjoint sets of particles (each MPI rank its own) combine into the hash of the
  // union: the partial sums and counts, summed modulo 2^64 in any order, then add_partial.
  std::uint64_t partial_sum() const { return sum_; }
  std::uint64_t partial_count() const { return count_; }
  void add_partial(std::uint64_t sum, std::uint64_t count) {
    sum_ += sum;
    count_ += count;
  }
  std::uint64_t value() const { return splitmix64_mix(sum_ ^ splitmix64_mix(count_)); }
  // 16 lower-case hex digits: JSON numbers would lose bits above 2^53
  std::string hex() const {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(value()));
    return buf;
  }

 private:
  std::uint64_t sum_ = 0, count_ = 0;
};

}  // namespace grainbath
