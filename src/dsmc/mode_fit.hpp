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

namespace grainbath::dsmc {

// The part of the error of a quantity that is linear in the window-mean cell densities,
// Q = sum_i w_i dn_i/n_i (e.g. the slope of ln n across the cells of a 1D profile: w_i the
// least-squares weights), that comes from the grains' slow density modes along x.
//
// Why: the cell errors of the fields are jackknifed over batches of the window and treat the
// cells as independent, but the density modes of wavelength L/m move all cells together and
// relax only at D (2 pi m/L)^2 (the fundamental of cases/thermal-gradient in about 3 time
// units, a sixth of its window), so the batches cannot see them. Model: the relative density
// fluctuation is sum_m a_m cos(q_m x) + b_m sin(q_m x), q_m = 2 pi m/L, with the equilibrium
// variance 2/N of independent grains for each of a_m, b_m and the correlation
// exp(-D q_m^2 |dt|) (Onsager's regression, as for the density mode: mode_fit above); a window
// mean over W has the variance (2/N) f(D q^2 W), f(u) = (2/u)(1 - (1 - e^-u)/u); a cell
// averages cos(q x) to cos(q x_i) sinc(q h/2). Then
//   Var Q = sum_m (2/N) f(D q_m^2 W) sinc^2(q_m h/2) [(sum_i w_i cos(q_m x_i)/r_i)^2
//                                                      + (sum_i w_i sin(q_m x_i)/r_i)^2],
// r_i = n_i/nbar (the fluctuation is relative to the mean density, the fit's to the cell's),
// summed over m = 1 .. cells/2. D is one coefficient for the whole box (a spatially varying D
// gives modes that are not pure sines: an approximation, tested against seeds in
// cases/thermal-gradient/README.md).
double slow_mode_error(const std::vector<double>& x, const std::vector<double>& w, const std::vector<double>& r,
                       double length, double cell_width, double grains, double diffusion, double window);

}  // namespace grainbath::dsmc
