// Collision equilibria (u# = uB, T#) and their eps-expansions.
#include <gsl/gsl_errno.h>
#include <gsl/gsl_roots.h>

#include <cmath>
#include <functional>
#include <memory>
#include <sstream>

#include "closures/closures.hpp"
#include "closures/root_finding.hpp"

namespace grainbath::closures {
namespace {
constexpr double kSqrt2OverPi = 0.79788456080286535588;

double trampoline(double x, void* params) {
  return (*static_cast<const std::function<double(double)>*>(params))(x);
}
}  // namespace

double brent_root(const std::function<double(double)>& f, double lo, double hi, double rel_tol,
                  const std::string& what) {
  const double flo = f(lo), fhi = f(hi);
  if (!std::isfinite(flo) || !std::isfinite(fhi) || flo * fhi > 0.0) {
    std::ostringstream os;
    os << what << ": no sign change in the bracket [" << lo << ", " << hi << "] (f = " << flo
       << ", " << fhi << ")";
    throw ClosureError(os.str());
  }
  if (flo == 0.0) return lo;
  if (fhi == 0.0) return hi;
  gsl_function F{&trampoline, const_cast<std::function<double(double)>*>(&f)};
  std::unique_ptr<gsl_root_fsolver, decltype(&gsl_root_fsolver_free)> s(
      gsl_root_fsolver_alloc(gsl_root_fsolver_brent), &gsl_root_fsolver_free);
  gsl_error_handler_t* old = gsl_set_error_handler_off();
  gsl_root_fsolver_set(s.get(), &F, lo, hi);
  double root = 0.5 * (lo + hi);
  for (int it = 0; it < 500; ++it) {
    if (gsl_root_fsolver_iterate(s.get()) != GSL_SUCCESS) break;
    root = gsl_root_fsolver_root(s.get());
    const double a = gsl_root_fsolver_x_lower(s.get()), b = gsl_root_fsolver_x_upper(s.get());
    if (gsl_root_test_interval(a, b, 0.0, rel_tol) == GSL_SUCCESS) break;
  }
  gsl_set_error_handler(old);
  return root;
}

namespace {
// dT/dt at u = uB for the two closed (u, T) systems.
double energy_balance(Closure c, const Parameters& p, double T) {
  const RelaxationState st{p.uB, T, 0.0};
  return sources(c, p, st).dT_dt;
}

}  // namespace

void check_restitution(const Parameters& p, double T) {
  const double P = negative_restitution_probability(p, T);
  if (P > kMaxNegativeRestitutionProbability) {
    std::ostringstream os;
    os << "restitution.beta = " << p.beta << " with restitution.delta = " << p.delta
       << " makes the unclamped power law e = 1 - 2 beta |g.n|^delta negative in a fraction "
       << P << " of collisions at T = " << T
       << " (limit " << kMaxNegativeRestitutionProbability
       << "); reduce beta: the closures (which, like the paper, do not clamp e) are invalid";
    throw ClosureError(os.str());
  }
}

double equilibrium_temperature_gaussian(Closure c, const Parameters& p) {
  validate(p);
  check_restitution(p, p.TB);  // T# <= TB, so P(T#) <= P(TB); checked again at T# below
  if (p.beta == 0.0) return p.TB;  // no loss: (TB - T) s(T) = 0 (Bisi-Spiga eq. 27)
  const double fTB = energy_balance(c, p, p.TB);
  if (!(fTB < 0.0)) {
    std::ostringstream os;
    os << "no collision equilibrium in (0, TB]: with restitution.beta = " << p.beta
       << " and restitution.delta = " << p.delta
       << " the inelastic term does not cool at T = TB (dT/dt = " << fTB << ")";
    throw ClosureError(os.str());
  }
  // The exchange term > 0 and the loss -> 0 as T -> 0, so f(lo) > 0 for small enough lo.
  double lo = 1e-3 * p.TB;
  while (energy_balance(c, p, lo) <= 0.0) {
    lo *= 1e-3;
    if (lo < 1e-15 * p.TB)
      throw ClosureError(std::string("no collision equilibrium of the ") + to_string(c) +
                         " closure in (0, TB]: background.knudsen (eps) or grains.density too "
                         "large for the bath to balance the loss");
  }
  const double T = brent_root([&](double x) { return energy_balance(c, p, x); }, lo, p.TB,
                              1e-14, std::string("equilibrium_temperature(") + to_string(c) + ")");
  check_restitution(p, T);
  return T;
}

Expansion expansion(const Parameters& p) {
  validate(p);
  // Energy balance at u = uB (Bisi-Spiga eq. 27, docs eq. C13):
  //   K s(T) (TB - T) = eps Lambda(T),  K = (16/3) sqrt(2/pi) alpha (1-alpha) nB,
  // Lambda = -maxwellian_loss = C1 T^{(d+3)/2} - C2 T^{(2d+3)/2}.
  const double K = (16.0 / 3.0) * kSqrt2OverPi * p.alpha * (1.0 - p.alpha) * p.nB;
  const double s0 = relative_speed_scale(p, p.TB);
  const double ds0 = 1.0 / (2.0 * p.mass * s0);  // ds/dT at TB (docs eq. C1)
  double Lam = 0.0, dLam = 0.0;
  if (p.beta > 0.0) {
    const double d = p.delta, th = p.TB / p.mass;
    const double c = (16.0 / (3.0 * std::sqrt(M_PI))) * p.mass * p.n * p.beta;
    const double first = c * std::pow(2.0, d) * std::tgamma(0.5 * d + 2.0) * std::pow(th, 0.5 * (d + 3.0));
    const double second = c * p.beta * std::pow(2.0, 2.0 * d) * std::tgamma(d + 2.0) *
                          std::pow(th, 0.5 * (2.0 * d + 3.0));
    Lam = first - second;
    dLam = (first * 0.5 * (d + 3.0) - second * 0.5 * (2.0 * d + 3.0)) / p.TB;
  }
  Expansion e;
  e.T0 = p.TB;                                      // docs eq. C13
  e.T1 = -Lam / (K * s0);                           // docs eq. C14 (Bisi-Spiga eq. 28)
  e.T2_maxwellian = -(dLam * e.T1 + K * ds0 * e.T1 * e.T1) / (K * s0);  // docs eq. C15 (eq. 29)
  e.T2_grad = -dLam * e.T1 / (K * s0);              // docs eq. G12: s frozen at s(TB)
  return e;
}

}  // namespace grainbath::closures
