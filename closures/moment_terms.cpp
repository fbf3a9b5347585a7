// Closed collision terms of the local-Maxwellian and Grad closures.
// Every formula cites docs/closures.md; tests/closures/ checks each one against an
// independent quadrature or Monte Carlo of the collision rule.
#include <cmath>
#include <sstream>

#include "closures/closures.hpp"

namespace grainbath::closures {
namespace {
constexpr double kSqrt2OverPi = 0.79788456080286535588;  // sqrt(2/pi)
constexpr double kSqrtPi = 1.77245385090551602730;

double dot(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
std::array<double, 3> drift(const Parameters& p, const std::array<double, 3>& u) {
  return {u[0] - p.uB[0], u[1] - p.uB[1], u[2] - p.uB[2]};
}
void require_temperature(double T, const char* what) {
  if (!(T > 0.0) || !std::isfinite(T)) {
    std::ostringstream os;
    os << what << ": the grain temperature T must be finite and > 0 (got " << T << ")";
    throw ClosureError(os.str());
  }
}
}  // namespace

const char* to_string(Closure c) {
  switch (c) {
    case Closure::maxwellian: return "maxwellian";
    case Closure::grad: return "grad";
    case Closure::sonine: return "sonine";
  }
  return "?";
}

void validate(const Parameters& p) {
  auto fail = [](const std::string& s) { throw ClosureError(s); };
  auto finite_pos = [](double x) { return std::isfinite(x) && x > 0.0; };
  if (!(p.alpha > 0.0 && p.alpha < 1.0))
    fail("background.mass_ratio (alpha) must lie in the open interval (0, 1); got " +
         std::to_string(p.alpha));
  if (!finite_pos(p.mass)) fail("grains.mass (m) must be finite and > 0");
  if (!finite_pos(p.nB)) fail("background.density (nB) must be finite and > 0");
  if (!finite_pos(p.TB)) fail("background.temperature (TB) must be finite and > 0");
  if (!finite_pos(p.eps)) fail("background.knudsen (eps) must be finite and > 0");
  if (!finite_pos(p.n)) fail("grains.density (n) must be finite and > 0");
  if (!(std::isfinite(p.beta) && p.beta >= 0.0))
    fail("restitution.beta must be finite and >= 0; got " + std::to_string(p.beta));
  if (!(std::isfinite(p.delta) && p.delta >= 0.0))
    fail("restitution.delta must be finite and >= 0; got " + std::to_string(p.delta));
  for (double x : p.uB)
    if (!std::isfinite(x)) fail("background.velocity (uB) must be finite");
}

double background_mass(const Parameters& p) { return p.alpha * p.mass / (1.0 - p.alpha); }

double relative_speed_scale(const Parameters& p, double T) {
  // docs eq. C1: s^2 = T/m + TB/mB = (alpha T + (1-alpha) TB) / (alpha m)
  return std::sqrt((p.alpha * T + (1.0 - p.alpha) * p.TB) / (p.alpha * p.mass));
}

double pair_speed_moment(double y, double T, double m) {
  // g = v - w ~ N(0, 2T/m I):  <|g|^y> = (2T/m)^{y/2} E|z|^y  (Bisi-Spiga eq. 24)
  return std::pow(2.0 * T / m, 0.5 * y) * central_chi_moment(y);
}

// ------------------------------------------------------------------ Maxwellian ------------
Exchange maxwellian_exchange_exact(const Parameters& p, const std::array<double, 3>& u,
                                   double T) {
  require_temperature(T, "maxwellian_exchange_exact");
  const auto U = drift(p, u);
  const double s = relative_speed_scale(p, T);
  const double A = std::sqrt(dot(U, U)) / s;
  const RadialMoment m1 = noncentral_chi_moment(1, A);
  const RadialMoment m3 = noncentral_chi_moment(3, A);
  const double rate = p.nB / p.eps;
  // docs eq. C5: du/dt = -(nB/eps) alpha <|g| g> = -(nB/eps) alpha s (F1(A)/A) U,
  // F1(A)/A = m1 + m1'/A  (from E[|x| x] = a_hat (A m1 + m1'), docs eq. C4)
  const double friction = rate * p.alpha * s * (m1.value + m1.d1_over_A);
  Exchange e;
  for (int i = 0; i < 3; ++i) e.du_dt[i] = -friction * U[i];
  // docs eq. C6: dT/dt = (2/3)(nB/eps) m alpha s^3 [(alpha - tau) m3 + tau A F1],
  // tau = T/(m s^2), A F1 = A^2 (m1 + m1'/A)
  const double tau = T / (p.mass * s * s);
  const double AF1 = A * A * (m1.value + m1.d1_over_A);
  e.dT_dt = (2.0 / 3.0) * rate * p.mass * p.alpha * s * s * s *
            ((p.alpha - tau) * m3.value + tau * AF1);
  return e;
}

Exchange maxwellian_exchange_truncated(const Parameters& p, const std::array<double, 3>& u,
                                       double T) {
  require_temperature(T, "maxwellian_exchange_truncated");
  const auto U = drift(p, u);
  const double s = relative_speed_scale(p, T);
  const double U2 = dot(U, U);
  const double rate = p.nB / p.eps;
  const double tau = T / (p.mass * s * s);  // = alpha T / ((1-alpha) TB + alpha T)
  Exchange e;
  // docs eq. C7 (printed eq. 26, momentum): -(4 alpha/3) sqrt(2/pi) (nB/eps)/s [2 s^2 + U^2/5] U
  const double friction = (4.0 * p.alpha / 3.0) * kSqrt2OverPi * rate / s * (2.0 * s * s + U2 / 5.0);
  for (int i = 0; i < 3; ++i) e.du_dt[i] = -friction * U[i];
  // docs eq. C8 (printed eq. 26, energy):
  // (2/3) alpha m sqrt(2/pi) (nB/eps)/s { (1/5)[alpha + tau/3] U^4 + 4 [alpha - tau/3] s^2 U^2
  //                                      + 8 [alpha - tau] s^4 }
  const double s2 = s * s;
  e.dT_dt = (2.0 / 3.0) * p.alpha * p.mass * kSqrt2OverPi * rate / s *
            ((p.alpha + tau / 3.0) * U2 * U2 / 5.0 + 4.0 * (p.alpha - tau / 3.0) * s2 * U2 +
             8.0 * (p.alpha - tau) * s2 * s2);
  return e;
}

double maxwellian_loss(const Parameters& p, double T) {
  require_temperature(T, "maxwellian_loss");
  if (p.beta == 0.0) return 0.0;
  // Bisi-Spiga eq. 25 / docs eq. C10:
  // dT/dt = -(16/(3 sqrt pi)) m n beta [2^d G(d/2+2) (T/m)^{(d+3)/2}
  //                                     - beta 2^{2d} G(d+2) (T/m)^{(2d+3)/2}]
  const double d = p.delta, th = T / p.mass;
  const double first = std::pow(2.0, d) * std::tgamma(0.5 * d + 2.0) * std::pow(th, 0.5 * (d + 3.0));
  const double second =
      p.beta * std::pow(2.0, 2.0 * d) * std::tgamma(d + 2.0) * std::pow(th, 0.5 * (2.0 * d + 3.0));
  return -(16.0 / (3.0 * kSqrtPi)) * p.mass * p.n * p.beta * (first - second);
}

double negative_restitution_probability(const Parameters& p, double T) {
  if (p.beta == 0.0) return 0.0;
  if (p.delta == 0.0) return (2.0 * p.beta > 1.0) ? 1.0 : 0.0;
  // docs eq. C12: among collisions (weight |g.n|) of Maxwellian grains the normal relative
  // speed q has density (m/2T) q exp(-m q^2 / 4T); e < 0 iff q > q* = (2 beta)^{-1/delta}.
  const double qstar = std::pow(2.0 * p.beta, -1.0 / p.delta);
  return std::exp(-qstar * qstar * p.mass / (4.0 * T));
}

MomentSources maxwellian_sources(const Parameters& p, const RelaxationState& st) {
  const Exchange e = maxwellian_exchange_exact(p, st.u, st.T);
  MomentSources m;
  m.du_dt = e.du_dt;
  m.dT_dt = e.dT_dt + maxwellian_loss(p, st.T);
  return m;
}

// ------------------------------------------------------------------ Grad ------------------
double grad_kappa(const Parameters& p, const std::array<double, 3>& u, double T) {
  const auto U = drift(p, u);
  // docs eq. G2: kappa = (3 (T - TB)/m + U^2) / (6 TB/m)
  return (3.0 * (T - p.TB) / p.mass + dot(U, U)) / (6.0 * p.TB / p.mass);
}

GradStreaming grad_streaming(const Parameters& p, const std::array<double, 3>& u, double T) {
  const auto U = drift(p, u);
  const double U2 = dot(U, U);
  GradStreaming g{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j)  // docs eq. G4
      g.pressure[i][j] = p.n * p.mass * ((i == j ? U2 / 3.0 : 0.0) - U[i] * U[j]) +
                         (i == j ? p.n * T : 0.0);
    g.heat_flux[i] = 0.5 * p.n * (5.0 * (p.TB - T) + p.mass * U2 / 3.0) * U[i];  // docs eq. G5
  }
  return g;
}

Exchange grad_exchange(const Parameters& p, const std::array<double, 3>& u, double T) {
  require_temperature(T, "grad_exchange");
  const auto U = drift(p, u);
  const double s0 = relative_speed_scale(p, p.TB);  // s at T = TB: sqrt(TB/(alpha m))
  const double rate = p.nB / p.eps;
  Exchange e;
  // docs eq. G7: du/dt = -(8/3) sqrt(2/pi) alpha (nB/eps) s0 U  (exactly linear in U)
  const double friction = (8.0 / 3.0) * kSqrt2OverPi * p.alpha * rate * s0;
  for (int i = 0; i < 3; ++i) e.du_dt[i] = -friction * U[i];
  // docs eq. G8: dT/dt = (16/3) sqrt(2/pi) alpha (nB/eps) s0 [(1-alpha)(TB-T) + alpha m U^2/3]
  e.dT_dt = (16.0 / 3.0) * kSqrt2OverPi * p.alpha * rate * s0 *
            ((1.0 - p.alpha) * (p.TB - T) + p.alpha * p.mass * dot(U, U) / 3.0);
  return e;
}

double grad_loss(const Parameters& p, const std::array<double, 3>& u, double T) {
  require_temperature(T, "grad_loss");
  if (p.beta == 0.0) return 0.0;
  const double kappa = grad_kappa(p, u, T);
  const double x = (T - p.TB) / (2.0 * p.TB);
  // docs eq. G9: <|g|^y>_Grad = E_y(TB) [1 + y x + kappa^2 y (y-2)/4],  x = (T-TB)/(2TB)
  auto pair = [&](double y) {
    return pair_speed_moment(y, p.TB, p.mass) * (1.0 + y * x + kappa * kappa * y * (y - 2.0) / 4.0);
  };
  const double d = p.delta;
  // docs eq. G10 (Bisi-Spiga eq. 18, last line):
  // dT/dt = -(2/3) m n [beta/(4+d) <g^{d+3}> - beta^2/(4+2d) <g^{2d+3}>]
  return -(2.0 / 3.0) * p.mass * p.n *
         (p.beta / (4.0 + d) * pair(d + 3.0) - p.beta * p.beta / (4.0 + 2.0 * d) * pair(2.0 * d + 3.0));
}

MomentSources grad_sources(const Parameters& p, const RelaxationState& st) {
  const Exchange e = grad_exchange(p, st.u, st.T);
  MomentSources m;
  m.du_dt = e.du_dt;
  m.dT_dt = e.dT_dt + grad_loss(p, st.u, st.T);
  return m;
}

MomentSources sources(Closure c, const Parameters& p, const RelaxationState& st) {
  switch (c) {
    case Closure::maxwellian: return maxwellian_sources(p, st);
    case Closure::grad: return grad_sources(p, st);
    case Closure::sonine: return sonine_sources(p, st);
  }
  throw ClosureError("sources: unknown closure");
}

}  // namespace grainbath::closures
