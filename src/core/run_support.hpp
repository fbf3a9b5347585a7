#pragma once
// What every driver needs around its loop: a safe output directory, a progress line,
// block-averaged statistics, wall-clock timing.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace grainbath {

// Thrown by a solver that stopped on a stop request (a signal) after writing its checkpoint;
// the CLI exits with 130. Under MPI every rank throws it at the same step (the ranks agree on
// the stop), so they can all leave normally instead of through MPI_Abort.
struct RunInterrupted : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Results are written into a temporary sibling directory and moved into place only when
// the run succeeded, so an existing output directory is never clobbered half-way. The
// previous output, if any, is kept as OUT.previous (and the one before it deleted).
// Because of that deletion only grainbath's own output is ever moved aside: the
// constructor (at start-up, before any work) refuses an OUT that is a file, a non-empty
// directory grainbath did not write (holds_grainbath_output), the current directory or
// one of its ancestors, or a directory holding one of `keep` (the case directory), and an
// OUT.previous that is not grainbath output either. If the final move fails, the
// temporary directory with the finished results is kept and named in the error.
class OutputDirectory {
 public:
  // throws std::runtime_error
  explicit OutputDirectory(std::filesystem::path final_path, const std::vector<std::filesystem::path>& keep = {});
  ~OutputDirectory();
  OutputDirectory(const OutputDirectory&) = delete;
  OutputDirectory& operator=(const OutputDirectory&) = delete;
  const std::filesystem::path& tmp() const { return tmp_; }
  const std::filesystem::path& final_path() const { return final_; }
  // moves the results into place; returns a note on what happened to an earlier output there
  // ("" when there was none), for the run to print: an older OUT.previous is deleted
  std::string commit();

 private:
  std::filesystem::path final_, tmp_;
  bool committed_ = false, keep_tmp_ = false;
  int lock_fd_ = -1;  // the temporary's marker, flock-ed for the run's life (live-run test)
};

// A word for a POSIX shell: as is when it needs no quoting, else in single quotes with any
// single quote inside written '\'' (for the commands printed to resume a run or a sweep).
std::string shell_quote(const std::string& word);

// Whether `dir` holds what grainbath writes: the marker file every run and sweep directory
// gets (mark_output_directory), or, for directories from before the marker, a run's
// results.h5 with grainbath's summary.json, a sweep's sweep.tsv, or variant-* runs. Only
// such a directory (or an empty one) is moved aside or deleted by a run or a sweep.
bool holds_grainbath_output(const std::filesystem::path& dir);
void mark_output_directory(const std::filesystem::path& dir);

// The checks of OutputDirectory's constructor for `out` (and out.previous), for callers that
// write into `out` directly (a sweep): throws std::runtime_error naming the path, what was
// found and what to do. Returns the path checked (absolute, its directories resolved), which
// is the path to move aside and write.
std::filesystem::path check_output_path(const std::filesystem::path& out,
                                        const std::vector<std::filesystem::path>& keep = {});

// Writes text to `path` via a temporary file and rename (atomic on POSIX).
void write_file_atomic(const std::filesystem::path& path, const std::string& text);

// A progress line with ETA: redrawn in place on a terminal, one line per 10% otherwise.
class Progress {
 public:
  Progress(std::string label, double total, bool quiet = false);
  void update(double done, const std::string& extra = "");
  void finish();

 private:
  std::string label_;
  double total_;
  bool quiet_, tty_;
  int last_decile_ = -1;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

struct MeanError {
  double mean = 0.0;
  double stderr_ = 0.0;  // standard error of the mean, corrected for correlations
  std::size_t samples = 0;
  // Whether the blocking reached a plateau: some level's blocks are long enough by the
  // criterion of Lee, Needs & Drummond (Phys. Rev. B 83, 245122 (2011), eq. 14; pyblock):
  // blocks of m samples with m^3 > 2 n (e_m/e_1)^4, e_1 the error of uncorrelated samples,
  // (e_m/e_1)^2 the measured statistical inefficiency. false: the series is correlated over a
  // good part of the window, the blocks (at least 16) stay shorter than the correlation, and
  // stderr_ is a lower bound (use independent replicas). A series that drifts through the
  // window (a transient) trips it too.
  bool plateau = true;
  // Whether the series is long enough for that test to say anything: blocks of at most n/16
  // samples pass it even for uncorrelated samples only when n > 90. false: plateau is false
  // too, but it means "not known" (summary.json leaves the flag out): the error assumes correlations
  // shorter than the longest blocks.
  bool plateau_judged = true;
};

// Flyvbjerg-Petersen blocking: the standard error is taken as the largest estimate over
// blocking levels that keep at least 16 blocks (conservative for correlated series).
MeanError block_average(const std::vector<double>& series);

// The same for a series whose correlations decay in `clock` rather than in the sample index
// (clock non-decreasing, one value per sample): e.g. a free-cooling gas sampled at equal times
// whose collision rate falls as sqrt(T), where the correlation time of a2 is a fixed number of
// collisions per grain but a growing number of samples. The blocks span equal lengths of the
// clock (2^j of them, j down to 16 blocks, a level skipped while a block is empty) and the
// variance of the plain sample mean is the clustered estimate sum_b S_b^2 / n^2 * B/(B-1), S_b
// the sum of (x - mean) over block b (equal blocks: the Flyvbjerg-Petersen estimate). The mean
// is the plain sample mean. A clock that does not advance falls back to block_average(series).
MeanError block_average(const std::vector<double>& series, const std::vector<double>& clock);

double wall_seconds_since(std::chrono::steady_clock::time_point start);

// `[run] threads = 0` (automatic): the cores not taken by other processes. OpenMP threads
// wait for each other at every barrier by spinning; with one of them on a core another job
// is using, a 2-thread DSMC run was measured 10-30x slower than on one thread
// (docs/performance/dsmc-cases.md; 13x for cases/density-mode on 2026-11-26), while one
// thread too few costs at most the share of that core. Results do not depend on the count,
// so it is chosen from the machine's state at start: the cores busy with other processes are
// the larger of the CPU time the machine spent outside idle over a short window while this
// process slept (/proc/stat, in cores, rounded) and the runnable tasks other than this one at
// the end of it (/proc/loadavg). Not the load average: it lags by a minute, so a run started
// right after a previous run would count that run as another job.
struct CoreUse {
  int cores = 1;              // cores this process may run on
  double busy = 0.0;          // cores' worth of CPU time other processes used over the window
  int other_runnable = 0;     // runnable tasks at its end, this one not counted
};
int available_cores();  // the cores this process may run on (affinity: taskset, cgroup cpusets)
CoreUse core_use(double window_seconds = 0.1);  // this machine, now (Linux /proc; none seen elsewhere)
int busy_cores(const CoreUse& u);
int automatic_threads(const CoreUse& u);  // cores - busy, at least 1

// Test hook for the non-finite monitors (issue #8, docs/RELIABILITY.md): when the
// environment variable GRAINBATH_FAULT_NONFINITE_SAMPLE = K is set, the drivers replace the
// temperature of their K-th sample (0 = the initial one) by NaN, so that tests can show the
// run stops with a clear message and a checkpoint. -1 when unset or not a whole number.
std::int64_t fault_nonfinite_sample();
// Test hook: GRAINBATH_FAULT_CHECKPOINT_RANK=r makes MPI rank r fail when it writes its part
// of a checkpoint (-1: unset), to test that every rank stops with the same message.
int fault_checkpoint_rank();
std::string utc_timestamp();

}  // namespace grainbath
