// hydro/transport.cpp -- first-Sonine (paper) and Sonine-Galerkin (kinetic) transport
// coefficients of the drift-diffusion limit. Derivations: docs/hydro.md sections 1-2.
#include "hydro/transport.hpp"

#include "hydro/quadrature.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <numbers>
#include <sstream>
#include <tuple>
#include <stdexcept>

namespace grainbath::hydro {
namespace {

constexpr double kPi = std::numbers::pi;

void check_alpha(double alpha) {
  if (!(alpha > 0.0 && alpha < 1.0)) {
    std::ostringstream os;
    os << "alpha = mB/(m+mB) must lie in (0,1), got " << alpha << ".";
    throw std::invalid_argument(os.str());
  }
}
void check_positive(double v, const char* what) {
  if (!(v > 0.0) || !std::isfinite(v)) {
    std::ostringstream os;
    os << what << " must be positive and finite, got " << v << ".";
    throw std::invalid_argument(os.str());
  }
}

// Generalised Laguerre (Sonine) polynomials L_p^{(3/2)}(x), p = 0..N-1, by the three-term
// recurrence (p+1) L_{p+1} = (2p + 1 + a - x) L_p - (p + a) L_{p-1}, a = 3/2.
inline void sonine32(double x, int N, double* out) {
  constexpr double a = 1.5;
  out[0] = 1.0;
  if (N > 1) out[1] = 1.0 + a - x;
  for (int p = 1; p + 1 < N; ++p)
    out[p + 1] = ((2.0 * p + 1.0 + a - x) * out[p] - (p + a) * out[p - 1]) / (p + 1.0);
}

// C_pq = <c_z S_p L[c_z S_q]>_M in reduced units (T = TB = m = 1, nB = 1), docs/hydro.md eq. H10:
//   C_pq = -(1/6) E[ |g| (Delta(v S_p)) . (Delta(v S_q)) ],
// v = V + alpha g, v' = V + alpha g', V ~ N(0, (1-alpha) I), g ~ N(0, I/alpha), g' = |g| e',
// e' uniform on the unit sphere (hard spheres scatter isotropically in the centre-of-mass frame).
// All three quadratures are exact for the polynomial integrand (see eq. H10 notes).
Eigen::MatrixXd galerkin_matrix(double alpha, int N) {
  const int nV = 2 * N;      // degree in V <= 4N-2
  const int nU = 2 * N;      // degree in cos(theta') <= 4N-2
  const int nT = N + 1;      // degree in t = alpha g^2/2 <= 2N-1
  const quad::Rule hV = quad::gauss_hermite_prob(nV);
  const quad::Rule lU = quad::gauss_legendre(nU, -1.0, 1.0);
  const quad::Rule gT = quad::gauss_laguerre(nT, 1.0);
  const double sV = std::sqrt(1.0 - alpha);
  // E_g[|g| F(|g|)] = (2 sqrt(2/pi)/sqrt(alpha)) sum_i w_i F(sqrt(2 t_i/alpha)), eq. H10.
  const double gpref = 2.0 * std::sqrt(2.0 / kPi) / std::sqrt(alpha);

  // V_y enters only through V_y^2 (in |v|^2, |v'|^2 and the product of the y-components), so
  // the y-rule keeps the positive nodes of the symmetric Hermite rule with doubled weights.
  // Right only for an even node count (nV = 2N above): an odd rule has a node at 0, which this would drop
  // (the mutation audit's TR2, docs/reviews/mutation-audit-closures-hydro.md).
  std::vector<double> yx, yw;
  for (int b = 0; b < nV; ++b)
    if (hV.x[b] > 0.0) {
      yx.push_back(hV.x[b]);
      yw.push_back(2.0 * hV.w[b]);
    }
  const int nY = static_cast<int>(yx.size());
  const int nVV = nV * nY * nV;
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(N, N);
  Eigen::MatrixXd B(3 * nVV, N);  // rows: sqrt(weight) * Delta(v S_p) components
  std::vector<double> Sp(N), Sq(N);
  for (int it = 0; it < nT; ++it) {
    const double g = std::sqrt(2.0 * gT.x[it] / alpha);
    for (int iu = 0; iu < nU; ++iu) {
      const double u = lU.x[iu], su = std::sqrt(std::max(0.0, 1.0 - u * u));
      const double wTU = gpref * gT.w[it] * 0.5 * lU.w[iu];
      int row = 0;
      for (int a = 0; a < nV; ++a)
        for (int b = 0; b < nY; ++b)
          for (int c = 0; c < nV; ++c) {
            const double Vx = sV * hV.x[a], Vy = sV * yx[b], Vz = sV * hV.x[c];
            const double sw = std::sqrt(wTU * hV.w[a] * yw[b] * hV.w[c]);
            const double vx = Vx, vy = Vy, vz = Vz + alpha * g;           // pre-collision
            const double wx = Vx + alpha * g * su, wy = Vy, wz = Vz + alpha * g * u;  // post
            sonine32(0.5 * (vx * vx + vy * vy + vz * vz), N, Sp.data());
            sonine32(0.5 * (wx * wx + wy * wy + wz * wz), N, Sq.data());
            for (int p = 0; p < N; ++p) {
              B(row, p) = sw * (wx * Sq[p] - vx * Sp[p]);
              B(row + 1, p) = sw * (wy * Sq[p] - vy * Sp[p]);
              B(row + 2, p) = sw * (wz * Sq[p] - vz * Sp[p]);
            }
            row += 3;
          }
      // C -= (1/6) B^T B, lower triangle only (symmetric rank-k update).
      C.selfadjointView<Eigen::Lower>().rankUpdate(B.transpose(), -1.0 / 6.0);
    }
  }
  return C.selfadjointView<Eigen::Lower>();
}

// <c_z^2 S_p^2>_M = (4/(3 sqrt(pi))) Gamma(p+5/2)/p!  (Sonine orthogonality, weight x^{3/2} e^{-x}).
double gram_diag(int p) {
  return 4.0 / (3.0 * std::sqrt(kPi)) * std::exp(std::lgamma(p + 2.5) - std::lgamma(p + 1.0));
}

}  // namespace

double background_mass(double alpha, double mass) {
  check_alpha(alpha);
  check_positive(mass, "The grain mass m");
  return alpha * mass / (1.0 - alpha);
}

double friction_rate_per_nB(double alpha, double mass, double T, double TB) {
  check_alpha(alpha);
  check_positive(mass, "The grain mass m");
  check_positive(T, "The grain temperature T");
  check_positive(TB, "The background temperature TB");
  // docs/hydro.md eq. H3 (Bisi-Spiga eq. 26, linear part of the momentum source).
  return (8.0 / 3.0) * std::sqrt(2.0 / kPi) * alpha *
         std::sqrt(((1.0 - alpha) * TB + alpha * T) / (alpha * mass));
}

double diffusion_coefficient_paper(double alpha, double mass, double nB, double TB, double eps) {
  check_positive(nB, "The background density nB");
  check_positive(eps, "eps");
  // Bisi-Spiga eq. 35/36 == docs/hydro.md eq. H6: D = eps TB/(m nB nu1).
  return eps * TB / (mass * nB * friction_rate_per_nB(alpha, mass, TB, TB));
}

std::vector<SonineGalerkin> sonine_galerkin_sequence(double alpha, int N) {
  check_alpha(alpha);
  if (N < 1 || N > 40) throw std::invalid_argument("The Sonine order N must lie in 1..40.");
  const Eigen::MatrixXd C = galerkin_matrix(alpha, N);
  Eigen::VectorXd gram(N);
  for (int p = 0; p < N; ++p) gram(p) = gram_diag(p);
  std::vector<SonineGalerkin> out;
  for (int n = 1; n <= N; ++n) {
    SonineGalerkin s;
    s.alpha = alpha;
    s.order = n;
    s.collision = C.topLeftCorner(n, n);
    s.gram = gram.head(n);
    // -C is symmetric positive definite (H-theorem for the linear operator), eq. H11-H12.
    Eigen::LDLT<Eigen::MatrixXd> ldlt(-s.collision);
    Eigen::VectorXd b0 = Eigen::VectorXd::Zero(n);
    b0(0) = gram(0);
    const Eigen::VectorXd a0 = -ldlt.solve(b0);  // C a0 = b0
    s.Dhat = -a0(0) * gram(0);
    if (n >= 2) {
      Eigen::VectorXd b1 = Eigen::VectorXd::Zero(n);
      b1(1) = gram(1);
      const Eigen::VectorXd a1 = -ldlt.solve(b1);
      s.K1 = -a1(0) * gram(0);
    }
    out.push_back(std::move(s));
  }
  return out;
}

KineticTransport kinetic_transport(double alpha, double rel_tol, int max_order) {
  check_alpha(alpha);
  if (max_order < 3 || max_order > 40)
    throw std::invalid_argument("max_order for the Sonine-Galerkin solution must lie in 3..40.");
  if (!(rel_tol > 0.0)) throw std::invalid_argument("rel_tol must be positive.");
  static std::mutex mu;
  static std::map<std::tuple<double, double, int>, KineticTransport> cache;
  const auto key = std::make_tuple(alpha, rel_tol, max_order);
  {
    std::lock_guard<std::mutex> lock(mu);
    auto it = cache.find(key);
    if (it != cache.end()) return it->second;
  }
  // The bases are nested, so one N x N matrix gives every smaller order; grow N geometrically.
  // Convergence criterion: two successive orders change Dhat (relative) and p (absolute) by
  // less than rel_tol.
  KineticTransport k;
  for (int N = std::min(8, max_order);; N = std::min(2 * N, max_order)) {
    const auto seq = sonine_galerkin_sequence(alpha, N);
    int found = 0;
    for (int n = 3; n <= N && !found; ++n) {
      const double dD = std::abs(seq[n - 1].Dhat / seq[n - 2].Dhat - 1.0);
      const double dp = std::abs(seq[n - 1].p() - seq[n - 2].p());
      if (dD < rel_tol && dp < rel_tol) found = n;
    }
    const int n = found ? found : N;
    k.Dhat = seq[n - 1].Dhat;
    k.p = seq[n - 1].p();
    k.order = n;
    k.change = std::max(std::abs(seq[n - 1].Dhat / seq[n - 2].Dhat - 1.0),
                        std::abs(seq[n - 1].p() - seq[n - 2].p()));
    k.converged = found != 0;
    if (found || N >= max_order) break;
  }
  std::lock_guard<std::mutex> lock(mu);
  cache[key] = k;
  return k;
}

double diffusion_coefficient_kinetic(double alpha, double mass, double nB, double TB, double eps,
                                     int sonine_order) {
  check_positive(mass, "The grain mass m");
  check_positive(nB, "The background density nB");
  check_positive(TB, "The background temperature TB");
  check_positive(eps, "eps");
  if (sonine_order < 0) throw std::invalid_argument("sonine_order must be >= 0 (0 = converged).");
  const double Dhat = sonine_order == 0 ? kinetic_transport(alpha).Dhat
                                        : sonine_galerkin_sequence(alpha, sonine_order).back().Dhat;
  return eps * Dhat * std::sqrt(TB / mass) / nB;  // docs/hydro.md eq. H8
}

double thermal_diffusion_exponent_kinetic(double alpha, int sonine_order) {
  if (sonine_order < 0) throw std::invalid_argument("sonine_order must be >= 0 (0 = converged).");
  return sonine_order == 0 ? kinetic_transport(alpha).p
                           : sonine_galerkin_sequence(alpha, sonine_order).back().p();
}

double thermal_diffusion_factor_kinetic(double alpha, int sonine_order) {
  return thermal_diffusion_exponent_kinetic(alpha, sonine_order) - 1.0;
}

double DriftDiffusionCoefficients::mass_ratio() const { return (1.0 - alpha) / alpha; }

double DriftDiffusionCoefficients::D(double nB, double TB) const {
  return eps * Dhat * std::sqrt(TB / mass) / nB;
}

DriftDiffusionCoefficients paper_coefficients(double alpha, double mass, double eps) {
  check_alpha(alpha);
  check_positive(mass, "The grain mass m");
  check_positive(eps, "eps");
  DriftDiffusionCoefficients c;
  c.alpha = alpha;
  c.mass = mass;
  c.eps = eps;
  c.Dhat = 0.375 * std::sqrt(kPi / (2.0 * alpha));  // docs/hydro.md eq. H6
  c.p = 1.0;
  c.name = "paper";
  return c;
}

DriftDiffusionCoefficients kinetic_coefficients(double alpha, double mass, double eps,
                                                int sonine_order) {
  check_alpha(alpha);
  check_positive(mass, "The grain mass m");
  check_positive(eps, "eps");
  if (sonine_order < 0) throw std::invalid_argument("sonine_order must be >= 0 (0 = converged).");
  DriftDiffusionCoefficients c;
  c.alpha = alpha;
  c.mass = mass;
  c.eps = eps;
  if (sonine_order == 0) {
    const KineticTransport k = kinetic_transport(alpha);
    c.Dhat = k.Dhat;
    c.p = k.p;
    c.sonine_order = k.order;
    c.converged = k.converged;
  } else {
    const SonineGalerkin s = sonine_galerkin_sequence(alpha, sonine_order).back();
    c.Dhat = s.Dhat;
    c.p = s.p();
    c.sonine_order = sonine_order;
    c.converged = false;  // a fixed truncation, not a converged value
  }
  c.name = "kinetic";
  return c;
}

}  // namespace grainbath::hydro
