#include "core/checkpoint.hpp"

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <type_traits>

#include "core/h5.hpp"

namespace grainbath {

namespace fs = std::filesystem;

CheckpointSettings read_checkpoint_settings(CaseReader& r, const char* every_unit) {
  CheckpointSettings s;
  s.every = r.real("checkpoint", "every", 0.0, Bounds::non_negative(), every_unit);
  s.every_minutes = r.real("checkpoint", "every_minutes", 0.0, Bounds::non_negative(), "minutes");
  s.keep = r.boolean("checkpoint", "keep", false);
  return s;
}

fs::path checkpoint_directory(const fs::path& final_out) {
  fs::path p = final_out;
  p += ".checkpoints";
  return p;
}

namespace {

std::string hex(std::uint64_t x) {
  char b[24];
  std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(x));
  return b;
}

// checkpoint-<digits>.h5 files of `dir` with their index, sorted by index (oldest first):
// numeric order, so the name's width never matters.
std::vector<std::pair<std::uint64_t, fs::path>> list_checkpoints(const fs::path& dir) {
  std::vector<std::pair<std::uint64_t, fs::path>> all;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (e.path().extension() != ".h5" || name.rfind("checkpoint-", 0) != 0) continue;
    const std::string digits = name.substr(11, name.size() - 11 - 3);
    if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 19) continue;
    all.emplace_back(std::stoull(digits), e.path());
  }
  std::sort(all.begin(), all.end());
  return all;
}

}  // namespace

void Fnv1a::add(const void* data, std::size_t bytes) {
  const auto* b = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < bytes; ++i) {
    h ^= b[i];
    h *= 1099511628211ull;
  }
}

std::uint64_t CheckpointArrays::checksum() const {
  Fnv1a c;
  for (const auto& [name, v] : real) {
    c.add_length(v->size());
    c.add_elements(*v);
  }
  for (const auto& [name, v] : integer) {
    c.add_length(v->size());
    c.add_elements(*v);
  }
  return c.h;
}

namespace {
const CheckpointSlab* slab_of(const CheckpointSlabs& slabs, const std::string& name) {
  for (const auto& [n, slab] : slabs)
    if (n == name) return &slab;
  return nullptr;
}
}  // namespace

fs::path partial_checkpoint_path(const fs::path& dir, std::uint64_t index) {
  char name[64];
  std::snprintf(name, sizeof name, "checkpoint-%012llu.h5.partial", static_cast<unsigned long long>(index));
  return dir / name;
}

fs::path begin_checkpoint_file(const fs::path& dir, std::uint64_t index, const CheckpointArrays& arrays,
                               const CheckpointSlabs& slabs, std::uint64_t checksum, const RunContext& ctx,
                               const std::string& solver) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw std::runtime_error(dir.string() + ": cannot create the checkpoint directory: " + ec.message());
  const fs::path tmp = partial_checkpoint_path(dir, index);
  H5File h(tmp.string(), H5File::Mode::create);
  // the datasets in list order, whether whole or a part: the same file at any process count
  auto put = [&](const std::string& n, const auto& v) {
    if (const CheckpointSlab* slab = slab_of(slabs, n))
      h.write_slab("/" + n, *v, slab->total, slab->offset);
    else
      h.write("/" + n, *v);
  };
  for (const auto& [n, v] : arrays.real) put(n, v);
  for (const auto& [n, v] : arrays.integer) put(n, v);
  h.write_string("/case/case.toml", ctx.case_text);
  for (const auto& [key, value] : ctx.resolved) h.attribute("/parameters", key, value);
  h.attribute("/", "checksum", hex(checksum));
  h.attribute("/", "seed", std::to_string(ctx.seed));
  h.attribute("/", "solver", solver);
  h.attribute("/", "grainbath_version", std::string(GRAINBATH_VERSION));
  h.close();  // flushes; a failed write (disk full) throws here, before the rename
  return tmp;
}

void add_checkpoint_slabs(const fs::path& partial, const CheckpointArrays& arrays, const CheckpointSlabs& slabs) {
  H5File h(partial.string(), H5File::Mode::update);
  for (const auto& [n, v] : arrays.real)
    if (const CheckpointSlab* slab = slab_of(slabs, n); slab && !v->empty()) h.write_slab("/" + n, *v, slab->total, slab->offset);
  for (const auto& [n, v] : arrays.integer)
    if (const CheckpointSlab* slab = slab_of(slabs, n); slab && !v->empty()) h.write_slab("/" + n, *v, slab->total, slab->offset);
  h.close();
}

void commit_checkpoint_file(const fs::path& partial) {
  fs::path final_path = partial;
  final_path.replace_extension();  // drops ".partial"
  std::error_code ec;
  fs::rename(partial, final_path, ec);
  if (ec) throw std::runtime_error(final_path.string() + ": cannot move the checkpoint into place: " + ec.message());
  // keep this one and the previous one
  auto all = list_checkpoints(final_path.parent_path());
  while (all.size() > 2) {
    fs::remove(all.front().second, ec);
    all.erase(all.begin());
  }
}

void discard_checkpoint_file(const fs::path& partial) {
  std::error_code ec;
  fs::remove(partial, ec);
}

void write_checkpoint_file(const fs::path& dir, std::uint64_t index, const CheckpointArrays& arrays,
                           const RunContext& ctx, const std::string& solver) {
  commit_checkpoint_file(begin_checkpoint_file(dir, index, arrays, {}, arrays.checksum(), ctx, solver));
}

namespace {
// One array of a checkpoint into v, its bytes into the checksum: whole, or (a per-grain array
// of a CheckpointPart) in chunks, keeping [lo, hi).
template <class T>
void read_array(const H5File& h, const std::string& name, std::vector<T>& v, const CheckpointPart* part, Fnv1a& sum) {
  const std::string path = "/" + name;
  auto slab = [&](std::uint64_t at, std::uint64_t count) {
    if constexpr (std::is_same_v<T, double>)
      return h.read_doubles_slab(path, at, count);
    else
      return h.read_u64_slab(path, at, count);
  };
  std::uint64_t lo = 0, hi = 0;
  if (!part || !part->range(name, lo, hi)) {
    if constexpr (std::is_same_v<T, double>)
      v = h.read_doubles(path);
    else
      v = h.read_u64(path);
    sum.add_length(v.size());
    sum.add_elements(v);
    return;
  }
  const std::uint64_t total = h.length(path);
  hi = std::min(hi, total);
  lo = std::min(lo, hi);
  v.clear();
  v.reserve(hi - lo);
  sum.add_length(total);
  for (std::uint64_t at = 0; at < total; at += CheckpointPart::kChunk) {
    const std::uint64_t count = std::min(CheckpointPart::kChunk, total - at);
    const std::vector<T> chunk = slab(at, count);
    sum.add_elements(chunk);
    const std::uint64_t from = std::clamp(lo, at, at + count), to = std::clamp(hi, at, at + count);
    v.insert(v.end(), chunk.begin() + static_cast<std::ptrdiff_t>(from - at), chunk.begin() + static_cast<std::ptrdiff_t>(to - at));
  }
}
}  // namespace

fs::path read_newest_checkpoint_file(const fs::path& dir, const RunContext& ctx, const std::string& solver,
                                     const std::function<bool(const std::string&)>& may_change,
                                     const std::string& may_change_text,
                                     const std::function<CheckpointArrays()>& prepare,
                                     const std::function<void()>& finish, std::string& warning,
                                     const CheckpointPart* part) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return {};
  auto all = list_checkpoints(dir);
  std::reverse(all.begin(), all.end());
  for (const auto& [index, path] : all) {
    try {
      H5File h(path.string(), H5File::Mode::read);
      // the case first: a case that changed in what decides the arrays' layout (e.g. a
      // [transport] section added) must be reported as a changed case, not as corrupt files
      std::string stored_solver = solver;
      try {
        stored_solver = h.read_attribute("/", "solver");
      } catch (const std::runtime_error&) {
        // checkpoints written before the attribute existed were DSMC's
        stored_solver = "dsmc";
      }
      if (stored_solver != solver)
        throw std::invalid_argument(path.string() + ": the checkpoint was written by solver " + stored_solver +
                                    ", the case now runs " + solver);
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
                                      ", now " + value + " (only " + may_change_text + " may change on --resume)");
      }
      // ... and a key the checkpoint's case had that the case has no more (a section removed)
      for (const std::string& key : h.attribute_names("/parameters")) {
        if (may_change(key) || ctx.resolved.count(key)) continue;
        throw std::invalid_argument(path.string() + ": the case changed since the checkpoint: " + key + " was " +
                                    h.read_attribute("/parameters", key) + ", now absent (only " + may_change_text +
                                    " may change on --resume)");
      }
      const CheckpointArrays a = prepare();
      if (part && part->plan) part->plan(h);
      Fnv1a sum;  // CheckpointArrays::checksum, as the arrays are read
      for (const auto& [n, v] : a.real) read_array(h, n, *v, part, sum);
      for (const auto& [n, v] : a.integer) read_array(h, n, *v, part, sum);
      const std::string stored = h.read_attribute("/", "checksum");
      if (stored != hex(sum.h)) throw std::runtime_error("checksum mismatch");
      finish();
      return path;
    } catch (const std::invalid_argument&) {
      throw;
    } catch (const std::exception& e) {
      warning += (warning.empty() ? "" : "; ") + path.string() + " is unreadable or corrupt (" + e.what() +
                 "), trying the previous checkpoint";
    }
  }
  return {};
}

}  // namespace grainbath
