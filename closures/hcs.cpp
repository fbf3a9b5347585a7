// Homogeneous cooling state beyond the first Sonine approximation (docs/closures.md Sec. H).
#include "closures/hcs.hpp"

#include <gsl/gsl_integration.h>

#include <cmath>
#include <memory>
#include <sstream>
#include <utility>
#include <vector>

#include "closures/closures.hpp"

namespace grainbath::closures {
namespace {
constexpr double kPi = 3.14159265358979323846;

struct Rule {
  std::vector<double> x, w;
};

// GSL fixed rules (Hermite: weight e^{-x^2} on R; Laguerre: e^{-x} on [0, inf);
// Legendre: 1 on [a, b]).
Rule gsl_fixed(const gsl_integration_fixed_type* type, int n, double a, double b) {
  std::unique_ptr<gsl_integration_fixed_workspace, decltype(&gsl_integration_fixed_free)> ws(
      gsl_integration_fixed_alloc(type, n, a, b, 0.0, 0.0), &gsl_integration_fixed_free);
  if (!ws) throw ClosureError("hcs: could not build a GSL quadrature rule");
  const double* x = gsl_integration_fixed_nodes(ws.get());
  const double* w = gsl_integration_fixed_weights(ws.get());
  return {std::vector<double>(x, x + n), std::vector<double>(w, w + n)};
}

double S2(double x) { return x * x / 2.0 - 2.5 * x + 15.0 / 8.0; }                      // docs eq. H1
double S3(double x) { return -x * x * x / 6.0 + 1.75 * x * x - 35.0 / 8.0 * x + 35.0 / 16.0; }  // H1

// mu_p = sum_{k=1}^{p} lambda^k sum_t table[p/2-1][k][t] m_t(a2, a3), m = {1, a2, a3, a2^2, a2 a3, a3^2}
struct Table {
  double c[3][7][6] = {};
};

// docs eq. H5. Weak form: mu_p = -(1/2) ∫∫ f(c1) f(c2) ∫_{g.n>0} (g.n) Delta(c1^p + c2^p) d2n,
// g = c1 - c2, c1' = c1 - lambda (g.n) n, c2' = c2 + lambda (g.n) n. Under phi(c1) phi(c2),
// G = (c1 + c2)/2 ~ N(0, I/4) and g ~ N(0, I) are independent. Put g = r z_hat, n at polar
// angle acos(mu) in the x-z plane (the azimuth of n is trivial once G is integrated over its
// isotropic Gaussian), u = r^2/2. The integrand is a polynomial: in G of degree <= 18 (the
// weights S3 S3 carry 12, Delta c^6 six), in u of degree <= 10 times e^{-u} (only even powers
// of r survive the G average, and r^2 dr (g.n) = 2 u mu du), in mu of degree <= 8. Hence
// 10-point Gauss-Hermite per axis, 12-point Gauss-Laguerre and 10-point Gauss-Legendre are
// exact (to round-off); the test HcsMoments.QuadratureIsConverged checks that more nodes
// change nothing.
Table build_table(int n_hermite, int n_laguerre, int n_legendre) {
  Table tab;
  const Rule gh = gsl_fixed(gsl_integration_fixed_hermite, n_hermite, 0.0, 1.0);
  const Rule gl = gsl_fixed(gsl_integration_fixed_laguerre, n_laguerre, 0.0, 1.0);
  const Rule lg = gsl_fixed(gsl_integration_fixed_legendre, n_legendre, 0.0, 1.0);
  struct GNode {
    double x, y, z, w;
  };
  std::vector<GNode> gn;
  const double s = 1.0 / std::sqrt(2.0), wn = 1.0 / std::sqrt(kPi);  // N(0, 1/4) per axis
  for (std::size_t a = 0; a < gh.x.size(); ++a)
    for (std::size_t b = 0; b < gh.x.size(); ++b)
      for (std::size_t c = 0; c < gh.x.size(); ++c)
        gn.push_back({s * gh.x[a], s * gh.x[b], s * gh.x[c], gh.w[a] * gh.w[b] * gh.w[c] * wn * wn * wn});
  // g density (2 pi)^{-3/2} e^{-r^2/2} 4 pi r^2 dr; hemisphere d2n = 2 pi dmu
  const double norm = std::pow(2.0 * kPi, -1.5) * 4.0 * kPi * 2.0 * kPi;
  for (std::size_t iu = 0; iu < gl.x.size(); ++iu) {
    const double u = gl.x[iu], r = std::sqrt(2.0 * u);
    for (std::size_t im = 0; im < lg.x.size(); ++im) {
      const double mu = lg.x[im], sn = std::sqrt(1.0 - mu * mu), q = r * mu;  // q = g.n
      // r^2 dr = r du; times the collision factor (g.n); the -(1/2) of the weak form
      const double wq = -0.5 * norm * gl.w[iu] * lg.w[im] * r * q;
      for (const GNode& G : gn) {
        const double z1 = G.z + 0.5 * r, z2 = G.z - 0.5 * r;
        const double x1 = G.x * G.x + G.y * G.y + z1 * z1, x2 = G.x * G.x + G.y * G.y + z2 * z2;
        const double c1n = G.x * sn + z1 * mu, c2n = G.x * sn + z2 * mu;
        const double s21 = S2(x1), s22 = S2(x2), s31 = S3(x1), s32 = S3(x2);
        const double m[6] = {1.0, s21 + s22, s31 + s32, s21 * s22, s21 * s32 + s31 * s22, s31 * s32};
        // c1'^2 = x1 - 2 lambda q c1n + lambda^2 q^2 (and c2 with +): coefficients in lambda
        const double A1[3] = {x1, -2.0 * q * c1n, q * q}, A2[3] = {x2, 2.0 * q * c2n, q * q};
        double P1[7] = {1.0}, P2[7] = {1.0};  // (c1'^2)^k, (c2'^2)^k as polynomials in lambda
        for (int k = 1; k <= 3; ++k) {
          double N1[7] = {}, N2[7] = {};
          for (int i = 0; i <= 2 * (k - 1); ++i)
            for (int j = 0; j < 3; ++j) {
              N1[i + j] += P1[i] * A1[j];
              N2[i + j] += P2[i] * A2[j];
            }
          for (int i = 0; i < 7; ++i) P1[i] = N1[i], P2[i] = N2[i];
          // Delta(c1^{2k} + c2^{2k}): the lambda^0 term is the pre-collision value and cancels
          for (int l = 1; l <= 2 * k; ++l) {
            const double d = G.w * wq * (P1[l] + P2[l]);
            for (int t = 0; t < 6; ++t) tab.c[k - 1][l][t] += d * m[t];
          }
        }
      }
    }
  }
  return tab;
}

// docs Sec. H.8: the linear hierarchy to order 6. lin.c[k][l][t]: coefficient of lambda^l in
// mu_{2k} (k = 1..6) for the weight t = 0 (1) or t = j (S_j(x1) + S_j(x2), j = 2..6). Degrees:
// <= 24 in G (S_6: 12, Delta c^12: 12), <= 13 in u, <= 14 in mu, so 14 Hermite nodes per axis,
// 16 Laguerre and 14 Legendre are exact.
constexpr int kMaxOrder = 6;
struct LinearTable {
  double c[kMaxOrder + 1][2 * kMaxOrder + 1][kMaxOrder + 1] = {};
};

// S_j = L_j^{(1/2)} by the three-term recurrence (j <= 6)
void sonine_all(double x, double* S) {
  S[0] = 1.0;
  S[1] = 1.5 - x;
  for (int j = 1; j < kMaxOrder; ++j) S[j + 1] = ((2 * j + 1.5 - x) * S[j] - (j + 0.5) * S[j - 1]) / (j + 1);
}

LinearTable build_linear_table() {
  auto tab = std::make_unique<LinearTable>();
  const Rule gh = gsl_fixed(gsl_integration_fixed_hermite, 14, 0.0, 1.0);
  const Rule gl = gsl_fixed(gsl_integration_fixed_laguerre, 16, 0.0, 1.0);
  const Rule lg = gsl_fixed(gsl_integration_fixed_legendre, 14, 0.0, 1.0);
  const double s = 1.0 / std::sqrt(2.0), wn = 1.0 / std::sqrt(kPi);
  const double norm = std::pow(2.0 * kPi, -1.5) * 4.0 * kPi * 2.0 * kPi;
  for (std::size_t iu = 0; iu < gl.x.size(); ++iu) {
    const double u = gl.x[iu], r = std::sqrt(2.0 * u);
    for (std::size_t im = 0; im < lg.x.size(); ++im) {
      const double mu = lg.x[im], sn = std::sqrt(1.0 - mu * mu), q = r * mu;
      const double wq = -0.5 * norm * gl.w[iu] * lg.w[im] * r * q;
      for (std::size_t a = 0; a < gh.x.size(); ++a)
        for (std::size_t b = 0; b < gh.x.size(); ++b)
          for (std::size_t c = 0; c < gh.x.size(); ++c) {
            const double Gx = s * gh.x[a], Gy = s * gh.x[b], Gz = s * gh.x[c];
            const double w = wq * gh.w[a] * gh.w[b] * gh.w[c] * wn * wn * wn;
            const double z1 = Gz + 0.5 * r, z2 = Gz - 0.5 * r;
            const double x1 = Gx * Gx + Gy * Gy + z1 * z1, x2 = Gx * Gx + Gy * Gy + z2 * z2;
            const double c1n = Gx * sn + z1 * mu, c2n = Gx * sn + z2 * mu;
            double S1[kMaxOrder + 1], S2v[kMaxOrder + 1], W[kMaxOrder + 1];
            sonine_all(x1, S1);
            sonine_all(x2, S2v);
            W[0] = 1.0;
            W[1] = 0.0;  // S_1 is not in the expansion (it would shift T)
            for (int j = 2; j <= kMaxOrder; ++j) W[j] = S1[j] + S2v[j];
            const double A1[3] = {x1, -2.0 * q * c1n, q * q}, A2[3] = {x2, 2.0 * q * c2n, q * q};
            double P1[2 * kMaxOrder + 1] = {1.0}, P2[2 * kMaxOrder + 1] = {1.0};
            for (int k = 1; k <= kMaxOrder; ++k) {
              double N1[2 * kMaxOrder + 1] = {}, N2[2 * kMaxOrder + 1] = {};
              for (int i = 0; i <= 2 * (k - 1); ++i)
                for (int j = 0; j < 3; ++j) {
                  N1[i + j] += P1[i] * A1[j];
                  N2[i + j] += P2[i] * A2[j];
                }
              for (int i = 0; i <= 2 * k; ++i) P1[i] = N1[i], P2[i] = N2[i];
              for (int l = 1; l <= 2 * k; ++l) {
                const double d = w * (P1[l] + P2[l]);
                for (int t = 0; t <= kMaxOrder; ++t) tab->c[k][l][t] += d * W[t];
              }
            }
          }
    }
  }
  return *tab;
}

const Table& table() {
  static const Table tab = build_table(10, 12, 10);  // thread-safe static initialisation
  return tab;
}

void check_e(double e) {
  if (!(e >= 0.0 && e <= 1.0)) {
    std::ostringstream os;
    os << "homogeneous cooling state: restitution e = " << e << " is outside [0, 1]";
    throw ClosureError(os.str());
  }
}

std::array<double, 6> coefficients(const Table& tab, int p, double e) {
  const double lambda = 0.5 * (1.0 + e);
  std::array<double, 6> out{};
  double lk = 1.0;
  for (int k = 0; k <= p; ++k, lk *= lambda)
    for (int t = 0; t < 6; ++t) out[t] += lk * tab.c[p / 2 - 1][k][t];
  return out;
}

double evaluate(const std::array<double, 6>& c, double a2, double a3) {
  return c[0] + c[1] * a2 + c[2] * a3 + c[3] * a2 * a2 + c[4] * a2 * a3 + c[5] * a3 * a3;
}
}  // namespace

// exposed for the convergence test only (tests/closures/test_hcs.cpp)
HcsCollisionMoments hcs_collision_moments_with_nodes(double e, int n_hermite, int n_laguerre, int n_legendre) {
  check_e(e);
  const Table tab = build_table(n_hermite, n_laguerre, n_legendre);
  return {coefficients(tab, 2, e), coefficients(tab, 4, e), coefficients(tab, 6, e)};
}

HcsCollisionMoments hcs_collision_moments(double e) {
  check_e(e);
  return {coefficients(table(), 2, e), coefficients(table(), 4, e), coefficients(table(), 6, e)};
}

double hcs_collision_moment(int p, double e, double a2, double a3) {
  if (p != 2 && p != 4 && p != 6) throw ClosureError("hcs_collision_moment: p must be 2, 4 or 6");
  check_e(e);
  return evaluate(coefficients(table(), p, e), a2, a3);
}

// docs eq. H4: the scaled state is steady when mu_p = (p/3) mu_2 <c^p>, i.e.
//   E4 = mu_4 - 5 mu_2 (1 + a2) = 0,   E6 = mu_6 - (105/4) mu_2 (1 + 3 a2 - a3) = 0.
double hcs_a2_first_sonine(double e) {
  const HcsCollisionMoments m = hcs_collision_moments(e);
  // docs eq. H7: E4 to first order in a2 with a3 = 0
  return -(m.mu4[0] - 5.0 * m.mu2[0]) / (m.mu4[1] - 5.0 * (m.mu2[0] + m.mu2[1]));
}

HcsSonine hcs_sonine2_linear(double e) {
  check_e(e);
  if (e == 1.0) return {0.0, 0.0};  // elastic: the Maxwellian (without building the table)
  const HcsCollisionMoments m = hcs_collision_moments(e);
  // docs eq. H8: E4 and E6 to first order in (a2, a3)
  const double A = m.mu4[1] - 5.0 * (m.mu2[0] + m.mu2[1]), B = m.mu4[2] - 5.0 * m.mu2[2];
  const double C = m.mu6[1] - 26.25 * (3.0 * m.mu2[0] + m.mu2[1]), D = m.mu6[2] - 26.25 * (m.mu2[2] - m.mu2[0]);
  const double r4 = -(m.mu4[0] - 5.0 * m.mu2[0]), r6 = -(m.mu6[0] - 26.25 * m.mu2[0]);
  const double det = A * D - B * C;
  if (e == 1.0 || det == 0.0) return {0.0, 0.0};  // elastic: the Maxwellian
  return {(r4 * D - B * r6) / det, (A * r6 - C * r4) / det};
}

HcsSonine hcs_sonine2_nonlinear(double e) {
  check_e(e);
  if (e == 1.0) return {0.0, 0.0};
  const HcsCollisionMoments m = hcs_collision_moments(e);
  // docs eq. H9: Newton on (E4, E6) with the full quadratic mu_p and the analytic Jacobian.
  // Divided by mu_2(0,0) ~ (1 - e^2) so the tolerance is relative.
  const double scale = m.mu2[0];
  HcsSonine s = hcs_sonine2_linear(e);
  auto d_a2 = [](const std::array<double, 6>& c, double a2, double a3) { return c[1] + 2 * c[3] * a2 + c[4] * a3; };
  auto d_a3 = [](const std::array<double, 6>& c, double a2, double a3) { return c[2] + c[4] * a2 + 2 * c[5] * a3; };
  for (int it = 0; it < 60; ++it) {
    const double m2 = evaluate(m.mu2, s.a2, s.a3), m4 = evaluate(m.mu4, s.a2, s.a3), m6 = evaluate(m.mu6, s.a2, s.a3);
    const double w4 = 1.0 + s.a2, w6 = 1.0 + 3.0 * s.a2 - s.a3;
    const double E4 = (m4 - 5.0 * m2 * w4) / scale, E6 = (m6 - 26.25 * m2 * w6) / scale;
    const double J11 = (d_a2(m.mu4, s.a2, s.a3) - 5.0 * (d_a2(m.mu2, s.a2, s.a3) * w4 + m2)) / scale;
    const double J12 = (d_a3(m.mu4, s.a2, s.a3) - 5.0 * d_a3(m.mu2, s.a2, s.a3) * w4) / scale;
    const double J21 = (d_a2(m.mu6, s.a2, s.a3) - 26.25 * (d_a2(m.mu2, s.a2, s.a3) * w6 + 3.0 * m2)) / scale;
    const double J22 = (d_a3(m.mu6, s.a2, s.a3) - 26.25 * (d_a3(m.mu2, s.a2, s.a3) * w6 - m2)) / scale;
    const double det = J11 * J22 - J12 * J21;
    const double da2 = -(E4 * J22 - J12 * E6) / det, da3 = -(J11 * E6 - J21 * E4) / det;
    s.a2 += da2;
    s.a3 += da3;
    if (std::abs(da2) + std::abs(da3) < 1e-14) return s;
  }
  std::ostringstream os;
  os << "hcs_sonine2_nonlinear: Newton did not converge at e = " << e;
  throw ClosureError(os.str());
}

std::vector<double> hcs_sonine_linear(double e, int K) {
  check_e(e);
  if (K < 2 || K > kMaxOrder) throw ClosureError("hcs_sonine_linear: K must be 2 ... 6");
  // elastic: the Maxwellian, before the tables (their first build takes ~0.1 s, which every
  // elastic DSMC run paid for nothing in its theory values)
  if (e == 1.0) return std::vector<double>(K - 1, 0.0);
  static const LinearTable lin = build_linear_table();
  const double lambda = 0.5 * (1.0 + e);
  auto C = [&](int k, int t) {  // coefficient of mu_{2k} for weight t at this e
    double v = 0.0, lk = 1.0;
    for (int l = 0; l <= 2 * k; ++l, lk *= lambda) v += lk * lin.c[k][l][t];
    return v;
  };
  // <x^k S_j> under phi (x = c^2, density x^{1/2} e^{-x} / Gamma(3/2)): 20-point generalised
  // Gauss-Laguerre, exact for the degree <= 12 polynomials
  static const Rule gla = [] {
    std::unique_ptr<gsl_integration_fixed_workspace, decltype(&gsl_integration_fixed_free)> ws(
        gsl_integration_fixed_alloc(gsl_integration_fixed_laguerre, 20, 0.0, 1.0, 0.5, 0.0),
        &gsl_integration_fixed_free);
    const double* x = gsl_integration_fixed_nodes(ws.get());
    const double* w = gsl_integration_fixed_weights(ws.get());
    Rule r{std::vector<double>(x, x + 20), std::vector<double>(w, w + 20)};
    double sum = 0.0;
    for (double wi : r.w) sum += wi;
    for (double& wi : r.w) wi /= sum;
    return r;
  }();
  auto moment = [&](int k, int j) {  // <x^k S_j> (j = 0: <x^k>)
    double v = 0.0;
    for (std::size_t i = 0; i < gla.x.size(); ++i) {
      double S[kMaxOrder + 1];
      sonine_all(gla.x[i], S);
      v += gla.w[i] * std::pow(gla.x[i], k) * S[j];
    }
    return v;
  };
  // E_k = mu_{2k} - (2k/3) mu_2 <x^k> to first order in the a_j (docs eq. H4 for every k)
  const int n = K - 1;
  std::vector<double> A(n * n), rhs(n);
  for (int k = 2; k <= K; ++k) {
    const double f = 2.0 * k / 3.0, m0 = moment(k, 0);
    rhs[k - 2] = -(C(k, 0) - f * C(1, 0) * m0);
    for (int j = 2; j <= K; ++j) A[(k - 2) * n + (j - 2)] = C(k, j) - f * (C(1, 0) * moment(k, j) + C(1, j) * m0);
  }
  // Gaussian elimination with partial pivoting (n <= 5)
  for (int c = 0; c < n; ++c) {
    int p = c;
    for (int r = c + 1; r < n; ++r)
      if (std::abs(A[r * n + c]) > std::abs(A[p * n + c])) p = r;
    for (int j = 0; j < n; ++j) std::swap(A[c * n + j], A[p * n + j]);
    std::swap(rhs[c], rhs[p]);
    for (int r = c + 1; r < n; ++r) {
      const double m = A[r * n + c] / A[c * n + c];
      for (int j = c; j < n; ++j) A[r * n + j] -= m * A[c * n + j];
      rhs[r] -= m * rhs[c];
    }
  }
  std::vector<double> a(n);
  for (int r = n - 1; r >= 0; --r) {
    double v = rhs[r];
    for (int j = r + 1; j < n; ++j) v -= A[r * n + j] * a[j];
    a[r] = v / A[r * n + r];
  }
  return a;
}

double hcs_cooling_rate_ratio(const HcsSonine& s) {
  // docs eq. H10: every coefficient of mu_2 carries the factor (1 - e^2) sqrt(2 pi), so the
  // ratio does not depend on e.
  return 1.0 + 3.0 * s.a2 / 16.0 + s.a3 / 64.0 + 9.0 * s.a2 * s.a2 / 1024.0 + 15.0 * s.a2 * s.a3 / 2048.0 +
         35.0 * s.a3 * s.a3 / 16384.0;
}

}  // namespace grainbath::closures
