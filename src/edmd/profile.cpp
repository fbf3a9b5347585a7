#include "edmd/profile.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace grainbath::edmd {

namespace {
inline double comp(const Vec3& v, int d) { return d == 0 ? v.x : d == 1 ? v.y : v.z; }
constexpr char kAxisName[] = "xyz";
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

const ProfileField& ProfileResult::field(const std::string& name) const {
  for (const auto& f : fields)
    if (f.name == name) return f;
  throw std::out_of_range("profile: no field named '" + name + "'");
}

void SlabProfiles::init(const ProfileSetup& s) {
  if (s.dims != 2 && s.dims != 3) throw std::invalid_argument("profile: dims must be 2 or 3");
  if (s.axis < 0 || s.axis >= s.dims) throw std::invalid_argument("profile: axis outside the dimensions");
  if (s.slabs < 1) throw std::invalid_argument("profile: need at least one slab");
  setup_ = s;
  L_ = comp(s.length, s.axis);
  width_ = L_ / s.slabs;
  double cross = 1.0;
  for (int d = 0; d < s.dims; ++d)
    if (d != s.axis) cross *= comp(s.length, d);
  volume_ = cross * width_;
  acc_ = ProfileAccumulators{};
  acc_.open.kin.assign(static_cast<std::size_t>(s.slabs) * kKin, 0.0);
  acc_.open.coll.assign(static_cast<std::size_t>(s.slabs) * kColl, 0.0);
}

int SlabProfiles::slab_of(double z) const {
  if (setup_.periodic_axis) z -= L_ * std::floor(z / L_);
  const int k = static_cast<int>(std::floor(z / width_));
  return std::clamp(k, 0, setup_.slabs - 1);
}

// Irving-Kirkwood with slabs (docs/edmd.md "Slab profiles"): the collision's contribution to
// the momentum-flux density at r is J_a r_b Int_0^1 delta(r - r_i - s r) ds, so slab k gets the
// fraction of the segment r_i -> r_j lying in it. The energy change dE_i delta(r - r_i) +
// dE_j delta(r - r_j) splits exactly into a flux of dE_tr = (dE_j - dE_i)/2 along the segment
// and a sink (dE_i + dE_j)/2 at each centre.
void SlabProfiles::add_collision(const CollisionRecord& c) {
  ++acc_.collisions;
  const int ax = setup_.axis;
  const double z0 = comp(c.ri, ax), dz = comp(c.rij, ax);
  const double dE_tr = 0.5 * (c.dEj - c.dEi);
  double flux[12];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) flux[a * 3 + b] = comp(c.impulse, a) * comp(c.rij, b);
  for (int b = 0; b < 3; ++b) flux[9 + b] = dE_tr * comp(c.rij, b);
  double* coll = acc_.open.coll.data();
  auto deposit = [&](int slab, double f) {
    double* p = coll + static_cast<std::size_t>(slab) * kColl;
    for (int q = 0; q < 12; ++q) p[q] += f * flux[q];
  };
  const double lo = std::min(z0, z0 + dz), hi = std::max(z0, z0 + dz);
  const double len = hi - lo;
  if (len <= 1e-12 * width_) {
    deposit(slab_of(z0), 1.0);
  } else {
    // walk the slabs crossed in unwrapped coordinates; slab_of() wraps / clamps the index
    const long k0 = static_cast<long>(std::floor(lo / width_)), k1 = static_cast<long>(std::floor(hi / width_));
    for (long k = k0; k <= k1; ++k) {
      const double a = std::max(lo, k * width_), b = std::min(hi, (k + 1) * width_);
      if (b > a) deposit(slab_of((k + 0.5) * width_), (b - a) / len);
    }
  }
  const double sink = 0.5 * (c.dEi + c.dEj);
  coll[static_cast<std::size_t>(slab_of(z0)) * kColl + 12] += sink;
  coll[static_cast<std::size_t>(slab_of(z0 + dz)) * kColl + 12] += sink;
}

void SlabProfiles::add_snapshot(const std::vector<Vec3>& x, const std::vector<Vec3>& v) {
  const int ax = setup_.axis;
  double* kin = acc_.open.kin.data();
  for (std::size_t i = 0; i < x.size(); ++i) {
    double* p = kin + static_cast<std::size_t>(slab_of(comp(x[i], ax))) * kKin;
    const double u[3] = {v[i].x, v[i].y, v[i].z};
    const double u2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
    p[0] += 1.0;
    for (int a = 0; a < 3; ++a) {
      p[1 + a] += u[a];
      for (int b = 0; b < 3; ++b) p[4 + a * 3 + b] += u[a] * u[b];
      p[13 + a] += u2 * u[a];
    }
  }
  acc_.open.snapshots += 1.0;
}

void SlabProfiles::end_interval(double dt) {
  acc_.open.time += dt;
  if (++acc_.open_intervals >= acc_.block_intervals) close_block();
}

void SlabProfiles::close_block() {
  acc_.blocks.push_back(acc_.open);
  std::fill(acc_.open.kin.begin(), acc_.open.kin.end(), 0.0);
  std::fill(acc_.open.coll.begin(), acc_.open.coll.end(), 0.0);
  acc_.open.snapshots = acc_.open.time = 0.0;
  acc_.open_intervals = 0;
  if (acc_.blocks.size() >= 2 * kMaxBlocks) {  // bounded memory: merge neighbours, double the block
    std::vector<ProfileBlock> merged;
    for (std::size_t k = 0; k + 1 < acc_.blocks.size(); k += 2) {
      ProfileBlock m = acc_.blocks[k];
      const ProfileBlock& o = acc_.blocks[k + 1];
      m.snapshots += o.snapshots;
      m.time += o.time;
      for (std::size_t q = 0; q < m.kin.size(); ++q) m.kin[q] += o.kin[q];
      for (std::size_t q = 0; q < m.coll.size(); ++q) m.coll[q] += o.coll[q];
      merged.push_back(std::move(m));
    }
    acc_.blocks = std::move(merged);
    acc_.block_intervals *= 2;
  }
}

std::vector<std::string> SlabProfiles::field_names() const {
  const int D = setup_.dims;
  std::vector<std::string> names{"density"};
  for (int a = 0; a < D; ++a) names.push_back(std::string("u_") + kAxisName[a]);
  for (int a = 0; a < D; ++a) names.push_back(std::string("T_") + kAxisName[a]);
  names.push_back("T");
  for (const char* part : {"P_kin_", "P_col_", "P_"})
    for (int a = 0; a < D; ++a)
      for (int b = 0; b < D; ++b) names.push_back(std::string(part) + kAxisName[a] + kAxisName[b]);
  names.push_back("p_kin");  // trace / D
  names.push_back("p_col");
  names.push_back("p");
  for (const char* part : {"q_kin_", "q_col_", "q_"})
    for (int a = 0; a < D; ++a) names.push_back(std::string(part) + kAxisName[a]);
  names.push_back("loss_rate");  // collisional energy loss per unit volume and time
  return names;
}

std::vector<std::vector<double>> SlabProfiles::fields_of(const ProfileBlock& blk) const {
  const int D = setup_.dims;
  const int S = setup_.slabs;
  const auto names = field_names();
  std::vector<std::vector<double>> out(names.size(), std::vector<double>(static_cast<std::size_t>(S), kNaN));
  for (int k = 0; k < S; ++k) {
    const double* K = blk.kin.data() + static_cast<std::size_t>(k) * kKin;
    const double* C = blk.coll.data() + static_cast<std::size_t>(k) * kColl;
    const double ns = blk.snapshots, t = blk.time;
    double u[3] = {0, 0, 0};
    double Pk[9] = {}, Pc[9] = {}, qk[3] = {}, qc[3] = {};
    double n = kNaN;
    bool kin_ok = ns > 0.0 && K[0] > 0.0;
    if (ns > 0.0) n = K[0] / (ns * volume_);
    if (kin_ok) {
      for (int a = 0; a < 3; ++a) u[a] = K[1 + a] / K[0];
      // P_kin_ab = Sum (v_a - u_a)(v_b - u_b) / (snapshots V) = (S_ab - S1_a u_b) / (ns V)
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) Pk[a * 3 + b] = (K[4 + a * 3 + b] - K[1 + a] * u[b]) / (ns * volume_);
      // q_kin_a = Sum |c|^2 c_a / 2 with c = v - u, expanded in the raw moments
      double S2 = 0.0, uS1 = 0.0, uu = 0.0;
      for (int b = 0; b < 3; ++b) S2 += K[4 + b * 3 + b], uS1 += u[b] * K[1 + b], uu += u[b] * u[b];
      for (int a = 0; a < 3; ++a) {
        double uSa = 0.0;
        for (int b = 0; b < 3; ++b) uSa += u[b] * K[4 + b * 3 + a];
        const double s = K[13 + a] - u[a] * S2 - 2.0 * uSa + 2.0 * u[a] * uS1 + uu * K[1 + a] - uu * u[a] * K[0];
        qk[a] = 0.5 * s / (ns * volume_);
      }
    }
    const bool coll_ok = t > 0.0;
    if (coll_ok) {
      for (int q = 0; q < 9; ++q) Pc[q] = C[q] / (t * volume_);
      // lab-frame collisional energy flux minus the work term: in the frame of u the
      // transferred energy is dE_tr - J.u, so q_col_b = Q_b - u_a P_col_ab (docs/edmd.md)
      for (int b = 0; b < 3; ++b) {
        double w = 0.0;
        for (int a = 0; a < 3; ++a) w += u[a] * Pc[a * 3 + b];
        qc[b] = C[9 + b] / (t * volume_) - (kin_ok ? w : 0.0);
      }
    }
    std::size_t f = 0;
    auto put = [&](double val, bool ok) { out[f++][static_cast<std::size_t>(k)] = ok ? val : kNaN; };
    put(n, ns > 0.0);
    for (int a = 0; a < D; ++a) put(u[a], kin_ok);
    double Tsum = 0.0;
    for (int a = 0; a < D; ++a) {
      const double Ta = kin_ok ? Pk[a * 3 + a] / n : kNaN;
      Tsum += Ta;
      put(Ta, kin_ok);
    }
    put(Tsum / D, kin_ok);
    for (int a = 0; a < D; ++a)
      for (int b = 0; b < D; ++b) put(Pk[a * 3 + b], kin_ok);
    for (int a = 0; a < D; ++a)
      for (int b = 0; b < D; ++b) put(Pc[a * 3 + b], coll_ok);
    for (int a = 0; a < D; ++a)
      for (int b = 0; b < D; ++b) put(Pk[a * 3 + b] + Pc[a * 3 + b], kin_ok && coll_ok);
    double trk = 0.0, trc = 0.0;
    for (int a = 0; a < D; ++a) trk += Pk[a * 3 + a], trc += Pc[a * 3 + a];
    put(trk / D, kin_ok);
    put(trc / D, coll_ok);
    put((trk + trc) / D, kin_ok && coll_ok);
    for (int a = 0; a < D; ++a) put(qk[a], kin_ok);
    for (int a = 0; a < D; ++a) put(qc[a], coll_ok && kin_ok);
    for (int a = 0; a < D; ++a) put(qk[a] + qc[a], kin_ok && coll_ok);
    put(-C[12] / (t * volume_), coll_ok);
  }
  return out;
}

ProfileResult SlabProfiles::result(std::size_t batches) const {
  ProfileResult r;
  const int S = setup_.slabs;
  for (int k = 0; k < S; ++k) r.centres.push_back((k + 0.5) * width_);
  r.slab_volume = volume_;
  const auto names = field_names();
  ProfileBlock total;
  total.kin.assign(acc_.open.kin.size(), 0.0);
  total.coll.assign(acc_.open.coll.size(), 0.0);
  auto add_to = [](ProfileBlock& into, const ProfileBlock& b) {
    into.snapshots += b.snapshots;
    into.time += b.time;
    for (std::size_t q = 0; q < into.kin.size(); ++q) into.kin[q] += b.kin[q];
    for (std::size_t q = 0; q < into.coll.size(); ++q) into.coll[q] += b.coll[q];
  };
  for (const auto& b : acc_.blocks) add_to(total, b);
  const auto mean = fields_of(total);
  // contiguous batches of closed blocks (equal sizes up to one block)
  const std::size_t nb = acc_.blocks.size();
  const std::size_t B = std::min(batches, nb);
  std::vector<std::vector<std::vector<double>>> per_batch;
  for (std::size_t q = 0; q < B; ++q) {
    ProfileBlock bt;
    bt.kin.assign(total.kin.size(), 0.0);
    bt.coll.assign(total.coll.size(), 0.0);
    for (std::size_t k = q * nb / B; k < (q + 1) * nb / B; ++k) add_to(bt, acc_.blocks[k]);
    per_batch.push_back(fields_of(bt));
  }
  r.batches = B;
  for (std::size_t f = 0; f < names.size(); ++f) {
    ProfileField pf;
    pf.name = names[f];
    pf.mean = mean[f];
    pf.stderr_.assign(static_cast<std::size_t>(S), kNaN);
    for (int k = 0; k < S; ++k) {
      double s = 0.0, s2 = 0.0;
      std::size_t m = 0;
      for (const auto& pb : per_batch) {
        const double x = pb[f][static_cast<std::size_t>(k)];
        if (std::isfinite(x)) s += x, s2 += x * x, ++m;
      }
      if (m >= 2) {
        const double mu = s / m;
        const double var = std::max(0.0, (s2 - m * mu * mu) / (m - 1));
        pf.stderr_[static_cast<std::size_t>(k)] = std::sqrt(var / m);
      }
    }
    r.fields.push_back(std::move(pf));
  }
  return r;
}

void SlabVelocityHistograms::init(int d, int nslabs, int nbins, double v_max) {
  dims = d;
  slabs = nslabs;
  bins = nbins;
  vmax = v_max;
  counts.assign(static_cast<std::size_t>(slabs) * dims * bins, 0.0);
  samples.assign(static_cast<std::size_t>(slabs), 0.0);
  outside.assign(static_cast<std::size_t>(slabs) * dims, 0.0);
}

void SlabVelocityHistograms::add(const SlabProfiles& p, const std::vector<Vec3>& x, const std::vector<Vec3>& v) {
  const int ax = p.setup().axis;
  const double scale = bins / (2.0 * vmax);
  for (std::size_t i = 0; i < x.size(); ++i) {
    const int k = p.slab_of(comp(x[i], ax));
    samples[static_cast<std::size_t>(k)] += 1.0;
    for (int a = 0; a < dims; ++a) {
      const double b = (comp(v[i], a) + vmax) * scale;
      if (b >= 0.0 && b < bins)
        counts[(static_cast<std::size_t>(k) * dims + a) * bins + static_cast<std::size_t>(b)] += 1.0;
      else
        outside[static_cast<std::size_t>(k) * dims + a] += 1.0;
    }
  }
}

std::vector<double> SlabVelocityHistograms::centres() const {
  std::vector<double> c(static_cast<std::size_t>(bins));
  for (int b = 0; b < bins; ++b) c[static_cast<std::size_t>(b)] = -vmax + (b + 0.5) * 2.0 * vmax / bins;
  return c;
}

}  // namespace grainbath::edmd
