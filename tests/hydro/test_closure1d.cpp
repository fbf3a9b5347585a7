// 1D closure solvers (Maxwellian and Grad (n, u, T) systems, IMEX ARS(2,2,2)) and their
// linearised density-mode eigenvalues (docs/hydro.md sec. 4).
#include "hydro/hydro.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace grainbath::hydro;
using grainbath::closures::Closure;
constexpr double kPi = std::numbers::pi;

namespace {
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
// Amplitude of the cos/sin(k x) Fourier component of n.
double mode_amplitude(const Closure1DSolver& s, double k) {
  const auto w = s.primitive();
  double c = 0, d = 0;
  for (int i = 0; i < s.grid().n[0]; ++i) {
    const double x = s.grid().x(0, i);
    c += w[i].n * std::cos(k * x);
    d += w[i].n * std::sin(k * x);
  }
  return 2.0 * std::hypot(c, d) / s.grid().n[0];
}
}  // namespace

// Elastic Maxwellian closure: the mode matrix is known in closed form (docs/hydro.md eq. H25):
// B = [[0, n, 0], [T/(m n), 0, 1/m], [0, 2T/3, 0]], C_uu = -nB nu1/eps (eq. H3),
// C_TT = -(nB/eps)(16/3) alpha (1-alpha) sqrt(2/pi) sqrt(TB/(alpha m)) (eq. H23). This checks
// closures/ sources against the independent derivation in docs/hydro.md.
TEST(HydroClosureModes, MaxwellianElasticMatchesClosedForm) {
  ModeParams p;
  p.alpha = 0.4;
  p.mass = 1.3;
  p.nB = 1.7;
  p.TB = 0.9;
  p.eps = 0.05;
  p.n = 0.8;
  const double k = 1.5, m = p.mass, T = p.TB, n = p.n;
  const double Cuu = -p.nB * friction_rate_per_nB(p.alpha, m, T, T) / p.eps;
  const double CTT = -(p.nB / p.eps) * (16.0 / 3.0) * p.alpha * (1 - p.alpha) * std::sqrt(2 / kPi) *
                     std::sqrt(p.TB / (p.alpha * m));
  Eigen::Matrix3cd M;
  const std::complex<double> ik(0.0, k);
  M << 0.0, -ik * n, 0.0, -ik * T / (m * n), Cuu, -ik / m, 0.0, -ik * 2.0 * T / 3.0, CTT;
  Eigen::ComplexEigenSolver<Eigen::Matrix3cd> es(M);
  std::vector<std::complex<double>> ref(es.eigenvalues().data(), es.eigenvalues().data() + 3);
  std::sort(ref.begin(), ref.end(), [](auto a, auto b) { return a.real() > b.real(); });
  const auto ev = closure_mode_eigenvalues(Closure::maxwellian, p, k);
  for (int i = 0; i < 3; ++i) EXPECT_LT(std::abs(ev[i] - ref[i]), 1e-6 * std::abs(ref[i]) + 1e-9) << i;
}

// eps -> 0: both closures' density-mode rates tend to the paper's D k^2 (Bisi-Spiga: the two
// closures share the Navier-Stokes limit eq. 36), with a relative deviation that vanishes
// linearly or faster in eps -- also with inelastic grains (T# != TB).
ModeModel model_of(Closure c) {
  return c == Closure::grad ? ModeModel::grad_closure : c == Closure::sonine ? ModeModel::sonine_closure : ModeModel::maxwellian_closure;
}

TEST(HydroClosureModes, EpsToZeroGivesPaperDiffusion) {
  for (Closure c : {Closure::maxwellian, Closure::grad, Closure::sonine}) {
    for (double beta : {0.0, 0.05}) {
      ModeParams p;
      p.alpha = 0.5;
      p.beta = beta;
      const double k = 1.0;
      double prev = 1.0;
      for (double eps : {1e-2, 1e-3, 1e-4}) {
        p.eps = eps;
        const double r = mode_decay_rate(model_of(c), p, k);
        const double dev = std::abs(r / mode_decay_rate(ModeModel::paper, p, k) - 1.0);
        std::printf("  %s beta=%.2f eps=%.0e rate/paper - 1 = %.3e\n", to_string(c), beta, eps, r / mode_decay_rate(ModeModel::paper, p, k) - 1.0);
        EXPECT_LT(dev, 0.6 * prev) << to_string(c) << " eps=" << eps;
        prev = dev;
      }
      EXPECT_LT(prev, 2e-3) << to_string(c) << " beta=" << beta;
    }
  }
}

// The 1D solver's measured density-mode decay matches its closure's linear eigenvalue at finite
// eps (inelastic, so the Grad heat flux term is active).
// The Sonine closure's sources are evaluated by quadrature of the collision rule (~0.3 ms per
// call), so its 1D-solver runs are in the long tier (HydroClosureSolverLong below); the default
// tier keeps a short Sonine smoke run.
void density_mode_case(Closure c, int cells, double t1, double t2, double tol) {
  {
    Closure1DConfig cfg;
    cfg.closure = c;
    cfg.alpha = 0.5;
    cfg.eps = 0.1;
    cfg.beta = 0.05;
    cfg.limiter = Limiter::None;
    const double k = 1.0;
    const Grid g = Grid::make({cells}, {2 * kPi / k}, Boundary::Periodic);
    const Background bg = uniform_background(g, 1.0, 1.0, {0.3, 0.0, 0.0});
    Closure1DSolver s(cfg, bg, 1.0);
    s.set_equilibrium(g.sample([&](double x, double, double) { return 1.0 + 1e-3 * std::cos(k * x); }));
    s.run_to(t1, 0.05);  // fast modes (rates ~ 1/eps) die out
    const double a1 = mode_amplitude(s, k);
    s.run_to(t2, 0.05);
    const double a2 = mode_amplitude(s, k);
    const double measured = std::log(a1 / a2) / (t2 - t1);
    ModeParams p;
    p.alpha = 0.5;
    p.eps = 0.1;
    p.beta = 0.05;
    const double theory = mode_decay_rate(model_of(c), p, k);
    std::printf("  %s: measured %.6f eigenvalue %.6f paper %.6f\n", to_string(c), measured, theory,
                mode_decay_rate(ModeModel::paper, p, k));
    EXPECT_NEAR(measured / theory, 1.0, tol) << to_string(c);
  }
}

TEST(HydroClosureSolver, DensityModeDecayMatchesEigenvalue) {
  density_mode_case(Closure::maxwellian, 128, 1.0, 6.0, 5e-3);
  density_mode_case(Closure::grad, 128, 1.0, 6.0, 5e-3);
}

TEST(HydroClosureSolverLong, SonineDensityModeDecayMatchesEigenvalue) {
  density_mode_case(Closure::sonine, 64, 1.0, 4.0, 1e-2);
}

TEST(HydroClosureSolver, MassConservedToRoundOff) {
  for (Boundary b : {Boundary::Periodic, Boundary::Wall}) {
    for (Closure c : {Closure::maxwellian, Closure::grad}) {
      Closure1DConfig cfg;
      cfg.closure = c;
      cfg.eps = 0.05;
      cfg.beta = 0.05;
      const Grid g = Grid::make({48}, {2 * kPi}, b);
      const Background bg = isobaric_background(g, 1.0, 1.0, 0.3, 1.0);
      Closure1DSolver s(cfg, bg, 1.0);
      s.set_equilibrium(g.sample([](double x, double, double) { return 1.0 + 0.3 * std::sin(x) + 0.2 * std::cos(2 * x); }));
      const double m0 = s.mass();
      s.run_to(2.0, 0.1);
      std::printf("  closure %s mass drift (%s): %.2e\n", to_string(c), b == Boundary::Wall ? "walls" : "periodic", s.mass() / m0 - 1.0);
      EXPECT_LT(std::abs(s.mass() / m0 - 1.0), 1e-13) << to_string(c);
    }
  }
}

// Asymptotic preservation: eps = 1e-9 with CFL-limited steps (dt ~ 1e7 eps) stays stable and
// relaxes to u = uB, T = T#; the density is transported by the uniform drift uB.
void ap_case(Closure c, int cells);
TEST(HydroClosureSolver, AsymptoticPreservingAsEpsToZero) {
  ap_case(Closure::maxwellian, 128);
  ap_case(Closure::grad, 128);
}
TEST(HydroClosureSolverLong, SonineAsymptoticPreserving) { ap_case(Closure::sonine, 64); }

void ap_case(Closure c, int cells) {
  {
    Closure1DConfig cfg;
    cfg.closure = c;
    cfg.eps = 1e-9;
    cfg.beta = 0.05;
    const Grid g = Grid::make({cells}, {2 * kPi}, Boundary::Periodic);
    const double uB = 0.5;
    const Background bg = uniform_background(g, 1.0, 1.0, {uB, 0.0, 0.0});
    Closure1DSolver s(cfg, bg, 1.0);
    s.set_equilibrium(g.sample([](double x, double, double) { return 1.0 + 0.2 * std::sin(x); }));
    EXPECT_GT(s.max_stable_dt(), 1e6 * cfg.eps);
    s.run_to(2.0, 1.0);
    const auto w = s.primitive();
    double err_n = 0, err_u = 0, err_T = 0;
    for (int i = 0; i < g.n[0]; ++i) {
      const double x = g.x(0, i);
      err_n = std::max(err_n, std::abs(w[i].n - (1.0 + 0.2 * std::sin(x - uB * 2.0))));
      err_u = std::max(err_u, std::abs(w[i].u - uB));
      grainbath::closures::Parameters prm{};
      prm.alpha = cfg.alpha;
      prm.nB = 1.0;
      prm.TB = 1.0;
      prm.eps = cfg.eps;
      prm.n = w[i].n;
      prm.beta = cfg.beta;
      err_T = std::max(err_T, std::abs(w[i].T / grainbath::closures::equilibrium_temperature(c, prm) - 1.0));
    }
    std::printf("  AP eps=1e-9 %s: max|n - n_exact| %.2e, max|u - uB| %.2e, max|T/T# - 1| %.2e\n", to_string(c), err_n, err_u, err_T);
    EXPECT_LT(err_n, 2e-3 * (128.0 / cells) * (128.0 / cells)) << to_string(c);
    EXPECT_LT(err_u, 1e-6) << to_string(c);
    EXPECT_LT(err_T, 1e-6) << to_string(c);
  }
}

// Default-tier Sonine smoke run: 24 walled cells, isobaric background, 6 steps: mass to round-off,
// a2 stays near its equilibrium (O(eps) relaxation), the state stays physical.
TEST(HydroClosureSolver, SonineSmoke) {
  Closure1DConfig cfg;
  cfg.closure = Closure::sonine;
  cfg.eps = 0.1;
  cfg.beta = 0.05;
  const Grid g = Grid::make({24}, {2 * kPi}, Boundary::Wall);
  const Background bg = isobaric_background(g, 1.0, 1.0, 0.3, 1.0);
  Closure1DSolver s(cfg, bg, 1.0);
  s.set_equilibrium(g.sample([](double x, double, double) { return 1.0 + 0.3 * std::sin(x); }));
  const double m0 = s.mass();
  const auto w0 = s.primitive();
  EXPECT_NE(w0[5].a2, 0.0);  // inelastic: the Sonine equilibrium has a2# != 0
  for (int i = 0; i < 6; ++i) s.step(0.05);
  const auto w1 = s.primitive();
  std::printf("  sonine smoke: mass drift %.2e, a2 in cell 5: %.4e -> %.4e\n", s.mass() / m0 - 1.0, w0[5].a2, w1[5].a2);
  EXPECT_LT(std::abs(s.mass() / m0 - 1.0), 1e-13);
  for (std::size_t i = 0; i < w1.size(); ++i) {
    EXPECT_GT(w1[i].T, 0.0);
    // a2 = O(1e-3) follows T - T#(n) (compression heats, d a2/dT ~ -0.1 here): stays O(1e-3).
    EXPECT_LT(std::abs(w1[i].a2 - w0[i].a2), 3e-3);
  }
}

// Second order in space (and time, dt ~ h by CFL) for smooth data.
TEST(HydroClosureSolver, SecondOrderConvergence) {
  Closure1DConfig cfg;
  cfg.closure = Closure::grad;
  cfg.eps = 0.2;
  cfg.beta = 0.05;
  cfg.limiter = Limiter::None;
  auto solve = [&](int N) {
    const Grid g = Grid::make({N}, {2 * kPi}, Boundary::Periodic);
    const Background bg = isobaric_background(g, 1.0, 1.0, 0.3, 1.0);
    Closure1DSolver s(cfg, bg, 1.0);
    std::vector<Primitive1D> w0(N);
    for (int i = 0; i < N; ++i) {
      const double x = g.x(0, i);
      w0[i] = {1.0 + 0.2 * std::sin(x), 0.1 * std::cos(x), 1.0 + 0.1 * std::sin(2 * x)};
    }
    s.set_state(w0);
    s.run_to(0.5, 1.0);
    std::vector<double> n(N);
    const auto w = s.primitive();
    for (int i = 0; i < N; ++i) n[i] = w[i].n;
    return std::make_pair(g, n);
  };
  std::vector<double> hs, errs;
  auto prev = solve(64);
  for (int N : {128, 256, 512}) {
    auto cur = solve(N);
    const auto c = coarsen(cur.second, cur.first, prev.first);
    double e = 0;
    for (std::size_t i = 0; i < c.size(); ++i) e += (c[i] - prev.second[i]) * (c[i] - prev.second[i]);
    hs.push_back(prev.first.h(0));
    errs.push_back(std::sqrt(e / c.size()));
    prev = cur;
  }
  const double slope = fitted_slope(hs, errs);
  std::printf("  closure solver space-time: %.3e %.3e %.3e slope %.3f\n", errs[0], errs[1], errs[2], slope);
  EXPECT_NEAR(slope, 2.0, 0.2);
}

TEST(HydroClosureSolver, BadInput) {
  Closure1DConfig cfg;
  cfg.closure = static_cast<Closure>(99);
  const Grid g = Grid::make({16}, {1.0}, Boundary::Wall);
  EXPECT_THROW(Closure1DSolver(cfg, uniform_background(g, 1, 1), 1.0), std::invalid_argument);
  cfg.closure = Closure::maxwellian;
  EXPECT_THROW(Closure1DSolver(cfg, uniform_background(Grid::make({8, 8}, {1.0, 1.0}, Boundary::Wall), 1, 1), 1.0),
               std::invalid_argument);
  cfg.alpha = 1.5;
  EXPECT_THROW(Closure1DSolver(cfg, uniform_background(g, 1, 1), 1.0), std::invalid_argument);
  EXPECT_THROW(closure_mode_eigenvalues(static_cast<Closure>(99), ModeParams{}, 1.0), std::invalid_argument);
  EXPECT_THROW(closure_mode_eigenvalues(Closure::maxwellian, ModeParams{}, -1.0), std::invalid_argument);
}

// The closed systems in space approach the drift-diffusion limit (Bisi-Spiga eq. 36, solved by
// the FV drift-diffusion solver with the paper coefficients) as eps decreases: walled isobaric
// box, elastic grains, both runs to the same diffusive time t = 0.4/eps. The difference falls
// roughly linearly in eps (at fixed resolution the closure solver's numerical diffusion sets a
// floor for smaller eps, docs/hydro.md sec. 4.1).
TEST(HydroClosureSolver, ApproachesDriftDiffusionLimit) {
  const int N = 256;
  std::vector<double> diffs;
  for (double eps : {0.2, 0.1}) {
    const Grid g = Grid::make({N}, {2 * kPi}, Boundary::Wall);
    const Background bg = isobaric_background(g, 1.0, 1.0, 0.3, 1.0);
    const auto init = [](double x, double, double) { return 1.0 + 0.3 * std::cos(x); };
    FiniteVolumeSolver fv(bg, paper_coefficients(0.5, 1.0, eps));
    fv.set_density(g.sample(init));
    Closure1DConfig cfg;
    cfg.eps = eps;
    cfg.limiter = Limiter::None;
    Closure1DSolver cs(cfg, bg, 1.0);
    cs.set_equilibrium(g.sample(init));
    fv.run_to(0.4 / eps, 0.01);
    cs.run_to(0.4 / eps, 1.0);
    const auto w = cs.primitive();
    double d = 0.0;
    for (int i = 0; i < N; ++i) d = std::max(d, std::abs(w[i].n - fv.density()[i]));
    std::printf("  closure (maxwellian) vs drift-diffusion, eps=%.2f: max |n_closure - n_dd| = %.3e\n", eps, d);
    diffs.push_back(d);
  }
  EXPECT_LT(diffs[1], 0.6 * diffs[0]);
  EXPECT_LT(diffs[1], 6e-3);
}

// A uniform state has no flux divergence, so the 1D solver integrates the homogeneous
// relaxation ODEs of closures/ (mutation audit 2026-12-06, docs/reviews/mutation-audit-closures-hydro.md).
// Grain mass 1.3, a background drifting at uB = 0.3 and grains starting 0.8 faster and hotter
// than it: the IMEX steps (second order) must follow closures::relax (an independent adaptive
// rk8pd integration of the same sources) for u, T. This sees the conversion between the
// conservative energy n u^2/2 + 3 n T/(2 m) and (u, T) in the implicit source step (the
// friction's kinetic-energy term n u du/dt, the 1/m) and the background drift handed to the
// sources, none of which the density-mode tests (linear about u = uB = 0) can see.
TEST(HydroClosureSolver, UniformStateFollowsTheHomogeneousRelaxation) {
  for (Closure c : {Closure::maxwellian, Closure::grad}) {
    Closure1DConfig cfg;
    cfg.closure = c;
    cfg.alpha = 0.4;
    cfg.mass = 1.3;
    cfg.eps = 0.2;
    cfg.beta = 0.05;
    cfg.delta = 0.3;
    const Grid g = Grid::make({3}, {30.0}, Boundary::Periodic);
    const double nB = 1.2, TB = 0.9, uB = 0.3, n = 1.1;
    const Background bg = uniform_background(g, nB, TB, {uB, 0.0, 0.0});
    Closure1DSolver s(cfg, bg, n);
    const Primitive1D w0{n, uB + 0.8, 1.7 * TB};
    s.set_state({w0, w0, w0});
    const double t_end = 0.25;
    s.run_to(t_end, 2e-4);
    grainbath::closures::Parameters p{};
    p.alpha = cfg.alpha;
    p.mass = cfg.mass;
    p.nB = nB;
    p.TB = TB;
    p.uB = {uB, 0.0, 0.0};
    p.eps = cfg.eps;
    p.n = n;
    p.beta = cfg.beta;
    p.delta = cfg.delta;
    const auto ref = grainbath::closures::relax(c, p, {{w0.u, 0.0, 0.0}, w0.T, 0.0}, {t_end}).back();
    const auto w = s.primitive();
    std::printf("  %s: solver u %.8f T %.8f, relax u %.8f T %.8f\n", to_string(c), w[1].u, w[1].T, ref.u[0], ref.T);
    ASSERT_GT(std::abs(ref.u[0] - uB), 0.05);  // still drifting: the test sees the friction
    for (const auto& x : w) {
      EXPECT_NEAR(x.n, n, 1e-14 * n);
      EXPECT_NEAR(x.u - uB, ref.u[0] - uB, 1e-5 * std::abs(ref.u[0] - uB)) << to_string(c);
      EXPECT_NEAR(x.T, ref.T, 1e-5 * ref.T) << to_string(c);
    }
  }
}

// Reflecting walls are mirrors (mutation audit 2026-12-06, docs/reviews/mutation-audit-closures-hydro.md):
// a walled box [0, L] evolves as the left half of a periodic box [0, 2L] whose initial state is
// its mirror image (n, T even, u odd about x = 0 and x = L, uB = 0), which keeps that symmetry.
// The periodic run knows nothing about walls, so this checks the wall ghost cells of the
// reconstruction and the wall fluxes, cell by cell, for the Maxwellian and Grad closures.
TEST(HydroClosureSolver, WalledBoxIsTheMirrorImageOfAPeriodicBox) {
  const int N = 24;
  const double L = 3.0;
  for (Closure c : {Closure::maxwellian, Closure::grad}) {
    Closure1DConfig cfg;
    cfg.closure = c;
    cfg.eps = 0.3;
    cfg.beta = 0.05;
    const Grid gw = Grid::make({N}, {L}, Boundary::Wall), gp = Grid::make({2 * N}, {2 * L}, Boundary::Periodic);
    Closure1DSolver sw(cfg, uniform_background(gw, 1.0, 1.0), 1.0), sp(cfg, uniform_background(gp, 1.0, 1.0), 1.0);
    std::vector<Primitive1D> ww(N), wp(2 * N);
    for (int i = 0; i < N; ++i) {
      const double x = gw.x(0, i);
      ww[i] = {1.0 + 0.3 * std::cos(2.0 * x) + 0.1 * x, 0.2 * std::sin(1.7 * x) + 0.05, 0.9 + 0.1 * x};
      wp[i] = ww[i];
      wp[2 * N - 1 - i] = {ww[i].n, -ww[i].u, ww[i].T};
    }
    sw.set_state(ww);
    sp.set_state(wp);
    const double dt = 0.5 * std::min(sw.max_stable_dt(), sp.max_stable_dt());
    for (int s = 0; s < 40; ++s) {
      sw.step(dt);
      sp.step(dt);
    }
    const auto a = sw.primitive(), b = sp.primitive();
    double d = 0.0, moved = 0.0;
    for (int i = 0; i < N; ++i) {
      d = std::max({d, std::abs(a[i].n - b[i].n), std::abs(a[i].u - b[i].u), std::abs(a[i].T - b[i].T)});
      moved = std::max(moved, std::abs(a[i].u - ww[i].u));
    }
    std::printf("  %s: walled vs mirrored periodic, max difference %.2e (u changed by up to %.3f)\n", to_string(c), d, moved);
    EXPECT_GT(moved, 0.01);
    EXPECT_LT(d, 1e-12) << to_string(c);
  }
}

// The step bound is CFL h / (fastest characteristic speed of the streaming part) (mutation
// audit 2026-12-06): for a resting state the speeds are the eigenvalues of the linearised
// flux, read here from the mode problem at large k where the 1/eps collision terms are
// negligible, lambda ~ -i k c: Maxwellian c = +-sqrt(5 T/(3 m)) (sound), Grad its own.
TEST(HydroClosureSolver, StableStepUsesTheFastestCharacteristicSpeed) {
  for (Closure c : {Closure::maxwellian, Closure::grad}) {
    Closure1DConfig cfg;
    cfg.closure = c;
    cfg.eps = 0.5;
    cfg.mass = 1.4;
    cfg.cfl = 0.4;
    const Grid g = Grid::make({16}, {2.0}, Boundary::Periodic);
    Closure1DSolver s(cfg, uniform_background(g, 1.0, 1.0), 1.0);
    const double T = s.primitive()[0].T;
    ModeParams mp;
    mp.eps = cfg.eps;
    mp.mass = cfg.mass;
    const double k = 1e7;
    double cmax = 0.0;
    for (const auto& l : closure_mode_eigenvalues(c, mp, k)) cmax = std::max(cmax, std::abs(l.imag()) / k);
    if (c == Closure::maxwellian) {
      EXPECT_NEAR(cmax, std::sqrt(5.0 * T / (3.0 * cfg.mass)), 1e-6 * cmax);
    }
    std::printf("  %s: max_stable_dt %.10f, cfl h / c_max %.10f (c_max %.8f)\n", to_string(c), s.max_stable_dt(),
                cfg.cfl * g.h(0) / cmax, cmax);
    EXPECT_NEAR(s.max_stable_dt(), cfg.cfl * g.h(0) / cmax, 1e-6 * s.max_stable_dt()) << to_string(c);
  }
}

// Mass scaling (mutation audit 2026-12-06, docs/reviews/mutation-audit-closures-hydro.md): the
// kinetic equation depends on the grain mass only through the thermal speeds T/m, TB/m (mB = alpha
// m/(1 - alpha) scales with m; both collision rules act on velocities). A run with mass m and all
// temperatures times m is the unit-mass run with T -> m T: same n and u, T/m equal. Checked for
// the Maxwellian and Grad 1D solvers (streaming fluxes, Grad heat flux, implicit sources) on a
// walled isobaric background with a non-equilibrium start.
TEST(HydroClosureSolver, GrainMassOnlyRescalesTheTemperature) {
  const int N = 32;
  for (Closure c : {Closure::maxwellian, Closure::grad}) {
    std::vector<Primitive1D> w[2];
    for (int r = 0; r < 2; ++r) {
      const double m = r == 0 ? 1.0 : 1.7;
      Closure1DConfig cfg;
      cfg.closure = c;
      cfg.mass = m;
      cfg.eps = 0.4;
      cfg.beta = 0.05;
      cfg.delta = 0.4;
      const Grid g = Grid::make({N}, {2 * kPi}, Boundary::Wall);
      Closure1DSolver s(cfg, isobaric_background(g, 1.0, m * 1.1, 0.3, 1.0), 1.0);
      std::vector<Primitive1D> w0(N);
      for (int i = 0; i < N; ++i) {
        const double x = g.x(0, i);
        w0[i] = {1.0 + 0.3 * std::cos(x), 0.3 * std::sin(x), m * (0.9 + 0.2 * std::sin(2 * x))};
      }
      s.set_state(w0);
      for (int k = 0; k < 30; ++k) s.step(0.02);
      w[r] = s.primitive();
    }
    double d = 0.0;
    for (int i = 0; i < N; ++i)
      d = std::max({d, std::abs(w[1][i].n - w[0][i].n), std::abs(w[1][i].u - w[0][i].u),
                    std::abs(w[1][i].T / 1.7 - w[0][i].T)});
    std::printf("  %s: mass 1.7 vs mass 1 (temperatures scaled), max difference %.2e\n", to_string(c), d);
    EXPECT_LT(d, 1e-11) << to_string(c);
  }
}
