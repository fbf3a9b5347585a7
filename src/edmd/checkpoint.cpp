#include "edmd/checkpoint.hpp"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "core/checkpoint.hpp"

namespace grainbath::edmd {

namespace fs = std::filesystem;

namespace {

// Guards against silently unsaved state: a member added to one of these structs changes
// its size, and this fails to compile until the member is packed below and the size here
// updated (x86-64 sizes).
static_assert(sizeof(Counters) == 9 * 8 + 10 * 8 + 2 * 8 + 2 * 8 + 2 * 8 + sizeof(std::vector<std::uint64_t>),
              "Counters changed: save the new member in the checkpoint (pack/unpack below)");
static_assert(sizeof(EngineState) == 7 * sizeof(std::vector<double>) + 3 * 8 + 5 * 8 + sizeof(Counters),
              "EngineState changed: save the new member in the checkpoint (arrays_of below)");
static_assert(sizeof(VelocityHistogram) == 8 + 8 + 3 * sizeof(std::vector<double>) + 4 * 8,
              "VelocityHistogram changed: save the new member in the checkpoint (arrays_of below)");
static_assert(sizeof(ProfileAccumulators) == 8 + 8 + sizeof(std::vector<ProfileBlock>) + sizeof(ProfileBlock) + 8,
              "ProfileAccumulators changed: save the new member in the checkpoint (arrays_of below)");
static_assert(sizeof(ProfileBlock) == 8 + 8 + 2 * sizeof(std::vector<double>),
              "ProfileBlock changed: save the new member in the checkpoint (stage/unstage below)");
static_assert(sizeof(SlabVelocityHistograms) == 3 * 4 + 4 + 8 + 3 * sizeof(std::vector<double>),
              "SlabVelocityHistograms changed: save the new member in the checkpoint (arrays_of below)");
static_assert(sizeof(PairStatistics) == 8 + sizeof(Vec3) + 8 + 3 * 8 + 4 * sizeof(std::vector<double>) + 3 * 8,
              "PairStatistics changed: save the new member in the checkpoint (arrays_of below)");

struct PackedCounters {
  std::vector<double> real;
  std::vector<std::uint64_t> integer;
};

// Test hook (tests/edmd/restart_test.cpp, EdmdRestart.OldCounterLayout*): with the
// environment variable GRAINBATH_TEST_OLD_EDMD_COUNTERS=1 the counters are written in the
// layout of before 2026-12-05 (12 reals, no static-wall loss), so that reading such files,
// which unpack() still accepts, stays tested. Read at every write (checkpoints are rare).
bool write_old_counter_layout() {
  const char* v = std::getenv("GRAINBATH_TEST_OLD_EDMD_COUNTERS");
  return v && std::strcmp(v, "1") == 0;
}

PackedCounters pack(const Counters& c) {
  PackedCounters p{{c.virial, c.energy_lost, c.heating_energy, c.background_energy, c.wall_virial, c.sum_vn, c.sum_vn2,
                    c.sum_e, c.wall_energy[0], c.wall_energy[1], c.wall_momentum[0], c.wall_momentum[1],
                    c.wall_energy_lost, c.guard_receding},
                   {c.collisions, c.events, c.stale, c.cell_crossings, c.wall_collisions, c.background_candidates,
                    c.background_collisions, c.guard_elastic, c.clamped, c.wall_hits[0], c.wall_hits[1]}};
  if (write_old_counter_layout()) p.real.resize(12);  // without the wall loss (13th) and guard_receding (14th)
  return p;
}

void unpack(const PackedCounters& p, Counters& c) {
  // 12 reals: written before static-wall losses had their own counter (they were added to
  // energy_lost). Their wall loss is unknown (NaN): Engine::restore refuses such a checkpoint
  // if the case has lossy static walls and otherwise sets it to 0, the value it had.
  // 12 or 13 reals: written before guard_receding (2026-12-06). It is 0 if the TC guard had not
  // acted, else unknown: NaN, so g_r.contact_from_collisions is null for such a run.
  if ((p.real.size() < 12 || p.real.size() > 14) || p.integer.size() != 11)
    throw std::runtime_error("wrong counter layout");
  c.virial = p.real[0];
  c.energy_lost = p.real[1];
  c.heating_energy = p.real[2];
  c.background_energy = p.real[3];
  c.wall_virial = p.real[4];
  c.sum_vn = p.real[5];
  c.sum_vn2 = p.real[6];
  c.sum_e = p.real[7];
  c.collisions = p.integer[0];
  c.events = p.integer[1];
  c.stale = p.integer[2];
  c.cell_crossings = p.integer[3];
  c.wall_collisions = p.integer[4];
  c.background_candidates = p.integer[5];
  c.background_collisions = p.integer[6];
  c.guard_elastic = p.integer[7];
  c.clamped = p.integer[8];
  c.wall_energy = {p.real[8], p.real[9]};
  c.wall_momentum = {p.real[10], p.real[11]};
  c.wall_energy_lost = p.real.size() > 12 ? p.real[12] : std::numeric_limits<double>::quiet_NaN();
  c.guard_receding = p.real.size() > 13 ? p.real[13]
                     : c.guard_elastic == 0 ? 0.0
                                            : std::numeric_limits<double>::quiet_NaN();
  c.wall_hits = {p.integer[9], p.integer[10]};
}

std::vector<double> flatten(const std::vector<Vec3>& v) {
  std::vector<double> out;
  out.reserve(3 * v.size());
  for (const Vec3& x : v) out.insert(out.end(), {x.x, x.y, x.z});
  return out;
}

std::vector<Vec3> unflatten(const std::vector<double>& f) {
  if (f.size() % 3) throw std::runtime_error("vector array of odd length");
  std::vector<Vec3> out(f.size() / 3);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = {f[3 * i], f[3 * i + 1], f[3 * i + 2]};
  return out;
}

template <class To, class From>
std::vector<To> convert(const std::vector<From>& v) {
  return std::vector<To>(v.begin(), v.end());
}

// Everything in the file, as arrays: engine and run state are copied in (write) or out
// (read) of this staging record, so one list (arrays_of) drives writing, reading and the
// checksum.
struct Staging {
  std::vector<double> positions, velocities, omega, accelerations, last_collision, engine_real;
  std::vector<std::uint64_t> counters, pairs, engine_int;
  PackedCounters engine_c, eq_c, prev_c;
  std::vector<std::uint64_t> engine_hist, eq_hist, prev_hist;
  std::vector<double> run_real;
  std::vector<std::uint64_t> run_int, traj_step;
  std::vector<double> vhist_real, pairs_real;
  std::vector<std::uint64_t> pairs_int;
  // slab profiles: blocks as [snapshots, time, kin..., coll...] rows, the open block alike
  std::vector<double> profile_blocks, profile_open, profile_real;
  std::vector<std::uint64_t> profile_int;
  TransportCheckpoint transport;  // only with [transport]
};

CheckpointArrays arrays_of(Staging& g, RunState& r) {
  CheckpointArrays a;
  a.add("engine/positions", g.positions);
  a.add("engine/velocities", g.velocities);
  a.add("engine/angular_velocities", g.omega);
  a.add("engine/accelerations", g.accelerations);
  a.add("engine/last_collision", g.last_collision);
  a.add("engine/scalars_real", g.engine_real);
  a.add("engine/event_counters", g.counters);
  a.add("engine/air_table_pairs", g.pairs);
  a.add("engine/scalars_integer", g.engine_int);
  a.add("counters/engine/real", g.engine_c.real);
  a.add("counters/engine/integer", g.engine_c.integer);
  a.add("counters/engine/vn_histogram", g.engine_hist);
  a.add("counters/equilibration/real", g.eq_c.real);
  a.add("counters/equilibration/integer", g.eq_c.integer);
  a.add("counters/equilibration/vn_histogram", g.eq_hist);
  a.add("counters/previous_sample/real", g.prev_c.real);
  a.add("counters/previous_sample/integer", g.prev_c.integer);
  a.add("counters/previous_sample/vn_histogram", g.prev_hist);
  a.add("run/scalars_real", g.run_real);
  a.add("run/scalars_integer", g.run_int);
  Series& s = r.series;
  a.add("series/time", s.time);
  a.add("series/temperature", s.temperature);
  a.add("series/Z", s.z);
  a.add("series/energy_lost", s.energy_lost);
  a.add("series/heating", s.heating);
  a.add("series/background", s.background);
  a.add("series/collisions", s.collisions);
  a.add("series/rotational_temperature", s.rotational_temperature);
  a.add("trajectory/position", r.traj_pos);
  a.add("trajectory/time", r.traj_time);
  a.add("trajectory/step", g.traj_step);
  a.add("pairs/gr_counts", r.pairs.gr_counts);
  a.add("pairs/corr_par", r.pairs.corr_par);
  a.add("pairs/corr_perp", r.pairs.corr_perp);
  a.add("pairs/corr_counts", r.pairs.corr_counts);
  a.add("pairs/scalars_real", g.pairs_real);
  a.add("pairs/scalars_integer", g.pairs_int);
  a.add("velocity_histogram/x", r.vhist.counts[0]);
  a.add("velocity_histogram/y", r.vhist.counts[1]);
  a.add("velocity_histogram/z", r.vhist.counts[2]);
  a.add("velocity_histogram/scalars_real", g.vhist_real);
  a.add("series/wall_input", r.wall_in_series);
  a.add("series/wall_loss", r.loss_series);
  a.add("profiles/blocks", g.profile_blocks);
  a.add("profiles/open_block", g.profile_open);
  a.add("profiles/scalars_real", g.profile_real);
  a.add("profiles/scalars_integer", g.profile_int);
  a.add("profiles/tails/counts", r.tails.counts);
  a.add("profiles/tails/samples", r.tails.samples);
  a.add("profiles/tails/outside", r.tails.outside);
  // [transport] runs only, so that checkpoints of other runs keep their earlier layout
  if (r.transport_on) {
    a.add("transport/stored", g.transport.stored);
    a.add("transport/blocks", g.transport.blocks);
    a.add("transport/open_block", g.transport.open);
    a.add("transport/slab_of_particle", g.transport.slab_of);
    a.add("transport/counts", g.transport.counts);
  }
  return a;
}

Staging stage(const EngineState& e, const RunState& r) {
  Staging g;
  g.positions = flatten(e.positions);
  g.velocities = flatten(e.velocities);
  g.omega = flatten(e.omega);
  g.accelerations = flatten(e.accelerations);
  g.last_collision = e.last_collision;
  g.engine_real = {e.offset, e.calendar_width, e.vn_bin_width};
  g.counters = e.event_counters;
  g.pairs = convert<std::uint64_t>(e.pairs);
  g.engine_int = {e.rebuilds, e.total_collisions, e.next_rebuild, e.rebuild_every, e.cell_capacity};
  g.engine_c = pack(e.counters);
  g.engine_hist = e.counters.vn_histogram;
  g.eq_c = pack(r.c_eq);
  g.eq_hist = r.c_eq.vn_histogram;
  g.prev_c = pack(r.prev);
  g.prev_hist = r.prev.vn_histogram;
  g.run_real = {r.rate_eq, r.t0, r.T0, r.e_initial, r.p_initial.x, r.p_initial.y, r.p_initial.z,
                r.t_prev, r.T_prev, r.engine_seconds};
  g.run_int = {r.phase, r.eq_chunk, static_cast<std::uint64_t>(r.sample_no), r.next_traj};
  g.traj_step = convert<std::uint64_t>(r.traj_step);
  g.pairs_real = {r.pairs.temperature_sum};
  g.pairs_int = {r.pairs.snapshots, static_cast<std::uint64_t>(r.pairs.n)};
  g.vhist_real = {r.vhist.total, r.vhist.c4_sum, r.vhist.c2_sum, r.vhist.samples};
  const ProfileAccumulators& pa = r.profiles.accumulators();
  auto row = [](std::vector<double>& out, const ProfileBlock& b) {
    out.push_back(b.snapshots);
    out.push_back(b.time);
    out.insert(out.end(), b.kin.begin(), b.kin.end());
    out.insert(out.end(), b.coll.begin(), b.coll.end());
  };
  for (const ProfileBlock& b : pa.blocks) row(g.profile_blocks, b);
  row(g.profile_open, pa.open);
  g.profile_real = {r.tails.vmax};
  g.profile_int = {pa.block_intervals, pa.open_intervals, pa.collisions, pa.blocks.size()};
  if (r.transport_on) g.transport = r.transport.save();
  return g;
}

void unstage(const Staging& g, EngineState& e, RunState& r) {
  e.positions = unflatten(g.positions);
  e.velocities = unflatten(g.velocities);
  e.omega = unflatten(g.omega);
  e.accelerations = unflatten(g.accelerations);
  e.last_collision = g.last_collision;
  // engine_real: 2 values in checkpoints written before the normal-speed bins followed the
  // temperature (their width is then the setup's, as when they were written)
  if ((g.engine_real.size() != 2 && g.engine_real.size() != 3) || g.engine_int.size() != 5 || g.run_real.size() != 10 || g.run_int.size() != 4 ||
      g.pairs_real.size() != 1 || g.pairs_int.size() != 2 || g.vhist_real.size() != 4)
    throw std::runtime_error("wrong scalar layout");
  e.offset = g.engine_real[0];
  e.calendar_width = g.engine_real[1];
  e.vn_bin_width = g.engine_real.size() > 2 ? g.engine_real[2] : 0.0;
  e.event_counters = g.counters;
  for (std::uint64_t p : g.pairs)
    if (p > 0xffffffffull) throw std::runtime_error("air-table pair id out of range");
  e.pairs = convert<std::uint32_t>(g.pairs);
  e.rebuilds = g.engine_int[0];
  e.total_collisions = g.engine_int[1];
  e.next_rebuild = g.engine_int[2];
  e.rebuild_every = g.engine_int[3];
  e.cell_capacity = g.engine_int[4];
  unpack(g.engine_c, e.counters);
  e.counters.vn_histogram = g.engine_hist;
  unpack(g.eq_c, r.c_eq);
  r.c_eq.vn_histogram = g.eq_hist;
  unpack(g.prev_c, r.prev);
  r.prev.vn_histogram = g.prev_hist;
  r.rate_eq = g.run_real[0];
  r.t0 = g.run_real[1];
  r.T0 = g.run_real[2];
  r.e_initial = g.run_real[3];
  r.p_initial = {g.run_real[4], g.run_real[5], g.run_real[6]};
  r.t_prev = g.run_real[7];
  r.T_prev = g.run_real[8];
  r.engine_seconds = g.run_real[9];
  r.phase = g.run_int[0];
  r.eq_chunk = g.run_int[1];
  r.sample_no = static_cast<std::int64_t>(g.run_int[2]);
  r.next_traj = g.run_int[3];
  if (r.phase != RunState::equilibrating && r.phase != RunState::measuring) throw std::runtime_error("unknown phase");
  r.traj_step = convert<std::int64_t>(g.traj_step);
  r.pairs.temperature_sum = g.pairs_real[0];
  r.pairs.snapshots = g.pairs_int[0];
  r.pairs.n = static_cast<std::size_t>(g.pairs_int[1]);
  r.vhist.total = g.vhist_real[0];
  r.vhist.c4_sum = g.vhist_real[1];
  r.vhist.c2_sum = g.vhist_real[2];
  r.vhist.samples = g.vhist_real[3];
  // slab profiles: row length from the case's layout (init() ran before the load)
  if (g.profile_real.size() != 1 || g.profile_int.size() != 4) throw std::runtime_error("wrong profile layout");
  r.tails.vmax = g.profile_real[0];
  ProfileAccumulators& pa = r.profiles.accumulators();
  const std::size_t nk = pa.open.kin.size(), nc = pa.open.coll.size(), row = 2 + nk + nc;
  auto unrow = [&](const double* p, ProfileBlock& b) {
    b.snapshots = p[0];
    b.time = p[1];
    b.kin.assign(p + 2, p + 2 + nk);
    b.coll.assign(p + 2 + nk, p + row);
  };
  const std::uint64_t nblocks = g.profile_int[3];
  if (g.profile_open.size() != row || g.profile_blocks.size() != nblocks * row)
    throw std::runtime_error("profile arrays do not match the case's slabs");
  pa.blocks.resize(nblocks);
  for (std::size_t k = 0; k < nblocks; ++k) unrow(g.profile_blocks.data() + k * row, pa.blocks[k]);
  unrow(g.profile_open.data(), pa.open);
  pa.block_intervals = g.profile_int[0];
  pa.open_intervals = g.profile_int[1];
  pa.collisions = g.profile_int[2];
  const bool tails_on = !(r.tails.counts.empty() && r.tails.samples.empty());
  if (tails_on && (r.tails.counts.size() != static_cast<std::size_t>(r.tails.slabs * r.tails.dims * r.tails.bins) ||
                   r.tails.samples.size() != static_cast<std::size_t>(r.tails.slabs)))
    throw std::runtime_error("velocity histograms do not match the case's slabs");
  // the transport sums begin with the measurements: stored contents iff measuring
  if (r.transport_on) r.transport.load(g.transport, r.phase == RunState::measuring);
}

// Keys that may change between the checkpoint and the resumed run: the length of the
// measuring phase (a run can be extended), the checkpoint settings, the thread count.
bool may_change(const std::string& key) {
  return key == "edmd.collisions" || key.rfind("checkpoint.", 0) == 0 || key == "run.threads";
}

}  // namespace

std::vector<std::string> checkpoint_array_names(bool transport) {
  Staging g;
  RunState r;
  r.transport_on = transport;
  std::vector<std::string> names;
  arrays_of(g, r).for_each([&](const std::string& n, const auto&) { names.push_back(n); });
  return names;
}

void write_checkpoint(const fs::path& dir, const Engine& engine, const RunState& run, const RunContext& ctx) {
  const EngineState e = engine.state();
  Staging g = stage(e, run);
  RunState& r = const_cast<RunState&>(run);  // arrays_of needs non-const pointers; nothing is modified
  write_checkpoint_file(dir, e.total_collisions, arrays_of(g, r), ctx, "edmd");
}

bool read_newest_checkpoint(const fs::path& dir, const RunContext& ctx, Engine& engine, RunState& run,
                            std::string& warning, std::string* saved_collisions) {
  const RunState fresh = run;  // bin layouts of the measurements, from the case
  Staging g;
  const fs::path loaded = read_newest_checkpoint_file(
      dir, ctx, "edmd", may_change, "edmd.collisions, run.threads and [checkpoint]",
      [&] {
        g = Staging{};
        run = fresh;
        return arrays_of(g, run);
      },
      [&] {
        EngineState e;
        unstage(g, e, run);
        const PairStatistics& p = fresh.pairs;
        if (run.pairs.gr_counts.size() != p.gr_counts.size() || run.pairs.corr_par.size() != p.corr_par.size() ||
            run.pairs.corr_perp.size() != p.corr_perp.size() || run.pairs.corr_counts.size() != p.corr_counts.size())
          throw std::runtime_error("pair-statistics bins differ from the case");
        for (int d = 0; d < 3; ++d)
          if (run.vhist.counts[d].size() != fresh.vhist.counts[d].size())
            throw std::runtime_error("velocity-histogram bins differ from the case");
        engine.restore(e);  // checks the engine arrays against the case before changing anything
        // a checkpoint from before the wall-loss counter, accepted by restore (no lossy
        // static walls): the run's other counter snapshots had no wall loss either
        for (Counters* c : {&run.c_eq, &run.prev})
          if (std::isnan(c->wall_energy_lost)) c->wall_energy_lost = 0.0;
      },
      warning);
  if (loaded.empty()) {
    run = fresh;
    return false;
  }
  if (saved_collisions) {  // only for the message of collisions before the checkpoint (driver.cpp)
    saved_collisions->clear();
    try {
      *saved_collisions = H5File(loaded.string(), H5File::Mode::read).read_attribute("/parameters", "edmd.collisions");
    } catch (const std::exception&) {
    }
  }
  return true;
}

}  // namespace grainbath::edmd
