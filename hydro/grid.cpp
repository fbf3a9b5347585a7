// hydro/grid.cpp -- grids, coarsening and the background fields of issue #4.
#include "hydro/grid.hpp"

#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace grainbath::hydro {

Grid Grid::make(const std::vector<int>& cells, const std::vector<double>& lengths,
                Boundary bc_all, const std::vector<double>& origin) {
  const int d = static_cast<int>(cells.size());
  if (d < 1 || d > 3)
    throw std::invalid_argument("A grid needs 1, 2 or 3 cell counts.");
  if (lengths.size() != cells.size())
    throw std::invalid_argument("A grid needs one box length per cell count.");
  if (!origin.empty() && origin.size() != cells.size())
    throw std::invalid_argument("A grid origin needs one coordinate per dimension.");
  Grid g;
  g.dim = d;
  for (int a = 0; a < d; ++a) {
    if (cells[a] < 1) {
      std::ostringstream os;
      os << "The cell count along axis " << a << " must be at least 1, got " << cells[a] << ".";
      throw std::invalid_argument(os.str());
    }
    if (!(lengths[a] > 0.0) || !std::isfinite(lengths[a])) {
      std::ostringstream os;
      os << "The box length along axis " << a << " must be positive, got " << lengths[a] << ".";
      throw std::invalid_argument(os.str());
    }
    g.n[a] = cells[a];
    g.length[a] = lengths[a];
    if (!origin.empty()) g.origin[a] = origin[a];
    g.bc[a] = bc_all;
  }
  return g;
}

Grid Grid::from_spacing(const std::vector<double>& lengths, const std::vector<double>& spacing,
                        Boundary bc_all, const std::vector<double>& origin) {
  if (spacing.size() != lengths.size())
    throw std::invalid_argument("A grid needs one spacing per box length.");
  std::vector<int> cells;
  for (std::size_t a = 0; a < lengths.size(); ++a) {
    if (!(spacing[a] > 0.0)) throw std::invalid_argument("A grid spacing must be positive.");
    const double r = lengths[a] / spacing[a];
    const double ri = std::round(r);
    if (ri < 1.0 || std::abs(r - ri) > 1e-9 * std::max(1.0, r)) {
      std::ostringstream os;
      os << "The spacing " << spacing[a] << " does not divide the box length " << lengths[a]
         << " along axis " << a << " (ratio " << r << " is not an integer).";
      throw std::invalid_argument(os.str());
    }
    cells.push_back(static_cast<int>(ri));
  }
  return make(cells, lengths, bc_all, origin);
}

double Grid::cell_volume() const {
  double v = 1.0;
  for (int a = 0; a < dim; ++a) v *= h(a);
  return v;
}

bool Grid::all_periodic() const {
  for (int a = 0; a < dim; ++a)
    if (bc[a] != Boundary::Periodic) return false;
  return true;
}

double Grid::integral(const std::vector<double>& f) const {
  if (f.size() != size()) throw std::invalid_argument("Field size does not match the grid.");
  // Pairwise-free but ordered sum: deterministic and adequate for mass checks at 1e-13.
  long double s = 0.0L;
  for (double v : f) s += v;
  return static_cast<double>(s) * cell_volume();
}

std::vector<double> Grid::sample(const std::function<double(double, double, double)>& f) const {
  std::vector<double> out(size());
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i)
        out[index(i, j, k)] = f(x(0, i), dim > 1 ? x(1, j) : 0.0, dim > 2 ? x(2, k) : 0.0);
  return out;
}

std::vector<double> coarsen(const std::vector<double>& fine, const Grid& fg, const Grid& cg) {
  if (fg.dim != cg.dim) throw std::invalid_argument("Coarsening needs grids of equal dimension.");
  if (fine.size() != fg.size()) throw std::invalid_argument("Field size does not match the fine grid.");
  std::array<int, 3> r{1, 1, 1};
  for (int a = 0; a < fg.dim; ++a) {
    if (fg.n[a] % cg.n[a] != 0) {
      std::ostringstream os;
      os << "The coarse cell count " << cg.n[a] << " does not divide the fine cell count "
         << fg.n[a] << " along axis " << a << ".";
      throw std::invalid_argument(os.str());
    }
    if (std::abs(fg.length[a] - cg.length[a]) > 1e-12 * fg.length[a])
      throw std::invalid_argument("Coarsening needs grids covering the same box.");
    r[a] = fg.n[a] / cg.n[a];
  }
  std::vector<double> out(cg.size(), 0.0);
  const double inv = 1.0 / (static_cast<double>(r[0]) * r[1] * r[2]);
  for (int k = 0; k < fg.n[2]; ++k)
    for (int j = 0; j < fg.n[1]; ++j)
      for (int i = 0; i < fg.n[0]; ++i)
        out[cg.index(i / r[0], j / r[1], k / r[2])] += inv * fine[fg.index(i, j, k)];
  return out;
}

void require_commensurate(const Grid& g, int axis, double k, const char* what) {
  if (axis < 0 || axis >= g.dim) {
    std::ostringstream os;
    os << what << ": axis " << axis << " does not exist on a " << g.dim << "-D grid.";
    throw std::invalid_argument(os.str());
  }
  if (g.bc[axis] != Boundary::Periodic) return;
  const double m = k * g.length[axis] / (2.0 * std::numbers::pi);
  if (std::abs(m - std::round(m)) > 1e-9 * std::max(1.0, std::abs(m)) || std::round(m) == 0.0) {
    std::ostringstream os;
    os << what << ": the wavenumber k = " << k << " is not commensurate with the periodic box "
       << "length " << g.length[axis] << " along axis " << axis << " (k L / 2pi = " << m
       << " is not a nonzero integer).";
    throw std::invalid_argument(os.str());
  }
}

void Background::validate() const {
  const std::size_t N = grid.size();
  if (nB.size() != N || TB.size() != N)
    throw std::invalid_argument("Background nB and TB need one value per grid cell.");
  for (int a = 0; a < 3; ++a)
    if (uB[a].size() != N) throw std::invalid_argument("Background uB needs one value per cell and component.");
  for (std::size_t i = 0; i < N; ++i) {
    if (!(nB[i] > 0.0) || !std::isfinite(nB[i]))
      throw std::invalid_argument("The background density nB must be positive and finite everywhere.");
    if (!(TB[i] > 0.0) || !std::isfinite(TB[i]))
      throw std::invalid_argument("The background temperature TB must be positive and finite everywhere.");
    for (int a = 0; a < 3; ++a)
      if (!std::isfinite(uB[a][i])) throw std::invalid_argument("The background drift uB must be finite.");
  }
}

Background uniform_background(const Grid& g, double nB, double TB, std::array<double, 3> uB) {
  Background b;
  b.grid = g;
  b.nB.assign(g.size(), nB);
  b.TB.assign(g.size(), TB);
  for (int a = 0; a < 3; ++a) b.uB[a].assign(g.size(), uB[a]);
  b.validate();
  return b;
}

Background uniform_drift_background(const Grid& g, double nB, double TB, std::array<double, 3> uB) {
  return uniform_background(g, nB, TB, uB);
}

Background isobaric_background(const Grid& g, double nB0, double TB0, double A, double k,
                               int axis) {
  if (!(std::abs(A) < 1.0))
    throw std::invalid_argument("The isobaric amplitude A must satisfy |A| < 1 so that TB stays positive.");
  require_commensurate(g, axis, k, "isobaric background");
  Background b = uniform_background(g, nB0, TB0);
  for (int kk = 0; kk < g.n[2]; ++kk)
    for (int j = 0; j < g.n[1]; ++j)
      for (int i = 0; i < g.n[0]; ++i) {
        const int idx[3] = {i, j, kk};
        const double x = g.x(axis, idx[axis]);
        const std::size_t c = g.index(i, j, kk);
        b.TB[c] = TB0 * (1.0 + A * std::sin(k * x));
        b.nB[c] = nB0 * TB0 / b.TB[c];  // nB TB = const (isobaric)
      }
  b.validate();
  return b;
}

Background shear_background(const Grid& g, double nB, double TB,
                            const std::function<double(double)>& U) {
  if (g.dim < 2) throw std::invalid_argument("A shear flow U(y) needs a grid of dimension 2 or 3.");
  Background b = uniform_background(g, nB, TB);
  for (int k = 0; k < g.n[2]; ++k)
    for (int j = 0; j < g.n[1]; ++j)
      for (int i = 0; i < g.n[0]; ++i) b.uB[0][g.index(i, j, k)] = U(g.x(1, j));
  b.validate();
  return b;
}

Background sine_shear_background(const Grid& g, double nB, double TB, double U0, double k) {
  if (g.dim < 2) throw std::invalid_argument("A shear flow U(y) needs a grid of dimension 2 or 3.");
  require_commensurate(g, 1, k, "sine shear background");
  return shear_background(g, nB, TB, [U0, k](double y) { return U0 * std::sin(k * y); });
}

}  // namespace grainbath::hydro
