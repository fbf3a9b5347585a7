#pragma once
// Moments of a shifted 3D Gaussian ("non-central chi" moments) -- the building block of the
// exact exchange terms (docs/closures.md Sec. C.2, eqs. C2-C4).
//
// For x ~ N(a, I_3) with A = |a|:
//   m_k(A) = E|x|^k = mu_k 1F1(-k/2; 3/2; -A^2/2),  mu_k = E|z|^k = 2^{k/2} G((k+3)/2)/G(3/2)
// and, for odd k, the closed form in erf and exp (docs eq. C3)
//   m_k(A) = h_{k+1}(A) / A,  h_j(A) = E[y^j sgn y],  y ~ N(A, 1),
// with h_j a polynomial in A times erf(A/sqrt2) plus a polynomial times exp(-A^2/2).
// Vector moments follow from Stein's identity E[h(x)(x-a)] = grad_a E[h(x)] (docs eq. C4):
//   E[|x|^k x] = a_hat (A m_k + m_k')
//   E[|x|^k x x^T] = (m_k + m_k'/A) I + (A^2 m_k + 2 A m_k' + m_k'' - m_k'/A) a_hat a_hat^T
namespace grainbath::closures {

struct RadialMoment {
  double value;       // m_k(A)
  double d1;          // m_k'(A)
  double d1_over_A;   // m_k'(A)/A, finite at A = 0 (m_k is even in A)
  double d2;          // m_k''(A)
};

// E|x|^k and its A-derivatives for odd k in 1..7. Series (Kummer) for A < 1, the erf/exp
// closed form above; both to ~1e-15 relative.
RadialMoment noncentral_chi_moment(int k, double A);

// m_1, m_3 and m_5 with derivatives in one pass (one erfc, one exp): the same formulas as
// noncentral_chi_moment, arranged for the Sonine quadrature's inner loop.
struct ChiMoments135 {
  RadialMoment m1, m3, m5;
};
ChiMoments135 noncentral_chi_moments_135(double A);

// E|z|^y for z ~ N(0, I_3), any real y > -3: 2^{y/2} G((y+3)/2) / G(3/2).
double central_chi_moment(double y);

// h_j(A) = E[y^j sgn y], y ~ N(A,1), j >= 0 (docs eq. C3), closed form in erf/exp.
double signed_normal_moment(int j, double A);

}  // namespace grainbath::closures
