// hydro/closure1d.cpp -- 1D IMEX finite-volume solvers of the closed (n, u, T) systems and the
// linearised density-mode eigenproblems (docs/hydro.md sec. 4, eqs. H19-H24). Collision sources
// and Grad streaming moments come from closures/ (closures::sources, closures::grad_streaming).
#include "hydro/closure1d.hpp"

#include "hydro/transport.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace grainbath::hydro {
namespace {

using closures::Closure;

void check_closure(Closure c) {
  if (c != Closure::maxwellian && c != Closure::grad)
    throw std::invalid_argument("The 1D closure solver and mode problem support the maxwellian and grad closures (the (n, u, T) systems) only.");
}

// Streaming flux along x of the closed system in conservative variables (n, n u, E), velocities
// along x only (docs/hydro.md eq. H19):
//   F = (n u, n u^2 + P_xx/m, u (E + P_xx/m) + q_x/m),  E = n u^2/2 + 3 n T/(2 m).
// Maxwellian: P = n T I, q = 0 (Bisi-Spiga eq. 22); Grad: closures::grad_streaming.
std::array<double, 3> streaming_flux(Closure closure, const closures::Parameters& prm,
                                     const Primitive1D& w) {
  const double m = prm.mass;
  double Pxx = w.n * w.T, qx = 0.0;
  if (closure == Closure::grad) {
    closures::Parameters p = prm;
    p.n = w.n;
    const auto gs = closures::grad_streaming(p, {w.u, 0.0, 0.0}, w.T);
    Pxx = gs.pressure[0][0];
    qx = gs.heat_flux[0];
  }
  const double E = 0.5 * w.n * w.u * w.u + 1.5 * w.n * w.T / m;
  return {w.n * w.u, w.n * w.u * w.u + Pxx / m, w.u * (E + Pxx / m) + qx / m};
}

std::array<double, 3> prim_to_cons(const Primitive1D& w, double m) {
  return {w.n, w.n * w.u, 0.5 * w.n * w.u * w.u + 1.5 * w.n * w.T / m};
}
Primitive1D cons_to_prim(const std::array<double, 3>& U, double m) {
  Primitive1D w;
  w.n = U[0];
  w.u = U[1] / U[0];
  w.T = (U[2] / U[0] - 0.5 * w.u * w.u) * (2.0 * m / 3.0);
  return w;
}

// Collision sources (du/dt, dT/dt) along x from closures/ (the 1/eps included).
std::array<double, 2> collision_rates(Closure closure, closures::Parameters prm,
                                      const Primitive1D& w) {
  prm.n = w.n;
  const closures::RelaxationState s{{w.u, 0.0, 0.0}, w.T, 0.0};
  const closures::MomentSources S = closures::sources(closure, prm, s);
  return {S.du_dt[0], S.dT_dt};
}

// Quasi-linear matrix B = (dU/dW)^{-1} dF/dW in primitive variables W = (n, u, T), by central
// differences of the flux (consistent with the solver's flux by construction).
Eigen::Matrix3d primitive_flux_matrix(Closure closure, const closures::Parameters& prm,
                                      const Primitive1D& w) {
  const double m = prm.mass;
  const double hs[3] = {1e-6 * w.n, 1e-6 * std::sqrt(w.T / m) + 1e-6 * std::abs(w.u), 1e-6 * w.T};
  Eigen::Matrix3d dF, dU;
  for (int j = 0; j < 3; ++j) {
    Primitive1D a = w, b = w;
    double* pa = j == 0 ? &a.n : j == 1 ? &a.u : &a.T;
    double* pb = j == 0 ? &b.n : j == 1 ? &b.u : &b.T;
    *pa += hs[j];
    *pb -= hs[j];
    const auto Fa = streaming_flux(closure, prm, a), Fb = streaming_flux(closure, prm, b);
    const auto Ua = prim_to_cons(a, m), Ub = prim_to_cons(b, m);
    for (int i = 0; i < 3; ++i) {
      dF(i, j) = (Fa[i] - Fb[i]) / (2.0 * hs[j]);
      dU(i, j) = (Ua[i] - Ub[i]) / (2.0 * hs[j]);
    }
  }
  return dU.inverse() * dF;
}

double spectral_radius(const Eigen::Matrix3d& B) {
  Eigen::EigenSolver<Eigen::Matrix3d> es(B, false);
  double r = 0.0;
  for (int i = 0; i < 3; ++i) r = std::max(r, std::abs(es.eigenvalues()(i)));
  return r;
}

double limited_slope(Limiter lim, double dl, double dr) {
  switch (lim) {
    case Limiter::None:
      return 0.5 * (dl + dr);
    case Limiter::Minmod:
      if (dl * dr <= 0.0) return 0.0;
      return std::abs(dl) < std::abs(dr) ? dl : dr;
    case Limiter::MonotonizedCentral: {
      if (dl * dr <= 0.0) return 0.0;
      const double s = dl > 0 ? 1.0 : -1.0;
      return s * std::min({2.0 * std::abs(dl), 2.0 * std::abs(dr), 0.5 * std::abs(dl + dr)});
    }
  }
  return 0.0;
}

}  // namespace

// ------------------------------------------------------------------------------- solver
Closure1DSolver::Closure1DSolver(const Closure1DConfig& cfg, const Background& bg, double n_ref)
    : cfg_(cfg), bg_(bg) {
  check_closure(cfg.closure);
  bg_.validate();
  if (bg_.grid.dim != 1) throw std::invalid_argument("The closure solver is one-dimensional: give a 1D grid.");
  if (bg_.grid.n[0] < 3) throw std::invalid_argument("The closure solver needs at least 3 cells.");
  if (!(cfg.cfl > 0.0 && cfg.cfl <= 1.0)) throw std::invalid_argument("The CFL number must lie in (0, 1].");
  closures::validate(params(0, n_ref));
  U_.resize(bg_.grid.size());
  set_equilibrium(std::vector<double>(bg_.grid.size(), n_ref));
}

closures::Parameters Closure1DSolver::params(std::size_t c, double n) const {
  closures::Parameters p{};
  p.alpha = cfg_.alpha;
  p.mass = cfg_.mass;
  p.nB = bg_.nB[c];
  p.TB = bg_.TB[c];
  p.uB = {bg_.uB[0][c], 0.0, 0.0};
  p.eps = cfg_.eps;
  p.n = n;
  p.beta = cfg_.beta;
  p.delta = cfg_.delta;
  return p;
}

Primitive1D Closure1DSolver::to_prim(const State& s) const { return cons_to_prim(s, cfg_.mass); }
Closure1DSolver::State Closure1DSolver::to_cons(const Primitive1D& p) const { return prim_to_cons(p, cfg_.mass); }

std::array<double, 3> Closure1DSolver::physical_flux(const Primitive1D& p, std::size_t c) const {
  return streaming_flux(cfg_.closure, params(c, p.n), p);
}

std::array<double, 2> Closure1DSolver::source(const Primitive1D& p, std::size_t c) const {
  const auto r = collision_rates(cfg_.closure, params(c, p.n), p);
  // d(n u)/dt = n du/dt; dE/dt = n u du/dt + 3 n/(2 m) dT/dt (dn/dt = 0).
  return {p.n * r[0], p.n * p.u * r[0] + 1.5 * p.n / cfg_.mass * r[1]};
}

double Closure1DSolver::wave_speed(const Primitive1D& p, std::size_t c) const {
  if (cfg_.closure == Closure::maxwellian)  // Euler: |u| + sqrt(5 T/(3 m))
    return std::abs(p.u) + std::sqrt(5.0 * p.T / (3.0 * cfg_.mass));
  return spectral_radius(primitive_flux_matrix(cfg_.closure, params(c, p.n), p));
}

void Closure1DSolver::set_state(const std::vector<Primitive1D>& prim) {
  if (prim.size() != bg_.grid.size()) throw std::invalid_argument("The closure state needs one value per cell.");
  for (std::size_t i = 0; i < prim.size(); ++i) {
    if (!(prim[i].n > 0.0) || !(prim[i].T > 0.0))
      throw std::invalid_argument("The closure state needs positive n and T in every cell.");
    U_[i] = to_cons(prim[i]);
  }
}

std::vector<Primitive1D> Closure1DSolver::primitive() const {
  std::vector<Primitive1D> out(U_.size());
  for (std::size_t i = 0; i < U_.size(); ++i) out[i] = to_prim(U_[i]);
  return out;
}

void Closure1DSolver::set_equilibrium(const std::vector<double>& n) {
  if (n.size() != bg_.grid.size()) throw std::invalid_argument("The density needs one value per cell.");
  for (std::size_t i = 0; i < n.size(); ++i) {
    const closures::Parameters p = params(i, n[i]);
    const double T = closures::equilibrium_temperature(cfg_.closure, p);
    U_[i] = to_cons({n[i], bg_.uB[0][i], T});
  }
}

double Closure1DSolver::mass() const {
  long double s = 0.0L;
  for (const State& u : U_) s += u[0];
  return static_cast<double>(s) * bg_.grid.h(0);
}

double Closure1DSolver::max_stable_dt() const {
  double smax = 0.0;
  for (std::size_t i = 0; i < U_.size(); ++i) smax = std::max(smax, wave_speed(to_prim(U_[i]), i));
  return cfg_.cfl * bg_.grid.h(0) / smax;
}

// -d/dx F by MUSCL (limited slopes of n, u, T) + Rusanov fluxes; reflecting walls mirror the
// face state (u -> 2 uB - u), which makes the wall mass flux exactly zero (eq. H20).
std::vector<Closure1DSolver::State> Closure1DSolver::flux_divergence(const std::vector<State>& U) const {
  const int N = bg_.grid.n[0];
  const bool periodic = bg_.grid.bc[0] == Boundary::Periodic;
  std::vector<Primitive1D> w(N);
  for (int i = 0; i < N; ++i) w[i] = to_prim(U[i]);
  for (int i = 0; i < N; ++i)
    if (!(w[i].n > 0.0) || !(w[i].T > 0.0) || !std::isfinite(w[i].u)) {
      std::ostringstream os;
      os << "The closure solver lost positivity in cell " << i << " (n = " << w[i].n << ", T = " << w[i].T
         << "); reduce the time step or the CFL number.";
      throw std::runtime_error(os.str());
    }
  auto nb = [&](int i) -> Primitive1D {  // neighbour with ghost cells
    if (i >= 0 && i < N) return w[i];
    if (periodic) return w[(i + N) % N];
    const int j = i < 0 ? -1 - i : 2 * N - 1 - i;  // mirror cell
    Primitive1D g = w[j];
    g.u = 2.0 * bg_.uB[0][j] - g.u;
    return g;
  };
  // Face states: left (from cell i, right face) and right (from cell i+1, left face).
  std::vector<Primitive1D> wl(N), wr(N);  // per cell: value at its left and right faces
  for (int i = 0; i < N; ++i) {
    const Primitive1D a = nb(i - 1), b = w[i], c = nb(i + 1);
    const double sn = limited_slope(cfg_.limiter, b.n - a.n, c.n - b.n);
    const double su = limited_slope(cfg_.limiter, b.u - a.u, c.u - b.u);
    const double sT = limited_slope(cfg_.limiter, b.T - a.T, c.T - b.T);
    wl[i] = {b.n - 0.5 * sn, b.u - 0.5 * su, b.T - 0.5 * sT};
    wr[i] = {b.n + 0.5 * sn, b.u + 0.5 * su, b.T + 0.5 * sT};
    // Positivity fallback: first order in this cell if a face value is unphysical.
    if (wl[i].n <= 0 || wr[i].n <= 0 || wl[i].T <= 0 || wr[i].T <= 0) wl[i] = wr[i] = b;
  }
  std::vector<std::array<double, 3>> F(N + 1);  // F[f]: face f between cells f-1 and f
  for (int f = 0; f <= N; ++f) {
    int iL = f - 1, iR = f;
    Primitive1D L, R;
    std::size_t cL, cR;
    if (f == 0 || f == N) {
      if (periodic) {
        iL = N - 1;
        iR = 0;
        L = wr[iL];
        R = wl[iR];
        cL = iL;
        cR = iR;
      } else if (f == 0) {
        R = wl[0];
        L = R;
        L.u = 2.0 * bg_.uB[0][0] - R.u;
        cL = cR = 0;
      } else {
        L = wr[N - 1];
        R = L;
        R.u = 2.0 * bg_.uB[0][N - 1] - L.u;
        cL = cR = N - 1;
      }
    } else {
      L = wr[iL];
      R = wl[iR];
      cL = iL;
      cR = iR;
    }
    const auto FL = physical_flux(L, cL), FR = physical_flux(R, cR);
    const auto UL = to_cons(L), UR = to_cons(R);
    const double a = std::max(wave_speed(L, cL), wave_speed(R, cR));
    for (int k = 0; k < 3; ++k) F[f][k] = 0.5 * (FL[k] + FR[k]) - 0.5 * a * (UR[k] - UL[k]);
    if (!periodic && (f == 0 || f == N)) F[f][0] = 0.0;  // exact zero mass flux at a wall
  }
  if (periodic) F[N] = F[0];
  std::vector<State> out(N);
  const double h = bg_.grid.h(0);
  for (int i = 0; i < N; ++i)
    for (int k = 0; k < 3; ++k) out[i][k] = -(F[i + 1][k] - F[i][k]) / h;
  return out;
}

// Per cell: solve U = R + gdt S(U) for (u, T) at fixed n (Newton with a finite-difference
// Jacobian, damped to keep T > 0). The stiff 1/eps rates make this the asymptotic-preserving
// step: as gdt/eps -> infinity its solution is u = uB, T = T#.
void Closure1DSolver::implicit_source(std::vector<State>& U, double gdt) const {
  const double m = cfg_.mass;
  for (std::size_t c = 0; c < U.size(); ++c) {
    const State R = U[c];
    const double n = R[0];
    const double r1 = R[1] / n, r2 = R[2] / n;
    Primitive1D w = to_prim(R);
    if (!(w.T > 0.0)) w.T = bg_.TB[c];
    auto resid = [&](const Primitive1D& x) {
      const auto s = source(x, c);  // (n du/dt, dE/dt)
      return Eigen::Vector2d(x.u - r1 - gdt * s[0] / n,
                             0.5 * x.u * x.u + 1.5 * x.T / m - r2 - gdt * s[1] / n);
    };
    Eigen::Vector2d G = resid(w);
    bool ok = false;
    for (int it = 0; it < 60; ++it) {
      const double hu = 1e-7 * (std::sqrt(w.T / m) + std::abs(w.u)), hT = 1e-7 * w.T;
      Eigen::Matrix2d J;
      Primitive1D a = w;
      a.u += hu;
      J.col(0) = (resid(a) - G) / hu;
      a = w;
      a.T += hT;
      J.col(1) = (resid(a) - G) / hT;
      const Eigen::Vector2d d = J.partialPivLu().solve(-G);
      double lam = 1.0;
      Primitive1D x = w;
      Eigen::Vector2d Gx = G;
      for (int ls = 0; ls < 30; ++ls) {
        x = w;
        x.u += lam * d(0);
        x.T += lam * d(1);
        if (x.T > 0.0) {
          Gx = resid(x);
          if (Gx.norm() < (1.0 - 1e-4 * lam) * G.norm() || G.norm() < 1e-300) break;
        }
        lam *= 0.5;
      }
      const bool small = std::abs(lam * d(0)) <= 1e-13 * (std::sqrt(w.T / m) + std::abs(w.u)) &&
                         std::abs(lam * d(1)) <= 1e-13 * w.T;
      w = x;
      G = Gx;
      if (small || G.norm() < 1e-14 * (1.0 + std::abs(r2))) {
        ok = true;
        break;
      }
    }
    if (!ok) {
      std::ostringstream os;
      os << "The implicit collision-source solve did not converge in cell " << c << ".";
      throw std::runtime_error(os.str());
    }
    U[c] = to_cons(w);
  }
}

// IMEX ARS(2,2,2) (Ascher, Ruuth & Spiteri 1997), docs/hydro.md eq. H21: explicit fluxes,
// implicit sources; globally stiffly accurate (U^{n+1} = last stage).
void Closure1DSolver::step(double dt) {
  if (!(dt > 0.0)) throw std::invalid_argument("The time step must be positive.");
  const double g = 1.0 - 1.0 / std::sqrt(2.0);
  const double d = 1.0 - 1.0 / (2.0 * g);
  const std::size_t N = U_.size();
  const std::vector<State> U0 = U_;
  const auto K1 = flux_divergence(U0);
  std::vector<State> U2(N), S2(N), U3(N);
  for (std::size_t i = 0; i < N; ++i)
    for (int k = 0; k < 3; ++k) U2[i][k] = U0[i][k] + dt * g * K1[i][k];
  const std::vector<State> R2 = U2;
  implicit_source(U2, g * dt);
  for (std::size_t i = 0; i < N; ++i)
    for (int k = 0; k < 3; ++k) S2[i][k] = (U2[i][k] - R2[i][k]) / (g * dt);
  const auto K2 = flux_divergence(U2);
  for (std::size_t i = 0; i < N; ++i)
    for (int k = 0; k < 3; ++k)
      U3[i][k] = U0[i][k] + dt * (d * K1[i][k] + (1.0 - d) * K2[i][k]) + dt * (1.0 - g) * S2[i][k];
  implicit_source(U3, g * dt);
  U_ = U3;
  t_ += dt;
}

void Closure1DSolver::run_to(double t_end, double max_dt) {
  if (!(max_dt > 0.0)) throw std::invalid_argument("run_to needs a positive max_dt.");
  while (t_ < t_end - 1e-14 * std::max(1.0, std::abs(t_end))) {
    const double dt = std::min({max_dt, max_stable_dt(), t_end - t_});
    step(dt);
  }
  t_ = std::max(t_, t_end);
}

// ------------------------------------------------------------------------------- modes
std::array<std::complex<double>, 3> closure_mode_eigenvalues(Closure closure, const ModeParams& p,
                                                             double k) {
  check_closure(closure);
  if (!(k >= 0.0) || !std::isfinite(k)) throw std::invalid_argument("The mode wavenumber k must be finite and non-negative.");
  closures::Parameters prm{};
  prm.alpha = p.alpha;
  prm.mass = p.mass;
  prm.nB = p.nB;
  prm.TB = p.TB;
  prm.uB = {0.0, 0.0, 0.0};  // Galilean invariance: a uniform uB only shifts Im(lambda)
  prm.eps = p.eps;
  prm.n = p.n;
  prm.beta = p.beta;
  prm.delta = p.delta;
  closures::validate(prm);
  const double Teq = closures::equilibrium_temperature(closure, prm);
  const Primitive1D w0{p.n, 0.0, Teq};
  const double m = p.mass;
  // Linearised collision sources in primitive variables: dW/dt|coll = C dW, by central
  // differences of closures::sources about the equilibrium (eq. H23).
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  const double hs[3] = {1e-5 * w0.n, 1e-5 * std::sqrt(Teq / m), 1e-5 * Teq};
  for (int j = 0; j < 3; ++j) {
    Primitive1D a = w0, b = w0;
    double* pa = j == 0 ? &a.n : j == 1 ? &a.u : &a.T;
    double* pb = j == 0 ? &b.n : j == 1 ? &b.u : &b.T;
    *pa += hs[j];
    *pb -= hs[j];
    const auto ra = collision_rates(closure, prm, a), rb = collision_rates(closure, prm, b);
    C(1, j) = (ra[0] - rb[0]) / (2.0 * hs[j]);
    C(2, j) = (ra[1] - rb[1]) / (2.0 * hs[j]);
  }
  const Eigen::Matrix3d B = primitive_flux_matrix(closure, prm, w0);
  // lambda dW = (-i k B + C) dW   (eq. H24)
  const Eigen::Matrix3cd M = std::complex<double>(0.0, -k) * B.cast<std::complex<double>>() +
                             C.cast<std::complex<double>>();
  Eigen::ComplexEigenSolver<Eigen::Matrix3cd> es(M);
  if (es.info() != Eigen::Success) throw std::runtime_error("The closure mode eigenproblem failed.");
  std::array<std::complex<double>, 3> out;
  for (int i = 0; i < 3; ++i) out[i] = es.eigenvalues()(i);
  std::sort(out.begin(), out.end(), [](auto a, auto b) { return a.real() > b.real(); });
  return out;
}

const char* to_string(ModeModel m) {
  switch (m) {
    case ModeModel::paper: return "paper";
    case ModeModel::kinetic: return "kinetic";
    case ModeModel::maxwellian_closure: return "maxwellian_closure";
    case ModeModel::grad_closure: return "grad_closure";
  }
  return "?";
}

double mode_decay_rate(ModeModel model, const ModeParams& p, double k) {
  switch (model) {
    case ModeModel::paper:
      return diffusion_coefficient_paper(p.alpha, p.mass, p.nB, p.TB, p.eps) * k * k;
    case ModeModel::kinetic:
      return diffusion_coefficient_kinetic(p.alpha, p.mass, p.nB, p.TB, p.eps) * k * k;
    case ModeModel::maxwellian_closure:
    case ModeModel::grad_closure: {
      const auto ev = closure_mode_eigenvalues(
          model == ModeModel::grad_closure ? Closure::grad : Closure::maxwellian, p, k);
      return -ev[0].real();  // sorted: largest real part = slowest decay
    }
  }
  throw std::invalid_argument("Unknown mode model.");
}

}  // namespace grainbath::hydro
