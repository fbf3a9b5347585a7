#include "dsmc/theory.hpp"

#include "dsmc/rough.hpp"
#include "hydro/hydro.hpp"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <variant>

namespace grainbath::dsmc {

std::optional<std::pair<double, double>> power_law_equivalent(const RestitutionLaw& law) {
  if (std::holds_alternative<ElasticRestitution>(law)) return std::pair{0.0, 0.0};
  if (auto c = std::get_if<ConstantRestitution>(&law)) return std::pair{0.5 * (1.0 - c->e), 0.0};
  if (auto p = std::get_if<PowerLawRestitution>(&law)) return std::pair{p->beta, p->delta};
  return std::nullopt;
}

std::optional<closures::Parameters> closure_parameters(const Config& c) {
  const auto pl = power_law_equivalent(c.restitution);
  if (!c.background.present() || !pl) return std::nullopt;
  closures::Parameters p;
  p.alpha = c.background.mass_ratio;
  p.mass = c.grains.mass;
  p.nB = c.background.density;
  p.TB = c.background.temperature;
  p.uB = {c.background.velocity.x, c.background.velocity.y, c.background.velocity.z};
  p.eps = c.background.knudsen;
  p.n = c.grains.density;
  p.beta = pl->first;
  p.delta = pl->second;
  return p;
}

double vne_a2(double e, int d) {
  return 16.0 * (1.0 - e) * (1.0 - 2.0 * e * e) / (9.0 + 24.0 * d - e * (41.0 - 8.0 * d) + 30.0 * (1.0 - e) * e * e);
}

double haff_zeta0(double e, double density, double mass) {
  return 4.0 * density * (1.0 - e * e) / (3.0 * std::sqrt(std::numbers::pi * mass));
}

double haff_temperature_with_ratio(double t, double T0, double e, double density, double mass, double ratio) {
  const double zeta = haff_zeta0(e, density, mass) * ratio;
  const double x = 1.0 + 0.5 * zeta * std::sqrt(T0) * t;  // dT/dt = -zeta T^{3/2}
  return T0 / (x * x);
}

double haff_temperature(double t, double T0, double e, double density, double mass, bool with_a2) {
  return haff_temperature_with_ratio(t, T0, e, density, mass, with_a2 ? 1.0 + 3.0 * vne_a2(e) / 16.0 : 1.0);
}

namespace {
// zeta/zeta0 of the second Sonine cooling state (docs/closures.md eq. H10), if it exists
std::optional<double> sonine2_rate_ratio(double e) {
  try {
    return closures::hcs_cooling_rate_ratio(closures::hcs_sonine2_linear(e));
  } catch (const closures::ClosureError&) {
    return std::nullopt;
  }
}
}  // namespace

static std::optional<double> constant_e(const RestitutionLaw& law) {
  if (std::holds_alternative<ElasticRestitution>(law)) return 1.0;
  if (auto c = std::get_if<ConstantRestitution>(&law)) return c->e;
  if (auto p = std::get_if<PowerLawRestitution>(&law); p && p->delta == 0.0) return 1.0 - 2.0 * p->beta;
  return std::nullopt;
}

std::vector<std::pair<std::string, double>> theory_values(const Config& c) {
  if (c.rough) return rough_theory_values(c);  // the smooth-grain theories below do not apply
  std::vector<std::pair<std::string, double>> out;
  if (auto p = closure_parameters(c)) {
    try {
      out = closures::theory_values(*p);
    } catch (const closures::ClosureError& e) {
      std::fprintf(stderr, "note: no closure theory for these parameters: %s\n", e.what());
    }
    // the drift-diffusion limit (Bisi-Spiga eq. 36) and its kinetic coefficients
    hydro::HydroTheoryParams h;
    h.alpha = p->alpha;
    h.mass = p->mass;
    h.nB = p->nB;
    h.TB = p->TB;
    h.eps = p->eps;
    h.n = p->n;
    h.beta = p->beta;
    h.delta = p->delta;
    // The density-mode rates (D k^2 and the closures' linear rates) are those of a uniform
    // background (a uniform drift only moves the mode). In an isobaric, shear or file background
    // the cos(kx) projection the run fits is not an eigenmode: e.g. the drift-diffusion solver
    // gives 0.561 instead of D k^2 = 0.656 over the fit window of cases/diffusion-limit (eps = 0.1)
    // with an isobaric amplitude 0.5; so no decay rate is printed there rather than a wrong one.
    if (c.spatial() && c.grains.profile == GrainProfile::mode) {
      if (c.field.profile == BackgroundProfile::uniform)
        h.k = c.wavenumber();
      else
        std::fprintf(stderr,
                     "note: no density-mode decay rate from the hydrodynamic theory: D k^2 and the closures' "
                     "mode rates hold in a uniform background, and this background is not uniform\n");
    }
    try {
      const auto hv = hydro::hydro_theory_values(h);
      out.insert(out.end(), hv.begin(), hv.end());
      // say so when the kinetic coefficients' Sonine series stopped unconverged (alpha near
      // 1: hydro/theory.cpp), instead of leaving it to a 0 in summary.json
      auto value = [&](const char* key) {
        for (const auto& [k, v] : hv)
          if (k == key) return v;
        return std::nan("");
      };
      if (value("hydro.kinetic_sonine_converged") == 0.0)
        std::fprintf(stderr,
                     "note: the Sonine series of the kinetic diffusion coefficients did not converge (order %.0f, last "
                     "relative change %.2g; mass ratio alpha = %.3g): theory.hydro.*_kinetic are uncertain, the "
                     "closures' and the paper's values are not affected\n",
                     value("hydro.kinetic_sonine_order"), value("hydro.kinetic_sonine_change"), h.alpha);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "note: no hydrodynamic theory for these parameters: %s\n", e.what());
    }
  } else if (!c.background.present()) {
    if (auto e = constant_e(c.restitution)) {
      out.emplace_back("haff.zeta0", haff_zeta0(*e, c.grains.density, c.grains.mass));
      out.emplace_back("haff.a2_van_noije_ernst", vne_a2(*e));
      // the homogeneous cooling state beyond the first Sonine approximation (docs/closures.md
      // Sec. H): second Sonine a2, a3, linear (eq. H8) and with the quadratic terms (eq. H9), and
      // the cooling rate over the Maxwellian one, zeta/zeta0 (eq. H10) with the linear a2, a3
      try {
        const closures::HcsSonine lin = closures::hcs_sonine2_linear(*e);
        const closures::HcsSonine nl = closures::hcs_sonine2_nonlinear(*e);
        out.emplace_back("hcs.a2_sonine2", lin.a2);
        out.emplace_back("hcs.a3_sonine2", lin.a3);
        out.emplace_back("hcs.a2_sonine2_nonlinear", nl.a2);
        out.emplace_back("hcs.a3_sonine2_nonlinear", nl.a3);
        out.emplace_back("hcs.cooling_rate_ratio_sonine2", closures::hcs_cooling_rate_ratio(lin));
        // the linear hierarchy to a6 (eq. H.8): the second Sonine value's truncation estimate
        const std::vector<double> k6 = closures::hcs_sonine_linear(*e, 6);
        out.emplace_back("hcs.a2_linear_to_a6", k6[0]);
        out.emplace_back("hcs.a3_linear_to_a6", k6[1]);
      } catch (const closures::ClosureError& err) {
        std::fprintf(stderr, "note: no second-Sonine cooling state: %s\n", err.what());
      }
      // with the homogeneous cooling state's a2, and the Maxwellian cooling rate alone
      out.emplace_back("haff.temperature_at_t_end",
                       haff_temperature(c.t_end, c.grains.temperature, *e, c.grains.density, c.grains.mass, true));
      out.emplace_back("haff.temperature_at_t_end_no_a2",
                       haff_temperature(c.t_end, c.grains.temperature, *e, c.grains.density, c.grains.mass, false));
      // with the second Sonine cooling rate zeta0 (1 + 3 a2/16 + a3/64 + ...) (eq. H10)
      if (const auto r = sonine2_rate_ratio(*e))
        out.emplace_back("haff.temperature_at_t_end_sonine2",
                         haff_temperature_with_ratio(c.t_end, c.grains.temperature, *e, c.grains.density,
                                                     c.grains.mass, *r));
    }
  }
  return out;
}

std::vector<std::pair<std::string, std::vector<double>>> relaxation_series(const Config& c,
                                                                           const std::vector<double>& times) {
  std::vector<std::pair<std::string, std::vector<double>>> out;
  if (auto p = closure_parameters(c)) {
    const closures::RelaxationState init{{c.grains.drift.x, c.grains.drift.y, c.grains.drift.z},
                                         c.grains.temperature, 0.0};
    for (auto which : {closures::Closure::maxwellian, closures::Closure::grad, closures::Closure::sonine}) {
      try {
        const auto states = closures::relax(which, *p, init, times);
        std::vector<double> T, u, a2;
        for (const auto& s : states) {
          T.push_back(s.T);
          u.insert(u.end(), s.u.begin(), s.u.end());
          a2.push_back(s.a2);
        }
        const std::string name = closures::to_string(which);
        out.emplace_back(name + "/temperature", T);
        out.emplace_back(name + "/velocity", u);
        if (which == closures::Closure::sonine) out.emplace_back(name + "/a2", a2);
      } catch (const closures::ClosureError& e) {
        std::fprintf(stderr, "note: %s closure relaxation unavailable: %s\n", closures::to_string(which), e.what());
      }
    }
  } else if (!c.background.present()) {
    if (auto e = constant_e(c.restitution)) {
      std::vector<double> T, T_no_a2;
      for (double t : times) {
        T.push_back(haff_temperature(t, c.grains.temperature, *e, c.grains.density, c.grains.mass, true));
        T_no_a2.push_back(haff_temperature(t, c.grains.temperature, *e, c.grains.density, c.grains.mass, false));
      }
      out.emplace_back("haff/temperature", T);
      out.emplace_back("haff/temperature_no_a2", T_no_a2);
      if (const auto r = sonine2_rate_ratio(*e)) {
        std::vector<double> T2;
        for (double t : times)
          T2.push_back(haff_temperature_with_ratio(t, c.grains.temperature, *e, c.grains.density, c.grains.mass, *r));
        out.emplace_back("haff/temperature_sonine2", T2);
      }
    }
  }
  return out;
}

}  // namespace grainbath::dsmc
