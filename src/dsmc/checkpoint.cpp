#include "dsmc/checkpoint.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "core/checkpoint.hpp"

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
         static_cast<std::uint64_t>(s.fields.window_samples), static_cast<std::uint64_t>(s.fields.taken)};
  return k;
}

void unpack(const Scalars& k, State& s) {
  if (k.d.size() != 5 || k.u.size() != 12) throw std::runtime_error("checkpoint: wrong scalar layout");
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
}

// The state as named arrays (core/checkpoint.hpp): one list drives writing, reading and
// the checksum.
CheckpointArrays arrays_of(State& s, Scalars& k, std::vector<std::uint64_t>& batch_samples) {
  Particles& p = s.particles;
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
                 {"scalars/real", &k.d}};
  a.integer = {{"particles/id", &p.id},
               {"series/bath_collisions", &t.bath_collisions},
               {"series/grain_collisions", &t.grain_collisions},
               {"fields/batch_samples", &batch_samples},
               {"scalars/integer", &k.u}};
  return a;
}

// Keys that may change between the checkpoint and the resumed run.
bool may_change(const std::string& key) {
  return key == "dsmc.t_end" || key.rfind("checkpoint.", 0) == 0 || key == "run.threads";
}

}  // namespace

void write_checkpoint(const fs::path& dir, const State& state, const RunContext& ctx) {
  State& s = const_cast<State&>(state);  // arrays_of needs non-const pointers; nothing is modified
  Scalars k = pack(s);
  std::vector<std::uint64_t> bs(s.fields.batch_samples.begin(), s.fields.batch_samples.end());
  write_checkpoint_file(dir, static_cast<std::uint64_t>(s.step), arrays_of(s, k, bs), ctx, "dsmc");
}

std::optional<State> read_newest_checkpoint(const fs::path& dir, const RunContext& ctx, std::string& warning) {
  State s;
  Scalars k;
  std::vector<std::uint64_t> bs;
  const fs::path loaded = read_newest_checkpoint_file(
      dir, ctx, "dsmc", may_change, "dsmc.t_end and [checkpoint]",
      [&] {
        s = State{};
        k = Scalars{};
        bs.clear();
        return arrays_of(s, k, bs);
      },
      [&] {
        unpack(k, s);
        s.fields.batch_samples.assign(bs.begin(), bs.end());
      },
      warning);
  if (loaded.empty()) return std::nullopt;
  return s;
}

}  // namespace grainbath::dsmc
