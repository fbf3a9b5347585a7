#include "dsmc/moments.hpp"

#include <vector>

namespace grainbath::dsmc {

namespace {
constexpr std::size_t kBlock = 4096;

struct RawSums {
  double v[3] = {0, 0, 0};
  double e = 0;
};
struct CentralSums {
  double c2 = 0, c4 = 0;
  double p[6] = {0, 0, 0, 0, 0, 0};
  double q[3] = {0, 0, 0};
};
}  // namespace

Moments measure_moments(const Particles& p, std::size_t begin, std::size_t end, double mass) {
  Moments m;
  const std::size_t n = end - begin;
  m.count = static_cast<double>(n);
  if (n == 0) return m;
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  std::vector<RawSums> raw(blocks);
#pragma omp parallel for schedule(static)
  for (std::size_t b = 0; b < blocks; ++b) {
    RawSums s;
    const std::size_t lo = begin + b * kBlock, hi = std::min(end, lo + kBlock);
    for (std::size_t i = lo; i < hi; ++i) {
      s.v[0] += p.vx[i];
      s.v[1] += p.vy[i];
      s.v[2] += p.vz[i];
      s.e += p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] + p.vz[i] * p.vz[i];
    }
    raw[b] = s;
  }
  RawSums tot;
  for (const auto& s : raw) {
    for (int k = 0; k < 3; ++k) tot.v[k] += s.v[k];
    tot.e += s.e;
  }
  const double inv = 1.0 / m.count;
  m.mean_velocity = {tot.v[0] * inv, tot.v[1] * inv, tot.v[2] * inv};
  m.kinetic_energy = 0.5 * mass * tot.e;
  const Vec3 u = m.mean_velocity;
  std::vector<CentralSums> cen(blocks);
#pragma omp parallel for schedule(static)
  for (std::size_t b = 0; b < blocks; ++b) {
    CentralSums s;
    const std::size_t lo = begin + b * kBlock, hi = std::min(end, lo + kBlock);
    for (std::size_t i = lo; i < hi; ++i) {
      const double cx = p.vx[i] - u.x, cy = p.vy[i] - u.y, cz = p.vz[i] - u.z;
      const double c2 = cx * cx + cy * cy + cz * cz;
      s.c2 += c2;
      s.c4 += c2 * c2;
      s.p[0] += cx * cx;
      s.p[1] += cy * cy;
      s.p[2] += cz * cz;
      s.p[3] += cx * cy;
      s.p[4] += cx * cz;
      s.p[5] += cy * cz;
      s.q[0] += c2 * cx;
      s.q[1] += c2 * cy;
      s.q[2] += c2 * cz;
    }
    cen[b] = s;
  }
  CentralSums t;
  for (const auto& s : cen) {
    t.c2 += s.c2;
    t.c4 += s.c4;
    for (int k = 0; k < 6; ++k) t.p[k] += s.p[k];
    for (int k = 0; k < 3; ++k) t.q[k] += s.q[k];
  }
  m.temperature = mass * t.c2 * inv / 3.0;
  const double theta = m.temperature / mass;
  m.a2 = theta > 0 ? t.c4 * inv / (15.0 * theta * theta) - 1.0 : 0.0;
  for (int k = 0; k < 6; ++k) m.pressure[k] = mass * t.p[k] * inv;
  m.heat_flux = {0.5 * mass * t.q[0] * inv, 0.5 * mass * t.q[1] * inv, 0.5 * mass * t.q[2] * inv};
  return m;
}

}  // namespace grainbath::dsmc
