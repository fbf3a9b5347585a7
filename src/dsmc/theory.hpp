#pragma once
// Theory beside every DSMC run: the closures' equilibria and expansions (closures/), the
// closures' relaxation on the DSMC time grid, and Haff's law with the van Noije-Ernst a2
// for free cooling.
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "closures/closures.hpp"
#include "dsmc/dsmc.hpp"

namespace grainbath::dsmc {

// Power-law parameters (beta, delta) equivalent to the case's restitution law, if it has
// one (elastic: beta = 0; constant e: beta = (1 - e)/2, delta = 0; power: as given).
std::optional<std::pair<double, double>> power_law_equivalent(const RestitutionLaw&);

// The closures' Parameters for a homogeneous case (nullopt: no medium or no power law).
std::optional<closures::Parameters> closure_parameters(const Config&);

// Free cooling of constant-e hard spheres, d = 3 (Haff; van Noije & Ernst 1998):
//   dT/dt = -zeta0 (1 + 3 a2 / 16) T^(3/2),  zeta0 = 4 n (1 - e^2) / (3 sqrt(pi m))
// (docs/dsmc.md D4; the Maxwellian part is Bisi-Spiga eq. 25 with delta = 0), and
//   a2 = 16 (1 - e)(1 - 2 e^2) / (81 - 17 e + 30 e^2 (1 - e)).
// haff_temperature: T0 / (1 + zeta sqrt(T0) t / 2)^2 with zeta = zeta0 (1 + 3 a2 / 16) if
// with_a2, else zeta0 (Maxwellian grains). Written both ways: theory.haff.temperature_at_t_end
// and /theory/haff/temperature with a2, ..._no_a2 without (docs/OUTPUT.md).
double vne_a2(double e, int dimension = 3);
double haff_zeta0(double e, double density, double mass);
double haff_temperature(double t, double T0, double e, double density, double mass, bool with_a2);
// The same with the cooling rate zeta0 * ratio, ratio = zeta/zeta0 of the second Sonine
// cooling state (closures::hcs_cooling_rate_ratio, docs/closures.md eq. H10):
// theory.haff.temperature_at_t_end_sonine2 and /theory/haff/temperature_sonine2.
double haff_temperature_with_ratio(double t, double T0, double e, double density, double mass, double ratio);

// Relaxation of each closure, sampled at `times`: names like "maxwellian/temperature",
// "grad/velocity" (3 per time), "sonine/a2", "haff/temperature" (with a2),
// "haff/temperature_no_a2", "haff/temperature_sonine2".
std::vector<std::pair<std::string, std::vector<double>>> relaxation_series(const Config&,
                                                                           const std::vector<double>& times);

}  // namespace grainbath::dsmc
