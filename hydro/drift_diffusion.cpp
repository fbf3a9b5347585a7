// hydro/drift_diffusion.cpp -- spectral (ETDRK2) and finite-volume (Scharfetter-Gummel,
// implicit) solvers of docs/hydro.md eq. H7 (Bisi-Spiga eq. 36 with general coefficients).
#include "hydro/drift_diffusion.hpp"

#include <Eigen/Sparse>
#include <Eigen/SparseLU>
#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace grainbath::hydro {

// ---------------------------------------------------------------- coefficient fields
DriftDiffusionFields DriftDiffusionFields::build(const Background& bg,
                                                 const DriftDiffusionCoefficients& c) {
  bg.validate();
  DriftDiffusionFields f;
  const std::size_t N = bg.grid.size();
  f.D.resize(N);
  f.lnPhi.resize(N);
  const double r = c.mass_ratio();
  for (std::size_t i = 0; i < N; ++i) {
    f.D[i] = c.D(bg.nB[i], bg.TB[i]);  // docs/hydro.md eq. H8
    // eq. H7b: Phi = TB^(-p) (nB TB)^(m/mB)
    f.lnPhi[i] = -c.p * std::log(bg.TB[i]) + r * std::log(bg.nB[i] * bg.TB[i]);
  }
  return f;
}

DriftDiffusionSolver::DriftDiffusionSolver(const Background& bg, const DriftDiffusionCoefficients& c)
    : bg_(bg), coef_(c), fields_(DriftDiffusionFields::build(bg, c)), n_(bg.grid.size(), 0.0) {}

void DriftDiffusionSolver::set_density(const std::vector<double>& n) {
  if (n.size() != bg_.grid.size())
    throw std::invalid_argument("The density field needs one value per grid cell.");
  n_ = n;
}

void DriftDiffusionSolver::run_to(double t_end, double max_dt) {
  if (!(max_dt > 0.0)) throw std::invalid_argument("run_to needs a positive max_dt.");
  if (t_end < t_ - 1e-12 * std::max(1.0, std::abs(t_)))
    throw std::invalid_argument("run_to cannot integrate backwards in time.");
  const double span = t_end - t_;
  if (span <= 0.0) return;
  const long steps = std::max(1L, static_cast<long>(std::ceil(span / max_dt - 1e-12)));
  const double dt = span / steps;
  for (long s = 0; s < steps; ++s) step(dt);
  t_ = t_end;  // remove accumulated round-off in the clock
}

double bernoulli(double x) {
  if (std::abs(x) < 1e-4) return 1.0 - 0.5 * x + x * x / 12.0;
  if (x > 700.0) return x * std::exp(-x);
  return x / std::expm1(x);
}

double drift_diffusion_decay_rate(const DriftDiffusionCoefficients& c, double nB, double TB,
                                  double k) {
  return c.D(nB, TB) * k * k;  // eq. H17
}

// ---------------------------------------------------------------- spectral solver
namespace {
using cplx = std::complex<double>;

// FFTW's planner is not thread-safe: plan creation and destruction are serialised.
std::mutex& fftw_planner_mutex() {
  static std::mutex m;
  return m;
}

// phi1(z) = (e^z - 1)/z, phi2(z) = (e^z - 1 - z)/z^2, with Taylor series near 0 to avoid
// cancellation (|z| < 0.2: 14 terms give full double precision).
void etd_phis(cplx z, cplx& e, cplx& p1, cplx& p2) {
  e = std::exp(z);
  if (std::abs(z) < 0.2) {
    cplx t1 = 0.0, t2 = 0.0, term = 1.0;  // term = z^k/k!
    for (int k = 0; k < 16; ++k) {
      t1 += term / static_cast<double>(k + 1);
      t2 += term / static_cast<double>((k + 1) * (k + 2));
      term *= z / static_cast<double>(k + 1);
    }
    p1 = t1;
    p2 = t2;
  } else {
    p1 = (e - 1.0) / z;
    p2 = (e - 1.0 - z) / (z * z);
  }
}
}  // namespace

struct SpectralSolver::Impl {
  const Grid& g;
  int dim;
  std::size_t nr, nc;           // real and complex array sizes
  std::array<int, 3> nfft{};    // FFTW dims, slowest first
  double* rbuf = nullptr;
  fftw_complex* cbuf = nullptr;
  fftw_plan fwd = nullptr, bwd = nullptr;
  std::vector<std::array<double, 3>> kvec;  // Nyquist-zeroed (first derivatives)
  std::vector<double> k2;                   // full |k|^2 (Laplacian)
  std::vector<double> dD;                   // D - Dbar
  std::array<std::vector<double>, 3> dW;    // W - Wbar
  double Dbar = 0.0;
  std::array<double, 3> Wbar{0, 0, 0};
  double cached_dt = -1.0;
  std::vector<cplx> E, P1, P2;
  std::vector<cplx> nh, Nn, ah, Na;
  std::array<std::vector<double>, 3> grad;

  explicit Impl(const Grid& grid) : g(grid), dim(grid.dim) {}
  ~Impl() {
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
    if (fwd) fftw_destroy_plan(fwd);
    if (bwd) fftw_destroy_plan(bwd);
    if (rbuf) fftw_free(rbuf);
    if (cbuf) fftw_free(cbuf);
  }

  void forward(const std::vector<double>& in, std::vector<cplx>& out) {
    std::copy(in.begin(), in.end(), rbuf);
    fftw_execute(fwd);
    out.resize(nc);
    for (std::size_t i = 0; i < nc; ++i) out[i] = cplx(cbuf[i][0], cbuf[i][1]);
  }
  // Unnormalised FFTW inverse divided by the number of points.
  void inverse(const std::vector<cplx>& in, std::vector<double>& out) {
    for (std::size_t i = 0; i < nc; ++i) {
      cbuf[i][0] = in[i].real();
      cbuf[i][1] = in[i].imag();
    }
    fftw_execute(bwd);  // c2r destroys cbuf, which is scratch here
    out.resize(nr);
    const double s = 1.0 / static_cast<double>(nr);
    for (std::size_t i = 0; i < nr; ++i) out[i] = rbuf[i] * s;
  }

  // Explicit remainder of eq. H14: N(n) = div((D - Dbar) grad n - n (W - Wbar)), in Fourier space.
  void nonlinear(const std::vector<cplx>& nhat, std::vector<cplx>& out) {
    std::vector<double> n;
    inverse(nhat, n);
    std::vector<cplx> tmp(nc);
    for (int a = 0; a < dim; ++a) {
      for (std::size_t i = 0; i < nc; ++i) tmp[i] = cplx(0.0, kvec[i][a]) * nhat[i];
      inverse(tmp, grad[a]);
    }
    out.assign(nc, cplx(0.0, 0.0));
    std::vector<double> F(nr);
    std::vector<cplx> Fh;
    for (int a = 0; a < dim; ++a) {
      for (std::size_t i = 0; i < nr; ++i) F[i] = dD[i] * grad[a][i] - n[i] * dW[a][i];
      forward(F, Fh);
      for (std::size_t i = 0; i < nc; ++i) out[i] += cplx(0.0, kvec[i][a]) * Fh[i];
    }
    out[0] = 0.0;  // exact: a divergence has no mean (mass conservation to round-off)
  }
};

SpectralSolver::SpectralSolver(const Background& bg, const DriftDiffusionCoefficients& c)
    : DriftDiffusionSolver(bg, c) {
  const Grid& g = bg_.grid;
  if (!g.all_periodic())
    throw std::invalid_argument("The spectral solver needs a periodic box on every axis; use the finite-volume solver for walls.");
  impl_ = std::make_unique<Impl>(bg_.grid);
  Impl& m = *impl_;
  const int d = g.dim;
  // FFTW row-major dims, slowest first: (n2, n1, n0) with x contiguous.
  for (int a = 0; a < d; ++a) m.nfft[a] = g.n[d - 1 - a];
  m.nr = g.size();
  m.nc = m.nr / g.n[0] * (g.n[0] / 2 + 1);
  {
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
    m.rbuf = fftw_alloc_real(m.nr);
    m.cbuf = fftw_alloc_complex(m.nc);
    // FFTW_ESTIMATE: no timing-based planning, so runs are bit-reproducible.
    m.fwd = fftw_plan_dft_r2c(d, m.nfft.data(), m.rbuf, m.cbuf, FFTW_ESTIMATE);
    m.bwd = fftw_plan_dft_c2r(d, m.nfft.data(), m.cbuf, m.rbuf, FFTW_ESTIMATE);
  }
  if (!m.fwd || !m.bwd) throw std::runtime_error("FFTW could not create the spectral plans.");

  // Wavevectors of the r2c layout: index = i0 + (n0/2+1) (i1 + n1 i2).
  const int h0 = g.n[0] / 2 + 1;
  m.kvec.resize(m.nc);
  m.k2.resize(m.nc);
  for (int i2 = 0; i2 < g.n[2]; ++i2)
    for (int i1 = 0; i1 < g.n[1]; ++i1)
      for (int i0 = 0; i0 < h0; ++i0) {
        const int idx[3] = {i0, i1, i2};
        const std::size_t c = static_cast<std::size_t>(i0) + h0 * (static_cast<std::size_t>(i1) + g.n[1] * i2);
        std::array<double, 3> kk{0, 0, 0};
        double kk2 = 0.0;
        for (int a = 0; a < d; ++a) {
          const int na = g.n[a];
          const int s = idx[a] <= na / 2 ? idx[a] : idx[a] - na;
          const double ka = 2.0 * std::numbers::pi * s / g.length[a];
          kk2 += ka * ka;
          // Odd derivatives: zero the Nyquist mode (its derivative is not real-representable).
          kk[a] = (na % 2 == 0 && idx[a] == na / 2) ? 0.0 : ka;
        }
        m.kvec[c] = kk;
        m.k2[c] = kk2;
      }

  // Drift W = uB + D grad ln Phi (eq. H7), grad ln Phi spectrally.
  std::vector<cplx> lph;
  m.forward(fields_.lnPhi, lph);
  std::array<std::vector<double>, 3> W;
  for (int a = 0; a < 3; ++a) W[a] = bg_.uB[a];
  for (int a = 0; a < d; ++a) {
    std::vector<cplx> t(m.nc);
    for (std::size_t i = 0; i < m.nc; ++i) t[i] = cplx(0.0, m.kvec[i][a]) * lph[i];
    std::vector<double> gr;
    m.inverse(t, gr);
    for (std::size_t i = 0; i < m.nr; ++i) W[a][i] += fields_.D[i] * gr[i];
  }
  m.Dbar = *std::max_element(fields_.D.begin(), fields_.D.end());
  m.dD.resize(m.nr);
  for (std::size_t i = 0; i < m.nr; ++i) m.dD[i] = fields_.D[i] - m.Dbar;
  for (int a = 0; a < 3; ++a) {
    double s = 0.0;
    for (double w : W[a]) s += w;
    m.Wbar[a] = a < d ? s / static_cast<double>(m.nr) : 0.0;
    m.dW[a].resize(m.nr);
    for (std::size_t i = 0; i < m.nr; ++i) m.dW[a][i] = W[a][i] - m.Wbar[a];
  }
}

SpectralSolver::~SpectralSolver() = default;

void SpectralSolver::step(double dt) {
  if (!(dt > 0.0)) throw std::invalid_argument("The time step must be positive.");
  Impl& m = *impl_;
  if (dt != m.cached_dt) {
    m.E.resize(m.nc);
    m.P1.resize(m.nc);
    m.P2.resize(m.nc);
    for (std::size_t i = 0; i < m.nc; ++i) {
      cplx kw = 0.0;
      for (int a = 0; a < m.dim; ++a) kw += m.kvec[i][a] * m.Wbar[a];
      const cplx L = -m.Dbar * m.k2[i] - cplx(0.0, 1.0) * kw;  // eq. H14 linear part
      etd_phis(L * dt, m.E[i], m.P1[i], m.P2[i]);
    }
    m.cached_dt = dt;
  }
  // ETDRK2 (Cox & Matthews 2002): a = e^{L dt} u + dt phi1 N(u);
  // u+ = a + dt phi2 (N(a) - N(u)).
  m.forward(n_, m.nh);
  m.nonlinear(m.nh, m.Nn);
  m.ah.resize(m.nc);
  for (std::size_t i = 0; i < m.nc; ++i) m.ah[i] = m.E[i] * m.nh[i] + dt * m.P1[i] * m.Nn[i];
  m.nonlinear(m.ah, m.Na);
  for (std::size_t i = 0; i < m.nc; ++i) m.ah[i] += dt * m.P2[i] * (m.Na[i] - m.Nn[i]);
  m.inverse(m.ah, n_);
  t_ += dt;
}

// ---------------------------------------------------------------- finite-volume solver
struct FiniteVolumeSolver::Impl {
  TimeScheme scheme;
  Eigen::SparseMatrix<double> A;  // dn/dt = A n
  double cached_dt = -1.0;
  Eigen::SparseMatrix<double> lhs, rhs;
  Eigen::SparseLU<Eigen::SparseMatrix<double>> lu;
};

FiniteVolumeSolver::FiniteVolumeSolver(const Background& bg, const DriftDiffusionCoefficients& c,
                                       TimeScheme scheme)
    : DriftDiffusionSolver(bg, c), impl_(std::make_unique<Impl>()) {
  impl_->scheme = scheme;
  const Grid& g = bg_.grid;
  const std::size_t N = g.size();
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(N * (1 + 4 * g.dim));
  for (int a = 0; a < g.dim; ++a) {
    const double h = g.h(a);
    for (int k = 0; k < g.n[2]; ++k)
      for (int j = 0; j < g.n[1]; ++j)
        for (int i = 0; i < g.n[0]; ++i) {
          int idx[3] = {i, j, k};
          // Face between cell idx and its + neighbour along a.
          int nb[3] = {i, j, k};
          nb[a] += 1;
          if (nb[a] == g.n[a]) {
            if (g.bc[a] == Boundary::Wall) continue;  // zero-flux wall: no face term
            nb[a] = 0;
            if (g.n[a] == 1) continue;                // a cell is not its own neighbour
          }
          const std::size_t P = g.index(idx[0], idx[1], idx[2]);
          const std::size_t Q = g.index(nb[0], nb[1], nb[2]);
          const double Df = 0.5 * (fields_.D[P] + fields_.D[Q]);
          // Face drift, eq. H15: W_f = uB_f + D_f (lnPhi_Q - lnPhi_P)/h.
          const double Wf = 0.5 * (bg_.uB[a][P] + bg_.uB[a][Q]) +
                            Df * (fields_.lnPhi[Q] - fields_.lnPhi[P]) / h;
          const double Pe = Wf * h / Df;
          // Scharfetter-Gummel flux P -> Q: F = (D_f/h) [B(-Pe) n_P - B(Pe) n_Q], eq. H16.
          const double cP = Df * bernoulli(-Pe) / (h * h), cQ = Df * bernoulli(Pe) / (h * h);
          trip.emplace_back(P, P, -cP);
          trip.emplace_back(P, Q, cQ);
          trip.emplace_back(Q, P, cP);
          trip.emplace_back(Q, Q, -cQ);
        }
  }
  impl_->A.resize(N, N);
  impl_->A.setFromTriplets(trip.begin(), trip.end());
  impl_->A.makeCompressed();
}

FiniteVolumeSolver::~FiniteVolumeSolver() = default;

std::vector<double> FiniteVolumeSolver::apply(const std::vector<double>& n) const {
  if (n.size() != bg_.grid.size()) throw std::invalid_argument("Field size does not match the grid.");
  Eigen::Map<const Eigen::VectorXd> x(n.data(), n.size());
  Eigen::VectorXd y = impl_->A * x;
  return std::vector<double>(y.data(), y.data() + y.size());
}

void FiniteVolumeSolver::step(double dt) {
  if (!(dt > 0.0)) throw std::invalid_argument("The time step must be positive.");
  Impl& m = *impl_;
  const std::size_t N = bg_.grid.size();
  if (dt != m.cached_dt) {
    Eigen::SparseMatrix<double> I(N, N);
    I.setIdentity();
    const double th = m.scheme == TimeScheme::CrankNicolson ? 0.5 : 1.0;
    m.lhs = I - (th * dt) * m.A;
    m.rhs = I + ((1.0 - th) * dt) * m.A;
    m.lhs.makeCompressed();
    m.lu.compute(m.lhs);
    if (m.lu.info() != Eigen::Success)
      throw std::runtime_error("The finite-volume implicit matrix could not be factorised.");
    m.cached_dt = dt;
  }
  Eigen::Map<Eigen::VectorXd> x(n_.data(), N);
  const Eigen::VectorXd b = m.rhs * x;
  x = m.lu.solve(b);
  t_ += dt;
}

}  // namespace grainbath::hydro
