#pragma once
// Configuration measurements of the EDMD engine (Bizon Sec. IV): the radial distribution
// g(r), the parallel / perpendicular velocity correlations vs separation (Bizon eqs. 25-26)
// and per-component velocity histograms. Taken on synchronised snapshots.
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "operators/vec3.hpp"

namespace grainbath::edmd {

struct PairStatistics {
  int dims = 3;
  Vec3 L;
  std::array<bool, 3> walls{false, false, false};
  double rmax = 5.0;   // range of both g(r) and the correlations
  double gr_bin = 0.02;
  double corr_bin = 0.1;
  std::vector<double> gr_counts;     // pair counts per bin (each pair once)
  std::vector<double> corr_par, corr_perp, corr_counts;
  std::uint64_t snapshots = 0;
  double temperature_sum = 0.0;     // to normalise the correlations by T
  std::size_t n = 0;

  void init(int d, Vec3 box, std::array<bool, 3> w, double r_max, double grb, double cb);
  // Adds one snapshot: positions x, velocities v (mean velocity removed by the caller).
  // The pair loop runs in AVX2 lanes where the CPU has them (GRAINBATH_SIMD=sse2: not);
  // PairKernel::scalar forces the one-pair-at-a-time loop. Both give the same bits (tested).
  enum class PairKernel { automatic, scalar };
  void add(const std::vector<Vec3>& x, const std::vector<Vec3>& v, double temperature,
           PairKernel kernel = PairKernel::automatic);
  // The pairs of one snapshot by the direct O(N^2) sum (used for small boxes, and by the tests
  // as the reference for add()'s cell search); does not count a snapshot.
  void add_all_pairs(const std::vector<Vec3>& x, const std::vector<Vec3>& v);
  // g(r) per bin, reported at the bin centres: pair counts over the ideal-gas count of the
  // N(N-1)/2 pairs (periodic box). The last bin ends at rmax (a partial shell when rmax is not
  // a whole number of bins).
  std::vector<double> gr() const;
  std::vector<double> gr_radii() const;
  std::vector<double> corr_radii() const;
  // <v1par v2par>/T and <v1perp . v2perp>/((D-1) T) per bin (Bizon eqs. 25-26).
  std::vector<double> parallel() const;
  std::vector<double> perpendicular() const;
  // g at contact: a quadratic least-squares fit in r of the bin averages of g(r) over
  // [1, 1 + width] (fitted exactly as bin averages, not centre values), evaluated at r = 1;
  // NaN with fewer than 3 bins there (gr_bin > width / 3).
  double contact_value(double width = 0.1) const;
};

// g(sigma+) of the pair histogram from the grain-grain collisions, exact in expectation for
// any pair velocity distribution (docs/edmd.md, "Contact values of inelastic grains"). A pair
// approaching with normal speed u lies in the shell [sigma, sigma + dr] for dr/u before it
// collides, and leaves it at e(u) u, so over a time t the shell holds on average
// R dr (<1/u>_c + <1/(e u)>_c) pairs (R = N omega/2 collisions per time, <.>_c averages over
// the collisions' pre-collision normal speeds u). Against the ideal count N(N-1)/2 S dr/V of
// gr() (S = 2 pi sigma, 4 pi sigma^2; sigma = 1):
//   g_approaching = omega <1/u>_c / (S n'),  g_receding = omega <1/(e u)>_c / (S n'),
//   n' = (N - 1)/V.
// Molecular chaos at T with e = 1 gives <1/u>_c = sqrt(pi/T)/2 and g_approaching =
// g_receding = g/2 (the virial and the collision rate give g); a driven inelastic gas has
// g_receding / g_approaching = <1/(e u)>_c / <1/u>_c > 1 (its receding pairs are slower), which
// neither the virial nor the rate sees. The averages come from the normal-speed histogram
// (Counters::vn_histogram, bins of width w from 0, counts at the centres (b + 1/2) w; the
// midpoint rule is exact for the flux-weighted P_c(u) ~ u of the first bin and O(w^2)
// elsewhere); collisions beyond the last bin count in `collisions` and add nothing (< 1/(bins w)
// each). e_of(u) is the law's restitution at normal speed u; collisions the TC guard made
// elastic are corrected by receding_correction = Sum over them of (1 - 1/e_law(u))/u
// (Counters::guard_receding), added to the receding sum. NaN if e = 0 anywhere used.
struct CollisionContact {
  double g = std::nan(""), g_approaching = std::nan(""), g_receding = std::nan("");
  double inverse_speed = std::nan(""), inverse_receding_speed = std::nan("");  // <1/u>_c, <1/(e u)>_c
};
template <class RestitutionOf>
CollisionContact contact_from_collisions(int dims, double pair_density, double frequency,
                                         const std::vector<std::uint64_t>& vn_histogram, double bin_width,
                                         std::uint64_t collisions, const RestitutionOf& e_of,
                                         double receding_correction = 0.0) {
  CollisionContact out;
  if (collisions == 0 || !(bin_width > 0.0) || !(pair_density > 0.0)) return out;
  double s1 = 0.0, s2 = 0.0;
  for (std::size_t b = 0; b < vn_histogram.size(); ++b) {
    if (vn_histogram[b] == 0) continue;
    const double u = (b + 0.5) * bin_width, e = e_of(u);
    if (!(e > 0.0)) return out;
    s1 += static_cast<double>(vn_histogram[b]) / u;
    s2 += static_cast<double>(vn_histogram[b]) / (e * u);
  }
  s2 += receding_correction;
  if (!std::isfinite(s2)) return out;
  out.inverse_speed = s1 / static_cast<double>(collisions);
  out.inverse_receding_speed = s2 / static_cast<double>(collisions);
  const double surface = dims == 2 ? 2.0 * std::numbers::pi : 4.0 * std::numbers::pi;
  out.g_approaching = frequency * out.inverse_speed / (surface * pair_density);
  out.g_receding = frequency * out.inverse_receding_speed / (surface * pair_density);
  out.g = out.g_approaching + out.g_receding;
  return out;
}

struct VelocityHistogram {
  double vmax = 5.0;   // in units of sqrt(T)
  int bins = 100;
  std::array<std::vector<double>, 3> counts;
  double total = 0.0;
  void init(double v_max, int nbins);
  void add(const std::vector<Vec3>& v, double temperature, int dims);
  std::vector<double> density(int d) const;  // per unit v/sqrt(T)
  std::vector<double> centres() const;
  // Sonine coefficient a2 = <c^4> / <c^4>_Maxwell - 1 accumulated alongside
  double c4_sum = 0.0, c2_sum = 0.0, samples = 0.0;
};

}  // namespace grainbath::edmd
