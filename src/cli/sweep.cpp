// grainbath sweep CASE_DIR --set section.key=v1,v2,... : runs every combination of the
// listed values as a separate `grainbath run` (in parallel up to --jobs), then gathers the
// variants' summary.json into one table (sweep.tsv with every number, sweep.md with the
// headline columns) and one plot (scripts/plot_sweep.py, if Python with matplotlib is there).
// MPI build under mpirun: the ranks share the variants (each run alone in its rank's
// process) and rank 0 gathers; `--set run.seed=...` alone is the MPI ensemble mode.
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cctype>
#include <cmath>
#include <cerrno>
#include <cstdio>
#include <ctime>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "cli/commands.hpp"
#include "core/case_file.hpp"
#include "core/checkpoint.hpp"
#include "core/run_support.hpp"
#include "core/summary.hpp"
#include "dsmc/decomposition.hpp"

namespace grainbath::cli {

namespace fs = std::filesystem;

namespace {

// Splits "a,b,[1,2],c" at top-level commas (not inside brackets or quotes).
std::vector<std::string> split_values(const std::string& s) {
  std::vector<std::string> out;
  std::string cur;
  int depth = 0;
  bool quoted = false;
  for (char ch : s) {
    if (ch == '"') quoted = !quoted;
    if (!quoted && (ch == '[' || ch == '{')) ++depth;
    if (!quoted && (ch == ']' || ch == '}')) --depth;
    if (ch == ',' && depth == 0 && !quoted) {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += ch;
    }
  }
  out.push_back(cur);
  // "1, 2" is 1 and 2, as each run reads them (spaces around a value are the shell quoting's):
  // untrimmed, "1, 1" passed the repeated-value check and names and tables carried the space
  for (auto& v : out) v = std::string(trim(v));
  return out;
}

// A minimal reader for the summary.json grainbath writes: flattens every number (and
// boolean) to "a.b.c" -> value. Strings are skipped.
struct FlatJson {
  const std::string& s;
  std::size_t i = 0;
  std::map<std::string, double> out;
  void ws() {
    while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
  }
  std::string str() {
    std::string r;
    ++i;  // opening quote
    while (i < s.size() && s[i] != '"') {
      if (s[i] == '\\') ++i;
      if (i < s.size()) r += s[i++];
    }
    ++i;
    return r;
  }
  void value(const std::string& key) {
    ws();
    if (i >= s.size()) throw std::runtime_error("truncated JSON");
    if (s[i] == '{') {
      ++i;
      ws();
      if (s[i] == '}') {
        ++i;
        return;
      }
      for (;;) {
        ws();
        const std::string k = str();
        ws();
        ++i;  // ':'
        value(key.empty() ? k : key + "." + k);
        ws();
        if (s[i] == ',') {
          ++i;
          continue;
        }
        ++i;  // '}'
        return;
      }
    }
    if (s[i] == '"') {
      str();
      return;
    }
    if (s.compare(i, 4, "true") == 0) {
      out[key] = 1;
      i += 4;
      return;
    }
    if (s.compare(i, 5, "false") == 0) {
      out[key] = 0;
      i += 5;
      return;
    }
    if (s.compare(i, 4, "null") == 0) {
      out[key] = NAN;
      i += 4;
      return;
    }
    std::size_t used = 0;
    out[key] = std::stod(s.substr(i, 40), &used);
    i += used;
  }
};

std::map<std::string, double> read_summary(const fs::path& p) {
  std::ifstream in(p);
  if (!in) throw std::runtime_error(p.string() + ": missing (did the run fail?)");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  FlatJson j{text, 0, {}};
  j.value("");
  return j.out;
}

std::string read_text_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The lines of a sweep's identity (sweep.identity: the case text, the --set list, the checksums
// of the files the variants name) that differ between the stored sweep and this command, a
// few of each, for --resume's refusal: "--set: was ..., now ...", not only "differ" (review 4).
std::string identity_difference(const std::string& stored, const std::string& now) {
  auto lines = [](const std::string& t) {
    std::vector<std::string> v;
    std::istringstream in(t);
    for (std::string l; std::getline(in, l);) v.push_back(l);
    return v;
  };
  const std::vector<std::string> a = lines(stored), b = lines(now);
  auto only_in = [](const std::vector<std::string>& x, const std::vector<std::string>& y) {
    std::vector<std::string> r;
    for (const std::string& l : x)
      if (std::find(y.begin(), y.end(), l) == y.end()) r.push_back(l);
    return r;
  };
  auto shown = [](const std::vector<std::string>& v) {
    std::string t;
    for (std::size_t k = 0; k < v.size() && k < 3; ++k) t += (k ? ", " : "") + std::string("'") + v[k] + "'";
    if (v.size() > 3) t += " and " + std::to_string(v.size() - 3) + " more";
    return t.empty() ? std::string("nothing") : t;
  };
  const std::vector<std::string> gone = only_in(a, b), added = only_in(b, a);
  if (gone.empty() && added.empty()) return "the same lines in another order";
  return "the sweep's lines not in this command: " + shown(gone) + "; this command's lines not in the sweep: " + shown(added);
}

std::string read_case_text(const std::string& case_dir) { return read_text_file(fs::path(case_dir) / "case.toml"); }

// Stop requests to the sweep: counted when 2 s or more apart (a request delivered twice, e.g.
// to a whole process group and again by the sweep, is one request; commands.cpp on_signal)
std::atomic<int> g_sweep_signals{0};
std::atomic<long long> g_sweep_last_ns{0};
extern "C" void on_sweep_signal(int) {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  const long long now = static_cast<long long>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
  const long long last = g_sweep_last_ns.load();
  if (last != 0 && now - last < 2000000000LL) return;
  g_sweep_last_ns.store(now);
  g_sweep_signals.fetch_add(1);
}

std::string quote_arg(const std::string& x) { return shell_quote(x); }

// The command that continues an interrupted sweep: the user's command with every option it was
// given (a sweep option added to SweepArgs belongs here too), and --resume.
std::string continue_command(const SweepArgs& a, const std::string& self) {
  std::string cmd = quote_arg(self) + " sweep " + quote_arg(a.case_dir);
  if (!a.out_dir.empty()) cmd += " --out " + quote_arg(a.out_dir);
  if (a.jobs > 0) cmd += " -j " + std::to_string(a.jobs);
  if (a.quiet) cmd += " -q";
  for (const auto& o : a.overrides) cmd += " --set " + quote_arg(o);
  return cmd + " --resume";
}

// "12 s" (one decimal under 10 s): the wall times of the progress lines
std::string seconds_text(double s) {
  char b[32];
  std::snprintf(b, sizeof b, s < 10 ? "%.1f s" : "%.0f s", s);
  return b;
}

std::string sanitize(const std::string& s) {
  std::string r;
  for (char c : s) r += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-') ? c : '_';
  return r;
}

}  // namespace

int command_sweep(const SweepArgs& a) {
  // parse the swept keys
  std::vector<std::pair<std::string, std::vector<std::string>>> axes;
  std::map<std::string, std::string> given;  // key (spaces trimmed, as the run reads it) -> its --set
  for (const auto& o : a.overrides) {
    const auto eq = o.find('=');
    if (eq == std::string::npos) {
      std::fprintf(stderr, "error: --set %s: expected section.key=value1,value2,...\n", o.c_str());
      return 2;
    }
    // A key in two --set options: each run would take the later value, so a fixed value was
    // dropped without a word, or two axes over one key made runs that differ only in name
    const std::string key(trim(std::string_view(o).substr(0, eq)));
    if (const auto [at, fresh] = given.emplace(key, o); !fresh) {
      std::fprintf(stderr,
                   "error: --set %s: %s is also given by --set %s; give each key once, with all its values "
                   "(section.key=v1,v2,...)\n",
                   o.c_str(), key.c_str(), at->second.c_str());
      return 2;
    }
    axes.emplace_back(key, split_values(o.substr(eq + 1)));
    // A value given twice makes the same run twice: over run.seed, identical copies counted
    // as independent replicas (the ensemble error then too small: sqrt(3) with 1,1,2,2).
    const auto& values = axes.back().second;
    for (std::size_t i = 0; i < values.size(); ++i)
      for (std::size_t j = 0; j < i; ++j)
        if (values[i] == values[j]) {
          std::fprintf(stderr, "error: --set %s: the value %s is given twice; each value makes one run%s\n", o.c_str(),
                       values[i].c_str(),
                       axes.back().first == "run.seed" ? " (a repeated seed is the same run, not another replica)" : "");
          return 2;
        }
  }
  // A key given one value is a setting of every run, not an axis: it is passed to each run
  // but names no directory and no table column, and it does not stop a sweep over run.seed
  // alone from being an ensemble.
  std::vector<std::string> fixed;
  for (auto it = axes.begin(); it != axes.end();)
    if (it->second.size() == 1) {
      fixed.push_back(it->first + "=" + it->second[0]);
      it = axes.erase(it);
    } else {
      ++it;
    }
  std::vector<std::vector<std::string>> variants{{}};
  for (const auto& [key, values] : axes) {
    std::vector<std::vector<std::string>> next;
    for (const auto& v : variants)
      for (const auto& value : values) {
        auto w = v;
        w.push_back(key + "=" + value);
        next.push_back(w);
      }
    variants.swap(next);
  }
  // every run's overrides: the fixed settings, then its values of the axes
  auto overrides_of = [&](std::size_t k) {
    std::vector<std::string> o = fixed;
    o.insert(o.end(), variants[k].begin(), variants[k].end());
    return o;
  };
  // validate every variant before running any; a problem common to several variants (a key
  // of the file, a fixed --set) is printed once, with the variants it concerns
  int bad = 0;
  std::vector<std::pair<std::string, std::vector<std::size_t>>> problems;  // in order of first appearance
  for (std::size_t k = 0; k < variants.size(); ++k) {
    RunArgs ra;
    ra.case_dir = a.case_dir;
    ra.overrides = overrides_of(k);
    const auto found = case_problems(ra);
    bad += !found.empty();
    for (const auto& p : found) {
      auto at = std::find_if(problems.begin(), problems.end(), [&](const auto& q) { return q.first == p; });
      if (at == problems.end()) problems.push_back({p, {k}});
      else at->second.push_back(k);
    }
  }
  for (const auto& [p, in] : problems) {
    std::string which;
    if (variants.size() > 1 && in.size() == variants.size()) {
      which = " (every variant)";
    } else if (in.size() == 1 && variants.size() > 1) {
      which = " (variant " + std::to_string(in[0]);
      for (const auto& w : variants[in[0]]) which += (w == variants[in[0]].front() ? ": " : " ") + w;
      which += ")";
    } else if (variants.size() > 1) {
      which = " (variants";
      for (std::size_t i = 0; i < in.size() && i < 12; ++i) which += (i ? ", " : " ") + std::to_string(in[i]);
      if (in.size() > 12) which += ", ...";
      which += ")";
    }
    std::fprintf(stderr, "error: %s%s\n", p.c_str(), which.c_str());
  }
  if (bad) {
    std::fprintf(stderr, "%d of %zu variants are invalid; nothing was run.\n", bad, variants.size());
    return 2;
  }
  fs::path out = a.out_dir.empty() ? fs::path(a.case_dir) / "sweep" : fs::path(a.out_dir);
  if (!out.has_filename() && out.has_parent_path()) out = out.parent_path();  // "out/": out.previous beside it
  namespace mpi = dsmc::mpi_env;
  // A sweep writes into `out` as its runs finish, so an earlier sweep there is moved aside
  // to out.previous first (the runs of two sweeps must not mix in one table); as for a run,
  // only a directory grainbath wrote is moved aside (check_output_path), and exactly the path
  // checked is moved. Rank 0 alone checks and moves; the others learn the verdict in a
  // collective (a rank checking while rank 0 moves could see half a move).
  int refused = 0;
  fs::path checked;
  // what a sweep is: the case file's text and the --set list, recorded in the sweep directory
  // so that --resume continues the same sweep and nothing else
  std::string identity = "case.toml:\n" + read_case_text(a.case_dir) + "\n--set:\n";
  for (const auto& o : a.overrides) identity += o + "\n";
  // ... and what the files the variants name held (a background grid changed in place under
  // its name would otherwise mix two media in one table)
  for (std::size_t k = 0; k < variants.size(); ++k) {
    RunArgs ra;
    ra.case_dir = a.case_dir;
    ra.overrides = overrides_of(k);
    for (const std::string& sum : case_file_checksums(ra)) identity += "variant " + std::to_string(k + 1) + ": " + sum + "\n";
  }
  const std::string identity_file = "sweep.identity";
  if (mpi::world_rank() == 0) {
    try {
      checked = check_output_path(out, {fs::path(a.case_dir)});
      if (a.resume) {
        std::error_code e2;
        if (!fs::is_regular_file(checked / identity_file, e2))
          throw std::runtime_error(out.string() + ": no sweep to resume here (no " + identity_file +
                                   "; it is written by sweeps from 2026-11-27 on): run the sweep without --resume");
        if (const std::string stored = read_text_file(checked / identity_file); stored != identity)
          throw std::runtime_error(out.string() + ": the case file, the files it names or the --set list differ from the sweep's (" +
                                   (checked / identity_file).string() + " holds them; " +
                                   identity_difference(stored, identity) +
                                   "): --resume continues the same sweep only; to add values, run a new sweep "
                                   "into another --out with only the new values");
      }
    } catch (const std::exception& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      refused = 1;
    }
  }
  if (mpi::active()) refused = static_cast<int>(mpi::sum(refused));
  if (refused) return 2;
  std::error_code ec;
  if (!a.resume && mpi::world_rank() == 0 && fs::exists(checked, ec) && !fs::is_empty(checked, ec)) {
    fs::path previous = checked;
    previous += ".previous";
    // what is moved: a sweep (sweep.tsv or sweep.identity) or a single run's output
    const bool was_sweep = fs::exists(checked / "sweep.tsv", ec) || fs::exists(checked / identity_file, ec);
    const bool had_previous = fs::exists(fs::symlink_status(previous, ec));
    fs::remove_all(previous, ec);
    if (!ec) fs::rename(checked, previous, ec);
    if (ec) {
      std::fprintf(stderr, "error: %s: cannot move the previous sweep aside to %s (%s)\n", out.string().c_str(),
                   previous.string().c_str(), ec.message().c_str());
      if (mpi::active()) mpi::abort(2);
      return 2;
    }
    std::fprintf(stderr, "sweep: the previous %s in %s was moved to %s%s\n", was_sweep ? "sweep" : "output",
                 out.string().c_str(), previous.string().c_str(),
                 had_previous ? " (the older output there was deleted)" : "");
  }
  if (mpi::world_rank() == 0 && !a.resume) {
    fs::create_directories(out, ec);
    if (!ec) mark_output_directory(out);
    if (!ec) write_file_atomic(out / identity_file, identity);
  }
  if (mpi::active()) mpi::barrier();  // the other ranks write into `out` only after the move
  fs::create_directories(out, ec);
  if (ec) {
    std::fprintf(stderr, "error: %s: cannot create the sweep directory (%s)\n", out.string().c_str(),
                 ec.message().c_str());
    return 2;
  }
  // -j unset: the cores other processes leave free (core_use(), as a run's automatic threads;
  // review 4: all cores even on a busy machine), said when that is fewer than all. Results do
  // not depend on it.
  int jobs = a.jobs;
  if (jobs <= 0) {
    const CoreUse use = core_use();
    jobs = automatic_threads(use);
    if (jobs < use.cores && mpi::world_rank() == 0 && !mpi::active())
      std::fprintf(stderr,
                   "note: %d of %d cores busy with other processes: running %d variant(s) at a time; -j N chooses "
                   "(results do not depend on it)\n",
                   busy_cores(use), use.cores, jobs);
  }
  const std::string self = fs::canonical("/proc/self/exe").string();
  std::vector<fs::path> dirs;
  for (std::size_t k = 0; k < variants.size(); ++k) {
    std::string name = "variant-" + std::to_string(k);
    for (const auto& kv : variants[k]) name += "_" + sanitize(kv.substr(kv.find('.') + 1));
    dirs.push_back(out / name);
  }
  if (mpi::world_rank() == 0 && !a.quiet)
    std::fprintf(stderr, "sweep: %zu variants, %d at a time, into %s\n", variants.size(),
                 mpi::active() ? mpi::world_size() : jobs, out.string().c_str());
  std::size_t next = 0, done = 0;
  int running = 0, failed = 0;
  // --resume: a variant with its summary.json finished in the earlier sweep and is not run
  // again; one with checkpoints continues from them (grainbath run --resume); the others start
  auto finished = [&](std::size_t k) { return fs::is_regular_file(dirs[k] / "summary.json", ec); };
  auto resumable = [&](std::size_t k) { return count_checkpoints(checkpoint_directory(dirs[k])) > 0; };
  std::vector<char> skip(variants.size(), 0);
  if (a.resume) {
    std::size_t earlier = 0;
    for (std::size_t k = 0; k < variants.size(); ++k) earlier += skip[k] = finished(k);
    if (mpi::world_rank() == 0 && !a.quiet)
      std::fprintf(stderr, "sweep: resuming: %zu of %zu variants finished earlier\n", earlier, variants.size());
  }
  auto log_of = [&](std::size_t k) { return dirs[k].string() + ".log"; };
  // what became of each variant in this sweep (the counts of the progress lines and of an
  // interruption's summary say exactly this)
  enum : int { kNotStarted = 0, kRunning = 1, kDone = 2, kStopped = 3, kFailed = 4 };
  std::vector<int> state(variants.size(), kNotStarted);
  std::size_t finished_count = 0;  // the variants with their results, earlier ones (--resume) included
  for (std::size_t k = 0; k < variants.size(); ++k) finished_count += skip[k];
  // "(variant 12 s, sweep 30 s)": the variant's own wall time and the time since the sweep started
  auto times_text = [&](std::chrono::steady_clock::time_point variant_start, std::chrono::steady_clock::time_point sweep_start) {
    return "(variant " + seconds_text(wall_seconds_since(variant_start)) + ", sweep " +
           seconds_text(wall_seconds_since(sweep_start)) + " elapsed)";
  };
  // one progress line: finished variants are counted ("3/6 done": 3 of the 6 have their
  // results), a stopped or failed one is not; under MPI each rank says its own, uncounted
  auto progress = [&](std::size_t k, int code, const std::string& who, const std::string& times) {
    if (code == 0 && who.empty())
      std::fprintf(stderr, "sweep: %zu/%zu done     %s  %s\n", finished_count, variants.size(),
                   dirs[k].filename().string().c_str(), times.c_str());
    else if (code == 0)
      std::fprintf(stderr, "sweep: %sdone     %s  %s\n", who.c_str(), dirs[k].filename().string().c_str(), times.c_str());
    else if (code == 130)
      std::fprintf(stderr, "sweep: %sstopped     %s  %s, %s\n", who.c_str(), dirs[k].filename().string().c_str(),
                   times.c_str(), resumable(k) ? "with a checkpoint" : "before its first checkpoint");
    else
      std::fprintf(stderr, "sweep: %sFAILED      %s  %s, exit code %d: see %s\n", who.c_str(),
                   dirs[k].filename().string().c_str(), times.c_str(), code, log_of(k).c_str());
  };
  bool stopped = false;
  std::vector<int> handled;  // the stop signals the sweep handles (not those it inherited ignored)
  if (mpi::active()) {
    // rank r runs variants r, r + size, ... one after the other, in this process (a child
    // started from an MPI process would inherit its launcher environment); after a stop
    // request (the run's own handler, commands.cpp) no further variant starts
    const auto rank = static_cast<std::size_t>(mpi::world_rank()), size = static_cast<std::size_t>(mpi::world_size());
    const auto start = std::chrono::steady_clock::now();
    install_stop_handlers();  // also between variants: a stop then starts no more
    for (std::size_t k = rank; k < variants.size(); k += size) {
      if (skip[k] || stop_requested()) continue;
      RunArgs ra;
      ra.case_dir = a.case_dir;
      ra.overrides = overrides_of(k);
      if (size > 1) ra.overrides.push_back("run.threads=1");  // the ranks share the cores
      ra.out_dir = dirs[k].string();
      ra.quiet = true;
      ra.alone = true;
      ra.resume = a.resume && resumable(k);
      const auto variant_start = std::chrono::steady_clock::now();
      std::fflush(nullptr);
      const int saved_out = dup(STDOUT_FILENO), saved_err = dup(STDERR_FILENO);
      std::FILE* log = std::fopen(log_of(k).c_str(), a.resume ? "a" : "w");
      if (log) {
        dup2(fileno(log), STDOUT_FILENO);
        dup2(fileno(log), STDERR_FILENO);
      }
      CaseReader::forget_said_notes();  // this variant's notes into its log too (review 3)
      const int code = command_run(ra);
      std::fflush(nullptr);
      dup2(saved_out, STDOUT_FILENO);
      dup2(saved_err, STDERR_FILENO);
      close(saved_out);
      close(saved_err);
      if (log) std::fclose(log);
      if (code != 0 && code != 130) ++failed;
      state[k] = code == 0 ? kDone : code == 130 ? kStopped : kFailed;
      if (!a.quiet || code != 0)
        progress(k, code, "rank " + std::to_string(rank) + ": ", times_text(variant_start, start));
    }
    failed = static_cast<int>(mpi::sum(failed));
    // rank 0 learns what became of the others' variants (each variant is one rank's)
    for (std::size_t k = 0; k < variants.size(); ++k) state[k] = static_cast<int>(mpi::sum(state[k]));
    stopped = mpi::sum(stop_requested() ? 1 : 0) > 0;
    // Rank 0 carries the sweep's exit code (it knows the sums): mpirun exits with it. Another
    // rank that left with a non-zero code made mpirun abort the job while rank 0 still wrote
    // the table or the interruption's summary (seen: rank 0 sent SIGTERM, its stdout lost).
    if (rank != 0) return 0;
    done = variants.size();  // rank 0 gathers below
  } else {
    // Ctrl-C reaches the sweep alone (the variants run in process groups of their own); it
    // passes each stop request on to the running variants: the first makes them write a
    // checkpoint and stop, a second stops them at once. No variant starts after a stop.
    g_sweep_signals.store(0);
    for (int sig : stop_signals()) {
      struct sigaction old {};
      if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;  // nohup: stays ignored
      std::signal(sig, on_sweep_signal);
      handled.push_back(sig);
    }
  }
  std::map<pid_t, std::size_t> children;
  std::map<pid_t, std::chrono::steady_clock::time_point> started_at;
  const auto start = std::chrono::steady_clock::now();
  int forwarded = 0;
  for (std::size_t k = 0; k < variants.size() && !mpi::active(); ++k) done += skip[k];
  while (done < variants.size() && !mpi::active()) {
    while (running < jobs && next < variants.size() && g_sweep_signals.load() == 0) {
      if (skip[next]) {
        ++next;
        continue;
      }
      std::vector<std::string> args = {self, "run", a.case_dir, "--out", dirs[next].string(), "-q"};
      for (const auto& kv : overrides_of(next)) {
        args.push_back("--set");
        args.push_back(kv);
      }
      if (jobs > 1) {
        args.push_back("--set");
        args.push_back("run.threads=1");  // the variants share the cores
      }
      if (a.resume && resumable(next)) args.push_back("--resume");
      const std::string log = log_of(next);
      const char* mode = a.resume ? "a" : "w";
      // The stop signals are blocked from before the fork until the variant's run has its
      // handlers (command_run unblocks them): a stop passed on while it starts up waits
      // instead of killing it without a checkpoint.
      sigset_t stops, before;
      sigemptyset(&stops);
      for (int sig : stop_signals()) sigaddset(&stops, sig);
      ::sigprocmask(SIG_BLOCK, &stops, &before);
      const pid_t parent = ::getpid();
      const pid_t pid = fork();
      if (pid == 0) {
        ::setpgid(0, 0);  // the terminal's Ctrl-C goes to the sweep, which passes it on once
        for (int sig : handled) std::signal(sig, SIG_DFL);  // ignored ones stay ignored (nohup)
        // a sweep that dies (SIGKILL, out of memory) stops its variants, with checkpoints
        ::prctl(PR_SET_PDEATHSIG, SIGTERM);
        if (::getppid() != parent) _exit(130);
        std::FILE* f = std::fopen(log.c_str(), mode);
        if (f) {
          dup2(fileno(f), STDOUT_FILENO);
          dup2(fileno(f), STDERR_FILENO);
        }
        std::vector<char*> argv;
        for (auto& x : args) argv.push_back(x.data());
        argv.push_back(nullptr);
        execv(self.c_str(), argv.data());
        _exit(127);
      }
      if (pid > 0) ::setpgid(pid, pid);  // both sides, the usual idiom: no window either way
      ::sigprocmask(SIG_SETMASK, &before, nullptr);
      if (pid < 0) {
        std::fprintf(stderr, "error: sweep: cannot start a variant: %s\n", std::strerror(errno));
        break;
      }
      state[next] = kRunning;
      started_at[pid] = std::chrono::steady_clock::now();
      children[pid] = next++;
      ++running;
    }
    // each stop request once to the running variants, said once
    auto pass_on_stops = [&] {
      const int signals = g_sweep_signals.load();
      if (signals <= forwarded) return;
      if (forwarded == 0)
        std::fprintf(stderr, "\nsweep: stop requested: the running variants write a checkpoint and stop; no "
                             "variant starts (the same signal again stops them at once)\n");
      for (const auto& [child, k] : children) ::kill(child, SIGTERM);
      forwarded = signals;
    };
    pass_on_stops();
    if (running == 0) break;  // stopped before every variant started
    int status = 0;
    pid_t pid = 0;
    while ((pid = waitpid(-1, &status, WNOHANG)) == 0) {
      pass_on_stops();
      ::usleep(50000);
    }
    if (pid < 0) break;
    const auto it = children.find(pid);
    if (it == children.end()) continue;
    const std::size_t k = it->second;
    children.erase(it);
    --running;
    ++done;
    const bool ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
    const bool interrupted = WIFEXITED(status) && WEXITSTATUS(status) == 130;
    if (!ok && !interrupted) ++failed;
    state[k] = ok ? kDone : interrupted ? kStopped : kFailed;
    finished_count += ok;
    const std::string times = times_text(started_at[pid], start);
    started_at.erase(pid);
    if (!a.quiet || !ok)
      progress(k, ok ? 0 : interrupted ? 130 : WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status),
               "", times);
  }
  if (!mpi::active()) stopped = g_sweep_signals.load() > 0;
  if (stopped) {
    // each variant in exactly one count: finished (now or earlier), failed, stopped with a
    // checkpoint (or left with one by an earlier sweep), stopped before its first checkpoint,
    // not started
    std::size_t finished_now = 0, failed_now = 0, with_checkpoint = 0, stopped_early = 0, not_started = 0;
    for (std::size_t k = 0; k < variants.size(); ++k) {
      if (finished(k)) ++finished_now;
      else if (state[k] == kFailed) ++failed_now;
      else if (resumable(k)) ++with_checkpoint;
      else if (state[k] != kNotStarted) ++stopped_early;
      else ++not_started;
    }
    std::string counts = std::to_string(finished_now) + " of " + std::to_string(variants.size()) +
                         " variants finished, " + std::to_string(with_checkpoint) + " stopped with a checkpoint";
    if (stopped_early) counts += ", " + std::to_string(stopped_early) + " stopped before their first checkpoint (they start again)";
    counts += ", " + std::to_string(not_started) + " not started";
    if (failed_now) counts += ", " + std::to_string(failed_now) + " failed (their .log says why; --resume runs them again)";
    std::fprintf(stderr, "sweep: interrupted: %s; no table was made. Continue with:\n  %s%s\n", counts.c_str(),
                 mpi::active() ? ("mpirun -np " + std::to_string(mpi::world_size()) + " ").c_str() : "",
                 continue_command(a, self).c_str());
    return 130;
  }
  // gather
  std::vector<std::map<std::string, double>> rows(variants.size());
  std::set<std::string> columns;
  for (std::size_t k = 0; k < variants.size(); ++k) {
    try {
      rows[k] = read_summary(dirs[k] / "summary.json");
      for (const auto& [key, v] : rows[k]) columns.insert(key);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "warning: %s (see %s.log)\n", e.what(), dirs[k].string().c_str());
    }
  }
  // a swept key that a summary also holds (run.seed) is its axis column alone: sweep.tsv had it
  // twice, and csv readers keep the later, the summary's, blank for a failed variant
  for (const auto& [key, values] : axes) columns.erase(key);
  std::ostringstream tsv, md;
  tsv << "variant";
  for (const auto& [key, values] : axes) tsv << "\t" << key;
  for (const auto& c : columns) tsv << "\t" << c;
  tsv << "\n";
  // sweep.md's columns (docs/OUTPUT.md, "Sweep directories"): a headline quantity, its error,
  // and the theory values of it, each beside the measured quantity it belongs to. A column is
  // shown only when some variant has a number in it (a key null in every variant is left
  // out), and a theory column only when its measured quantity is shown: the hydrodynamic
  // limit's theory.hydro.* (constant in a homogeneous case, which measures no mode or profile)
  // does not crowd a homogeneous sweep, nor theory.Z one without pressure.Z.
  const std::vector<std::pair<std::string, std::string>> headline = {  // column, its measured quantity
      {"temperature.mean", ""},
      {"temperature.stderr", "temperature.mean"},
      {"a2.mean", ""},
      {"a2.stderr", "a2.mean"},
      {"a3.mean", ""},
      {"a3.stderr", "a3.mean"},
      {"mode.decay_rate", ""},
      {"mode.decay_rate_stderr", "mode.decay_rate"},
      {"profile.exponent", ""},
      {"profile.exponent_stderr", "profile.exponent"},
      {"pressure.Z", ""},
      {"pressure.Z_stderr", "pressure.Z"},
      {"theory.Z", "pressure.Z"},
      {"theory.medium_steady_temperature", "temperature.mean"},
      {"theory.wall_balance_temperature", "temperature.mean"},
      {"theory.heating_balance_temperature", "temperature.mean"},
      {"theory.equilibrium.maxwellian.T", "temperature.mean"},
      {"theory.equilibrium.grad.T", "temperature.mean"},
      {"theory.equilibrium.sonine.T", "temperature.mean"},
      {"theory.expansion.first_order.T", "temperature.mean"},
      {"theory.hydro.decay_rate", "mode.decay_rate"},
      {"theory.hydro.decay_rate_kinetic", "mode.decay_rate"},
      {"theory.hydro.thermal_diffusion_exponent_kinetic", "profile.exponent"}};
  auto has_number = [&](const std::string& c) {
    return std::any_of(rows.begin(), rows.end(), [&](const auto& r) {
      const auto it = r.find(c);
      return it != r.end() && std::isfinite(it->second);
    });
  };
  std::vector<std::string> shown;
  for (const auto& [h, measured] : headline)
    if (has_number(h) && (measured.empty() || has_number(measured))) shown.push_back(h);
  md << "| variant |";
  for (const auto& [key, values] : axes) md << " " << key << " |";
  for (const auto& h : shown) md << " " << h << " |";
  md << "\n|---|";
  for (std::size_t i = 0; i < axes.size() + shown.size(); ++i) md << "---|";
  md << "\n";
  for (std::size_t k = 0; k < variants.size(); ++k) {
    tsv << dirs[k].filename().string();
    md << "| " << k << " |";
    for (const auto& kv : variants[k]) {
      tsv << "\t" << kv.substr(kv.find('=') + 1);
      md << " " << kv.substr(kv.find('=') + 1) << " |";
    }
    for (const auto& c : columns) {
      auto it = rows[k].find(c);
      char b[40] = "";
      if (it != rows[k].end()) std::snprintf(b, sizeof b, "%.17g", it->second);
      tsv << "\t" << b;
    }
    for (const auto& h : shown) {
      auto it = rows[k].find(h);
      char b[40] = "";
      if (it != rows[k].end()) std::snprintf(b, sizeof b, "%.6g", it->second);
      md << " " << b << " |";
    }
    tsv << "\n";
    md << "\n";
  }
  // Ensemble mode: a sweep over run.seed alone is a set of independent replicas; merge them
  // (mean over replicas, standard error = sample standard deviation / sqrt(R), which is an
  // honest error whatever the correlations inside each run).
  if (axes.size() == 1 && axes[0].first == "run.seed" && variants.size() >= 2) {
    // the replicas whose summary was read (a failed run is not one)
    const auto read = static_cast<std::size_t>(std::count_if(rows.begin(), rows.end(), [](const auto& r) { return !r.empty(); }));
    std::ostringstream em;
    em << "| quantity | mean over " << read << " replicas | standard error | per-run stderr combined |\n|---|---|---|---|\n";
    Summary merged;
    // a quantity's own error: `key.stderr` for a `key.mean` (temperature.stderr), `key_stderr`
    // for a `key_mean` (rotation.Ttr_stderr; until 2026-12-06 looked for as Ttr_mean_stderr, so
    // its column was blank), else `key_stderr` (mode.decay_rate_stderr, rotation.R_stderr)
    auto ends_with = [](const std::string& c, const char* tail) {
      const std::size_t n = std::strlen(tail);
      return c.size() > n && c.compare(c.size() - n, n, tail) == 0;
    };
    for (const auto& c : columns) {
      // nor the flags and parts of the runs' own errors (`a2.stderr_plateau`,
      // `profile.exponent_stderr_fit`, `_modes`): the ensemble's error is the replicas' scatter
      // whatever they say
      if (c.rfind("performance.", 0) == 0 || c.rfind("run.", 0) == 0 || ends_with(c, ".stderr") || ends_with(c, "_stderr") ||
          ends_with(c, "_plateau") || ends_with(c, "_stderr_fit") || ends_with(c, "_stderr_modes") ||
          c == "theory.homogeneous")  // (a flag of the case, no quantity)
        continue;
      std::vector<double> v;
      for (const auto& r : rows)
        if (auto it = r.find(c); it != r.end() && std::isfinite(it->second)) v.push_back(it->second);
      if (v.size() < 2) continue;
      double m = 0;
      for (double x : v) m += x;
      m /= v.size();
      double var = 0;
      for (double x : v) var += (x - m) * (x - m);
      double se = std::sqrt(var / (v.size() - 1) / v.size());
      // the same number in every replica (theory, settings): that number, with no error
      // (the sums above would leave rounding noise of ~1e-17 in both)
      if (std::all_of(v.begin(), v.end(), [&](double x) { return x == v[0]; })) m = v[0], se = 0.0;
      merged.set(c + ".ensemble_mean", m);
      merged.set(c + ".ensemble_stderr", se);
      merged.set(c + ".replicas", static_cast<std::int64_t>(v.size()));
      // the runs' own standard errors combined as the error of a mean of R independent
      // runs, sqrt(sum s_i^2)/R, for comparison with the scatter (before 2026-12-05: the mean
      // of the s_i over sqrt(R), low by Jensen's inequality, and blank for the `_stderr` keys)
      std::string own;
      const std::string err_key = ends_with(c, ".mean")   ? c.substr(0, c.size() - 5) + ".stderr"
                                  : ends_with(c, "_mean") ? c.substr(0, c.size() - 5) + "_stderr"
                                                          : c + "_stderr";
      if (columns.count(err_key)) {
        double s2 = 0;
        int cnt = 0;
        for (const auto& r : rows)
          if (auto it = r.find(err_key); it != r.end() && std::isfinite(it->second)) {
            s2 += it->second * it->second;
            ++cnt;
          }
        if (cnt) {
          char b[40];
          std::snprintf(b, sizeof b, "%.4g", std::sqrt(s2) / cnt);
          own = b;
        }
      }
      char line[256];
      std::snprintf(line, sizeof line, "| %s | %.10g | %.4g | %s |\n", c.c_str(), m, se, own.c_str());
      em << line;
    }
    write_file_atomic(out / "ensemble.md", em.str());
    write_file_atomic(out / "ensemble.json", merged.to_json());
    std::printf("ensemble of %zu replicas: %s/ensemble.md, %s/ensemble.json\n", read, out.string().c_str(),
                out.string().c_str());
  }
  write_file_atomic(out / "sweep.tsv", tsv.str());
  write_file_atomic(out / "sweep.md", md.str());
  std::fputs(md.str().c_str(), stdout);
  // one plot, if Python with matplotlib is available (the C++ side never needs it)
  // A plot that cannot be made is said, with where its messages are (review 5: a failure, or
  // no script beside the binary, left only a missing "plot:" line).
  const fs::path exe_dir = fs::path(self).parent_path();
  bool plot_script = false;
  for (const fs::path& cand : {exe_dir / "../scripts/plot_sweep.py", exe_dir / "../../scripts/plot_sweep.py"})
    if (fs::exists(cand)) {
      plot_script = true;
      const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
      const fs::path log = out / "plot.log";
      // quoted for the shell whatever the paths hold (a "'" in --out broke the command, and
      // could have run a command of its own)
      const std::string cmd = python + " " + quote_arg(cand.string()) + " " + quote_arg(out.string()) + " >" +
                              quote_arg(log.string()) + " 2>&1";
      const int status = std::system(cmd.c_str());
      std::error_code ec;
      if (status == 0) {
        std::printf("plot: %s/sweep.png\n", out.string().c_str());
        fs::remove(log, ec);
      } else {
        std::fprintf(stderr,
                     "note: no sweep.png: %s failed (exit %d; its messages are in %s). The tables do not need "
                     "it: /usr/bin/python3 with numpy and matplotlib makes it (python/README.md)\n",
                     cand.lexically_normal().string().c_str(), WIFEXITED(status) ? WEXITSTATUS(status) : -1,
                     log.string().c_str());
      }
      break;
    }
  if (!plot_script)
    std::fprintf(stderr, "note: no sweep.png: scripts/plot_sweep.py is not beside this binary (looked in %s); the "
                         "tables do not need it\n",
                 (exe_dir / "../scripts").lexically_normal().string().c_str());
  std::printf("table: %s/sweep.tsv, %s/sweep.md\n", out.string().c_str(), out.string().c_str());
  return failed ? 1 : 0;
}

}  // namespace grainbath::cli
