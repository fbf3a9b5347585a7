#pragma once
// Running the real grainbath binary from a test: a fresh temporary directory per test, the
// child's cwd inside it, stdout/stderr captured through pipes (nothing written to disk),
// optional resource limits, and a recursive listing to prove nothing else was written.
#include <sys/resource.h>

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace grainbath::testing {

namespace fs = std::filesystem;

class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }
  fs::path operator/(const std::string& s) const { return path_ / s; }

 private:
  fs::path path_;
};

struct RunResult {
  bool exited = false;  // false: killed by a signal (or timed out)
  int code = -1;        // exit status if exited
  int signal = 0;       // terminating signal otherwise
  bool timed_out = false;
  std::string out, err;
  std::string describe() const;  // "exit 2" / "signal 11"; with stderr, for failure messages
};

struct RunOptions {
  fs::path cwd;
  std::optional<rlim_t> file_size_limit;  // RLIMIT_FSIZE in bytes, with SIGXFSZ ignored
  bool ignore_sigxfsz = true;             // as a full disk does not signal: writes fail with EFBIG
  std::optional<rlim_t> address_space_limit;  // RLIMIT_AS in bytes (allocations beyond it fail)
  double timeout_s = 60;
  int send_signal = 0;                    // if set: sent once stderr contains send_when (then 0.3 s later)
  std::string send_when;
  fs::path send_when_exists;              // if set too: and once this path exists (a quiet process)
  std::string send_again_when;            // if set: the same signal once more when stderr contains it
  double pause_before_again_s = 0;        // if > 0: the child is stopped (SIGSTOP) this long before that
                                          // repeat, then continued: a repeat that much later, with the
                                          // run held where it was meanwhile
  std::vector<std::pair<std::string, std::string>> env;  // extra environment variables
  std::vector<int> ignored_signals;       // ignored in the child from the start, as nohup ignores SIGHUP
  bool close_stdout = false;              // the child's stdout a pipe nobody reads (`| head` after its lines)
  bool stdout_to_dev_full = false;        // the child's stdout /dev/full (every write fails: ENOSPC)
};

RunResult run_binary(const std::vector<std::string>& args, const RunOptions& opt);

// path (relative to root) -> size, or -1 for a directory; every entry below root.
std::map<std::string, long long> listing(const fs::path& root);

void write_text(const fs::path& p, const std::string& text);
std::string read_text(const fs::path& p);

}  // namespace grainbath::testing
