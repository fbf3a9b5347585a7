// hydro/hydro.hpp -- public interface of grainbath::hydro: the drift-diffusion (eps -> 0) limit
// of the Bisi-Spiga kinetic equation (seed 002, eqs. 30-37) and 1D solvers of the closed
// (n, u, T) moment systems. Derivations: docs/hydro.md; validation: docs/validation/hydro.md.
#pragma once

#include "hydro/closure1d.hpp"
#include "hydro/drift_diffusion.hpp"
#include "hydro/grid.hpp"
#include "hydro/transport.hpp"

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace grainbath::hydro {

// Parameters of `grainbath theory` for the hydro block.
struct HydroTheoryParams {
  double alpha = 0.5;
  double mass = 1.0;
  double nB = 1.0;
  double TB = 1.0;
  double eps = 0.1;
  double n = 1.0;                 // grain density (closure modes: inelastic cooling ~ n)
  double beta = 0.0;              // inelasticity 1 - e = 2 beta |g.n|^delta (Bisi-Spiga eq. 5)
  double delta = 0.0;
  std::optional<double> k;        // density-mode wavenumber; decay rates reported when set
};

// Dotted keys for the CLI:
//   hydro.diffusion_coefficient            Bisi-Spiga eq. 36 (first Sonine)
//   hydro.diffusion_coefficient_kinetic    Sonine-Galerkin, converged
//   hydro.thermal_diffusion_exponent_kinetic, hydro.kinetic_sonine_order, hydro.kinetic_sonine_change
//   with k: hydro.decay_rate (D k^2, paper), hydro.decay_rate_kinetic, and the closures'
//   finite-eps mode rates hydro.decay_rate_maxwellian_closure, hydro.decay_rate_grad_closure,
//   hydro.decay_rate_sonine_closure (closure1d.hpp).
std::vector<std::pair<std::string, double>> hydro_theory_values(const HydroTheoryParams& p);

}  // namespace grainbath::hydro
