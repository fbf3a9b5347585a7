#pragma once
// grainbath::closures::rough -- mean-field theories (models A-E of thesis seed 000, chapter
// 10; Herbst et al. 2005) for the translational and rotational temperatures Ttr(t), Trot(t)
// of a homogeneously driven gas of rough particles colliding by Walton's rule
// (operators/walton.hpp). docs/rough.md derives every formula; labels (R1-R14, and R15-R16
// for 3D) are cited here.
//
// Setting (docs/rough.md sec. 1): in 2D translation in the plane (2 degrees of freedom) and
// spin along z only (1 degree of freedom); in 3D three of each. Moment of inertia I = q m a^2
// (q = 1/2 disks, 2/5 spheres). Ttr = m <v^2>/d, Trot = I <w^2>/d_rot. Gaussian velocities,
// molecular chaos, spatial homogeneity. White-noise driving of the translational velocities
// feeds dTtr/dt = H. Collision frequency per particle nu(Ttr) = G sqrt(Ttr) (R1).
//
// All models have the form (R2; c_tr = 1, c_rot = 2, n0 = (1-e^2)/2 in 2D and
// c_tr = c_rot = 4/3, n0 = (1-e^2)/4 in 3D, eq. R15)
//   dTtr/dt  = H + c_tr nu [ -n0 Ttr - E1 Ttr + E2 (Ttr + Trot/q) ]     (E)
//   dTrot/dt = c_rot nu / q [ -E1 Trot + E2 (Ttr + Trot/q) ]
// or, for A-D, the linear form (10.4) of the thesis (R3)
//   dTtr/dt  = H + c_tr nu [ -A Ttr + B Trot ],   dTrot/dt = c_rot nu [ B' Ttr - C Trot ].
#include <string>
#include <vector>

#include "operators/walton.hpp"

namespace grainbath::closures::rough {

enum class Model { A, B, C, D, E };
const char* to_string(Model);
Model model_from_string(const std::string&);  // "A".."E"; throws ClosureError otherwise

struct Parameters {
  double e = 1.0;       // normal restitution
  double beta0 = 1.0;   // maximal tangential restitution
  double mu = 1e300;    // Coulomb friction (+inf allowed: no sliding)
  double q = 0.5;       // I / (m a^2)
  double G = 1.0;       // nu = G sqrt(Ttr) (R1); see collision_prefactor_2d/3d
  double H = 0.0;       // driving: dTtr/dt from the noise
  int dim = 2;          // 2: planar translation + spin along z; 3: three of each
  // driving keyed on collisions (EDMD white noise, kicks at every collision): adds
  // H_per_collision * nu to dTtr/dt, i.e. a fixed temperature gain per collision per particle
  // (last member: positional initialisers of the members above stay valid)
  double H_per_collision = 0.0;
};

// The material part of Parameters (e, beta0, mu, q, dim) from a Walton law
// (operators/walton.hpp; mu = inf becomes 1e300); G, H, H_per_collision keep their defaults.
Parameters parameters_of(const WaltonRestitution& law, double q, int dim);

// Throws ClosureError for e not in [0,1], beta0 not in [-1,1], mu < 0, q <= 0, G <= 0, H < 0
// or H_per_collision < 0,
// dim not 2 or 3.
void validate(const Parameters&);

// G of eq. R1 for disks of diameter sigma, mass m, area fraction phi (n = 4 phi/(pi sigma^2),
// Henderson chi = (1 - 7 phi/16)/(1 - phi)^2).
double collision_prefactor_2d(double phi, double sigma = 1.0, double mass = 1.0);
// G for spheres (nu = 4 n sigma^2 chi sqrt(pi T/m), n = 6 phi/(pi sigma^3), Carnahan-Starling
// chi = (1 - phi/2)/(1 - phi)^3).
double collision_prefactor_3d(double phi, double sigma = 1.0, double mass = 1.0);

// Impact-angle averages over Gaussian contact velocities (R5-R10 in 2D, R16 in 3D).
// k^2 = 1 + Trot/(q Ttr)
// is the ratio of the tangential to the normal contact-velocity variance; u0 = tan(gamma0)/k.
struct ImpactAverages {
  double u0;    // sticking/sliding boundary in scaled impact angle tan(gamma)/k (R5)
  double E1;    // <eta g_t^2> / <g_t^2>, collision weighted (R6)
  double E2;    // <eta^2 g_t^2> / <g_t^2> (R7)
  double P1;    // <eta>, collision weighted impact-angle distribution (R8)
  double P2;    // <eta^2> (R9)
  double sliding_fraction;  // fraction of collisions that slide (R10)
};
ImpactAverages impact_averages(const Parameters&, double k);

// Coefficients of the linear form R3 (models A, B, D; C at a given Trot/Ttr).
struct LinearCoefficients {
  double A, B, Bp, C;
};
LinearCoefficients linear_coefficients(Model, const Parameters&, double R = 0.0);

struct Rates {
  double dTtr, dTrot;
};
// Right-hand side of the model's ODE (R2/R3, driving H included).
Rates rhs(Model, const Parameters&, double Ttr, double Trot);

// Steady R = Trot/Ttr: root of the rotational equation (independent of G and H) (R11).
double steady_ratio(Model, const Parameters&);
struct SteadyState {
  double Ttr, Trot, R;
};
// Steady temperatures for H > 0 or H_per_collision > 0 (R12: G F Ttr^{3/2} = H + H_nu G Ttr^{1/2}).
SteadyState steady_state(Model, const Parameters&);

// Linearisation about the steady state (thesis sec. 10.5: "an eigenvalue problem with two
// relaxation rates"; docs/rough.md eq. R17): the eigenvalues of the 2x2 Jacobian of rhs at
// steady_state(), both negative, as decay rates (> 0), fast >= slow. The fast one is mostly the
// Ttr-Trot equilibration, the slow one the common approach to the steady state.
struct RelaxationRates {
  double fast, slow;
};
RelaxationRates relaxation_rates(Model, const Parameters&);

struct Sample {
  double t, Ttr, Trot;
};
// Integrates the model from (Ttr0, Trot0) with GSL odeiv2 (rk8pd, rel. tol 1e-10) and
// returns the state at the requested (increasing) times.
std::vector<Sample> integrate(Model, const Parameters&, double Ttr0, double Trot0,
                              const std::vector<double>& times);

}  // namespace grainbath::closures::rough
