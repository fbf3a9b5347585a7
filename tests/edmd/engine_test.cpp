// Engine-level tests: conservation, no overlaps, calendar, bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <variant>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "edmd/edmd.hpp"
#include "edmd/measure.hpp"
#include "tests/edmd/config_support.hpp"
#include "edmd/theory.hpp"

using namespace grainbath;
using namespace grainbath::edmd;

using grainbath::edmd::testing::config_from;

TEST(EdmdEngine, ElasticEnergyAndMomentumConservedToRoundOff) {
  for (int dims : {2, 3}) {
    Config c = config_from("[edmd]\ndimensions = " + std::to_string(dims) +
                           "\nparticles = 500\npacking_fraction = 0.4\n");
    const auto init = make_initial_state(c, 7);
    Engine eng(make_setup(c, 7), init.positions, init.velocities);
    eng.synchronize();
    const double e0 = eng.kinetic_energy();
    const Vec3 p0 = eng.momentum();
    eng.advance(ElasticRestitution{}, kInf, 100000);
    eng.synchronize();
    EXPECT_EQ(eng.counters().collisions, 100000u);
    EXPECT_NEAR(eng.kinetic_energy() / e0 - 1.0, 0.0, 1e-12) << dims;
    EXPECT_NEAR(norm(eng.momentum() - p0), 0.0, 1e-10) << dims;
    EXPECT_GE(eng.min_distance(), 1.0 - 1e-9) << dims;
    EXPECT_TRUE(eng.calendar_valid());
  }
}

TEST(EdmdEngine, WhiteNoiseConservesMomentum) {
  Config c = config_from(
      "[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.5\n"
      "[restitution]\nlaw = \"bizon\"\ne = 0.7\ncrossover = 1.0\n"
      "[heating]\nmodel = \"white_noise\"\nkick = 0.5\n");
  const auto init = make_initial_state(c, 3);
  Engine eng(make_setup(c, 3), init.positions, init.velocities);
  eng.synchronize();
  const Vec3 p0 = eng.momentum();
  const BizonRestitution law{0.7, 1.0};
  eng.advance(law, kInf, 100000);
  eng.synchronize();
  EXPECT_GT(eng.counters().heating_energy, 0.0);
  EXPECT_GT(eng.counters().energy_lost, 0.0);
  EXPECT_NEAR(norm(eng.momentum() - p0), 0.0, 1e-10);
  EXPECT_GE(eng.min_distance(), 1.0 - 1e-9);
}

TEST(EdmdEngine, HardWallsKeepGrainsInside) {
  Config c = config_from(
      "[edmd]\ndimensions = 3\nparticles = 512\npacking_fraction = 0.3\n[walls]\ndirections = [\"z\"]\n");
  const auto init = make_initial_state(c, 5);
  Engine eng(make_setup(c, 5), init.positions, init.velocities);
  eng.synchronize();
  const double e0 = eng.kinetic_energy();
  eng.advance(ElasticRestitution{}, kInf, 50000);
  eng.synchronize();
  EXPECT_GT(eng.counters().wall_collisions, 0u);
  EXPECT_NEAR(eng.kinetic_energy() / e0 - 1.0, 0.0, 1e-12);
  for (std::size_t i = 0; i < eng.size(); ++i) {
    EXPECT_GE(eng.position(i).z, 0.5 - 1e-9);
    EXPECT_LE(eng.position(i).z, eng.length().z - 0.5 + 1e-9);
  }
  EXPECT_GE(eng.min_distance(), 1.0 - 1e-9);
}

TEST(EdmdEngine, SameSeedSameTrajectoryAndRebuildIsHarmless) {
  Config c = config_from("[edmd]\ndimensions = 3\nparticles = 343\npacking_fraction = 0.3\n");
  const auto init = make_initial_state(c, 11);
  Engine a(make_setup(c, 11), init.positions, init.velocities);
  Engine b(make_setup(c, 11), init.positions, init.velocities);
  a.advance(ElasticRestitution{}, kInf, 20000);
  b.advance(ElasticRestitution{}, kInf, 20000);
  a.synchronize();
  b.synchronize();
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a.position(i).x, b.position(i).x);
    EXPECT_EQ(a.velocity(i).y, b.velocity(i).y);
  }
  b.rebuild();
  b.advance(ElasticRestitution{}, kInf, 40000);
  b.synchronize();
  EXPECT_GE(b.min_distance(), 1.0 - 1e-9);
}

TEST(EdmdEngine, BadInputGivesClearErrors) {
  Config c = config_from("[edmd]\ndimensions = 2\nparticles = 100\npacking_fraction = 0.3\n");
  auto init = make_initial_state(c, 1);
  auto overlapping = init;
  overlapping.positions[1] = overlapping.positions[0];
  overlapping.positions[1].x += 0.5;
  EXPECT_THROW(Engine(make_setup(c, 1), overlapping.positions, overlapping.velocities), std::invalid_argument);
  auto outside = init;
  outside.positions[3].x = -1.0;
  EXPECT_THROW(Engine(make_setup(c, 1), outside.positions, outside.velocities), std::invalid_argument);
  // above close packing, and walls that cut a 2D box
  EXPECT_THROW(config_from("[edmd]\ndimensions = 2\nparticles = 100\npacking_fraction = 0.95\n"), CaseError);
  EXPECT_THROW(config_from("[edmd]\ndimensions = 3\nparticles = 100\npacking_fraction = 0.8\n"), CaseError);
  EXPECT_THROW(config_from("[edmd]\ndimensions = 2\nparticles = 100\npacking_fraction = 0.3\n[walls]\ndirections = [\"z\"]\n"),
               CaseError);
  EXPECT_THROW(config_from("[edmd]\ndimensions = 2\nparticles = 100\npacking_fraction = 0.3\n[walls]\ndirections = [\"q\"]\n"),
               CaseError);
  EXPECT_THROW(config_from("[edmd]\ndimensions = 3\nparticles = 100\npacking_fraction = 0.3\nunknown_key = 1\n"), CaseError);
}

TEST(EdmdEngine, AirTableQuarticPredictionsKeepGrainsApart) {
  Config c = config_from(
      "[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.5\n"
      "[restitution]\nlaw = \"bizon\"\ne = 0.7\ncrossover = 1.0\n"
      "[heating]\nmodel = \"air_table\"\nacceleration = 4.0\n");
  const auto init = make_initial_state(c, 9);
  Engine eng(make_setup(c, 9), init.positions, init.velocities);
  eng.synchronize();
  const Vec3 p0 = eng.momentum();
  eng.advance(BizonRestitution{0.7, 1.0}, kInf, 30000);
  eng.synchronize();
  EXPECT_GE(eng.min_distance(), 1.0 - 1e-9);
  // opposite accelerations of paired grains: total momentum conserved by the driving too
  EXPECT_NEAR(norm(eng.momentum() - p0), 0.0, 1e-8);
  const double T = eng.kinetic_energy() / eng.size();
  EXPECT_GT(T, 0.3);
  EXPECT_LT(T, 3.0);
}

TEST(EdmdEngine, ConstantRestitutionWithGuardDoesNotCollapse) {
  // e = 0.5 free cooling of a dense disk gas: without the TC guard such runs stall in
  // inelastic collapse; with it the collision count is reached in finite simulated time.
  Config c = config_from(
      "[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.6\n"
      "[restitution]\nlaw = \"constant\"\ne = 0.5\n");
  EXPECT_GT(c.contact_time, 0.0);
  const auto init = make_initial_state(c, 4);
  Engine eng(make_setup(c, 4), init.positions, init.velocities);
  eng.advance(ConstantRestitution{0.5}, kInf, 200000);
  eng.synchronize();
  EXPECT_EQ(eng.counters().collisions, 200000u);
  EXPECT_GE(eng.min_distance(), 1.0 - 1e-9);
  EXPECT_TRUE(std::isfinite(eng.time()));
}

TEST(EdmdEngine, SplittingAdvanceCallsIsBitwiseNeutral) {
  // Automatic rebuilds are keyed on the collision count, heating draws on the collision
  // number, medium draws on (id, event counter): how a run is cut into advance() calls
  // must not change a single bit (the property exact restart, issue #8, builds on).
  Config c = config_from(
      "[edmd]\ndimensions = 3\nparticles = 512\npacking_fraction = 0.3\n"
      "[restitution]\nlaw = \"bizon\"\ne = 0.7\n"
      "[heating]\nmodel = \"white_noise\"\nkick = 0.3\n"
      "[background]\ndensity = 0.2\n");
  const auto init = make_initial_state(c, 13);
  const BizonRestitution law{0.7, 1.0};
  Engine a(make_setup(c, 13), init.positions, init.velocities);
  Engine b(make_setup(c, 13), init.positions, init.velocities);
  a.advance(law, kInf, 30000);
  for (std::uint64_t k = 1; k <= 30; ++k) b.advance(law, kInf, 1000 * k);
  EXPECT_GT(a.rebuilds(), 3u);
  EXPECT_EQ(a.rebuilds(), b.rebuilds());
  EXPECT_EQ(a.time(), b.time());
  a.synchronize();
  b.synchronize();
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a.position(i).x, b.position(i).x) << i;
    ASSERT_EQ(a.velocity(i).z, b.velocity(i).z) << i;
    ASSERT_EQ(a.event_counter(i), b.event_counter(i)) << i;
  }
  EXPECT_GT(a.counters().background_collisions, 0u);
}

TEST(EdmdCalendar, CalendarQueueAndHeapGiveTheSameOrder) {
  // Random schedule/pop sequence with ties, +inf entries and far-future (overflow) times:
  // the calendar queue must pop exactly what the heap pops.
  const std::uint32_t n = 500;
  for (const bool defer : {false, true}) {  // linking at once, and late (EventCalendar::update)
    EventHeap heap;
    EventCalendar cal;
    heap.reset(n);
    cal.reset(n, 0.0, 0.01, defer);
    CounterRng rng(5, Stream::edmd_collisions, 0, 0);
    double now = 0.0;
    for (std::uint32_t i = 0; i < n; ++i) {
      const double t = rng.uniform() < 0.05 ? kInf : now + rng.exponential();
      heap.update(i, t);
      cal.update(i, t);
    }
    for (int step = 0; step < 20000; ++step) {
      ASSERT_EQ(heap.top(), cal.top()) << step;
      ASSERT_EQ(heap.top_key(), cal.top_key()) << step;
      const std::uint32_t i = heap.top();
      now = heap.top_key();
      if (!std::isfinite(now)) break;
      const double u = rng.uniform();
      double t = u < 0.1 ? now : u < 0.15 ? kInf : u < 0.2 ? now + 100.0 * rng.exponential() : now + rng.exponential();
      if (u > 0.95) t = std::floor(t * 4.0) / 4.0;  // exact ties
      heap.update(i, t);
      cal.update(i, t);
      const std::uint32_t k = static_cast<std::uint32_t>(rng.uniform() * n);  // an unrelated re-schedule
      const double tk = now + rng.exponential();
      heap.update(k, tk);
      cal.update(k, tk);
    }
    EXPECT_TRUE(heap.valid());
    EXPECT_TRUE(cal.valid());
  }
}

TEST(EdmdCalendar, WaitingEntriesKeepTheHeapOrder) {
  // EventCalendar::update links an entry only a few updates later. With fewer entries than
  // the calendar keeps waiting, every entry can be waiting at once (no entry in any bucket):
  // top() must still find the (time, index) minimum, through ties, +inf and times beyond
  // the window (re-base), exactly as the heap does.
  for (const std::uint32_t n : {2u, 3u, 4u, 5u, 9u}) {
    EventHeap heap;
    EventCalendar cal;
    heap.reset(n);
    cal.reset(n, 0.0, 0.5, true);
    CounterRng rng(11, Stream::edmd_collisions, n, 0);
    for (std::uint32_t i = 0; i < n; ++i) {
      const double t = rng.exponential();
      heap.update(i, t);
      cal.update(i, t);
    }
    for (int step = 0; step < 5000; ++step) {
      ASSERT_EQ(heap.top(), cal.top()) << n << " " << step;
      ASSERT_EQ(heap.top_key(), cal.top_key()) << n << " " << step;
      const std::uint32_t i = heap.top();
      const double now = heap.top_key();
      if (!std::isfinite(now)) break;
      const double u = rng.uniform();
      // the same time as now (a tie with the next entries), far beyond the window, or near
      double t = u < 0.2 ? now : u < 0.3 ? now + 1000.0 * rng.exponential() : now + rng.exponential();
      if (u > 0.9) t = std::floor(t);  // exact ties between entries
      if (t < now) t = now;
      heap.update(i, t);
      cal.update(i, t);
      ASSERT_TRUE(cal.valid()) << n << " " << step;
    }
  }
}

TEST(EdmdEngine, AirTableEnergyBudgetCloses) {
  // kinetic-energy change = work of the accelerations - inelastic loss
  Config c = config_from(
      "[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.4\n"
      "[restitution]\nlaw = \"bizon\"\ne = 0.7\ncrossover = 1.0\n"
      "[heating]\nmodel = \"air_table\"\nacceleration = 4.0\n");
  const auto init = make_initial_state(c, 2);
  Engine eng(make_setup(c, 2), init.positions, init.velocities);
  eng.synchronize();
  const double e0 = eng.kinetic_energy();
  eng.advance(BizonRestitution{0.7, 1.0}, kInf, 20000);
  eng.synchronize();
  const auto& k = eng.counters();
  EXPECT_GT(k.heating_energy, 0.0);
  EXPECT_NEAR(eng.kinetic_energy() - e0, k.heating_energy - k.energy_lost, 1e-8 * (k.heating_energy + e0));
}

// Added by the mutation audit of first_contact_time (docs/reviews/mutation-audit-pair-time.md).
// A contact the air table's prediction loses does not show at the end of a run: the pair
// passes through itself until an event of one of the grains rescans it, and the shortcut for
// touching and approaching pairs (contact time 0) then collides it out of the overlap. So the
// distance is checked all along the run, every 25 collisions (splitting advance() changes
// nothing), in the driving of the Bizon cases: dense 2D, 3D with a0 = 30, dilute 2D with the
// tent profile (relative accelerations near zero where the tent vanishes).
TEST(EdmdEngine, AirTableGrainsStayApartThroughoutTheRun) {
  const char* cases[] = {
      "[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.5\n[restitution]\nlaw = \"bizon\"\ne = 0.7\n"
      "crossover = 1.0\n[heating]\nmodel = \"air_table\"\nacceleration = 4.0\n",
      "[edmd]\ndimensions = 3\nparticles = 500\npacking_fraction = 0.3\n[restitution]\nlaw = \"bizon\"\ne = 0.7\n"
      "crossover = 1.0\n[heating]\nmodel = \"air_table\"\nacceleration = 30.0\n",
      "[edmd]\ndimensions = 2\nparticles = 400\npacking_fraction = 0.1\n[restitution]\nlaw = \"bizon\"\ne = 0.7\n"
      "crossover = 1.0\n[heating]\nmodel = \"air_table\"\nacceleration = 1.0\nprofile = \"tent\"\n"};
  for (const char* text : cases) {
    Config c = config_from(text);
    const auto init = make_initial_state(c, 5);
    Engine eng(make_setup(c, 5), init.positions, init.velocities);
    double closest = kInf;
    for (std::uint64_t k = 1; k <= 1600; ++k) {
      eng.advance(BizonRestitution{0.7, 1.0}, kInf, 25 * k);
      eng.synchronize();
      closest = std::min(closest, eng.min_distance());
    }
    EXPECT_EQ(eng.counters().collisions, 40000u);
    EXPECT_GE(closest, 1.0 - 1e-9) << text;
  }
}

// The event loop's shortcuts (delayed states, layer-only rescans after a cell crossing, the
// second candidate promoted when the first partner is stale, the shared scan of a colliding
// pair) must not lose or invent a collision: the engine's sequence of colliding pairs and
// times equals that of an all-pairs reference which advances every grain at every
// collision and re-predicts every pair (O(N^2) per collision), up to round-off.
namespace {
struct SeenCollision {
  double t;
  std::uint32_t a, b;
};
struct Recorder {
  const Engine* eng = nullptr;
  std::vector<SeenCollision> seen;
};
void record_collision(void* ctx, const CollisionRecord& r) {
  auto* rec = static_cast<Recorder*>(ctx);
  rec->seen.push_back({rec->eng->time(), std::min(r.id_i, r.id_j), std::max(r.id_i, r.id_j)});
}
// Elastic hard spheres / disks in a periodic box, all pairs, minimum image (L > 2 sigma).
std::vector<SeenCollision> brute_force_collisions(std::vector<Vec3> r, std::vector<Vec3> v, const Vec3& L, int dims,
                                                  double now, std::size_t count) {
  const std::size_t n = r.size();
  auto image = [&](Vec3 d) {
    for (int k = 0; k < dims; ++k) {
      double& x = k == 0 ? d.x : k == 1 ? d.y : d.z;
      const double l = k == 0 ? L.x : k == 1 ? L.y : L.z;
      x -= l * std::round(x / l);
    }
    return d;
  };
  std::vector<SeenCollision> out;
  while (out.size() < count) {
    double best = kInf;
    std::size_t bi = 0, bj = 0;
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = i + 1; j < n; ++j) {
        const Vec3 dr = image(r[j] - r[i]), dv = v[j] - v[i];
        const double b = dot(dr, dv);
        if (b >= 0.0) continue;
        const double q2 = dot(dr, dr) - 1.0, disc = b * b - dot(dv, dv) * q2;
        if (disc <= 0.0) continue;
        const double dt = q2 <= 0.0 ? 0.0 : q2 / (-b + std::sqrt(disc));
        if (dt < best) best = dt, bi = i, bj = j;
      }
    for (std::size_t i = 0; i < n; ++i) r[i] += best * v[i];
    now += best;
    const Vec3 dr = image(r[bj] - r[bi]);
    inelastic_collision(v[bi], v[bj], (1.0 / norm(dr)) * dr, 1.0, 1.0);
    out.push_back({now, static_cast<std::uint32_t>(bi), static_cast<std::uint32_t>(bj)});
  }
  return out;
}
}  // namespace

TEST(EdmdEngine, CollisionSequenceMatchesAllPairsReference) {
  // Chaos amplifies round-off by about an order of magnitude per ten collisions per grain,
  // so the reference restarts from the engine's synchronised state every `chunk` collisions.
  for (int dims : {2, 3}) {
    Config c = config_from("[edmd]\ndimensions = " + std::to_string(dims) + "\nparticles = " +
                           (dims == 2 ? "144" : "125") + "\npacking_fraction = " + (dims == 2 ? "0.6" : "0.4") + "\n");
    const auto init = make_initial_state(c, 11);
    Engine eng(make_setup(c, 11), init.positions, init.velocities);
    Recorder rec;
    rec.eng = &eng;
    eng.set_collision_hook(record_collision, &rec);
    const std::size_t chunk = 400, chunks = 20;  // 8000 collisions, ~60 per grain, 6 rebuilds
    for (std::size_t m = 0; m < chunks; ++m) {
      eng.synchronize();
      std::vector<Vec3> r(eng.size()), v(eng.size());
      for (std::size_t id = 0; id < eng.size(); ++id) r[id] = eng.position(id), v[id] = eng.velocity(id);
      const auto ref = brute_force_collisions(r, v, eng.length(), dims, eng.time(), chunk);
      eng.advance(ElasticRestitution{}, kInf, (m + 1) * chunk);
      ASSERT_EQ(rec.seen.size(), (m + 1) * chunk);
      for (std::size_t k = 0; k < chunk; ++k) {
        const SeenCollision& got = rec.seen[m * chunk + k];
        ASSERT_EQ(got.a, ref[k].a) << "dims " << dims << ", collision " << m * chunk + k;
        ASSERT_EQ(got.b, ref[k].b) << "dims " << dims << ", collision " << m * chunk + k;
        ASSERT_NEAR(got.t, ref[k].t, 1e-9 * (1.0 + ref[k].t)) << "dims " << dims << ", collision " << m * chunk + k;
      }
    }
    EXPECT_GT(eng.counters().stale, chunk * chunks / 20) << "the stale-event path must be exercised";
    EXPECT_GT(eng.counters().cell_crossings, chunk * chunks / 20);
  }
}

// PairStatistics::add finds the pairs through a cell grid (half shell, images implied by the
// cell offsets, cells of rmax/2): it must count exactly the pairs the
// direct O(N^2) sum with explicit nearest images counts, bin by bin, and give the same
// correlation sums up to round-off (the summation order differs). Periodic and walled boxes,
// 2D and 3D, a box too small for the grid, positions slightly outside the box included; the
// same sums at 1 and 2 threads, and with the AVX2 and the scalar pair loop.
TEST(EdmdMeasure, PairStatisticsCellSearchEqualsDirectSum) {
  struct Box {
    int dims;
    Vec3 L;
    std::array<bool, 3> walls;
    double rmax;
  };
  const Box boxes[] = {
      {2, {26.0, 23.0, 0.0}, {false, false, false}, 5.0},  // 10 x 9 cells of rmax/2
      {2, {16.0, 12.4, 0.0}, {false, false, false}, 5.0},  // 4 cells of rmax/2 in y: the direct sum
      {2, {26.0, 23.0, 0.0}, {true, false, false}, 5.0},   // a walled x
      {3, {13.0, 14.0, 16.0}, {false, false, false}, 2.5},
      {3, {13.0, 14.0, 16.0}, {false, false, true}, 2.5},
  };
  CounterRng rng(11, Stream::edmd_collisions, 0, 0);
  for (const Box& box : boxes) {
    const std::size_t n = box.dims == 2 ? 600 : 900;
    std::vector<Vec3> x(n), v(n);
    for (std::size_t i = 0; i < n; ++i) {
      // uniform in the box, one in ten slightly outside a periodic face (not yet wrapped)
      const double out = rng.uniform() < 0.1 ? 1e-9 : 0.0;
      x[i] = {rng.uniform() * box.L.x - (box.walls[0] ? 0.0 : out), rng.uniform() * box.L.y + (box.walls[1] ? 0.0 : out),
              box.dims == 3 ? rng.uniform() * box.L.z : 0.0};
      v[i] = {rng.normal(), rng.normal(), box.dims == 3 ? rng.normal() : 0.0};
    }
    PairStatistics cells, direct, cells2;
    cells.init(box.dims, box.L, box.walls, box.rmax, 0.05, 0.25);
    cells2.init(box.dims, box.L, box.walls, box.rmax, 0.05, 0.25);
    direct.init(box.dims, box.L, box.walls, box.rmax, 0.05, 0.25);
#ifdef _OPENMP
    const int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    cells.add(x, v, 1.0);
    omp_set_num_threads(2);
    cells2.add(x, v, 1.0);
    omp_set_num_threads(threads);
#else
    cells.add(x, v, 1.0);
    cells2.add(x, v, 1.0);
#endif
    // the cell search's sums do not depend on the thread count (fixed chunks of rows)
    EXPECT_EQ(cells.gr_counts, cells2.gr_counts);
    EXPECT_EQ(cells.corr_par, cells2.corr_par);
    EXPECT_EQ(cells.corr_perp, cells2.corr_perp);
    EXPECT_EQ(cells.corr_counts, cells2.corr_counts);
    // nor on the kernel: the AVX2 lanes (where the CPU has them) give the one-pair loop's bits
    PairStatistics scalar;
    scalar.init(box.dims, box.L, box.walls, box.rmax, 0.05, 0.25);
    scalar.add(x, v, 1.0, PairStatistics::PairKernel::scalar);
    EXPECT_EQ(cells.gr_counts, scalar.gr_counts);
    EXPECT_EQ(cells.corr_par, scalar.corr_par);
    EXPECT_EQ(cells.corr_perp, scalar.corr_perp);
    EXPECT_EQ(cells.corr_counts, scalar.corr_counts);
    direct.add_all_pairs(x, v);
    double pairs = 0.0;
    for (std::size_t b = 0; b < direct.gr_counts.size(); ++b) {
      ASSERT_EQ(cells.gr_counts[b], direct.gr_counts[b]) << "box " << (&box - boxes) << " g(r) bin " << b;
      pairs += direct.gr_counts[b];
    }
    // about n(n-1)/2 x (ball / box volume) pairs in range (fewer near walls)
    const double ball = box.dims == 2 ? std::numbers::pi * box.rmax * box.rmax : 4.0 / 3.0 * std::numbers::pi * std::pow(box.rmax, 3);
    const double volume = box.dims == 2 ? box.L.x * box.L.y : box.L.x * box.L.y * box.L.z;
    EXPECT_GT(pairs, 0.5 * 0.5 * n * (n - 1.0) * ball / volume);
    for (std::size_t c = 0; c < direct.corr_counts.size(); ++c) {
      ASSERT_EQ(cells.corr_counts[c], direct.corr_counts[c]) << "box " << (&box - boxes) << " bin " << c;
      const double scale = 1e-12 * (1.0 + direct.corr_counts[c]);
      EXPECT_NEAR(cells.corr_par[c], direct.corr_par[c], scale) << c;
      EXPECT_NEAR(cells.corr_perp[c], direct.corr_perp[c], scale) << c;
    }
  }
}

// The restitution of every grain collision is the law's value at the pair's normal approach
// speed g_n = (v_i - v_j).n (Bisi-Spiga eq. 5, Bizon eq. 18), read back from each collision's
// record alone, without the engine's restitution code: for smooth grains of unit mass the
// impulse on j is J n with J = (1 + e) g_n / 2 and the pair loses (1 - e^2) g_n^2 / 4, so
// loss / J^2 = (1 - e) / (1 + e), e = (J^2 - loss) / (J^2 + loss) and g_n = 2 J / (1 + e).
// The laws are typed here from the papers. Restitution taken at |g| instead of g_n (an
// easy slip: both are "the impact speed") gives e too small at every oblique collision.
namespace {
struct RestitutionReadBack {
  double (*law)(double vn) = nullptr;
  std::size_t seen = 0, informative = 0;
  double max_error = 0.0, min_e = 1.0, max_gn = 0.0;
  static void hook(void* self, const CollisionRecord& c) {
    auto* t = static_cast<RestitutionReadBack*>(self);
    ++t->seen;
    const Vec3 n = (1.0 / norm(c.rij)) * c.rij;
    const double J = dot(c.impulse, n), J2 = J * J, loss = -(c.dEi + c.dEj);
    if (J2 < 1e-8) return;  // grazing: e not resolved by the energies' round-off
    ++t->informative;
    const double e = (J2 - loss) / (J2 + loss), gn = 2.0 * J / (1.0 + e);
    t->max_error = std::max(t->max_error, std::abs(e - t->law(gn)));
    t->min_e = std::min(t->min_e, e);
    t->max_gn = std::max(t->max_gn, gn);
  }
};
// Bizon et al. eq. 18 with e_c = 0.7, v0 = 2: e = 1 - (1 - e_c)(v_n / v0)^(3/4) below v0, e_c above
double bizon_07_2(double vn) { return vn >= 2.0 ? 0.7 : 1.0 - 0.3 * std::pow(vn / 2.0, 0.75); }
// Bisi-Spiga eq. 5 with beta = 0.15, delta = 1/5: 1 - e = 2 beta v_n^delta (clamped at 0)
double power_015_02(double vn) { return std::max(0.0, 1.0 - 0.3 * std::pow(vn, 0.2)); }
}  // namespace

TEST(EdmdEngine, RestitutionIsTheLawAtTheNormalApproachSpeed) {
  struct Run {
    int dims;
    const char* law_toml;
    double (*law)(double);
  };
  for (const Run& run : {Run{3, "law = \"bizon\"\ne = 0.7\ncrossover = 2.0\n", bizon_07_2},
                         Run{2, "law = \"power\"\nbeta = 0.15\ndelta = 0.2\n", power_015_02}}) {
    SCOPED_TRACE(run.dims);
    Config c = config_from("[edmd]\ndimensions = " + std::to_string(run.dims) +
                           "\nparticles = 400\npacking_fraction = 0.2\ntemperature = 2.0\ncontact_time = 0\n"
                           "[restitution]\n" + run.law_toml);
    const auto init = make_initial_state(c, 9);
    Engine eng(make_setup(c, 9), init.positions, init.velocities);
    RestitutionReadBack rb;
    rb.law = run.law;
    eng.set_collision_hook(&RestitutionReadBack::hook, &rb);
    std::visit([&](const auto& law) { eng.advance(law, kInf, 20000); }, c.restitution);
    std::printf("dims %d: %zu collisions, %zu read back, e >= %.3f, g_n <= %.2f, max |e - law(g_n)| = %.1e\n", run.dims,
                rb.seen, rb.informative, rb.min_e, rb.max_gn, rb.max_error);
    EXPECT_EQ(rb.seen, 20000u);
    EXPECT_GT(rb.informative, 19000u);
    EXPECT_LT(rb.min_e, 0.8);  // the laws are exercised well away from e = 1
    EXPECT_LT(rb.max_error, 1e-9);
  }
}
