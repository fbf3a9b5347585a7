#include "dsmc/moments.hpp"

#include <algorithm>

namespace grainbath::dsmc {

void add_raw_moment_sums(const Particles& p, std::size_t lo, std::size_t hi, RawMomentSums& s) {
  s.count += static_cast<double>(hi - lo);  // an integer: exact in any order
  for (std::size_t i = lo; i < hi; ++i) {
    s.v[0] += p.vx[i];
    s.v[1] += p.vy[i];
    s.v[2] += p.vz[i];
    s.e += p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] + p.vz[i] * p.vz[i];
  }
}

void raw_moment_sums(const Particles& p, const std::vector<std::size_t>& bounds, std::vector<RawMomentSums>& out) {
  const std::size_t blocks = bounds.empty() ? 0 : bounds.size() - 1;
  out.assign(blocks, RawMomentSums{});
#pragma omp parallel for schedule(static)
  for (std::size_t b = 0; b < blocks; ++b) {
    RawMomentSums s;
    add_raw_moment_sums(p, bounds[b], bounds[b + 1], s);
    out[b] = s;
  }
}

void central_moment_sums(const Particles& p, const std::vector<std::size_t>& bounds, const Vec3& u,
                         std::vector<CentralMomentSums>& out) {
  const std::size_t blocks = bounds.empty() ? 0 : bounds.size() - 1;
  out.assign(blocks, CentralMomentSums{});
#pragma omp parallel for schedule(static)
  for (std::size_t b = 0; b < blocks; ++b) {
    CentralMomentSums s;
    add_central_moment_sums(p, bounds[b], bounds[b + 1], u, s);
    out[b] = s;
  }
}

void add_central_moment_sums(const Particles& p, std::size_t lo, std::size_t hi, const Vec3& u, CentralMomentSums& s) {
  for (std::size_t i = lo; i < hi; ++i) {
    const double cx = p.vx[i] - u.x, cy = p.vy[i] - u.y, cz = p.vz[i] - u.z;
    const double c2 = cx * cx + cy * cy + cz * cz;
    s.c2 += c2;
    s.c4 += c2 * c2;
    s.c6 += c2 * c2 * c2;
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
}

Moments moments_from_raw(const std::vector<RawMomentSums>& raw, double mass) {
  Moments m;
  RawMomentSums tot;
  for (const auto& s : raw) {
    tot.count += s.count;
    for (int k = 0; k < 3; ++k) tot.v[k] += s.v[k];
    tot.e += s.e;
  }
  m.count = tot.count;
  if (m.count == 0) return m;
  const double inv = 1.0 / m.count;
  m.mean_velocity = {tot.v[0] * inv, tot.v[1] * inv, tot.v[2] * inv};
  m.kinetic_energy = 0.5 * mass * tot.e;
  return m;
}

void finish_moments(const std::vector<CentralMomentSums>& central, double mass, Moments& m) {
  if (m.count == 0) return;
  CentralMomentSums t;
  for (const auto& s : central) {
    t.c2 += s.c2;
    t.c4 += s.c4;
    t.c6 += s.c6;
    for (int k = 0; k < 6; ++k) t.p[k] += s.p[k];
    for (int k = 0; k < 3; ++k) t.q[k] += s.q[k];
  }
  const double inv = 1.0 / m.count;
  m.temperature = mass * t.c2 * inv / 3.0;
  const double theta = m.temperature / mass;
  m.a2 = theta > 0 ? t.c4 * inv / (15.0 * theta * theta) - 1.0 : 0.0;
  // third Sonine coefficient (docs/closures.md eq. H2): with f = phi [1 + a2 S2 + a3 S3] in
  // c = v / sqrt(2T/m), <c^6> = (105/8)(1 + 3 a2 - a3), i.e. <|v - u|^6> = 105 (T/m)^3 (1 + 3 a2 - a3)
  // (<x^3 S2> = 315/8 and <x^3 S3> = -105/8 over phi, x = c^2); a Maxwellian has a3 = 0
  m.a3 = theta > 0 ? 1.0 + 3.0 * m.a2 - t.c6 * inv / (105.0 * theta * theta * theta) : 0.0;
  for (int k = 0; k < 6; ++k) m.pressure[k] = mass * t.p[k] * inv;
  m.heat_flux = {0.5 * mass * t.q[0] * inv, 0.5 * mass * t.q[1] * inv, 0.5 * mass * t.q[2] * inv};
}

Moments measure_moments(const Particles& p, std::size_t begin, std::size_t end, double mass) {
  constexpr std::size_t kBlock = 4096;
  if (end <= begin) return Moments{};
  std::vector<std::size_t> bounds;
  for (std::size_t lo = begin; lo < end; lo += kBlock) bounds.push_back(lo);
  bounds.push_back(end);
  std::vector<RawMomentSums> raw;
  raw_moment_sums(p, bounds, raw);
  Moments m = moments_from_raw(raw, mass);
  std::vector<CentralMomentSums> central;
  central_moment_sums(p, bounds, m.mean_velocity, central);
  finish_moments(central, mass, m);
  return m;
}

}  // namespace grainbath::dsmc
