// Homogeneous relaxation ODEs of the closed moment systems (GSL odeiv2 with error control).
#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>

#include <cmath>
#include <memory>
#include <sstream>

#include "closures/closures.hpp"
#include "closures/root_finding.hpp"

namespace grainbath::closures {
namespace {
struct OdeContext {
  Closure closure;
  const Parameters* p;
  std::string failure;
};

int rhs(double, const double y[], double dydt[], void* params);

// Forward-difference Jacobian for the stiff (BDF) integration of the Sonine system, whose
// right-hand side is a quadrature (no closed-form derivative). Steps are relative to the
// natural scale of each variable.
int jacobian(double t, const double y[], double* dfdy, double dfdt[], void* params) {
  auto* ctx = static_cast<OdeContext*>(params);
  const int dim = ctx->closure == Closure::sonine ? 5 : 4;
  double f0[5], f1[5], yp[5];
  if (int st = rhs(t, y, f0, params); st != GSL_SUCCESS) return st;
  const double uscale = std::sqrt(std::max(y[3], ctx->p->TB) / ctx->p->mass);
  for (int j = 0; j < dim; ++j) {
    for (int i = 0; i < dim; ++i) yp[i] = y[i];
    const double scale = j < 3 ? uscale : (j == 3 ? y[3] : 0.1);
    const double h = 1e-7 * std::max(std::abs(y[j]), scale);
    yp[j] = y[j] + h;
    if (int st = rhs(t, yp, f1, params); st != GSL_SUCCESS) return st;
    for (int i = 0; i < dim; ++i) dfdy[i * dim + j] = (f1[i] - f0[i]) / h;
  }
  for (int i = 0; i < dim; ++i) dfdt[i] = 0.0;  // autonomous
  return GSL_SUCCESS;
}

int rhs(double, const double y[], double dydt[], void* params) {
  auto* ctx = static_cast<OdeContext*>(params);
  if (!(y[3] > 0.0) || !std::isfinite(y[3])) return GSL_EBADFUNC;
  try {
    const RelaxationState st{{y[0], y[1], y[2]}, y[3], ctx->closure == Closure::sonine ? y[4] : 0.0};
    const MomentSources m = sources(ctx->closure, *ctx->p, st);
    for (int i = 0; i < 3; ++i) dydt[i] = m.du_dt[i];
    dydt[3] = m.dT_dt;
    if (ctx->closure == Closure::sonine) dydt[4] = m.da2_dt;
  } catch (const std::exception& e) {
    ctx->failure = e.what();
    return GSL_EBADFUNC;
  }
  return GSL_SUCCESS;
}
}  // namespace

std::vector<RelaxationState> relax(Closure c, const Parameters& p, const RelaxationState& initial,
                                   const std::vector<double>& times) {
  // The Sonine right-hand side is a quadrature (~1 ms): integrate it with the stiff BDF method
  // (few steps once near equilibrium, where an explicit method is held to ~eps/nB steps);
  // the closed-form systems are cheap and integrated with explicit rk8pd.
  return relax_integrator(c, p, initial, times, c == Closure::sonine);
}

std::vector<RelaxationState> relax_integrator(Closure c, const Parameters& p,
                                              const RelaxationState& initial,
                                              const std::vector<double>& times, bool stiff) {
  validate(p);
  if (!(initial.T > 0.0)) throw ClosureError("relax: the initial grain temperature must be > 0");
  // The unclamped power law must stay e >= 0 at the hottest temperature of the relaxation
  // (the initial one, or TB which it approaches).
  check_restitution(p, std::max(initial.T, p.TB));
  const size_t dim = (c == Closure::sonine) ? 5 : 4;
  OdeContext ctx{c, &p, {}};
  gsl_odeiv2_system sys{&rhs, &jacobian, dim, &ctx};
  // Fastest rate in the system: the background collision frequency (nB/eps) alpha s; start
  // the step well below it and let the rk8pd error control take over.
  const double s = relative_speed_scale(p, std::max(initial.T, p.TB));
  const double fast = p.nB / p.eps * 4.0 * s + p.n * 4.0 * std::sqrt(initial.T / p.mass);
  std::unique_ptr<gsl_odeiv2_driver, decltype(&gsl_odeiv2_driver_free)> d(
      gsl_odeiv2_driver_alloc_standard_new(&sys, stiff ? gsl_odeiv2_step_msbdf : gsl_odeiv2_step_rk8pd,
                                           1e-3 / fast, 1e-12 * p.TB, stiff ? 1e-9 : 1e-10, 1.0, 1.0),
      &gsl_odeiv2_driver_free);
  double y[5] = {initial.u[0], initial.u[1], initial.u[2], initial.T, initial.a2};
  double t = 0.0;
  std::vector<RelaxationState> out;
  out.reserve(times.size());
  gsl_error_handler_t* old = gsl_set_error_handler_off();
  for (double ti : times) {
    if (!(ti >= t)) {
      gsl_set_error_handler(old);
      throw ClosureError("relax: requested times must be non-negative and non-decreasing");
    }
    if (ti > t) {
      const int status = gsl_odeiv2_driver_apply(d.get(), &t, ti, y);
      if (status != GSL_SUCCESS) {
        gsl_set_error_handler(old);
        std::ostringstream os;
        os << "relax(" << to_string(c) << "): integration failed at t = " << t << " ("
           << (ctx.failure.empty() ? gsl_strerror(status) : ctx.failure) << ")";
        throw ClosureError(os.str());
      }
    }
    out.push_back({{y[0], y[1], y[2]}, y[3], c == Closure::sonine ? y[4] : 0.0});
  }
  gsl_set_error_handler(old);
  return out;
}

}  // namespace grainbath::closures
