// hydro/drift_diffusion.hpp -- solvers of the drift-diffusion limit (Bisi-Spiga eq. 36,
// docs/hydro.md eq. H7):
//   dn/dt = div( D grad n - n W ),   W = uB + D grad ln Phi,
//   Phi = TB^(-p) (nB TB)^(m/mB),    D = eps Dhat sqrt(TB/m)/nB.
// Phi is the zero-drift equilibrium shape (n ~ Phi when uB = 0).
#pragma once

#include "hydro/grid.hpp"
#include "hydro/transport.hpp"

#include <complex>
#include <memory>
#include <vector>

namespace grainbath::hydro {

// Per-cell coefficient fields of eq. H7 built from a background and a coefficient set.
struct DriftDiffusionFields {
  std::vector<double> D;       // diffusion coefficient
  std::vector<double> lnPhi;   // log of the equilibrium shape, eq. H7b
  static DriftDiffusionFields build(const Background& bg, const DriftDiffusionCoefficients& c);
};

// Common interface: both solvers own their density array and advance it in time.
class DriftDiffusionSolver {
 public:
  virtual ~DriftDiffusionSolver() = default;
  virtual void step(double dt) = 0;
  // Advances to t_end with equal steps no longer than max_dt (the last step is not shortened:
  // the step is (t_end - t)/ceil((t_end - t)/max_dt)).
  void run_to(double t_end, double max_dt);
  double time() const { return t_; }
  const Grid& grid() const { return bg_.grid; }
  const Background& background() const { return bg_; }
  const std::vector<double>& density() const { return n_; }
  void set_density(const std::vector<double>& n);
  double mass() const { return bg_.grid.integral(n_); }

 protected:
  DriftDiffusionSolver(const Background& bg, const DriftDiffusionCoefficients& c);
  Background bg_;
  DriftDiffusionCoefficients coef_;
  DriftDiffusionFields fields_;
  std::vector<double> n_;
  double t_ = 0.0;
};

// Pseudo-spectral solver for all-periodic boxes (FFTW, FFTW_ESTIMATE plans): exponential time
// differencing ETDRK2 (Cox-Matthews) with the stiff linear part -Dbar k^2 - i Wbar.k exact
// (Dbar = max D, Wbar = mean W) and the variable-coefficient remainder
//   div((D - Dbar) grad n - n (W - Wbar))
// explicit (docs/hydro.md eq. H14). The k = 0 mode is untouched, so mass is conserved to
// round-off; for a uniform background the scheme is exact.
class SpectralSolver final : public DriftDiffusionSolver {
 public:
  SpectralSolver(const Background& bg, const DriftDiffusionCoefficients& c);
  ~SpectralSolver() override;
  SpectralSolver(const SpectralSolver&) = delete;
  SpectralSolver& operator=(const SpectralSolver&) = delete;
  void step(double dt) override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

enum class TimeScheme { BackwardEuler, CrankNicolson };

// Conservative finite-volume solver (periodic or zero-flux walls per axis): Scharfetter-Gummel
// face fluxes (exponentially fitted, exactly well-balanced for n ~ Phi, second order for smooth
// fields) and implicit time stepping (Crank-Nicolson, order 2, or backward Euler, order 1) with
// a sparse LU solve; every column of the operator sums to zero, so mass is conserved to
// round-off (docs/hydro.md eqs. H15-H16).
class FiniteVolumeSolver final : public DriftDiffusionSolver {
 public:
  FiniteVolumeSolver(const Background& bg, const DriftDiffusionCoefficients& c,
                     TimeScheme scheme = TimeScheme::CrankNicolson);
  ~FiniteVolumeSolver() override;
  FiniteVolumeSolver(const FiniteVolumeSolver&) = delete;
  FiniteVolumeSolver& operator=(const FiniteVolumeSolver&) = delete;
  void step(double dt) override;
  // Discrete operator applied to a field (dn/dt = A n).
  std::vector<double> apply(const std::vector<double>& n) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Bernoulli function B(x) = x/(e^x - 1) (Scharfetter-Gummel weights), accurate near x = 0.
double bernoulli(double x);

// Smallest decay rate of a density perturbation exp(i k.x) in a uniform background:
// Re lambda = D k^2 (docs/hydro.md eq. H17).
double drift_diffusion_decay_rate(const DriftDiffusionCoefficients& c, double nB, double TB,
                                  double k);

}  // namespace grainbath::hydro
