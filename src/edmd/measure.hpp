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
  // N(N-1)/2 pairs (periodic box).
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
