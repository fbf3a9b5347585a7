#include "edmd/measure.hpp"

#include <algorithm>

namespace grainbath::edmd {

namespace {
inline double& comp(Vec3& v, int d) { return d == 0 ? v.x : d == 1 ? v.y : v.z; }
inline double comp(const Vec3& v, int d) { return d == 0 ? v.x : d == 1 ? v.y : v.z; }
}  // namespace

void PairStatistics::init(int d, Vec3 box, std::array<bool, 3> w, double r_max, double grb, double cb) {
  dims = d;
  L = box;
  walls = w;
  double half = 1e300;
  for (int k = 0; k < dims; ++k) half = std::min(half, 0.5 * comp(L, k));
  rmax = std::min(r_max, half);
  gr_bin = grb;
  corr_bin = cb;
  gr_counts.assign(static_cast<std::size_t>(std::ceil(rmax / gr_bin)), 0.0);
  const std::size_t nc = static_cast<std::size_t>(std::ceil(rmax / corr_bin));
  corr_par.assign(nc, 0.0);
  corr_perp.assign(nc, 0.0);
  corr_counts.assign(nc, 0.0);
}

// One pair (i, j) at separation dr (the nearest image, j minus i): g(r) and the velocity
// correlations (Bizon eqs. 25-26) into the histograms `h`. Pairs at r >= rmax are ignored.
namespace {
struct PairHistograms {
  double* gr;
  double *par, *perp, *count;
  std::size_t gr_bins, corr_bins;
};
inline void accumulate_pair(const PairHistograms& h, double rmax, double gr_bin, double corr_bin, const Vec3& dr,
                            const Vec3& vi, const Vec3& vj) {
  const double r2 = norm2(dr);
  if (r2 >= rmax * rmax) return;
  const double r = std::sqrt(r2);
  const std::size_t b = static_cast<std::size_t>(r / gr_bin);
  if (b < h.gr_bins) h.gr[b] += 1.0;
  const std::size_t c = static_cast<std::size_t>(r / corr_bin);
  if (c < h.corr_bins && r > 0.0) {
    const Vec3 k = (1.0 / r) * dr;
    const double p1 = dot(vi, k), p2 = dot(vj, k);
    const Vec3 q1 = vi - p1 * k, q2 = vj - p2 * k;
    h.par[c] += p1 * p2;
    h.perp[c] += dot(q1, q2);
    h.count[c] += 1.0;
  }
}
}  // namespace

void PairStatistics::add_all_pairs(const std::vector<Vec3>& x, const std::vector<Vec3>& v) {
  const PairHistograms h{gr_counts.data(), corr_par.data(), corr_perp.data(), corr_counts.data(), gr_counts.size(),
                         corr_counts.size()};
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::size_t j = i + 1; j < x.size(); ++j) {
      Vec3 dr = x[j] - x[i];
      for (int d = 0; d < dims; ++d) {
        if (walls[d]) continue;
        double& c = comp(dr, d);
        const double l = comp(L, d);
        c -= l * std::round(c / l);
      }
      if (dims == 2) dr.z = 0.0;
      accumulate_pair(h, rmax, gr_bin, corr_bin, dr, v[i], v[j]);
    }
}

void PairStatistics::add(const std::vector<Vec3>& x, const std::vector<Vec3>& v, double temperature) {
  n = x.size();
  ++snapshots;
  temperature_sum += temperature;
  // Cells of side >= rmax / s, s = 2, where the box holds 2s + 1 = 5 of them along every
  // dimension (else all pairs): the candidates of a grain then cover (2s + 1)^D (rmax/s)^D,
  // 6.25 rmax^2 in 2D against 9 rmax^2 for cells of rmax, with the circle pi rmax^2 of the
  // pairs kept. At N = 10^6 disks (rmax = 10) this step took a third of a run's time with
  // cells of rmax, in id order (perf, docs/performance/edmd.md).
  constexpr int s = 2;
  std::array<int, 3> nc{1, 1, 1};
  bool fits = true;
  for (int d = 0; d < dims; ++d) fits = fits && std::floor(comp(L, d) / (rmax / s)) >= 2 * s + 1;
  if (!fits) {
    add_all_pairs(x, v);
    return;
  }
  for (int d = 0; d < dims; ++d) nc[d] = static_cast<int>(std::floor(comp(L, d) / (rmax / s)));
  // counting sort by cell: positions wrapped into the box (periodic dimensions) and velocities
  // in cell order, so that a cell's members are read as one contiguous run
  const std::size_t ncell = static_cast<std::size_t>(nc[0]) * nc[1] * nc[2];
  std::vector<std::uint32_t> cell_of(x.size()), start(ncell + 1, 0);
  for (std::size_t i = 0; i < x.size(); ++i) {
    std::size_t idx = 0;
    for (int d = dims - 1; d >= 0; --d) {
      const double l = comp(L, d);
      double p = comp(x[i], d);
      if (!walls[d]) p -= l * std::floor(p / l);  // periodic: into [0, L); walls: as is
      const int c = std::clamp(static_cast<int>(p / l * nc[d]), 0, nc[d] - 1);
      idx = idx * static_cast<std::size_t>(nc[d]) + static_cast<std::size_t>(c);
    }
    cell_of[i] = static_cast<std::uint32_t>(idx);
    ++start[idx + 1];
  }
  for (std::size_t c = 0; c < ncell; ++c) start[c + 1] += start[c];
  std::vector<Vec3> xs(x.size()), vs(x.size());
  {
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < x.size(); ++i) {
      const std::uint32_t k = fill[cell_of[i]]++;
      Vec3 p = x[i];
      for (int d = 0; d < dims; ++d)
        if (!walls[d]) comp(p, d) -= comp(L, d) * std::floor(comp(p, d) / comp(L, d));
      if (dims == 2) p.z = 0.0;
      xs[k] = p;
      vs[k] = v[i];
    }
  }
  // Half shell: each unordered pair of cells once (offsets after (0, 0, 0) in z, y, x order),
  // pairs inside a cell once. With at least 2s + 1 cells per dimension the offsets reach
  // distinct cells, and for a pair closer than rmax (<= s cells apart) the image the offset
  // implies is the nearest one.
  struct Offset {
    int d[3];
  };
  std::vector<Offset> shell;
  const int zr = dims == 3 ? s : 0;
  for (int dz = -zr; dz <= zr; ++dz)
    for (int dy = -s; dy <= s; ++dy)
      for (int dx = -s; dx <= s; ++dx)
        if (dz > 0 || (dz == 0 && (dy > 0 || (dy == 0 && dx > 0)))) shell.push_back({{dx, dy, dz}});
  // The rows of cells (cy, cz) in a fixed number of chunks of consecutive rows, each with its
  // own histograms, summed in chunk order at the end: the threads ([run] threads) share the
  // chunks, and the sums do not depend on how many there are.
  const std::size_t rows = static_cast<std::size_t>(nc[1]) * nc[2];
  const std::size_t chunks = std::min<std::size_t>(rows, 64);
  const std::size_t gb = gr_counts.size(), cb = corr_counts.size(), width = gb + 3 * cb;
  std::vector<double> part(chunks * width, 0.0);
#pragma omp parallel for schedule(dynamic, 1)
  for (std::size_t k = 0; k < chunks; ++k) {
    double* base = &part[k * width];
    const PairHistograms h{base, base + gb, base + gb + cb, base + gb + 2 * cb, gb, cb};
    for (std::size_t row = rows * k / chunks; row < rows * (k + 1) / chunks; ++row) {
      const int cy = static_cast<int>(row % static_cast<std::size_t>(nc[1]));
      const int cz = static_cast<int>(row / static_cast<std::size_t>(nc[1]));
      for (int cx = 0; cx < nc[0]; ++cx) {
        const std::size_t a = (static_cast<std::size_t>(cz) * nc[1] + cy) * nc[0] + cx;
        const std::uint32_t a0 = start[a], a1 = start[a + 1];
        for (std::uint32_t i = a0; i < a1; ++i)
          for (std::uint32_t j = i + 1; j < a1; ++j) accumulate_pair(h, rmax, gr_bin, corr_bin, xs[j] - xs[i], vs[i], vs[j]);
        for (const Offset& o : shell) {
          const int c[3] = {cx + o.d[0], cy + o.d[1], cz + o.d[2]};
          int w[3];
          Vec3 shift{0.0, 0.0, 0.0};
          bool skip = false;
          for (int d = 0; d < 3; ++d) {
            w[d] = c[d];
            if (c[d] >= 0 && c[d] < nc[d]) continue;
            if (walls[d]) {
              skip = true;
              break;
            }
            // periodic wrap: the neighbour cell's members are seen shifted by one box length
            w[d] = c[d] < 0 ? c[d] + nc[d] : c[d] - nc[d];
            comp(shift, d) = c[d] < 0 ? -comp(L, d) : comp(L, d);
          }
          if (skip) continue;
          const std::size_t b = (static_cast<std::size_t>(w[2]) * nc[1] + w[1]) * nc[0] + w[0];
          const std::uint32_t b0 = start[b], b1 = start[b + 1];
          for (std::uint32_t i = a0; i < a1; ++i) {
            const Vec3 xi = xs[i] - shift;  // i seen from the neighbour's image
            for (std::uint32_t j = b0; j < b1; ++j) accumulate_pair(h, rmax, gr_bin, corr_bin, xs[j] - xi, vs[i], vs[j]);
          }
        }
      }
    }
  }
  for (std::size_t k = 0; k < chunks; ++k) {
    const double* base = &part[k * width];
    for (std::size_t q = 0; q < gb; ++q) gr_counts[q] += base[q];
    for (std::size_t q = 0; q < cb; ++q) {
      corr_par[q] += base[gb + q];
      corr_perp[q] += base[gb + cb + q];
      corr_counts[q] += base[gb + 2 * cb + q];
    }
  }
}

std::vector<double> PairStatistics::gr_radii() const {
  std::vector<double> r(gr_counts.size());
  for (std::size_t b = 0; b < r.size(); ++b) r[b] = (b + 0.5) * gr_bin;
  return r;
}
std::vector<double> PairStatistics::corr_radii() const {
  std::vector<double> r(corr_counts.size());
  for (std::size_t b = 0; b < r.size(); ++b) r[b] = (b + 0.5) * corr_bin;
  return r;
}

std::vector<double> PairStatistics::gr() const {
  std::vector<double> g(gr_counts.size(), 0.0);
  if (snapshots == 0 || n < 2) return g;
  double volume = 1.0;
  for (int d = 0; d < dims; ++d) volume *= comp(L, d);
  const double density = n / volume;
  for (std::size_t b = 0; b < g.size(); ++b) {
    const double r0 = b * gr_bin, r1 = r0 + gr_bin;
    const double shell = dims == 2 ? std::numbers::pi * (r1 * r1 - r0 * r0)
                                   : 4.0 / 3.0 * std::numbers::pi * (r1 * r1 * r1 - r0 * r0 * r0);
    const double ideal = 0.5 * n * density * shell * snapshots;  // pairs counted once
    g[b] = gr_counts[b] / ideal;
  }
  return g;
}

std::vector<double> PairStatistics::parallel() const {
  std::vector<double> c(corr_counts.size(), 0.0);
  const double t = snapshots ? temperature_sum / snapshots : 1.0;
  for (std::size_t b = 0; b < c.size(); ++b)
    c[b] = corr_counts[b] > 0 ? corr_par[b] / corr_counts[b] / t : 0.0;
  return c;
}

std::vector<double> PairStatistics::perpendicular() const {
  std::vector<double> c(corr_counts.size(), 0.0);
  const double t = snapshots ? temperature_sum / snapshots : 1.0;
  for (std::size_t b = 0; b < c.size(); ++b)
    c[b] = corr_counts[b] > 0 ? corr_perp[b] / corr_counts[b] / (t * (dims - 1)) : 0.0;
  return c;
}

double PairStatistics::contact_value(double width) const {
  const auto g = gr();
  const auto r = gr_radii();
  double sx = 0, sy = 0, sxx = 0, sxy = 0, m = 0;
  for (std::size_t b = 0; b < g.size(); ++b) {
    if (r[b] < 1.0 || r[b] > 1.0 + width) continue;
    sx += r[b], sy += g[b], sxx += r[b] * r[b], sxy += r[b] * g[b], m += 1;
  }
  if (m < 2) return std::nan("");
  const double slope = (m * sxy - sx * sy) / (m * sxx - sx * sx);
  const double icpt = (sy - slope * sx) / m;
  return icpt + slope * 1.0;
}

void VelocityHistogram::init(double v_max, int nbins) {
  vmax = v_max;
  bins = nbins;
  for (auto& c : counts) c.assign(static_cast<std::size_t>(bins), 0.0);
}

void VelocityHistogram::add(const std::vector<Vec3>& v, double temperature, int dims) {
  const double s = 1.0 / std::sqrt(temperature);
  const double w = 2.0 * vmax / bins;
  for (const auto& u : v) {
    for (int d = 0; d < dims; ++d) {
      const double c = comp(u, d) * s;
      const int b = static_cast<int>(std::floor((c + vmax) / w));
      if (b >= 0 && b < bins) counts[d][b] += 1.0;
    }
    const double c2 = norm2(u) / temperature;
    c2_sum += c2;
    c4_sum += c2 * c2;
    samples += 1.0;
  }
  total += static_cast<double>(v.size());
}

std::vector<double> VelocityHistogram::density(int d) const {
  std::vector<double> p(counts[d].size(), 0.0);
  const double w = 2.0 * vmax / bins;
  for (std::size_t b = 0; b < p.size(); ++b) p[b] = total > 0 ? counts[d][b] / (total * w) : 0.0;
  return p;
}

std::vector<double> VelocityHistogram::centres() const {
  std::vector<double> c(static_cast<std::size_t>(bins));
  const double w = 2.0 * vmax / bins;
  for (int b = 0; b < bins; ++b) c[b] = -vmax + (b + 0.5) * w;
  return c;
}

}  // namespace grainbath::edmd
