// hydro/quadrature.hpp -- Gauss rules from the Golub-Welsch eigenproblem (internal helper).
#pragma once

#include <vector>

namespace grainbath::hydro::quad {

struct Rule {
  std::vector<double> x;
  std::vector<double> w;
};

// Probabilists' Gauss-Hermite: sum_i w_i f(x_i) ~= E[f(X)], X ~ N(0,1); exact to degree 2n-1.
Rule gauss_hermite_prob(int n);
// Gauss-Legendre on [a,b]: sum_i w_i f(x_i) ~= int_a^b f dx; exact to degree 2n-1.
Rule gauss_legendre(int n, double a = -1.0, double b = 1.0);
// Generalised Gauss-Laguerre with weight t^a e^{-t} on [0,inf), weights normalised so that
// sum_i w_i = Gamma(a+1); exact to degree 2n-1.
Rule gauss_laguerre(int n, double a);

}  // namespace grainbath::hydro::quad
