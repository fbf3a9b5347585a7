// hydro/transport.hpp -- transport coefficients of the drift-diffusion (eps -> 0) limit.
//
// The drift-diffusion equation (Bisi-Spiga eq. 36, generalised in docs/hydro.md eq. H7) is
//   dn/dt + div(n uB) = div{ D [ grad n + p n grad ln TB - n (m/mB) grad ln(nB TB) ] },
//   D = eps * Dhat(alpha) * sqrt(TB/m) / nB                                 (docs/hydro.md eq. H8)
// Two coefficient sets exist:
//   * paper (first Sonine / first Chapman-Enskog approximation): Dhat = 3/8 sqrt(pi/(2 alpha)),
//     p = 1 (docs/hydro.md eqs. H4-H6, Bisi-Spiga eq. 35);
//   * kinetic: Dhat and p from a Sonine-polynomial Galerkin solution of the linearised
//     background operator (docs/hydro.md eqs. H9-H13), converged in the number of polynomials.
#pragma once

#include <Eigen/Dense>

#include <string>
#include <vector>

namespace grainbath::hydro {

// mB = alpha m / (1 - alpha)  (grainbath convention; Bisi-Spiga eq. 2 inverted).
double background_mass(double alpha, double mass);

// Momentum-exchange (friction) rate per unit background density for a Maxwellian grain
// distribution at temperature T drifting slowly relative to the background (T_B, u_B):
//   nu1 = (8/3) sqrt(2/pi) alpha sqrt(((1-alpha) TB + alpha T)/(alpha m))      (docs/hydro.md eq. H3)
// so that du/dt = -(nB/eps) nu1 (u - uB) + O(|u-uB|^3).
double friction_rate_per_nB(double alpha, double mass, double T, double TB);

// Bisi-Spiga eq. 35/36 diffusion coefficient with the first-Sonine value (docs/hydro.md eq. H6):
//   D = eps TB / (m nB nu1(T=TB)) = eps (3/(8 nB)) sqrt(pi TB / (2 alpha m)).
double diffusion_coefficient_paper(double alpha, double mass, double nB, double TB, double eps);

// Result of the Sonine-Galerkin solution of the l=1 sector of the linear background operator
// (docs/hydro.md eqs. H9-H13), in reduced units (TB = m = nB = 1, eps = 1).
struct SonineGalerkin {
  double alpha = 0.5;
  int order = 0;                 // number of Sonine polynomials N in the basis c S_p, p < N
  Eigen::MatrixXd collision;     // C_pq = <c_z S_p L[c_z S_q]>_M, N x N, symmetric negative definite
  Eigen::VectorXd gram;          // <c_z^2 S_p^2>_M (diagonal of the Gram matrix)
  double Dhat = 0.0;             // K0: reduced tracer diffusion coefficient (eq. H11)
  double K1 = 0.0;               // reduced thermal-diffusion response (eq. H12)
  double p() const { return 1.0 - K1 / Dhat; }  // thermal-diffusion exponent (eq. H13)
};

// Builds the N x N Galerkin matrix by quadrature (exact for the polynomial integrand up to
// round-off: Gauss-Hermite in the centre-of-mass velocity, Gauss-Legendre in the scattering
// cosine, generalised Gauss-Laguerre in alpha g^2/2; docs/hydro.md eq. H10) and solves for Dhat and p
// with the first n polynomials for every n <= N (nested bases: leading principal submatrices).
// Returns one entry per n = 1..N.
std::vector<SonineGalerkin> sonine_galerkin_sequence(double alpha, int N);

// The converged kinetic coefficients: increases N (8, then max_order) until two successive
// orders change Dhat (relative) and p (absolute) by less than rel_tol. Convergence is fast for
// alpha <~ 0.8 (N <~ 12 for 1e-6) and algebraic towards the Lorentz limit alpha -> 1
// (docs/hydro.md sec. 2.4); if max_order is reached first, the max_order result is returned with
// converged = false and the last change as an error estimate (it never throws for that).
// Cost: about 2 s for max_order 16 (the N^5 exact quadrature); results are cached per process.
struct KineticTransport {
  double Dhat = 0.0;      // reduced diffusion coefficient: D = eps Dhat sqrt(TB/m)/nB
  double p = 1.0;         // thermal-diffusion exponent: steady isobaric profile n ~ TB^(-p)
  int order = 0;          // number of Sonine polynomials used
  double change = 0.0;    // last change (max of relative dDhat, absolute dp)
  bool converged = false; // change < rel_tol reached before max_order
};
KineticTransport kinetic_transport(double alpha, double rel_tol = 1e-5, int max_order = 16);

double diffusion_coefficient_kinetic(double alpha, double mass, double nB, double TB, double eps,
                                     int sonine_order = 0 /*0 = converged*/);
// Thermal-diffusion exponent p (eq. H13); sonine_order 0 = converged. p = 1 at first Sonine
// order (Bisi-Spiga eq. 36: n TB = const in the isobaric steady state).
double thermal_diffusion_exponent_kinetic(double alpha, int sonine_order = 0);
// Tracer thermal-diffusion factor alpha_T = p - 1 (steady isobaric: grad ln(n/nB) = -alpha_T grad ln TB).
double thermal_diffusion_factor_kinetic(double alpha, int sonine_order = 0);

// Coefficient set used by the drift-diffusion solvers.
struct DriftDiffusionCoefficients {
  double alpha = 0.5;
  double mass = 1.0;
  double eps = 0.1;
  double Dhat = 0.0;  // D = eps Dhat sqrt(TB/m) / nB
  double p = 1.0;     // thermal-diffusion exponent
  std::string name;   // "paper" or "kinetic"
  int sonine_order = 1;        // Sonine polynomials behind Dhat and p (paper: 1)
  bool converged = true;       // kinetic: kinetic_transport reached its tolerance
  double mass_ratio() const;  // m/mB = (1-alpha)/alpha
  double D(double nB, double TB) const;
};
DriftDiffusionCoefficients paper_coefficients(double alpha, double mass, double eps);
DriftDiffusionCoefficients kinetic_coefficients(double alpha, double mass, double eps,
                                                int sonine_order = 0);

}  // namespace grainbath::hydro
