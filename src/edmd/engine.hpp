#pragma once
// Event-driven molecular dynamics of inelastic hard disks (2D) and hard spheres (3D).
//
// Units: diameter sigma = 1, grain mass m = 1, k_B = 1; time in sigma sqrt(m / energy).
//
// Algorithm (docs/edmd.md):
//  * particles move ballistically (or with a constant acceleration in the air-table bath)
//    between events; each particle carries its own local time ("delayed states"), and is
//    only brought to the current time when it takes part in an event;
//  * cell lists with cells of side >= sigma; a particle's next event is the earliest of: a
//    collision with a particle of the 3^D neighbouring cells, leaving its cell, hitting a
//    hard wall, a Poisson-timed background-medium candidate;
//  * calendar: one entry per particle in an indexed binary heap (event_heap.hpp);
//    invalidation is lazy: a predicted collision stores the partner's event counter; the
//    counter of a particle is bumped whenever its trajectory changes, so a stale prediction
//    is recognised when it reaches the top and the particle is re-predicted;
//  * randomness is counter-based (Philox), keyed on (seed, stream; particle id, particle
//    event counter) or (seed, stream; global entity, collision number): nothing but the
//    counters has to be saved for an exact restart, and rebuild() recomputes the whole
//    calendar from positions and velocities alone (issue #8 design).
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "edmd/background2d.hpp"
#include "edmd/event_calendar.hpp"
#include "edmd/event_heap.hpp"
#include "operators/background.hpp"
#include "operators/binary_collision.hpp"
#include "operators/random.hpp"
#include "operators/restitution.hpp"
#include "operators/vec3.hpp"
#include "operators/walton.hpp"

namespace grainbath::edmd {

inline constexpr double kInf = std::numeric_limits<double>::infinity();
// Entity id for draws that belong to the whole system (heating choices), far above any
// particle id.
inline constexpr std::uint64_t kSystemEntity = std::uint64_t{1} << 62;

enum class HeatingKind { none, white_noise, air_table, boltzmann };
// Spatial profile of the air-table accelerations (Bizon Sec. V, docs/edmd.md "Transport
// coefficients"): uniform (eq. 22), tent = magnitude a0 (1 - |z - L/2|/(L/2)) set by the
// redrawn grain's position (eq. 34), shear = Gaussian components a0 psi plus the bias
// a0 * bias * sin(2 pi z / L) on one component (eqs. 35-36). The partner always receives
// the opposite acceleration, wherever it is (momentum conserved).
enum class ForcingProfile { uniform, tent, shear };

// One grain-grain collision as a measurement hook sees it (slab profiles, docs/edmd.md
// "Slab profiles"). Masses are 1, so momenta are velocities.
struct CollisionRecord {
  Vec3 ri;            // centre of grain i at contact (inside the box up to a cell crossing)
  Vec3 rij;           // r_j - r_i, minimum image: |rij| = sigma
  Vec3 impulse;       // momentum given to j (grain i receives -impulse)
  double dEi = 0.0;   // kinetic energy change of i (lab frame)
  double dEj = 0.0;   // kinetic energy change of j
  std::uint32_t id_i = 0, id_j = 0;  // stable particle ids
};
// Called once per processed collision when set (Engine::set_collision_hook); the
// non-measuring path pays one predictable branch.
using CollisionHook = void (*)(void* context, const CollisionRecord& record);
// Called at every free-flight piece when set (Engine::set_move_hook): particle `id` moved
// from r0 (velocity v0) to r1 (velocity v1) in time dt under the constant acceleration a
// (zero unless air table). Position wraps at periodic faces happen outside the pieces.
// Used by the transport bookkeeping (src/edmd/transport.hpp) to find slab-plane crossings.
using MoveHook = void (*)(void* context, std::uint32_t id, const Vec3& r0, const Vec3& v0, const Vec3& r1,
                          const Vec3& v1, const Vec3& a, double dt);

// Bizon Sec. III. All three act at grain-grain collisions, "rate" pairs/particles per collision.
struct Heating {
  HeatingKind kind = HeatingKind::none;
  int rate = 1;              // r_v (pairs kicked), r_a (accelerations redrawn), r_b (particles thermalised)
  double kick = 0.0;         // white noise: |dv| of each kick (eqs. 20-21)
  double acceleration = 0.0; // air table: a0 (eq. 22)
  double temperature = 1.0;  // Boltzmann bath temperature
  ForcingProfile profile = ForcingProfile::uniform;  // air table only
  int profile_axis = 1;      // z of eqs. 34-36 (index 0, 1, 2)
  int bias_component = 0;    // y of eq. 35: the biased acceleration component
  double bias = 0.01;        // eq. 35: relative amplitude of the sinusoidal bias
};

struct EngineSetup {
  int dims = 3;
  Vec3 length{1, 1, 1};
  std::array<bool, 3> walls{false, false, false};  // hard walls at 0 and L in that direction
  double wall_restitution = 1.0;
  // Driving walls (thesis ch. 3, infinitely fast vibration, docs/edmd.md "Driving walls"):
  // a grain hitting the wall at the low (index 0) / high (index 1) end of a wall direction
  // leaves with normal speed restitution * |v_n| + driving_speed. Both zero: plain walls.
  std::array<double, 2> wall_driving{0.0, 0.0};
  std::array<double, 2> wall_restitution_side{-1.0, -1.0};  // < 0: wall_restitution
  double contact_time = 0.0;  // TC-model collapse guard: e = 1 if either grain collided within t_c
  // Rough grains (advance() with WaltonRestitution; docs/rough.md): moment of inertia
  // I = inertia_q m a^2 with a = sigma/2, so I = inertia_q / 4 in engine units.
  double inertia_q = 0.4;
  Heating heating;
  std::optional<BackgroundState> background;
  std::uint64_t seed = 1;
  double rebuild_interval = 10.0;  // collisions per particle between automatic rebuilds (0: never)
  // Calendar links deferred (EventCalendar::update): -1 at N >= 50000 (where the calendar's
  // lines miss the caches), 0 never, 1 always. Results do not depend on it (the same event
  // order); bench_edmd's BM_EdmdDeferAB times the two side by side.
  int calendar_defer = -1;
  double vn_bin_width = 0.05;  // histogram of normal speed at collision
  int vn_bins = 200;
};

// Event accounting and the per-collision tallies of the measurements (Bizon Sec. IV).
struct Counters {
  std::uint64_t collisions = 0;
  std::uint64_t events = 0;          // all processed events incl. stale ones
  std::uint64_t stale = 0;
  std::uint64_t cell_crossings = 0;
  std::uint64_t wall_collisions = 0;
  std::uint64_t background_candidates = 0;
  std::uint64_t background_collisions = 0;
  std::uint64_t guard_elastic = 0;    // TC-model collisions made elastic
  std::uint64_t clamped = 0;          // restitution law clamped to [0, 1]
  double virial = 0.0;                // Sum sigma k.dv_i = Sum (1+e)/2 g_n  (Bizon eq. 24)
  double energy_lost = 0.0;           // Sum (m/4)(1-e^2) g_n^2: grain-grain collisions only
  double heating_energy = 0.0;        // energy injected by the heat bath (air table: work of the forces)
  double background_energy = 0.0;     // energy given by the background medium
  double wall_virial = 0.0;           // Sum m |dv_n| at walls (momentum transferred)
  // Plain (static) walls with restitution e_w < 1: Sum (1 - e_w^2) m v_n^2 / 2. Kept apart
  // from energy_lost, which loss.gamma compares with the grain-grain theory (Bizon eqs.
  // 29-31) and the slab loss_rate of [profiles] sums to.
  double wall_energy_lost = 0.0;
  // Driving walls only (plain walls book their loss in wall_energy_lost): energy given to the
  // grains by the low / high wall (signed, net of the wall's restitution loss), and the
  // momentum given along the wall normal (into the box positive).
  std::array<double, 2> wall_energy{0.0, 0.0};
  std::array<double, 2> wall_momentum{0.0, 0.0};
  std::array<std::uint64_t, 2> wall_hits{0, 0};
  double sum_vn = 0.0, sum_vn2 = 0.0, sum_e = 0.0;
  // Collisions the TC guard made elastic: Sum (1 - 1/e_law(g_n)) / g_n, what g_r.contact_from_collisions
  // (measure.hpp) adds to its receding-pair sum, which takes every histogram entry at the law's e.
  // NaN after a checkpoint written before this counter (2026-12-06): the key is then null if the
  // guard acted.
  double guard_receding = 0.0;
  std::vector<std::uint64_t> vn_histogram;
};

// The engine's whole mutable state at a rebuild point (issue #8), arrays by particle id.
// With the EngineSetup it fixes the rest of the run bitwise: cells, storage order,
// background times and the calendar are recomputed from it exactly as rebuild() does.
struct EngineState {
  std::vector<Vec3> positions, velocities;  // wrapped into the box, at the time origin
  std::vector<Vec3> omega;                  // angular velocities (empty if not allocated)
  std::vector<Vec3> accelerations;          // air table (empty otherwise)
  std::vector<std::uint32_t> pairs;         // air-table partner ids (empty otherwise)
  std::vector<std::uint64_t> event_counters;
  std::vector<double> last_collision;       // relative to the time origin
  double offset = 0.0;                      // time of the origin: time() = offset
  double calendar_width = 0.0;
  double vn_bin_width = 0.0;                // normal-speed histogram bins (0: the setup's)
  std::uint64_t rebuilds = 0, total_collisions = 0, next_rebuild = 0, rebuild_every = 0;
  std::uint64_t cell_capacity = 4;
  Counters counters;
};

class Engine {
 public:
  // Throws std::invalid_argument on overlapping or out-of-box positions.
  Engine(const EngineSetup& setup, const std::vector<Vec3>& positions, const std::vector<Vec3>& velocities);

  // Runs events until the total time reaches t_end or the collision count reaches
  // max_collisions, whichever first. Particles are NOT synchronised afterwards.
  template <class Law>
  void advance(const Law& law, double t_end, std::uint64_t max_collisions);

  // Brings every particle to the current time (positions, velocities); predictions stay valid.
  void synchronize();
  // synchronize(), shift the time origin to now (keeps round-off of event times bounded),
  // bump all counters, redraw background times, recompute the whole calendar. A checkpoint
  // taken right after a rebuild restores bitwise (issue #8).
  void rebuild();

  double time() const { return offset_ + now_; }
  std::size_t size() const { return n_; }
  int dims() const { return dims_; }
  const Vec3& length() const { return L_; }
  // By stable particle id (storage order is internal: sorted by cell at every rebuild).
  Vec3 position(std::size_t id) const { return k_[slot_of_[id]].r; }   // valid after synchronize()
  Vec3 velocity(std::size_t id) const { return k_[slot_of_[id]].v; }
  // Rough grains: angular velocity (2D: along z), changed only by Walton collisions.
  Vec3 angular_velocity(std::size_t id) const { return omega_[slot_of_[id]]; }
  void set_angular_velocities(const std::vector<Vec3>& w);  // by id; 2D keeps z only
  double moment_of_inertia() const { return 0.25 * q_; }   // I = q m a^2, a = 1/2
  double rotational_energy() const;                        // sum I |omega|^2 / 2
  std::uint64_t event_counter(std::size_t id) const { return k_[slot_of_[id]].counter; }
  const Counters& counters() const { return c_; }
  Counters& counters() { return c_; }
  // Width (velocity) of the normal-speed histogram's bins; the driver sets it from the
  // temperature when the measurements start, with the counts zeroed.
  double vn_bin_width() const { return vn_bin_width_; }
  void set_vn_bin_width(double w) { vn_bin_width_ = w; }
  double kinetic_energy() const;   // after synchronize()
  Vec3 momentum() const;
  // Smallest centre distance over all pairs (cell search), after synchronize().
  double min_distance() const;
  // Heap property and one-entry-per-particle consistency (tests).
  bool calendar_valid() const { return heap_.valid(); }
  std::uint64_t rebuilds() const { return rebuilds_; }
  // Replace velocities (e.g. rescaling during equilibration); rebuilds the calendar.
  void set_velocities(const std::vector<Vec3>& v);
  // Measurement hook called at every grain-grain collision (nullptr: off).
  void set_collision_hook(CollisionHook hook, void* context) {
    hook_ = hook;
    hook_context_ = context;
  }
  // Free-flight hook (transport bookkeeping, nullptr: off).
  void set_move_hook(MoveHook hook, void* context) {
    move_hook_ = hook;
    move_hook_context_ = context;
  }
  // Air-table acceleration of a particle by id (zero for other heatings).
  Vec3 acceleration(std::size_t id) const { return a_[slot_of_[id]]; }

  // Checkpoint support (issue #8). Automatic rebuilds happen when the never-reset collision
  // total reaches the next multiple of rebuild_interval * N; advance(max_collisions =
  // collisions + collisions_until_rebuild()) stops just before one, and rebuild_if_due()
  // then performs it exactly as advance() would have (splitting advance() there changes
  // nothing). state() is valid only right after a rebuild (throws std::logic_error
  // otherwise); restore() on an engine built with the same EngineSetup and N continues
  // bitwise as the engine state() was taken from.
  std::uint64_t collisions_until_rebuild() const {
    if (!rebuild_every_) return std::numeric_limits<std::uint64_t>::max();
    return next_rebuild_ > total_collisions_ ? next_rebuild_ - total_collisions_ : 0;
  }
  bool rebuild_if_due();
  std::uint64_t total_collisions() const { return total_collisions_; }
  EngineState state() const;
  void restore(const EngineState& state);

 private:
  enum EventType : std::uint8_t { ev_none, ev_collision, ev_cell, ev_wall, ev_background };
  struct Kin {          // the kinematic record, read together in every prediction
    Vec3 r;             // position at local time t
    double t = 0.0;     // local time (relative to offset_)
    Vec3 v;             // velocity at local time t
    // Event counter, bumped whenever the trajectory changes (lazy invalidation). It fills
    // the 8 bytes that would otherwise pad the record to 64: the staleness test of a
    // predicted collision reads the partner's counter, and a valid collision needs the
    // partner's kinematics next, so both come with one cache line.
    std::uint64_t counter = 0;
  };
  static_assert(sizeof(Kin) == 64, "the kinematic record is one cache line");
  // Everything else the event loop touches for a particle, in one cache line (by slot).
  // Separate arrays cost one cache miss each per event at large N (docs/performance/edmd.md,
  // 2026-11-25); one record costs one. The scheduled event is a collision (with coll_partner,
  // valid while its counter still equals coll_partner_counter), a cell crossing, a wall hit
  // or a background candidate.
  //
  // Second candidate (coll2_*): every scan keeps the two earliest collisions it finds.
  // Invariant: every pair (i, k) that i's scans cover (k not changed since) and that is
  // neither of the two stored ones collides no earlier than coll2_time. When the first
  // partner turns out stale (it changed trajectory; the pair is then covered by the
  // partner's own scan), the second, if its partner is unchanged, is therefore i's next
  // collision among the pairs i still covers: it is promoted without a rescan. A second
  // slot that is unknown (after a promotion, or under acceleration) keeps the bound
  // coll2_time but carries kUnknownCounter, which never matches, forcing the full rescan.
  struct alignas(64) Sched {
    double coll_time = kInf;                // best predicted collision (absolute time)
    std::uint64_t coll_partner_counter = 0;  // the partner's counter when predicted
    double coll2_time = kInf;               // second candidate (see above)
    std::uint64_t coll2_partner_counter = 0;
    double last_collision = -kInf;          // TC-model guard
    std::array<int, 3> cell{0, 0, 0};       // cell coordinates
    std::uint32_t coll_partner = 0;         // slot
    std::uint32_t coll2_partner = 0;        // slot
    std::uint16_t cell_pos = 0;             // position in the cell's member list (< cap_ <= 65535)
    std::uint8_t type = ev_none;            // the scheduled event
    std::uint8_t aux = 0;  // cell crossing: 2 * dim + (dir > 0); wall: 2 * dim + (high side)
  };
  static constexpr std::uint64_t kUnknownCounter = ~std::uint64_t{0};
  static_assert(sizeof(Sched) == 64, "the scheduling record is one cache line");

  void move_to(std::uint32_t i, double t);
  // Next-event prefetch (docs/performance/edmd.md, 2026-11-25 night): the grain of the
  // probable next event is requested one event ahead, in two stages so that each stage's
  // addresses come from lines the previous stage requested.
  void request_next_records(std::uint32_t r) const;     // its Sched and Kin lines
  void request_next_neighbourhood(std::uint32_t r) const;  // its partner, its cells' member rows
  void advance_piece(std::uint32_t i, double dt);
  void predict(std::uint32_t i);   // full scan + schedule
  void predict_pair(std::uint32_t i, std::uint32_t j);  // both partners of a collision, one shared scan
  template <int D>
  void predict_pair_d(std::uint32_t i, std::uint32_t j);  // predict_pair for D dimensions
  bool promote_second(std::uint32_t i);  // first candidate stale: take the second if still valid
  void schedule(std::uint32_t i);  // combine stored collision, cell faces, walls, background
  template <int D>
  void schedule_d(std::uint32_t i);  // schedule() for ballistic grains
  template <int D>
  double next_event_d(std::uint32_t i);  // schedule_d without the calendar update: sets type, returns the time
  void scan_neighbours(std::uint32_t i, int layer_dim, int layer_dir);
  template <int D>
  bool scan_neighbours_d(std::uint32_t i, int layer_dim, int layer_dir);  // ballistic fast path
  // The two earliest collisions found so far by a scan (Sched's coll_* and coll2_*).
  struct Top2 {
    double t1, t2;
    std::uint32_t p1, p2;
    std::uint64_t c1, c2;
    void offer(double tc, std::uint32_t j, std::uint64_t cj) {
      if (tc < t1) {
        t2 = t1, p2 = p1, c2 = c1;
        t1 = tc, p1 = j, c1 = cj;
      } else if (tc < t2) {
        t2 = tc, p2 = j, c2 = cj;
      }
    }
  };
  Top2 load_top2(const Sched& s) const {
    return {s.coll_time, s.coll2_time, s.coll_partner, s.coll2_partner, s.coll_partner_counter, s.coll2_partner_counter};
  }
  void store_top2(std::uint32_t i, const Top2& b);
  void scan_cell(std::uint32_t i, const Kin& ki, const Vec3& ai, int cell, const Vec3& shift, Top2& best) const;
  void trajectory_changed(std::uint32_t i);  // counter++, redraw background time
  void draw_background_time(std::uint32_t i);  // from (id, counter): next background candidate
  void draw_background_window(std::uint32_t i);  // air table: next candidate of the current window
  void rebuild_calendar();  // predict everyone, size and fill the calendar (rebuild, restore)
  void insert_cell(std::uint32_t i);
  void remove_cell(std::uint32_t i);
  int cell_index(int cx, int cy, int cz) const { return (cz * nc_[1] + cy) * nc_[0] + cx; }
  // A neighbour cell coordinate c along axis d (one cell beyond the grid at most) brought
  // into the grid: across a periodic side it wraps and `shift` gets the image offset of its
  // members (-L or +L); beyond a wall there is no cell (false).
  bool image_cell(int d, int& c, double& shift) const {
    const double l = d == 0 ? L_.x : d == 1 ? L_.y : L_.z;
    if (c < 0) {
      if (walls_[d]) return false;
      c += nc_[d], shift = -l;
    } else if (c >= nc_[d]) {
      if (walls_[d]) return false;
      c -= nc_[d], shift = l;
    }
    return true;
  }
  void assign_cell(std::uint32_t i);
  void process_cell(std::uint32_t i);
  void process_wall(std::uint32_t i);
  void process_background(std::uint32_t i);
  template <class Law>
  void process_collision(const Law& law, std::uint32_t i, std::uint32_t j);
  void apply_heating();
  Vec3 draw_acceleration(CounterRng& rng, const Vec3& r);  // air table: eq. 22 or the Sec. V profiles
  void grow_cells();
  void fill_cells();
  void sort_by_cell();

  // configuration
  std::size_t n_ = 0;
  int dims_ = 3;
  Vec3 L_;
  std::array<bool, 3> walls_{};
  double wall_e_ = 1.0;
  std::array<double, 2> wall_drive_{0.0, 0.0};
  std::array<double, 2> wall_e_side_{1.0, 1.0};
  bool driving_walls_ = false;
  CollisionHook hook_ = nullptr;
  void* hook_context_ = nullptr;
  MoveHook move_hook_ = nullptr;
  void* move_hook_context_ = nullptr;
  double tc_ = 0.0;
  double q_ = 0.4;  // I / (m a^2), rough grains
  Heating heating_;
  std::optional<BackgroundState> bg_;
  std::uint64_t seed_ = 1;
  bool accelerated_ = false;
  double vn_bin_width_ = 0.05;

  // particle storage (structure of arrays, indexed by storage slot; slots are re-sorted by
  // cell at every rebuild for memory locality, id_[slot] is the stable particle id)
  HugePageVector<std::uint32_t> id_, slot_of_;
  HugePageVector<Kin> k_;
  std::vector<Vec3> a_;          // acceleration (air table), zero otherwise
  std::vector<Vec3> omega_;      // angular velocity: reserved for rough grains (issue #6)
  std::vector<std::uint32_t> pair_;  // by id: air-table partner (id) with the opposite acceleration
  HugePageVector<Sched> sc_;
  std::vector<double> bg_time_;  // next background-medium candidate (only with a medium)
  // Air table with a medium only (empty otherwise): the velocity changes along a free flight,
  // so the candidate process is thinned from a bound valid over a window of the flight
  // (draw_background_window). bound: the window's candidate rate; draws: windows and
  // thinned candidates since the last trajectory change (the RNG sequence); refresh: the
  // event at bg_time_ is the window's end, not a candidate.
  struct BgWindow {
    double bound = 0.0;
    std::uint32_t draws = 0;
    bool refresh = false;
  };
  std::vector<BgWindow> bg_win_;

  // cells: fixed-capacity member arrays
  std::array<int, 3> nc_{1, 1, 1};
  Vec3 w_;  // cell widths
  int cap_ = 8;
  // cell c's block at c * (cap_ + 1): [member count, members...]; the count sits next to
  // the members, so a neighbour scan touches one cache line per row of cells, not two
  HugePageVector<std::uint32_t> members_;
  // predict_pair: j's cells outside i's 3^D block, by offset c_j - c_i (constructor)
  std::array<std::vector<int>, 27> union_extra_;
  std::uint32_t* cell_block(int c) { return &members_[static_cast<std::size_t>(c) * (cap_ + 1)]; }
  const std::uint32_t* cell_block(int c) const { return &members_[static_cast<std::size_t>(c) * (cap_ + 1)]; }

  // The calendar: bounded calendar queue by default (O(1) per update); the 4-ary heap gives
  // bitwise the same event order and is kept for small systems / cross-checks.
#ifdef GRAINBATH_EDMD_HEAP
  EventHeap heap_;
#else
  EventCalendar heap_;
#endif
  double calendar_width_ = 0.0;
  double now_ = 0.0, offset_ = 0.0;
  std::uint64_t rebuilds_ = 0;
  std::uint64_t total_collisions_ = 0;   // never reset (schedules the automatic rebuilds)
  std::uint64_t rebuild_every_ = 0, next_rebuild_ = 0;
  bool at_rebuild_ = false;  // no event processed since the last rebuild / restore (state())
  // Next-event prefetch on (advance()): only for systems whose records do not stay in the
  // cache (at N = 1e4 it would only add instructions). Results do not depend on it.
  bool prefetch_next_ = false;
  bool defer_links_ = false;  // EngineSetup::calendar_defer, resolved
  Counters c_;
};

// ---------------------------------------------------------------------------------------
// Template members

template <class Law>
void Engine::process_collision(const Law& law, std::uint32_t i, std::uint32_t j) {
  move_to(i, now_);
  move_to(j, now_);
  Kin& a = k_[i];
  Kin& b = k_[j];
  Vec3 dr = b.r - a.r;
  // minimum image (positions are kept within one box length of each other's cell)
  for (int d = 0; d < dims_; ++d) {
    if (walls_[d]) continue;
    double* x = d == 0 ? &dr.x : d == 1 ? &dr.y : &dr.z;
    const double l = d == 0 ? L_.x : d == 1 ? L_.y : L_.z;
    if (*x > 0.5 * l) *x -= l;
    else if (*x < -0.5 * l) *x += l;
  }
  const double dist = norm(dr);
#ifndef NDEBUG
  // debug builds: the colliding pair must be in contact, never overlapping
  if (!(dist > 1.0 - 1e-9 && dist < 1.0 + 1e-6))
    throw std::logic_error("edmd: colliding pair at distance " + std::to_string(dist) + " (expected sigma = 1); cells (" +
                           std::to_string(sc_[i].cell[0]) + "," + std::to_string(sc_[i].cell[1]) + ") (" +
                           std::to_string(sc_[j].cell[0]) + "," + std::to_string(sc_[j].cell[1]) + "), collisions " +
                           std::to_string(c_.collisions) + ", rebuilds " + std::to_string(rebuilds_) + ", t " +
                           std::to_string(now_) + ", last collisions " + std::to_string(sc_[i].last_collision) + " " +
                           std::to_string(sc_[j].last_collision));
#endif
  const Vec3 n = (1.0 / dist) * dr;  // unit vector from i to j (Bizon's k)
  const double gn = dot(a.v - b.v, n);    // approach speed > 0
  double e = 1.0;
  if (tc_ > 0.0 && (now_ - sc_[i].last_collision < tc_ || now_ - sc_[j].last_collision < tc_)) {
    ++c_.guard_elastic;  // TC model (Luding-McNamara): collapse guard for constant e
    const double e_law = restitution(law, gn).e;
    if (e_law > 0.0) c_.guard_receding += (1.0 - 1.0 / e_law) / gn;
    else c_.guard_receding = std::numeric_limits<double>::infinity();  // the law's receding pairs would stick
  } else {
    const RestitutionOutcome out = restitution(law, gn);
    e = out.e;
    if (out.clamped) ++c_.clamped;
  }
  const Vec3 va0 = a.v, vb0 = b.v;  // for the measurement hook
  if constexpr (std::is_same_v<Law, WaltonRestitution>) {
    // rough grains: Walton's rule on v and omega (docs/rough.md W1-W5), chosen at compile
    // time; the loss is eq. W5 (translational + rotational). The TC guard makes only the
    // normal part elastic.
    WaltonRestitution rule = law;
    rule.e = e;
    c_.energy_lost += walton_collision(a.v, b.v, omega_[i], omega_[j], n, 0.5, q_, rule, 1.0).energy_lost;
  } else {
    c_.energy_lost += inelastic_collision(a.v, b.v, n, e, 1.0);  // Bizon eq. 28 per collision
  }
  if (hook_) {
    CollisionRecord rec;
    rec.ri = a.r;
    rec.rij = dr;
    rec.impulse = b.v - vb0;
    rec.dEi = 0.5 * (norm2(a.v) - norm2(va0));
    rec.dEj = 0.5 * (norm2(b.v) - norm2(vb0));
    rec.id_i = id_[i];
    rec.id_j = id_[j];
    hook_(hook_context_, rec);
  }
  c_.virial += 0.5 * (1.0 + e) * gn;                             // sigma k.dv, Bizon eq. 24
  c_.sum_vn += gn;
  c_.sum_vn2 += gn * gn;
  c_.sum_e += e;
  const std::size_t bin = static_cast<std::size_t>(gn / vn_bin_width_);
  if (bin < c_.vn_histogram.size()) ++c_.vn_histogram[bin];
  sc_[i].last_collision = sc_[j].last_collision = now_;
  ++c_.collisions;
  ++total_collisions_;
  trajectory_changed(i);
  trajectory_changed(j);
  predict_pair(i, j);
  if (heating_.kind != HeatingKind::none) apply_heating();
}

template <class Law>
void Engine::advance(const Law& law, double t_end, std::uint64_t max_collisions) {
  while (c_.collisions < max_collisions) {
    if (rebuild_every_ && total_collisions_ >= next_rebuild_) {
      // deterministic in the collision count, whatever the split into advance() calls
      next_rebuild_ += rebuild_every_;
      rebuild();
      continue;
    }
    const double t_stop = t_end - offset_;
    const std::uint32_t i = heap_.top();
    const double t = heap_.top_key();
    if (!(t <= t_stop)) {
      now_ = std::max(now_, t_stop);
      return;
    }
    now_ = t;
    at_rebuild_ = false;
    ++c_.events;
    // Stage 1 for the probable next event (the calendar's runner-up): its records arrive
    // while this event is processed; stage 2 at the end of this event reads them to request
    // its partner and its cells' member rows, which arrive while the calendar finds the
    // next minimum. Hints only: no decision depends on them, the results are unchanged.
    const std::uint32_t next = prefetch_next_ ? heap_.runner_up() : heap_.kNoHint;
    if (next != heap_.kNoHint) request_next_records(next);
    // the calendar's next buckets: their nodes, and the records of their grains
    if (prefetch_next_) heap_.request_ahead([this](std::uint32_t r) { request_next_records(r); });
    const Sched& ev = sc_[i];
    switch (ev.type) {
      case ev_collision:
        // the partner's scheduling record is needed only after its kinematics (counter,
        // move_to): request it now so that the two misses overlap
        __builtin_prefetch(&sc_[ev.coll_partner]);
        heap_.request(ev.coll_partner);  // its calendar node, for the re-schedule at the end
        if (k_[ev.coll_partner].counter != ev.coll_partner_counter) {
          ++c_.stale;
          move_to(i, now_);
          if (promote_second(i)) schedule(i);  // the second candidate is still valid: no rescan
          else predict(i);
        } else {
          process_collision(law, i, ev.coll_partner);
        }
        break;
      case ev_cell: process_cell(i); break;
      case ev_wall: process_wall(i); break;
      case ev_background: process_background(i); break;
      default:
        throw std::logic_error("edmd: a particle has no next event (a free particle in an unbounded box?)");
    }
    // (a third stage, requesting the next grain's cell members' Kin, with stage 2 moved
    // into the collision, measured slower: docs/performance/edmd.md, 2026-11-25 night)
    if (next != heap_.kNoHint) request_next_neighbourhood(next);
  }
}

}  // namespace grainbath::edmd
