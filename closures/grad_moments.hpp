#pragma once
// Grad closure: the distribution and its streaming moments (docs/closures.md Sec. G).
//
// Maximising the quadratic entropy -int f^2/M d3v (M = grain-mass Maxwellian at the background
// uB, TB, the equilibrium of J_EL; Bisi-Spiga eq. 15) at fixed n, u, T gives (docs eq. G2)
//   f = n M(v) [1 + U.c/th0 + kappa (c^2/th0 - 3)],  c = v - uB,  U = u - uB,  th0 = TB/m,
//   kappa = (3 (T - TB)/m + |U|^2) / (6 th0).
// The streaming terms of Bisi-Spiga eq. 18 then close as (docs eqs. G4, G5)
//   P = n T I + n m (|U|^2/3 I - U U^T),   q = (n/2) [5 (TB - T) + m |U|^2/3] U.
#include <array>

namespace grainbath::closures {

struct Parameters;

// kappa of docs eq. G2.
double grad_kappa(const Parameters&, const std::array<double, 3>& u, double T);

struct GradStreaming {
  std::array<std::array<double, 3>, 3> pressure;  // full pressure tensor P_ij (docs eq. G4)
  std::array<double, 3> heat_flux;                // q_i (docs eq. G5)
};
// Pressure tensor and heat flux of the Grad distribution with density p.n (docs eqs. G4, G5),
// for a spatial solver of the Grad (n, u, T) system.
GradStreaming grad_streaming(const Parameters&, const std::array<double, 3>& u, double T);

}  // namespace grainbath::closures
