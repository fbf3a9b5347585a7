#include "core/physics_config.hpp"

#include <algorithm>
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

namespace {

// The key names of a law: the first word of each of its descriptions ("mu (inf, >= 0): ...").
std::vector<std::string> law_keys(std::string_view law) {
  std::vector<std::string> keys;
  for (const auto& m : restitution_models())
    if (m.name == law)
      for (const auto& k : m.keys) keys.push_back(k.substr(0, k.find(' ')));
  return keys;
}

bool contains(const std::vector<std::string>& v, std::string_view x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

std::string quoted_list(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : sep) + x;
  return s.empty() ? "none" : s;
}

// A key of another law is not "unknown": say whose key it is. The one exception: when --set
// switched the law, the file's keys of the law it replaced are ignored with a note, so
// `--set restitution.law=...` (and sweeps over laws) work without editing the file. Only exact
// keys of the file's own law are dropped, so a misspelt key is still an error.
void reject_other_law_keys(CaseReader& r, const std::string& law, std::string_view trot_section) {
  const std::string file_law = r.overridden("restitution", "law") ? r.file_string("restitution", "law") : "";
  const bool switched = !file_law.empty() && file_law != law;
  const std::vector<std::string> mine = law_keys(law);
  auto drop_or_reject = [&](std::string_view section, const std::string& key, const std::string& owner_law,
                            std::string message) {
    if (switched && owner_law == file_law && !r.overridden(section, key))
      r.ignore(section, key,
               "ignored: a key of the file's law = \"" + file_law + "\", which --set restitution.law = \"" + law +
                   "\" replaces");
    else
      r.used_elsewhere(section, key, std::move(message));
  };
  for (const auto& m : restitution_models()) {
    if (m.name == law) continue;
    for (const auto& key : law_keys(m.name)) {
      if (contains(mine, key) || !r.has("restitution", key)) continue;
      std::vector<std::string> owners;
      for (const auto& o : restitution_models())
        if (contains(law_keys(o.name), key)) owners.push_back("\"" + o.name + "\"");
      drop_or_reject("restitution", key, contains(law_keys(file_law), key) ? file_law : m.name,
                     "not used by law = \"" + law + "\" (it is a key of law = " + quoted_list(owners, " or ") +
                         "; keys of law = \"" + law + "\": " + quoted_list(mine, ", ") + ")");
    }
  }
  if (law != "walton" && !trot_section.empty() && r.has(trot_section, "rotational_temperature"))
    drop_or_reject(trot_section, "rotational_temperature", "walton",
                   "only rough grains spin: used only with [restitution] law = \"walton\", found law = \"" + law +
                       "\"");
}

}  // namespace

RestitutionLaw read_restitution(CaseReader& r, std::string_view trot_section) {
  std::vector<std::string> names;
  for (const auto& m : restitution_models()) names.push_back(m.name);
  const std::string law = r.choice("restitution", "law", "elastic", names);
  // a law that is no law (already reported) says nothing about which keys are right
  const auto named = r.resolved().find("restitution.law");
  if (named != r.resolved().end() && named->second == "\"" + law + "\"") reject_other_law_keys(r, law, trot_section);
  if (law == "constant") {
    return ConstantRestitution{r.real_required("restitution", "e", Bounds::half_open(0.0, 1.0))};
  }
  if (law == "power") {
    PowerLawRestitution p;
    p.beta = r.real("restitution", "beta", 0.0, Bounds::non_negative(), "velocity^-delta");
    p.delta = r.real("restitution", "delta", 0.0, Bounds::closed(0.0, 10.0));
    if (p.delta == 0.0 && p.beta > 0.5)
      r.problem("restitution", "beta",
                "with delta = 0 the power law gives e = 1 - 2 beta < 0; expected beta <= 0.5, found " +
                    format_real(p.beta));
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
  r.accept("restitution", "mu");  // a valid key even when absent: listed in messages, suggested for "muu"
  g.law.mu = r.has("restitution", "mu") ? r.real("restitution", "mu", 0.0, Bounds::non_negative(), "Coulomb friction")
                                        : std::numeric_limits<double>::infinity();
  g.q = r.real("restitution", "q", default_q, Bounds::positive(), "I / (m a^2)");
  g.rotational_temperature = r.real(trot_section, "rotational_temperature", 0.0, Bounds::non_negative(), "energy");
  reject_other_law_keys(r, "walton", trot_section);
  return g;
}

void name_other_solver_keys(CaseReader& r, std::string_view solver) {
  // The sections and [sampling] keys only one solver reads (the shared ones, [run],
  // [background], [restitution], [checkpoint], are read by both). Keep in step with the
  // readers (dsmc/config.cpp, edmd/driver.cpp); tests/cli/bad_input_test.cpp checks a few.
  struct Own { std::string_view solver; std::vector<std::string_view> sections, sampling; };
  static const Own owns[] = {
      {"dsmc", {"grains", "dsmc", "domain"},
       {"every", "steady_from", "histogram_bins", "histogram_range", "relaxation_theory", "fields", "field_batches",
        "mode_fit_from", "mode_fit_to"}},
      {"edmd", {"edmd", "heating", "walls", "profiles", "transport"},
       {"interval", "gr_max", "gr_bin", "corr_max", "corr_bin", "trajectory_interval", "free_cooling"}},
  };
  for (const Own& o : owns) {
    if (o.solver == solver) {
      for (const auto sec : o.sections) r.accept_section(sec);  // valid even when absent
      continue;
    }
    const std::string owner = "solver = \"" + std::string(o.solver) + "\"";
    const std::string mine = "solver = \"" + std::string(solver) + "\"";
    for (const auto sec : o.sections) {
      std::string m = "[";
      m.append(sec).append("] is a section of ").append(owner).append(", this case has ").append(mine);
      r.used_elsewhere(sec, "", std::move(m));
    }
    for (const auto key : o.sampling)
      r.used_elsewhere("sampling", key, "not used by " + mine + " (a [sampling] key of " + owner + ")");
  }
}

BackgroundParameters read_background(CaseReader& r) {
  BackgroundParameters b;
  b.mass_ratio = r.real("background", "mass_ratio", 0.5, Bounds::open(0.0, 1.0), "alpha = mB/(m+mB)");
  b.density = r.real("background", "density", 0.0, Bounds::non_negative(), "nB");
  b.temperature = r.real("background", "temperature", 1.0, Bounds::positive(), "energy");
  b.velocity = r.vec3("background", "velocity", {});
  b.knudsen = r.real("background", "knudsen", 1.0, Bounds::positive(), "eps");
  // [background] keys without a density describe a medium that is not there: the default
  // nB = 0 means none, and the grains would cool freely. Say so instead of running free
  // cooling silently. An explicit density = 0 is a deliberate "no medium" (a sweep over nB);
  // profile = "file" takes nB from its grid; the diffuse walls of a spatial DSMC run take TB as
  // their default wall_temperature.
  if (!r.has("background", "density") && !r.has("background", "file")) {
    std::vector<std::string> given;
    for (const char* key : {"knudsen", "temperature", "mass_ratio", "velocity"}) {
      if (!r.has("background", key)) continue;
      if (std::string_view(key) == "temperature" && r.has_section("domain") && !r.has("domain", "wall_temperature"))
        continue;
      given.push_back(key);
    }
    if (!given.empty()) {
      std::string also;
      for (std::size_t i = 1; i < given.size(); ++i) also += (also.empty() ? "" : ", ") + given[i];
      r.problem("background", given.front(),
                "given without background.density, whose default 0 means no medium (the grains would cool freely" +
                    (also.empty() ? std::string(")") : "; also without effect: " + also + ")") +
                    "; give density = nB > 0 for a medium, or density = 0 to run without one");
    }
  } else if (b.density == 0.0 && !r.has("background", "file")) {
    // density = 0 on purpose (a sweep over nB reaching 0): accepted, but the medium's other
    // keys then do nothing, which is said (review 4: it passed silently)
    std::string given;
    for (const char* key : {"knudsen", "temperature", "mass_ratio", "velocity"})
      if (r.has("background", key) &&
          !(std::string_view(key) == "temperature" && r.has_section("domain") && !r.has("domain", "wall_temperature")))
        given += (given.empty() ? "" : ", ") + std::string(key);
    if (!given.empty())
      r.note("background", "density",
             "density = 0: no medium, so background." + given + (given.find(',') == std::string::npos ? " does" : " do") +
                 " nothing in this run");
  }
  return b;
}

}  // namespace grainbath
