#include "dsmc/mode_fit.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace grainbath::dsmc {

ModeDecayFit fit_mode_decay(const std::vector<double>& t, const std::vector<double>& A, double noise_variance,
                            double from, double to) {
  ModeDecayFit f;
  std::vector<double> x, y;
  for (std::size_t k = 0; k < t.size() && k < A.size(); ++k)
    if (t[k] >= from && t[k] <= to && std::isfinite(A[k])) {
      x.push_back(t[k]);
      y.push_back(A[k]);
    }
  const std::size_t n = x.size();
  f.points = n;
  if (n < 3) return f;
  // start: a straight line through ln A of the samples well above the noise (A > 5 sqrt(var))
  double S = 0, Sx = 0, Sy = 0, Sxx = 0, Sxy = 0;
  for (std::size_t k = 0; k < n; ++k)
    if (y[k] > 5 * std::sqrt(noise_variance)) {
      const double w = y[k] * y[k], ly = std::log(y[k]);  // weights 1/var(ln A) ~ A^2
      S += w, Sx += w * x[k], Sy += w * ly, Sxx += w * x[k] * x[k], Sxy += w * x[k] * ly;
    }
  double G = 0.0, B = 0.0;
  const double D0 = S * Sxx - Sx * Sx;
  if (S > 0 && D0 > 0) {
    G = -(S * Sxy - Sx * Sy) / D0;
    B = std::exp((Sxx * Sy - Sx * Sxy) / D0);
  } else {  // nothing above the noise: start from the first sample and no decay
    B = y[0];
  }
  // Gauss-Newton on the residuals y - B exp(-G x), halving a step that does not lower them
  auto cost = [&](double b, double g) {
    double c = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const double r = y[k] - b * std::exp(-g * x[k]);
      c += r * r;
    }
    return c;
  };
  double c = cost(B, G);
  bool converged = false;
  for (int it = 0; it < 100 && !converged; ++it) {
    double a11 = 0, a12 = 0, a22 = 0, g1 = 0, g2 = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const double e = std::exp(-G * x[k]);
      const double jb = e, jg = -x[k] * B * e, r = y[k] - B * e;
      a11 += jb * jb, a12 += jb * jg, a22 += jg * jg, g1 += jb * r, g2 += jg * r;
    }
    const double det = a11 * a22 - a12 * a12;
    if (!(det > 0)) break;
    const double dB = (a22 * g1 - a12 * g2) / det, dG = (a11 * g2 - a12 * g1) / det;
    // the Gauss-Newton step itself is negligible: at the minimum (to ~1e-10 of the rate; the
    // cost no longer resolves such steps)
    if (std::abs(dG) <= 1e-10 * (std::abs(G) + 1e-12) && std::abs(dB) <= 1e-10 * std::abs(B)) {
      B += dB, G += dG;
      converged = true;
      break;
    }
    double lambda = 1.0, cn = cost(B + dB, G + dG);
    while (!(cn <= c) && lambda > 1e-6) {
      lambda *= 0.5;
      cn = cost(B + lambda * dB, G + lambda * dG);
    }
    if (!(cn <= c)) {
      // no step lowers the cost: at the minimum if the step is below what the cost resolves
      // (its relative rounding ~1e-16 resolves parameter steps of ~1e-8), else give up
      converged = std::abs(dG) <= 1e-7 * (std::abs(G) + 1e-12) && std::abs(dB) <= 1e-7 * std::abs(B);
      break;
    }
    B += lambda * dB, G += lambda * dG, c = cn;
  }
  if (!converged || !std::isfinite(G) || !std::isfinite(B)) return f;
  f.rate = G;
  f.amplitude = B;
  // sandwich: Cov(B, G) = M^-1 (J^T C J) M^-1, C_kl = var exp(-G |x_k - x_l|)
  std::vector<double> jb(n), jg(n);
  double m11 = 0, m12 = 0, m22 = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double e = std::exp(-G * x[k]);
    jb[k] = e, jg[k] = -x[k] * B * e;
    m11 += jb[k] * jb[k], m12 += jb[k] * jg[k], m22 += jg[k] * jg[k];
  }
  // (C v)_k / var = sum_l exp(-G |x_k - x_l|) v_l for sorted x in O(n): a forward and a
  // backward exponential sweep, the diagonal counted once
  auto kernel = [&](const std::vector<double>& v) {
    std::vector<double> fw(n), bw(n), out(n);
    for (std::size_t k = 0; k < n; ++k) fw[k] = v[k] + (k ? std::exp(-std::abs(G) * (x[k] - x[k - 1])) * fw[k - 1] : 0.0);
    for (std::size_t k = n; k-- > 0;)
      bw[k] = v[k] + (k + 1 < n ? std::exp(-std::abs(G) * (x[k + 1] - x[k])) * bw[k + 1] : 0.0);
    for (std::size_t k = 0; k < n; ++k) out[k] = fw[k] + bw[k] - v[k];
    return out;
  };
  const std::vector<double> Cb = kernel(jb), Cg = kernel(jg);
  double c11 = 0, c12 = 0, c22 = 0;  // J^T C J / var
  for (std::size_t k = 0; k < n; ++k) c11 += jb[k] * Cb[k], c12 += jb[k] * Cg[k], c22 += jg[k] * Cg[k];
  const double det = m11 * m22 - m12 * m12;
  // the G row of M^-1: (-m12, m11) / det
  const double u1 = -m12 / det, u2 = m11 / det;
  const double varG = noise_variance * (u1 * u1 * c11 + 2 * u1 * u2 * c12 + u2 * u2 * c22);
  f.rate_stderr = std::sqrt(varG);
  return f;
}

}  // namespace grainbath::dsmc

namespace grainbath::dsmc {

double slow_mode_error(const std::vector<double>& x, const std::vector<double>& w, const std::vector<double>& r,
                       double length, double cell_width, double grains, double diffusion, double window) {
  if (x.size() != w.size() || x.size() != r.size() || !(length > 0) || !(grains > 0) || !(diffusion > 0) ||
      !(window > 0))
    return std::nan("");
  const int modes = std::max(1, static_cast<int>(std::lround(length / cell_width)) / 2);
  double var = 0.0;
  for (int m = 1; m <= modes; ++m) {
    const double q = 2.0 * std::numbers::pi * m / length, u = diffusion * q * q * window;
    const double f = u > 1e-8 ? (2.0 / u) * (1.0 - (1.0 - std::exp(-u)) / u) : 1.0;  // window-mean variance factor
    const double hq = 0.5 * q * cell_width, sinc = hq > 0 ? std::sin(hq) / hq : 1.0;
    double c = 0.0, s = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      c += w[i] * std::cos(q * x[i]) / r[i];
      s += w[i] * std::sin(q * x[i]) / r[i];
    }
    var += (2.0 / grains) * f * sinc * sinc * (c * c + s * s);
  }
  return std::sqrt(var);
}

}  // namespace grainbath::dsmc
