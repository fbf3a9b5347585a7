#pragma once
// Internal helpers shared by the closure sources (not part of the public API).
#include <functional>
#include <string>

#include "closures/closures.hpp"

namespace grainbath::closures {
// GSL Brent on [lo, hi]; throws ClosureError(what + ...) without a sign change.
double brent_root(const std::function<double(double)>& f, double lo, double hi, double rel_tol,
                  const std::string& what);
// Throws ClosureError naming restitution.beta/delta if P(e < 0) at temperature T exceeds
// kMaxNegativeRestitutionProbability (docs eq. C12).
void check_restitution(const Parameters&, double T);
// T# of the maxwellian or grad closure (Bisi-Spiga eq. 27, docs eq. G11).
double equilibrium_temperature_gaussian(Closure, const Parameters&);
// relax() with an explicit choice of integrator: stiff = GSL msbdf with a finite-difference
// Jacobian, otherwise rk8pd (used by relax for sonine and the others respectively; exposed
// so the tests can check one against the other).
std::vector<RelaxationState> relax_integrator(Closure, const Parameters&, const RelaxationState&,
                                              const std::vector<double>& times, bool stiff);
}  // namespace grainbath::closures
