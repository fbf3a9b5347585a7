#pragma once
// Reference formulas for the EDMD engine (units: sigma = 1, m = 1, k_B = 1).
// Each function cites its source; the derivations are in docs/edmd.md.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "operators/restitution.hpp"

namespace grainbath::edmd::theory {

// Number density from the packing (solid) fraction: 2D nu = n pi/4, 3D phi = n pi/6.
inline double number_density(int dims, double packing) {
  return dims == 2 ? 4.0 * packing / std::numbers::pi : 6.0 * packing / std::numbers::pi;
}
// Close packing: hexagonal disks pi/(2 sqrt 3), fcc spheres pi/(3 sqrt 2).
inline double close_packing(int dims) {
  return dims == 2 ? std::numbers::pi / (2.0 * std::sqrt(3.0)) : std::numbers::pi / (3.0 * std::sqrt(2.0));
}

// Henderson (1975) hard-disk fluid EOS: Z = (1 + nu^2/8) / (1 - nu)^2.
inline double z_henderson(double nu) { return (1.0 + nu * nu / 8.0) / ((1.0 - nu) * (1.0 - nu)); }

// Hard-disk fluid EOS fitted to the Kolafa-Rottner (2006) MD data (H. Liu 2020, eq. 1, stable
// fluid): Z = (1 + nu^2/8 + nu^3/18 - 4 nu^4/21) / (1 - nu)^2. Agrees with Henderson to 0.2% at
// nu <= 0.5 and corrects its overestimate near the hexatic transition.
inline double z_disk_kr(double nu) {
  const double n2 = nu * nu;
  return (1.0 + n2 / 8.0 + n2 * nu / 18.0 - 4.0 * n2 * n2 / 21.0) / ((1.0 - nu) * (1.0 - nu));
}

// Carnahan-Starling hard-sphere EOS: Z = (1 + phi + phi^2 - phi^3) / (1 - phi)^3.
inline double z_carnahan_starling(double phi) {
  const double d = 1.0 - phi;
  return (1.0 + phi + phi * phi - phi * phi * phi) / (d * d * d);
}

// Contact value g(sigma) consistent with the EOS through the virial route
// Z = 1 + 2 nu g (2D), Z = 1 + 4 phi g (3D).
inline double g_contact_from_z(int dims, double packing, double z) {
  return (z - 1.0) / ((dims == 2 ? 2.0 : 4.0) * packing);
}
// Bizon eq. 5 (2D, "Carnahan-Starling" for disks = Henderson): G_CS = nu (16 - 7 nu) / (16 (1 - nu)^2),
// g = G/nu = (1 - 7 nu/16)/(1 - nu)^2.
inline double g_contact_disk_cs(double nu) { return (1.0 - 7.0 * nu / 16.0) / ((1.0 - nu) * (1.0 - nu)); }
// 3D Carnahan-Starling contact value g = (1 - phi/2)/(1 - phi)^3.
inline double g_contact_sphere_cs(double phi) { return (1.0 - 0.5 * phi) / std::pow(1.0 - phi, 3); }

// Kolafa-Labik-Malijevsky (2004) hard-sphere EOS (fitted to MD; ~0.01 % accurate in the
// stable fluid): Z = (1 + phi + phi^2 - (2/3)(phi^3 + phi^4)) / (1 - phi)^3. CS is 0.15-0.3 %
// below it at phi = 0.2-0.45.
inline double z_sphere_klm(double phi) {
  const double d = 1.0 - phi;
  return (1.0 + phi + phi * phi - 2.0 / 3.0 * (phi * phi * phi + phi * phi * phi * phi)) / (d * d * d);
}

// Best available reference Z(packing) for elastic grains: KR fit (2D), CS (3D).
inline double z_reference(int dims, double packing) {
  return dims == 2 ? z_disk_kr(packing) : z_carnahan_starling(packing);
}
inline double g_contact_reference(int dims, double packing) {
  return g_contact_from_z(dims, packing, z_reference(dims, packing));
}

// Enskog collision frequency per particle (collisions a particle takes per unit time):
//   2D: omega = 2 n g sigma sqrt(pi T / m);  3D: omega = 4 n g sigma^2 sqrt(pi T / m).
// (n g sigma^{D-1} * <|g.k| over the hemisphere of contact> with Maxwellian relative velocity.)
inline double enskog_frequency(int dims, double packing, double g, double temperature) {
  const double n = number_density(dims, packing);
  const double c = std::sqrt(std::numbers::pi * temperature);
  return (dims == 2 ? 2.0 : 4.0) * n * g * c;
}

// Bizon eq. 14 (2D): gamma0 = 16 nu G (1 - e^2) T^{3/2} / (pi^{3/2} sigma^3), the loss rate of
// n T (energy per unit area) by inelastic collisions with constant e and molecular chaos.
// In D dims the same derivation gives gamma0 = (1 - e^2)/4 <v_n^2>_c (n omega / 2)
// with <v_n^2>_c = 4T: gamma0 = (1 - e^2) T n omega / 2.
inline double gamma0(int dims, double packing, double g, double e, double temperature) {
  const double n = number_density(dims, packing);
  return 0.5 * (1.0 - e * e) * temperature * n * enskog_frequency(dims, packing, g, temperature);
}

// Collision-weighted distribution of the normal relative speed under molecular chaos
// (Bizon, after eq. 33): P_c(v_n) = v_n/(2T) exp(-v_n^2/(4T)); <v_n^2>_c = 4T, <v_n>_c = sqrt(pi T).
inline double normal_speed_density(double vn, double temperature) {
  return vn / (2.0 * temperature) * std::exp(-vn * vn / (4.0 * temperature));
}

// <(1 - e(v_n)^2) v_n^2>_c over P_c by composite Simpson quadrature on [0, 12 sqrt(T)]
// (Bizon eqs. 27-30 evaluated numerically rather than through incomplete gamma functions).
template <class Law>
double mean_loss_factor(const Law& law, double temperature) {
  const int n = 4000;
  const double hi = 12.0 * std::sqrt(temperature);
  const double h = hi / n;
  double s = 0.0;
  for (int k = 0; k <= n; ++k) {
    const double v = k * h;
    const double e = restitution(law, v).e;
    const double f = (1.0 - e * e) * v * v * normal_speed_density(v, temperature);
    s += f * (k == 0 || k == n ? 1.0 : (k % 2 ? 4.0 : 2.0));
  }
  return s * h / 3.0;
}

// Bizon eqs. 29-30: gamma_e, the molecular-chaos loss rate with e depending on v_n:
// gamma_e = (1/4) <(1 - e^2) v_n^2>_c * (n omega / 2).
template <class Law>
double gamma_e(const Law& law, int dims, double packing, double g, double temperature) {
  const double n = number_density(dims, packing);
  return 0.25 * mean_loss_factor(law, temperature) * 0.5 * n * enskog_frequency(dims, packing, g, temperature);
}

// van Noije-Ernst (1998) second Sonine coefficient of the homogeneous cooling state:
// a2 = 16 (1 - e)(1 - 2 e^2) / (9 + 24 d - e (41 - 8 d) + 30 (1 - e) e^2).
inline double a2_van_noije_ernst(int dims, double e) {
  const double d = dims;
  return 16.0 * (1.0 - e) * (1.0 - 2.0 * e * e) / (9.0 + 24.0 * d - e * (41.0 - 8.0 * d) + 30.0 * (1.0 - e) * e * e);
}

// Haff's law T(t) = T0 / (1 + t/t0)^2 with dT/dt = -zeta T, zeta = (2/D) gamma0 /(n T)
// (energy density (D/2) n T) times the Sonine correction (1 + 3 a2 / 16).
// Returns t0 = 2 / (zeta(T0)).
inline double haff_time(int dims, double packing, double g, double e, double t0_temperature, bool sonine) {
  const double n = number_density(dims, packing);
  double zeta = (2.0 / dims) * gamma0(dims, packing, g, e, t0_temperature) / (n * t0_temperature);
  if (sonine) zeta *= 1.0 + 3.0 * a2_van_noije_ernst(dims, e) / 16.0;
  return 2.0 / zeta;
}

// Temperature relaxation of Maxwellian grains (mass 1) in the background medium (elastic
// grain-medium collisions, rate K |g| per grain, K = nB/eps, alpha = mB/(m + mB)); re-derived
// in docs/edmd.md from the centre-of-mass form of Bisi-Spiga eq. 3: per collision
// dE = m alpha V.(<g'> - g), <g'> = 0 (3D, isotropic), -g/3 (2D hard disks), and
// <|g| V.g> = (T - TB) <|g|^3> / (M (s1 + s2)), s1 = T/m, s2 = TB/mB:
//   3D: dT/dt = -(16/3) sqrt(2/pi) alpha (1-alpha) K sqrt(s1 + s2) (T - TB)
//   2D: dT/dt = -4 sqrt(pi/2)      alpha (1-alpha) K sqrt(s1 + s2) (T - TB)
inline double background_heating_rate(int dims, double T, double TB, double K, double alpha) {
  const double mB = alpha / (1.0 - alpha);
  const double c = dims == 3 ? 16.0 / 3.0 * std::sqrt(2.0 / std::numbers::pi) : 4.0 * std::sqrt(std::numbers::pi / 2.0);
  return -c * alpha * (1.0 - alpha) * K * std::sqrt(T + TB / mB) * (T - TB);
}

// Bizon eq. 27 with the Enskog factor: collisional cooling dT/dt = -(2/D) gamma_e(T) / n.
template <class Law>
double collisional_cooling_rate(const Law& law, int dims, double packing, double g, double T) {
  return -(2.0 / dims) * gamma_e(law, dims, packing, g, T) / number_density(dims, packing);
}

// Steady granular temperature in the medium: background heating = collisional cooling
// (Maxwellian grains, molecular chaos, g(sigma) from the reference EOS). Bisection on (0, TB].
template <class Law>
double steady_temperature_medium(const Law& law, int dims, double packing, double TB, double K, double alpha) {
  const double g = g_contact_reference(dims, packing);
  auto f = [&](double T) {
    return background_heating_rate(dims, T, TB, K, alpha) + collisional_cooling_rate(law, dims, packing, g, T);
  };
  double lo = 1e-8 * TB, hi = TB;
  if (f(hi) >= 0.0) return TB;
  for (int it = 0; it < 200; ++it) {
    const double m = 0.5 * (lo + hi);
    (f(m) > 0.0 ? lo : hi) = m;
  }
  return 0.5 * (lo + hi);
}

// ---- Driving walls (thesis ch. 3, eqs. 3.12 and B.1-B.4; derivation in docs/edmd.md) ----
// Two flat walls a distance `width` apart (the box edge along their normal), each with
// driving speed v and restitution alpha: a grain hitting it with normal speed u leaves with
// alpha u + v. Homogeneous Maxwellian gas at density n, temperature T (m = 1).
struct WallDriving {
  double v_low = 0.0, v_high = 0.0;
  double alpha_low = 1.0, alpha_high = 1.0;
  double width = 1.0;
};

// Mean energy a wall gives per hit, averaged over the flux-weighted (Rayleigh) normal speeds
// of a Maxwellian: <u>_flux = sqrt(pi T/2), <u^2>_flux = 2T:
//   <dE> = (1/2)[v^2 + 2 alpha v <u>_flux - (1 - alpha^2) <u^2>_flux].
// thesis_reading = true replaces <u>_flux by the Maxwell mean <|v_x|> = sqrt(2T/pi), which is
// how the extracted eq. B.1 reads its cross term (4 alpha v sqrt(T/(2 pi))); kept to let the
// simulation decide between the two.
inline double wall_energy_per_hit(double v, double alpha, double T, bool thesis_reading = false) {
  const double u1 = thesis_reading ? std::sqrt(2.0 * T / std::numbers::pi) : std::sqrt(std::numbers::pi * T / 2.0);
  return 0.5 * (v * v + 2.0 * alpha * v * u1 - (1.0 - alpha * alpha) * 2.0 * T);
}

// Energy per grain and unit time given by both walls: hits per grain and time on one wall =
// n_c sqrt(T/(2 pi)) / (n width), with the contact density n_c = n * contact (contact = Z(nu)
// by the contact theorem P = n_c T at a hard wall; 1 for the dilute form).
inline double wall_input_per_grain(const WallDriving& w, double T, double contact, bool thesis_reading = false) {
  const double hits = contact * std::sqrt(T / (2.0 * std::numbers::pi)) / w.width;
  return hits * (wall_energy_per_hit(w.v_low, w.alpha_low, T, thesis_reading) +
                 wall_energy_per_hit(w.v_high, w.alpha_high, T, thesis_reading));
}

// Steady temperature of the energy balance: wall input = collisional loss gamma_e(T)/n
// (molecular chaos, Maxwellian). enskog = true: g(sigma) and the wall contact factor Z from
// the reference EOS at the mean packing; false: the dilute (Boltzmann) form g = Z = 1.
// Bisection in log T; +inf when nothing dissipates (elastic grains and walls).
template <class Law>
double wall_balance_temperature(const Law& law, int dims, double packing, const WallDriving& w, bool enskog,
                                bool thesis_reading = false) {
  const double g = enskog ? g_contact_reference(dims, packing) : 1.0;
  const double contact = enskog ? z_reference(dims, packing) : 1.0;
  const double n = number_density(dims, packing);
  auto f = [&](double T) {
    return wall_input_per_grain(w, T, contact, thesis_reading) - gamma_e(law, dims, packing, g, T) / n;
  };
  const double vmax = std::max({w.v_low, w.v_high, 1e-300});
  double lo = 1e-12 * vmax * vmax, hi = vmax * vmax;
  int grow = 0;
  while (f(hi) > 0.0) {
    lo = hi;
    hi *= 4.0;
    if (++grow > 200) return std::numeric_limits<double>::infinity();
  }
  for (int it = 0; it < 200; ++it) {
    const double m = std::sqrt(lo * hi);
    (f(m) > 0.0 ? lo : hi) = m;
  }
  return std::sqrt(lo * hi);
}

// ---- Heat baths that act at the grain-grain collisions (Bizon Sec. III) ----
// A homogeneous gas heated at its collisions is steady when the energy the bath adds per
// collision equals the mean loss per collision, (1/4) <(1 - e^2) v_n^2>_c (reduced mass 1/2;
// <.>_c over the collision-weighted normal speeds P_c of molecular chaos, above). Both are per
// collision, so the density and g(sigma) drop out. `input(T)` is the bath's energy per
// collision at T. Bisection in log T on a bracket grown from T = 1; +inf when the input
// outruns every loss (elastic grains under white noise).
template <class Law, class Input>
double collision_heating_balance_temperature(const Law& law, const Input& input) {
  auto f = [&](double T) { return input(T) - 0.25 * mean_loss_factor(law, T); };
  double lo = 1.0, hi = 1.0;
  int grow = 0;
  while (f(hi) > 0.0) {
    lo = hi;
    hi *= 4.0;
    if (++grow > 200) return std::numeric_limits<double>::infinity();
  }
  while (f(lo) <= 0.0) {
    hi = lo;
    lo *= 0.25;
    if (++grow > 400) return 0.0;  // no input at any T
  }
  for (int it = 0; it < 200; ++it) {
    const double m = std::sqrt(lo * hi);
    (f(m) > 0.0 ? lo : hi) = m;
  }
  return std::sqrt(lo * hi);
}
// White noise (Bizon eqs. 20-21): `rate` random pairs per collision get kicks +kick u and
// -kick u along a random direction u; each adds kick^2 on average (the cross term
// kick (v_p - v_q).u averages to 0 over u). Steady: rate kick^2 = (1/4) <(1 - e^2) v_n^2>_c;
// constant e: <v_n^2>_c = 4T, T = rate kick^2 / (1 - e^2).
template <class Law>
double white_noise_balance_temperature(const Law& law, int rate, double kick) {
  return collision_heating_balance_temperature(law, [&](double) { return rate * kick * kick; });
}
// Boltzmann bath (Bizon Sec. III C): `rate` random grains per collision get a fresh
// Maxwellian velocity at T_bath, each adding (D/2)(T_bath - T) on average.
template <class Law>
double boltzmann_bath_balance_temperature(const Law& law, int dims, int rate, double T_bath) {
  return collision_heating_balance_temperature(law, [&](double T) { return rate * 0.5 * dims * (T_bath - T); });
}

// ---- Enskog transport coefficients of elastic hard disks / spheres (Bizon eqs. 16-17) ----
// Bizon: to the order kinetic theory is taken, the inelastic mu and kappa equal the elastic
// Enskog values (Sec. II). First Sonine approximation in D dimensions (Garzo & Dufty 1999,
// elastic limit), m = sigma = k_B = 1, chi = g(sigma), phi = packing fraction:
//   eta_0 = (D+2)/8 Gamma(D/2) pi^{-(D-1)/2} sqrt(T)            (2D: sqrt(T/pi)/2)
//   eta   = eta_0 [ (1 + 2^D/(D+2) phi chi)^2 / chi + D/(D+2) 2^{2D+2}/(pi (D+2)) phi^2 chi ]
//   2D:     eta_0 [ (1 + G)^2 / chi + (8/pi) nu G ],  G = nu chi (Bizon's G(nu))
//   lam_0 = D (D+2) / (2 (D-1)) eta_0                            (2D: 2 sqrt(T/pi))
//   lam   = lam_0 [ (1 + 3 2^{D-1}/(D+2) phi chi)^2 / chi + 2^{2D+2} (D-1)/((D+2)^2 pi) phi^2 chi ]
//   2D:     lam_0 [ (1 + 3G/2)^2 / chi + (4/pi) nu G ]
// For D = 3 these are Chapman-Cowling's first-Sonine coefficients (1/chi + 3.2 phi +
// (4/25)(1 + 12/pi) 16 phi^2 chi for eta), checked in tests/edmd/transport_test.cpp.
inline double dilute_viscosity(int dims, double temperature) {
  const double D = dims;
  return (D + 2.0) / 8.0 * std::tgamma(0.5 * D) * std::pow(std::numbers::pi, -(D - 1.0) / 2.0) * std::sqrt(temperature);
}
inline double dilute_conductivity(int dims, double temperature) {
  const double D = dims;
  return D * (D + 2.0) / (2.0 * (D - 1.0)) * dilute_viscosity(dims, temperature);
}
// eta = eta_0 [(1 + x phi chi)^2 / chi + c phi^2 chi]: x = the collisional transfer of the
// first-order (Sonine) perturbation relative to the kinetic flux, c = the collisional
// transfer of the local Maxwellian (both checked by Monte Carlo of the collision integrals in
// tests/edmd/transport_test.cpp).
struct EnskogCoefficients {
  double x = 0.0, c = 0.0;
};
inline EnskogCoefficients enskog_viscosity_coefficients(int dims) {
  const double D = dims;
  return {std::pow(2.0, D) / (D + 2.0), D / (D + 2.0) * std::pow(2.0, 2.0 * D + 2.0) / (std::numbers::pi * (D + 2.0))};
}
inline EnskogCoefficients enskog_conductivity_coefficients(int dims) {
  const double D = dims;
  return {3.0 * std::pow(2.0, D - 1.0) / (D + 2.0),
          std::pow(2.0, 2.0 * D + 2.0) * (D - 1.0) / ((D + 2.0) * (D + 2.0) * std::numbers::pi)};
}
inline double enskog_viscosity(int dims, double packing, double g, double temperature) {
  const EnskogCoefficients k = enskog_viscosity_coefficients(dims);
  const double a = 1.0 + k.x * packing * g;
  return dilute_viscosity(dims, temperature) * (a * a / g + k.c * packing * packing * g);
}
inline double enskog_conductivity(int dims, double packing, double g, double temperature) {
  const EnskogCoefficients k = enskog_conductivity_coefficients(dims);
  const double a = 1.0 + k.x * packing * g;
  return dilute_conductivity(dims, temperature) * (a * a / g + k.c * packing * packing * g);
}

}  // namespace grainbath::edmd::theory
