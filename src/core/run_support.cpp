#include "core/run_support.hpp"

#include <sched.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <sstream>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <iterator>
#include <stdexcept>

namespace grainbath {

namespace fs = std::filesystem;

// The marker every run and sweep directory gets (OutputDirectory, sweep.cpp); directories
// from before it (2026-11-26) are recognised by their contents, read, not by their names
// alone: a run's results.h5 beside a summary.json that has grainbath's run.seed and
// run.version, a sweep's sweep.tsv whose header starts with "variant", or variant-*
// directories that are such runs.
const char* const kOutputMarker = ".grainbath-output";

namespace {

// a is b or lies below it (both absolute and normalised: weakly_canonical)
bool is_within(const fs::path& a, const fs::path& b) {
  auto ia = a.begin(), ib = b.begin();
  for (; ib != b.end(); ++ia, ++ib) {
    if (ib->empty() && std::next(ib) == b.end()) break;  // b's trailing separator
    if (ia == a.end() || *ia != *ib) return false;
  }
  return true;
}

// p absolute with its directories resolved in order (symbolic links, then . and .., as the
// kernel does: "link/../x" is x beside the link's target), its last component kept as given
// so that a link named as the output is seen as a link (check_replaceable). A lexical
// normalisation first would resolve ".." before the link and name another directory.
fs::path normalised(const fs::path& p) {
  fs::path q = fs::absolute(p);
  while (!q.has_filename() && q.has_parent_path() && q != q.root_path()) q = q.parent_path();  // "out/"
  std::error_code ec;
  const fs::path name = q.filename();
  if (name == "." || name == "..") {  // a directory named by . or ..: resolve it whole
    const fs::path r = fs::weakly_canonical(q, ec);
    return ec ? q.lexically_normal() : r;
  }
  if (!q.has_parent_path() || q == q.root_path()) return q;
  const fs::path parent = fs::weakly_canonical(q.parent_path(), ec);
  return ec ? q.lexically_normal() : parent / name;
}

// p with every symbolic link resolved (for containment)
fs::path resolved(const fs::path& p) {
  std::error_code ec;
  const fs::path q = fs::weakly_canonical(fs::absolute(p), ec);
  return ec ? normalised(p) : normalised(q);
}

bool empty_directory(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec) && fs::is_empty(p, ec) && !ec;
}

// `what` (OUT or OUT.previous) would be moved aside or deleted: only grainbath's own output
void check_replaceable(const fs::path& p, const std::string& shown, const std::string& fate) {
  std::error_code ec;
  const auto st = fs::symlink_status(p, ec);
  if (ec || !fs::exists(st)) return;
  // moving a link aside would write the results beside it, not where it points
  if (fs::is_symlink(st))
    throw std::runtime_error(shown + ": is a symbolic link; grainbath " + fate +
                             " at the end of a run, which would move the link, not write where it points: give the "
                             "directory it points to (" + fs::read_symlink(p, ec).string() + "), or another path");
  if (!fs::is_directory(st))
    throw std::runtime_error(shown + ": exists and is not a directory (grainbath writes a directory there and " + fate +
                             "): choose another --out, or move the file away");
  if (!empty_directory(p) && !holds_grainbath_output(p))
    throw std::runtime_error(shown + ": exists and does not hold grainbath output (no " + std::string(kOutputMarker) +
                             ", no run's results.h5 and summary.json, no sweep.tsv or variant-* runs in it); grainbath " +
                             fate +
                             ", so it only takes a directory it wrote: choose another --out, or empty or remove " +
                             shown + " yourself");
}

}  // namespace


namespace {
bool holds_run_output(const fs::path& dir) {
  std::error_code ec;
  if (fs::exists(dir / kOutputMarker, ec)) return true;
  if (!fs::is_regular_file(dir / "results.h5", ec)) return false;
  std::ifstream in(dir / "summary.json");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return text.find("\"run\"") != std::string::npos && text.find("\"seed\"") != std::string::npos &&
         text.find("\"version\"") != std::string::npos;
}
}  // namespace

bool holds_grainbath_output(const fs::path& dir) {
  if (holds_run_output(dir)) return true;
  std::error_code ec;
  {
    std::ifstream in(dir / "sweep.tsv");
    std::string header;
    if (in && std::getline(in, header) && header.rfind("variant", 0) == 0) return true;
  }
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (it->path().filename().string().rfind("variant-", 0) == 0 && it->is_directory(ec) && holds_run_output(it->path()))
      return true;
  return false;
}

void mark_output_directory(const fs::path& dir) {
  std::ofstream(dir / kOutputMarker) << "written by grainbath (docs/OUTPUT.md): --out may replace this directory\n";
}

namespace {

std::string host_name() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "?";
  return name;
}

// The marker of a run's temporary directory names the run's host and process (for people),
// and the run holds an exclusive flock on it for its whole life: that lock, not the process
// id, tells a later run whether the temporary belongs to a live run (a process id says
// nothing across hosts of a shared file system or across PID namespaces, and is reused).
void mark_temporary_directory(const fs::path& dir) {
  std::ofstream(dir / kOutputMarker) << "written by grainbath (docs/OUTPUT.md): --out may replace this directory\n"
                                     << "temporary of the run on host " << host_name() << " process " << ::getpid()
                                     << "\n";
}

enum class Holder { none, live, unknown };

// Whether a live process holds the flock on `marker` (unknown: no marker, or the file system
// has no locks). Taking the lock briefly to test it is harmless: a run takes it only once,
// when it creates its temporary directory.
Holder lock_holder(const fs::path& marker) {
  const int fd = ::open(marker.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Holder::unknown;
  Holder h = Holder::none;
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) h = errno == EWOULDBLOCK ? Holder::live : Holder::unknown;
  ::close(fd);
  return h;
}

std::string read_small(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The temporary directories OUT.tmp-* that other runs into OUT left or are writing. A live
// one means another run writes OUT now: refused (two runs into one OUT would replace each
// other's results and prune each other's checkpoints). A dead run's temporary (its lock
// free, its marker a temporary's, no summary.json) is removed with a note; complete results
// (a summary.json: the run died between its final renames) and results kept after a failed
// final move (re-marked as plain output) are only named. `mine` is skipped.
void clear_other_temporaries(const fs::path& final_path, const fs::path& mine) {
  const fs::path parent = final_path.has_parent_path() ? final_path.parent_path() : fs::path(".");
  const std::string prefix = final_path.filename().string() + ".tmp-";
  std::error_code ec;
  std::vector<fs::path> found;
  for (const auto& e : fs::directory_iterator(parent, ec))
    if (e.path().filename().string().rfind(prefix, 0) == 0 && e.path() != mine &&
        fs::is_directory(fs::symlink_status(e.path(), ec)))
      found.push_back(e.path());
  std::sort(found.begin(), found.end());
  for (const fs::path& t : found) {
    const std::string marker = read_small(t / kOutputMarker);
    if (marker.empty()) continue;  // not grainbath's
    const bool temporary = marker.find("temporary of the run") != std::string::npos;
    const Holder holder = lock_holder(t / kOutputMarker);
    if (holder == Holder::live)
      throw std::runtime_error(final_path.string() + ": another run is writing it now (its temporary directory " +
                               t.string() + " is in use; " +
                               (temporary ? marker.substr(marker.find("temporary of the run")) : std::string("\n")) +
                               "wait for that run to end, or choose another --out");
    if (temporary && holder == Holder::none && !fs::exists(t / "summary.json", ec)) {
      fs::remove_all(t, ec);
      std::fprintf(stderr, "note: removed %s, the temporary output of an earlier run that did not finish\n",
                   t.string().c_str());
    } else if (fs::exists(t / "summary.json", ec) || !temporary) {
      std::fprintf(stderr, "note: %s holds the results of an earlier run that were not moved into place: look at "
                           "them, and remove the directory when it is no longer needed\n", t.string().c_str());
    } else {
      std::fprintf(stderr, "note: %s is the temporary output of another run (this file system cannot tell whether "
                           "it is still running): remove it if no run is writing it\n", t.string().c_str());
    }
  }
}

}  // namespace

fs::path check_output_path(const fs::path& out, const std::vector<fs::path>& keep) {
  const std::string shown = out.string();
  const fs::path full = normalised(out), target = resolved(out);
  std::error_code ec;
  // OUT's siblings must fit the file system's limit on a name too: the longest is
  // OUT.checkpoints.previous (OUT.tmp-PID-N and OUT.previous are shorter). A name that fits
  // alone but not with them would fail only later: a second sweep could not move the first
  // aside, a run's checkpoints could not be kept, after the work.
  {
    constexpr std::size_t kLongestSuffix = std::char_traits<char>::length(".checkpoints.previous");
    fs::path dir = full.parent_path();
    while (!dir.empty() && !fs::is_directory(dir, ec) && dir.has_parent_path() && dir != dir.parent_path())
      dir = dir.parent_path();  // the nearest existing ancestor decides the file system
    const long limit = ::pathconf(dir.empty() ? "." : dir.c_str(), _PC_NAME_MAX);
    const std::size_t name_max = limit > 0 ? static_cast<std::size_t>(limit) : 255;
    const std::size_t bytes = full.filename().native().size();
    if (bytes + kLongestSuffix > name_max)
      throw std::runtime_error(shown + ": its last name is " + std::to_string(bytes) +
                               " bytes long; grainbath writes siblings beside it (NAME.previous, NAME.tmp-PID, "
                               "NAME.checkpoints.previous) and this file system allows " + std::to_string(name_max) +
                               " bytes per name, so NAME may have at most " + std::to_string(name_max - kLongestSuffix) +
                               ": choose a shorter --out");
  }
  const fs::path cwd = resolved(fs::current_path(ec));
  if (!ec && is_within(cwd, target))
    throw std::runtime_error(shown + ": is the current directory or contains it; the output directory is replaced as a "
                             "whole at the end of a run: choose an --out that does not contain the directory you "
                             "run from");
  for (const auto& k : keep)
    if (!k.empty() && is_within(resolved(k), target))
      throw std::runtime_error(shown + ": would hold " + k.string() +
                               " (the case directory); the output directory is replaced as a whole at the end of a "
                               "run: choose an --out that does not contain it, e.g. " + (fs::path(k) / "output").string() +
                                   " (the default)");
  check_replaceable(full, shown, "moves the previous output aside to " + shown + ".previous");
  // out.previous is deleted only when there is an output to move there
  if (!fs::exists(fs::symlink_status(full, ec))) return full;
  fs::path previous = full;
  previous += ".previous";
  check_replaceable(previous, shown + ".previous", "deletes the output kept there when a newer one is moved aside");
  return full;
}

OutputDirectory::OutputDirectory(fs::path final_path, const std::vector<fs::path>& keep)
    : final_(std::move(final_path)) {
  // the path checked is the path used (absolute, directories resolved; "out/" is out, whose
  // temporary and previous siblings go beside it)
  final_ = check_output_path(final_, keep);
  std::error_code ec;
  fs::path parent = final_.has_parent_path() ? final_.parent_path() : fs::path(".");
  if (!fs::exists(parent, ec)) fs::create_directories(parent, ec);
  if (ec || !fs::is_directory(parent))
    throw std::runtime_error(parent.string() + ": cannot create the output's parent directory");
  // this run's temporary, OUT.tmp-PID (-N after it when that name is taken: a process id of
  // another PID namespace, or results kept there), created and locked before the others are
  // looked at, so that of two runs starting together into one OUT neither misses the other
  for (int n = 0;; ++n) {
    tmp_ = final_;
    std::string suffix = ".tmp-";  // built piece by piece: GCC 12's -Wrestrict misfires on "-" + to_string(n)
    suffix += std::to_string(::getpid());
    if (n > 0) {
      suffix += '-';
      suffix += std::to_string(n);
    }
    tmp_ += suffix;
    if (fs::create_directory(tmp_, ec) && !ec) break;
    if (!fs::exists(fs::symlink_status(tmp_, ec)) || n > 100)
      throw std::runtime_error(final_.string() + ": cannot write the output: creating its temporary sibling " +
                               tmp_.filename().string() + " in " + parent.string() + " failed (" +
                               (ec ? ec.message() : std::string("it exists")) +
                               "); choose an --out in a writable directory");
  }
  mark_temporary_directory(tmp_);
  lock_fd_ = ::open((tmp_ / kOutputMarker).c_str(), O_RDONLY | O_CLOEXEC);
  if (lock_fd_ >= 0 && ::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    ::close(lock_fd_);
    lock_fd_ = -1;
  }
  try {
    clear_other_temporaries(final_, tmp_);
  } catch (...) {
    if (lock_fd_ >= 0) ::close(lock_fd_);
    fs::remove_all(tmp_, ec);
    throw;
  }
}

OutputDirectory::~OutputDirectory() {
  if (!committed_ && !keep_tmp_) {
    std::error_code ec;
    fs::remove_all(tmp_, ec);
  }
  if (lock_fd_ >= 0) ::close(lock_fd_);
}

std::string shell_quote(const std::string& word) {
  if (!word.empty() && word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789"
                                              "_-+=.,/:@%") == std::string::npos)
    return word;
  std::string q = "'";
  for (char c : word) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string OutputDirectory::commit() {
  std::error_code ec;
  std::string note;
  if (fs::exists(final_, ec)) {
    fs::path previous = final_;
    previous += ".previous";
    // the same checks as at start-up: something may have been put there during the run
    try {
      check_replaceable(previous, previous.string(), "deletes the output kept there when a newer one is moved aside");
      check_replaceable(final_, final_.string(), "moves the previous output aside");
    } catch (const std::exception& e) {
      keep_tmp_ = true;
      mark_output_directory(tmp_);  // kept results: no later run may take them for a dead run's
      throw std::runtime_error(std::string(e.what()) + "; the results of this run are kept in " + tmp_.string());
    }
    const bool had_previous = fs::exists(fs::symlink_status(previous, ec));
    fs::remove_all(previous, ec);
    fs::rename(final_, previous, ec);
    if (!ec)
      note = "the previous output in " + final_.string() + " was moved to " + previous.string() +
             (had_previous ? " (the older output there was deleted)" : "");
    if (ec) {
      keep_tmp_ = true;
      mark_output_directory(tmp_);  // kept results: no later run may take them for a dead run's
      throw std::runtime_error(final_.string() + ": cannot move the previous output aside (" + ec.message() +
                               "); the results of this run are kept in " + tmp_.string());
    }
  }
  mark_output_directory(tmp_);  // the results: no longer a temporary (the lock stays on the same file)
  fs::rename(tmp_, final_, ec);
  if (ec) {
    keep_tmp_ = true;
    mark_output_directory(tmp_);  // kept results: no later run may take them for a dead run's
    throw std::runtime_error(final_.string() + ": cannot move the new output into place (" + ec.message() +
                             "); the results of this run are kept in " + tmp_.string());
  }
  committed_ = true;
  return note;
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
  // no estimate before the rate is known: the first steps or events (set-up, cold caches,
  // an EDMD melt) are not the run's pace (an 18-minute ETA for a 40-second run, review 2)
  const double eta = frac >= 0.01 && elapsed >= 1.0 ? elapsed * (1 - frac) / frac : NAN;
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

namespace {
// Lee, Needs & Drummond (2011) eq. 14: a level of blocks of m samples (on average) is long
// enough when m^3 > 2 n (e_m/e_1)^4, e_1 the standard error of uncorrelated samples.
bool blocks_long_enough(double m, double n, double e_m, double e_1) {
  if (!(e_1 > 0)) return true;  // a constant series
  const double r = e_m / e_1;
  return m * m * m > 2 * n * r * r * r * r;
}
// Whether blocks of m samples could pass that test at all: even uncorrelated samples
// (e_m = e_1) need m^3 > 2 n, which blocks of at most n/16 samples meet only for n > 90
// (the clock blocking, 16 blocks of n/16; the halving of the index may need more)
bool blocks_could_pass(double m, double n) { return m * m * m > 2 * n; }
// A series constant up to rounding (the temperature of elastic grains, conserved exactly):
// its spread, ~1e-14 of the mean, is noise of the last bits, not a correlation to be judged
bool constant_up_to_rounding(double e_1, double mean) { return e_1 <= 1e-12 * std::abs(mean); }

struct BlockLevel {
  double m, e, blocks;  // mean samples per block, the level's error, the number of blocks
};
struct PlateauVerdict {
  bool plateau = false, judged = false;
};
// Some level passes the test. e_m from B blocks is itself uncertain, by a relative standard
// error of about 1/sqrt(2(B - 1)) (B - 1 degrees of freedom). Where a single level can pass
// at all (windows of ~90-250 samples), the test is taken there with e_m one such error
// lower: on that one chance uncorrelated windows of 121 samples (16 blocks) failed in ~14 %
// of runs and warned of an unreliable error (review 4: 8 of 36 clean DSMC errors). With two
// or more such levels the test has several chances already and is left as it is: with the
// allowance there, windows whose blocked error is 1.5x too small passed (cases/rough-driven,
// R at mu = 0.5: 4 of 14 runs instead of 0).
PlateauVerdict judge_plateau(const std::vector<BlockLevel>& levels, double n, double e_1) {
  PlateauVerdict v;
  int judgeable = 0;
  for (const BlockLevel& l : levels) judgeable += blocks_could_pass(l.m, n);
  for (const BlockLevel& l : levels) {
    const bool could = blocks_could_pass(l.m, n);
    const double e = could && judgeable == 1 ? l.e / (1.0 + 1.0 / std::sqrt(2.0 * (l.blocks - 1.0))) : l.e;
    v.plateau = v.plateau || blocks_long_enough(l.m, n, e, e_1);
    v.judged = v.judged || could;
  }
  v.plateau = v.plateau && v.judged;
  return v;
}
}  // namespace

MeanError block_average(const std::vector<double>& series) {
  MeanError r;
  r.samples = series.size();
  // fewer than 2 samples: no error, and so nothing to judge (no `*_plateau` flag is written:
  // a flag true beside a null error said a plateau was reached, 2026-12-07)
  if (series.empty()) return {NAN, NAN, 0, false, false};
  std::vector<double> x = series;
  double sum = 0;
  for (double v : x) sum += v;
  r.mean = sum / x.size();
  if (x.size() < 2) {
    r.stderr_ = NAN;
    r.plateau = r.plateau_judged = false;
    return r;
  }
  double best = 0.0, first = -1.0;
  std::vector<BlockLevel> levels;
  while (x.size() >= 16) {
    const double n = static_cast<double>(x.size());
    double m = 0;
    for (double v : x) m += v;
    m /= n;
    double var = 0;
    for (double v : x) var += (v - m) * (v - m);
    var /= (n - 1);
    const double e = std::sqrt(var / n);
    if (first < 0) first = e;
    best = std::max(best, e);
    levels.push_back({static_cast<double>(series.size()) / n, e, n});
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
  const PlateauVerdict v = judge_plateau(levels, static_cast<double>(series.size()), first);
  r.plateau_judged = v.judged;  // false for fewer than ~91 samples (and below 16: no blocking)
  r.plateau = v.plateau;
  if (first >= 0 && constant_up_to_rounding(first, r.mean)) r.plateau_judged = r.plateau = true;
  return r;
}

MeanError block_average(const std::vector<double>& series, const std::vector<double>& clock) {
  const std::size_t n = series.size();
  if (clock.size() != n || n < 16 || !(clock.back() > clock.front())) return block_average(series);
  for (std::size_t k = 1; k < n; ++k)
    if (!(clock[k] >= clock[k - 1])) return block_average(series);
  MeanError r;
  r.samples = n;
  double sum = 0;
  for (double v : series) sum += v;
  r.mean = sum / static_cast<double>(n);
  double var1 = 0;  // the error of uncorrelated samples
  for (double v : series) var1 += (v - r.mean) * (v - r.mean);
  const double e1 = std::sqrt(var1 / static_cast<double>(n - 1) / static_cast<double>(n));
  std::size_t B = 1;
  while (2 * B <= n) B *= 2;
  const double c0 = clock.front(), span = clock.back() - c0;
  double best = 0.0;
  bool any = false;
  std::vector<BlockLevel> levels;
  std::vector<double> S;
  std::vector<std::size_t> count;
  for (; B >= 16; B /= 2) {
    S.assign(B, 0.0);
    count.assign(B, 0);
    for (std::size_t k = 0; k < n; ++k) {
      const auto b = std::min(B - 1, static_cast<std::size_t>(static_cast<double>(B) * (clock[k] - c0) / span));
      S[b] += series[k] - r.mean;
      ++count[b];
    }
    if (std::find(count.begin(), count.end(), std::size_t{0}) != count.end()) continue;  // too fine for the clock
    double ss = 0;
    for (double s : S) ss += s * s;
    const double e = std::sqrt(ss * static_cast<double>(B) / static_cast<double>(B - 1)) / static_cast<double>(n);
    best = std::max(best, e);
    any = true;
    levels.push_back({static_cast<double>(n) / static_cast<double>(B), e, static_cast<double>(B)});
  }
  if (!any) return block_average(series);
  r.stderr_ = best;
  const PlateauVerdict v = judge_plateau(levels, static_cast<double>(n), e1);
  r.plateau_judged = v.judged;
  r.plateau = v.plateau;
  if (constant_up_to_rounding(e1, r.mean)) r.plateau_judged = r.plateau = true;
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
