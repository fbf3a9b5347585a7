// hydro/grid.hpp -- uniform cell-centred grids and background (nB, uB, TB) fields per cell.
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <vector>

namespace grainbath::hydro {

enum class Boundary { Periodic, Wall };

// A uniform cell-centred grid in 1-3 dimensions. Cell centres x_i = origin + (i + 1/2) h;
// storage is x-fastest: index = i + n0 (j + n1 k).
struct Grid {
  int dim = 1;
  std::array<int, 3> n{1, 1, 1};
  std::array<double, 3> length{1.0, 1.0, 1.0};
  std::array<double, 3> origin{0.0, 0.0, 0.0};
  std::array<Boundary, 3> bc{Boundary::Periodic, Boundary::Periodic, Boundary::Periodic};

  // Throws std::invalid_argument with a sentence for dim outside 1..3, non-positive counts or
  // lengths, or mismatched vector sizes.
  static Grid make(const std::vector<int>& cells, const std::vector<double>& lengths,
                   Boundary bc_all, const std::vector<double>& origin = {});
  // Cell count from a requested spacing: throws when length/spacing is not an integer
  // (to relative 1e-9): the cells must tile the box exactly.
  static Grid from_spacing(const std::vector<double>& lengths, const std::vector<double>& spacing,
                           Boundary bc_all, const std::vector<double>& origin = {});

  std::size_t size() const { return static_cast<std::size_t>(n[0]) * n[1] * n[2]; }
  double h(int axis) const { return length[axis] / n[axis]; }
  double cell_volume() const;
  double x(int axis, int i) const { return origin[axis] + (i + 0.5) * h(axis); }
  std::size_t index(int i, int j = 0, int k = 0) const {
    return static_cast<std::size_t>(i) + static_cast<std::size_t>(n[0]) * (j + static_cast<std::size_t>(n[1]) * k);
  }
  bool all_periodic() const;
  // Sum of values times the cell volume.
  double integral(const std::vector<double>& f) const;
  // Field from a function of the cell centre (unused coordinates are 0).
  std::vector<double> sample(const std::function<double(double, double, double)>& f) const;
};

// Cell averages of a fine-grid field on a coarser grid covering the same box. Throws unless
// every fine cell count is an integer multiple of the coarse one ("cell counts must divide").
std::vector<double> coarsen(const std::vector<double>& fine, const Grid& fine_grid,
                            const Grid& coarse_grid);

// Throws unless k * length / (2 pi) is a (nonzero) integer: a sinusoid of wavenumber k is
// periodic on a periodic axis only then.
void require_commensurate(const Grid& g, int axis, double k, const char* what);

// Background fields per cell (Bisi-Spiga: nB, uB, TB obey the Euler equations, eq. 14; the
// steady cases below do). Only fields are stored: the solver evaluates D and drift from them.
struct Background {
  Grid grid;
  std::vector<double> nB, TB;
  std::array<std::vector<double>, 3> uB;
  void validate() const;  // sizes, positivity, finiteness; throws with a sentence
};

// Uniform nB, TB and uniform drift uB (Galilean drift: Euler-steady).
Background uniform_background(const Grid& g, double nB, double TB,
                              std::array<double, 3> uB = {0.0, 0.0, 0.0});
// Uniform nB, TB with a uniform drift uB (the "uniform drift" case of issue #4).
Background uniform_drift_background(const Grid& g, double nB, double TB, std::array<double, 3> uB);
// Isobaric temperature profile TB = TB0 (1 + A sin(k x_axis)), nB TB = nB0 TB0, uB = 0
// (steady Euler: grad(nB TB) = 0). Requires |A| < 1 and, on a periodic axis, commensurate k.
Background isobaric_background(const Grid& g, double nB0, double TB0, double A, double k,
                               int axis = 0);
// Steady shear flow uB = (U(y), 0, 0) with uniform nB, TB (grid dim >= 2).
Background shear_background(const Grid& g, double nB, double TB,
                            const std::function<double(double)>& U);
// Periodic shear U(y) = U0 sin(k y); k must be commensurate on a periodic y axis.
Background sine_shear_background(const Grid& g, double nB, double TB, double U0, double k);

}  // namespace grainbath::hydro
