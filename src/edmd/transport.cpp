#include "edmd/transport.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <stdexcept>

#include "edmd/theory.hpp"

namespace grainbath::edmd {

namespace {
inline double comp(const Vec3& v, int d) { return d == 0 ? v.x : d == 1 ? v.y : v.z; }
inline int wrap(long k, int S) {
  const long m = k % S;
  return static_cast<int>(m < 0 ? m + S : m);
}
// The integer closest to `d` that is congruent to `target` modulo S: reconciles a level
// difference computed from coordinates with the tracked slabs (round-off at a plane).
inline long reconcile(long d, long target, int S) {
  const long m = ((target - d) % S + S) % S;
  if (m == 0) return d;
  return 2 * m <= S ? d + m : d + m - S;
}
}  // namespace

const TransportField& TransportResult::field(const std::string& name) const {
  for (const auto& f : fields)
    if (f.name == name) return f;
  throw std::out_of_range("transport: no field named '" + name + "'");
}

void SlabTransport::init(const TransportSetup& s, std::size_t particles) {
  if (s.dims != 2 && s.dims != 3) throw std::invalid_argument("transport: dims must be 2 or 3");
  if (s.axis < 0 || s.axis >= s.dims) throw std::invalid_argument("transport: axis outside the dimensions");
  if (s.component < 0 || s.component >= s.dims || s.component == s.axis)
    throw std::invalid_argument("transport: the momentum component must be a box direction other than the axis");
  if (s.slabs < 2) throw std::invalid_argument("transport: need at least two slabs");
  setup_ = s;
  L_ = comp(s.length, s.axis);
  width_ = L_ / s.slabs;
  cross_ = 1.0;
  for (int d = 0; d < s.dims; ++d)
    if (d != s.axis) cross_ *= comp(s.length, d);
  slab_.assign(particles, 0);
  const std::size_t S = static_cast<std::size_t>(s.slabs);
  open_ = TransportBlock{0.0, std::vector<double>(S * kSlab, 0.0), std::vector<double>(S * kPlane, 0.0)};
  blocks_.clear();
  block_intervals_ = 1;
  open_intervals_ = 0;
}

void SlabTransport::contents(const std::vector<Vec3>& v, std::vector<double>& e, std::vector<double>& pc,
                             std::vector<double>& pz) const {
  e.assign(setup_.slabs, 0.0);
  pc.assign(setup_.slabs, 0.0);
  pz.assign(setup_.slabs, 0.0);
  for (std::size_t i = 0; i < v.size(); ++i) {
    const int k = slab_[i];
    e[k] += 0.5 * norm2(v[i]);
    pc[k] += comp(v[i], setup_.component);
    pz[k] += comp(v[i], setup_.axis);
  }
}

void SlabTransport::begin(const std::vector<Vec3>& x, const std::vector<Vec3>& v) {
  if (x.size() != slab_.size() || v.size() != slab_.size())
    throw std::invalid_argument("transport: begin() needs one position and velocity per particle");
  for (std::size_t i = 0; i < x.size(); ++i)
    slab_[i] = wrap(static_cast<long>(std::floor(comp(x[i], setup_.axis) / width_)), setup_.slabs);
  contents(v, e_prev_, pc_prev_, pz_prev_);
}

void SlabTransport::end_interval(double dt, const std::vector<Vec3>& v) {
  std::vector<double> e, pc, pz;
  contents(v, e, pc, pz);
  for (int k = 0; k < setup_.slabs; ++k) {
    double* s = &open_.slab[static_cast<std::size_t>(k) * kSlab];
    s[16] += e[k] - e_prev_[k];
    s[17] += pc[k] - pc_prev_[k];
    s[18] += pz[k] - pz_prev_[k];
  }
  e_prev_ = std::move(e);
  pc_prev_ = std::move(pc);
  pz_prev_ = std::move(pz);
  open_.time += dt;
  if (++open_intervals_ < block_intervals_) return;
  blocks_.push_back(open_);
  std::fill(open_.slab.begin(), open_.slab.end(), 0.0);
  std::fill(open_.plane.begin(), open_.plane.end(), 0.0);
  open_.time = 0.0;
  open_intervals_ = 0;
  if (blocks_.size() >= 2 * kMaxBlocks) {  // merge pairwise: memory stays bounded
    std::vector<TransportBlock> merged;
    for (std::size_t b = 0; b + 1 < blocks_.size(); b += 2) {
      TransportBlock m = blocks_[b];
      m.time += blocks_[b + 1].time;
      for (std::size_t q = 0; q < m.slab.size(); ++q) m.slab[q] += blocks_[b + 1].slab[q];
      for (std::size_t q = 0; q < m.plane.size(); ++q) m.plane[q] += blocks_[b + 1].plane[q];
      merged.push_back(std::move(m));
    }
    blocks_ = std::move(merged);
    block_intervals_ *= 2;
  }
}

TransportCheckpoint SlabTransport::save() const {
  TransportCheckpoint ck;
  ck.stored.reserve(3 * e_prev_.size());
  for (const auto* a : {&e_prev_, &pc_prev_, &pz_prev_}) ck.stored.insert(ck.stored.end(), a->begin(), a->end());
  auto row = [](std::vector<double>& out, const TransportBlock& b) {
    out.push_back(b.time);
    out.insert(out.end(), b.slab.begin(), b.slab.end());
    out.insert(out.end(), b.plane.begin(), b.plane.end());
  };
  for (const auto& b : blocks_) row(ck.blocks, b);
  row(ck.open, open_);
  ck.slab_of.assign(slab_.begin(), slab_.end());
  ck.counts = {block_intervals_, open_intervals_, blocks_.size()};
  return ck;
}

void SlabTransport::load(const TransportCheckpoint& ck, bool begun) {
  const std::size_t S = static_cast<std::size_t>(setup_.slabs), row = 1 + S * kSlab + S * kPlane;
  auto bad = [](const std::string& what) { throw std::runtime_error("transport checkpoint: " + what); };
  if (ck.counts.size() != 3) bad("wrong counter layout");
  const std::uint64_t nblocks = ck.counts[2];
  if (ck.open.size() != row || ck.blocks.size() != nblocks * row || nblocks >= 2 * kMaxBlocks)
    bad("block arrays do not match the case's " + std::to_string(S) + " slabs");
  if (ck.stored.size() != (begun ? 3 * S : 0))
    bad(begun ? "stored slab contents do not match the case's slabs" : "stored slab contents before the measurements began");
  if (ck.slab_of.size() != slab_.size()) bad("tracked slabs do not have one entry per particle");
  if (ck.counts[0] < 1 || ck.counts[1] >= ck.counts[0]) bad("block interval counts out of range");
  for (std::uint64_t k : ck.slab_of)
    if (k >= S) bad("a tracked slab is out of range");
  auto unrow = [&](const double* p, TransportBlock& b) {
    b.time = p[0];
    b.slab.assign(p + 1, p + 1 + S * kSlab);
    b.plane.assign(p + 1 + S * kSlab, p + row);
  };
  blocks_.resize(nblocks);
  for (std::size_t b = 0; b < nblocks; ++b) unrow(ck.blocks.data() + b * row, blocks_[b]);
  unrow(ck.open.data(), open_);
  // empty before begin() (a checkpoint from the equilibration)
  e_prev_.assign(ck.stored.begin(), ck.stored.begin() + (ck.stored.empty() ? 0 : S));
  pc_prev_.assign(ck.stored.begin() + (ck.stored.empty() ? 0 : S), ck.stored.begin() + (ck.stored.empty() ? 0 : 2 * S));
  pz_prev_.assign(ck.stored.begin() + (ck.stored.empty() ? 0 : 2 * S), ck.stored.end());
  for (std::size_t i = 0; i < slab_.size(); ++i) slab_[i] = static_cast<int>(ck.slab_of[i]);
  block_intervals_ = ck.counts[0];
  open_intervals_ = ck.counts[1];
}

TransportBlock SlabTransport::total() const {
  TransportBlock t{0.0, std::vector<double>(open_.slab.size(), 0.0), std::vector<double>(open_.plane.size(), 0.0)};
  for (const auto& b : blocks_) {
    t.time += b.time;
    for (std::size_t q = 0; q < t.slab.size(); ++q) t.slab[q] += b.slab[q];
    for (std::size_t q = 0; q < t.plane.size(); ++q) t.plane[q] += b.plane[q];
  }
  return t;
}

// One piece of free flight inside slab k, times ta..tb of the move with velocity
// v(t) = v0 + a t, end velocities va, vb (the engine's own values at the move's ends).
void SlabTransport::add_piece(int k, const Vec3& v0, const Vec3& a, double ta, double tb, double Ea, double Eb,
                              double ca, double cb, double za, double zb) {
  double* s = &open_.slab[static_cast<std::size_t>(k) * kSlab];
  s[0] += Eb - Ea;  // work of the constant force = change of kinetic energy
  s[1] += cb - ca;
  s[19] += zb - za;
  const double d1 = tb - ta, d2 = 0.5 * (tb * tb - ta * ta), d3 = (tb * tb * tb - ta * ta * ta) / 3.0;
  s[3] += d1;
  const double v[3] = {v0.x, v0.y, v0.z}, acc[3] = {a.x, a.y, a.z};
  for (int p = 0; p < 3; ++p) {
    s[4 + p] += v[p] * d1 + acc[p] * d2;
    for (int q = 0; q < 3; ++q) s[7 + p * 3 + q] += v[p] * v[q] * d1 + (v[p] * acc[q] + acc[p] * v[q]) * d2 + acc[p] * acc[q] * d3;
  }
}

void SlabTransport::cross(int plane, int sign, double E, double vc, double vz) {
  double* p = &open_.plane[static_cast<std::size_t>(plane) * kPlane];
  p[0] += sign * E;
  p[2] += sign * vc;
  p[4] += sign * vz;
  p[6] += sign;
}

void SlabTransport::add_move(std::uint32_t id, const Vec3& r0, const Vec3& v0, const Vec3& r1, const Vec3& v1,
                             const Vec3& a, double dt) {
  const int S = setup_.slabs, ax = setup_.axis, c = setup_.component;
  const double w = width_;
  const double z0 = comp(r0, ax), z1 = comp(r1, ax), vz = comp(v0, ax), az = comp(a, ax);
  int k = slab_[id];
  const long f0 = reconcile(static_cast<long>(std::floor(z0 / w)), k, S);
  const long f1 = static_cast<long>(std::floor(z1 / w));
  // turning point of z(t) inside the move splits it into monotonic parts
  double ts = -1.0;
  long fs = f0;
  if (az != 0.0) {
    ts = -vz / az;
    if (ts > 0.0 && ts < dt) fs = static_cast<long>(std::floor((z0 + vz * ts + 0.5 * az * ts * ts) / w));
    else ts = -1.0;
  }
  double t_prev = 0.0, E_prev = 0.5 * norm2(v0), c_prev = comp(v0, c), z_prev = vz;
  // time in [ta, tb] at which z(t) = level * w (the unique root of a monotonic part)
  auto root = [&](long level, double ta, double tb) {
    const double cc = z0 - level * w;
    double t;
    if (az == 0.0) {
      t = vz != 0.0 ? -cc / vz : ta;
    } else {
      const double A = 0.5 * az;
      const double disc = std::max(0.0, vz * vz - 4.0 * A * cc);
      const double q = -0.5 * (vz + std::copysign(std::sqrt(disc), vz));
      const double t1 = q / A, t2 = q != 0.0 ? cc / q : t1;
      auto dist = [&](double x) { return x < ta ? ta - x : x > tb ? x - tb : 0.0; };
      t = dist(t1) <= dist(t2) ? t1 : t2;
    }
    return std::clamp(t, std::max(ta, t_prev), tb);
  };
  auto step = [&](long level, int sign, double ta, double tb) {
    const double tc = root(level, ta, tb);
    const Vec3 vc = v0 + tc * a;
    const double Ec = 0.5 * norm2(vc), cc = comp(vc, c), zc = comp(vc, ax);
    add_piece(k, v0, a, t_prev, tc, E_prev, Ec, c_prev, cc, z_prev, zc);
    cross(wrap(level, S), sign, Ec, cc, zc);
    k = wrap(sign > 0 ? level : level - 1, S);
    t_prev = tc, E_prev = Ec, c_prev = cc, z_prev = zc;
  };
  auto walk = [&](long from, long to, double ta, double tb) {
    for (long p = from + 1; p <= to; ++p) step(p, +1, ta, tb);  // upward through plane p w
    for (long p = from; p > to; --p) step(p, -1, ta, tb);       // downward through plane p w
  };
  if (ts > 0.0) {
    walk(f0, fs, 0.0, ts);
    walk(fs, f1, ts, dt);
  } else {
    walk(f0, f1, 0.0, dt);
  }
  add_piece(k, v0, a, t_prev, dt, E_prev, 0.5 * norm2(v1), c_prev, comp(v1, c), z_prev, comp(v1, ax));
  slab_[id] = k;
}

void SlabTransport::add_collision(const CollisionRecord& rec) {
  const int S = setup_.slabs, ax = setup_.axis;
  const int ki = slab_[rec.id_i], kj = slab_[rec.id_j];
  const double zi = comp(rec.ri, ax), zj = zi + comp(rec.rij, ax);
  const long d = reconcile(static_cast<long>(std::floor(zj / width_)) - static_cast<long>(std::floor(zi / width_)),
                           kj - ki, S);
  const double sink = 0.5 * (rec.dEi + rec.dEj);
  open_.slab[static_cast<std::size_t>(ki) * kSlab + 2] += sink;
  open_.slab[static_cast<std::size_t>(kj) * kSlab + 2] += sink;
  const double Etr = 0.5 * (rec.dEj - rec.dEi), Jc = comp(rec.impulse, setup_.component), Jz = comp(rec.impulse, ax);
  auto add = [&](long plane, double sign) {
    double* p = &open_.plane[static_cast<std::size_t>(wrap(plane, S)) * kPlane];
    p[1] += sign * Etr;
    p[3] += sign * Jc;
    p[5] += sign * Jz;
  };
  for (long l = 1; l <= d; ++l) add(ki + l, 1.0);    // j above i: lower faces of slabs ki+1..ki+d
  for (long l = 0; l < -d; ++l) add(ki - l, -1.0);   // j below i: lower faces of slabs ki..ki+d+1
  // Collisional virial r_ij (x) J, split over the slabs ki, ki+sign(d), ..., ki+d by the
  // fraction of the segment z_i..z_j inside each (in the frame of slab ki, so that the split
  // agrees with the plane count d); a segment in one slab (d = 0) goes there whole.
  const int c = setup_.component;
  const double rc = comp(rec.rij, c), rz = comp(rec.rij, ax);
  // (c, z): r_z J_c, the flux of c-momentum along z that the planes count (equal to r_c J_z
  // for central impulses only: rough grains have a tangential part)
  const double w_cc = rc * Jc, w_zz = rz * Jz, w_cz = rz * Jc;
  auto deposit = [&](long k, double frac) {
    double* s = &open_.slab[static_cast<std::size_t>(wrap(k, S)) * kSlab];
    s[20] += frac * w_cc;
    s[21] += frac * w_zz;
    s[22] += frac * w_cz;
  };
  if (d == 0) {
    deposit(ki, 1.0);
    return;
  }
  // z_i above the lower face of slab ki (floor(z_i / w) differs from ki only by round-off at
  // a plane: then the segment starts at the top of slab ki, not at the bottom of the next)
  const double a = zi - reconcile(static_cast<long>(std::floor(zi / width_)), ki, S) * width_;
  const double len = std::abs(rz);
  const long n = d > 0 ? d : -d;
  for (long l = 0; l <= n; ++l) {
    // the part of the segment inside slab ki + l sign(d), measured from z_i along the segment
    double lo, hi;
    if (d > 0) lo = l == 0 ? 0.0 : (l * width_ - a), hi = l == n ? len : ((l + 1) * width_ - a);
    else lo = l == 0 ? 0.0 : (a - (1 - l) * width_), hi = l == n ? len : (a + l * width_);
    lo = std::clamp(lo, 0.0, len), hi = std::clamp(hi, 0.0, len);
    deposit(ki + (d > 0 ? l : -l), len > 0 ? (hi - lo) / len : (l == 0 ? 1.0 : 0.0));
  }
}

// ---- analysis ---------------------------------------------------------------------------

namespace {
double enskog_g(int dims, double packing) {
  // Bizon compares with Enskog using G(nu) of eq. 5 (Henderson for disks); CS for spheres
  return dims == 2 ? theory::g_contact_disk_cs(packing) : theory::g_contact_sphere_cs(packing);
}
double packing_of(int dims, double n) { return dims == 2 ? n * std::numbers::pi / 4.0 : n * std::numbers::pi / 6.0; }
}  // namespace

std::vector<TransportField> transport_fields(const SlabTransport& t, const TransportBlock& b) {
  const TransportSetup& su = t.setup();
  const int S = su.slabs, D = su.dims, c = su.component, ax = su.axis;
  const double w = t.slab_width(), A = t.cross_section(), V = A * w, time = b.time;
  std::vector<TransportField> f;
  f.reserve(64);  // references returned by field() stay valid
  auto field = [&](const std::string& name) -> std::vector<double>& {
    f.push_back({name, std::vector<double>(S, 0.0), {}});
    return f.back().mean;
  };
  auto slab = [&](int k, int q) { return b.slab[static_cast<std::size_t>(wrap(k, S)) * SlabTransport::kSlab + q]; };
  auto plane = [&](int k, int q) { return b.plane[static_cast<std::size_t>(wrap(k, S)) * SlabTransport::kPlane + q]; };
  std::vector<double> dens(S), T(S), Tc(S), Tz(S), uc(S), uz(S), pack(S);
  for (int k = 0; k < S; ++k) {
    const double occ = slab(k, 3);
    dens[k] = occ / (time * V);
    pack[k] = packing_of(D, dens[k]);
    double u[3], Ta[3], tr = 0.0;
    for (int p = 0; p < 3; ++p) u[p] = occ > 0 ? slab(k, 4 + p) / occ : 0.0;
    for (int p = 0; p < 3; ++p) {
      Ta[p] = occ > 0 ? slab(k, 7 + 4 * p) / occ - u[p] * u[p] : 0.0;
      if (p < D) tr += Ta[p];
    }
    T[k] = tr / D, Tc[k] = Ta[c], Tz[k] = Ta[ax], uc[k] = u[c], uz[k] = u[ax];
  }
  field("density") = dens;
  field("packing") = pack;
  field("T") = T;
  field("T_c") = Tc;
  field("T_z") = Tz;
  field("u_c") = uc;
  field("u_z") = uz;
  {
    auto& wr = field("work_rate");
    auto& lr = field("loss_rate");
    auto& sr = field("storage_rate");
    auto& fd = field("forcing_density");
    auto& er = field("energy_residual");
    auto& mr = field("momentum_residual");
    auto& mz = field("momentum_residual_z");
    for (int k = 0; k < S; ++k) {
      wr[k] = slab(k, 0) / (V * time);
      lr[k] = -slab(k, 2) / (V * time);
      sr[k] = slab(k, 16) / (V * time);
      fd[k] = slab(k, 1) / (V * time);
      // exact balances of slab k (raw sums): storage = input + sink + in(k) - out(k+1)
      er[k] = (slab(k, 16) - slab(k, 0) - slab(k, 2) - (plane(k, 0) + plane(k, 1)) + (plane(k + 1, 0) + plane(k + 1, 1))) /
              (V * time);
      mr[k] = (slab(k, 17) - slab(k, 1) - (plane(k, 2) + plane(k, 3)) + (plane(k + 1, 2) + plane(k + 1, 3))) / (V * time);
      mz[k] = (slab(k, 18) - slab(k, 19) - (plane(k, 4) + plane(k, 5)) + (plane(k + 1, 4) + plane(k + 1, 5))) / (V * time);
    }
  }
  {
    // volume-averaged pressure tensor per slab (kinetic n T_a + collisional virial / volume):
    // the second set of planes of Bizon Sec. V B, orthogonal to the first, measures the same
    // P_cc in a system homogeneous along c; Fig. 15 plots (P_cc - P_zz) / P against 1 - e
    auto& pcc = field("P_cc_slab");
    auto& pzz = field("P_zz_slab");
    auto& pcz = field("P_cz_slab");
    auto& nsd = field("normal_stress_difference");
    for (int k = 0; k < S; ++k) {
      const double occ = slab(k, 3);
      const double kin_cz = occ > 0 ? (slab(k, 7 + 3 * c + ax) - slab(k, 4 + c) * slab(k, 4 + ax) / occ) : 0.0;
      pcc[k] = dens[k] * Tc[k] + slab(k, 20) / (V * time);
      pzz[k] = dens[k] * Tz[k] + slab(k, 21) / (V * time);
      pcz[k] = kin_cz / (V * time) + slab(k, 22) / (V * time);
      // over the mean of the two (the pressure in 2D); NaN for a slab nobody visited
      nsd[k] = (pcc[k] - pzz[k]) / (0.5 * (pcc[k] + pzz[k]));
    }
  }
  std::vector<double> F(S), Fk(S), Fc(S);
  for (int k = 0; k < S; ++k) Fk[k] = plane(k, 0) / (A * time), Fc[k] = plane(k, 1) / (A * time), F[k] = Fk[k] + Fc[k];
  field("energy_flux_kin") = Fk;
  field("energy_flux_col") = Fc;
  field("energy_flux") = F;
  {
    auto& fb = field("energy_flux_balance");
    auto& fz = field("energy_flux_bizon");
    fb[0] = F[0], fz[0] = 0.0;
    for (int k = 0; k + 1 < S; ++k) {
      fb[k + 1] = fb[k] + (slab(k, 0) + slab(k, 2) - slab(k, 16)) / (A * time);
      fz[k + 1] = fz[k] + (slab(k, 0) + slab(k, 2)) / (A * time);
    }
  }
  {
    auto& tp = field("T_plane");
    auto& gr = field("dTdz");
    auto& ka = field("kappa");
    auto& ke = field("kappa_enskog");
    auto& kr = field("kappa_ratio");
    auto& pk = field("P_cz_kin");
    auto& pc = field("P_cz_col");
    auto& pt = field("P_cz");
    auto& pzz = field("P_zz");
    auto& du = field("dudz");
    auto& me = field("mu_enskog");
    auto& nf = field("net_flux");
    auto& pp = field("packing_plane");
    // du/dz at plane k from the slab averages of u_c on either side. For the forced mode
    // u = U sin(kz), k = 2 pi / L, a slab average over width w is U sin(k z_centre) sinc(kw/2)
    // (sinc x = sin x / x), and the difference of two adjacent averages over w is
    //   U sinc(kw/2) [sin(k(z_p + w/2)) - sin(k(z_p - w/2))] / w = U k cos(k z_p) sinc^2(kw/2),
    // i.e. du/dz at the plane times sinc^2(pi/S). P_cz is booked exactly at the plane, so
    // -P/(du/dz) overestimated mu by 1/sinc^2(pi/S) (S = 32: +0.32 %, S = 16: +1.3 %, S = 8:
    // +5.3 %). Dividing by sinc^2(pi/S) makes the difference exact for the forced mode,
    // which carries the shear; a mode of wavelength L/m keeps sinc^2(m pi/S)/sinc^2(pi/S).
    const double half_kw = std::numbers::pi / S;
    const double sinc2 = S > 1 ? std::pow(std::sin(half_kw) / half_kw, 2) : 1.0;
    // T, dT/dz and the packing at plane k. A slab holds slab averages of the number density n
    // and of the kinetic energy density e = n T (T[k] = kinetic energy / number in the slab,
    // density-weighted), not the values at its centre. The means and the difference of the
    // two adjacent slabs used before 2026-12-05 were off at O(w^2) (Taylor expansion of the
    // slab averages about the plane): T_plane by T'' w^2/6 + (n'T'/n) w^2/12, dT/dz by
    // T''' w^2/12 + (n'T'/n)' w^2/12, packing_plane by nu'' w^2/6. In cases/bizon-conductivity
    // (S = 32) that moved kappa_over_enskog by -0.4 % (nu = 0.5, a0 = 30) to -1.5 % (nu = 0.75,
    // a0 = 30: 0.6 sigma) and single planes' kappa_ratio by 1-6 % (smooth models of the runs'
    // profiles; docs/VALIDATION.md, cases/bizon-conductivity/gradient_bias.py).
    // Now n, e and their slopes at the plane come from four-slab stencils exact for cubic
    // profiles (solved from the slab averages of 1, s, s^2, s^3; a = the slab averages):
    //   f(z_k)  = [7 (a_k + a_{k-1}) - (a_{k+1} + a_{k-2})] / 12
    //   f'(z_k) = [15 (a_k - a_{k-1}) - (a_{k+1} - a_{k-2})] / (12 w)
    // and T = e/n, dT/dz = (e' - T n')/n there; the O(w^4) left is <= 2.5e-4 of
    // kappa_over_enskog on smooth models of the case's profiles (<= 7.5e-4 with wigglier ones).
    // The price is noise: the stencil's slope has 1.25x the white noise of a two-slab
    // difference; the jackknife errors grew by <= 3 % where the gradient is resolved, 18 % at
    // nu = 0.75, a0 = 1 (crystalline planes) and 52 % in the noise-dominated e = 0.99 check.
    // With S < 4 the stencil would reuse slabs, and at a plane where one of the four slabs is
    // empty or the stencil's n or nT is not positive (outer slabs more than 7x denser than
    // the inner two: a profile the cubic does not describe), the two-slab forms are kept.
    std::vector<double> e(S);
    for (int k = 0; k < S; ++k) e[k] = dens[k] * T[k];
    auto two_slab = [&](const std::vector<double>& a, int k) { return 0.5 * (a[k] + a[wrap(k - 1, S)]); };
    auto two_slab_slope = [&](const std::vector<double>& a, int k) { return (a[k] - a[wrap(k - 1, S)]) / w; };
    auto stencil = [&](const std::vector<double>& a, int k) {
      return (7.0 * (a[k] + a[wrap(k - 1, S)]) - (a[wrap(k + 1, S)] + a[wrap(k - 2, S)])) / 12.0;
    };
    auto stencil_slope = [&](const std::vector<double>& a, int k) {
      return (15.0 * (a[k] - a[wrap(k - 1, S)]) - (a[wrap(k + 1, S)] - a[wrap(k - 2, S)])) / (12.0 * w);
    };
    for (int k = 0; k < S; ++k) {
      const int km = wrap(k - 1, S);
      bool four = S >= 4;
      for (int j = -2; four && j <= 1; ++j) four = dens[wrap(k + j, S)] > 0.0 && std::isfinite(e[wrap(k + j, S)]);
      four = four && stencil(dens, k) > 0.0 && stencil(e, k) > 0.0;
      const double n_p = four ? stencil(dens, k) : two_slab(dens, k);
      tp[k] = four ? stencil(e, k) / n_p : two_slab(T, k);
      gr[k] = four ? (stencil_slope(e, k) - tp[k] * stencil_slope(dens, k)) / n_p : two_slab_slope(T, k);
      ka[k] = -F[k] / gr[k];
      pp[k] = four ? packing_of(D, n_p) : two_slab(pack, k);
      ke[k] = theory::enskog_conductivity(D, pp[k], enskog_g(D, pp[k]), tp[k]);
      kr[k] = ka[k] / ke[k];
      pk[k] = plane(k, 2) / (A * time);
      pc[k] = plane(k, 3) / (A * time);
      pt[k] = pk[k] + pc[k];
      pzz[k] = (plane(k, 4) + plane(k, 5)) / (A * time);
      du[k] = (uc[k] - uc[km]) / (w * sinc2);
      me[k] = theory::enskog_viscosity(D, pp[k], enskog_g(D, pp[k]), tp[k]);
      nf[k] = plane(k, 6) / (A * time);
    }
  }
  return f;
}

namespace {
// Jackknife over the blocks of any function of a summed block returning a vector.
template <class Fn>
void jackknife(const SlabTransport& t, Fn fn, std::vector<double>& mean, std::vector<double>& err, std::size_t& nb) {
  const TransportBlock tot = t.total();
  mean = fn(tot);
  err.assign(mean.size(), 0.0);
  const auto& bl = t.blocks();
  nb = bl.size();
  if (bl.size() < 2) return;
  std::vector<std::vector<double>> loo;
  for (const auto& b : bl) {
    TransportBlock m = tot;
    m.time -= b.time;
    for (std::size_t q = 0; q < m.slab.size(); ++q) m.slab[q] -= b.slab[q];
    for (std::size_t q = 0; q < m.plane.size(); ++q) m.plane[q] -= b.plane[q];
    loo.push_back(fn(m));
  }
  const double B = static_cast<double>(bl.size());
  for (std::size_t q = 0; q < mean.size(); ++q) {
    double avg = 0.0;
    for (const auto& l : loo) avg += l[q];
    avg /= B;
    double ss = 0.0;
    for (const auto& l : loo) ss += (l[q] - avg) * (l[q] - avg);
    err[q] = std::sqrt((B - 1.0) / B * ss);
  }
}
}  // namespace

TransportResult transport_result(const SlabTransport& t) {
  TransportResult r;
  const int S = t.setup().slabs;
  for (int k = 0; k < S; ++k) r.z_slab.push_back((k + 0.5) * t.slab_width()), r.z_plane.push_back(k * t.slab_width());
  const auto names = transport_fields(t, t.total());
  std::vector<double> mean, err;
  jackknife(t, [&](const TransportBlock& b) {
    std::vector<double> flat;
    for (const auto& fld : transport_fields(t, b)) flat.insert(flat.end(), fld.mean.begin(), fld.mean.end());
    return flat;
  }, mean, err, r.blocks);
  for (std::size_t q = 0; q < names.size(); ++q) {
    TransportField fld{names[q].name, {}, {}};
    fld.mean.assign(mean.begin() + q * S, mean.begin() + (q + 1) * S);
    fld.stderr_.assign(err.begin() + q * S, err.begin() + (q + 1) * S);
    r.fields.push_back(std::move(fld));
  }
  return r;
}

std::vector<TransportScalar> transport_scalars(const SlabTransport& t, const TransportAnalysis& an) {
  const TransportSetup& su = t.setup();
  const int S = su.slabs, D = su.dims;
  const double L = S * t.slab_width();
  std::vector<std::string> names;
  auto compute = [&](const TransportBlock& b) {
    const auto f = transport_fields(t, b);
    auto get = [&](const char* n) -> const std::vector<double>& {
      for (const auto& x : f)
        if (x.name == n) return x.mean;
      throw std::logic_error("transport: missing field");
    };
    std::vector<std::pair<std::string, double>> out;
    out.reserve(32);  // also quiets GCC 12's false -Warray-bounds on the first emplace_back
    const auto& T = get("T");
    const auto& dens = get("density");
    double occ = 0.0, Tm = 0.0;
    for (int k = 0; k < S; ++k) occ += dens[k], Tm += dens[k] * T[k];
    Tm /= occ;  // grain-weighted mean temperature
    out.emplace_back("T_mean", Tm);
    out.emplace_back("T_min", *std::min_element(T.begin(), T.end()));
    out.emplace_back("T_max", *std::max_element(T.begin(), T.end()));
    const double pack_mean = packing_of(D, occ / S);
    out.emplace_back("packing_mean", pack_mean);
    {
      // box averages of the pressure tensor (slab volumes equal): Bizon Fig. 15's normal
      // stress difference over the pressure, and P_zz from the slabs' virial beside P_zz
      // from the planes' momentum flux (two measurements of the same mean)
      const auto& pcc = get("P_cc_slab");
      const auto& pzz = get("P_zz_slab");
      const auto& pzp = get("P_zz");
      double sc = 0.0, sz = 0.0, sp = 0.0;
      for (int k = 0; k < S; ++k) sc += pcc[k], sz += pzz[k], sp += pzp[k];
      out.emplace_back("P_cc_mean", sc / S);
      out.emplace_back("P_zz_mean", sz / S);
      out.emplace_back("P_zz_planes_mean", sp / S);
      out.emplace_back("normal_stress_difference", (sc - sz) / (0.5 * (sc + sz)));
    }
    if (an.kind == TransportAnalysis::conductivity) {
      const auto& kr = get("kappa_ratio");
      const auto& ka = get("kappa");
      const auto& tp = get("T_plane");
      const auto& F = get("energy_flux");
      const auto& Fb = get("energy_flux_bizon");
      const auto& pp = get("packing_plane");
      const auto& ke = get("kappa_enskog");
      double ske = 0.0;
      double sr = 0.0, sk = 0.0, st = 0.0, sf = 0.0, sfb = 0.0, m = 0.0, srf = 0.0, stf = 0.0, mf = 0.0;
      for (int k = 0; k < S; ++k) {
        const double d = std::abs(k * t.slab_width() - 0.5 * L) / (0.5 * L);
        if (d < an.fit_inner || d > an.fit_outer) continue;
        sr += kr[k], sk += ka[k], st += tp[k], sf += std::abs(F[k]), sfb += std::abs(Fb[k]), m += 1.0;
        ske += ke[k];
        if (pp[k] < an.fluid_packing) srf += kr[k], stf += tp[k], mf += 1.0;
      }
      out.emplace_back("kappa_over_enskog", sr / m);
      // NaN when no fit plane is fluid (the summary then omits nothing: NaN is written as null)
      out.emplace_back("kappa_over_enskog_fluid", mf > 0 ? srf / mf : std::nan(""));
      out.emplace_back("T_fit_fluid", mf > 0 ? stf / mf : std::nan(""));
      out.emplace_back("fluid_planes", mf);
      out.emplace_back("kappa", sk / m);
      out.emplace_back("kappa_enskog", ske / m);  // mean over the same planes (local nu, T)
      out.emplace_back("T_fit", st / m);
      out.emplace_back("flux_over_bizon_integrated", sf / sfb);  // measured |flux| / Bizon's integrated balance
    } else {
      // Newton's law (eq. 38): least-squares line P_cz = alpha + beta dudz over all planes, mu = -beta
      const auto& P = get("P_cz");
      const auto& du = get("dudz");
      double sx = 0, sy = 0, sxx = 0, sxy = 0;
      for (int k = 0; k < S; ++k) sx += du[k], sy += P[k], sxx += du[k] * du[k], sxy += du[k] * P[k];
      const double beta = (S * sxy - sx * sy) / (S * sxx - sx * sx);
      const double alpha = (sy - beta * sx) / S;
      out.emplace_back("mu", -beta);
      out.emplace_back("fit_intercept", alpha);
      const double g = enskog_g(D, pack_mean);
      const double mu0 = theory::enskog_viscosity(D, pack_mean, g, Tm);
      out.emplace_back("mu_enskog", mu0);
      out.emplace_back("mu_over_enskog", -beta / mu0);
      double umax = 0.0, gmax = 0.0, an_sum = 0.0;
      const auto& uc = get("u_c");
      const auto& Tc = get("T_c");
      const auto& Tz = get("T_z");
      for (int k = 0; k < S; ++k) {
        umax = std::max(umax, std::abs(uc[k]));
        gmax = std::max(gmax, std::abs(du[k]));
        an_sum += Tc[k] / Tz[k] - 1.0;
      }
      // the forced mode alone (Fourier projection on k = 2 pi / L): P_cz = -mu du/dz for the
      // cos component at the planes; filters the noise of the other modes out of the fit.
      // dudz already carries the 1/sinc^2(pi/S) of the slab averages (transport_fields), so
      // -Pc/Gc is unbiased for the forced mode. The sine components of the slab averages u_c
      // and forcing_density are the point amplitudes times sinc(pi/S) (slab average of
      // sin(kz)); the amplitudes are reported divided by it, their ratio F/(k^2 U) is
      // unaffected either way.
      const double kw = 2.0 * std::numbers::pi / L, w = t.slab_width();
      const double sinc = std::sin(std::numbers::pi / S) / (std::numbers::pi / S);
      const auto& fd = get("forcing_density");
      double Pc = 0.0, Gc = 0.0, Us = 0.0, Fs = 0.0;
      for (int k = 0; k < S; ++k) {
        Pc += P[k] * std::cos(kw * k * w), Gc += du[k] * std::cos(kw * k * w);
        Us += uc[k] * std::sin(kw * (k + 0.5) * w), Fs += fd[k] * std::sin(kw * (k + 0.5) * w);
      }
      out.emplace_back("mu_mode", -Pc / Gc);
      out.emplace_back("mu_mode_over_enskog", -Pc / Gc / mu0);
      out.emplace_back("velocity_amplitude", 2.0 * Us / (S * sinc));
      out.emplace_back("force_amplitude", 2.0 * Fs / (S * sinc));
      // steady momentum balance of the mode: F = mu k^2 U (storage neglected)
      out.emplace_back("mu_from_forcing", Fs / (kw * kw * Us));
      out.emplace_back("mach_max", umax / std::sqrt(Tm));
      out.emplace_back("shear_rate_max", gmax);
      out.emplace_back("anisotropy", an_sum / S);  // T_c/T_z - 1, slab mean
    }
    if (names.empty())
      for (const auto& [n, v] : out) names.push_back(n);
    std::vector<double> v;
    for (const auto& [n, x] : out) v.push_back(x);
    return v;
  };
  std::vector<double> mean, err;
  std::size_t nb = 0;
  jackknife(t, compute, mean, err, nb);
  std::vector<TransportScalar> res;
  for (std::size_t q = 0; q < names.size(); ++q) res.push_back({names[q], mean[q], err[q]});
  // exact bookkeeping: largest slab residuals relative to the largest input / flux
  const auto f = transport_fields(t, t.total());
  auto maxabs = [&](const char* n) {
    double m = 0.0;
    for (const auto& x : f)
      if (x.name == n)
        for (double y : x.mean) m = std::max(m, std::abs(y));
    return m;
  };
  res.push_back({"energy_balance_residual", maxabs("energy_residual") / std::max(maxabs("work_rate"), 1e-300), 0.0});
  res.push_back({"momentum_balance_residual",
                 maxabs("momentum_residual") / std::max(maxabs("P_cz") / t.slab_width(), 1e-300), 0.0});
  return res;
}

}  // namespace grainbath::edmd
