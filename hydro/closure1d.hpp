// hydro/closure1d.hpp -- 1D finite-volume solvers of the closed moment systems of the
// Maxwellian and Grad closures ((n, u, T): Bisi-Spiga eq. 26 and sec. 4) and of the Sonine
// closure ((n, u, T, a2)), with collision sources from closures/, and their linearised
// density-mode eigenproblems (docs/hydro.md sec. 4).
#pragma once

#include "closures/closures.hpp"
#include "hydro/grid.hpp"

#include <array>
#include <complex>
#include <string>
#include <vector>

namespace grainbath::hydro {

enum class Limiter { None, Minmod, MonotonizedCentral };

struct Closure1DConfig {
  closures::Closure closure = closures::Closure::maxwellian;  // maxwellian, grad or sonine
  double alpha = 0.5;
  double mass = 1.0;
  double eps = 0.1;
  double beta = 0.0, delta = 0.0;  // restitution law (Bisi-Spiga eq. 5)
  Limiter limiter = Limiter::MonotonizedCentral;
  double cfl = 0.4;                // of the Rusanov wave-speed bound
};

// Primitive state per cell, 1D: velocity along x only; a2 is the Sonine coefficient (used by the
// Sonine closure only, 0 otherwise).
struct Primitive1D {
  double n, u, T;
  double a2 = 0.0;
};

// Conservative 1D solver: MUSCL reconstruction of (n, u, T, a2), Rusanov fluxes of the closure's
// streaming terms (Euler for Maxwellian and Sonine -- a2 is then advected, eq. H19b; with P_xx,
// q_x of the Grad distribution for Grad, closures::grad_streaming), and the IMEX ARS(2,2,2)
// scheme: fluxes explicit, 1/eps collision sources implicit (per-cell Newton on (u, T[, a2])).
// The implicit stages are L-stable and the scheme is globally stiffly accurate, so it is
// asymptotic-preserving: dt is limited by the CFL condition only, and as eps -> 0 it relaxes to
// u = uB, T = T# (docs/hydro.md eq. H22).
// Walls reflect (zero mass flux); mass is conserved to round-off in both cases.
class Closure1DSolver {
 public:
  Closure1DSolver(const Closure1DConfig& cfg, const Background& bg, double n_ref);
  // n_ref: reference grain density for the equilibrium temperature used to initialise T.
  void set_state(const std::vector<Primitive1D>& prim);
  std::vector<Primitive1D> primitive() const;
  // Equilibrium initial state: given n, u = uB, T = T#(n) (and a2 = a2#(n)) cell by cell.
  void set_equilibrium(const std::vector<double>& n);
  void step(double dt);
  // Advance to t_end with steps limited by both max_dt and the CFL condition.
  void run_to(double t_end, double max_dt);
  double max_stable_dt() const;
  double time() const { return t_; }
  double mass() const;
  const Grid& grid() const { return bg_.grid; }

 private:
  using State = std::array<double, 4>;  // (n, n u, E, n a2), E = n u^2/2 + 3 n T/(2 m)
  std::vector<State> flux_divergence(const std::vector<State>& U) const;
  void implicit_source(std::vector<State>& U, double gdt) const;  // U <- solve U = R + gdt S(U)
  Primitive1D to_prim(const State& s) const;
  State to_cons(const Primitive1D& p) const;
  State physical_flux(const Primitive1D& p, std::size_t cell) const;
  State source(const Primitive1D& p, std::size_t cell) const;  // (0, d(nu)/dt, dE/dt, d(n a2)/dt)
  double wave_speed(const Primitive1D& p, std::size_t cell) const;
  closures::Parameters params(std::size_t cell, double n) const;

  Closure1DConfig cfg_;
  Background bg_;
  std::vector<State> U_;
  double t_ = 0.0;
};

// Linearised mode problem of a closure about the homogeneous equilibrium (n0, uB, T#[, a2#]) in a
// uniform background, perturbations ~ exp(i k x + lambda t): returns the eigenvalues lambda
// (Eigen::ComplexEigenSolver on the 3x3 -- 4x4 for Sonine -- matrix of docs/hydro.md eq. H24),
// sorted by decreasing real part.
struct ModeParams {
  double alpha = 0.5, mass = 1.0, nB = 1.0, TB = 1.0, eps = 0.1;
  double n = 1.0, beta = 0.0, delta = 0.0;
};
std::vector<std::complex<double>> closure_mode_eigenvalues(closures::Closure closure,
                                                           const ModeParams& p, double k);

enum class ModeModel { paper, kinetic, maxwellian_closure, grad_closure, sonine_closure };
const char* to_string(ModeModel);
// Decay rate (-Re lambda >= 0) of the slowest (density) mode of wavenumber k:
// paper: D k^2 (eq. 36); kinetic: D_kin k^2; closures: the eigenvalue of eq. H24 with the
// smallest |Re lambda|.
double mode_decay_rate(ModeModel model, const ModeParams& p, double k);

}  // namespace grainbath::hydro
