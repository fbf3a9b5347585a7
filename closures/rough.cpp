// Mean-field models A-E for a homogeneously driven 2D gas of rough particles with Walton's
// collision rule (docs/rough.md; thesis seed 000 chapter 10 and appendix C).
#include "closures/rough.hpp"

#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <sstream>

#include "closures/closures.hpp"
#include "closures/root_finding.hpp"

namespace grainbath::closures::rough {

const char* to_string(Model m) {
  switch (m) {
    case Model::A: return "A";
    case Model::B: return "B";
    case Model::C: return "C";
    case Model::D: return "D";
    case Model::E: return "E";
  }
  return "?";
}

Model model_from_string(const std::string& s) {
  if (s == "A") return Model::A;
  if (s == "B") return Model::B;
  if (s == "C") return Model::C;
  if (s == "D") return Model::D;
  if (s == "E") return Model::E;
  throw ClosureError("rough: unknown model '" + s + "' (expected A, B, C, D or E)");
}

Parameters parameters_of(const WaltonRestitution& law, double q, int dim) {
  Parameters p;
  p.e = law.e;
  p.beta0 = law.beta0;
  p.mu = std::isfinite(law.mu) ? law.mu : 1e300;
  p.q = q;
  p.dim = dim;
  return p;
}

void validate(const Parameters& p) {
  if (!(p.e >= 0.0 && p.e <= 1.0)) throw ClosureError("rough: restitution.e must be in [0, 1]");
  if (!(p.beta0 >= -1.0 && p.beta0 <= 1.0))
    throw ClosureError("rough: restitution.beta0 must be in [-1, 1]");
  if (!(p.mu >= 0.0)) throw ClosureError("rough: restitution.mu must be >= 0");
  if (!(p.q > 0.0)) throw ClosureError("rough: moment of inertia factor q must be > 0");
  if (!(p.G > 0.0)) throw ClosureError("rough: collision prefactor G must be > 0");
  if (!(p.H >= 0.0)) throw ClosureError("rough: driving power H must be >= 0");
  if (!(p.H_per_collision >= 0.0)) throw ClosureError("rough: driving per collision must be >= 0");
  if (p.dim != 2 && p.dim != 3) throw ClosureError("rough: dimension must be 2 or 3");
}

double collision_prefactor_2d(double phi, double sigma, double mass) {
  const double n = 4.0 * phi / (std::numbers::pi * sigma * sigma);
  const double chi = (1.0 - 7.0 * phi / 16.0) / ((1.0 - phi) * (1.0 - phi));
  return 2.0 * n * sigma * chi * std::sqrt(std::numbers::pi / mass);  // eq. R1
}

double collision_prefactor_3d(double phi, double sigma, double mass) {
  const double n = 6.0 * phi / (std::numbers::pi * sigma * sigma * sigma);
  const double chi = (1.0 - 0.5 * phi) / std::pow(1.0 - phi, 3);
  return 4.0 * n * sigma * sigma * chi * std::sqrt(std::numbers::pi / mass);  // eq. R1 (3D)
}

namespace {
// Prefactors of eq. R15: dTtr = H + c_tr nu [...], dTrot = c_rot nu [...], normal loss n0.
struct DimensionFactors {
  double c_tr, c_rot, n0;
};
DimensionFactors factors(const Parameters& p) {
  if (p.dim == 3) return {4.0 / 3.0, 4.0 / 3.0, 0.25 * (1.0 - p.e * p.e)};
  return {1.0, 2.0, 0.5 * (1.0 - p.e * p.e)};
}
Parameters unit_rates(const Parameters& p) {  // G = 1, H = 0: the collision part per nu
  Parameters u = p;
  u.G = 1.0;
  u.H = 0.0;
  u.H_per_collision = 0.0;
  return u;
}
double eta0_of(const Parameters& p) { return p.q * (1.0 + p.beta0) / (2.0 * (1.0 + p.q)); }
double eta_n_of(const Parameters& p) { return 0.5 * (1.0 + p.e); }
double k_of(const Parameters& p, double R) { return std::sqrt(1.0 + std::max(0.0, R) / p.q); }
}  // namespace

ImpactAverages impact_averages(const Parameters& p, double k) {
  const double eta0 = eta0_of(p);
  if (eta0 == 0.0) return {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};  // smooth: no tangential impulse
  // eq. R5: tan(gamma0) = mu eta_n / eta0, u0 = tan(gamma0) / k
  const double t0 = p.mu * eta_n_of(p) / eta0;
  const double u0 = t0 / k;
  // u0 > 1e8: the corrections to the no-sliding limit are O(1/u0^2), below round-off
  if (!(u0 <= 1e8)) return {u0, eta0, eta0 * eta0, eta0, eta0 * eta0, 0.0};
  if (u0 == 0.0) return {0.0, 0.0, 0.0, 0.0, 0.0, 1.0};  // mu = 0: always sliding, no impulse
  ImpactAverages a;
  a.u0 = u0;
  if (p.dim == 3) {  // eq. R16: angle densities 2u(1+u^2)^-2 and 4u^3(1+u^2)^-3 on u > 0
    const double w = 1.0 + u0 * u0;
    const double acot = std::atan2(1.0, u0);  // pi/2 - atan(u0)
    a.E1 = eta0 * u0 * u0 * u0 * u0 / (w * w) +
           0.5 * eta0 * u0 * (acot - u0 * (u0 * u0 - 1.0) / (w * w));
    a.E2 = eta0 * eta0 * u0 * u0 / w;
    a.P1 = eta0 * u0 * acot;
    a.P2 = eta0 * eta0 * u0 * u0 * std::log1p(1.0 / (u0 * u0));
    a.sliding_fraction = 1.0 / w;
    return a;
  }
  const double r = std::sqrt(1.0 + u0 * u0);
  a.E1 = eta0 * u0 / r;                                   // eq. R6
  a.E2 = 2.0 * eta0 * eta0 * u0 * u0 / (r * (r + u0));   // eq. R7: 2 eta0^2 u0^2 (1 - u0/r)
  // eq. R8: eta0 u0 artanh(s0), s0 = 1/r; artanh(s) = ln((1+s)/(1-s))/2 with 1 - s0 written
  // without cancellation
  const double s0 = 1.0 / r;
  const double one_minus_s0 = u0 * u0 / (r * (r + 1.0));
  a.P1 = eta0 * u0 * 0.5 * std::log((1.0 + s0) / one_minus_s0);
  a.P2 = 2.0 * eta0 * eta0 * u0 / (r + u0);  // eq. R9: 2 eta0^2 u0 (r - u0)
  a.sliding_fraction = 1.0 - u0 / r;        // eq. R10
  return a;
}

LinearCoefficients linear_coefficients(Model m, const Parameters& p, double R) {
  const double q = p.q;
  const double normal = factors(p).n0;
  auto from_eta = [&](double eta) {  // eq. R4 (model A with a constant eta)
    return LinearCoefficients{normal + eta * (1.0 - eta), eta * eta / q, eta * eta / q,
                              eta / q * (1.0 - eta / q)};
  };
  switch (m) {
    case Model::A: return from_eta(eta0_of(p));                     // eq. R4
    case Model::B: return from_eta(impact_averages(p, 1.0).P1);     // eq. R13a
    case Model::C: return from_eta(impact_averages(p, k_of(p, R)).P1);  // eq. R13b
    case Model::D: {                                                // eq. R14
      const ImpactAverages a = impact_averages(p, 1.0);
      return {normal + a.E1 - a.E2, a.P2 / q, a.E2 / q, a.P1 / q - a.P2 / (q * q)};
    }
    case Model::E: break;
  }
  throw ClosureError("rough: model E has no linear form (use rhs)");
}

Rates rhs(Model m, const Parameters& p, double Ttr, double Trot) {
  const double nu = p.G * std::sqrt(std::max(0.0, Ttr));  // eq. R1
  const DimensionFactors f = factors(p);                  // eq. R15
  if (m == Model::E) {                                    // eq. R2
    const double R = Ttr > 0.0 ? Trot / Ttr : 0.0;
    const ImpactAverages a = impact_averages(p, k_of(p, R));
    const double tang = Ttr + Trot / p.q;  // proportional to <g_t^2>, eq. R6
    return {p.H + p.H_per_collision * nu + f.c_tr * nu * (-f.n0 * Ttr - a.E1 * Ttr + a.E2 * tang),
            f.c_rot * nu / p.q * (-a.E1 * Trot + a.E2 * tang)};
  }
  const LinearCoefficients c =
      linear_coefficients(m, p, Ttr > 0.0 ? Trot / Ttr : 0.0);  // eq. R3
  return {p.H + p.H_per_collision * nu + f.c_tr * nu * (-c.A * Ttr + c.B * Trot),
          f.c_rot * nu * (c.Bp * Ttr - c.C * Trot)};
}

namespace {
// Rotational right-hand side per nu Ttr, as a function of R (eq. R11).
double rot_residual(Model m, const Parameters& p, double R) {
  return rhs(m, unit_rates(p), 1.0, R).dTrot;
}
}  // namespace

double steady_ratio(Model m, const Parameters& p) {
  validate(p);
  if (eta0_of(p) == 0.0 || p.mu == 0.0)
    throw ClosureError("rough: no steady Trot/Ttr for smooth grains (beta0 = -1 or mu = 0)");
  if (m == Model::A || m == Model::B || m == Model::D) {
    const LinearCoefficients c = linear_coefficients(m, p);
    return c.Bp / c.C;  // eq. R11, linear models
  }
  // f(0) > 0 (rotation is fed by translation); f -> -infinity for large R.
  double hi = 1.0;
  while (rot_residual(m, p, hi) > 0.0) {
    hi *= 2.0;
    if (hi > 1e12) throw ClosureError("rough: steady Trot/Ttr not bracketed");
  }
  return brent_root([&](double R) { return rot_residual(m, p, R); }, 0.0, hi, 1e-13,
                    "rough steady ratio");
}

SteadyState steady_state(Model m, const Parameters& p) {
  validate(p);
  if (!(p.H > 0.0) && !(p.H_per_collision > 0.0))
    throw ClosureError("rough: steady state needs driving H > 0 or H_per_collision > 0");
  const double R = steady_ratio(m, p);
  // dTtr/dt = H + H_nu G Ttr^{1/2} - G Ttr^{3/2} F(R) = 0 (eq. R12); F from the rhs at
  // Ttr = 1, H = H_nu = 0, G = 1. With s = Ttr^{1/2}: F s^3 - H_nu s - H/G = 0, one positive
  // root (one sign change); H_nu = 0 gives (H/(G F))^{2/3}, H = 0 gives H_nu / F.
  const double F = -rhs(m, unit_rates(p), 1.0, R).dTtr;
  if (!(F > 0.0)) throw ClosureError("rough: no dissipation, no steady state");
  const double hn = p.H_per_collision, h = p.H / p.G;
  double Ttr;
  if (hn == 0.0) {
    Ttr = std::pow(h / F, 2.0 / 3.0);
  } else if (h == 0.0) {
    Ttr = hn / F;
  } else {
    auto cubic = [&](double s) { return F * s * s * s - hn * s - h; };
    double hi = 1.0;
    while (cubic(hi) < 0.0) hi *= 2.0;
    const double s = brent_root(cubic, 0.0, hi, 1e-14, "rough steady temperature");
    Ttr = s * s;
  }
  return {Ttr, R * Ttr, R};
}

RelaxationRates relaxation_rates(Model m, const Parameters& p) {
  const SteadyState s = steady_state(m, p);
  // eq. R17: central differences of the rhs (smooth there: the closed forms are analytic in
  // Ttr, Trot > 0), step 1e-5 of the steady temperatures
  const double h1 = 1e-5 * s.Ttr, h2 = 1e-5 * std::max(s.Trot, 1e-3 * s.Ttr);
  const Rates a = rhs(m, p, s.Ttr + h1, s.Trot), b = rhs(m, p, s.Ttr - h1, s.Trot);
  const Rates c = rhs(m, p, s.Ttr, s.Trot + h2), d = rhs(m, p, s.Ttr, s.Trot - h2);
  const double J11 = (a.dTtr - b.dTtr) / (2 * h1), J21 = (a.dTrot - b.dTrot) / (2 * h1);
  const double J12 = (c.dTtr - d.dTtr) / (2 * h2), J22 = (c.dTrot - d.dTrot) / (2 * h2);
  const double tr = J11 + J22, det = J11 * J22 - J12 * J21;
  const double disc = 0.25 * tr * tr - det;
  if (disc < 0.0) throw ClosureError("rough: complex relaxation rates (oscillatory approach)");
  const double r = std::sqrt(disc);
  const double l1 = 0.5 * tr - r, l2 = 0.5 * tr + r;  // l1 <= l2
  if (!(l2 < 0.0)) throw ClosureError("rough: steady state is not linearly stable");
  return {-l1, -l2};
}

namespace {
struct OdeContext {
  Model m;
  const Parameters* p;
};
int ode_rhs(double, const double y[], double f[], void* params) {
  const auto* c = static_cast<const OdeContext*>(params);
  const Rates r = rhs(c->m, *c->p, y[0], y[1]);
  f[0] = r.dTtr;
  f[1] = r.dTrot;
  return GSL_SUCCESS;
}
}  // namespace

std::vector<Sample> integrate(Model m, const Parameters& p, double Ttr0, double Trot0,
                              const std::vector<double>& times) {
  validate(p);
  if (!(Ttr0 > 0.0) || !(Trot0 >= 0.0))
    throw ClosureError("rough: initial temperatures must be Ttr > 0, Trot >= 0");
  OdeContext ctx{m, &p};
  gsl_odeiv2_system sys{&ode_rhs, nullptr, 2, &ctx};
  const double nu0 = p.G * std::sqrt(Ttr0);
  std::unique_ptr<gsl_odeiv2_driver, decltype(&gsl_odeiv2_driver_free)> d(
      gsl_odeiv2_driver_alloc_standard_new(&sys, gsl_odeiv2_step_rk8pd, 1e-4 / nu0,
                                           1e-14 * Ttr0, 1e-10, 1.0, 1.0),
      &gsl_odeiv2_driver_free);
  double y[2] = {Ttr0, Trot0};
  double t = 0.0;
  std::vector<Sample> out;
  out.reserve(times.size());
  gsl_error_handler_t* old = gsl_set_error_handler_off();
  for (double ti : times) {
    if (!(ti >= t)) {
      gsl_set_error_handler(old);
      throw ClosureError("rough: requested times must be non-negative and non-decreasing");
    }
    if (ti > t) {
      const int status = gsl_odeiv2_driver_apply(d.get(), &t, ti, y);
      if (status != GSL_SUCCESS) {
        gsl_set_error_handler(old);
        std::ostringstream os;
        os << "rough(" << to_string(m) << "): integration failed at t = " << t << " ("
           << gsl_strerror(status) << ")";
        throw ClosureError(os.str());
      }
    }
    out.push_back({ti, y[0], y[1]});
  }
  gsl_set_error_handler(old);
  return out;
}

}  // namespace grainbath::closures::rough
