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
  if (c != Closure::maxwellian && c != Closure::grad && c != Closure::sonine)
    throw std::invalid_argument("Unknown closure: the 1D solver and mode problem support maxwellian, grad and sonine.");
}

using Vec4 = std::array<double, 4>;

// Streaming flux along x of the closed system in conservative variables (n, n u, E, n a2),
// velocities along x only (docs/hydro.md eqs. H19, H19b):
//   F = (n u, n u^2 + P_xx/m, u (E + P_xx/m) + q_x/m, n u a2),  E = n u^2/2 + 3 n T/(2 m).
// Maxwellian and Sonine: P = n T I, q = 0 (Bisi-Spiga eq. 22; the Sonine ansatz is isotropic
// about u, so a2 is merely advected, eq. H19b); Grad: closures::grad_streaming.
Vec4 streaming_flux(Closure closure, const closures::Parameters& prm, const Primitive1D& w) {
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
  return {w.n * w.u, w.n * w.u * w.u + Pxx / m, w.u * (E + Pxx / m) + qx / m, w.n * w.u * w.a2};
}

Vec4 prim_to_cons(const Primitive1D& w, double m) {
  return {w.n, w.n * w.u, 0.5 * w.n * w.u * w.u + 1.5 * w.n * w.T / m, w.n * w.a2};
}
Primitive1D cons_to_prim(const Vec4& U, double m) {
  Primitive1D w;
  w.n = U[0];
  w.u = U[1] / U[0];
  w.T = (U[2] / U[0] - 0.5 * w.u * w.u) * (2.0 * m / 3.0);
  w.a2 = U[3] / U[0];
  return w;
}

// Collision rates (du/dt, dT/dt, da2/dt) along x from closures/ (the 1/eps included).
std::array<double, 3> collision_rates(Closure closure, closures::Parameters prm,
                                      const Primitive1D& w) {
  prm.n = w.n;
  const closures::RelaxationState s{{w.u, 0.0, 0.0}, w.T, w.a2};
  const closures::MomentSources S = closures::sources(closure, prm, s);
  return {S.du_dt[0], S.dT_dt, closure == Closure::sonine ? S.da2_dt : 0.0};
}

double& component(Primitive1D& w, int j) { return j == 0 ? w.n : j == 1 ? w.u : j == 2 ? w.T : w.a2; }

// Quasi-linear matrix B = (dU/dW)^{-1} dF/dW in primitive variables W = (n, u, T[, a2]), by
// central differences of the flux (consistent with the solver's flux by construction).
Eigen::MatrixXd primitive_flux_matrix(Closure closure, const closures::Parameters& prm,
                                      const Primitive1D& w) {
  const double m = prm.mass;
  const int d = closure == Closure::sonine ? 4 : 3;
  const double hs[4] = {1e-6 * w.n, 1e-6 * std::sqrt(w.T / m) + 1e-6 * std::abs(w.u), 1e-6 * w.T,
                        1e-6 * (1.0 + std::abs(w.a2))};
  Eigen::MatrixXd dF(d, d), dU(d, d);
  for (int j = 0; j < d; ++j) {
    Primitive1D a = w, b = w;
    component(a, j) += hs[j];
    component(b, j) -= hs[j];
    const auto Fa = streaming_flux(closure, prm, a), Fb = streaming_flux(closure, prm, b);
    const auto Ua = prim_to_cons(a, m), Ub = prim_to_cons(b, m);
    for (int i = 0; i < d; ++i) {
      dF(i, j) = (Fa[i] - Fb[i]) / (2.0 * hs[j]);
      dU(i, j) = (Ua[i] - Ub[i]) / (2.0 * hs[j]);
    }
  }
  return dU.inverse() * dF;
}

double spectral_radius(const Eigen::MatrixXd& B) {
  Eigen::EigenSolver<Eigen::MatrixXd> es(B, false);
  double r = 0.0;
  for (int i = 0; i < B.rows(); ++i) r = std::max(r, std::abs(es.eigenvalues()(i)));
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

Closure1DSolver::State Closure1DSolver::physical_flux(const Primitive1D& p, std::size_t c) const {
  return streaming_flux(cfg_.closure, params(c, p.n), p);
}

Closure1DSolver::State Closure1DSolver::source(const Primitive1D& p, std::size_t c) const {
  const auto r = collision_rates(cfg_.closure, params(c, p.n), p);
  // d(n u)/dt = n du/dt; dE/dt = n u du/dt + 3 n/(2 m) dT/dt; d(n a2)/dt = n da2/dt (dn/dt = 0).
  return {0.0, p.n * r[0], p.n * p.u * r[0] + 1.5 * p.n / cfg_.mass * r[1], p.n * r[2]};
}

double Closure1DSolver::wave_speed(const Primitive1D& p, std::size_t c) const {
  if (cfg_.closure != Closure::grad)  // Euler (a2 advected): |u| + sqrt(5 T/(3 m))
    return std::abs(p.u) + std::sqrt(5.0 * p.T / (3.0 * cfg_.mass));
  return spectral_radius(primitive_flux_matrix(cfg_.closure, params(c, p.n), p));
}

void Closure1DSolver::set_state(const std::vector<Primitive1D>& prim) {
  if (prim.size() != bg_.grid.size()) throw std::invalid_argument("The closure state needs one value per cell.");
  for (std::size_t i = 0; i < prim.size(); ++i) {
    if (!(prim[i].n > 0.0) || !(prim[i].T > 0.0))
      throw std::invalid_argument("The closure state needs positive n and T in every cell.");
    Primitive1D w = prim[i];
    if (cfg_.closure != Closure::sonine) w.a2 = 0.0;  // only the Sonine closure carries a2
    U_[i] = to_cons(w);
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
    if (cfg_.closure == Closure::sonine) {
      const closures::SonineEquilibrium e = closures::equilibrium_sonine(p);
      U_[i] = to_cons({n[i], bg_.uB[0][i], e.T, e.a2});
    } else {
      U_[i] = to_cons({n[i], bg_.uB[0][i], closures::equilibrium_temperature(cfg_.closure, p), 0.0});
    }
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
    const double sa = limited_slope(cfg_.limiter, b.a2 - a.a2, c.a2 - b.a2);
    wl[i] = {b.n - 0.5 * sn, b.u - 0.5 * su, b.T - 0.5 * sT, b.a2 - 0.5 * sa};
    wr[i] = {b.n + 0.5 * sn, b.u + 0.5 * su, b.T + 0.5 * sT, b.a2 + 0.5 * sa};
    // Positivity fallback: first order in this cell if a face value is unphysical.
    if (wl[i].n <= 0 || wr[i].n <= 0 || wl[i].T <= 0 || wr[i].T <= 0) wl[i] = wr[i] = b;
  }
  std::vector<State> F(N + 1);  // F[f]: face f between cells f-1 and f
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
    for (int k = 0; k < 4; ++k) F[f][k] = 0.5 * (FL[k] + FR[k]) - 0.5 * a * (UR[k] - UL[k]);
    if (!periodic && (f == 0 || f == N)) F[f][0] = F[f][3] = 0.0;  // exact zero mass flux at a wall
  }
  if (periodic) F[N] = F[0];
  std::vector<State> out(N);
  const double h = bg_.grid.h(0);
  for (int i = 0; i < N; ++i)
    for (int k = 0; k < 4; ++k) out[i][k] = -(F[i + 1][k] - F[i][k]) / h;
  return out;
}

// Per cell: solve U = R + gdt S(U) for (u, T[, a2]) at fixed n (Newton with a finite-difference
// Jacobian, damped to keep T > 0). The stiff 1/eps rates make this the asymptotic-preserving
// step: as gdt/eps -> infinity its solution is the collision equilibrium u = uB, T = T#.
void Closure1DSolver::implicit_source(std::vector<State>& U, double gdt) const {
  const double m = cfg_.mass;
  const int d = cfg_.closure == Closure::sonine ? 3 : 2;  // unknowns: u, T (, a2)
  for (std::size_t c = 0; c < U.size(); ++c) {
    const State R = U[c];
    const double n = R[0];
    const double r1 = R[1] / n, r2 = R[2] / n, r3 = R[3] / n;
    Primitive1D w = to_prim(R);
    if (!(w.T > 0.0)) w.T = bg_.TB[c];
    auto resid = [&](const Primitive1D& x) {
      const State s = source(x, c);  // (0, n du/dt, dE/dt, n da2/dt)
      Eigen::VectorXd G(d);
      G(0) = x.u - r1 - gdt * s[1] / n;
      G(1) = 0.5 * x.u * x.u + 1.5 * x.T / m - r2 - gdt * s[2] / n;
      if (d == 3) G(2) = x.a2 - r3 - gdt * s[3] / n;
      return G;
    };
    auto scale = [&](const Primitive1D& x, int j) {
      return j == 0 ? std::sqrt(x.T / m) + std::abs(x.u) : j == 1 ? x.T : 1.0 + std::abs(x.a2);
    };
    auto var = [](Primitive1D& x, int j) -> double& { return j == 0 ? x.u : j == 1 ? x.T : x.a2; };
    Eigen::VectorXd G = resid(w);
    bool ok = false;
    for (int it = 0; it < 60; ++it) {
      Eigen::MatrixXd J(d, d);
      for (int j = 0; j < d; ++j) {
        Primitive1D a = w;
        const double h = 1e-7 * scale(w, j);
        var(a, j) += h;
        J.col(j) = (resid(a) - G) / h;
      }
      const Eigen::VectorXd step = J.partialPivLu().solve(-G);
      double lam = 1.0;
      Primitive1D x = w;
      Eigen::VectorXd Gx = G;
      for (int ls = 0; ls < 30; ++ls) {
        x = w;
        for (int j = 0; j < d; ++j) var(x, j) += lam * step(j);
        if (x.T > 0.0) {
          Gx = resid(x);
          if (Gx.norm() < (1.0 - 1e-4 * lam) * G.norm() || G.norm() < 1e-300) break;
        }
        lam *= 0.5;
      }
      bool small = true;
      for (int j = 0; j < d; ++j) small = small && std::abs(lam * step(j)) <= 1e-13 * scale(w, j);
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
    for (int k = 0; k < 4; ++k) U2[i][k] = U0[i][k] + dt * g * K1[i][k];
  const std::vector<State> R2 = U2;
  implicit_source(U2, g * dt);
  for (std::size_t i = 0; i < N; ++i)
    for (int k = 0; k < 4; ++k) S2[i][k] = (U2[i][k] - R2[i][k]) / (g * dt);
  const auto K2 = flux_divergence(U2);
  for (std::size_t i = 0; i < N; ++i)
    for (int k = 0; k < 4; ++k)
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
std::vector<std::complex<double>> closure_mode_eigenvalues(Closure closure, const ModeParams& p,
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
  Primitive1D w0{p.n, 0.0, 0.0, 0.0};
  if (closure == Closure::sonine) {
    const closures::SonineEquilibrium e = closures::equilibrium_sonine(prm);
    w0.T = e.T;
    w0.a2 = e.a2;
  } else {
    w0.T = closures::equilibrium_temperature(closure, prm);
  }
  const int d = closure == Closure::sonine ? 4 : 3;
  const double m = p.mass;
  // Linearised collision rates in primitive variables: dW/dt|coll = C dW, by central
  // differences of closures::sources about the equilibrium (eq. H23).
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(d, d);
  const double hs[4] = {1e-5 * w0.n, 1e-5 * std::sqrt(w0.T / m), 1e-5 * w0.T, 1e-5};
  for (int j = 0; j < d; ++j) {
    Primitive1D a = w0, b = w0;
    component(a, j) += hs[j];
    component(b, j) -= hs[j];
    const auto ra = collision_rates(closure, prm, a), rb = collision_rates(closure, prm, b);
    for (int i = 1; i < d; ++i) C(i, j) = (ra[i - 1] - rb[i - 1]) / (2.0 * hs[j]);
  }
  const Eigen::MatrixXd B = primitive_flux_matrix(closure, prm, w0);
  // lambda dW = (-i k B + C) dW   (eq. H24)
  const Eigen::MatrixXcd M = std::complex<double>(0.0, -k) * B.cast<std::complex<double>>() +
                             C.cast<std::complex<double>>();
  Eigen::ComplexEigenSolver<Eigen::MatrixXcd> es(M);
  if (es.info() != Eigen::Success) throw std::runtime_error("The closure mode eigenproblem failed.");
  std::vector<std::complex<double>> out(es.eigenvalues().data(), es.eigenvalues().data() + d);
  std::sort(out.begin(), out.end(), [](auto x, auto y) { return x.real() > y.real(); });
  return out;
}

const char* to_string(ModeModel m) {
  switch (m) {
    case ModeModel::paper: return "paper";
    case ModeModel::kinetic: return "kinetic";
    case ModeModel::maxwellian_closure: return "maxwellian_closure";
    case ModeModel::grad_closure: return "grad_closure";
    case ModeModel::sonine_closure: return "sonine_closure";
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
    case ModeModel::grad_closure:
    case ModeModel::sonine_closure: {
      const Closure c = model == ModeModel::grad_closure     ? Closure::grad
                        : model == ModeModel::sonine_closure ? Closure::sonine
                                                             : Closure::maxwellian;
      return -closure_mode_eigenvalues(c, p, k).front().real();  // slowest decay
    }
  }
  throw std::invalid_argument("Unknown mode model.");
}

}  // namespace grainbath::hydro
