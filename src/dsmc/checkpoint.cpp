#include "dsmc/checkpoint.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "core/h5.hpp"

namespace grainbath::dsmc {

namespace fs = std::filesystem;

fs::path checkpoint_directory(const fs::path& final_out) {
  fs::path p = final_out;
  p += ".checkpoints";
  return p;
}

namespace {

// FNV-1a over bytes, chained across arrays in a fixed order.
struct Checksum {
  std::uint64_t h = 1469598103934665603ull;
  void add(const void* data, std::size_t bytes) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i) {
      h ^= b[i];
      h *= 1099511628211ull;
    }
  }
  template <class T>
  void add(const std::vector<T>& v) {
    const std::uint64_t n = v.size();
    add(&n, sizeof n);
    if (!v.empty()) add(v.data(), v.size() * sizeof(T));
  }
};

// The state as named arrays: one list drives writing, reading and the checksum, so the
// three can never disagree.
struct Fields {
  std::vector<std::pair<std::string, std::vector<double>*>> d;
  std::vector<std::pair<std::string, std::vector<std::uint64_t>*>> u;
};

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

Fields fields_of(State& s, Scalars& k, std::vector<std::uint64_t>& batch_samples) {
  Particles& p = s.particles;
  TimeSeries& t = s.series;
  return Fields{{{"particles/vx", &p.vx},
                 {"particles/vy", &p.vy},
                 {"particles/vz", &p.vz},
                 {"particles/x", &p.x},
                 {"particles/y", &p.y},
                 {"particles/z", &p.z},
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
                 {"scalars/real", &k.d}},
                {{"particles/id", &p.id},
                 {"series/bath_collisions", &t.bath_collisions},
                 {"series/grain_collisions", &t.grain_collisions},
                 {"fields/batch_samples", &batch_samples},
                 {"scalars/integer", &k.u}}};
}

std::uint64_t checksum(const Fields& f) {
  Checksum c;
  for (const auto& [name, v] : f.d) c.add(*v);
  for (const auto& [name, v] : f.u) c.add(*v);
  return c.h;
}

std::string hex(std::uint64_t x) {
  char b[24];
  std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(x));
  return b;
}

// Keys that may change between the checkpoint and the resumed run.
bool may_change(const std::string& key) {
  return key == "dsmc.t_end" || key.rfind("checkpoint.", 0) == 0 || key == "run.threads";
}

}  // namespace

void write_checkpoint(const fs::path& dir, const State& state, const RunContext& ctx) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw std::runtime_error(dir.string() + ": cannot create the checkpoint directory: " + ec.message());
  State& s = const_cast<State&>(state);  // fields_of needs non-const pointers; nothing is modified
  Scalars k = pack(s);
  std::vector<std::uint64_t> bs(s.fields.batch_samples.begin(), s.fields.batch_samples.end());
  const Fields f = fields_of(s, k, bs);
  char name[64];
  std::snprintf(name, sizeof name, "checkpoint-%012lld.h5", static_cast<long long>(s.step));
  const fs::path final_path = dir / name;
  fs::path tmp = final_path;
  tmp += ".partial";
  {
    H5File h(tmp.string(), H5File::Mode::create);
    for (const auto& [n, v] : f.d) h.write("/" + n, *v);
    for (const auto& [n, v] : f.u) h.write("/" + n, *v);
    h.write_string("/case/case.toml", ctx.case_text);
    for (const auto& [key, value] : ctx.resolved) h.attribute("/parameters", key, value);
    h.attribute("/", "checksum", hex(checksum(f)));
    h.attribute("/", "seed", std::to_string(ctx.seed));
    h.attribute("/", "grainbath_version", std::string(GRAINBATH_VERSION));
    h.close();
  }
  fs::rename(tmp, final_path, ec);
  if (ec) throw std::runtime_error(final_path.string() + ": cannot move the checkpoint into place: " + ec.message());
  // keep this one and the previous one
  std::vector<fs::path> all;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".h5" && e.path().filename().string().rfind("checkpoint-", 0) == 0)
      all.push_back(e.path());
  std::sort(all.begin(), all.end());
  while (all.size() > 2) {
    fs::remove(all.front(), ec);
    all.erase(all.begin());
  }
}

std::optional<State> read_newest_checkpoint(const fs::path& dir, const RunContext& ctx, std::string& warning) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return std::nullopt;
  std::vector<fs::path> all;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".h5" && e.path().filename().string().rfind("checkpoint-", 0) == 0)
      all.push_back(e.path());
  std::sort(all.rbegin(), all.rend());
  for (const auto& path : all) {
    State s;
    Scalars k;
    std::vector<std::uint64_t> bs;
    try {
      H5File h(path.string(), H5File::Mode::read);
      const Fields f = fields_of(s, k, bs);
      for (const auto& [n, v] : f.d) *v = h.read_doubles("/" + n);
      for (const auto& [n, v] : f.u) *v = h.read_u64("/" + n);
      const std::string stored = h.read_attribute("/", "checksum");
      if (stored != hex(checksum(f))) throw std::runtime_error("checksum mismatch");
      if (h.read_attribute("/", "seed") != std::to_string(ctx.seed))
        throw std::invalid_argument(path.string() + ": the checkpoint was written with seed " +
                                    h.read_attribute("/", "seed") + ", the case now has " + std::to_string(ctx.seed));
      for (const auto& [key, value] : ctx.resolved) {
        if (may_change(key)) continue;
        std::string old;
        try {
          old = h.read_attribute("/parameters", key);
        } catch (const std::runtime_error&) {
          old = "(absent)";
        }
        if (old != value)
          throw std::invalid_argument(path.string() + ": the case changed since the checkpoint: " + key + " was " + old +
                                      ", now " + value + " (only dsmc.t_end and [checkpoint] may change on --resume)");
      }
      unpack(k, s);
      s.fields.batch_samples.assign(bs.begin(), bs.end());
      return s;
    } catch (const std::invalid_argument&) {
      throw;
    } catch (const std::exception& e) {
      warning += (warning.empty() ? "" : "; ") + path.string() + " is unreadable or corrupt (" + e.what() +
                 "), trying the previous checkpoint";
    }
  }
  return std::nullopt;
}

}  // namespace grainbath::dsmc
