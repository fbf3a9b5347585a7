#pragma once
// The decay rate of a density mode from its projected amplitude A(t) (summary.json
// `mode.decay_rate`, docs/OUTPUT.md "/mode").
#include <cstddef>
#include <vector>

namespace grainbath::dsmc {

struct ModeDecayFit {
  double rate = 0.0 / 0.0;         // Gamma of A(t) = B exp(-Gamma t)
  double rate_stderr = 0.0 / 0.0;  // from the noise model (see fit_mode_decay)
  double amplitude = 0.0 / 0.0;    // B, the fitted amplitude at t = 0
  std::size_t points = 0;          // samples in the fit window
};

// Least squares of A(t) itself, A_k = B exp(-Gamma t_k) + noise, over the samples with
// from <= t_k <= to (Gauss-Newton, started from a straight line through ln A).
//
// Why A and not ln A: the projection's noise is additive with a constant variance
// noise_variance = 2/N (the variance of 2 cos kx for N grains), so the least squares of A
// is unbiased to first order, while ln(A + xi) has the mean ln A - var/(2A^2) (a bias that
// grows as A decays) and a fit of ln A weighted by the measured A and cut at A > 5 noise
// favours the samples that fluctuated upwards: that fit (grainbath up to 2026-12-05)
// measured Gamma 0.35 % low in cases/density-mode's noise and 0.8 % low with white noise
// (tests/dsmc/test_dsmc_statistics.cpp, DsmcStats.ModeDecay*).
//
// The standard error: the noise of the mode is the grains' own density fluctuation at
// wavenumber k, which relaxes at the rate of the mode itself (Onsager's regression; for
// grains diffusing independently <exp(ik(x(t) - x(0)))> = exp(-D k^2 t)), so it is
// correlated over 1/Gamma, as long as the whole fit window of a typical run. Blocking the
// residuals cannot see that (their blocks are far shorter), which left the old error 2-3
// times below the seed-to-seed scatter. The error here is the sandwich
// Var = M^-1 J^T C J M^-1 (M = J^T J, J the Jacobian of the model) with the noise covariance
// C_kl = noise_variance exp(-Gamma |t_k - t_l|).
// Fewer than 3 samples, or no convergence: rate NaN.
ModeDecayFit fit_mode_decay(const std::vector<double>& t, const std::vector<double>& A, double noise_variance,
                            double from, double to);

}  // namespace grainbath::dsmc
