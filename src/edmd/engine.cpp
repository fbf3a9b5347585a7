#include "edmd/engine.hpp"

#include "core/permute.hpp"
#include "edmd/contact_time.hpp"

#include <algorithm>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace grainbath::edmd {

namespace {

inline double& comp(Vec3& v, int d) { return d == 0 ? v.x : d == 1 ? v.y : v.z; }
inline double comp(const Vec3& v, int d) { return d == 0 ? v.x : d == 1 ? v.y : v.z; }

// Earliest t >= 0 with x + v t + acc t^2 / 2 = bound while moving outward through it
// (velocity v + acc t of sign `out`: +1 for an upper face, -1 for a lower one); inf if never.
// Requiring the outward direction stops a grain that sits on a face by round-off from
// crossing back and forth at the same instant. Cell faces and walls under the constant
// acceleration of the air table.
double quadratic_hit(double x, double v, double acc, double bound, double out) {
  const double A = 0.5 * acc, B = v, C = x - bound;
  double r1, r2;
  if (A == 0.0) {
    if (B == 0.0) return kInf;
    r1 = r2 = -C / B;
  } else {
    const double disc = B * B - 4.0 * A * C;
    if (disc < 0.0) return kInf;
    const double s = std::sqrt(disc);
    const double q = -0.5 * (B + (B >= 0.0 ? s : -s));
    r1 = q / A;
    r2 = (q != 0.0) ? C / q : r1;
    if (r1 > r2) std::swap(r1, r2);
  }
  for (double r : {r1, r2}) {
    const double t = std::max(r, 0.0);
    if (r >= -1e-12 * (1.0 + std::abs(r2)) && out * (v + acc * t) > 0.0) return t;
  }
  return kInf;
}

}  // namespace

Engine::Engine(const EngineSetup& s, const std::vector<Vec3>& positions, const std::vector<Vec3>& velocities)
    : n_(positions.size()), dims_(s.dims), L_(s.length), walls_(s.walls), wall_e_(s.wall_restitution),
      tc_(s.contact_time), q_(s.inertia_q), heating_(s.heating), bg_(s.background), seed_(s.seed),
      accelerated_(s.heating.kind == HeatingKind::air_table), vn_bin_width_(s.vn_bin_width) {
  for (int side = 0; side < 2; ++side) {
    wall_drive_[side] = s.wall_driving[side];
    wall_e_side_[side] = s.wall_restitution_side[side] >= 0.0 ? s.wall_restitution_side[side] : s.wall_restitution;
    if (!(wall_drive_[side] >= 0.0) || !std::isfinite(wall_drive_[side]))
      throw std::invalid_argument("edmd: wall driving speed must be finite and >= 0");
    if (!(wall_e_side_[side] >= 0.0 && wall_e_side_[side] <= 1.0))
      throw std::invalid_argument("edmd: wall restitution must lie in [0, 1]");
  }
  driving_walls_ = wall_drive_[0] > 0.0 || wall_drive_[1] > 0.0 || wall_e_side_[0] != wall_e_ ||
                   wall_e_side_[1] != wall_e_;
  if (dims_ != 2 && dims_ != 3) throw std::invalid_argument("edmd: dimensions must be 2 or 3");
  if (!(q_ > 0.0) || !std::isfinite(q_)) throw std::invalid_argument("edmd: moment of inertia factor q must be > 0");
  if (velocities.size() != n_) throw std::invalid_argument("edmd: positions and velocities differ in length");
  if (n_ < 2) throw std::invalid_argument("edmd: need at least 2 particles");
  if (n_ >= (std::size_t{1} << 32)) throw std::invalid_argument("edmd: too many particles");
  if (dims_ == 2) walls_[2] = false, L_.z = 1.0;
  for (int d = 0; d < dims_; ++d) {
    const double l = comp(L_, d);
    if (!(l >= 3.0)) {
      std::ostringstream m;
      m << "edmd: box length " << l << " in direction " << "xyz"[d]
        << " is below 3 sigma (the cell search needs at least 3 cells); use more particles";
      throw std::invalid_argument(m.str());
    }
    nc_[d] = static_cast<int>(std::floor(l));  // cell side l / nc >= 1 = sigma
    comp(w_, d) = l / nc_[d];
  }
  if (dims_ == 2) nc_[2] = 1, w_.z = 1.0;
  cap_ = 4;  // grows (doubles) on overflow; small keeps the cell arrays cache-friendly
  // predict_pair's union of cells: for each offset d = c_j - c_i (components -1, 0, 1) the
  // cells c_j + e (e in [-1, 1]^D, z order then y then x) that are not within one cell of
  // c_i, as linear index offsets from c_i (valid for interior cells: no wrap)
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        auto& extra = union_extra_[(dx + 1) + 3 * (dy + 1) + 9 * (dz + 1)];
        const int zr = dims_ == 3 ? 1 : 0;
        for (int ez = -zr; ez <= zr; ++ez)
          for (int ey = -1; ey <= 1; ++ey)
            for (int ex = -1; ex <= 1; ++ex) {
              const int ox = dx + ex, oy = dy + ey, oz = dz + ez;
              if (std::abs(ox) <= 1 && std::abs(oy) <= 1 && std::abs(oz) <= 1) continue;
              extra.push_back((oz * nc_[1] + oy) * nc_[0] + ox);
            }
      }
  prefetch_next_ = n_ >= 50000;  // about 13 MB of Kin + Sched: beyond the per-core caches
  defer_links_ = s.calendar_defer < 0 ? prefetch_next_ : s.calendar_defer != 0;
  rebuild_every_ = static_cast<std::uint64_t>(s.rebuild_interval * static_cast<double>(n_));
  next_rebuild_ = rebuild_every_;

  k_.resize(n_);
  id_.resize(n_);
  slot_of_.resize(n_);
  for (std::uint32_t i = 0; i < n_; ++i) id_[i] = slot_of_[i] = i;
  a_.assign(n_, Vec3{});
  omega_.assign(n_, Vec3{});
  sc_.assign(n_, Sched{});
  bg_time_.assign(n_, kInf);
  if (bg_ && accelerated_) bg_win_.assign(n_, BgWindow{});
  c_.vn_histogram.assign(static_cast<std::size_t>(std::max(1, s.vn_bins)), 0);

  for (std::size_t i = 0; i < n_; ++i) {
    Vec3 r = positions[i], v = velocities[i];
    if (dims_ == 2) r.z = 0.5, v.z = 0.0;
    for (int d = 0; d < dims_; ++d) {
      const double x = comp(r, d), l = comp(L_, d);
      const bool ok = walls_[d] ? (x >= 0.5 && x <= l - 0.5) : (x >= 0.0 && x < l);
      if (!ok || !std::isfinite(x)) {
        std::ostringstream m;
        m << "edmd: particle " << i << " is outside the box: " << "xyz"[d] << " = " << x << ", allowed "
          << (walls_[d] ? "[0.5, L - 0.5] (hard walls, sigma/2 from the wall)" : "[0, L)") << ", L = " << l;
        throw std::invalid_argument(m.str());
      }
    }
    k_[i].r = r;
    k_[i].v = v;
  }
  // Air table (Bizon eq. 22): particles paired (2k, 2k+1) with opposite accelerations.
  pair_.resize(n_);
  for (std::size_t i = 0; i < n_; ++i) pair_[i] = static_cast<std::uint32_t>(i ^ 1u);
  if (n_ % 2) pair_[n_ - 1] = static_cast<std::uint32_t>(n_ - 1);  // odd N: the last grain is not driven
  if (accelerated_) {
    for (std::size_t i = 0; i + 1 < n_; i += 2) {
      CounterRng rng(seed_, Stream::edmd_heating, i, 0);
      a_[i] = draw_acceleration(rng, k_[i].r);
      a_[i + 1] = -a_[i];
    }
  }
  for (std::uint32_t i = 0; i < n_; ++i) assign_cell(i);
  fill_cells();

  const double dmin = min_distance();
  if (dmin < 1.0 - 1e-10) {
    std::ostringstream m;
    m << "edmd: initial positions overlap: the closest pair is " << dmin << " apart (diameter sigma = 1)";
    throw std::invalid_argument(m.str());
  }
  rebuild();
}

void Engine::assign_cell(std::uint32_t i) {
  for (int d = 0; d < 3; ++d) {
    int c = 0;
    if (d < dims_) {
      c = static_cast<int>(std::floor(comp(k_[i].r, d) / comp(w_, d)));
      c = std::clamp(c, 0, nc_[d] - 1);
    }
    sc_[i].cell[d] = c;
  }
}

void Engine::fill_cells() {
  for (;;) {
    members_.assign(static_cast<std::size_t>(nc_[0]) * nc_[1] * nc_[2] * (cap_ + 1), 0);
    bool ok = true;
    for (std::uint32_t i = 0; i < n_ && ok; ++i) {
      const int c = cell_index(sc_[i].cell[0], sc_[i].cell[1], sc_[i].cell[2]);
      if (cell_block(c)[0] >= static_cast<std::uint32_t>(cap_)) ok = false;
      else insert_cell(i);
    }
    if (ok) return;
    cap_ *= 2;
  }
}

void Engine::grow_cells() {
  cap_ *= 2;
  fill_cells();
}

void Engine::insert_cell(std::uint32_t i) {
  const int c = cell_index(sc_[i].cell[0], sc_[i].cell[1], sc_[i].cell[2]);
  std::uint32_t* b = cell_block(c);
  if (b[0] >= static_cast<std::uint32_t>(cap_)) {
    grow_cells();  // rare: re-inserts everyone including i
    return;
  }
  const std::uint32_t s = b[0]++;
  b[1 + s] = i;
  sc_[i].cell_pos = static_cast<std::uint16_t>(s);
}

void Engine::remove_cell(std::uint32_t i) {
  const int c = cell_index(sc_[i].cell[0], sc_[i].cell[1], sc_[i].cell[2]);
  std::uint32_t* b = cell_block(c);
  const std::uint32_t last = b[b[0]];  // the last member, b[1 + count - 1]
  b[1 + sc_[i].cell_pos] = last;
  sc_[last].cell_pos = sc_[i].cell_pos;
  --b[0];
}

// Free flight of i over dt (ballistic, or under the constant air-table acceleration).
inline void Engine::advance_piece(std::uint32_t i, double dt) {
  Kin& k = k_[i];
  if (accelerated_) {
    const double e0 = norm2(k.v);
    k.r += dt * k.v + (0.5 * dt * dt) * a_[i];
    k.v += dt * a_[i];
    c_.heating_energy += 0.5 * (norm2(k.v) - e0);  // work of the air-table force
  } else {
    k.r += dt * k.v;
  }
}

void Engine::move_to(std::uint32_t i, double t) {
  Kin& k = k_[i];
  const double dt = t - k.t;
  if (dt == 0.0) return;
  if (move_hook_) {  // transport bookkeeping: the hook needs the piece's start
    const Vec3 r0 = k.r, v0 = k.v;
    advance_piece(i, dt);
    k.t = t;
    move_hook_(move_hook_context_, id_[i], r0, v0, k.r, k.v, accelerated_ ? a_[i] : Vec3{}, dt);
    return;
  }
  advance_piece(i, dt);
  k.t = t;
}

void Engine::request_next_records(std::uint32_t r) const {
  __builtin_prefetch(&sc_[r]);
  __builtin_prefetch(&k_[r]);
}

void Engine::request_next_neighbourhood(std::uint32_t r) const {
  const Sched& s = sc_[r];
  if (s.type == ev_collision) {
    __builtin_prefetch(&k_[s.coll_partner]);  // the staleness test reads its counter first
    __builtin_prefetch(&sc_[s.coll_partner]);
  }
  // the rows of r's 3^D block of cells (interior cells only: the rows are contiguous there),
  // as scan_neighbours_d and predict_pair_d request them
  const auto& c = s.cell;
  const bool interior = c[0] > 0 && c[0] < nc_[0] - 1 && c[1] > 0 && c[1] < nc_[1] - 1 &&
                        (dims_ == 2 || (c[2] > 0 && c[2] < nc_[2] - 1));
  if (!interior) return;
  const int zr = dims_ == 3 ? 1 : 0;
  for (int dz = -zr; dz <= zr; ++dz)
    for (int dy = -1; dy <= 1; ++dy) {
      const std::uint32_t* row = cell_block(cell_index(c[0] - 1, c[1] + dy, c[2] + dz));
      __builtin_prefetch(row);
      __builtin_prefetch(row + 3 * (cap_ + 1) - 1);
    }
}

void Engine::trajectory_changed(std::uint32_t i) {
  ++k_[i].counter;
  draw_background_time(i);
}

void Engine::draw_background_time(std::uint32_t i) {
  if (bg_) {
    if (accelerated_) {  // a new free flight: a new sequence of windows
      bg_win_[i].draws = 0;
      draw_background_window(i);
      return;
    }
    // Ballistic: the velocity is constant until the next trajectory change, so the majorant
    // at the current velocity bounds the attempt rate for the whole flight.
    CounterRng rng(seed_, Stream::edmd_background, id_[i], k_[i].counter);
    const double rate = dims_ == 2 ? background_majorant_rate_2d(k_[i].v, *bg_)
                                   : background_majorant_rate(k_[i].v, *bg_);
    bg_time_[i] = rate > 0.0 ? now_ + rng.exponential() / rate : kInf;
  }
}

// Air table: the velocity changes along the flight, v(t) = v(t0) + a (t - t0), so the
// majorant K(|c| + <|c_w|>) of the attempt (c = v - u_B) at the flight's start is no bound
// later on (drawing candidates at it gave 23 % too few medium collisions in 2D, a = 2,
// K = 1: docs/validation/edmd.md). Thinning over a window [t0, t0 + h]: |c(t)| <= |c(t0)| +
// |a| (t - t0), so B = K(|c(t0)| + |a| h + <|c_w|>) bounds the majorant there; candidates
// drawn at B and kept with probability K(|c(t)| + <|c_w|>)/B at their time
// (process_background) are exactly the candidates at the current velocity, each then
// attempted as for ballistic grains. A draw beyond t0 + h ends the window (a refresh event:
// a new window from there, the trajectory untouched, no rescan). h = max(m0/|a|,
// 1/sqrt(K|a|)), m0 = |c(t0)| + <|c_w|>: B is twice the majorant at t0 when m0/|a| wins (at
// least half the candidates kept), and a window holds K(m0 + |a|h)h >= 1 candidates on
// average otherwise. Randoms keyed on (id, counter) as the ballistic draw, the fourth
// counter word 2 draws (time) and 2 draws + 1 (thinning); draws restarts at 0 at every
// trajectory change and rebuild, so a restart redraws exactly the same windows.
void Engine::draw_background_window(std::uint32_t i) {
  BgWindow& w = bg_win_[i];
  const Kin& k = k_[i];
  Vec3 c = k.v + (now_ - k.t) * a_[i] - bg_->velocity;
  Vec3 a = a_[i];
  if (dims_ == 2) c.z = 0.0, a.z = 0.0;
  const double kr = bg_->rate_scale;
  const double m0 = norm(c) + (dims_ == 2 ? background_mean_speed_2d(*bg_) : bg_->mean_speed);
  const double amod = norm(a);
  const double h = (amod > 0.0 && kr > 0.0) ? std::max(m0 / amod, 1.0 / std::sqrt(kr * amod)) : kInf;
  w.bound = kr * (std::isfinite(h) ? m0 + amod * h : m0);
  w.refresh = false;
  if (!(w.bound > 0.0)) {
    bg_time_[i] = kInf;
    return;
  }
  CounterRng rng(seed_, Stream::edmd_background, id_[i], k.counter, 2ull * w.draws);
  const double dt = rng.exponential() / w.bound;
  w.refresh = dt > h;
  bg_time_[i] = now_ + (w.refresh ? h : dt);
}

// Earliest collision of i with the grains of one cell (image shifted by `shift`); updates
// the running best collision time and partner.
inline void Engine::scan_cell(std::uint32_t i, const Kin& ki, const Vec3& ai, int cell, const Vec3& shift,
                              Top2& best) const {
  const double t = ki.t;
  const std::uint32_t* m = cell_block(cell) + 1;
  const int cnt = static_cast<int>(m[-1]);
  for (int q = 0; q < cnt; ++q) {
    const std::uint32_t j = m[q];
    if (j == i) continue;
    const Kin& kj = k_[j];
    const double dtj = t - kj.t;
    double tcol;
    if (!accelerated_) {
      const Vec3 dr = kj.r + dtj * kj.v + shift - ki.r;
      const Vec3 dv = kj.v - ki.v;
      const double b = dot(dr, dv);
      if (b >= 0.0) continue;
      const double q2 = dot(dr, dr) - 1.0;
      if (q2 > 0.0 && t + q2 / (-2.0 * b) >= best.t2) continue;  // lower bound, no sqrt
      const double dv2 = dot(dv, dv);
      const double disc = b * b - dv2 * q2;
      if (disc <= 0.0) continue;
      tcol = q2 <= 0.0 ? 0.0 : q2 / (-b + std::sqrt(disc));
    } else {
      const Vec3 vj = kj.v + dtj * a_[j];
      const Vec3 rj = kj.r + dtj * kj.v + (0.5 * dtj * dtj) * a_[j] + shift;
      tcol = first_contact_time(rj - ki.r, vj - ki.v, a_[j] - ai, best.t1 - t);
#ifdef EDMD_DEBUG_QUARTIC
      {
        const Vec3 dr = rj - ki.r, dv = vj - ki.v, da = a_[j] - ai;
        const double hi = std::min({best.t1 - t, tcol, 2.0});
        if (dot(dr, dr) > 1.0 + 1e-9)
          for (int k = 1; k <= 4000; ++k) {
            const double tt = hi * k / 4000.0;
            const Vec3 x = dr + tt * dv + (0.5 * tt * tt) * da;
            if (dot(x, x) < 1.0 - 1e-9) {
              std::fprintf(stderr, "MISSED: tcol %.17g found overlap at %.17g; dr %.17g %.17g dv %.17g %.17g da %.17g %.17g tmax %.17g\n",
                           tcol, tt, dr.x, dr.y, dv.x, dv.y, da.x, da.y, best.t1 - t);
              break;
            }
          }
      }
#endif
      if (!std::isfinite(tcol)) continue;
    }
    best.offer(t + tcol, j, kj.counter);
  }
}

// scan_neighbours for ballistic grains in D dimensions (no air table): the candidates of
// all the cells are gathered first and their kinematic records prefetched, so the cache
// misses overlap instead of queueing one by one, then tested in one tight loop. Cells
// across a periodic face are gathered with the image shift of their group (the cells
// beyond a hard wall are skipped), so grains in the boundary cells take the same path as
// the interior ones. The shifted candidate position is ((r_j + dt v_j) + shift) - r_i,
// the operation order of scan_cell: the same collision times as the cell-by-cell scan.
// Returns false, having changed nothing, if the candidates overflow the buffer.
template <int D>
bool Engine::scan_neighbours_d(std::uint32_t i, int layer_dim, int layer_dir) {
  const Kin& ki = k_[i];
  const auto& c = sc_[i].cell;
  int lo[3] = {-1, -1, D == 3 ? -1 : 0}, hi[3] = {1, 1, D == 3 ? 1 : 0};
  if (layer_dim >= 0) lo[layer_dim] = hi[layer_dim] = layer_dir;
  const bool interior = c[0] > 0 && c[0] < nc_[0] - 1 && c[1] > 0 && c[1] < nc_[1] - 1 &&
                        (D == 2 || (c[2] > 0 && c[2] < nc_[2] - 1));
  constexpr int kMax = 192;
  std::uint32_t buf[kMax];
  int nb = 0;
  // boundary cells: candidates buf[seg_end[s - 1] .. seg_end[s]) carry the image shift
  // seg_shift[s]
  int seg_end[27];
  double seg_shift[27][3];  // plain doubles: a Vec3 array would be zeroed at every call
  int nseg = 0;
  if (interior) {
    // no wrap, no image shift; rows of cells requested first (as in predict_pair)
    for (int dz = lo[2]; dz <= hi[2]; ++dz)
      for (int dy = lo[1]; dy <= hi[1]; ++dy) {
        const std::uint32_t* row = cell_block(cell_index(c[0] + lo[0], c[1] + dy, c[2] + dz));
        __builtin_prefetch(row);
        __builtin_prefetch(row + (hi[0] - lo[0] + 1) * (cap_ + 1) - 1);
      }
    for (int dz = lo[2]; dz <= hi[2]; ++dz)
      for (int dy = lo[1]; dy <= hi[1]; ++dy) {
        const int row = cell_index(c[0], c[1] + dy, c[2] + dz);
        for (int dx = lo[0]; dx <= hi[0]; ++dx) {
          const std::uint32_t* m = cell_block(row + dx) + 1;
          const int cnt = static_cast<int>(m[-1]);
          if (nb + cnt > kMax) return false;
          for (int q = 0; q < cnt; ++q) {
            const std::uint32_t j = m[q];
            __builtin_prefetch(&k_[j]);
            buf[nb] = j;
            nb += (j != i);
          }
        }
      }
  } else {
    // wrapped cell coordinate and image shift per direction and offset (walls: skipped)
    int cc[3][3];
    double sh[3][3];
    bool skip[3][3];
    for (int d = 0; d < D; ++d)
      for (int o = lo[d]; o <= hi[d]; ++o) {
        int x = c[d] + o;
        double s = 0.0;
        const bool out = !image_cell(d, x, s);
        cc[d][o + 1] = x, sh[d][o + 1] = s, skip[d][o + 1] = out;
      }
    if constexpr (D == 2) cc[2][1] = 0, sh[2][1] = 0.0, skip[2][1] = false;
    for (int dz = lo[2]; dz <= hi[2]; ++dz) {
      if (skip[2][dz + 1]) continue;
      for (int dy = lo[1]; dy <= hi[1]; ++dy) {
        if (skip[1][dy + 1]) continue;
        for (int dx = lo[0]; dx <= hi[0]; ++dx) {
          if (skip[0][dx + 1]) continue;
          const std::uint32_t* m = cell_block(cell_index(cc[0][dx + 1], cc[1][dy + 1], cc[2][dz + 1])) + 1;
          const int cnt = static_cast<int>(m[-1]);
          if (cnt == 0) continue;
          if (nb + cnt > kMax) return false;
          for (int q = 0; q < cnt; ++q) {
            const std::uint32_t j = m[q];
            __builtin_prefetch(&k_[j]);
            buf[nb] = j;
            nb += (j != i);
          }
          seg_end[nseg] = nb;
          seg_shift[nseg][0] = sh[0][dx + 1], seg_shift[nseg][1] = sh[1][dy + 1], seg_shift[nseg][2] = sh[2][dz + 1];
          ++nseg;
        }
      }
    }
  }
  Top2 best = load_top2(sc_[i]);
  const double t = ki.t;
  // The pair test of scan_cell (ballistic branch) in two passes. Pass 1 computes, for every
  // candidate, the quantities that decide rejection without reference to the running best:
  // b = dr.dv (receding: b >= 0) and disc = b^2 - dv^2 q2 (no real root: disc <= 0). These
  // two tests go either way about equally often, so as branches they are mispredicted a
  // lot; instead every candidate is written to the survivor arrays and the write position
  // advances only when it passes (n += pass). Pass 2 runs the sqrt and division only on the
  // survivors, in candidate order, so offer() sees the same times in the same order. Same
  // operations as the base, so the same bits. The lower bound t + q2/(-2b) >= t2 of
  // scan_cell is left out: sqrt(disc) <= -b in floating point (sqrt of a correctly rounded
  // value <= b^2), so the computed time is never below the bound and offer() rejects it
  // anyway (tc >= t2); it only saved work, and here it would cost a division and a branch.
  std::uint32_t sj[kMax];
  double sb[kMax], sq2[kMax], sdisc[kMax];
  int ns = 0;
  // rj = candidate position at time t
  auto filter = [&](std::uint32_t j, const Kin& kj, double rjx, double rjy, double rjz) {
    const double drx = rjx - ki.r.x, dry = rjy - ki.r.y;
    const double dvx = kj.v.x - ki.v.x, dvy = kj.v.y - ki.v.y;
    double b = drx * dvx + dry * dvy;
    double dr2 = drx * drx + dry * dry;
    double dv2 = dvx * dvx + dvy * dvy;
    if constexpr (D == 3) {
      const double drz = rjz - ki.r.z, dvz = kj.v.z - ki.v.z;
      b += drz * dvz;
      dr2 += drz * drz;
      dv2 += dvz * dvz;
    }
    const double q2 = dr2 - 1.0;
    const double disc = b * b - dv2 * q2;
    sj[ns] = j, sb[ns] = b, sq2[ns] = q2, sdisc[ns] = disc;
    ns += static_cast<int>((b < 0.0) & (disc > 0.0));
  };
  if (interior) {
    for (int q = 0; q < nb; ++q) {
      const std::uint32_t j = buf[q];
      const Kin& kj = k_[j];
      const double dtj = t - kj.t;
      filter(j, kj, kj.r.x + dtj * kj.v.x, kj.r.y + dtj * kj.v.y, D == 3 ? kj.r.z + dtj * kj.v.z : 0.0);
    }
  } else {
    int q = 0;
    for (int sg = 0; sg < nseg; ++sg) {
      const double sx = seg_shift[sg][0], sy = seg_shift[sg][1], sz = seg_shift[sg][2];
      for (; q < seg_end[sg]; ++q) {
        const std::uint32_t j = buf[q];
        const Kin& kj = k_[j];
        const double dtj = t - kj.t;
        filter(j, kj, (kj.r.x + dtj * kj.v.x) + sx, (kj.r.y + dtj * kj.v.y) + sy,
               D == 3 ? (kj.r.z + dtj * kj.v.z) + sz : 0.0);
      }
    }
  }
  for (int s = 0; s < ns; ++s) {
    const double b = sb[s], q2 = sq2[s];
    best.offer(t + (q2 <= 0.0 ? 0.0 : q2 / (-b + std::sqrt(sdisc[s]))), sj[s], k_[sj[s]].counter);
  }
  store_top2(i, best);
  return true;
}

// Scans the neighbouring cells of i: all 3^D of them (layer_dim < 0) or only the layer
// at offset `layer_dir` in direction `layer_dim` (after a cell crossing: the other cells
// were scanned before and their best collision is kept in Sched::coll_time).
void Engine::scan_neighbours(std::uint32_t i, int layer_dim, int layer_dir) {
  if (!accelerated_ && (dims_ == 3 ? scan_neighbours_d<3>(i, layer_dim, layer_dir)
                                   : scan_neighbours_d<2>(i, layer_dim, layer_dir)))
    return;
  // air table (quartic pair times), or more candidates than the gather buffer holds: cell
  // by cell
  const Kin& ki = k_[i];
  const Vec3 ai = accelerated_ ? a_[i] : Vec3{};
  const auto& c = sc_[i].cell;
  Top2 best = load_top2(sc_[i]);
  int lo[3] = {-1, -1, dims_ == 3 ? -1 : 0}, hi[3] = {1, 1, dims_ == 3 ? 1 : 0};
  if (layer_dim >= 0) lo[layer_dim] = hi[layer_dim] = layer_dir;
  const bool interior = c[0] > 0 && c[0] < nc_[0] - 1 && c[1] > 0 && c[1] < nc_[1] - 1 &&
                        (dims_ == 2 || (c[2] > 0 && c[2] < nc_[2] - 1));
  if (interior) {  // no wrap, no image shift
    const Vec3 zero{};
    for (int dz = lo[2]; dz <= hi[2]; ++dz)
      for (int dy = lo[1]; dy <= hi[1]; ++dy) {
        const int row = cell_index(c[0], c[1] + dy, c[2] + dz);
        for (int dx = lo[0]; dx <= hi[0]; ++dx) scan_cell(i, ki, ai, row + dx, zero, best);
      }
  } else {
    for (int dz = lo[2]; dz <= hi[2]; ++dz) {
      int cz = c[2] + dz;
      double sz = 0.0;
      if (dims_ == 3 && !image_cell(2, cz, sz)) continue;
      for (int dy = lo[1]; dy <= hi[1]; ++dy) {
        int cy = c[1] + dy;
        double sy = 0.0;
        if (!image_cell(1, cy, sy)) continue;
        for (int dx = lo[0]; dx <= hi[0]; ++dx) {
          int cx = c[0] + dx;
          double sx = 0.0;
          if (!image_cell(0, cx, sx)) continue;
          scan_cell(i, ki, ai, cell_index(cx, cy, cz), Vec3{sx, sy, sz}, best);
        }
      }
    }
  }
  if (accelerated_) {
    // the quartic search is bounded by the first candidate only: the second is unknown,
    // and every other covered pair collides no earlier than the first
    best.t2 = best.t1;
    best.c2 = kUnknownCounter;
  }
  store_top2(i, best);
}

void Engine::store_top2(std::uint32_t i, const Top2& b) {
  Sched& s = sc_[i];
  s.coll_time = b.t1;
  s.coll_partner = b.p1;
  s.coll_partner_counter = b.c1;
  s.coll2_time = b.t2;
  s.coll2_partner = b.p2;
  s.coll2_partner_counter = b.c2;
}

// i's first candidate is stale (its partner changed trajectory). By the invariant of
// Sched (engine.hpp), the second is i's next collision among the pairs i still covers if
// its partner is unchanged (or there is none: +inf). Returns false when a rescan is needed.
bool Engine::promote_second(std::uint32_t i) {
  Sched& s = sc_[i];
  if (s.coll2_time == kInf) {  // no other collision among the covered pairs
    s.coll_time = kInf;
    return true;
  }
  if (s.coll2_partner_counter == kUnknownCounter || k_[s.coll2_partner].counter != s.coll2_partner_counter)
    return false;
  s.coll_time = s.coll2_time;
  s.coll_partner = s.coll2_partner;
  s.coll_partner_counter = s.coll2_partner_counter;
  s.coll2_partner_counter = kUnknownCounter;  // coll2_time stays as the bound on the rest
  return true;
}

// After a collision both grains need a full scan; their neighbourhoods overlap (the cells
// are adjacent), so one pass over the union of cells serves both, loading every neighbour's
// record once. Falls back to two scans near boundaries or under acceleration.
void Engine::predict_pair(std::uint32_t i, std::uint32_t j) {
  if (dims_ == 3) predict_pair_d<3>(i, j);
  else predict_pair_d<2>(i, j);
}

// The dimension is a compile-time constant here: the loops over cells and components
// unroll, and disks skip the z terms. Those are exact zeros in 2D (z = 1/2 and v_z = 0 for
// every disk), so leaving them out changes at most the sign of a zero sum, which no test
// below can see (b >= 0 and disc <= 0 hold for +0 and -0 alike): the same decisions and
// the same collision times as the 3-component arithmetic.
template <int D>
void Engine::predict_pair_d(std::uint32_t i, std::uint32_t j) {
  const auto& ci = sc_[i].cell;
  const auto& cj = sc_[j].cell;
  auto interior = [&](const std::array<int, 3>& c) {
    return c[0] > 0 && c[0] < nc_[0] - 1 && c[1] > 0 && c[1] < nc_[1] - 1 &&
           (D == 2 || (c[2] > 0 && c[2] < nc_[2] - 1));
  };
  if (accelerated_ || !interior(ci) || !interior(cj)) {
    predict(i);
    predict(j);
    return;
  }
  const int d[3] = {cj[0] - ci[0], cj[1] - ci[1], D == 3 ? cj[2] - ci[2] : 0};
  constexpr int kMax = 320;
  std::uint32_t buf[kMax];
  int nb = 0;
  bool overflow = false;
  constexpr int zr = D == 3 ? 1 : 0;
  auto add_cell = [&](int cell) {
    const std::uint32_t* m = cell_block(cell) + 1;
    const int cnt = static_cast<int>(m[-1]);
    if (nb + cnt > kMax) {
      overflow = true;
      return;
    }
    for (int q = 0; q < cnt; ++q) {
      __builtin_prefetch(&k_[m[q]]);
      buf[nb++] = m[q];
    }
  };
  // request every row of cells first, and j's cells outside i's block (their member counts
  // were the largest stall of this function at N = 10^6 when read after i's: perf,
  // docs/performance/edmd.md): independent misses in flight together; then gather
  const bool adjacent = std::abs(d[0]) <= 1 && std::abs(d[1]) <= 1 && std::abs(d[2]) <= 1;
  for (int dz = -zr; dz <= zr; ++dz)
    for (int dy = -1; dy <= 1; ++dy) {
      const std::uint32_t* row = cell_block(cell_index(ci[0] - 1, ci[1] + dy, ci[2] + dz));
      __builtin_prefetch(row);
      __builtin_prefetch(row + 3 * (cap_ + 1) - 1);
    }
  if (adjacent) {
    const int ci_index = cell_index(ci[0], ci[1], ci[2]);
    for (const int off : union_extra_[(d[0] + 1) + 3 * (d[1] + 1) + 9 * (d[2] + 1)]) {
      const std::uint32_t* block = cell_block(ci_index + off);
      __builtin_prefetch(block);
      __builtin_prefetch(block + cap_);
    }
  }
  for (int dz = -zr; dz <= zr; ++dz)
    for (int dy = -1; dy <= 1; ++dy) {
      const int row = cell_index(ci[0], ci[1] + dy, ci[2] + dz);
      for (int dx = -1; dx <= 1; ++dx) add_cell(row + dx);
    }
  // then j's cells that are not i's, in the order of j's own scan (table: union_extra_)
  if (adjacent) {
    const int ci_index = cell_index(ci[0], ci[1], ci[2]);
    for (const int off : union_extra_[(d[0] + 1) + 3 * (d[1] + 1) + 9 * (d[2] + 1)]) add_cell(ci_index + off);
  } else {
    // grains in contact two cells apart: both sit on a cell face up to round-off (cell side
    // >= sigma); never seen, handled as the table would be
    for (int dz = -zr; dz <= zr; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if (std::abs(d[0] + dx) <= 1 && std::abs(d[1] + dy) <= 1 && std::abs(d[2] + dz) <= 1) continue;
          add_cell(cell_index(cj[0] + dx, cj[1] + dy, cj[2] + dz));
        }
  }
  if (overflow) {
    predict(i);
    predict(j);
    return;
  }
  const Kin& ki = k_[i];
  const Kin& kj = k_[j];
  const double t = ki.t;  // == kj.t == now
  Top2 best[2] = {{kInf, kInf, 0, 0, 0, 0}, {kInf, kInf, 0, 0, 0, 0}};
  // Both grains are tested against every candidate at once, lane 0 = i, lane 1 = j (GCC
  // vector extension, SSE2 on x86-64: two IEEE operations side by side, the same rounding
  // as the scalar code; no FMA exists in the baseline ISA, so nothing is contracted). Pass 1
  // computes b = dr.dv, q2 and disc = b^2 - dv^2 q2 for every candidate and keeps, per lane,
  // those with b < 0 (approaching) and disc > 0 (a real root): as branches these tests go
  // either way about equally often and were mispredicted a lot; the extra arithmetic for
  // the rejected pairs is a few vector operations. Pass 2 is the scalar rest of the test,
  // in the base's operation order. A grain tested against itself (k = i in lane 0, k = j in
  // lane 1) has dr = 0 exactly (it is at time t: r + 0 v), hence b = 0, and is rejected by
  // the same test: no identity check is needed.
  using D2 = double __attribute__((vector_size(16)));
  const D2 rx = {ki.r.x, kj.r.x}, ry = {ki.r.y, kj.r.y}, rz = {ki.r.z, kj.r.z};
  const D2 vx = {ki.v.x, kj.v.x}, vy = {ki.v.y, kj.v.y}, vz = {ki.v.z, kj.v.z};
  std::uint32_t sk[2][kMax];
  double sb[2][kMax], sq2[2][kMax], sdisc[2][kMax];
  int ns[2] = {0, 0};
  for (int q = 0; q < nb; ++q) {
    const std::uint32_t k = buf[q];
    const Kin& kk = k_[k];
    const double dtk = t - kk.t;
    const double rkx = kk.r.x + dtk * kk.v.x, rky = kk.r.y + dtk * kk.v.y;
    const D2 drx = D2{rkx, rkx} - rx, dry = D2{rky, rky} - ry;
    const D2 dvx = D2{kk.v.x, kk.v.x} - vx, dvy = D2{kk.v.y, kk.v.y} - vy;
    D2 drz = {0.0, 0.0}, dvz = {0.0, 0.0};
    D2 b = drx * dvx + dry * dvy;
    if constexpr (D == 3) {
      const double rkz = kk.r.z + dtk * kk.v.z;
      drz = D2{rkz, rkz} - rz;
      dvz = D2{kk.v.z, kk.v.z} - vz;
      b = b + drz * dvz;
    }
    D2 dr2 = drx * drx + dry * dry, dv2 = dvx * dvx + dvy * dvy;
    if constexpr (D == 3) dr2 = dr2 + drz * drz, dv2 = dv2 + dvz * dvz;
    const D2 q2 = dr2 - 1.0;
    const D2 disc = b * b - dv2 * q2;
    // each lane's survivor (b < 0 and disc > 0) is appended by store-and-advance, no branch
    const auto pass = (b < 0.0) & (disc > 0.0);  // lanes: -1 or 0
    for (int l = 0; l < 2; ++l) {
      const int n = ns[l];
      sk[l][n] = k, sb[l][n] = b[l], sq2[l][n] = q2[l], sdisc[l][n] = disc[l];
      ns[l] = n + static_cast<int>(pass[l] & 1);
    }
  }
  // Pass 2, per lane in candidate order: the same offers in the same order as testing each
  // candidate in turn.
  for (int l = 0; l < 2; ++l)
    for (int s = 0; s < ns[l]; ++s) {
      const double q2 = sq2[l][s];
      best[l].offer(t + (q2 <= 0.0 ? 0.0 : q2 / (-sb[l][s] + std::sqrt(sdisc[l][s]))), sk[l][s],
                    k_[sk[l][s]].counter);
    }
  store_top2(i, best[0]);
  store_top2(j, best[1]);
  // Both new event times first, then the calendar lines both updates will touch are
  // requested together (the bucket heads, known only now, and the list neighbours), so that
  // their misses overlap instead of following one another (schedule_d's largest stall at
  // N = 10^6; docs/performance/edmd.md). The updates are the same, in the same order.
  const double ti = next_event_d<D>(i), tj = next_event_d<D>(j);
  heap_.request_update(i, ti);
  heap_.request_update(j, tj);
  heap_.update(i, ti);
  heap_.update(j, tj);
}

void Engine::predict(std::uint32_t i) {
  sc_[i].coll_time = sc_[i].coll2_time = kInf;
  scan_neighbours(i, -1, 0);
  schedule(i);
}

// schedule() for ballistic grains in D dimensions: the same comparisons in the same order
// (faces by increasing direction, then the stored collision), the loop over directions
// unrolled.
template <int D>
double Engine::next_event_d(std::uint32_t i) {
  const Kin& ki = k_[i];
  const double t = ki.t;
  double best = kInf;
  std::uint8_t type = ev_none, aux = 0;
  if (bg_) {
    best = bg_time_[i];
    type = ev_background;
  }
  Sched& s = sc_[i];
  const auto& c = s.cell;
  for (int d = 0; d < D; ++d) {
    const double x = comp(ki.r, d), v = comp(ki.v, d), w = comp(w_, d);
    if (v > 0.0) {
      const bool high_wall = walls_[d] && c[d] == nc_[d] - 1;
      const double bound = high_wall ? comp(L_, d) - 0.5 : c[d] * w + w;
      const double tc = t + std::max(0.0, (bound - x) / v);
      if (tc < best) {
        best = tc;
        type = high_wall ? ev_wall : ev_cell;
        aux = static_cast<std::uint8_t>(2 * d + 1);
      }
    } else if (v < 0.0) {
      const bool low_wall = walls_[d] && c[d] == 0;
      const double bound = low_wall ? 0.5 : c[d] * w;
      const double tc = t + std::max(0.0, (bound - x) / v);
      if (tc < best) {
        best = tc;
        type = low_wall ? ev_wall : ev_cell;
        aux = static_cast<std::uint8_t>(2 * d);
      }
    }
  }
  if (s.coll_time < best) {
    best = s.coll_time;
    type = ev_collision;
    aux = 0;
  }
  s.type = type;
  s.aux = aux;
  return best;
}

template <int D>
void Engine::schedule_d(std::uint32_t i) {
  heap_.update(i, next_event_d<D>(i));
}

// Next event of i = earliest of its stored best collision, its cell faces / walls and its
// next background candidate.
void Engine::schedule(std::uint32_t i) {
  if (!accelerated_) {
    if (dims_ == 3) schedule_d<3>(i);
    else schedule_d<2>(i);
    return;
  }
  const Kin& ki = k_[i];
  const double t = ki.t;
  double best = kInf;
  std::uint8_t type = ev_none, aux = 0;
  if (bg_) {
    best = bg_time_[i];
    type = ev_background;
  }
  Sched& s = sc_[i];
  const auto& c = s.cell;
  const Vec3 ai = a_[i];  // accelerated (air table): ballistic grains took schedule_d above
  for (int d = 0; d < dims_; ++d) {
    const double x = comp(ki.r, d), v = comp(ki.v, d), acc = comp(ai, d);
    const double lo = c[d] * comp(w_, d), hi = lo + comp(w_, d);
    const bool low_wall = walls_[d] && c[d] == 0;
    const bool high_wall = walls_[d] && c[d] == nc_[d] - 1;
    const double bh = high_wall ? comp(L_, d) - 0.5 : hi;
    const double bl = low_wall ? 0.5 : lo;
    const double th = (x >= bh && v > 0.0) ? 0.0 : quadratic_hit(x, v, acc, bh, 1.0);
    const double tl = (x <= bl && v < 0.0) ? 0.0 : quadratic_hit(x, v, acc, bl, -1.0);
    if (t + th < best) {
      best = t + th;
      type = high_wall ? ev_wall : ev_cell;
      aux = static_cast<std::uint8_t>(2 * d + 1);
    }
    if (t + tl < best) {
      best = t + tl;
      type = low_wall ? ev_wall : ev_cell;
      aux = static_cast<std::uint8_t>(2 * d);
    }
  }
  if (s.coll_time < best) {
    best = s.coll_time;
    type = ev_collision;
    aux = 0;
  }
  s.type = type;
  s.aux = aux;
  heap_.update(i, best);
}

void Engine::process_cell(std::uint32_t i) {
  move_to(i, now_);
  ++c_.cell_crossings;
  const int d = sc_[i].aux >> 1;
  const int dir = (sc_[i].aux & 1) ? 1 : -1;
  remove_cell(i);
  int& c = sc_[i].cell[d];
  c += dir;
  if (c >= nc_[d]) c = 0, comp(k_[i].r, d) -= comp(L_, d);
  else if (c < 0) c = nc_[d] - 1, comp(k_[i].r, d) += comp(L_, d);
  insert_cell(i);
  // keep the two best collisions found so far (the second promoted if the first partner
  // moved on and the second is still valid); scan only the new layer
  if (std::isfinite(sc_[i].coll_time) && k_[sc_[i].coll_partner].counter != sc_[i].coll_partner_counter &&
      !promote_second(i)) {
    predict(i);
  } else {
    scan_neighbours(i, d, dir);
    schedule(i);
  }
}

void Engine::process_wall(std::uint32_t i) {
  move_to(i, now_);
  ++c_.wall_collisions;
  const int d = sc_[i].aux >> 1;
  double& v = comp(k_[i].v, d);
  const bool high = sc_[i].aux & 1;
  if ((high && v > 0.0) || (!high && v < 0.0)) {
    const double e0 = 0.5 * v * v;
    if (driving_walls_) {
      // Infinitely fast vibration (thesis ch. 3; docs/edmd.md "Driving walls"): the grain
      // leaves with normal speed alpha_w |v_n| + v_dr whatever the wall's phase.
      const int side = high ? 1 : 0;
      const double out = wall_e_side_[side] * std::abs(v) + wall_drive_[side];
      const double v_new = high ? -out : out;
      c_.wall_virial += std::abs(v_new - v);
      c_.wall_momentum[side] += std::abs(v_new - v);
      v = v_new;
      c_.wall_energy[side] += 0.5 * v * v - e0;
      ++c_.wall_hits[side];
    } else {
      c_.wall_virial += (1.0 + wall_e_) * std::abs(v);
      v = -wall_e_ * v;
      c_.wall_energy_lost += e0 - 0.5 * v * v;
    }
    // pin to the wall against round-off drift
    comp(k_[i].r, d) = high ? comp(L_, d) - 0.5 : 0.5;
    trajectory_changed(i);
  }
  predict(i);
}

void Engine::process_background(std::uint32_t i) {
  if (accelerated_) {  // window thinning (draw_background_window)
    BgWindow& w = bg_win_[i];
    bool keep = false;
    if (!w.refresh) {
      const Kin& k = k_[i];
      Vec3 c = k.v + (now_ - k.t) * a_[i] - bg_->velocity;  // the velocity move_to gives
      if (dims_ == 2) c.z = 0.0;
      const double rate =
          bg_->rate_scale * (norm(c) + (dims_ == 2 ? background_mean_speed_2d(*bg_) : bg_->mean_speed));
      CounterRng rng(seed_, Stream::edmd_background, id_[i], k.counter, 2ull * w.draws + 1);
      keep = rng.uniform() * w.bound < rate;
    }
    if (!keep) {  // a window's end or a thinned candidate: the trajectory and its predictions stand
      ++w.draws;
      draw_background_window(i);
      schedule(i);
      return;
    }
  }
  move_to(i, now_);
  ++c_.background_candidates;
  CounterRng rng(seed_, Stream::edmd_collisions, id_[i], k_[i].counter);
  const bool hit = dims_ == 2 ? attempt_background_collision_2d(k_[i].v, *bg_, 1.0, rng, c_.background_energy)
                              : attempt_background_collision(k_[i].v, *bg_, 1.0, rng, c_.background_energy);
  if (hit) ++c_.background_collisions;
  trajectory_changed(i);  // also redraws the next candidate time at the new majorant rate
  predict(i);
}

void Engine::apply_heating() {
  CounterRng rng(seed_, Stream::edmd_heating, kSystemEntity, c_.collisions);
  auto pick = [&]() {  // a random particle id, returned as its storage slot
    return slot_of_[static_cast<std::uint32_t>(std::min<double>(static_cast<double>(n_ - 1), rng.uniform() * n_))];
  };
  auto direction = [&]() -> Vec3 {
    if (dims_ == 2) {
      const double phi = 2.0 * std::numbers::pi * rng.uniform();
      return {std::cos(phi), std::sin(phi), 0.0};
    }
    return rng.unit_vector();
  };
  auto kinetic = [&](std::uint32_t p) { return 0.5 * norm2(k_[p].v); };
  for (int r = 0; r < heating_.rate; ++r) {
    switch (heating_.kind) {
      case HeatingKind::white_noise: {  // Bizon eqs. 20-21: opposite kicks, momentum conserved
        const std::uint32_t p = pick();
        std::uint32_t q = pick();
        while (q == p) q = pick();
        const Vec3 u = direction();
        move_to(p, now_);
        move_to(q, now_);
        const double e0 = kinetic(p) + kinetic(q);
        k_[p].v += heating_.kick * u;
        k_[q].v -= heating_.kick * u;
        c_.heating_energy += kinetic(p) + kinetic(q) - e0;
        trajectory_changed(p);
        trajectory_changed(q);
        predict(p);
        predict(q);
        break;
      }
      case HeatingKind::air_table: {  // Bizon eq. 22: new direction, partner gets the opposite
        const std::uint32_t p = pick();
        const std::uint32_t q = slot_of_[pair_[id_[p]]];
        if (q == p) break;
        move_to(p, now_);
        move_to(q, now_);
        a_[p] = draw_acceleration(rng, k_[p].r);
        a_[q] = -a_[p];
        trajectory_changed(p);
        trajectory_changed(q);
        predict(p);
        predict(q);
        break;
      }
      case HeatingKind::boltzmann: {  // Bizon Sec. III C: velocity replaced by a Maxwellian draw
        const std::uint32_t p = pick();
        move_to(p, now_);
        const double e0 = kinetic(p);
        const double s = std::sqrt(heating_.temperature);
        k_[p].v = {s * rng.normal(), s * rng.normal(), dims_ == 3 ? s * rng.normal() : 0.0};
        c_.heating_energy += kinetic(p) - e0;
        trajectory_changed(p);
        predict(p);
        break;
      }
      case HeatingKind::none: break;
    }
  }
}

Vec3 Engine::draw_acceleration(CounterRng& rng, const Vec3& r) {
  const double a0 = heating_.acceleration;
  const int ax = heating_.profile_axis;
  const double L = comp(L_, ax);
  double z = comp(r, ax);  // wrapped position along the profile axis
  z -= L * std::floor(z / L);
  switch (heating_.profile) {
    case ForcingProfile::shear: {  // Bizon eqs. 35-36: Gaussian components, sinusoidal bias
      Vec3 a{a0 * rng.normal(), a0 * rng.normal(), dims_ == 3 ? a0 * rng.normal() : 0.0};
      comp(a, heating_.bias_component) += a0 * heating_.bias * std::sin(2.0 * std::numbers::pi * z / L);
      return a;
    }
    case ForcingProfile::tent:  // Bizon eq. 34: peak a0 at z = L/2, zero at the periodic face
    case ForcingProfile::uniform: {
      Vec3 u;
      if (dims_ == 2) {
        const double phi = 2.0 * std::numbers::pi * rng.uniform();
        u = {std::cos(phi), std::sin(phi), 0.0};
      } else {
        u = rng.unit_vector();
      }
      const double mag = heating_.profile == ForcingProfile::tent ? a0 * (1.0 - std::abs(z - 0.5 * L) / (0.5 * L)) : a0;
      return mag * u;
    }
  }
  return {};
}

void Engine::synchronize() {
  for (std::uint32_t i = 0; i < n_; ++i) move_to(i, now_);
}

void Engine::rebuild() {
  synchronize();
#ifndef NDEBUG
  // debug builds: full overlap check at every rebuild (every 10 collisions per particle)
  if (rebuilds_ > 0) {
    const double dmin = min_distance();
    if (dmin < 1.0 - 1e-9)
      throw std::logic_error("edmd: overlap detected at rebuild: closest pair " + std::to_string(dmin) + " apart");
  }
#endif
  // wrap into the box and reassign cells from positions alone, so that a run restarted
  // from (positions, velocities, counters) takes exactly the same decisions
  for (std::uint32_t i = 0; i < n_; ++i) {
    for (int d = 0; d < dims_; ++d) {
      if (walls_[d]) continue;
      double& x = comp(k_[i].r, d);
      const double l = comp(L_, d);
      if (x >= l) x -= l;
      else if (x < 0.0) x += l;
      if (x >= l) x = 0.0;  // x = -tiny + l rounds to l
    }
    k_[i].t = 0.0;
    assign_cell(i);
  }
  sort_by_cell();
  fill_cells();
  offset_ += now_;
  for (std::uint32_t i = 0; i < n_; ++i) sc_[i].last_collision -= now_;
  now_ = 0.0;
  ++rebuilds_;
  for (std::uint32_t i = 0; i < n_; ++i) trajectory_changed(i);
  rebuild_calendar();
}

void Engine::rebuild_calendar() {
#ifdef GRAINBATH_EDMD_HEAP
  heap_.reset(n_);
  for (std::uint32_t i = 0; i < n_; ++i) predict(i);
#else
  // predict everyone into a provisional calendar, then size the buckets from the mean delay
  // to the next event (about half an event per bucket near the front; EventCalendar::reset)
  // and re-insert
  // deferred links where the calendar's lines miss the caches (by default the threshold of
  // the next-event prefetch; EngineSetup::calendar_defer, event_calendar.hpp update())
  heap_.reset(n_, 0.0, calendar_width_ > 0.0 ? calendar_width_ : 1.0, defer_links_);
  for (std::uint32_t i = 0; i < n_; ++i) predict(i);
  std::vector<double> ev_time(n_);
  for (std::uint32_t i = 0; i < n_; ++i) ev_time[i] = heap_.key(i);
  double sum = 0.0;
  std::size_t finite = 0;
  for (std::uint32_t i = 0; i < n_; ++i)
    if (std::isfinite(ev_time[i])) sum += ev_time[i], ++finite;
  calendar_width_ = finite ? 0.5 * (sum / finite) / static_cast<double>(n_) : 1.0;
  if (!(calendar_width_ > 0.0)) calendar_width_ = 1e-6;
  heap_.reset(n_, 0.0, calendar_width_, defer_links_);
  for (std::uint32_t i = 0; i < n_; ++i) heap_.update(i, ev_time[i]);
#endif
  at_rebuild_ = true;
}

namespace {
// Interleaves the bits of (x, y, z) (Morton / Z order): cells close in space get close keys
// in all three directions, not only along x as with the row-major cell index.
std::uint64_t morton3(std::uint32_t x, std::uint32_t y, std::uint32_t z) {
  auto spread = [](std::uint64_t v) {
    v &= 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffULL;
    v = (v | v << 16) & 0x1f0000ff0000ffULL;
    v = (v | v << 8) & 0x100f00f00f00f00fULL;
    v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
    v = (v | v << 2) & 0x1249249249249249ULL;
    return v;
  };
  return spread(x) | spread(y) << 1 | spread(z) << 2;
}
}  // namespace

// Sorts the storage by the Morton key of the cell (ties by id): neighbours in space become
// neighbours in memory, which is what makes the neighbour scans cache-friendly.
// Deterministic: depends on cells and ids only.
void Engine::sort_by_cell() {
  struct Key {
    std::uint64_t morton;
    std::uint32_t id, slot;
  };
  std::vector<Key> key(n_);
  for (std::uint32_t s = 0; s < n_; ++s) key[s] = {morton3(sc_[s].cell[0], sc_[s].cell[1], sc_[s].cell[2]), id_[s], s};
  std::sort(key.begin(), key.end(),
            [](const Key& a, const Key& b) { return a.morton < b.morton || (a.morton == b.morton && a.id < b.id); });
  std::vector<std::uint32_t> order(n_);  // new slot -> old slot
  for (std::uint32_t k = 0; k < n_; ++k) order[k] = key[k].slot;
  key = {};
  // in place, cycle by cycle: copies of these arrays were fresh pages (zeroed by the kernel)
  // at every re-sort (src/core/permute.hpp). bg_win_ (empty without an air-table medium) is
  // redrawn after every sort, kept in step all the same.
  permute_in_place(order, k_, a_, omega_, sc_, bg_time_, bg_win_, id_);
  for (std::uint32_t k = 0; k < n_; ++k) slot_of_[id_[k]] = k;
}

bool Engine::rebuild_if_due() {
  // the same test and bookkeeping as at the top of advance()'s loop
  if (!(rebuild_every_ && total_collisions_ >= next_rebuild_)) return false;
  next_rebuild_ += rebuild_every_;
  rebuild();
  return true;
}

EngineState Engine::state() const {
  if (!at_rebuild_)
    throw std::logic_error("edmd: Engine::state() needs a rebuild point (events were processed since the last rebuild)");
  EngineState st;
  st.positions.resize(n_);
  st.velocities.resize(n_);
  st.event_counters.resize(n_);
  st.last_collision.resize(n_);
  if (!omega_.empty()) st.omega.resize(n_);
  if (accelerated_) st.accelerations.resize(n_), st.pairs = pair_;
  for (std::uint32_t s = 0; s < n_; ++s) {
    const std::uint32_t id = id_[s];
    st.positions[id] = k_[s].r;
    st.velocities[id] = k_[s].v;
    st.event_counters[id] = k_[s].counter;
    st.last_collision[id] = sc_[s].last_collision;
    if (!omega_.empty()) st.omega[id] = omega_[s];
    if (accelerated_) st.accelerations[id] = a_[s];
  }
  st.offset = offset_;
  st.calendar_width = calendar_width_;
  st.vn_bin_width = vn_bin_width_;
  st.rebuilds = rebuilds_;
  st.total_collisions = total_collisions_;
  st.next_rebuild = next_rebuild_;
  st.rebuild_every = rebuild_every_;
  st.cell_capacity = static_cast<std::uint64_t>(cap_);
  st.counters = c_;
  return st;
}

void Engine::restore(const EngineState& st) {
  auto bad = [](const std::string& what) { throw std::runtime_error("edmd: checkpoint state: " + what); };
  if (st.positions.size() != n_ || st.velocities.size() != n_ || st.event_counters.size() != n_ ||
      st.last_collision.size() != n_)
    bad("particle arrays do not have N = " + std::to_string(n_) + " entries");
  if (!st.omega.empty() && st.omega.size() != n_) bad("angular velocities do not have N entries");
  if (accelerated_ != !st.accelerations.empty() || (accelerated_ && (st.accelerations.size() != n_ || st.pairs.size() != n_)))
    bad("air-table accelerations do not match the case");
  if (st.rebuild_every != rebuild_every_) bad("rebuild interval differs from the case");
  if (st.cell_capacity < 1 || st.cell_capacity > 65535) bad("cell capacity out of range");
  if (st.counters.vn_histogram.size() != c_.vn_histogram.size()) bad("normal-speed histogram size differs from the case");
  const bool lossy_walls = !driving_walls_ && wall_e_ < 1.0 && std::any_of(walls_.begin(), walls_.end(), [](bool w) { return w; });
  // not a damaged file but one this case cannot continue (the previous checkpoint is as
  // old): std::invalid_argument, which the reader passes on instead of trying the previous
  // one and reporting both as corrupt
  if (std::isnan(st.counters.wall_energy_lost) && lossy_walls)
    throw std::invalid_argument(
        "edmd: checkpoint state: written before static-wall losses had their own counter (they were added to the "
        "grain-grain energy_lost): it cannot be continued with walls.restitution < 1; start the run again");
  for (std::uint32_t i = 0; i < n_; ++i)
    for (int d = 0; d < dims_; ++d) {
      const double x = comp(st.positions[i], d), l = comp(L_, d);
      if (!std::isfinite(x) || x < 0.0 || x > l) bad("particle " + std::to_string(i) + " is outside the box");
    }
  // checks done: from here on nothing throws
  for (std::uint32_t i = 0; i < n_; ++i) {
    id_[i] = slot_of_[i] = i;
    k_[i].r = st.positions[i];
    k_[i].v = st.velocities[i];
    k_[i].t = 0.0;
    k_[i].counter = st.event_counters[i];
    sc_[i].last_collision = st.last_collision[i];
    assign_cell(i);
  }
  if (!st.omega.empty()) omega_ = st.omega;
  if (accelerated_) a_ = st.accelerations, pair_ = st.pairs;
  // the second half of rebuild(), with the counters as saved (rebuild() had bumped them
  // before the state was taken): same cells, storage order, background times, calendar
  sort_by_cell();
  cap_ = static_cast<int>(st.cell_capacity);
  fill_cells();
  offset_ = st.offset;
  now_ = 0.0;
  rebuilds_ = st.rebuilds;
  total_collisions_ = st.total_collisions;
  next_rebuild_ = st.next_rebuild;
  c_ = st.counters;
  if (std::isnan(c_.wall_energy_lost)) c_.wall_energy_lost = 0.0;  // old checkpoint, no lossy walls (checked above)
  calendar_width_ = st.calendar_width;
  if (st.vn_bin_width > 0.0) vn_bin_width_ = st.vn_bin_width;
  for (std::uint32_t i = 0; i < n_; ++i) draw_background_time(i);
  rebuild_calendar();
}

void Engine::set_velocities(const std::vector<Vec3>& v) {
  synchronize();
  for (std::size_t i = 0; i < n_; ++i) {
    Vec3& u = k_[slot_of_[i]].v;
    u = v[i];
    if (dims_ == 2) u.z = 0.0;
  }
  rebuild();
}

void Engine::set_angular_velocities(const std::vector<Vec3>& w) {
  if (w.size() != n_) throw std::invalid_argument("edmd: angular velocities must have N entries");
  for (std::size_t i = 0; i < n_; ++i) {
    Vec3 u = w[i];
    if (dims_ == 2) u.x = u.y = 0.0;  // disks spin about z only (docs/rough.md sec. 1)
    omega_[slot_of_[i]] = u;
  }
}

double Engine::rotational_energy() const {
  double s = 0.0;
  for (const auto& w : omega_) s += norm2(w);
  return 0.5 * moment_of_inertia() * s;
}

double Engine::kinetic_energy() const {
  double s = 0.0;
  for (const auto& k : k_) s += 0.5 * norm2(k.v);
  return s;
}

Vec3 Engine::momentum() const {
  Vec3 p;
  for (const auto& k : k_) p += k.v;
  return p;
}

double Engine::min_distance() const {
  double best2 = kInf;
  for (std::uint32_t i = 0; i < n_; ++i) {
    const auto& c = sc_[i].cell;
    const int zlo = dims_ == 3 ? -1 : 0, zhi = dims_ == 3 ? 1 : 0;
    for (int dz = zlo; dz <= zhi; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int off[3] = {dx, dy, dz};
          int cc[3];
          bool skip = false;
          for (int d = 0; d < 3; ++d) {
            cc[d] = c[d] + off[d];
            if (cc[d] < 0 || cc[d] >= nc_[d]) {
              if (walls_[d] || d >= dims_) { skip = true; break; }
              cc[d] = (cc[d] + nc_[d]) % nc_[d];
            }
          }
          if (skip) continue;
          const int cell = cell_index(cc[0], cc[1], cc[2]);
          const std::uint32_t* m = cell_block(cell) + 1;
          for (int q = 0; q < static_cast<int>(m[-1]); ++q) {
            const std::uint32_t j = m[q];
            if (j <= i) continue;
            Vec3 dr = k_[j].r - k_[i].r;
            for (int d = 0; d < dims_; ++d) {
              if (walls_[d]) continue;
              double& x = comp(dr, d);
              const double l = comp(L_, d);
              x -= l * std::round(x / l);
            }
            best2 = std::min(best2, norm2(dr));
          }
        }
  }
  return std::sqrt(best2);
}

}  // namespace grainbath::edmd
