#pragma once
// Checkpoints: the whole DSMC State in one HDF5 file, written to a temporary name, flushed
// and renamed (the previous checkpoint is kept). A 64-bit checksum over every dataset
// detects truncated or corrupt files; resume falls back to the previous one with a warning.
// The file machinery is shared with EDMD (core/checkpoint.hpp).
#include <filesystem>
#include <optional>
#include <string>

#include "core/run_context.hpp"
#include "dsmc/dsmc.hpp"
#include "dsmc/state.hpp"

namespace grainbath::dsmc {

class Decomposition;

// Collective over the ranks of `dec`. The file is the one a single process holding the
// whole state writes (the same datasets, order and values, byte for byte; docs/dsmc.md):
// rank 0 writes the counters, series, per-cell data (gathered: O(cells)) and its own
// grains, then each rank in turn adds its grains at their global offset. No rank holds
// another's grains. A rank that fails makes every rank throw the same message.
void write_checkpoint(const std::filesystem::path& dir, const State& s, const RunContext& ctx,
                      const Decomposition& dec);

// The newest checkpoint in `dir` that verifies, or nullopt. `warning` receives a message
// for every checkpoint skipped as corrupt. Throws if the case differs from the checkpoint's
// in anything but t_end and the [checkpoint] settings.
// Several ranks (dec): collective; each rank reads only its own grains' slabs of the
// per-grain arrays (the cell ranges chosen from the positions, each rank counting an equal
// share of them: Decomposition::plan_restart) and the small arrays whole, and the ranks
// verify the file's checksum together, passing its state along in rank order (each byte of
// a per-grain array read by one rank); then Decomposition::distribute(s, c, true).
// `bytes_read` is increased by the dataset bytes this rank read (docs/OUTPUT.md,
// performance.checkpoint_read_bytes_*). `saved_t_end`, if given, receives the dsmc.t_end the
// loaded checkpoint was written with (its /parameters; empty if unreadable), for messages.
std::optional<State> read_newest_checkpoint(const std::filesystem::path& dir, const RunContext& ctx,
                                            std::string& warning, const Config& c, Decomposition& dec,
                                            std::uint64_t& bytes_read, std::string* saved_t_end = nullptr);

// The names of a checkpoint's arrays in list order: the order of the file's checksum
// (core/checkpoint.hpp, Fnv1a), for tools and tests that rewrite a checkpoint as an earlier
// build would have written it (tests/dsmc/test_dsmc_restart.cpp).
std::vector<std::string> checkpoint_array_names();

}  // namespace grainbath::dsmc
