// grainbath sweep CASE_DIR --set section.key=v1,v2,... : runs every combination of the
// listed values as a separate `grainbath run` (in parallel up to --jobs), then gathers the
// variants' summary.json into one table (sweep.tsv with every number, sweep.md with the
// headline columns) and one plot (scripts/plot_sweep.py, if Python with matplotlib is there).
// MPI build under mpirun: the ranks share the variants (each run alone in its rank's
// process) and rank 0 gathers; `--set run.seed=...` alone is the MPI ensemble mode.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "cli/commands.hpp"
#include "core/case_file.hpp"
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

std::string sanitize(const std::string& s) {
  std::string r;
  for (char c : s) r += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-') ? c : '_';
  return r;
}

}  // namespace

int command_sweep(const SweepArgs& a) {
  // parse the swept keys
  std::vector<std::pair<std::string, std::vector<std::string>>> axes;
  for (const auto& o : a.overrides) {
    const auto eq = o.find('=');
    if (eq == std::string::npos) {
      std::fprintf(stderr, "error: --set %s: expected section.key=value1,value2,...\n", o.c_str());
      return 2;
    }
    axes.emplace_back(o.substr(0, eq), split_values(o.substr(eq + 1)));
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
  if (mpi::world_rank() == 0) {
    try {
      checked = check_output_path(out, {fs::path(a.case_dir)});
    } catch (const std::exception& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      refused = 1;
    }
  }
  if (mpi::active()) refused = static_cast<int>(mpi::sum(refused));
  if (refused) return 2;
  std::error_code ec;
  if (mpi::world_rank() == 0 && fs::exists(checked, ec) && !fs::is_empty(checked, ec)) {
    fs::path previous = checked;
    previous += ".previous";
    fs::remove_all(previous, ec);
    if (!ec) fs::rename(checked, previous, ec);
    if (ec) {
      std::fprintf(stderr, "error: %s: cannot move the previous sweep aside to %s (%s)\n", out.string().c_str(),
                   previous.string().c_str(), ec.message().c_str());
      if (mpi::active()) mpi::abort(2);
      return 2;
    }
    std::fprintf(stderr, "sweep: the previous sweep in %s was moved to %s\n", out.string().c_str(),
                 previous.string().c_str());
  }
  if (mpi::world_rank() == 0) {
    fs::create_directories(out, ec);
    if (!ec) mark_output_directory(out);
  }
  if (mpi::active()) mpi::barrier();  // the other ranks write into `out` only after the move
  fs::create_directories(out, ec);
  if (ec) {
    std::fprintf(stderr, "error: %s: cannot create the sweep directory\n", out.string().c_str());
    return 2;
  }
  const int jobs = a.jobs > 0 ? a.jobs : std::max(1, static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN)));
  const std::string self = fs::canonical("/proc/self/exe").string();
  std::vector<fs::path> dirs;
  for (std::size_t k = 0; k < variants.size(); ++k) {
    std::string name = "variant-" + std::to_string(k);
    for (const auto& kv : variants[k]) name += "_" + sanitize(kv.substr(kv.find('.') + 1));
    dirs.push_back(out / name);
  }
  if (mpi::world_rank() == 0)
    std::fprintf(stderr, "sweep: %zu variants, %d at a time, into %s\n", variants.size(),
                 mpi::active() ? mpi::world_size() : jobs, out.string().c_str());
  std::size_t next = 0, done = 0;
  int running = 0, failed = 0;
  if (mpi::active()) {
    // rank r runs variants r, r + size, ... one after the other, in this process (a child
    // started from an MPI process would inherit its launcher environment)
    const auto rank = static_cast<std::size_t>(mpi::world_rank()), size = static_cast<std::size_t>(mpi::world_size());
    const auto start = std::chrono::steady_clock::now();
    for (std::size_t k = rank; k < variants.size(); k += size) {
      RunArgs ra;
      ra.case_dir = a.case_dir;
      ra.overrides = overrides_of(k);
      if (size > 1) ra.overrides.push_back("run.threads=1");  // the ranks share the cores
      ra.out_dir = dirs[k].string();
      ra.quiet = true;
      ra.alone = true;
      std::fflush(nullptr);
      const int saved_out = dup(STDOUT_FILENO), saved_err = dup(STDERR_FILENO);
      std::FILE* log = std::fopen((dirs[k].string() + ".log").c_str(), "w");
      if (log) {
        dup2(fileno(log), STDOUT_FILENO);
        dup2(fileno(log), STDERR_FILENO);
      }
      const int code = command_run(ra);
      std::fflush(nullptr);
      dup2(saved_out, STDOUT_FILENO);
      dup2(saved_err, STDERR_FILENO);
      close(saved_out);
      close(saved_err);
      if (log) std::fclose(log);
      if (code != 0) ++failed;
      std::fprintf(stderr, "sweep: rank %zu: %s %s  (%.0fs)\n", rank, code == 0 ? "done  " : "FAILED",
                   dirs[k].filename().string().c_str(), wall_seconds_since(start));
    }
    failed = static_cast<int>(mpi::sum(failed));
    if (rank != 0) return failed ? 1 : 0;
    done = variants.size();  // rank 0 gathers below
  }
  std::map<pid_t, std::size_t> children;
  const auto start = std::chrono::steady_clock::now();
  while (done < variants.size()) {
    while (running < jobs && next < variants.size()) {
      std::vector<std::string> args = {self, "run", a.case_dir, "--out", dirs[next].string(), "-q"};
      for (const auto& kv : overrides_of(next)) {
        args.push_back("--set");
        args.push_back(kv);
      }
      if (jobs > 1) {
        args.push_back("--set");
        args.push_back("run.threads=1");  // the variants share the cores
      }
      const fs::path log = dirs[next].string() + ".log";
      const pid_t pid = fork();
      if (pid == 0) {
        std::FILE* f = std::fopen(log.c_str(), "w");
        if (f) {
          dup2(fileno(f), STDOUT_FILENO);
          dup2(fileno(f), STDERR_FILENO);
        }
        std::vector<char*> argv;
        for (auto& s : args) argv.push_back(s.data());
        argv.push_back(nullptr);
        execv(self.c_str(), argv.data());
        _exit(127);
      }
      children[pid] = next++;
      ++running;
    }
    int status = 0;
    const pid_t pid = wait(&status);
    if (pid <= 0) break;
    const std::size_t k = children[pid];
    --running;
    ++done;
    const bool ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
    if (!ok) ++failed;
    std::fprintf(stderr, "sweep: %zu/%zu %s %s  (%.0fs)\n", done, variants.size(), ok ? "done  " : "FAILED",
                 dirs[k].filename().string().c_str(), wall_seconds_since(start));
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
  std::ostringstream tsv, md;
  tsv << "variant";
  for (const auto& [key, values] : axes) tsv << "\t" << key;
  for (const auto& c : columns) tsv << "\t" << c;
  tsv << "\n";
  const std::vector<std::string> headline = {"temperature.mean",
                                             "temperature.stderr",
                                             "a2.mean",
                                             "a2.stderr",
                                             "mode.decay_rate",
                                             "mode.decay_rate_stderr",
                                             "profile.exponent",
                                             "profile.exponent_stderr",
                                             "pressure.Z",
                                             "pressure.Z_stderr",
                                             "theory.equilibrium.maxwellian.T",
                                             "theory.equilibrium.grad.T",
                                             "theory.equilibrium.sonine.T",
                                             "theory.expansion.first_order.T",
                                             "theory.hydro.decay_rate",
                                             "theory.hydro.decay_rate_kinetic",
                                             "theory.hydro.thermal_diffusion_exponent_kinetic"};
  std::vector<std::string> shown;
  for (const auto& h : headline)
    if (columns.count(h)) shown.push_back(h);
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
    std::ostringstream em;
    em << "| quantity | mean over " << variants.size() << " replicas | standard error | per-run stderr (mean) |\n|---|---|---|---|\n";
    Summary merged;
    for (const auto& c : columns) {
      if (c.rfind("performance.", 0) == 0 || c.rfind("run.", 0) == 0 || (c.size() > 7 && c.compare(c.size() - 7, 7, ".stderr") == 0))
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
      // the runs' own (blocked) standard errors, averaged and divided by sqrt(R), for comparison
      std::string own;
      const std::string base = c.size() > 5 && c.compare(c.size() - 5, 5, ".mean") == 0 ? c.substr(0, c.size() - 5) : c;
      if (columns.count(base + ".stderr")) {
        double s2 = 0;
        int cnt = 0;
        for (const auto& r : rows)
          if (auto it = r.find(base + ".stderr"); it != r.end() && std::isfinite(it->second)) {
            s2 += it->second;
            ++cnt;
          }
        if (cnt) {
          char b[40];
          std::snprintf(b, sizeof b, "%.4g", s2 / cnt / std::sqrt(static_cast<double>(cnt)));
          own = b;
        }
      }
      char line[256];
      std::snprintf(line, sizeof line, "| %s | %.10g | %.4g | %s |\n", c.c_str(), m, se, own.c_str());
      em << line;
    }
    write_file_atomic(out / "ensemble.md", em.str());
    write_file_atomic(out / "ensemble.json", merged.to_json());
    std::printf("ensemble of %zu replicas: %s/ensemble.md, %s/ensemble.json\n", variants.size(), out.string().c_str(),
                out.string().c_str());
  }
  write_file_atomic(out / "sweep.tsv", tsv.str());
  write_file_atomic(out / "sweep.md", md.str());
  std::fputs(md.str().c_str(), stdout);
  // one plot, if Python with matplotlib is available (the C++ side never needs it)
  const fs::path exe_dir = fs::path(self).parent_path();
  for (const fs::path& cand : {exe_dir / "../scripts/plot_sweep.py", exe_dir / "../../scripts/plot_sweep.py"})
    if (fs::exists(cand)) {
      const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
      const std::string cmd = python + " '" + cand.string() + "' '" + out.string() + "' >/dev/null 2>&1";
      if (std::system(cmd.c_str()) == 0) std::printf("plot: %s/sweep.png\n", out.string().c_str());
      break;
    }
  std::printf("table: %s/sweep.tsv, %s/sweep.md\n", out.string().c_str(), out.string().c_str());
  return failed ? 1 : 0;
}

}  // namespace grainbath::cli
