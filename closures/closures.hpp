#pragma once
// grainbath::closures -- moment closures of the Bisi-Spiga kinetic equation for grains in a
// Maxwellian background (docs/closures.md). No dependence on the DSMC/EDMD engines.
//
// Units are the scaled units of the paper: both collision cross-sections are 1, k_B = 1.
// The homogeneous kinetic equation is df/dt = (1/eps) J_EL(f) + J_IN(f, f) with
//   J_EL: a grain meets background partners at rate (nB/eps)|v-w| M_B(w) d3w, apse density
//         |g.n|/(2 pi |g|) on S^2, v' = v - 2 alpha (g.n) n             (Bisi-Spiga eqs. 3, 13)
//   J_IN: grains meet grains at rate n |v-w| fhat(w) d3w, v* = v - (1+e)/2 (g.n) n,
//         e = 1 - 2 beta |g.n|^delta (unclamped)                        (Bisi-Spiga eqs. 5, 6)
// Three closures are provided:
//   maxwellian: f = local Maxwellian (n, u, T), exact Gaussian exchange terms (docs eqs. C1-C9)
//   grad:       f = M_TB(v - uB) * [1 + U.c/th0 + kappa (c^2/th0 - 3)], th0 = TB/m, the quadratic-entropy
//               maximiser w.r.t. J_EL (docs eqs. G1-G12)
//   sonine:     f = M_T(v - u) * [1 + a2 S2(m c^2 / 2T)], a2 as a fourth field, collision terms
//               by quadrature of the collision rule (docs eqs. S1-S10)
#include <array>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace grainbath::closures {

struct Parameters {            // one homogeneous bath + grain state, scaled units
  double alpha;                // mass ratio mB/(m+mB)
  double mass = 1.0;           // grain mass m
  double nB;                   // background density
  double TB;                   // background temperature
  std::array<double, 3> uB{};  // background velocity
  double eps;                  // Knudsen parameter (background mean free path / grain one)
  double n;                    // grain density
  double beta = 0.0, delta = 0.0;  // power-law restitution e = 1 - 2 beta |g.n|^delta
};

// Thrown for parameters outside the domain of a closure (e.g. alpha not in (0,1), e < 0 at
// thermal speeds, no equilibrium in the bracket). Its message names the offending parameter.
class ClosureError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

enum class Closure { maxwellian, grad, sonine };
const char* to_string(Closure);

struct RelaxationState {
  std::array<double, 3> u;
  double T;
  double a2;  // first Sonine coefficient; used by the sonine closure only
};

// Collision source terms of a closed moment system: time derivatives per unit (scaled) time,
// the 1/eps of the background operator included. dn/dt = 0 (number is the only invariant).
// da2_dt is zero for the maxwellian and grad closures (they carry no a2 field).
struct MomentSources {
  std::array<double, 3> du_dt{};
  double dT_dt = 0.0;
  double da2_dt = 0.0;
};

// Checks alpha in (0,1), m, nB, TB, eps, n > 0, beta >= 0, delta >= 0; throws ClosureError.
void validate(const Parameters&);

// Background mass mB = alpha m / (1 - alpha) (Bisi-Spiga eq. 2).
double background_mass(const Parameters&);
// Relative-velocity scale s^2 = T/m + TB/mB of a Maxwellian grain vs the background
// (docs eq. C1).
double relative_speed_scale(const Parameters&, double T);

// ---------------------------------------------------------------- collision sources -------
// These are the homogeneous right-hand sides; a spatial (hydro) solver adds them to its
// flux divergence cell by cell, passing the local nB, uB, TB, n in Parameters.
// Local-Maxwellian closure with the exact Gaussian exchange terms (docs eqs. C5, C6) and the
// inelastic loss (Bisi-Spiga eq. 25 = docs eq. C10). state.a2 is ignored.
MomentSources maxwellian_sources(const Parameters&, const RelaxationState&);
// Grad closure (docs eqs. G7, G8, G10). state.a2 is ignored.
MomentSources grad_sources(const Parameters&, const RelaxationState&);
// Sonine closure (docs eqs. S5-S9), including da2/dt.
MomentSources sonine_sources(const Parameters&, const RelaxationState&);
MomentSources sources(Closure, const Parameters&, const RelaxationState&);

// ---------------------------------------------------------------- pieces -------------------
// Elastic exchange with the background only (the 1/eps included), per closure.
struct Exchange {
  std::array<double, 3> du_dt{};
  double dT_dt = 0.0;
};
// Exact Gaussian exchange for Maxwellian grains (docs eqs. C5, C6).
Exchange maxwellian_exchange_exact(const Parameters&, const std::array<double, 3>& u, double T);
// The printed small-drift truncation of Bisi-Spiga eq. 26 (docs eqs. C7, C8): exact to
// O(|u-uB|^3) in du/dt and O(|u-uB|^4) in dT/dt; fails for |u-uB| ~ s (docs Sec. C.4).
Exchange maxwellian_exchange_truncated(const Parameters&, const std::array<double, 3>& u,
                                       double T);
// Grad closure exchange (docs eqs. G7, G8).
Exchange grad_exchange(const Parameters&, const std::array<double, 3>& u, double T);

// Inelastic grain-grain contribution to dT/dt (<= 0 for physical parameters).
// Maxwellian grains: Bisi-Spiga eq. 25 (docs eq. C10); two powers of T, (delta+3)/2 and
// (2 delta+3)/2.
double maxwellian_loss(const Parameters&, double T);
// Grad grains (docs eq. G10); depends on the drift through kappa.
double grad_loss(const Parameters&, const std::array<double, 3>& u, double T);

// <|g|^y> over two independent Maxwellian grains at temperature T (Bisi-Spiga eq. 24).
double pair_speed_moment(double y, double T, double m);

// Probability, over grain-grain collisions of a Maxwellian gas at temperature T (collision
// rate weighted), that the unclamped power law gives e < 0 (docs eq. C12):
// P = exp(-q*^2 m / (4T)) with q* = (2 beta)^(-1/delta); 1 if delta = 0 and beta > 1/2.
double negative_restitution_probability(const Parameters&, double T);
// Above this probability at the equilibrium (or background) temperature the closures refuse
// the parameters (ClosureError naming beta/delta): the unclamped power law would heat.
inline constexpr double kMaxNegativeRestitutionProbability = 1e-3;

// ---------------------------------------------------------------- equilibria ---------------
// Collision equilibrium u# = uB, T# (Bisi-Spiga eq. 27 for maxwellian; docs eq. G11 for grad;
// docs eq. S10 for sonine), by bracketed Brent root finding to 1e-13 relative.
double equilibrium_temperature(Closure, const Parameters&);
double equilibrium_a2_sonine(const Parameters&);
struct SonineEquilibrium {
  double T;
  double a2;
};
SonineEquilibrium equilibrium_sonine(const Parameters&);

// T# = T0 + eps T1 + eps^2 T2 (Bisi-Spiga eqs. 28-29 = docs eqs. C13-C15; docs eq. G12).
// T1 is common to both closures; T2 differs.
struct Expansion {
  double T0, T1, T2_maxwellian, T2_grad;
};
Expansion expansion(const Parameters&);

// ---------------------------------------------------------------- relaxation ---------------
// Integrates the homogeneous relaxation ODEs with error control (GSL odeiv2: rk8pd, rel. tol.
// 1e-10, for maxwellian and grad; msbdf with a finite-difference Jacobian, rel. tol. 1e-9, for
// the quadrature-based sonine system, which is stiff for small eps) from the
// initial state at t = 0 and returns the state at each requested time (non-decreasing, >= 0).
std::vector<RelaxationState> relax(Closure, const Parameters&, const RelaxationState& initial,
                                   const std::vector<double>& times);

// ---------------------------------------------------------------- reporting ----------------
// Dotted key -> value, e.g. {"equilibrium.maxwellian.T", 0.97}: everything `grainbath theory`
// prints: equilibrium.u.{x,y,z}, equilibrium.{maxwellian,grad}.T, equilibrium.sonine.{T,a2},
// expansion.{T0,T1,T2_maxwellian,T2_grad}, expansion.{first_order,second_order_maxwellian,
// second_order_grad}.T, rates.momentum, diagnostics.{sonine_available,
// negative_restitution_probability}. Throws ClosureError for invalid parameters. Where only
// the Sonine closure has no steady state (very strong dissipation) its two keys are omitted
// and diagnostics.sonine_available is 0.
std::vector<std::pair<std::string, double>> theory_values(const Parameters&);

}  // namespace grainbath::closures

#include "closures/gaussian_moments.hpp"
#include "closures/grad_moments.hpp"
#include "closures/hcs.hpp"
#include "closures/sonine.hpp"
