// The `grainbath theory` values: equilibria of all closures and the eps-expansion.
#include <cmath>
#include <optional>

#include "closures/closures.hpp"
#include "closures/root_finding.hpp"

namespace grainbath::closures {

double equilibrium_temperature(Closure c, const Parameters& p) {
  if (c == Closure::sonine) return equilibrium_sonine(p).T;
  return equilibrium_temperature_gaussian(c, p);
}

double equilibrium_a2_sonine(const Parameters& p) { return equilibrium_sonine(p).a2; }

std::vector<std::pair<std::string, double>> theory_values(const Parameters& p) {
  validate(p);
  std::vector<std::pair<std::string, double>> v;
  const double TM = equilibrium_temperature(Closure::maxwellian, p);
  const double TG = equilibrium_temperature(Closure::grad, p);
  // The Sonine closure can lack a steady state where the seed closures have one (very strong
  // dissipation, docs Sec. S.4): then its keys are left out and diagnostics.sonine_available
  // is 0, so the Maxwellian and Grad values are still reported.
  std::optional<SonineEquilibrium> S;
  try {
    S = equilibrium_sonine(p);
  } catch (const ClosureError&) {
    S.reset();
  }
  const bool sonine_ok = S.has_value();
  const Expansion e = expansion(p);
  v.emplace_back("equilibrium.u.x", p.uB[0]);  // u# = uB for every closure
  v.emplace_back("equilibrium.u.y", p.uB[1]);
  v.emplace_back("equilibrium.u.z", p.uB[2]);
  v.emplace_back("equilibrium.maxwellian.T", TM);
  v.emplace_back("equilibrium.grad.T", TG);
  if (sonine_ok) {
    v.emplace_back("equilibrium.sonine.T", S->T);
    v.emplace_back("equilibrium.sonine.a2", S->a2);
  }
  v.emplace_back("expansion.T0", e.T0);
  v.emplace_back("expansion.T1", e.T1);
  v.emplace_back("expansion.T2_maxwellian", e.T2_maxwellian);
  v.emplace_back("expansion.T2_grad", e.T2_grad);
  v.emplace_back("expansion.first_order.T", e.T0 + p.eps * e.T1);
  v.emplace_back("expansion.second_order_maxwellian.T",
                 e.T0 + p.eps * e.T1 + p.eps * p.eps * e.T2_maxwellian);
  v.emplace_back("expansion.second_order_grad.T", e.T0 + p.eps * e.T1 + p.eps * p.eps * e.T2_grad);
  // Momentum relaxation rate at zero drift, (8/3) sqrt(2/pi) alpha (nB/eps) s(T#) (docs eq. C5).
  v.emplace_back("rates.momentum", (8.0 / 3.0) * std::sqrt(2.0 / M_PI) * p.alpha * p.nB / p.eps *
                                       relative_speed_scale(p, TM));
  v.emplace_back("diagnostics.sonine_available", sonine_ok ? 1.0 : 0.0);
  v.emplace_back("diagnostics.negative_restitution_probability",
                 negative_restitution_probability(p, TM));
  return v;
}

}  // namespace grainbath::closures
