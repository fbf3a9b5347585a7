// Non-central chi moments, docs/closures.md eqs. C2-C4.
#include "closures/gaussian_moments.hpp"

#include <cmath>
#include <stdexcept>

namespace grainbath::closures {
namespace {
constexpr double kSqrt2 = 1.41421356237309504880;
constexpr double kInvSqrt2Pi = 0.39894228040143267794;

double binomial(int n, int k) {
  double r = 1.0;
  for (int i = 1; i <= k; ++i) r = r * (n - k + i) / i;
  return r;
}
// E z^i for z ~ N(0,1): (i-1)!! for even i, 0 for odd i.
double normal_moment(int i) {
  if (i % 2) return 0.0;
  double r = 1.0;
  for (int q = i - 1; q > 1; q -= 2) r *= q;
  return r;
}
}  // namespace

double central_chi_moment(double y) {
  // E|z|^y = 2^{y/2} Gamma((y+3)/2)/Gamma(3/2)  (docs eq. C2 with A = 0)
  return std::exp(0.5 * y * std::log(2.0) + std::lgamma(0.5 * (y + 3.0)) - std::lgamma(1.5));
}

double signed_normal_moment(int j, double A) {
  // h_j = E[y^j] - 2 E[y^j ; y < 0], y = A + z. The truncated moments
  // M_i = E[z^i ; z < -A] obey M_0 = Phi(-A), M_1 = -phi(A),
  // M_i = (i-1) M_{i-2} - (-A)^{i-1} phi(A)   (integration by parts; docs eq. C3).
  const double phi = kInvSqrt2Pi * std::exp(-0.5 * A * A);
  double Mm2 = 0.5 * std::erfc(A / kSqrt2), Mm1 = -phi;
  double full = 0.0, lower = 0.0;
  for (int i = 0; i <= j; ++i) {
    double Mi;
    if (i == 0) Mi = Mm2;
    else if (i == 1) Mi = Mm1;
    else {
      Mi = (i - 1) * Mm2 - std::pow(-A, i - 1) * phi;
      Mm2 = Mm1;
      Mm1 = Mi;
    }
    const double c = binomial(j, i) * std::pow(A, j - i);
    full += c * normal_moment(i);
    lower += c * Mi;
  }
  return full - 2.0 * lower;
}

RadialMoment noncentral_chi_moment(int k, double A) {
  if (k < 1 || k > 7 || k % 2 == 0)
    throw std::invalid_argument("noncentral_chi_moment: k must be odd in 1..7");
  if (!(A >= 0.0) || !std::isfinite(A))
    throw std::invalid_argument("noncentral_chi_moment: A must be finite and >= 0");
  const double mu = central_chi_moment(k);
  if (A < 1.0) {
    // m_k = mu_k sum_n t_n A^{2n}, t_n = (-k/2)_n (-1/2)^n / ((3/2)_n n!)  (Kummer series,
    // docs eq. C2); all terms shrink like A^{2n}/(2^n n!) so 40 terms are far past 1e-17.
    double t = 1.0, sum = 1.0, d1a = 0.0, d2 = 0.0;
    double Apow = 1.0;  // A^{2n-2}
    for (int n = 1; n <= 40; ++n) {
      t *= (-0.5 * k + n - 1) * (-0.5) / ((1.5 + n - 1) * n);
      sum += t * Apow * A * A;
      d1a += 2.0 * n * t * Apow;
      d2 += 2.0 * n * (2.0 * n - 1) * t * Apow;
      Apow *= A * A;
    }
    return {mu * sum, mu * d1a * A, mu * d1a, mu * d2};
  }
  // Closed form (docs eq. C3): m = h_{k+1}/A, using h_j' = j h_{j-1}.
  const double hk1 = signed_normal_moment(k + 1, A);
  const double hk = signed_normal_moment(k, A);
  const double hkm1 = signed_normal_moment(k - 1, A);
  const double m = hk1 / A;
  const double d1 = (k + 1) * hk / A - hk1 / (A * A);
  const double d2 = (k + 1) * k * hkm1 / A - 2.0 * (k + 1) * hk / (A * A) + 2.0 * hk1 / (A * A * A);
  return {m, d1, d1 / A, d2};
}

ChiMoments135 noncentral_chi_moments_135(double A) {
  if (!(A >= 0.0) || !std::isfinite(A))
    throw std::invalid_argument("noncentral_chi_moments_135: A must be finite and >= 0");
  static const double mu[3] = {central_chi_moment(1), central_chi_moment(3), central_chi_moment(5)};
  static const int ks[3] = {1, 3, 5};
  ChiMoments135 out{};
  RadialMoment* res[3] = {&out.m1, &out.m3, &out.m5};
  if (A < 1.0) {
    // Kummer series (docs eq. C2), the three k together; terms fall like (A^2/2)^n/n!.
    const double A2 = A * A;
    for (int q = 0; q < 3; ++q) {
      const int k = ks[q];
      double t = 1.0, sum = 1.0, d1a = 0.0, d2 = 0.0, Apow = 1.0;
      for (int n = 1; n <= 40; ++n) {
        t *= (-0.5 * k + n - 1) * (-0.5) / ((1.5 + n - 1) * n);
        const double term = t * Apow;
        sum += term * A2;
        d1a += 2.0 * n * term;
        d2 += 2.0 * n * (2.0 * n - 1) * term;
        Apow *= A2;
        if (std::abs(term) < 1e-18 * (1.0 + std::abs(d2)) && n > 3) break;
      }
      *res[q] = {mu[q] * sum, mu[q] * d1a * A, mu[q] * d1a, mu[q] * d2};
    }
    return out;
  }
  // Closed form (docs eq. C3): h_j for j = 0..6 from one set of truncated moments M_i.
  const double phi = kInvSqrt2Pi * std::exp(-0.5 * A * A);
  double M[7], Apw[7], h[7];
  M[0] = 0.5 * std::erfc(A / kSqrt2);
  M[1] = -phi;
  Apw[0] = 1.0;
  for (int i = 1; i < 7; ++i) Apw[i] = Apw[i - 1] * A;
  for (int i = 2; i < 7; ++i) M[i] = (i - 1) * M[i - 2] - ((i - 1) % 2 ? -Apw[i - 1] : Apw[i - 1]) * phi;
  static const double C[7][7] = {{1}, {1, 1}, {1, 2, 1}, {1, 3, 3, 1}, {1, 4, 6, 4, 1},
                                 {1, 5, 10, 10, 5, 1}, {1, 6, 15, 20, 15, 6, 1}};
  static const double Ez[7] = {1, 0, 1, 0, 3, 0, 15};
  for (int j = 0; j < 7; ++j) {
    double full = 0.0, lower = 0.0;
    for (int i = 0; i <= j; ++i) {
      const double c = C[j][i] * Apw[j - i];
      full += c * Ez[i];
      lower += c * M[i];
    }
    h[j] = full - 2.0 * lower;
  }
  for (int q = 0; q < 3; ++q) {
    const int k = ks[q];
    const double m = h[k + 1] / A;
    const double d1 = (k + 1) * h[k] / A - h[k + 1] / (A * A);
    const double d2 = (k + 1) * k * h[k - 1] / A - 2.0 * (k + 1) * h[k] / (A * A) + 2.0 * h[k + 1] / (A * A * A);
    *res[q] = {m, d1, d1 / A, d2};
  }
  return out;
}

}  // namespace grainbath::closures
