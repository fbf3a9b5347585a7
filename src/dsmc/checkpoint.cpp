#include "dsmc/checkpoint.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "core/checkpoint.hpp"
#include "core/run_support.hpp"
#include "dsmc/decomposition.hpp"
#include "dsmc/spatial.hpp"

namespace grainbath::dsmc {

namespace fs = std::filesystem;

namespace {

struct Scalars {  // counters and small values packed into arrays
  std::vector<double> d;
  std::vector<std::uint64_t> u;
};

Scalars pack(const State& s) {
  const RunCounters& c = s.counters;
  Scalars k;
  k.d = {c.bath_energy, c.grain.energy_loss, c.wall_energy, c.removed_energy, s.initial_kinetic_energy};
  k.u = {static_cast<std::uint64_t>(s.step), c.bath_candidates, c.bath_collisions, c.grain.candidates,
         c.grain.collisions, c.grain.clamped, c.grain.bound_exceeded, c.removed,
         static_cast<std::uint64_t>(s.fields.batches), s.fields.cells,
         static_cast<std::uint64_t>(s.fields.window_samples), static_cast<std::uint64_t>(s.fields.taken),
         s.bath_half_pending ? 1u : 0u};
  for (const FieldBatchSegment& g : s.fields.segments)  // 4 integers per segment after the 13
    k.u.insert(k.u.end(), {static_cast<std::uint64_t>(g.first_sample), static_cast<std::uint64_t>(g.end_sample),
                           static_cast<std::uint64_t>(g.first_batch), static_cast<std::uint64_t>(g.batches)});
  return k;
}

void unpack(const Scalars& k, State& s) {
  // 13 integers and 4 per field batch segment; 13 in checkpoints written before the segments
  // (2026-12-05: one segment, the whole window); 12 in those written before the bath halves
  // were joined, which were always written with both halves applied
  if (k.d.size() != 5 || k.u.size() < 12 || (k.u.size() > 13 && (k.u.size() - 13) % 4 != 0))
    throw std::runtime_error("checkpoint: wrong scalar layout");
  RunCounters& c = s.counters;
  c.bath_energy = k.d[0];
  c.grain.energy_loss = k.d[1];
  c.wall_energy = k.d[2];
  c.removed_energy = k.d[3];
  s.initial_kinetic_energy = k.d[4];
  s.step = static_cast<std::int64_t>(k.u[0]);
  c.bath_candidates = k.u[1];
  c.bath_collisions = k.u[2];
  c.grain.candidates = k.u[3];
  c.grain.collisions = k.u[4];
  c.grain.clamped = k.u[5];
  c.grain.bound_exceeded = k.u[6];
  c.removed = k.u[7];
  s.fields.batches = static_cast<int>(k.u[8]);
  s.fields.cells = k.u[9];
  s.fields.window_samples = static_cast<std::int64_t>(k.u[10]);
  s.fields.taken = static_cast<std::int64_t>(k.u[11]);
  s.bath_half_pending = k.u.size() > 12 && k.u[12] != 0;
  FieldAccumulator& f = s.fields;
  f.segments.clear();
  for (std::size_t i = 13; i + 4 <= k.u.size(); i += 4)
    f.segments.push_back({static_cast<std::int64_t>(k.u[i]), static_cast<std::int64_t>(k.u[i + 1]),
                          static_cast<int>(k.u[i + 2]), static_cast<int>(k.u[i + 3])});
  if (k.u.size() <= 13 && f.window_samples > 0) f.segments.push_back({0, f.window_samples, 0, f.batches});
  std::int64_t covered = 0;  // the segments must tile the window: batch_of relies on it
  int batches = 0;
  for (const FieldBatchSegment& g : f.segments) {
    if (g.first_sample != covered || g.end_sample <= g.first_sample || g.first_batch != batches || g.batches < 1)
      throw std::runtime_error("checkpoint: field batch segments do not tile the window");
    covered = g.end_sample;
    batches += g.batches;
  }
  if (!f.segments.empty() && (covered != f.window_samples || batches != f.batches))
    throw std::runtime_error("checkpoint: field batch segments do not tile the window");
}

// The state as named arrays (core/checkpoint.hpp): one list drives writing, reading and
// the checksum.
// p: the grains (s.particles, or this rank's part of them when s holds the rest on rank 0).
CheckpointArrays arrays_of(State& s, Particles& p, Scalars& k, std::vector<std::uint64_t>& batch_samples) {
  TimeSeries& t = s.series;
  CheckpointArrays a;
  a.real = {{"particles/vx", &p.vx},
                 {"particles/vy", &p.vy},
                 {"particles/vz", &p.vz},
                 {"particles/x", &p.x},
                 {"particles/y", &p.y},
                 {"particles/z", &p.z},
                 {"particles/bath_hazard", &p.bath_hazard},
                 {"cells/remainder", &s.remainder},
                 {"series/t", &t.t},
                 {"series/T", &t.T},
                 {"series/a2", &t.a2},
                 {"series/velocity", &t.velocity},
                 {"series/pressure", &t.pressure},
                 {"series/heat_flux", &t.heat_flux},
                 {"series/ke", &t.ke},
                 {"series/bath_in", &t.bath_in},
                 {"series/loss", &t.loss},
                 {"series/wall_in", &t.wall_in},
                 {"series/removed_out", &t.removed_out},
                 {"series/mode_amplitude", &t.mode_amplitude},
                 {"series/count", &t.count},
                 {"fields/sums", &s.fields.sums},
                 {"spins/wx", &s.wx},
                 {"spins/wy", &s.wy},
                 {"spins/wz", &s.wz},
                 {"series/Trot", &t.Trot},
                 {"series/a3", &t.a3},
                 {"scalars/real", &k.d}};
  a.optional = {"series/a3"};  // from 2026-12-06 on (h-cool): earlier checkpoints resume without it
  a.integer = {{"particles/id", &p.id},
               {"series/bath_collisions", &t.bath_collisions},
               {"series/grain_collisions", &t.grain_collisions},
               {"fields/batch_samples", &batch_samples},
               {"scalars/integer", &k.u}};
  return a;
}

// Arrays of one entry per grain, in the global (cell, id) order: spread over the ranks, each
// rank's part after those of the ranks before it. (Spins are per grain too, but only
// homogeneous runs have them, where rank 0 holds every grain: written whole by rank 0.)
bool per_grain(const std::string& name) { return name.rfind("particles/", 0) == 0; }

// Where this rank's part of every per-grain array goes, in list order.
CheckpointSlabs slabs_of(const CheckpointArrays& a, const Decomposition& dec) {
  std::vector<std::string> names;
  std::vector<std::uint64_t> local;
  a.for_each([&](const std::string& n, const auto& v) {
    if (per_grain(n)) names.push_back(n), local.push_back(v.size());
  });
  std::vector<std::uint64_t> offset, total;
  dec.offsets(local, offset, total);
  CheckpointSlabs slabs;
  for (std::size_t i = 0; i < names.size(); ++i) slabs.emplace_back(names[i], CheckpointSlab{total[i], offset[i]});
  return slabs;
}

// The checksum of the whole file (CheckpointArrays::checksum on one process): the arrays in
// list order; the bytes of a per-grain array are added by the ranks in turn (rank order is
// the global order), each going on from the sum of the ranks before. Meaningful on rank 0.
std::uint64_t distributed_checksum(const CheckpointArrays& a, const CheckpointSlabs& slabs, const Decomposition& dec) {
  Fnv1a sum;
  auto add = [&](const std::string& name, const auto& v) {
    const auto slab = std::find_if(slabs.begin(), slabs.end(), [&](const auto& e) { return e.first == name; });
    if (slab == slabs.end()) {  // rank 0 holds it whole
      if (!dec.root()) return;
      sum.add_length(v.size());
      sum.add_elements(v);
      return;
    }
    if (dec.root()) sum.add_length(slab->second.total);
    sum.h = dec.in_rank_order<std::uint64_t>(sum.h, [&](std::uint64_t& h) {
      Fnv1a part{h};
      part.add_elements(v);
      h = part.h;
    });
  };
  a.for_each(add);
  return sum.h;
}

// Keys that may change between the checkpoint and the resumed run.
bool may_change(const std::string& key) {
  return key == "dsmc.t_end" || key.rfind("checkpoint.", 0) == 0 || key == "run.threads";
}

}  // namespace

std::vector<std::string> checkpoint_array_names() {
  State s;
  Scalars k;
  std::vector<std::uint64_t> batch_samples;
  std::vector<std::string> names;
  arrays_of(s, s.particles, k, batch_samples).for_each([&](const std::string& n, const auto&) { names.push_back(n); });
  return names;
}

void write_checkpoint(const fs::path& dir, const State& state, const RunContext& ctx, const Decomposition& dec) {
  State& s = const_cast<State&>(state);  // arrays_of needs non-const pointers; nothing is modified
  State rest = dec.gather_cells(s);      // rank 0: all but the grains; other ranks: empty
  Scalars k = pack(rest);
  std::vector<std::uint64_t> bs(rest.fields.batch_samples.begin(), rest.fields.batch_samples.end());
  const CheckpointArrays arrays = arrays_of(rest, s.particles, k, bs);
  const CheckpointSlabs slabs = slabs_of(arrays, dec);
  const std::uint64_t checksum = distributed_checksum(arrays, slabs, dec);
  const auto index = static_cast<std::uint64_t>(s.step);
  // serial HDF5: one rank at a time in the file; rank 0 creates it, the others add their
  // grains; a failed rank passes "failed" on and the ranks after it do not touch the file
  std::string error;
  fs::path partial;
  const int written = dec.in_rank_order<int>(1, [&](int& ok) {
    if (!ok) return;
    try {
      if (fault_checkpoint_rank() == dec.rank())
        throw std::runtime_error(partial_checkpoint_path(dir, index).string() +
                                 ": write failed (GRAINBATH_FAULT_CHECKPOINT_RANK test hook)");
      if (dec.root())
        partial = begin_checkpoint_file(dir, index, arrays, slabs, checksum, ctx, "dsmc");
      else
        add_checkpoint_slabs(partial_checkpoint_path(dir, index), arrays, slabs);
    } catch (const std::exception& e) {
      error = e.what();
      ok = 0;
    }
  });
  if (dec.root()) {
    try {
      if (written)
        commit_checkpoint_file(partial);
      else
        discard_checkpoint_file(partial_checkpoint_path(dir, index));
    } catch (const std::exception& e) {
      if (error.empty()) error = e.what();
    }
  }
  if (dec.size() == 1) {
    if (!error.empty()) throw std::runtime_error(error);
    return;
  }
  error = dec.first_error(error);  // "rank r: ...", on every rank
  if (!error.empty()) throw std::runtime_error("writing a checkpoint failed on " + error);
}

namespace {
constexpr std::uint64_t kChunk = 1 << 20;  // grains per read of the positions

// Restart on several ranks: the grains per reduction block of the whole checkpoint, counted
// from its positions, each rank reading an equal share of them (and the grain before it, to
// check the order across the shares) and the counts summed over the ranks: no rank reads
// every position. The file holds the grains in (cell, id) order (written after a sort, in
// rank order = cell order): checked, since each rank's grains are then one contiguous range
// of it. Throws the same message on every rank if any rank fails. The share read is kept
// in `held` (x, y, z): most of it is this rank's own grains, not read a second time.
using Positions = std::array<CheckpointPart::Held, 3>;
std::vector<std::uint64_t> grains_per_block(const H5File& h, const Config& c, const Decomposition& dec,
                                            std::uint64_t& bytes_read, Positions& held) {
  const Domain& d = c.domain;
  const CellGrid grid(d);
  std::vector<double> w((d.cell_count() + dec.block_cells() - 1) / dec.block_cells(), 0.0);
  std::string error;
  try {
    const std::uint64_t n = h.length("/particles/x");
    std::size_t lo = 0, hi = 0;
    dec.share(n, 1, lo, hi);
    const std::uint64_t from = lo > 0 && hi > lo ? lo - 1 : lo;  // the grain before the share: its cell
    for (CheckpointPart::Held& e : held) e = {from, {}};
    std::uint32_t previous = 0;
    for (std::uint64_t at = from; at < hi; at += kChunk) {
      const std::uint64_t count = std::min<std::uint64_t>(kChunk, hi - at);
      const std::vector<double> x = h.read_doubles_slab("/particles/x", at, count);
      const std::vector<double> y = d.dimensions > 1 ? h.read_doubles_slab("/particles/y", at, count) : std::vector<double>{};
      const std::vector<double> z = d.dimensions > 2 ? h.read_doubles_slab("/particles/z", at, count) : std::vector<double>{};
      bytes_read += (x.size() + y.size() + z.size()) * sizeof(double);
      held[0].values.insert(held[0].values.end(), x.begin(), x.end());
      held[1].values.insert(held[1].values.end(), y.begin(), y.end());
      held[2].values.insert(held[2].values.end(), z.begin(), z.end());
      for (std::uint64_t i = 0; i < count; ++i) {
        const std::uint32_t k = grid(x[i], y.empty() ? 0.0 : y[i], z.empty() ? 0.0 : z[i]);
        if (k < previous || k >= d.cell_count())
          throw std::runtime_error("the grains are not in cell order (grain " + std::to_string(at + i) + ")");
        previous = k;
        if (at + i >= lo) w[k / dec.block_cells()] += 1.0;
      }
    }
  } catch (const std::exception& e) {
    error = e.what();
  }
  error = dec.first_error(error);
  if (!error.empty()) throw std::runtime_error(error);
  dec.sum_counts(w);  // integer counts: exact in any order
  return std::vector<std::uint64_t>(w.begin(), w.end());
}
}  // namespace

std::optional<State> read_newest_checkpoint(const fs::path& dir, const RunContext& ctx, std::string& warning,
                                            const Config& c, Decomposition& dec, std::uint64_t& bytes_read,
                                            std::string* saved_t_end) {
  State s;
  Scalars k;
  std::vector<std::uint64_t> bs;
  // several ranks: this rank's range of the per-grain arrays (spins: homogeneous runs only,
  // all on rank 0 like the grains)
  std::uint64_t first = 0, end = 0;
  Positions held;  // what the plan read of x, y, z
  CheckpointPart part;
  // The last rank's range runs to the end of every array, so that together the ranges cover
  // each one whatever its length (a per-grain array longer than the positions is then read,
  // and fails the checksum, instead of being left out of it).
  constexpr std::uint64_t kToTheEnd = ~std::uint64_t{0};
  part.plan = [&](const H5File& h) {
    if (c.spatial()) {
      dec.plan_restart(grains_per_block(h, c, dec, bytes_read, held), first, end);
      if (dec.rank() == dec.size() - 1) end = kToTheEnd;
    } else {  // one cell: rank 0 holds every grain
      first = 0;
      end = dec.root() ? kToTheEnd : 0;
    }
  };
  part.range = [&](const std::string& name, std::uint64_t& lo, std::uint64_t& hi) {
    if (!per_grain(name) && name.rfind("spins/", 0) != 0) return false;
    lo = first;
    hi = end;
    return true;
  };
  part.held = [&](const std::string& name) -> const CheckpointPart::Held* {
    const char* axes[] = {"particles/x", "particles/y", "particles/z"};
    for (std::size_t i = 0; i < held.size(); ++i)
      if (name == axes[i] && !held[i].values.empty()) return &held[i];
    return nullptr;
  };
  part.in_order = [&](ChecksumToken t, const std::function<void(ChecksumToken&)>& turn) {
    return dec.in_rank_order<ChecksumToken>(t, turn);
  };
  part.agree = [&](const std::string& mine) { return dec.first_error(mine); };
  part.first = dec.root();
  const fs::path loaded = read_newest_checkpoint_file(
      dir, ctx, "dsmc", may_change, "dsmc.t_end, run.threads and [checkpoint]",
      [&] {
        s = State{};
        k = Scalars{};
        bs.clear();
        return arrays_of(s, s.particles, k, bs);
      },
      [&] {
        unpack(k, s);
        s.fields.batch_samples.assign(bs.begin(), bs.end());
        // a checkpoint written before a3 was sampled: its samples have none (NaN; output.cpp
        // averages a3 over the finite samples of the window)
        TimeSeries& ts = s.series;
        if (ts.a3.size() < ts.t.size()) ts.a3.insert(ts.a3.begin(), ts.t.size() - ts.a3.size(), std::nan(""));
      },
      warning, dec.size() > 1 ? &part : nullptr, &bytes_read);
  if (loaded.empty()) return std::nullopt;
  if (saved_t_end) {  // only for the message of a t_end before the checkpoint (driver.cpp)
    saved_t_end->clear();
    try {
      *saved_t_end = H5File(loaded.string(), H5File::Mode::read).read_attribute("/parameters", "dsmc.t_end");
    } catch (const std::exception&) {
    }
  }
  return s;
}

}  // namespace grainbath::dsmc
