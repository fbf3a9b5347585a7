// Sonine-corrected closure: collision terms by quadrature of the collision rule
// (docs/closures.md Sec. S).
#include "closures/sonine.hpp"

#include <gsl/gsl_integration.h>

#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <vector>

#include "closures/closures.hpp"
#include "closures/root_finding.hpp"

namespace grainbath::closures {
namespace {
constexpr double kPi = 3.14159265358979323846;

struct Rule {
  std::vector<double> x, w;
};

// Gauss-Legendre on [a, b], split into `panels` equal panels of n nodes.
// (Use n that GSL tabulates: 2..20, 32, 64, 96, 100, 128, ...; see sonine_background.)
Rule gauss_legendre(int n, double a, double b, int panels = 1) {
  Rule r;
  std::unique_ptr<gsl_integration_glfixed_table, decltype(&gsl_integration_glfixed_table_free)> t(
      gsl_integration_glfixed_table_alloc(n), &gsl_integration_glfixed_table_free);
  const double h = (b - a) / panels;
  for (int k = 0; k < panels; ++k)
    for (int i = 0; i < n; ++i) {
      double xi, wi;
      gsl_integration_glfixed_point(a + k * h, a + (k + 1) * h, i, &xi, &wi, t.get());
      r.x.push_back(xi);
      r.w.push_back(wi);
    }
  return r;
}

// GSL fixed rules: Gauss-Jacobi on [0,1] with weight x^beta, Gauss-Hermite with e^{-x^2}.
Rule gsl_fixed(const gsl_integration_fixed_type* type, int n, double a, double b, double alpha,
               double beta) {
  std::unique_ptr<gsl_integration_fixed_workspace, decltype(&gsl_integration_fixed_free)> ws(
      gsl_integration_fixed_alloc(type, n, a, b, alpha, beta), &gsl_integration_fixed_free);
  if (!ws) throw ClosureError("sonine closure: could not build a GSL quadrature rule");
  const double* x = gsl_integration_fixed_nodes(ws.get());
  const double* w = gsl_integration_fixed_weights(ws.get());
  return {std::vector<double>(x, x + n), std::vector<double>(w, w + n)};
}

double sonine_S2(double x) { return 0.5 * x * x - 2.5 * x + 1.875; }  // docs eq. S1

double binom(int n, int k) {
  double r = 1.0;
  for (int i = 1; i <= k; ++i) r = r * (n - k + i) / i;
  return r;
}

// docs eq. S7: grain-grain moments in units T/m = 1, as coefficients of a2^p b^j,
// b = beta (T/m)^{delta/2}:  d<c^2>/dt = n th^{3/2} sum I2[p][j] a2^p b^j, same for c^4 (th^{5/2}).
struct GrainGrainTable {
  double I2[3][5] = {};
  double I4[3][5] = {};
};

GrainGrainTable build_grain_grain_table(double delta) {
  GrainGrainTable tab;
  // Centre-of-mass velocity G ~ N(0, I/2): 7-point Gauss-Hermite per axis is exact for the
  // degree <= 10 polynomials that occur (weight degree 8 times collision factor degree 2).
  const Rule gh = gsl_fixed(gsl_integration_fixed_hermite, 7, 0.0, 1.0, 0.0, 0.0);
  // |g| ~ radial part of N(0, 2I): density r^2 exp(-r^2/4) / (2 sqrt(pi)); r^{j delta} makes
  // the integrand non-polynomial, so use panelled Gauss-Legendre up to r = 14 (e^{-49}).
  const Rule rr = gauss_legendre(32, 0.0, 14.0, 4);
  struct Node {
    double G[3];
    double w;
  };
  std::vector<Node> gnodes;
  for (int a = 0; a < 7; ++a)
    for (int b = 0; b < 7; ++b)
      for (int c = 0; c < 7; ++c)
        gnodes.push_back({{gh.x[a], gh.x[b], gh.x[c]},
                          gh.w[a] * gh.w[b] * gh.w[c] / std::pow(kPi, 1.5)});
  for (int j = 0; j <= 4; ++j) {
    // mu = |g.n|/|g| in [0,1]; weight mu^{j delta} from |g.n|^{j delta} (Gauss-Jacobi, exact
    // for the remaining polynomial in mu of degree <= 9).
    const Rule mr = gsl_fixed(gsl_integration_fixed_jacobi, 8, 0.0, 1.0, 0.0, j * delta);
    for (size_t ir = 0; ir < rr.x.size(); ++ir) {
      const double r = rr.x[ir];
      const double pr = rr.w[ir] * r * r * std::exp(-0.25 * r * r) / (2.0 * std::sqrt(kPi));
      for (size_t im = 0; im < mr.x.size(); ++im) {
        const double mu = mr.x[im];
        const double q = r * mu;  // g.n
        const double n[3] = {std::sqrt(1.0 - mu * mu), 0.0, mu};  // g = r z_hat
        double F2[3][5] = {}, F4[3][5] = {};
        for (const Node& nd : gnodes) {
          const double G2 = nd.G[0] * nd.G[0] + nd.G[1] * nd.G[1] + nd.G[2] * nd.G[2];
          const double Gg = r * nd.G[2];
          const double Gn = nd.G[0] * n[0] + nd.G[2] * n[2];
          const double Sv = sonine_S2(0.5 * (G2 + Gg + 0.25 * r * r));  // c_v = G + g/2
          const double Sw = sonine_S2(0.5 * (G2 - Gg + 0.25 * r * r));  // c_w = G - g/2
          const double wp[3] = {nd.w, nd.w * (Sv + Sw), nd.w * Sv * Sw};
          const double X = G2 + 0.25 * r * r;
          // docs eq. S6: (1/2) Delta(c_v^4 + c_w^4) as a polynomial in lambda = (1+e)/2
          const double c4[5] = {0.0, -2.0 * q * q * X - 4.0 * q * Gn * Gg,
                                2.0 * q * q * X + q * q * q * q + 4.0 * q * q * Gn * Gn,
                                -2.0 * q * q * q * q, q * q * q * q};
          // (1/2) Delta(c_v^2 + c_w^2) = (lambda^2 - lambda) q^2
          const double c2[5] = {0.0, -q * q, q * q, 0.0, 0.0};
          for (int p = 0; p < 3; ++p)
            for (int k = 1; k <= 4; ++k) {
              F2[p][k] += wp[p] * c2[k];
              F4[p][k] += wp[p] * c4[k];
            }
        }
        // Angular measure |g.n|/(2 pi) d2n over S^2 = 2 r mu dmu (mu in [0,1]; azimuth
        // trivial after the isotropic G average); lambda^k = sum_j C(k,j) (-b)^j (r mu)^{j delta}.
        const double w = pr * 2.0 * r * mr.w[im] * mu * std::pow(r, j * delta) * ((j % 2) ? -1.0 : 1.0);
        for (int p = 0; p < 3; ++p)
          for (int k = std::max(j, 1); k <= 4; ++k) {
            tab.I2[p][j] += w * binom(k, j) * F2[p][k];
            tab.I4[p][j] += w * binom(k, j) * F4[p][k];
          }
      }
    }
  }
  return tab;
}

const GrainGrainTable& grain_grain_table(double delta) {
  static std::mutex mtx;
  static std::map<double, std::unique_ptr<GrainGrainTable>> cache;
  std::lock_guard<std::mutex> lock(mtx);
  auto& slot = cache[delta];
  if (!slot) slot = std::make_unique<GrainGrainTable>(build_grain_grain_table(delta));
  return *slot;
}

double dot(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
}  // namespace

SonineMoments sonine_grain_grain(const Parameters& p, double T, double a2) {
  SonineMoments out;
  // No shortcut for beta = 0: elastic grain-grain collisions conserve <c^2> but relax a2.
  const GrainGrainTable& tab = grain_grain_table(p.delta);
  const double th = T / p.mass;
  const double b = p.beta * std::pow(th, 0.5 * p.delta);
  double s2 = 0.0, s4 = 0.0, ap = 1.0;
  for (int pp = 0; pp < 3; ++pp, ap *= a2) {
    double bj = 1.0;
    for (int j = 0; j <= 4; ++j, bj *= b) {
      s2 += ap * bj * tab.I2[pp][j];
      s4 += ap * bj * tab.I4[pp][j];
    }
  }
  out.dc2_dt = p.n * std::pow(th, 1.5) * s2;
  out.dc4_dt = p.n * std::pow(th, 2.5) * s4;
  return out;
}

SonineMoments sonine_background(const Parameters& p, const std::array<double, 3>& u, double T,
                                double a2) {
  const double th = T / p.mass, thB = p.TB / background_mass(p);
  const double sqB = std::sqrt(thB);
  std::array<double, 3> U{u[0] - p.uB[0], u[1] - p.uB[1], u[2] - p.uB[2]};
  const double Umag = std::sqrt(dot(U, U));
  // Axis along U (any axis if U = 0) and a perpendicular unit vector.
  std::array<double, 3> e1{0.0, 0.0, 1.0}, e2{1.0, 0.0, 0.0};
  if (Umag > 0.0) {
    e1 = {U[0] / Umag, U[1] / Umag, U[2] / Umag};
    std::array<double, 3> t = std::abs(e1[0]) < 0.9 ? std::array<double, 3>{1, 0, 0}
                                                    : std::array<double, 3>{0, 1, 0};
    const double d = dot(t, e1);
    for (int i = 0; i < 3; ++i) t[i] -= d * e1[i];
    const double tn = std::sqrt(dot(t, t));
    for (int i = 0; i < 3; ++i) e2[i] = t[i] / tn;
  }
  // |c| on [0, 13 sqrt(th)] (e^{-84} beyond), mu = cos(c, U) on [-1,1]; at U = 0 the
  // integrand is isotropic and one direction carries the whole sphere (weight 2).
  // Only node counts that GSL tabulates to full precision are used (2-20, 32, 64, 96, 100,
  // 128, ...); other counts are computed on the fly with ~1e-12 errors in the weights.
  static const Rule rho_rule = gauss_legendre(32, 0.0, 13.0, 3);
  // The integrand is entire in mu; the background moments grow like exp(A^2/2) off the real
  // axis, i.e. like exp(x mu) with x = rho |U|/thB, and rho reaches ~8 sqrt(th) where the
  // c-Gaussian still matters. The node count grows with x; the thresholds were set so that the
  // a2 = 0 case reproduces the closed-form exchange (C5, C6) to 1e-12 up to |U| = 3 s and
  // T/TB from 0.3 to 3 (test Sonine.ReducesToMaxwellianClosureAtZeroA2).
  static const Rule mu8 = gauss_legendre(8, -1.0, 1.0), mu16 = gauss_legendre(16, -1.0, 1.0),
                    mu32 = gauss_legendre(32, -1.0, 1.0), mu64 = gauss_legendre(64, -1.0, 1.0),
                    mu96 = gauss_legendre(96, -1.0, 1.0);
  static const Rule iso{{1.0}, {2.0}};
  const double x = 8.0 * Umag * std::sqrt(th) / thB;
  const Rule& mr = (Umag == 0.0) ? iso
                   : x < 0.5     ? mu8
                   : x < 2.0     ? mu16
                   : x < 8.0     ? mu32
                   : x < 24.0    ? mu64
                                 : mu96;
  const double alpha = p.alpha;
  // once, not at each of the up to 32 x 96 nodes: std::pow is a libm call that GCC does not
  // hoist (errno), a fifth of the quadrature's time; the same values, so the same sums
  const double alpha3 = std::pow(alpha, 3), alpha4 = std::pow(alpha, 4);
  double mom = 0.0, d2 = 0.0, d4 = 0.0;
  const double norm = 2.0 * kPi * std::pow(2.0 * kPi, -1.5);  // azimuth * Gaussian normalisation
  for (size_t ir = 0; ir < rho_rule.x.size(); ++ir) {
    const double rt = rho_rule.x[ir];                     // |c|/sqrt(th)
    const double rho = rt * std::sqrt(th);
    const double W = 1.0 + a2 * sonine_S2(0.5 * rt * rt);  // docs eq. S1
    const double wr = rho_rule.w[ir] * rt * rt * std::exp(-0.5 * rt * rt) * W * norm;
    for (size_t im = 0; im < mr.x.size(); ++im) {
      const double mu = mr.x[im], sn = std::sqrt(std::max(0.0, 1.0 - mu * mu));
      const double w = wr * mr.w[im];
      std::array<double, 3> c;
      for (int i = 0; i < 3; ++i) c[i] = rho * (mu * e1[i] + sn * e2[i]);
      std::array<double, 3> a;  // g | c ~ N(c + U, thB I):  x = g/sqrt(thB) ~ N(a, I)
      for (int i = 0; i < 3; ++i) a[i] = (c[i] + U[i]) / sqB;
      const double A = std::sqrt(dot(a, a));
      const ChiMoments135 cm = noncentral_chi_moments_135(A);
      const RadialMoment &m1 = cm.m1, &m3 = cm.m3, &m5 = cm.m5;
      const double c2 = rho * rho, ac = dot(a, c);
      // docs eq. C4 (Stein): E|g|^k, E[|g| g], E[|g|^3 g], E[|g| g g^T] contracted with c
      const double Eg3 = thB * sqB * m3.value, Eg5 = thB * thB * sqB * m5.value;
      const double F1 = m1.value + m1.d1_over_A;  // E[|x| x] = F1 a
      const double F3 = m3.value + m3.d1_over_A;  // E[|x|^3 x] = F3 a
      const double T2 = (A > 0.0) ? A * A * m1.value + 2.0 * A * m1.d1 + m1.d2 - m1.d1_over_A : 0.0;
      const double ahc = (A > 0.0) ? ac / A : 0.0;  // a_hat . c
      const double E_g_c = thB * ac * F1;                                  // E[|g| g.c]
      const double E_g3_c = thB * thB * ac * F3;                           // E[|g|^3 g.c]
      const double E_g_cc = thB * sqB * (F1 * c2 + T2 * ahc * ahc);        // E[|g| (g.c)^2]
      const double E_g_U = thB * dot(a, e1) * F1;                          // E[|g| g].U_hat
      // docs eq. S3: angular averages of the elastic rule v' = v - 2 alpha (g.n) n
      mom += w * (-alpha * E_g_U);
      d2 += w * (-2.0 * alpha * E_g_c + 2.0 * alpha * alpha * Eg3);
      d4 += w * (4.0 * alpha * alpha * E_g_cc + (16.0 / 3.0) * alpha * alpha * c2 * Eg3 +
                 (16.0 / 3.0) * alpha4 * Eg5 - 4.0 * alpha * c2 * E_g_c -
                 (32.0 / 3.0) * alpha3 * E_g3_c);
    }
  }
  const double rate = p.nB / p.eps;
  SonineMoments out;
  if (Umag > 0.0)
    for (int i = 0; i < 3; ++i) out.du_dt[i] = rate * mom * e1[i];
  out.dc2_dt = rate * d2;
  out.dc4_dt = rate * d4;
  return out;
}

MomentSources sonine_sources(const Parameters& p, const RelaxationState& st) {
  if (!(st.T > 0.0) || !std::isfinite(st.T) || !std::isfinite(st.a2))
    throw ClosureError("sonine_sources: T must be finite and > 0 and a2 finite");
  const SonineMoments bg = sonine_background(p, st.u, st.T, st.a2);
  const SonineMoments gg = sonine_grain_grain(p, st.T, st.a2);
  const double th = st.T / p.mass;
  MomentSources m;
  m.du_dt = bg.du_dt;
  // docs eqs. S8, S9: T = m <c^2>/3 and a2 = <c^4>/(15 th^2) - 1, with <c^2 c> = 0 in the ansatz so
  // the moving frame c = v - u(t) adds no term.
  m.dT_dt = p.mass * (bg.dc2_dt + gg.dc2_dt) / 3.0;
  m.da2_dt = (bg.dc4_dt + gg.dc4_dt) / (15.0 * th * th) - 2.0 * (1.0 + st.a2) * m.dT_dt / st.T;
  return m;
}

SonineEquilibrium equilibrium_sonine(const Parameters& p) {
  validate(p);
  // T# of the Gaussian closures is validated first: it checks e >= 0 at thermal speeds and
  // that an equilibrium exists at all.
  const double TM = equilibrium_temperature_gaussian(Closure::maxwellian, p);
  if (p.beta == 0.0) return {p.TB, 0.0};  // f = M_TB(v - uB) is then an exact equilibrium
  auto a2_of_T = [&](double T) {
    auto g = [&](double a2) { return sonine_sources(p, {p.uB, T, a2}).da2_dt; };
    // da2/dt decreases through the root (the background and elastic collisions relax a2).
    // Strong dissipation with a heavy background drives a2 well above 0.1, so the bracket is
    // widened geometrically; a2 > 0.8 makes the ansatz negative near x = 5/2 (docs Sec. S.4).
    double lo = -0.45, hi = 0.45;
    while (g(lo) < 0.0 && lo > -0.95) lo = 0.5 * (lo - 1.0);
    while (g(hi) > 0.0 && hi < 20.0) hi *= 2.0;
    if (g(hi) > 0.0) {
      std::ostringstream os;
      os << "the sonine closure has no steady state for these parameters: da2/dt > 0 for every "
            "a2 up to "
         << hi << " at T = " << T
         << " (the fourth cumulant grows without bound; dissipation eps n/nB * "
            "restitution.beta = "
         << p.eps * p.n / p.nB * p.beta << " is too strong for a Sonine description)";
      throw ClosureError(os.str());
    }
    return brent_root(g, lo, hi, 1e-14, "equilibrium_sonine (a2 at fixed T)");
  };
  auto f = [&](double T) { return sonine_sources(p, {p.uB, T, a2_of_T(T)}).dT_dt; };
  // The Sonine T# lies within a few percent of (TB - T#) of the Maxwellian one.
  double lo = TM - 0.5 * (p.TB - TM), hi = std::min(p.TB, TM + 0.5 * (p.TB - TM));
  if (!(lo > 0.0)) lo = 0.5 * TM;
  for (int k = 0; k < 8 && f(lo) <= 0.0; ++k) lo = 0.5 * lo;
  if (f(hi) >= 0.0) hi = p.TB;
  const double T = brent_root(f, lo, hi, 1e-14, "equilibrium_sonine (T)");
  return {T, a2_of_T(T)};
}

}  // namespace grainbath::closures
