#pragma once
// What the CLI hands a solver: where to write, the seed, the case as given and resolved.
// A solver reads its own sections from the CaseReader (read_config), then run() writes
// OUT/results.h5 into `out_dir` (a temporary directory the CLI moves into place at the
// end) and fills the Summary that becomes summary.json.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

namespace grainbath {

struct RunContext {
  std::filesystem::path out_dir;      // temporary output directory (exists, writable)
  std::filesystem::path case_dir;
  std::uint64_t seed = 1;
  int threads = 1;
  bool quiet = false;                 // no progress line
  std::string case_text;              // case.toml as read (stored in results.h5)
  std::map<std::string, std::string> resolved;  // every parameter as used
  const std::atomic<bool>* stop_requested = nullptr;  // set by SIGINT/SIGTERM
  std::filesystem::path checkpoint_dir;  // where checkpoints go (empty: none)
  bool resume = false;                   // continue from the newest valid checkpoint
  std::string resume_command;            // the command line that resumes this run (messages)
  bool decompose = true;                 // MPI build: split a spatial DSMC run over all ranks
                                         // (false: this process runs alone, e.g. an ensemble replica)
};

// Writes the provenance every results.h5 carries: version, seed, case text, resolved
// parameters (as attributes of /parameters). Deterministic: no timestamps, so the same case
// and seed give a bitwise identical file.
class H5File;
void write_provenance(H5File& file, const RunContext& ctx, const std::string& solver);

}  // namespace grainbath
