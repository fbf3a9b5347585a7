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

void PairStatistics::add(const std::vector<Vec3>& x, const std::vector<Vec3>& v, double temperature) {
  n = x.size();
  ++snapshots;
  temperature_sum += temperature;
  // grid with cells of side >= rmax; all pairs if fewer than 3 cells in some direction
  std::array<int, 3> nc{1, 1, 1};
  bool grid = true;
  for (int d = 0; d < dims; ++d) {
    nc[d] = static_cast<int>(std::floor(comp(L, d) / rmax));
    if (nc[d] < 3) grid = false;
  }
  auto accumulate = [&](std::size_t i, std::size_t j) {
    Vec3 dr = x[j] - x[i];
    for (int d = 0; d < dims; ++d) {
      if (walls[d]) continue;
      double& c = comp(dr, d);
      const double l = comp(L, d);
      c -= l * std::round(c / l);
    }
    if (dims == 2) dr.z = 0.0;
    const double r2 = norm2(dr);
    if (r2 >= rmax * rmax) return;
    const double r = std::sqrt(r2);
    const std::size_t b = static_cast<std::size_t>(r / gr_bin);
    if (b < gr_counts.size()) gr_counts[b] += 1.0;
    const std::size_t c = static_cast<std::size_t>(r / corr_bin);
    if (c < corr_counts.size() && r > 0.0) {
      const Vec3 k = (1.0 / r) * dr;
      const double p1 = dot(v[i], k), p2 = dot(v[j], k);
      const Vec3 q1 = v[i] - p1 * k, q2 = v[j] - p2 * k;
      corr_par[c] += p1 * p2;
      corr_perp[c] += dot(q1, q2);
      corr_counts[c] += 1.0;
    }
  };
  if (!grid) {
    for (std::size_t i = 0; i < x.size(); ++i)
      for (std::size_t j = i + 1; j < x.size(); ++j) accumulate(i, j);
    return;
  }
  std::vector<std::vector<std::uint32_t>> cells(static_cast<std::size_t>(nc[0]) * nc[1] * nc[2]);
  auto index = [&](int cx, int cy, int cz) { return (static_cast<std::size_t>(cz) * nc[1] + cy) * nc[0] + cx; };
  std::vector<std::array<int, 3>> cc(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    for (int d = 0; d < 3; ++d) {
      int c = 0;
      if (d < dims) {
        const double l = comp(L, d);
        double p = comp(x[i], d);
        p -= l * std::floor(p / l);
        c = std::clamp(static_cast<int>(p / l * nc[d]), 0, nc[d] - 1);
      }
      cc[i][d] = c;
    }
    cells[index(cc[i][0], cc[i][1], cc[i][2])].push_back(static_cast<std::uint32_t>(i));
  }
  const int zr = dims == 3 ? 1 : 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    for (int dz = -zr; dz <= zr; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int off[3] = {dx, dy, dz};
          int c[3];
          bool skip = false;
          for (int d = 0; d < 3; ++d) {
            c[d] = cc[i][d] + off[d];
            if (c[d] < 0 || c[d] >= nc[d]) {
              if (d >= dims || walls[d]) { skip = true; break; }
              c[d] = (c[d] + nc[d]) % nc[d];
            }
          }
          if (skip) continue;
          for (std::uint32_t j : cells[index(c[0], c[1], c[2])])
            if (j > i) accumulate(i, j);
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
