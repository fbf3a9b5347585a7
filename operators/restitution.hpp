#pragma once
// Restitution laws: e as a function of the normal relative speed |g.n| at impact.
//
// Each law is a tiny value type with `double raw(double normal_speed) const`, the law as
// written (it may be negative for the power law at large impact speeds). Engines call
// `restitution(law, gn)`, which clamps to [0, 1] and reports the clamp so it can be
// counted (Issue #2: "clamp to 0, count it, warn when not negligible").
// The laws are selected by name once per run (std::variant), never inside the loop.
#include <algorithm>
#include <cmath>
#include <string_view>
#include <type_traits>
#include <variant>

namespace grainbath {

// e = 1: elastic grains.
struct ElasticRestitution {
  static constexpr std::string_view name = "elastic";
  double raw(double) const { return 1.0; }
};

// e constant in (0, 1].
struct ConstantRestitution {
  static constexpr std::string_view name = "constant";
  double e = 1.0;
  double raw(double) const { return e; }
};

// Bisi-Spiga eq. 5: 1 - e = 2 beta |g.n|^delta. delta = 0: constant e = 1 - 2 beta;
// delta = 1/5: leading term of viscoelastic spheres (Brilliantov-Poeschel).
struct PowerLawRestitution {
  static constexpr std::string_view name = "power";
  double beta = 0.0;
  double delta = 0.0;
  double raw(double normal_speed) const {
    if (delta == 0.0) return 1.0 - 2.0 * beta;
    return 1.0 - 2.0 * beta * std::pow(std::abs(normal_speed), delta);
  }
};

// Bizon et al. eq. 18: e = 1 - B v_n^(3/4) below the crossover speed v0, constant e_c
// above, with B = (1 - e_c) v0^(-3/4) so that e is continuous. Keeps nearly grazing
// collisions almost elastic, which prevents inelastic collapse in event-driven runs.
struct BizonRestitution {
  static constexpr std::string_view name = "bizon";
  double e_c = 0.7;        // restitution above the crossover speed
  double crossover = 1.0;  // v0, in the run's velocity unit
  double raw(double normal_speed) const {
    const double vn = std::abs(normal_speed);
    if (vn >= crossover) return e_c;
    return 1.0 - (1.0 - e_c) * std::pow(vn / crossover, 0.75);
  }
};

using RestitutionLaw =
    std::variant<ElasticRestitution, ConstantRestitution, PowerLawRestitution, BizonRestitution>;

struct RestitutionOutcome {
  double e;
  bool clamped;  // the law gave e < 0 (or > 1) and was clamped
};

template <class Law>
inline RestitutionOutcome restitution(const Law& law, double normal_speed) {
  const double e = law.raw(normal_speed);
  if (e < 0.0) return {0.0, true};
  if (e > 1.0) return {1.0, true};
  return {e, false};
}

inline std::string_view restitution_name(const RestitutionLaw& law) {
  return std::visit([](const auto& l) { return std::decay_t<decltype(l)>::name; }, law);
}

}  // namespace grainbath
