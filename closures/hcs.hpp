#pragma once
// Homogeneous cooling state (HCS) of smooth hard spheres (d = 3) with constant restitution e,
// beyond the first Sonine approximation (docs/closures.md Sec. H; no medium).
//
// Scaled distribution (docs eq. H1):
//   f(c) = phi(c) [1 + a2 S2(c^2) + a3 S3(c^2)],  c = v / v_T,  v_T = sqrt(2 T/m),
//   phi(c) = pi^{-3/2} exp(-c^2),  S2(x) = x^2/2 - 5x/2 + 15/8,
//   S3(x) = -x^3/6 + 7x^2/4 - 35x/8 + 35/16   (Laguerre polynomials of index 1/2),
// so that <c^4> = (15/4)(1 + a2), <c^6> = (105/8)(1 + 3 a2 - a3) (docs eq. H2), i.e.
// a2 = <c^4>/(15 (T/m)^2) - 1 in unscaled velocities, as the DSMC measures it.
//
// Units: the collision moments mu_p = -∫ c^p J[f, f] d3c (docs eq. H3) are those of the scaled
// equation with hard-sphere diameter 1 and unit density; in them the cooling rate is
// zeta = (2/3) n sigma^2 v_T mu_2 (docs Sec. H.2), so only ratios of mu_p enter a2, a3 and
// zeta / zeta0 (grainbath's cross-section pi sigma^2 = 1 is a common factor).
#include <array>
#include <vector>

namespace grainbath::closures {

// Coefficients of mu_p in the monomials {1, a2, a3, a2^2, a2 a3, a3^2} (docs eq. H6), exact to
// round-off for the truncated f of eq. H1: Gauss-Hermite (centre of mass), Gauss-Laguerre
// (|g|^2/2) and Gauss-Legendre (cos(g, n)) rules that integrate the polynomial integrand
// exactly (docs eq. H5), tabulated once as polynomials in lambda = (1 + e)/2.
struct HcsCollisionMoments {
  std::array<double, 6> mu2{}, mu4{}, mu6{};
};
// e in [0, 1]; throws ClosureError otherwise.
HcsCollisionMoments hcs_collision_moments(double e);
// mu_p(e; a2, a3) for p = 2, 4, 6 (the full quadratic form, docs eq. H6).
double hcs_collision_moment(int p, double e, double a2, double a3);
// The same table built with other node counts (Hermite per axis, Laguerre, Legendre): only for
// the test that the default rules are exact (tests/closures/test_hcs.cpp).
HcsCollisionMoments hcs_collision_moments_with_nodes(double e, int n_hermite, int n_laguerre, int n_legendre);

struct HcsSonine {
  double a2 = 0.0, a3 = 0.0;
};

// First Sonine approximation (a3 = 0, linear in a2; docs eq. H7): van Noije and Ernst,
// a2 = 16 (1 - e)(1 - 2 e^2) / (81 - 17 e + 30 e^2 (1 - e)). From the tabulated moments.
double hcs_a2_first_sonine(double e);
// Second Sonine approximation, linear in (a2, a3) (docs eq. H8; Brilliantov-Poeschel style).
HcsSonine hcs_sonine2_linear(double e);
// Second Sonine approximation with the full quadratic collision moments and the products in
// mu_p = (p/3) mu_2 <c^p> kept (docs eq. H9): Newton from the linear solution.
HcsSonine hcs_sonine2_nonlinear(double e);
// The linear Sonine hierarchy to order K (2 <= K <= 6; docs Sec. H.8): f = phi [1 + sum_{k=2}^K
// a_k S_k], the moment equations mu_{2k} = (2k/3) mu_2 <c^{2k}> for k = 2..K linearised in the a_k.
// Returns {a_2, ..., a_K}. K = 2 is eq. H7, K = 3 eq. H8; the change from K = 3 to 6 is the
// truncation estimate of the second Sonine value used by the free-cooling tests. (Exact Gauss
// rules as in eq. H5 with 14 Hermite nodes per axis, 16 Laguerre, 14 Legendre; built once.)
std::vector<double> hcs_sonine_linear(double e, int K);

// zeta / zeta0 = mu_2(a2, a3) / mu_2(0, 0) = 1 + 3 a2/16 + a3/64 + 9 a2^2/1024
//                                           + 15 a2 a3/2048 + 35 a3^2/16384 (docs eq. H10).
double hcs_cooling_rate_ratio(const HcsSonine&);

}  // namespace grainbath::closures
