// hydro/theory.cpp -- the hydro block of `grainbath theory`.
#include "hydro/hydro.hpp"

#include <cmath>
#include <stdexcept>

namespace grainbath::hydro {

std::vector<std::pair<std::string, double>> hydro_theory_values(const HydroTheoryParams& p) {
  std::vector<std::pair<std::string, double>> out;
  const DriftDiffusionCoefficients paper = paper_coefficients(p.alpha, p.mass, p.eps);
  const KineticTransport kin = kinetic_transport(p.alpha);
  DriftDiffusionCoefficients kinetic = paper;
  kinetic.Dhat = kin.Dhat;
  kinetic.p = kin.p;
  kinetic.name = "kinetic";
  // Bisi-Spiga eq. 36 (validates nB, TB, eps, alpha, m).
  out.emplace_back("hydro.diffusion_coefficient", diffusion_coefficient_paper(p.alpha, p.mass, p.nB, p.TB, p.eps));
  out.emplace_back("hydro.diffusion_coefficient_kinetic", kinetic.D(p.nB, p.TB));
  out.emplace_back("hydro.diffusion_ratio_kinetic_over_paper", kin.Dhat / paper.Dhat);
  out.emplace_back("hydro.thermal_diffusion_exponent", paper.p);
  out.emplace_back("hydro.thermal_diffusion_exponent_kinetic", kin.p);
  out.emplace_back("hydro.kinetic_sonine_order", kin.order);
  out.emplace_back("hydro.kinetic_sonine_change", kin.change);
  out.emplace_back("hydro.kinetic_sonine_converged", kin.converged ? 1.0 : 0.0);
  if (p.k) {
    const double k = *p.k;
    if (!(k > 0.0) || !std::isfinite(k))
      throw std::invalid_argument("The density-mode wavenumber k must be positive and finite.");
    out.emplace_back("hydro.k", k);
    out.emplace_back("hydro.decay_rate", drift_diffusion_decay_rate(paper, p.nB, p.TB, k));
    out.emplace_back("hydro.decay_rate_kinetic", drift_diffusion_decay_rate(kinetic, p.nB, p.TB, k));
    // Finite-eps density-mode rates of the closed (n, u, T) systems (docs/hydro.md eq. H24).
    ModeParams mp;
    mp.alpha = p.alpha;
    mp.mass = p.mass;
    mp.nB = p.nB;
    mp.TB = p.TB;
    mp.eps = p.eps;
    mp.n = p.n;
    mp.beta = p.beta;
    mp.delta = p.delta;
    out.emplace_back("hydro.decay_rate_maxwellian_closure", mode_decay_rate(ModeModel::maxwellian_closure, mp, k));
    out.emplace_back("hydro.decay_rate_grad_closure", mode_decay_rate(ModeModel::grad_closure, mp, k));
    out.emplace_back("hydro.decay_rate_sonine_closure", mode_decay_rate(ModeModel::sonine_closure, mp, k));
  }
  return out;
}

}  // namespace grainbath::hydro
