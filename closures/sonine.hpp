#pragma once
// Sonine-corrected closure (docs/closures.md Sec. S): beyond the paper.
//
// f = n M_T(c) [1 + a2 S2(x)],  c = v - u,  x = m c^2/(2T),  S2(x) = x^2/2 - 5x/2 + 15/8,
// a2 = <c^4>/(15 (T/m)^2) - 1 carried as a fourth field. Its collision terms are exact
// expectations of the collision rule under this f, computed by quadrature (docs eqs. S3-S9):
//  * background: the shifted-Gaussian w-average in closed form (docs eq. C4 machinery), then
//    a 2D Gauss-Legendre quadrature over c (|c| and its angle to u - uB);
//  * grain-grain: exact Gauss-Hermite (centre-of-mass velocity), Gauss-Jacobi (|g.n|^{j delta}
//    weights) and Gauss-Legendre (|g|) quadrature of the power-law rule, tabulated once per
//    delta as coefficients of a2^p (beta (T/m)^{delta/2})^j, p <= 2, j <= 4 (docs eq. S7).
#include <array>

namespace grainbath::closures {

struct Parameters;

// Background (elastic, J_EL/eps) contributions for a Sonine grain state (docs eqs. S3-S5):
// du/dt, d<c^2>/dt and d<c^4>/dt with c = v - u, per unit time (1/eps included).
struct SonineMoments {
  std::array<double, 3> du_dt{};
  double dc2_dt = 0.0;
  double dc4_dt = 0.0;
};
SonineMoments sonine_background(const Parameters&, const std::array<double, 3>& u, double T,
                                double a2);
// Grain-grain (J_IN) contributions (docs eq. S7); du/dt = 0 (momentum is conserved).
SonineMoments sonine_grain_grain(const Parameters&, double T, double a2);

}  // namespace grainbath::closures
