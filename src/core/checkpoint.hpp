#pragma once
// Checkpoint files shared by every solver (issue #8). A solver describes its state as named
// arrays (CheckpointArrays: one list drives writing, reading and the checksum, so the
// three can never disagree); this module writes them with the provenance to one HDF5 file
// OUT.checkpoints/checkpoint-<index>.h5 through a temporary name (flushed, closed with
// checked errors, renamed; the previous checkpoint is kept), and reads back the newest one
// that verifies (64-bit FNV-1a checksum over every array), falling back to the previous one
// with a warning when the newest is truncated or corrupt. Several processes each read only
// their part (CheckpointPart) and verify the same checksum together.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "core/no_fill_vector.hpp"

#include "core/case_file.hpp"
#include "core/h5.hpp"
#include "core/run_context.hpp"

namespace grainbath {

// [checkpoint]: the same keys for every solver; the unit of `every` is the solver's.
struct CheckpointSettings {
  double every = 0.0;          // solver units between checkpoints (0: none)
  double every_minutes = 0.0;  // wall-clock minutes between checkpoints (0: none)
  bool keep = false;           // keep the checkpoints after a successful run
};
// `every_unit` names the unit of `every` in error messages ("time", "collisions per particle").
CheckpointSettings read_checkpoint_settings(CaseReader& reader, const char* every_unit);

// Where checkpoints of the run writing to OUT live: OUT.checkpoints/ (next to the output,
// so that they survive a crash of the run that is writing OUT).
std::filesystem::path checkpoint_directory(const std::filesystem::path& final_out);

// The number of checkpoint files in `dir` (0 if there is no such directory).
std::size_t count_checkpoints(const std::filesystem::path& dir);

// A run that starts afresh (no --resume) writes a new series of checkpoints: the files an
// earlier run left in `dir` are moved to DIR.previous (replacing an older one), so that
// they cannot be mistaken for this run's, nor prune them (they used to: the two newest by
// index were kept). Returns a note for the user ("" if there was nothing). Throws when `dir`,
// or DIR.previous, holds anything but checkpoint files.
std::string set_aside_checkpoints(const std::filesystem::path& dir);

// The checksum: FNV-1a over bytes, chained across the arrays in their list order, each array
// prefixed by its length. Exposed so that processes that each hold a part of an array (MPI
// ranks, src/dsmc/checkpoint.cpp) can continue it in turn: the bytes of a part go in
// right after those of the part before it, which gives the sum of the whole array.
// It starts from 1469598103934665603, not from FNV's published offset basis
// 14695981039346656037 (a digit short): every checkpoint and every background.file_checksum
// written so far is sealed from this start, so it stays (tests/core/test_checkpoint_file.cpp
// pins it; a tool that recomputes a sum must start here).
struct Fnv1a {
  std::uint64_t h = 1469598103934665603ull;
  void add(const void* data, std::size_t bytes);
  void add_length(std::uint64_t n) { add(&n, sizeof n); }
  template <class T, class A>
  void add_elements(const std::vector<T, A>& v) {
    if (!v.empty()) add(v.data(), v.size() * sizeof(T));
  }
};

struct CheckpointArrays {
  // an array of the state: a plain vector, or one of the DSMC particle arrays
  // (core/no_fill_vector.hpp); the file holds the same dataset either way
  using Real = std::variant<std::vector<double>*, NoFillVector<double>*>;
  using Integer = std::variant<std::vector<std::uint64_t>*, NoFillVector<std::uint64_t>*>;
  std::vector<std::pair<std::string, Real>> real;
  std::vector<std::pair<std::string, Integer>> integer;
  // Arrays added after checkpoints were first written: always written, but a file without one
  // (written by an earlier build) still loads: the array is read as empty and left out of the
  // checksum, as the writer of that file left it out (the solver fills it in, e.g. with NaN).
  std::vector<std::string> optional;
  bool is_optional(const std::string& name) const {
    for (const auto& n : optional)
      if (n == name) return true;
    return false;
  }
  void add(std::string name, std::vector<double>& v) { real.emplace_back(std::move(name), &v); }
  void add(std::string name, std::vector<std::uint64_t>& v) { integer.emplace_back(std::move(name), &v); }
  // f(name, array) for every array in list order (the real ones, then the integer ones):
  // the order of the file, of the checksum and of the reads
  template <class F>
  void for_each(F&& f) const {
    for (const auto& [n, v] : real) std::visit([&](auto* a) { f(n, *a); }, v);
    for (const auto& [n, v] : integer) std::visit([&](auto* a) { f(n, *a); }, v);
  }
  std::uint64_t checksum() const;
};

// The writing of a checkpoint file in its three steps, for states spread over processes:
//  - begin_checkpoint_file creates dir/checkpoint-<index>.h5.partial and writes every array
//    (an array named in `slabs` as this process's part of a dataset of slab.total elements,
//    at slab.offset), the case, the parameters and the given checksum; returns the path;
//  - add_checkpoint_slabs: another process adds its parts of the `slabs` arrays;
//  - commit_checkpoint_file renames the file into place and keeps it and the previous one
//    (discard_checkpoint_file removes a file that failed).
// Every step flushes and closes the file with checked errors (a full disk throws).
struct CheckpointSlab {
  std::uint64_t total = 0, offset = 0;
};
using CheckpointSlabs = std::vector<std::pair<std::string, CheckpointSlab>>;
// dir/checkpoint-<index>.h5.partial: the name under which the file is written
std::filesystem::path partial_checkpoint_path(const std::filesystem::path& dir, std::uint64_t index);
std::filesystem::path begin_checkpoint_file(const std::filesystem::path& dir, std::uint64_t index,
                                            const CheckpointArrays& arrays, const CheckpointSlabs& slabs,
                                            std::uint64_t checksum, const RunContext& ctx, const std::string& solver);
void add_checkpoint_slabs(const std::filesystem::path& partial, const CheckpointArrays& arrays,
                          const CheckpointSlabs& slabs);
void commit_checkpoint_file(const std::filesystem::path& partial);
void discard_checkpoint_file(const std::filesystem::path& partial);

// Writes `arrays` to dir/checkpoint-<index>.h5 (index: a number that grows along the run,
// e.g. the step or the collision count) with the case text, the resolved parameters, the
// seed, the solver and the version; keeps this checkpoint and the previous one.
void write_checkpoint_file(const std::filesystem::path& dir, std::uint64_t index, const CheckpointArrays& arrays,
                           const RunContext& ctx, const std::string& solver);

// Reading a checkpoint on several processes (MPI ranks, src/dsmc/checkpoint.cpp), each one
// reading only its part of the spread (per-grain) arrays and the small arrays whole, so that
// no process reads the whole file, while the checksum is still verified exactly: FNV-1a is
// a chain (no sum of parts), so its state is handed from process to process in their order
// for every spread array, each adding the bytes of its part, which gives the sum of the
// whole file with every byte of a spread array read by one process only. Every step that
// may fail on some processes only ends in an agreement, so that all of them take the same
// path (the same checkpoint loaded, the same one skipped with the same message): no hang.
struct ChecksumToken {  // what goes from process to process along an array
  std::uint64_t h = 0;   // the FNV-1a state
  std::uint64_t at = 0;  // elements of the array added so far
};
struct CheckpointPart {
  // After the case checks: choose the parts (it may read the file and communicate; it must
  // throw the same on every process, e.g. after `agree`).
  std::function<void(const H5File&)> plan;
  // This process's part [lo, hi) of array `name` (clipped to the array), or false: the
  // array is read whole by every process. The processes' non-empty parts, in process order,
  // must follow each other from 0 to the array's end (checked, as part of the checksum).
  std::function<bool(const std::string& name, std::uint64_t& lo, std::uint64_t& hi)> range;
  // Elements of a real spread array this process already read (the plan reads positions to
  // choose the parts): [offset, offset + values.size()), or nullptr. The part is taken from
  // here where it overlaps, and only the rest is read from the file.
  struct Held {
    std::uint64_t offset = 0;
    std::vector<double> values;
  };
  std::function<const Held*(const std::string& name)> held;
  // Decomposition::in_rank_order: `turn` on each process in order, the result back on the first.
  std::function<ChecksumToken(ChecksumToken, const std::function<void(ChecksumToken&)>&)> in_order;
  // Decomposition::first_error: empty on every process if `mine` is empty everywhere, else
  // "rank r: <message of the lowest failing rank>" on every process.
  std::function<std::string(const std::string& mine)> agree;
  bool first = true;  // the process that adds the whole arrays to the checksum and decides on it
};

// Tries the checkpoints in `dir` newest first. For each, `prepare()` resets the caller's
// candidate state and returns its arrays (filled from the file), then the checksum, seed,
// solver and every resolved parameter not accepted by `may_change` are verified, then
// `finish()` unpacks (it may throw std::runtime_error on a bad layout: treated as corrupt).
// With `part` (several processes): collective, each process reads its parts only.
// `bytes_read` (if given) is increased by the dataset bytes this process read (the file's
// arrays; a plan counts its own reads).
// Returns the path loaded, or an empty path if none verifies; `warning` receives one
// message per checkpoint skipped as corrupt. Throws std::invalid_argument if the case
// changed in a key that may not change (naming the key; `may_change_text` says which may).
std::filesystem::path read_newest_checkpoint_file(const std::filesystem::path& dir, const RunContext& ctx,
                                                  const std::string& solver,
                                                  const std::function<bool(const std::string&)>& may_change,
                                                  const std::string& may_change_text,
                                                  const std::function<CheckpointArrays()>& prepare,
                                                  const std::function<void()>& finish, std::string& warning,
                                                  const CheckpointPart* part = nullptr,
                                                  std::uint64_t* bytes_read = nullptr);

}  // namespace grainbath
