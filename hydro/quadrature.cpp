// hydro/quadrature.cpp -- Golub-Welsch Gauss rules: nodes are the eigenvalues of the Jacobi
// matrix of the three-term recurrence, weights mu0 * (first eigenvector component)^2.
#include "hydro/quadrature.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <stdexcept>

namespace grainbath::hydro::quad {
namespace {

Rule golub_welsch(const Eigen::VectorXd& diag, const Eigen::VectorXd& off, double mu0) {
  const int n = static_cast<int>(diag.size());
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i) J(i, i) = diag(i);
  for (int i = 0; i + 1 < n; ++i) J(i, i + 1) = J(i + 1, i) = off(i);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(J);
  if (es.info() != Eigen::Success) throw std::runtime_error("Golub-Welsch eigen-solve failed.");
  Rule r;
  r.x.resize(n);
  r.w.resize(n);
  for (int i = 0; i < n; ++i) {
    r.x[i] = es.eigenvalues()(i);
    const double v0 = es.eigenvectors()(0, i);
    r.w[i] = mu0 * v0 * v0;
  }
  return r;
}

void check_n(int n) {
  if (n < 1) throw std::invalid_argument("A Gauss rule needs at least one node.");
}

}  // namespace

Rule gauss_hermite_prob(int n) {
  check_n(n);
  // Monic probabilists' Hermite: He_{k+1} = x He_k - k He_{k-1}.
  Eigen::VectorXd d = Eigen::VectorXd::Zero(n), o(std::max(n - 1, 0));
  for (int k = 1; k < n; ++k) o(k - 1) = std::sqrt(static_cast<double>(k));
  return golub_welsch(d, o, 1.0);
}

Rule gauss_legendre(int n, double a, double b) {
  check_n(n);
  Eigen::VectorXd d = Eigen::VectorXd::Zero(n), o(std::max(n - 1, 0));
  for (int k = 1; k < n; ++k) o(k - 1) = k / std::sqrt(4.0 * k * k - 1.0);
  Rule r = golub_welsch(d, o, 2.0);
  const double h = 0.5 * (b - a), c = 0.5 * (b + a);
  for (int i = 0; i < n; ++i) {
    r.x[i] = c + h * r.x[i];
    r.w[i] *= h;
  }
  return r;
}

Rule gauss_laguerre(int n, double a) {
  check_n(n);
  if (a <= -1.0) throw std::invalid_argument("Gauss-Laguerre needs a > -1.");
  Eigen::VectorXd d(n), o(std::max(n - 1, 0));
  for (int k = 0; k < n; ++k) d(k) = 2.0 * k + 1.0 + a;
  for (int k = 1; k < n; ++k) o(k - 1) = std::sqrt(k * (k + a));
  return golub_welsch(d, o, std::tgamma(a + 1.0));
}

}  // namespace grainbath::hydro::quad
