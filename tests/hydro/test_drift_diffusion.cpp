// Drift-diffusion solvers of docs/hydro.md eq. H7 (Bisi-Spiga eq. 36 with paper or kinetic
// coefficients): exactness, mass conservation, convergence orders, spectral vs finite volume,
// well-balanced steady states, bad input.
#include "hydro/hydro.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <vector>

using namespace grainbath::hydro;
constexpr double kPi = std::numbers::pi;

namespace {
double max_abs_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}
double l2_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(s / a.size());
}
// Least-squares slope of log(err) against log(h).
double fitted_slope(const std::vector<double>& h, const std::vector<double>& err) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double n = static_cast<double>(h.size());
  for (std::size_t i = 0; i < h.size(); ++i) {
    const double x = std::log(h[i]), y = std::log(err[i]);
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
  }
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}
// Isobaric background along `axis` of a periodic or walled box of length 2 pi / k.
const DriftDiffusionCoefficients kPaper = paper_coefficients(0.5, 1.0, 0.2);
}  // namespace

// Uniform background with uniform drift: the ETD scheme is exact for any step.
TEST(HydroSpectral, UniformDriftIsExact) {
  const Grid g = Grid::make({32, 16}, {2 * kPi, kPi}, Boundary::Periodic);
  const std::array<double, 3> u{0.3, -0.2, 0.0};
  const Background bg = uniform_drift_background(g, 1.5, 0.8, u);
  SpectralSolver s(bg, kPaper);
  const double kx = 2.0, ky = 4.0;
  s.set_density(g.sample([&](double x, double y, double) { return 1.0 + 0.2 * std::cos(kx * x + ky * y); }));
  s.run_to(3.0, 1.0);
  const double D = kPaper.D(1.5, 0.8), t = 3.0;
  const auto exact = g.sample([&](double x, double y, double) {
    return 1.0 + 0.2 * std::exp(-D * (kx * kx + ky * ky) * t) * std::cos(kx * (x - u[0] * t) + ky * (y - u[1] * t));
  });
  std::printf("  spectral uniform-drift max error: %.2e\n", max_abs_diff(s.density(), exact));
  EXPECT_LT(max_abs_diff(s.density(), exact), 1e-13);
}

TEST(HydroSpectral, MassConservedToRoundOff) {
  const DriftDiffusionCoefficients kin = kinetic_coefficients(0.5, 1.0, 0.2);
  // Isobaric in y with shear U(y) in x: a steady Euler background (uB.grad TB = 0).
  const Grid g = Grid::make({32, 32}, {2 * kPi, 2 * kPi}, Boundary::Periodic);
  Background bg = isobaric_background(g, 1.0, 1.0, 0.5, 1.0, 1);
  for (int j = 0; j < g.n[1]; ++j)
    for (int i = 0; i < g.n[0]; ++i) bg.uB[0][g.index(i, j)] = 0.8 * std::cos(g.x(1, j));
  SpectralSolver s(bg, kin);
  s.set_density(g.sample([](double x, double y, double) { return 1.0 + 0.5 * std::sin(x) * std::cos(2 * y) + 0.2 * std::cos(3 * x); }));
  const double m0 = s.mass();
  s.run_to(5.0, 0.02);
  std::printf("  spectral mass drift after 250 steps: %.2e\n", s.mass() / m0 - 1.0);
  EXPECT_LT(std::abs(s.mass() / m0 - 1.0), 1e-13);
}

TEST(HydroFiniteVolume, MassConservedToRoundOff) {
  const DriftDiffusionCoefficients kin = kinetic_coefficients(0.5, 1.0, 0.2);
  for (Boundary b : {Boundary::Wall, Boundary::Periodic}) {
    const Grid g = Grid::make({24, 20, 6}, {2 * kPi, 2 * kPi, 1.0}, b);
    Background bg = isobaric_background(g, 1.0, 1.0, 0.5, 1.0, 1);
    for (int k = 0; k < g.n[2]; ++k)
      for (int j = 0; j < g.n[1]; ++j)
        for (int i = 0; i < g.n[0]; ++i) bg.uB[0][g.index(i, j, k)] = 0.8 * std::cos(g.x(1, j));
    FiniteVolumeSolver s(bg, kin);
    s.set_density(g.sample([](double x, double y, double z) { return 1.0 + 0.5 * std::sin(x) * std::cos(2 * y) + 0.1 * z; }));
    const double m0 = s.mass();
    s.run_to(5.0, 0.05);
    std::printf("  FV 3D mass drift after 100 steps (%s): %.2e\n", b == Boundary::Wall ? "walls" : "periodic", s.mass() / m0 - 1.0);
    EXPECT_LT(std::abs(s.mass() / m0 - 1.0), 1e-13);
  }
}

// Uniform background in a periodic box: finite volume decays a Fourier mode at the rate
// D k^2 (1 + O(h^2)) -- the discrete rate D (2 - 2 cos kh)/h^2 exactly with SG weights at zero
// drift, integrated by CN.
TEST(HydroFiniteVolume, UniformModeDecay) {
  const Grid g = Grid::make({64}, {2 * kPi}, Boundary::Periodic);
  const Background bg = uniform_background(g, 1.0, 1.0);
  FiniteVolumeSolver s(bg, kPaper);
  s.set_density(g.sample([](double x, double, double) { return 1.0 + 0.3 * std::cos(2 * x); }));
  const double D = kPaper.D(1.0, 1.0), h = g.h(0), dt = 0.01, T = 2.0;
  s.run_to(T, dt);
  const double lam = D * (2.0 - 2.0 * std::cos(2.0 * h)) / (h * h);
  const double amp = std::pow((1.0 - 0.5 * dt * lam) / (1.0 + 0.5 * dt * lam), T / dt);
  const auto exact = g.sample([&](double x, double, double) { return 1.0 + 0.3 * amp * std::cos(2 * x); });
  EXPECT_LT(max_abs_diff(s.density(), exact), 1e-12);
}

// Spatial order of the FV scheme (walled, isobaric, kinetic coefficients): successive
// differences ||n_h - R n_{h/2}|| fitted in log-log; CN with dt ~ h so time error is O(h^2) too.
TEST(HydroFiniteVolume, SecondOrderInSpace) {
  const DriftDiffusionCoefficients kin = kinetic_coefficients(0.5, 1.0, 0.5);
  auto solve = [&](int N) {
    const Grid g = Grid::make({N}, {2 * kPi}, Boundary::Wall);
    const Background bg = isobaric_background(g, 1.0, 1.0, 0.6, 1.0);
    FiniteVolumeSolver s(bg, kin);
    s.set_density(g.sample([](double x, double, double) { return 1.0 + 0.4 * std::cos(x) + 0.2 * std::cos(3 * x); }));
    s.run_to(1.0, 0.4 / N);
    return std::make_pair(g, s.density());
  };
  std::vector<double> hs, errs;
  auto prev = solve(16);
  for (int N : {32, 64, 128, 256}) {
    auto cur = solve(N);
    hs.push_back(2 * kPi / (N / 2));
    errs.push_back(l2_diff(prev.second, coarsen(cur.second, cur.first, prev.first)));
    prev = cur;
  }
  const double slope = fitted_slope(hs, errs);
  std::printf("  FV space: errors %.3e %.3e %.3e %.3e slope %.3f\n", errs[0], errs[1], errs[2], errs[3], slope);
  EXPECT_NEAR(slope, 2.0, 0.15);
}

// Time orders: CN 2, backward Euler 1 (FV); ETDRK2 2 (spectral, non-uniform background so the
// explicit part is active).
TEST(HydroTimeOrder, CrankNicolsonBackwardEulerEtdrk2) {
  const Grid gw = Grid::make({32}, {2 * kPi}, Boundary::Wall);
  const Grid gp = Grid::make({32}, {2 * kPi}, Boundary::Periodic);
  const Background bw = isobaric_background(gw, 1.0, 1.0, 0.6, 1.0);
  Background bp = isobaric_background(gp, 1.0, 1.0, 0.6, 1.0);
  for (std::size_t i = 0; i < gp.size(); ++i) bp.uB[0][i] = 0.3;  // plus a uniform drift
  const auto init = [](double x, double, double) { return 1.0 + 0.4 * std::cos(x) + 0.2 * std::sin(2 * x); };
  const DriftDiffusionCoefficients c = paper_coefficients(0.5, 1.0, 0.2);
  auto run = [&](int which, double dt) {
    std::unique_ptr<DriftDiffusionSolver> s;
    if (which == 0) s = std::make_unique<FiniteVolumeSolver>(bw, c, TimeScheme::CrankNicolson);
    if (which == 1) s = std::make_unique<FiniteVolumeSolver>(bw, c, TimeScheme::BackwardEuler);
    if (which == 2) s = std::make_unique<SpectralSolver>(bp, c);
    s->set_density(s->grid().sample(init));
    s->run_to(1.0, dt);
    return s->density();
  };
  const double expected[3] = {2.0, 1.0, 2.0};
  const char* names[3] = {"CN", "BE", "ETDRK2"};
  for (int which = 0; which < 3; ++which) {
    std::vector<double> dts, errs;
    auto prev = run(which, 0.04);
    for (double dt : {0.02, 0.01, 0.005, 0.0025}) {
      auto cur = run(which, dt);
      dts.push_back(2 * dt);
      errs.push_back(l2_diff(prev, cur));
      prev = cur;
    }
    const double slope = fitted_slope(dts, errs);
    std::printf("  %s time: errors %.3e %.3e %.3e %.3e slope %.3f\n", names[which], errs[0], errs[1], errs[2], errs[3], slope);
    EXPECT_NEAR(slope, expected[which], 0.15) << names[which];
  }
}

// Spectral accuracy in space, free of time error: ETD fixed points are exactly the discrete
// steady states (L u + N(u) = 0), and the exact steady state of the periodic isobaric problem
// is n = c TB^(-p) (docs/hydro.md eq. H7b). Errors fall faster than any power of h.
TEST(HydroSpectral, SpectralConvergenceInSpace) {
  const DriftDiffusionCoefficients kin = kinetic_coefficients(0.5, 1.0, 0.5);
  const double A = 0.6, L = 2 * kPi;
  // c from mass conservation (initial n = 1): c = L / int TB^(-p) dx (periodic trapezoid rule,
  // spectrally accurate).
  double I = 0.0;
  const int M = 4096;
  for (int j = 0; j < M; ++j) I += std::pow(1.0 + A * std::sin(L * j / M), -kin.p) * L / M;
  const double c = L / I;
  std::vector<double> errs;
  for (int N : {8, 16, 32, 64}) {
    const Grid g = Grid::make({N}, {L}, Boundary::Periodic);
    const Background bg = isobaric_background(g, 1.0, 1.0, A, 1.0);
    SpectralSolver s(bg, kin);
    s.set_density(std::vector<double>(g.size(), 1.0));
    s.run_to(400.0, 0.5);
    std::vector<double> exact(g.size());
    for (std::size_t i = 0; i < g.size(); ++i) exact[i] = c * std::pow(bg.TB[i], -kin.p);
    errs.push_back(max_abs_diff(s.density(), exact));
  }
  std::printf("  spectral space (steady state): N=8 %.3e N=16 %.3e N=32 %.3e N=64 %.3e\n", errs[0], errs[1], errs[2], errs[3]);
  EXPECT_LT(errs[1], 3e-2 * errs[0]);
  EXPECT_LT(errs[2], 1e-3 * errs[1]);
  EXPECT_LT(errs[3], 1e-12);
}

// Spectral and finite-volume solvers agree on the same periodic 2D problem (isobaric in y,
// shear in x, kinetic coefficients): the FV - spectral difference falls as h^2.
TEST(HydroAgreement, SpectralAndFiniteVolumeAgreePeriodic2D) {
  const DriftDiffusionCoefficients kin = kinetic_coefficients(0.5, 1.0, 0.5);
  auto make_bg = [](const Grid& g) {
    Background bg = isobaric_background(g, 1.0, 1.0, 0.5, 1.0, 1);
    for (int j = 0; j < g.n[1]; ++j)
      for (int i = 0; i < g.n[0]; ++i) bg.uB[0][g.index(i, j)] = 0.5 * std::cos(g.x(1, j));
    return bg;
  };
  const auto init = [](double x, double y, double) { return 1.0 + 0.4 * std::cos(x) * std::sin(y) + 0.2 * std::cos(2 * y); };
  std::vector<double> hs, diffs;
  for (int N : {16, 32, 64}) {
    const Grid g = Grid::make({N, N}, {2 * kPi, 2 * kPi}, Boundary::Periodic);
    SpectralSolver sp(make_bg(g), kin);
    FiniteVolumeSolver fv(make_bg(g), kin);
    sp.set_density(g.sample(init));
    fv.set_density(g.sample(init));
    sp.run_to(1.0, 0.005);
    fv.run_to(1.0, 0.005);
    hs.push_back(g.h(0));
    diffs.push_back(max_abs_diff(sp.density(), fv.density()));
  }
  const double slope = fitted_slope(hs, diffs);
  std::printf("  spectral-FV 2D: %.3e %.3e %.3e slope %.3f\n", diffs[0], diffs[1], diffs[2], slope);
  EXPECT_NEAR(slope, 2.0, 0.2);
  EXPECT_LT(diffs.back(), 2e-3);
}

// Walled box vs periodic box: with coefficient fields and data symmetric about x = pi/(2k),
// the periodic solution on [0, 2pi/k) restricted to [pi/(2k), 3pi/(2k)] solves the zero-flux
// problem there (mirror symmetry), so FV-walls and spectral-periodic must agree to O(h^2).
TEST(HydroAgreement, WalledFiniteVolumeMatchesSymmetricPeriodicSpectral) {
  const DriftDiffusionCoefficients kin = kinetic_coefficients(0.5, 1.0, 0.5);
  const double k = 1.0, L = 2 * kPi / k;
  const auto init = [](double x, double, double) { return 1.0 + 0.3 * std::sin(x) + 0.1 * std::cos(2 * x); };
  std::vector<double> hs, diffs;
  for (int N : {32, 64, 128}) {
    const Grid gp = Grid::make({N}, {L}, Boundary::Periodic);
    const Grid gw = Grid::make({N / 2}, {L / 2}, Boundary::Wall, {L / 4});
    SpectralSolver sp(isobaric_background(gp, 1.0, 1.0, 0.6, k), kin);
    FiniteVolumeSolver fv(isobaric_background(gw, 1.0, 1.0, 0.6, k), kin);
    sp.set_density(gp.sample(init));
    fv.set_density(gw.sample(init));
    sp.run_to(2.0, 0.0005);
    fv.run_to(2.0, 0.0005);
    double d = 0.0;
    for (int i = 0; i < N / 2; ++i) d = std::max(d, std::abs(fv.density()[i] - sp.density()[i + N / 4]));
    hs.push_back(gp.h(0));
    diffs.push_back(d);
  }
  const double slope = fitted_slope(hs, diffs);
  std::printf("  walled FV vs periodic spectral: %.3e %.3e %.3e slope %.3f\n", diffs[0], diffs[1], diffs[2], slope);
  EXPECT_NEAR(slope, 2.0, 0.2);
}

// Steady isobaric profile n ~ TB^(-p): exact for SG (well-balanced), spectral to accuracy.
TEST(HydroSteadyState, IsobaricProfileExponent) {
  for (const DriftDiffusionCoefficients& c : {paper_coefficients(0.7, 1.0, 0.5), kinetic_coefficients(0.7, 1.0, 0.5)}) {
    const Grid gw = Grid::make({48}, {2 * kPi}, Boundary::Wall);
    const Background bw = isobaric_background(gw, 1.0, 1.0, 0.5, 1.0);
    FiniteVolumeSolver fv(bw, c, TimeScheme::BackwardEuler);
    fv.set_density(std::vector<double>(gw.size(), 1.0));
    fv.run_to(2000.0, 50.0);
    double lo = 1e300, hi = -1e300;
    for (std::size_t i = 0; i < gw.size(); ++i) {
      const double q = fv.density()[i] * std::pow(bw.TB[i], c.p);
      lo = std::min(lo, q);
      hi = std::max(hi, q);
    }
    std::printf("  FV steady n TB^p spread (%s, p=%.6f): %.2e\n", c.name.c_str(), c.p, (hi - lo) / hi);
    EXPECT_LT((hi - lo) / hi, 1e-9) << c.name;
    const Grid gp = Grid::make({48}, {2 * kPi}, Boundary::Periodic);
    const Background bp = isobaric_background(gp, 1.0, 1.0, 0.5, 1.0);
    SpectralSolver sp(bp, c);
    sp.set_density(std::vector<double>(gp.size(), 1.0));
    sp.run_to(300.0, 0.5);
    lo = 1e300;
    hi = -1e300;
    for (std::size_t i = 0; i < gp.size(); ++i) {
      const double q = sp.density()[i] * std::pow(bp.TB[i], c.p);
      lo = std::min(lo, q);
      hi = std::max(hi, q);
    }
    std::printf("  spectral steady n TB^p spread (%s): %.2e\n", c.name.c_str(), (hi - lo) / hi);
    EXPECT_LT((hi - lo) / hi, 1e-8) << c.name;
  }
  EXPECT_LT(kinetic_coefficients(0.7, 1.0, 0.5).p, 0.75);  // kinetic p differs from 1
}

// Backgrounds with a pressure gradient, grad(nB TB) != 0, and a non-uniform drift uB: the only
// place where the (m/mB) n grad ln(nB TB) term of eq. H7 acts (every factory background has
// uniform nB TB, so no other test sees its sign, its mass ratio m/mB = (1-alpha)/alpha, or
// whether it is there at all). Independent reference: eq. H7 in its first form,
//   dn/dt = d/dx{ D [dn/dx + p n dlnTB/dx - ((1-alpha)/alpha) n dln(nB TB)/dx] - n uB },
// with D = eps Dhat sqrt(TB/m)/nB from the fields themselves (not DriftDiffusionFields), central
// differences on 1024 cells, analytic face derivatives, explicit Heun steps. Plus the closed-form
// steady state of a walled box, n ~ TB^(-p) (nB TB)^((1-alpha)/alpha).
namespace {
struct Fields1D {
  std::function<double(double)> TB, nB, uB, dlnTB, dlnP;  // dlnP = d ln(nB TB)/dx
};
Background background_from(const Grid& g, const Fields1D& f) {
  Background b = uniform_background(g, 1.0, 1.0);
  for (int i = 0; i < g.n[0]; ++i) {
    b.TB[i] = f.TB(g.x(0, i));
    b.nB[i] = f.nB(g.x(0, i));
    b.uB[0][i] = f.uB(g.x(0, i));
  }
  b.validate();
  return b;
}
// Cell averages (Simpson per cell) of n0 on the N-cell grid of [0, L).
std::vector<double> cell_averages(int N, double L, const std::function<double(double)>& n0) {
  std::vector<double> out(N);
  const double h = L / N;
  for (int i = 0; i < N; ++i) out[i] = (n0(i * h) + 4.0 * n0((i + 0.5) * h) + n0((i + 1) * h)) / 6.0;
  return out;
}
std::vector<double> h7_reference(const Fields1D& f, double alpha, double Dhat, double p, double eps,
                                 double L, bool periodic, const std::function<double(double)>& n0,
                                 double t_end) {
  const int M = 1024;
  const double h = L / M, r = (1.0 - alpha) / alpha;
  // face f sits at x = f h, between cells f-1 and f; faces 0 and M are the walls (or the same
  // periodic face)
  std::vector<double> D(M + 1), drift(M + 1);
  for (int k = 0; k <= M; ++k) {
    const double x = k * h;
    D[k] = eps * Dhat * std::sqrt(f.TB(x)) / f.nB(x);
    drift[k] = -D[k] * (p * f.dlnTB(x) - r * f.dlnP(x)) + f.uB(x);  // J = -D dn/dx + drift n
  }
  double Dmax = 0, Wmax = 0;
  for (int k = 0; k <= M; ++k) Dmax = std::max(Dmax, D[k]), Wmax = std::max(Wmax, std::abs(drift[k]));
  const double dt_max = 0.2 * std::min(h * h / Dmax, h / std::max(Wmax, 1e-300));
  const long steps = static_cast<long>(std::ceil(t_end / dt_max));
  const double dt = t_end / steps;
  auto rhs = [&](const std::vector<double>& n, std::vector<double>& out) {
    std::vector<double> J(M + 1, 0.0);
    for (int k = 0; k <= M; ++k) {
      if (!periodic && (k == 0 || k == M)) continue;  // zero flux through the walls
      const double nl = n[(k - 1 + M) % M], nr = n[k % M];
      J[k] = -D[k] * (nr - nl) / h + drift[k] * 0.5 * (nl + nr);
    }
    for (int i = 0; i < M; ++i) out[i] = -(J[i + 1] - J[i]) / h;
  };
  std::vector<double> n = cell_averages(M, L, n0), k1(M), k2(M), m(M);
  for (long s = 0; s < steps; ++s) {
    rhs(n, k1);
    for (int i = 0; i < M; ++i) m[i] = n[i] + dt * k1[i];
    rhs(m, k2);
    for (int i = 0; i < M; ++i) n[i] += 0.5 * dt * (k1[i] + k2[i]);
  }
  return n;
}
}  // namespace

TEST(HydroNonIsobaric, PressureGradientDriftMatchesIndependentReference) {
  const double alpha = 0.7, eps = 0.5, L = 2 * kPi, t_end = 1.0;
  const DriftDiffusionCoefficients kin = kinetic_coefficients(alpha, 1.0, eps);
  const auto n0 = [](double x) { return 1.0 + 0.4 * std::cos(x) + 0.2 * std::sin(3 * x); };
  // Periodic: TB = 1 + 0.5 sin x, nB = 1.3 + 0.4 cos 2x, uB = 0.4 + 0.3 cos x.
  Fields1D per;
  per.TB = [](double x) { return 1.0 + 0.5 * std::sin(x); };
  per.nB = [](double x) { return 1.3 + 0.4 * std::cos(2 * x); };
  per.uB = [](double x) { return 0.4 + 0.3 * std::cos(x); };
  per.dlnTB = [](double x) { return 0.5 * std::cos(x) / (1.0 + 0.5 * std::sin(x)); };
  per.dlnP = [](double x) {
    return 0.5 * std::cos(x) / (1.0 + 0.5 * std::sin(x)) - 0.8 * std::sin(2 * x) / (1.3 + 0.4 * std::cos(2 * x));
  };
  // Walls: TB = 0.5 + x/L, nB = 1 + 0.5 x/L (nB TB grows 3-fold across the box), uB = 0.
  Fields1D wal;
  wal.TB = [=](double x) { return 0.5 + x / L; };
  wal.nB = [=](double x) { return 1.0 + 0.5 * x / L; };
  wal.uB = [](double) { return 0.0; };
  wal.dlnTB = [=](double x) { return (1.0 / L) / (0.5 + x / L); };
  wal.dlnP = [=](double x) { return (1.0 / L) / (0.5 + x / L) + (0.5 / L) / (1.0 + 0.5 * x / L); };
  for (bool periodic : {true, false}) {
    const Fields1D& f = periodic ? per : wal;
    const auto ref = h7_reference(f, alpha, kin.Dhat, kin.p, eps, L, periodic, n0, t_end);
    const Grid gref = Grid::make({1024}, {L}, periodic ? Boundary::Periodic : Boundary::Wall);
    std::vector<double> hs, errs;
    for (int N : {32, 64, 128}) {
      const Grid g = Grid::make({N}, {L}, periodic ? Boundary::Periodic : Boundary::Wall);
      FiniteVolumeSolver fv(background_from(g, f), kin);
      fv.set_density(cell_averages(N, L, n0));
      fv.run_to(t_end, 0.002);
      hs.push_back(g.h(0));
      errs.push_back(max_abs_diff(fv.density(), coarsen(ref, gref, g)));
    }
    const double slope = fitted_slope(hs, errs);
    std::printf("  non-isobaric %s, FV vs reference: N=32 %.3e N=64 %.3e N=128 %.3e slope %.3f\n",
                periodic ? "periodic" : "walls", errs[0], errs[1], errs[2], slope);
    EXPECT_NEAR(slope, 2.0, 0.2) << (periodic ? "periodic" : "walls");
    EXPECT_LT(errs[2], 1e-3) << (periodic ? "periodic" : "walls");
    if (periodic) {
      // spectral point values at the cell centres: the mean of the two reference cells that meet there
      const Grid g = Grid::make({64}, {L}, Boundary::Periodic);
      SpectralSolver sp(background_from(g, f), kin);
      sp.set_density(g.sample([&](double x, double, double) { return n0(x); }));
      sp.run_to(t_end, 0.001);
      double e = 0.0;
      for (int i = 0; i < 64; ++i) e = std::max(e, std::abs(sp.density()[i] - 0.5 * (ref[16 * i + 7] + ref[16 * i + 8])));
      std::printf("  non-isobaric periodic, spectral (64 points) vs reference: %.3e\n", e);
      EXPECT_LT(e, 1e-4);
    }
  }
  // Closed-form steady state of the walled box (zero flux face by face): n ~ TB^(-p) (nB TB)^(m/mB).
  const Grid g = Grid::make({48}, {L}, Boundary::Wall);
  const Background bw = background_from(g, wal);
  FiniteVolumeSolver fv(bw, kin, TimeScheme::BackwardEuler);
  fv.set_density(std::vector<double>(g.size(), 1.0));
  fv.run_to(4000.0, 50.0);
  double lo = 1e300, hi = -1e300;
  for (std::size_t i = 0; i < g.size(); ++i) {
    const double q = fv.density()[i] * std::pow(bw.TB[i], kin.p) * std::pow(bw.nB[i] * bw.TB[i], -(1.0 - alpha) / alpha);
    lo = std::min(lo, q);
    hi = std::max(hi, q);
  }
  std::printf("  non-isobaric walls, steady n TB^p (nB TB)^(-m/mB) spread: %.2e\n", (hi - lo) / hi);
  EXPECT_LT((hi - lo) / hi, 1e-9);
}

TEST(HydroBadInput, ClearErrors) {
  auto expect_msg = [](auto&& f, const char* fragment) {
    try {
      f();
      ADD_FAILURE() << "no exception; expected one mentioning '" << fragment << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  expect_msg([] { Grid::from_spacing({1.0}, {0.3}, Boundary::Wall); }, "does not divide");
  expect_msg([] {
    const Grid f = Grid::make({30}, {1.0}, Boundary::Wall), c = Grid::make({8}, {1.0}, Boundary::Wall);
    coarsen(std::vector<double>(30, 1.0), f, c);
  }, "does not divide");
  expect_msg([] { isobaric_background(Grid::make({16}, {1.0}, Boundary::Periodic), 1, 1, 0.5, 1.0); }, "not commensurate");
  expect_msg([] { sine_shear_background(Grid::make({8, 8}, {1.0, 2.0}, Boundary::Periodic), 1, 1, 0.5, 2.0); }, "not commensurate");
  expect_msg([] { isobaric_background(Grid::make({16}, {2 * kPi}, Boundary::Periodic), 1, 1, 1.5, 1.0); }, "|A| < 1");
  expect_msg([] { SpectralSolver s(uniform_background(Grid::make({8}, {1.0}, Boundary::Wall), 1, 1), kPaper); }, "periodic");
  expect_msg([] { Grid::make({0}, {1.0}, Boundary::Wall); }, "at least 1");
  expect_msg([] { shear_background(Grid::make({8}, {1.0}, Boundary::Wall), 1, 1, [](double) { return 0.0; }); }, "dimension 2");
  // Walls accept any k (no periodicity constraint).
  EXPECT_NO_THROW(isobaric_background(Grid::make({16}, {1.0}, Boundary::Wall), 1, 1, 0.5, 1.0));
  EXPECT_EQ(Grid::from_spacing({2.0, 1.0}, {0.25, 0.125}, Boundary::Wall).n[1], 8);
}

// Transport by a uniform drift W at any Peclet number Pe = W h / D (mutation audit 2026-12-06,
// docs/reviews/mutation-audit-closures-hydro.md). The Bernoulli weights obey B(-x) = B(x) + x
// exactly, so the Scharfetter-Gummel flux is F = (D/h) B(Pe) (n_P - n_Q) + W n_P: for
// n = 1 + a cos(k x) on a uniform grid the sin(k x) part of dn/dt is W a sin(k h)/h exactly
// (the diffusive part is even). Checked on the solver's operator for a weak drift (Pe ~ 1e-6,
// the series branch of bernoulli()), a moderate and a strong one, drifting both ways; and the
// identity and B(x) = x/(e^x - 1) (long double) on both branches of bernoulli().
TEST(HydroFiniteVolume, UniformDriftTransportsAtEveryPecletNumber) {
  for (long double x : {1e-7L, -3e-5L, 9e-5L, -2e-4L, 0.37L, -4.2L, 30.0L}) {
    const double b = bernoulli(static_cast<double>(x)), bm = bernoulli(static_cast<double>(-x));
    const long double ref = x / std::expm1(x);
    EXPECT_NEAR(b, static_cast<double>(ref), 1e-14 * static_cast<double>(ref)) << "x=" << static_cast<double>(x);
    EXPECT_NEAR(bm - b, static_cast<double>(x), 1e-14 * (1.0 + bm)) << "x=" << static_cast<double>(x);
  }
  const Grid g = Grid::make({40}, {2 * kPi}, Boundary::Periodic);
  const double k = 3.0, a = 0.2, h = g.h(0), D = kPaper.D(1.0, 1.0);
  for (double Pe : {1e-6, -3e-6, 0.4, -6.0}) {
    const double W = Pe * D / h;
    FiniteVolumeSolver s(uniform_drift_background(g, 1.0, 1.0, {W, 0.0, 0.0}), kPaper);
    const auto dn = s.apply(g.sample([&](double x, double, double) { return 1.0 + a * std::cos(k * x); }));
    double sin_part = 0.0;
    for (int i = 0; i < g.n[0]; ++i) sin_part += 2.0 / g.n[0] * dn[i] * std::sin(k * g.x(0, i));
    const double expect = W * a * std::sin(k * h) / h;
    std::printf("  Pe = %g: sin part of dn/dt %.12e, W a sin(kh)/h %.12e\n", Pe, sin_part, expect);
    EXPECT_NEAR(sin_part, expect, 1e-9 * std::abs(expect) + 1e-13) << "Pe=" << Pe;
  }
}

// The shear backgrounds (mutation audit 2026-12-06, docs/reviews/mutation-audit-closures-hydro.md):
// a steady Euler shear flow uB = (U(y), 0, 0) varies across the flow only (uB.grad uB = 0), with
// uniform nB, TB; the cell values are U at the cell centre's y, in 2D and 3D.
TEST(HydroGrid, ShearBackgroundVariesAcrossTheFlowOnly) {
  const double U0 = 0.7, k = 2.0;
  for (const Grid& g : {Grid::make({6, 8}, {1.5, kPi}, Boundary::Periodic),
                        Grid::make({5, 8, 3}, {2.0, kPi, 1.0}, Boundary::Periodic)}) {
    const Background bg = sine_shear_background(g, 1.3, 0.8, U0, k);
    for (int kk = 0; kk < g.n[2]; ++kk)
      for (int j = 0; j < g.n[1]; ++j)
        for (int i = 0; i < g.n[0]; ++i) {
          const std::size_t c = g.index(i, j, kk);
          const double y = (j + 0.5) * g.length[1] / g.n[1];
          EXPECT_NEAR(bg.uB[0][c], U0 * std::sin(k * y), 1e-15) << i << " " << j << " " << kk;
          EXPECT_EQ(bg.uB[1][c], 0.0);
          EXPECT_EQ(bg.uB[2][c], 0.0);
          EXPECT_EQ(bg.nB[c], 1.3);
          EXPECT_EQ(bg.TB[c], 0.8);
        }
  }
}
