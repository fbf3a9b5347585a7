// Transport coefficients of the drift-diffusion limit: the paper's first-Sonine value
// (Bisi-Spiga eqs. 33-36, docs/hydro.md eqs. H3-H6) and the Sonine-Galerkin kinetic values
// (docs/hydro.md eqs. H9-H13).
#include "hydro/hydro.hpp"
#include "hydro/quadrature.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

using namespace grainbath::hydro;
constexpr double kPi = std::numbers::pi;

namespace {
// E[|g| g_z] for g ~ N(Delta z, s2 I) by 2D quadrature in spherical coordinates.
double momentum_transfer_z(double Delta, double s2) {
  const double s = std::sqrt(s2);
  const auto gr = quad::gauss_legendre(240, 0.0, Delta + 14.0 * s);
  const auto mu = quad::gauss_legendre(96, -1.0, 1.0);
  double acc = 0.0;
  for (std::size_t i = 0; i < gr.x.size(); ++i)
    for (std::size_t j = 0; j < mu.x.size(); ++j) {
      const double g = gr.x[i], c = mu.x[j];
      const double rho = std::pow(2.0 * kPi * s2, -1.5) *
                         std::exp(-(g * g - 2.0 * g * Delta * c + Delta * Delta) / (2.0 * s2));
      acc += gr.w[i] * mu.w[j] * 2.0 * kPi * g * g * rho * g * (g * c);
    }
  return acc;
}

// A key of hydro_theory_values(); a missing key fails the test.
double theory_value(const std::vector<std::pair<std::string, double>>& values, const std::string& key) {
  for (const auto& [k, x] : values)
    if (k == key) return x;
  ADD_FAILURE() << "missing " << key;
  return 0.0;
}
}  // namespace

// Bisi-Spiga eq. 18: du/dt = -(nB/eps) alpha E[|g| g]; for small drift this is -(nB/eps) nu1
// (u - uB) with nu1 of docs/hydro.md eq. H3. Checked against direct quadrature, T != TB too.
TEST(HydroTransport, FrictionRateMatchesDirectQuadrature) {
  for (double alpha : {0.2, 0.5, 0.8}) {
    for (double T : {0.7, 1.0, 1.6}) {
      const double m = 1.3, TB = 1.1;
      const double mB = background_mass(alpha, m);
      const double s2 = T / m + TB / mB;
      const double Delta = 1e-4 * std::sqrt(s2);
      const double nu_quad = alpha * momentum_transfer_z(Delta, s2) / Delta;
      EXPECT_NEAR(friction_rate_per_nB(alpha, m, T, TB) / nu_quad, 1.0, 1e-7)
          << "alpha=" << alpha << " T=" << T;
    }
  }
}

// The drift coefficient of eq. 35 must equal Chapman-Cowling's first approximation for binary
// diffusion of a tracer in hard spheres, [D12]_1 = 3/(8 nB sigma12^2) sqrt(TB/(2 pi mu)), with
// the cross-section pi sigma12^2 = 1 (scaled units), reduced mass mu = alpha m and the 1/eps
// collision rate. The brief's reading "3/(8 alpha nB)" of eq. 35 is off by sqrt(alpha): the
// extracted text "eps sqrt alpha 8 nB" is 3/(8 sqrt(alpha) nB) (docs/hydro.md sec. 1.3).
TEST(HydroTransport, PaperDiffusionCoefficientIsChapmanCowlingFirstApproximation) {
  for (double alpha : {0.1, 0.5, 0.9}) {
    const double m = 2.0, nB = 3.0, TB = 1.7, eps = 0.05;
    const double sigma2 = 1.0 / kPi, mu = alpha * m;
    const double cc = eps * 3.0 / (8.0 * nB * sigma2) * std::sqrt(TB / (2.0 * kPi * mu));
    const double D = diffusion_coefficient_paper(alpha, m, nB, TB, eps);
    EXPECT_NEAR(D / cc, 1.0, 1e-14);
    // Printed form of eq. 36: eps (3/8) sqrt(m pi/(2 alpha)) /(nB sqrt(TB)) * TB/m.
    const double eq36 = eps * 0.375 * std::sqrt(m * kPi / (2.0 * alpha)) / (nB * std::sqrt(TB)) * TB / m;
    EXPECT_NEAR(D / eq36, 1.0, 1e-14);
    const double brief = eps * 3.0 / (8.0 * alpha * nB) * std::sqrt(m * kPi / (2.0 * TB)) * TB / m;
    EXPECT_GT(std::abs(D / brief - 1.0), 0.05);  // the misreading is not what we implement
  }
}

// C_00 = -nu1 (reduced units) and the first-Sonine Galerkin value equals the paper's.
TEST(HydroTransport, GalerkinFirstOrderIsPaperValue) {
  for (double alpha : {0.05, 0.3, 0.5, 0.7, 0.95}) {
    const auto s = sonine_galerkin_sequence(alpha, 1).front();
    EXPECT_NEAR(-s.collision(0, 0) / friction_rate_per_nB(alpha, 1.0, 1.0, 1.0), 1.0, 1e-13);
    EXPECT_NEAR(s.Dhat / paper_coefficients(alpha, 1.0, 1.0).Dhat, 1.0, 1e-13);
    EXPECT_DOUBLE_EQ(s.p(), 1.0);
    EXPECT_NEAR(diffusion_coefficient_kinetic(alpha, 1.0, 2.0, 1.5, 0.1, 1),
                diffusion_coefficient_paper(alpha, 1.0, 2.0, 1.5, 0.1), 1e-14);
  }
}

// The quadrature is exact for the polynomial integrand: the N = 4 matrix (rules of sizes
// 8/8/5) equals the leading block of the N = 9 matrix (18/18/10); the matrix is symmetric and
// negative definite (H-theorem of the linear operator).
TEST(HydroTransport, GalerkinMatrixIsExactSymmetricNegativeDefinite) {
  const double alpha = 0.6;
  const auto a = sonine_galerkin_sequence(alpha, 4).back().collision;
  const auto b = sonine_galerkin_sequence(alpha, 9).back().collision;
  EXPECT_LT((a - b.topLeftCorner(4, 4)).cwiseAbs().maxCoeff(), 1e-11 * b.cwiseAbs().maxCoeff());
  EXPECT_LT((b - b.transpose()).cwiseAbs().maxCoeff(), 1e-14);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(b);
  EXPECT_LT(es.eigenvalues().maxCoeff(), 0.0);
}

// Independent check of the matrix through the collision rule itself (not the centre-of-mass
// isotropy used by the quadrature): Monte Carlo of the weak form
// C_pq = E_{v~M, w~MB}[ |g| (S_p(v') v'_z - S_p(v) v_z) S_q(v) v_z ] with the apse vector
// sampled from |g.n|/(2 pi |g|) and v' = v - 2 alpha (g.n) n.
TEST(HydroTransport, GalerkinMatrixMatchesMonteCarloOfCollisionRule) {
  const double alpha = 0.4, mB = alpha / (1.0 - alpha);
  const auto C = sonine_galerkin_sequence(alpha, 3).back().collision;
  std::mt19937_64 rng(20261122);
  auto uni = [&] { return (static_cast<double>(rng() >> 11) + 0.5) * 0x1.0p-53; };
  auto normal = [&] {
    const double u1 = uni(), u2 = uni();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  };
  auto S = [](int p, double x) {
    if (p == 0) return 1.0;
    if (p == 1) return 2.5 - x;
    return 0.5 * x * x - 3.5 * x + 35.0 / 8.0;  // L_2^{(3/2)}
  };
  const int M = 400000;
  double sum[3][3] = {}, sum2[3][3] = {};
  for (int s = 0; s < M; ++s) {
    double v[3], w[3], g[3];
    for (int a = 0; a < 3; ++a) {
      v[a] = normal();
      w[a] = normal() / std::sqrt(mB);
      g[a] = v[a] - w[a];
    }
    const double gn = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    // n-hat with density |g.n|/(2 pi g): cos(theta) to g has density |c| on [-1,1].
    const double c = (uni() < 0.5 ? -1.0 : 1.0) * std::sqrt(uni());
    const double ph = 2.0 * kPi * uni();
    double e1[3], e2[3], gh[3] = {g[0] / gn, g[1] / gn, g[2] / gn};
    const double t[3] = {std::abs(gh[0]) < 0.9 ? 1.0 : 0.0, std::abs(gh[0]) < 0.9 ? 0.0 : 1.0, 0.0};
    e1[0] = gh[1] * t[2] - gh[2] * t[1];
    e1[1] = gh[2] * t[0] - gh[0] * t[2];
    e1[2] = gh[0] * t[1] - gh[1] * t[0];
    const double ne = std::sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    for (double& x : e1) x /= ne;
    e2[0] = gh[1] * e1[2] - gh[2] * e1[1];
    e2[1] = gh[2] * e1[0] - gh[0] * e1[2];
    e2[2] = gh[0] * e1[1] - gh[1] * e1[0];
    const double sn = std::sqrt(1.0 - c * c);
    double nv[3], vp[3];
    for (int a = 0; a < 3; ++a) nv[a] = c * gh[a] + sn * (std::cos(ph) * e1[a] + std::sin(ph) * e2[a]);
    const double gdotn = g[0] * nv[0] + g[1] * nv[1] + g[2] * nv[2];
    for (int a = 0; a < 3; ++a) vp[a] = v[a] - 2.0 * alpha * gdotn * nv[a];
    const double x = 0.5 * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    const double xp = 0.5 * (vp[0] * vp[0] + vp[1] * vp[1] + vp[2] * vp[2]);
    for (int p = 0; p < 3; ++p)
      for (int q = 0; q < 3; ++q) {
        // Average over the three components (isotropy) to reduce variance.
        double val = 0.0;
        for (int a = 0; a < 3; ++a) val += (S(p, xp) * vp[a] - S(p, x) * v[a]) * S(q, x) * v[a];
        val *= gn / 3.0;
        sum[p][q] += val;
        sum2[p][q] += val * val;
      }
  }
  for (int p = 0; p < 3; ++p)
    for (int q = 0; q < 3; ++q) {
      const double mean = sum[p][q] / M;
      const double se = std::sqrt((sum2[p][q] / M - mean * mean) / M);
      EXPECT_NEAR(mean, C(p, q), 5.0 * se + 1e-12) << "p=" << p << " q=" << q << " se=" << se;
    }
}

// Lorentz limit alpha -> 1 (static infinitely heavy scatterers): L[c A] = -|c| c A exactly, so
// C_pq -> -<c_z^2 |c| S_p S_q>_M (1D quadrature, independent of the 9D reduction), and the
// exact solution A = -1/|c| gives Dhat = (1/3)<|c|> = (2/3) sqrt(2/pi) (i.e. 32/(9 pi) times
// the first-Sonine value) and p = 1/2 (docs/hydro.md eq. H18).
TEST(HydroTransport, LorentzLimit) {
  const double alpha = 1.0 - 1e-10;
  const int N = 6;
  const auto C = sonine_galerkin_sequence(alpha, N).back().collision;
  // <c_z^2 |c| S_p S_q> = (1/3) (2/sqrt(pi)) int x^{1/2} e^{-x} (2x) sqrt(2x) S_p S_q dx.
  const auto lag = quad::gauss_laguerre(20, 2.0);  // weight x^2 e^{-x}
  for (int p = 0; p < N; ++p)
    for (int q = 0; q < N; ++q) {
      double ref = 0.0;
      for (std::size_t i = 0; i < lag.x.size(); ++i) {
        const double x = lag.x[i];
        double Sp = 1, Sq = 1;
        {
          double s0 = 1.0, s1 = 2.5 - x;
          Sp = p == 0 ? s0 : s1;
          for (int r = 1; r < p; ++r) {
            const double s2 = ((2.0 * r + 2.5 - x) * s1 - (r + 1.5) * s0) / (r + 1.0);
            s0 = s1;
            s1 = s2;
            Sp = s1;
          }
          s0 = 1.0;
          s1 = 2.5 - x;
          Sq = q == 0 ? s0 : s1;
          for (int r = 1; r < q; ++r) {
            const double s2 = ((2.0 * r + 2.5 - x) * s1 - (r + 1.5) * s0) / (r + 1.0);
            s0 = s1;
            s1 = s2;
            Sq = s1;
          }
        }
        ref += lag.w[i] * Sp * Sq;
      }
      ref *= -(1.0 / 3.0) * (2.0 / std::sqrt(kPi)) * 2.0 * std::sqrt(2.0);
      EXPECT_NEAR(C(p, q), ref, 1e-6 * std::abs(C(0, 0))) << p << "," << q;
    }
  // Convergence towards the exact Lorentz values is monotone (slow: algebraic in N).
  const auto seq = sonine_galerkin_sequence(alpha, 12);
  const double Dexact = (2.0 / 3.0) * std::sqrt(2.0 / kPi);
  for (std::size_t n = 1; n < seq.size(); ++n) {
    EXPECT_GT(seq[n].Dhat, seq[n - 1].Dhat);
    EXPECT_LT(seq[n].Dhat, Dexact);
    EXPECT_LT(seq[n].p(), seq[n - 1].p());
    EXPECT_GT(seq[n].p(), 0.5);
  }
  std::printf("  Lorentz N=12: D/D_exact = %.6f, p = %.6f\n", seq.back().Dhat / Dexact, seq.back().p());
  EXPECT_NEAR(seq.back().Dhat / Dexact, 1.0, 4e-3);
  EXPECT_NEAR(seq.back().p(), 0.5, 6e-3);
}

// Convergence table N = 1..8 at alpha = 1/2 (self-diffusion of hard spheres): monotone,
// geometrically shrinking increments, ~1.9% above the first approximation.
TEST(HydroTransport, SonineConvergenceAtHalf) {
  const auto seq = sonine_galerkin_sequence(0.5, 8);
  const double D1 = seq.front().Dhat;
  double prev_inc = 1.0;
  for (std::size_t n = 1; n < seq.size(); ++n) {
    const double inc = seq[n].Dhat - seq[n - 1].Dhat;
    EXPECT_GT(inc, 0.0);
    EXPECT_LT(inc, 0.6 * prev_inc) << "N=" << n + 1;
    prev_inc = inc;
    std::printf("  alpha=0.5 N=%zu D_N/D_1=%.10f p_N=%.10f\n", n + 1, seq[n].Dhat / D1, seq[n].p());
  }
  EXPECT_NEAR(seq.back().Dhat / D1, 1.01895, 2e-5);
  EXPECT_NEAR(seq.back().p(), 0.81903, 2e-5);
  const KineticTransport k = kinetic_transport(0.5, 1e-7, 16);
  EXPECT_TRUE(k.converged);
  EXPECT_NEAR(k.Dhat / D1, 1.0189538, 1e-6);
}

// Rayleigh limit alpha -> 0 (heavy grain, Brownian): the first approximation becomes exact and
// p -> 1 (n TB = const, Bisi-Spiga's isobaric steady state).
TEST(HydroTransport, RayleighLimit) {
  double prev = 1.0;
  for (double alpha : {0.1, 0.01, 0.001}) {
    const auto k = kinetic_transport(alpha);
    EXPECT_TRUE(k.converged);
    const double ratio = k.Dhat / paper_coefficients(alpha, 1.0, 1.0).Dhat;
    EXPECT_GT(ratio, 1.0);
    EXPECT_LT(ratio - 1.0, 0.05 * alpha);
    EXPECT_LT(1.0 - k.p, 0.25 * alpha);
    EXPECT_LT(ratio - 1.0, prev);
    prev = ratio - 1.0;
  }
}

TEST(HydroTransport, BadInputThrows) {
  EXPECT_THROW(diffusion_coefficient_paper(1.0, 1.0, 1.0, 1.0, 0.1), std::invalid_argument);
  EXPECT_THROW(diffusion_coefficient_paper(0.5, 1.0, -1.0, 1.0, 0.1), std::invalid_argument);
  EXPECT_THROW(sonine_galerkin_sequence(0.5, 0), std::invalid_argument);
  EXPECT_THROW(diffusion_coefficient_kinetic(0.5, 1.0, 1.0, 1.0, 0.1, -2), std::invalid_argument);
  try {
    diffusion_coefficient_paper(0.0, 1.0, 1.0, 1.0, 0.1);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("alpha"), std::string::npos);
  }
}

TEST(HydroTransport, TheoryValuesKeys) {
  HydroTheoryParams p;
  p.alpha = 0.5;
  p.eps = 0.1;
  p.k = 2.0;
  const auto v = hydro_theory_values(p);
  auto get = [&](const std::string& key) { return theory_value(v, key); };
  EXPECT_NEAR(get("hydro.diffusion_coefficient"), diffusion_coefficient_paper(0.5, 1, 1, 1, 0.1), 1e-15);
  EXPECT_NEAR(get("hydro.diffusion_coefficient_kinetic") / get("hydro.diffusion_coefficient"), 1.01895, 2e-5);
  EXPECT_NEAR(get("hydro.decay_rate"), 4.0 * get("hydro.diffusion_coefficient"), 1e-15);
  EXPECT_NEAR(get("hydro.decay_rate_kinetic"), 4.0 * get("hydro.diffusion_coefficient_kinetic"), 1e-15);
}

// The closures' finite-eps density-mode keys (mutation audit 2026-12-06,
// docs/reviews/mutation-audit-closures-hydro.md): each key is the slowest mode of its own
// closure's linearised system (eq. H24) for the grains' restitution law, i.e. the eigenvalue of
// largest real part of closure_mode_eigenvalues; the three closures give different rates for
// inelastic grains (T# < TB), so a key wired to the wrong closure or to elastic grains shows.
TEST(HydroTransport, TheoryValuesClosureModeRatesAreTheirClosuresSlowestModes) {
  HydroTheoryParams p;
  p.alpha = 0.4;
  p.eps = 0.3;
  p.n = 1.5;
  p.beta = 0.12;
  p.delta = 0.0;
  p.k = 1.5;
  const auto v = hydro_theory_values(p);
  auto get = [&](const std::string& key) { return theory_value(v, key); };
  ModeParams mp;
  mp.alpha = p.alpha;
  mp.eps = p.eps;
  mp.n = p.n;
  mp.beta = p.beta;
  mp.delta = p.delta;
  const std::pair<const char*, grainbath::closures::Closure> cases[] = {
      {"hydro.decay_rate_maxwellian_closure", grainbath::closures::Closure::maxwellian},
      {"hydro.decay_rate_grad_closure", grainbath::closures::Closure::grad},
      {"hydro.decay_rate_sonine_closure", grainbath::closures::Closure::sonine}};
  double rates[3];
  for (int i = 0; i < 3; ++i) {
    double slowest = -1e300;
    for (const auto& l : closure_mode_eigenvalues(cases[i].second, mp, *p.k)) slowest = std::max(slowest, l.real());
    rates[i] = -slowest;
    std::printf("%s: key %.12f, slowest mode %.12f\n", cases[i].first, get(cases[i].first), rates[i]);
    EXPECT_NEAR(get(cases[i].first), rates[i], 1e-12 * rates[i]) << cases[i].first;
  }
  // the three differ (and differ from elastic grains) by much more than the tolerance above
  mp.beta = 0.0;
  const double elastic = -closure_mode_eigenvalues(grainbath::closures::Closure::maxwellian, mp, *p.k).front().real();
  std::printf("elastic maxwellian-closure rate %.12f\n", elastic);
  EXPECT_GT(std::abs(rates[1] / rates[0] - 1.0), 1e-6);
  EXPECT_GT(std::abs(rates[2] / rates[0] - 1.0), 1e-6);
  EXPECT_GT(std::abs(elastic / rates[0] - 1.0), 1e-4);
}

// Grain mass m != 1 (mutation audit 2026-12-06, docs/reviews/mutation-audit-closures-hydro.md;
// the DSMC output evaluates the kinetic D with the case's grain mass): the first-Sonine Galerkin
// value is the Chapman-Cowling first approximation at any m, which the paper coefficient
// matches (PaperDiffusionCoefficientIsChapmanCowlingFirstApproximation, m = 2), and the
// coefficient sets the solvers use give the same D. At fixed alpha the reduced mass alpha m
// is the only mass scale, so the converged kinetic D goes as m^(-1/2) as well.
TEST(HydroTransport, KineticDiffusionCoefficientAtGrainMassNotOne) {
  const double alpha = 0.35, nB = 1.6, TB = 2.2, eps = 0.07;
  for (double m : {0.4, 2.5}) {
    const double sigma2 = 1.0 / kPi, mu = alpha * m;  // Chapman-Cowling, as in the test above
    const double cc = eps * 3.0 / (8.0 * nB * sigma2) * std::sqrt(TB / (2.0 * kPi * mu));
    EXPECT_NEAR(diffusion_coefficient_kinetic(alpha, m, nB, TB, eps, 1) / cc, 1.0, 1e-12) << "m=" << m;
    EXPECT_NEAR(kinetic_coefficients(alpha, m, eps, 1).D(nB, TB) / cc, 1.0, 1e-12) << "m=" << m;
    EXPECT_NEAR(paper_coefficients(alpha, m, eps).D(nB, TB) / cc, 1.0, 1e-12) << "m=" << m;
    const double D1 = diffusion_coefficient_kinetic(alpha, 1.0, nB, TB, eps);
    EXPECT_NEAR(diffusion_coefficient_kinetic(alpha, m, nB, TB, eps) / D1, 1.0 / std::sqrt(m), 1e-12) << "m=" << m;
    EXPECT_NEAR(kinetic_coefficients(alpha, m, eps).D(nB, TB) / D1, 1.0 / std::sqrt(m), 1e-12) << "m=" << m;
  }
}
