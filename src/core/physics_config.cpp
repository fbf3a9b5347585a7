#include "core/physics_config.hpp"

#include <limits>

namespace grainbath {

const std::vector<ModelDescription>& restitution_models() {
  static const std::vector<ModelDescription> models = {
      {"restitution", "elastic", "e = 1", {}},
      {"restitution", "constant", "e constant", {"e (required, dimensionless, (0, 1]): restitution coefficient"}},
      {"restitution", "power",
       "Bisi-Spiga eq. 5: e = 1 - 2 beta |g.n|^delta, clamped at 0 (delta = 0: constant; 1/5: viscoelastic)",
       {"beta (0, >= 0, velocity^-delta): inelasticity", "delta (0, >= 0): exponent"}},
      {"restitution", "bizon",
       "Bizon et al. eq. 18: e = 1 - (1 - e_c)(v_n/v0)^(3/4) below v0, e_c above",
       {"e (0.7, (0, 1]): restitution above the crossover", "crossover (1, > 0, velocity): v0"}},
      {"restitution", "walton",
       "Rough grains with spin (EDMD, homogeneous DSMC; docs/rough.md W1-W5): normal restitution e, tangential beta0 when sticking, "
       "Coulomb friction mu when sliding; [edmd] / [grains] rotational_temperature sets the initial Trot (0)",
       {"e (required, [0, 1]): normal restitution", "beta0 (required, [-1, 1]): tangential restitution (-1 smooth, 1 perfectly rough)",
        "mu (inf, >= 0): Coulomb friction coefficient (very large: never sliding)",
        "q (1/2 in 2D, 2/5 in 3D, > 0): moment of inertia I = q m a^2, a = sigma/2 (2D default: disks)"}},
  };
  return models;
}

RestitutionLaw read_restitution(CaseReader& r) {
  std::vector<std::string> names;
  for (const auto& m : restitution_models()) names.push_back(m.name);
  const std::string law = r.choice("restitution", "law", "elastic", names);
  if (law == "constant") {
    return ConstantRestitution{r.real_required("restitution", "e", Bounds::half_open(0.0, 1.0))};
  }
  if (law == "power") {
    PowerLawRestitution p;
    p.beta = r.real("restitution", "beta", 0.0, Bounds::non_negative(), "velocity^-delta");
    p.delta = r.real("restitution", "delta", 0.0, Bounds::closed(0.0, 10.0));
    if (p.delta == 0.0 && p.beta > 0.5)
      r.problem("restitution", "beta", "with delta = 0 the power law gives e = 1 - 2 beta < 0; expected beta <= 0.5");
    return p;
  }
  if (law == "walton")
    r.problem("restitution", "law", "law \"walton\" (rough grains) is read by the solvers that carry spins (EDMD, homogeneous DSMC), not here");
  if (law == "bizon") {
    BizonRestitution b;
    b.e_c = r.real("restitution", "e", 0.7, Bounds::half_open(0.0, 1.0));
    b.crossover = r.real("restitution", "crossover", 1.0, Bounds::positive(), "velocity");
    return b;
  }
  return ElasticRestitution{};
}

bool names_walton(CaseReader& r) {
  return r.has("restitution", "law") && r.text("restitution", "law", "elastic") == "walton";
}

RoughParameters read_rough(CaseReader& r, double default_q, std::string_view trot_section) {
  RoughParameters g;
  g.law.e = r.real_required("restitution", "e", Bounds::closed(0.0, 1.0), "normal restitution");
  g.law.beta0 = r.real_required("restitution", "beta0", Bounds::closed(-1.0, 1.0), "tangential restitution");
  g.law.mu = r.has("restitution", "mu") ? r.real("restitution", "mu", 0.0, Bounds::non_negative(), "Coulomb friction")
                                        : std::numeric_limits<double>::infinity();
  g.q = r.real("restitution", "q", default_q, Bounds::positive(), "I / (m a^2)");
  g.rotational_temperature = r.real(trot_section, "rotational_temperature", 0.0, Bounds::non_negative(), "energy");
  return g;
}

BackgroundParameters read_background(CaseReader& r) {
  BackgroundParameters b;
  b.mass_ratio = r.real("background", "mass_ratio", 0.5, Bounds::open(0.0, 1.0), "alpha = mB/(m+mB)");
  b.density = r.real("background", "density", 0.0, Bounds::non_negative(), "nB");
  b.temperature = r.real("background", "temperature", 1.0, Bounds::positive(), "energy");
  b.velocity = r.vec3("background", "velocity", {});
  b.knudsen = r.real("background", "knudsen", 1.0, Bounds::positive(), "eps");
  return b;
}

}  // namespace grainbath
