#include "core/run_support.hpp"

#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <stdexcept>

namespace grainbath {

namespace fs = std::filesystem;

OutputDirectory::OutputDirectory(fs::path final_path) : final_(std::move(final_path)) {
  std::error_code ec;
  fs::path parent = final_.has_parent_path() ? final_.parent_path() : fs::path(".");
  if (!fs::exists(parent, ec)) fs::create_directories(parent, ec);
  if (ec || !fs::is_directory(parent))
    throw std::runtime_error(parent.string() + ": cannot create the output's parent directory");
  tmp_ = final_;
  tmp_ += ".tmp-" + std::to_string(::getpid());
  fs::remove_all(tmp_, ec);
  if (!fs::create_directory(tmp_, ec) || ec)
    throw std::runtime_error(tmp_.string() + ": cannot create the output directory (not writable?)");
}

OutputDirectory::~OutputDirectory() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(tmp_, ec);
  }
}

void OutputDirectory::commit() {
  std::error_code ec;
  if (fs::exists(final_, ec)) {
    fs::path previous = final_;
    previous += ".previous";
    fs::remove_all(previous, ec);
    fs::rename(final_, previous, ec);
    if (ec) throw std::runtime_error(final_.string() + ": cannot move the previous output aside: " + ec.message());
  }
  fs::rename(tmp_, final_, ec);
  if (ec) throw std::runtime_error(final_.string() + ": cannot move the new output into place: " + ec.message());
  committed_ = true;
}

void write_file_atomic(const fs::path& path, const std::string& text) {
  fs::path tmp = path;
  tmp += ".partial";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error(tmp.string() + ": cannot open for writing");
    out << text;
    out.flush();
    if (!out) throw std::runtime_error(tmp.string() + ": write failed (disk full?)");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) throw std::runtime_error(path.string() + ": cannot rename into place: " + ec.message());
}

Progress::Progress(std::string label, double total, bool quiet)
    : label_(std::move(label)), total_(total), quiet_(quiet), tty_(::isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()), last_draw_(start_) {}

static std::string format_duration(double s) {
  char b[32];
  if (!std::isfinite(s) || s < 0) return "?";
  if (s < 60) std::snprintf(b, sizeof b, "%.0fs", s);
  else if (s < 3600) std::snprintf(b, sizeof b, "%dm%02ds", int(s) / 60, int(s) % 60);
  else std::snprintf(b, sizeof b, "%dh%02dm", int(s) / 3600, (int(s) % 3600) / 60);
  return b;
}

void Progress::update(double done, const std::string& extra) {
  if (quiet_ || total_ <= 0) return;
  const auto now = std::chrono::steady_clock::now();
  const double frac = std::min(1.0, std::max(0.0, done / total_));
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double eta = frac > 0 ? elapsed * (1 - frac) / frac : NAN;
  if (tty_) {
    if (std::chrono::duration<double>(now - last_draw_).count() < 0.2 && frac < 1.0) return;
    last_draw_ = now;
    const int width = 24, filled = static_cast<int>(frac * width);
    std::fprintf(stderr, "\r%s [%s%s] %5.1f%%  elapsed %s  ETA %s  %s\033[K", label_.c_str(),
                 std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(), 100 * frac,
                 format_duration(elapsed).c_str(), format_duration(eta).c_str(), extra.c_str());
  } else {
    const int decile = static_cast<int>(frac * 10);
    if (decile <= last_decile_) return;
    last_decile_ = decile;
    std::fprintf(stderr, "%s %3d%%  elapsed %s  ETA %s  %s\n", label_.c_str(), decile * 10,
                 format_duration(elapsed).c_str(), format_duration(eta).c_str(), extra.c_str());
  }
  std::fflush(stderr);
}

void Progress::finish() {
  if (quiet_) return;
  if (tty_) std::fprintf(stderr, "\n");
}

MeanError block_average(const std::vector<double>& series) {
  MeanError r;
  r.samples = series.size();
  if (series.empty()) return {NAN, NAN, 0};
  std::vector<double> x = series;
  double sum = 0;
  for (double v : x) sum += v;
  r.mean = sum / x.size();
  if (x.size() < 2) {
    r.stderr_ = NAN;
    return r;
  }
  double best = 0.0;
  while (x.size() >= 16) {
    const double n = static_cast<double>(x.size());
    double m = 0;
    for (double v : x) m += v;
    m /= n;
    double var = 0;
    for (double v : x) var += (v - m) * (v - m);
    var /= (n - 1);
    best = std::max(best, std::sqrt(var / n));
    std::vector<double> y(x.size() / 2);
    for (std::size_t i = 0; i < y.size(); ++i) y[i] = 0.5 * (x[2 * i] + x[2 * i + 1]);
    x.swap(y);
  }
  if (best == 0.0 && series.size() < 16) {  // too short to block: plain (optimistic) error
    double var = 0;
    for (double v : series) var += (v - r.mean) * (v - r.mean);
    best = std::sqrt(var / (series.size() - 1) / series.size());
  }
  r.stderr_ = best;
  return r;
}

namespace {
// the "cpu" line of /proc/stat: all CPUs' time in clock ticks, and the part spent idle or
// waiting for I/O
bool cpu_ticks(unsigned long long& total, unsigned long long& idle) {
  std::FILE* f = std::fopen("/proc/stat", "r");
  if (f == nullptr) return false;
  unsigned long long v[8] = {};
  const int n = std::fscanf(f, "cpu %llu %llu %llu %llu %llu %llu %llu %llu", &v[0], &v[1], &v[2], &v[3], &v[4],
                            &v[5], &v[6], &v[7]);
  std::fclose(f);
  if (n < 5) return false;
  total = 0;
  for (int k = 0; k < n; ++k) total += v[k];
  idle = v[3] + v[4];
  return true;
}
}  // namespace

int available_cores() {
  cpu_set_t set;
  if (sched_getaffinity(0, sizeof set, &set) == 0) return std::max(1, CPU_COUNT(&set));
  return static_cast<int>(std::max(1L, sysconf(_SC_NPROCESSORS_ONLN)));
}

CoreUse core_use(double window_seconds) {
  CoreUse u;
  u.cores = available_cores();
  unsigned long long t0 = 0, i0 = 0, t1 = 0, i1 = 0;
  if (cpu_ticks(t0, i0)) {
    struct timespec pause {};
    pause.tv_sec = static_cast<time_t>(window_seconds);
    pause.tv_nsec = static_cast<long>((window_seconds - static_cast<double>(pause.tv_sec)) * 1e9);
    nanosleep(&pause, nullptr);
    if (cpu_ticks(t1, i1) && t1 > t0) {
      // every CPU of the machine, as a count of CPUs busy (this process slept throughout)
      const long cpus = std::max(1L, sysconf(_SC_NPROCESSORS_ONLN));
      u.busy = static_cast<double>(cpus) * static_cast<double>((t1 - t0) - (i1 - i0)) / static_cast<double>(t1 - t0);
    }
  }
  if (std::FILE* f = std::fopen("/proc/loadavg", "r")) {
    double l1 = 0, l5 = 0, l15 = 0;
    int running = 0, total = 0;
    if (std::fscanf(f, "%lf %lf %lf %d/%d", &l1, &l5, &l15, &running, &total) == 5)
      u.other_runnable = std::max(0, running - 1);  // this process is running while it reads
    std::fclose(f);
  }
  return u;
}

int busy_cores(const CoreUse& u) {
  const int from_time = static_cast<int>(std::lround(std::max(0.0, u.busy)));
  return std::min(u.cores, std::max(from_time, u.other_runnable));
}

int automatic_threads(const CoreUse& u) { return std::max(1, u.cores - busy_cores(u)); }

double wall_seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

int fault_checkpoint_rank() {
  static const int r = [] {
    const char* v = std::getenv("GRAINBATH_FAULT_CHECKPOINT_RANK");
    if (!v || !*v) return -1;
    char* end = nullptr;
    const long x = std::strtol(v, &end, 10);
    return (*end == '\0' && x >= 0) ? static_cast<int>(x) : -1;
  }();
  return r;
}

std::int64_t fault_nonfinite_sample() {
  static const std::int64_t k = [] {
    const char* v = std::getenv("GRAINBATH_FAULT_NONFINITE_SAMPLE");
    if (!v || !*v) return std::int64_t{-1};
    char* end = nullptr;
    const long long x = std::strtoll(v, &end, 10);
    return (*end == '\0' && x >= 0) ? static_cast<std::int64_t>(x) : std::int64_t{-1};
  }();
  return k;
}

std::string utc_timestamp() {
  std::time_t t = std::time(nullptr);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return b;
}

}  // namespace grainbath
