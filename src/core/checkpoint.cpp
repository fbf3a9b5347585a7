#include "core/checkpoint.hpp"

#include <algorithm>
#include <cstdio>
#include <memory>
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
  for_each([&](const std::string&, const auto& v) {
    c.add_length(v.size());
    c.add_elements(v);
  });
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
  arrays.for_each([&](const std::string& n, const auto& v) {
    if (const CheckpointSlab* slab = slab_of(slabs, n))
      h.write_slab("/" + n, v, slab->total, slab->offset);
    else
      h.write("/" + n, v);
  });
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
  arrays.for_each([&](const std::string& n, const auto& v) {
    if (const CheckpointSlab* slab = slab_of(slabs, n); slab && !v.empty()) h.write_slab("/" + n, v, slab->total, slab->offset);
  });
  h.close();
}

void commit_checkpoint_file(const fs::path& partial) {
  fs::path final_path = partial;
  final_path.replace_extension();  // drops ".partial"
  std::error_code ec;
  fs::rename(partial, final_path, ec);
  if (ec) throw std::runtime_error(final_path.string() + ": cannot move the checkpoint into place: " + ec.message());
  // keep this one and the newest before it; never the one just written, whatever else the
  // directory holds (a file of a higher index can only be a stale or corrupt one: a fresh run
  // sets an earlier run's checkpoints aside, set_aside_checkpoints, and --resume continues
  // from the newest valid one)
  const auto all = list_checkpoints(final_path.parent_path());  // by index, oldest first
  const auto mine = std::find_if(all.begin(), all.end(),
                                 [&](const auto& c) { return c.second.filename() == final_path.filename(); });
  const fs::path* previous = nullptr;
  for (auto c = all.begin(); c != mine && mine != all.end(); ++c) previous = &c->second;
  for (const auto& [index, path] : all)
    if (path.filename() != final_path.filename() && (previous == nullptr || path != *previous)) fs::remove(path, ec);
}

std::size_t count_checkpoints(const fs::path& dir) { return list_checkpoints(dir).size(); }

std::string set_aside_checkpoints(const fs::path& dir) {
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(dir, ec))) return {};
  if (fs::is_symlink(fs::symlink_status(dir, ec)))
    throw std::runtime_error(dir.string() + ": is a symbolic link; a run started afresh moves an earlier run's "
                             "checkpoints aside and would move the link: remove it (or its checkpoints), or continue "
                             "that run with --resume");
  if (!fs::is_directory(fs::symlink_status(dir, ec)))
    throw std::runtime_error(dir.string() + ": is not a directory of checkpoints; this run would write its checkpoints "
                             "there: move it away or choose another --out");
  // only checkpoint files (and their .partial leftovers) are moved, so a directory of the
  // user's own that happens to have this name is never touched
  const auto ours = [](const fs::path& p) {
    const std::string n = p.filename().string();
    return n.rfind("checkpoint-", 0) == 0 && (p.extension() == ".h5" || p.extension() == ".partial");
  };
  std::size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!ours(e.path()))
      throw std::runtime_error(dir.string() + ": holds " + e.path().filename().string() +
                               ", which is not a checkpoint; this run would write its checkpoints there: move it "
                               "away or choose another --out");
    ++files;
  }
  if (files == 0) return {};
  const auto kept = list_checkpoints(dir);
  fs::path previous = dir;
  previous += ".previous";
  if (fs::exists(fs::symlink_status(previous, ec))) {
    if (!fs::is_directory(fs::symlink_status(previous, ec)))
      throw std::runtime_error(previous.string() + ": is not a directory of checkpoints; it would be replaced by " +
                               dir.string() + " (the checkpoints of an earlier run): move it away");
    for (const auto& e : fs::directory_iterator(previous, ec))
      if (!ours(e.path()))
        throw std::runtime_error(previous.string() + ": holds " + e.path().filename().string() +
                                 ", which is not a checkpoint; it would be replaced by " + dir.string() +
                                 " (the checkpoints of an earlier run): move it away");
    fs::remove_all(previous, ec);
  }
  fs::rename(dir, previous, ec);
  if (ec)
    throw std::runtime_error(dir.string() + ": cannot move the earlier run's checkpoints aside (" + ec.message() + ")");
  return dir.string() + " held " + std::to_string(kept.size()) + " checkpoint(s) of an earlier run" +
         (kept.empty() ? std::string() : " (the newest: " + kept.back().second.filename().string() + ")") +
         "; this run starts afresh (no --resume), so they were moved to " + previous.string() +
         " (to continue that run instead: move them back and add --resume)";
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

// The case first: a case that changed in what decides the arrays' layout (e.g. a [transport]
// section added) must be reported as a changed case (std::invalid_argument), not as a
// corrupt file.
void check_case(const H5File& h, const fs::path& path, const RunContext& ctx, const std::string& solver,
                const std::function<bool(const std::string&)>& may_change, const std::string& may_change_text) {
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
  // Keys added after checkpoints of their solver existed, with the value that continues an
  // older checkpoint exactly (the behaviour before the key): an absent key stands for it.
  struct AddedKey {
    const char* key;
    const char* value;
  };
  static constexpr AddedKey kAddedLater[] = {
      {"dsmc.collision_group", "0"},  // homogeneous DSMC collision groups (2026-11-26); 0 = one cell as before
      {"dsmc.bound", "\"bird\""},     // the exact NTC bound (2026-12-05); "bird" = the start-of-step bound as before
  };
  for (const auto& [key, value] : ctx.resolved) {
    if (may_change(key)) continue;
    std::string old;
    std::string hint;
    try {
      old = h.read_attribute("/parameters", key);
    } catch (const std::runtime_error&) {
      // a file's checksum (CaseReader::record_file_checksum) that a checkpoint written before
      // 2026-12-04 does not hold: what its file contained is unknown, so it is not compared
      if (key.ends_with("_checksum")) continue;
      old = "(absent)";
      for (const AddedKey& a : kAddedLater)
        if (key == a.key) {
          old = a.value;
          hint = "; the checkpoint predates this key: --set " + key + "=" + a.value + " continues it exactly";
        }
    }
    if (old != value && key.ends_with("_checksum"))
      throw std::invalid_argument(path.string() + ": the case changed since the checkpoint: " +
                                  key.substr(0, key.size() - 9) + " names a file whose contents changed (" + key +
                                  " was " + old + ", now " + value + "); restore the file, or start afresh without --resume");
    if (old != value)
      throw std::invalid_argument(path.string() + ": the case changed since the checkpoint: " + key + " was " + old +
                                  ", now " + value + " (only " + may_change_text + " may change on --resume" + hint +
                                  ")");
  }
  // ... and a key the checkpoint's case had that the case has no more (a section removed)
  for (const std::string& key : h.attribute_names("/parameters")) {
    if (may_change(key) || ctx.resolved.count(key)) continue;
    throw std::invalid_argument(path.string() + ": the case changed since the checkpoint: " + key + " was " +
                                h.read_attribute("/parameters", key) + ", now absent (only " + may_change_text +
                                " may change on --resume)");
  }
}

// v = read (a plain vector or a DSMC particle array: core/no_fill_vector.hpp)
template <class T, class A>
void assign(std::vector<T, A>& v, std::vector<T>&& read) {
  if constexpr (std::is_same_v<A, std::allocator<T>>)
    v = std::move(read);
  else
    v.assign(read.begin(), read.end());
}

template <class T>
std::vector<T> read_whole(const H5File& h, const std::string& path) {
  if constexpr (std::is_same_v<T, double>)
    return h.read_doubles(path);
  else
    return h.read_u64(path);
}

template <class T>
std::vector<T> read_slab(const H5File& h, const std::string& path, std::uint64_t at, std::uint64_t count) {
  if (count == 0) return {};
  if constexpr (std::is_same_v<T, double>)
    return h.read_doubles_slab(path, at, count);
  else
    return h.read_u64_slab(path, at, count);
}

// "checksum mismatch" if the stored checksum is not `computed` (the file's own words in the message).
std::string checksum_verdict(const H5File& h, std::uint64_t computed) {
  const std::string stored = h.read_attribute("/", "checksum");
  if (stored == hex(computed)) return {};
  return "checksum mismatch: the file says " + stored + ", its arrays sum to " + hex(computed);
}

// One process: every array whole, in list order, each into the checksum as it is read.
void load_whole(const H5File& h, const CheckpointArrays& a, std::uint64_t* bytes_read) {
  Fnv1a sum;  // CheckpointArrays::checksum, as the arrays are read
  a.for_each([&](const std::string& name, auto& v) {
    using T = typename std::decay_t<decltype(v)>::value_type;
    if (a.is_optional(name) && !h.exists("/" + name)) {  // an older file: not in its checksum either
      v.clear();
      return;
    }
    assign(v, read_whole<T>(h, "/" + name));
    if (bytes_read) *bytes_read += v.size() * sizeof(T);
    sum.add_length(v.size());
    sum.add_elements(v);
  });
  if (const std::string verdict = checksum_verdict(h, sum.h); !verdict.empty()) throw std::runtime_error(verdict);
}

// What a process read of one array (several processes).
struct ReadPart {
  bool spread = false;     // a part of it (else: whole)
  bool absent = false;     // an optional array the file does not hold (CheckpointArrays::optional)
  std::uint64_t total = 0; // the array's length in the file
  std::uint64_t lo = 0;    // the first element read (spread arrays)
};

template <class T, class A>
ReadPart read_part(const H5File& h, const std::string& name, std::vector<T, A>& v, const CheckpointPart& part,
                   std::uint64_t* bytes_read, bool optional) {
  const std::string path = "/" + name;
  ReadPart r;
  if (optional && !h.exists(path)) {
    v.clear();
    r.absent = true;
    return r;
  }
  std::uint64_t lo = 0, hi = 0;
  if (!part.range(name, lo, hi)) {
    assign(v, read_whole<T>(h, path));
    r.total = v.size();
  } else {
    r.spread = true;
    r.total = h.length(path);
    hi = std::min(hi, r.total);
    r.lo = std::min(lo, hi);
    const CheckpointPart::Held* held = nullptr;
    if constexpr (std::is_same_v<T, double>) held = part.held ? part.held(name) : nullptr;
    if (!held) {
      assign(v, read_slab<T>(h, path, r.lo, hi - r.lo));
      if (bytes_read) *bytes_read += v.size() * sizeof(T);
      return r;
    }
    // [a, b): the overlap with what is held; before and after it from the file
    const std::uint64_t a = std::clamp(held->offset, r.lo, hi);
    const std::uint64_t b = std::clamp(held->offset + held->values.size(), a, hi);
    assign(v, read_slab<T>(h, path, r.lo, a - r.lo));
    const std::vector<T> after = read_slab<T>(h, path, b, hi - b);
    if (bytes_read) *bytes_read += (v.size() + after.size()) * sizeof(T);
    if constexpr (std::is_same_v<T, double>)
      v.insert(v.end(), held->values.begin() + static_cast<std::ptrdiff_t>(a - held->offset),
               held->values.begin() + static_cast<std::ptrdiff_t>(b - held->offset));
    v.insert(v.end(), after.begin(), after.end());
    return r;
  }
  if (bytes_read) *bytes_read += v.size() * sizeof(T);
  return r;
}

// Adds one array to the checksum `sum` (meaningful on the first process): a whole array by
// the first process, as one process would; a spread array by the processes in order, each
// going on from the state the one before it left, its part right after the elements added
// so far (`at`), so that the bytes go in as the file holds them. A gap or an overlap between
// the parts leaves the sum unverifiable: `verdict` (first process) says so.
constexpr std::uint64_t kNotInOrder = ~std::uint64_t{0};
template <class T, class A>
void add_part(const std::string& name, const std::vector<T, A>& v, const ReadPart& r, const CheckpointPart& part,
              ChecksumToken& sum, std::string& verdict) {
  if (r.absent) return;  // not in the file's checksum either
  Fnv1a f{sum.h};
  if (!r.spread) {
    if (!part.first) return;
    f.add_length(v.size());
    f.add_elements(v);
    sum.h = f.h;
    return;
  }
  f.add_length(r.total);
  sum.h = f.h;
  sum.at = 0;
  sum = part.in_order(sum, [&](ChecksumToken& t) {
    if (v.empty() || t.at == kNotInOrder) return;
    if (t.at != r.lo) {
      t.at = kNotInOrder;
      return;
    }
    Fnv1a mine{t.h};
    mine.add_elements(v);
    t.h = mine.h;
    t.at += v.size();
  });
  if (part.first && sum.at != r.total && verdict.empty())
    verdict = "the processes' parts of " + name + " do not cover its " + std::to_string(r.total) +
              " elements in order (the checksum cannot be verified)";
}

// The message of an agreement without its "rank r: " (for a verdict of the first process
// on the whole file, not an error of that rank).
std::string without_rank(const std::string& agreed) {
  const std::size_t colon = agreed.find(": ");
  return agreed.rfind("rank ", 0) == 0 && colon != std::string::npos ? agreed.substr(colon + 2) : agreed;
}

// Several processes: each reads its parts of the spread arrays and every other array whole,
// then they verify the checksum together. Every step that can fail on some processes only
// is followed by an agreement, so that every process returns, or throws the same exception
// with the same message (std::invalid_argument: the case changed).
void load_in_parts(const fs::path& path, const RunContext& ctx, const std::string& solver,
                   const std::function<bool(const std::string&)>& may_change, const std::string& may_change_text,
                   const std::function<CheckpointArrays()>& prepare, const std::function<void()>& finish,
                   const CheckpointPart& part, std::uint64_t* bytes_read) {
  auto agree_or_throw = [&](const std::string& mine) {
    if (const std::string e = part.agree(mine); !e.empty()) throw std::runtime_error(e);
  };
  std::unique_ptr<H5File> h;
  std::string changed, failed;
  try {
    h = std::make_unique<H5File>(path.string(), H5File::Mode::read);
    check_case(*h, path, ctx, solver, may_change, may_change_text);
  } catch (const std::invalid_argument& e) {
    changed = e.what();
  } catch (const std::exception& e) {
    failed = e.what();
  }
  if (const std::string e = part.agree(changed); !e.empty()) throw std::invalid_argument(without_rank(e));
  agree_or_throw(failed);

  const CheckpointArrays a = prepare();
  if (part.plan) part.plan(*h);  // collective; throws alike on every process
  std::vector<ReadPart> reads;
  try {
    a.for_each([&](const std::string& n, auto& v) { reads.push_back(read_part(*h, n, v, part, bytes_read, a.is_optional(n))); });
  } catch (const std::exception& e) {
    failed = e.what();
  }
  agree_or_throw(failed);

  ChecksumToken sum{Fnv1a{}.h, 0};
  std::string verdict;
  std::size_t i = 0;
  a.for_each([&](const std::string& n, const auto& v) { add_part(n, v, reads[i++], part, sum, verdict); });
  if (part.first && verdict.empty()) {
    try {
      verdict = checksum_verdict(*h, sum.h);
    } catch (const std::exception& e) {
      verdict = e.what();
    }
  }
  if (const std::string e = part.agree(verdict); !e.empty()) throw std::runtime_error(without_rank(e));

  try {
    finish();
  } catch (const std::exception& e) {
    failed = e.what();
  }
  agree_or_throw(failed);
}

}  // namespace

fs::path read_newest_checkpoint_file(const fs::path& dir, const RunContext& ctx, const std::string& solver,
                                     const std::function<bool(const std::string&)>& may_change,
                                     const std::string& may_change_text,
                                     const std::function<CheckpointArrays()>& prepare,
                                     const std::function<void()>& finish, std::string& warning,
                                     const CheckpointPart* part, std::uint64_t* bytes_read) {
  // every process lists the same directory (a shared file system): the same candidates
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return {};
  auto all = list_checkpoints(dir);
  std::reverse(all.begin(), all.end());
  for (const auto& [index, path] : all) {
    try {
      if (part) {
        load_in_parts(path, ctx, solver, may_change, may_change_text, prepare, finish, *part, bytes_read);
      } else {
        H5File h(path.string(), H5File::Mode::read);
        check_case(h, path, ctx, solver, may_change, may_change_text);
        load_whole(h, prepare(), bytes_read);
        try {
          finish();
        } catch (const std::invalid_argument& e) {  // a state this case cannot continue: name the file
          throw std::invalid_argument(path.string() + ": " + e.what());
        }
      }
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
