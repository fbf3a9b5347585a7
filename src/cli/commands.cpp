#include "cli/commands.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <cerrno>
#include <filesystem>
#include <iostream>
#include <variant>

#include "core/case_file.hpp"
#include "core/checkpoint.hpp"
#include "core/physics_config.hpp"
#include "core/run_support.hpp"
#include "core/summary.hpp"
#include "dsmc/decomposition.hpp"
#include "dsmc/dsmc.hpp"
#include "edmd/edmd.hpp"

namespace grainbath::cli {

namespace fs = std::filesystem;

namespace {

std::atomic<bool> g_stop{false};
std::atomic<long long> g_first_stop_ns{0};  // CLOCK_MONOTONIC of the first stop request
std::atomic<bool> g_announce_stop{true};     // false on the MPI ranks that do not write

long long monotonic_ns() {  // clock_gettime is async-signal-safe
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<long long>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

// SIGINT, SIGTERM, SIGHUP (a closed terminal or ssh session), SIGUSR1 and SIGXCPU (batch
// systems' warnings before a kill): the run stops at its next step (DSMC) or rebuild (EDMD)
// and writes a checkpoint; it says so at once, since an EDMD stop can take seconds. A request
// repeated 2 s or more after the first stops at once, without a checkpoint (the default
// action; the temporary output directory it leaves is removed by the next run into the same
// --out: OutputDirectory). Repeats within 2 s are the same request delivered twice (a closed
// terminal: SIGHUP from the kernel and again from the shell; a process group killed while a
// sweep passes the request on), not a second one.
extern "C" void on_signal(int sig) {
  const long long now = monotonic_ns();
  long long first = 0;
  if (!g_first_stop_ns.compare_exchange_strong(first, now)) {
    if (now - first < 2000000000LL) return;
    std::signal(sig, SIG_DFL);
    std::raise(sig);
    return;
  }
  g_stop.store(true);
  if (g_announce_stop.load()) {
    static const char msg[] =
        "\ngrainbath: stop requested: writing a checkpoint at the next step (DSMC) or rebuild (EDMD), then stopping "
        "(the same request again, 2 s or more later, stops at once, without a checkpoint)\n";
    [[maybe_unused]] const auto written = ::write(STDERR_FILENO, msg, sizeof msg - 1);
  }
}

}  // namespace

const std::vector<int>& stop_signals() {
  static const std::vector<int> s = {SIGINT, SIGTERM, SIGHUP, SIGUSR1, SIGXCPU};
  return s;
}

void install_stop_handlers() {
  for (int sig : stop_signals()) {
    // a signal the run was started with ignored stays ignored: nohup's SIGHUP, the SIGINT
    // of a background job of a non-interactive shell
    struct sigaction old {};
    if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;
    std::signal(sig, on_signal);
  }
  std::signal(SIGPIPE, SIG_IGN);
  sigset_t stops;
  sigemptyset(&stops);
  for (int sig : stop_signals()) sigaddset(&stops, sig);
  ::sigprocmask(SIG_UNBLOCK, &stops, nullptr);
}

bool stop_requested() { return g_stop.load(); }

namespace {

using SolverConfig = std::variant<dsmc::Config, edmd::Config>;

// What an error says: std::bad_alloc's own what() ("std::bad_alloc") tells a user nothing.
std::string error_text(const std::exception& e) {
  if (dynamic_cast<const std::bad_alloc*>(&e))
    return std::string("out of memory (") + e.what() +
           "): the case needs more memory than the process can have. Fewer grains (dsmc.particles, "
           "edmd.particles), cells or bins, or a larger machine; docs/PERFORMANCE.md gives the memory per particle "
           "(DSMC about 56 bytes, EDMD about 400 bytes per disk)";
  return e.what();
}

// Solver dispatch: one overload per engine.
std::vector<std::pair<std::string, double>> solver_theory(const dsmc::Config& c) { return dsmc::theory_values(c); }
std::vector<std::pair<std::string, double>> solver_theory(const edmd::Config& c) { return edmd::theory_values(c); }
void solver_run(const dsmc::Config& c, const RunContext& ctx, Summary& s) { dsmc::run(c, ctx, s); }
void solver_run(const edmd::Config& c, const RunContext& ctx, Summary& s) { edmd::run(c, ctx, s); }
bool keep_checkpoints(const dsmc::Config& c) { return c.checkpoint.keep; }
bool keep_checkpoints(const edmd::Config& c) { return c.checkpoint.keep; }

struct LoadedCase {
  CaseReader reader;
  std::string solver;
  std::uint64_t seed = 1;
  int threads = 0;
  SolverConfig config;
};

// Reads [run], dispatches to the solver's own reader, then rejects unknown keys.
LoadedCase load_case(const RunArgs& a) {
  CaseReader reader = CaseReader::from_directory(a.case_dir);
  // A key in two --set options takes the later value (scripts override their own settings
  // so, and the sweep's MPI mode appends run.threads=1), said in a note rather than silently
  // (review 4); `grainbath sweep` refuses it, since there each value would make a run.
  std::vector<std::pair<std::string, std::string>> given;  // key, the option
  for (const auto& o : a.overrides) {
    std::string key = o.substr(0, o.find('='));
    key.erase(0, key.find_first_not_of(" \t"));
    key.erase(key.find_last_not_of(" \t") + 1);
    const auto earlier = std::find_if(given.begin(), given.end(), [&](const auto& g) { return g.first == key; });
    if (earlier != given.end()) {
      if (earlier->second != o && dsmc::mpi_env::world_rank() == 0)
        std::fprintf(stderr, "note: --set %s follows --set %s: the later value is used\n", o.c_str(),
                     earlier->second.c_str());
      earlier->second = o;
    } else {
      given.emplace_back(key, o);
    }
  }
  for (const auto& o : a.overrides) reader.apply_override(o);
  const std::string solver = reader.choice("run", "solver", "dsmc", {"dsmc", "edmd"});
  const auto seed = static_cast<std::uint64_t>(reader.integer("run", "seed", 1, 0, INT64_MAX));
  const int threads = static_cast<int>(reader.integer("run", "threads", 0, 0, 4096));
  SolverConfig config = solver == "edmd" ? SolverConfig(edmd::read_config(reader)) : SolverConfig(dsmc::read_config(reader));
  reader.finish();
  return LoadedCase{std::move(reader), solver, seed, threads, std::move(config)};
}

int report_case_error(const CaseError& e) {
  for (const auto& p : e.problems()) std::fprintf(stderr, "error: %s\n", p.to_string().c_str());
  // the pointer to list-models only where a model name was wrong
  std::fprintf(stderr, "%zu problem(s); nothing was run.%s\n", e.problems().size(),
               e.about_names() ? " `grainbath list-models` lists the valid names." : "");
  return 2;
}

void print_table(const Summary& s) {
  auto row = [&](const char* label, const std::string& mean, const std::string& err) {
    const double m = s.number(mean);
    if (std::isnan(m)) return;
    const double e = err.empty() ? NAN : s.number(err);
    // an error whose blocking reached no plateau (`key.stderr_plateau` false) is unreliable: a
    // lower bound for a series correlated over the window, and a drifting one has no steady mean
    const Summary::Value* plateau = err.empty() ? nullptr : s.get(err + "_plateau");
    // (an error without the flag: the window was too short to check, the run's log says so)
    const bool lower_bound = plateau && std::holds_alternative<bool>(*plateau) && !std::get<bool>(*plateau);
    const Summary::Value* solver = s.get("solver");
    const bool dsmc = solver && std::holds_alternative<std::string>(*solver) && std::get<std::string>(*solver) == "dsmc";
    const bool edmd = solver && std::holds_alternative<std::string>(*solver) && std::get<std::string>(*solver) == "edmd";
    const bool unchecked = !err.empty() && !plateau &&
                           ((dsmc && (err == "temperature.stderr" || err == "a2.stderr" || err == "a3.stderr" ||
                                      err == "rotation.R_stderr")) ||
                            (edmd && (err == "temperature.stderr" || err == "pressure.Z_stderr" ||
                                      err == "rotation.R_stderr")));
    if (std::isnan(e))
      std::printf("  %-34s %14.8g\n", label, m);
    else
      std::printf("  %-34s %14.8g +- %.3g%s\n", label, m, e,
                  lower_bound ? " (no plateau: use replicas)" : unchecked ? " (few samples: unchecked)" : "");
  };
  // DSMC with walls that exchange energy or grains, or a background profile (theory.homogeneous
  // false): the homogeneous theories are references, not this domain's prediction (run-table
  // audit 2026-12-06: cases/hot-walls read "+94 sigma", cases/thermal-gradient "+236 sigma")
  const Summary::Value* hom = s.get("theory.homogeneous");
  const bool homogeneous = !hom || !std::holds_alternative<bool>(*hom) || std::get<bool>(*hom);
  // A theory value beside the measurement it predicts: the distance (measured - theory) in
  // the measurement's standard errors, only where that error reached its plateau (flag true),
  // as the report does (review 4: the run's table showed no distance and no expansion)
  auto theory_row = [&](const char* label, const std::string& key, const std::string& measured,
                        const std::string& err) {
    const double th = s.number(key), m = s.number(measured), e = s.number(err);
    if (std::isnan(th)) return;
    const Summary::Value* plateau = s.get(err + "_plateau");
    const bool reliable = plateau && std::holds_alternative<bool>(*plateau) && std::get<bool>(*plateau);
    if (std::isnan(m) || !(e > 0) || !reliable || !homogeneous)
      std::printf("  %-34s %14.8g\n", label, th);
    else
      std::printf("  %-34s %14.8g    measured %+.1f sigma\n", label, th, (m - th) / e);
  };
  std::printf("\n  %-34s %14s\n", "quantity", "value");
  // each case's headline result beside its theory (means over the averaging window, which
  // in free cooling is a mean over a decaying state, hence "window", not "steady")
  row("temperature (window mean)", "temperature.mean", "temperature.stderr");
  row("temperature (final)", "temperature.final", "");
  row("a2 (window mean)", "a2.mean", "a2.stderr");
  row("a3 (window mean)", "a3.mean", "a3.stderr");
  // the hydrodynamic predictions beside the measurement they predict
  if (!std::isnan(s.number("mode.decay_rate"))) {
    row("density-mode decay rate", "mode.decay_rate", "mode.decay_rate_stderr");
    row("theory: D k^2 (hydro, paper)", "theory.hydro.decay_rate", "");
    row("theory: D k^2 (hydro, kinetic)", "theory.hydro.decay_rate_kinetic", "");
  }
  if (!std::isnan(s.number("profile.exponent"))) {
    row("density profile exponent", "profile.exponent", "profile.exponent_stderr");
    row("theory: exponent (kinetic)", "theory.hydro.thermal_diffusion_exponent_kinetic", "");
  }
  row("compressibility Z", "pressure.Z", "pressure.Z_stderr");
  // the reference EOS by name (review 4: "elastic EOS" did not say which); theory.Z_henderson
  // is written for disks only
  // The EOS is a prediction of elastic grains in a homogeneous, undriven gas, where the driver
  // writes theory.Z_enskog (= theory.Z for e = 1). Elsewhere it is a reference only, without a
  // distance in sigma: inelastic grains scale the collisional part by (1 + e)/2, and heating or
  // walls change the contact value itself (run-table audit 2026-12-06: "-52.7 sigma" for dense-medium's e = 0.9)
  const char* eos = std::isnan(s.number("theory.Z_henderson")) ? "Carnahan-Starling" : "Kolafa-Rottner fit";
  const double Z_enskog = s.number("theory.Z_enskog");
  const bool eos_is_prediction = !std::isnan(Z_enskog) && std::abs(Z_enskog - s.number("theory.Z")) <= 1e-12 * Z_enskog;
  if (eos_is_prediction) {
    theory_row(("theory: Z, " + std::string(eos)).c_str(), "theory.Z", "pressure.Z", "pressure.Z_stderr");
  } else {
    row(("elastic Z, " + std::string(eos)).c_str(), "theory.Z", "");
    theory_row("theory: Z, Enskog, (1+e)/2 x EOS", "theory.Z_enskog", "pressure.Z", "pressure.Z_stderr");
  }
  // rough grains (docs/rough.md): the steady ratio R = Trot/Ttr beside models A-E (R11; E keeps
  // the full beta(gamma), the thesis' best), each the steady root of its rotational equation
  row("rotational / translational T, R", "rotation.R", "rotation.R_stderr");
  for (const char* m : {"E", "D", "C", "B", "A"})
    theory_row(("theory: R, model " + std::string(m)).c_str(), "theory.model_" + std::string(m) + ".R", "rotation.R",
               "rotation.R_stderr");
  // the loss rate against molecular chaos at the measured contact value (Bizon eqs. 29-30,
  // Fig. 8): a check that holds for driven grains too, where no Z or T theory is written
  row("loss rate / chaos, Bizon gamma_e", "loss.gamma_over_gamma_e", "");
  theory_row("theory: medium steady T", "theory.medium_steady_temperature", "temperature.mean", "temperature.stderr");
  row("theory: wall-balance T", "theory.wall_balance_temperature", "");
  row("theory: bath balance T, mol. chaos", "theory.heating_balance_temperature", "");
  if (!homogeneous && !std::isnan(s.number("theory.equilibrium.maxwellian.T")))
    std::printf("  (walls or a background profile: the homogeneous theory below is a reference, not a prediction\n"
                "   of the domain's means; the report shows the profiles, `grainbath theory` a bulk's own state)\n");
  theory_row("theory: T# local Maxwellian", "theory.equilibrium.maxwellian.T", "temperature.mean", "temperature.stderr");
  theory_row("theory: T# Grad", "theory.equilibrium.grad.T", "temperature.mean", "temperature.stderr");
  theory_row("theory: T# Sonine", "theory.equilibrium.sonine.T", "temperature.mean", "temperature.stderr");
  // the expansion in eps = background.knudsen (closures/, docs/closures.md)
  theory_row("theory: T0 + eps T1", "theory.expansion.first_order.T", "temperature.mean", "temperature.stderr");
  theory_row("theory: + eps^2 T2, Maxwellian", "theory.expansion.second_order_maxwellian.T", "temperature.mean",
             "temperature.stderr");
  theory_row("theory: + eps^2 T2, Grad", "theory.expansion.second_order_grad.T", "temperature.mean",
             "temperature.stderr");
  theory_row("theory: a2 Sonine", "theory.equilibrium.sonine.a2", "a2.mean", "a2.stderr");
  row("theory: Haff T(t_end), Maxwellian", "theory.haff.temperature_at_t_end_no_a2", "");
  row("theory: Haff T(t_end), with a2", "theory.haff.temperature_at_t_end", "");
  row("theory: Haff T(t_end), Sonine 2", "theory.haff.temperature_at_t_end_sonine2", "");
  // EDMD free cooling: the fitted Haff time against Enskog theory
  row("Haff time t0 (fit)", "haff.t0_measured", "");
  row("theory: Haff t0, with a2", "haff.t0_theory", "");
  row("theory: Haff t0, Maxwellian", "haff.t0_theory_no_a2", "");
  row("theory: a2 van Noije-Ernst", "theory.haff.a2_van_noije_ernst", "");
  row("theory: a2 second Sonine", "theory.hcs.a2_sonine2", "");
  row("theory: a3 second Sonine", "theory.hcs.a3_sonine2", "");
  row("energy budget residual (rel.)", "energy.budget_relative_residual", "");
  row("wall time [s]", "performance.wall_seconds", "");
  row("  of which the step loop [s]", "performance.loop_seconds", "");
  // EDMD: per second of the event loop (measurements excluded), DSMC: per wall second
  row(s.get("performance.engine_seconds") ? "collisions per event-loop second" : "collisions per second",
      "performance.collisions_per_second", "");
  std::printf("\n");
}

}  // namespace

int command_check(const RunArgs& a) {
  try {
    LoadedCase lc = load_case(a);
    std::printf("%s: OK (solver %s, seed %llu)\n", lc.reader.file().c_str(), lc.solver.c_str(),
                static_cast<unsigned long long>(lc.seed));
    return 0;
  } catch (const CaseError& e) {
    return report_case_error(e);
  }
}

std::vector<std::string> case_problems(const RunArgs& a) {
  std::vector<std::string> problems;
  try {
    load_case(a);
  } catch (const CaseError& e) {
    for (const auto& p : e.problems()) problems.push_back(p.to_string());
  }
  return problems;
}

std::vector<std::string> case_file_checksums(const RunArgs& a) {
  std::vector<std::string> sums;
  try {
    const LoadedCase lc = load_case(a);
    for (const auto& [key, value] : lc.reader.resolved())
      if (key.ends_with("_checksum")) sums.push_back(key + "=" + value);
  } catch (const CaseError&) {
  }
  return sums;
}

int command_theory(const RunArgs& a) {
  try {
    LoadedCase lc = load_case(a);
    Summary s;
    std::visit([&](const auto& cfg) { s.set_all("", solver_theory(cfg)); }, lc.config);
    // what the numbers are in, and what the expansion's orders mean (review 4: the JSON said
    // neither; docs/OUTPUT.md "theory")
    if (lc.solver == "dsmc") {
      s.set("about.units", std::string("DSMC units: lengths in grain-grain mean free paths, grain mass m, "
                                       "temperatures in energy units (k_B = 1); grainbath --help, docs/CASE_FILE.md"));
      const auto eps = lc.reader.resolved().find("background.knudsen");
      if (!std::isnan(s.number("expansion.T1")) && eps != lc.reader.resolved().end())
        s.set("about.expansion", "T = T0 + eps T1 + eps^2 T2 in the Knudsen number eps = background.knudsen = " +
                                     eps->second + "; first_order: T0 + eps T1, second_order_*: with T2 of that closure");
    } else {
      s.set("about.units", std::string("EDMD units: lengths in grain diameters (sigma = 1), m = 1, temperatures in "
                                       "energy units (k_B = 1); grainbath --help, docs/CASE_FILE.md"));
    }
    std::fputs(s.to_json().c_str(), stdout);
    return 0;
  } catch (const CaseError& e) {
    return report_case_error(e);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", error_text(e).c_str());
    return 1;
  }
}

int command_run(const RunArgs& a) {
  // stop requests from the start: one that arrives while the case is read or the output
  // directory made stops the run at its first step, with a checkpoint, instead of killing it
  // half set up (a sweep starts its variants with the stop signals blocked, so that one
  // passed on before this point waits until here)
  install_stop_handlers();
  std::optional<LoadedCase> lc;
  try {
    lc.emplace(load_case(a));
  } catch (const CaseError& e) {
    return report_case_error(e);
  }
  fs::path out = a.out_dir.empty() ? fs::path(a.case_dir) / "output" : fs::path(a.out_dir);
  // "out/" is out: its checkpoints (out.checkpoints) and siblings go beside it, not inside
  while (!out.has_filename() && out.has_parent_path() && out != out.root_path()) out = out.parent_path();
  // MPI (several ranks, not an ensemble replica): one DSMC run split over the ranks; rank 0
  // writes everything, the others only compute
  namespace mpi = dsmc::mpi_env;
  const bool split = !a.alone && mpi::world_size() > 1;
  const bool writer = !split || mpi::world_rank() == 0;
  if (split && lc->solver != "dsmc") {
    if (writer)
      std::fprintf(stderr, "error: %s: [run] solver = \"%s\" does not run on several MPI ranks (found %d); run it "
                           "with one rank, or run replicas with `mpirun grainbath sweep CASE --set run.seed=1,2,...`\n",
                   lc->reader.file().c_str(), lc->solver.c_str(), mpi::world_size());
    return 2;
  }
  // --resume needs a checkpoint: said before anything is created or moved (exit 2, bad input);
  // decided on the writing rank and shared, so that all ranks of a split run agree even where
  // their listings of a shared file system differ
  int no_checkpoint = a.resume && writer && count_checkpoints(checkpoint_directory(out)) == 0 ? 1 : 0;
  if (split && a.resume) no_checkpoint = static_cast<int>(mpi::sum(no_checkpoint));
  if (no_checkpoint) {
    if (writer)
      std::fprintf(stderr,
                   "error: --resume: no checkpoint in %s: nothing to resume (a run writes one when it is interrupted, "
                   "at every [checkpoint] every, and at its end with [checkpoint] keep = true; without --resume the run "
                   "starts afresh)\n",
                   checkpoint_directory(out).string().c_str());
    return 2;
  }
  std::unique_ptr<OutputDirectory> dir;
  try {
    // the case directory must survive the move-aside of a previous output
    if (writer) dir = std::make_unique<OutputDirectory>(out, std::vector<fs::path>{fs::path(a.case_dir)});
    // a fresh run starts a fresh series of checkpoints (an earlier run's would otherwise be
    // taken for this run's by --resume, and pruned this run's away)
    if (writer && !a.resume)
      if (const std::string note = set_aside_checkpoints(checkpoint_directory(out)); !note.empty())
        std::fprintf(stderr, "note: %s\n", note.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    if (split) mpi::abort(2);
    return 2;
  }
  g_announce_stop.store(writer);
  // (output piped into `head` must not kill the run when the pipe closes, hence SIGPIPE
  // ignored in install_stop_handlers: stdout's table is a copy of summary.json, the results
  // are the files)
  RunContext ctx;
  ctx.out_dir = writer ? dir->tmp() : fs::path();
  ctx.case_dir = a.case_dir;
  ctx.seed = lc->seed;
  ctx.threads = lc->threads;
  // [run] threads = 0: the cores other processes leave free (core_use(), run_support.hpp);
  // OMP_NUM_THREADS, where set, is the user's choice and OpenMP's default takes it. A run
  // split over MPI ranks shares the machine's cores among the ranks on it instead (they
  // start together, so none would see the others' load): cores / ranks, at least 1.
  // (node_ranks() is collective: every rank of a split run calls it, whatever its settings)
  if (split) {
    const int local_ranks = mpi::node_ranks();
    if (lc->threads == 0 && std::getenv("OMP_NUM_THREADS") == nullptr)
      ctx.threads = std::max(1, available_cores() / local_ranks);
  }
  if (lc->solver == "dsmc" && !split && lc->threads != 1 && std::getenv("OMP_NUM_THREADS") == nullptr) {
    const CoreUse use = core_use();
    const int busy = busy_cores(use);
    if (lc->threads == 0) {
      ctx.threads = automatic_threads(use);
      if (ctx.threads < use.cores && writer && !a.quiet)
        std::fprintf(stderr,
                     "note: %d of %d cores busy with other processes (%.2f cores' worth, %d other runnable): "
                     "running on %d thread(s); [run] threads = %d forces all (results do not depend on it)\n",
                     busy, use.cores, use.busy, use.other_runnable, ctx.threads, use.cores);
    } else if (lc->threads > 1 && lc->threads + busy > use.cores && std::getenv("OMP_WAIT_POLICY") == nullptr &&
               writer) {
      std::fprintf(stderr,
                   "warning: [run] threads = %d with %d of %d cores busy with other processes: OpenMP threads "
                   "spin-waiting on a shared core can make the run many times slower; use threads = 0 (automatic), "
                   "fewer threads, or OMP_WAIT_POLICY=PASSIVE\n",
                   lc->threads, busy, use.cores);
    }
  }
  // EDMD: the event loop is serial; threads serve only the snapshot measurements, and their
  // idle OpenMP workers spin between snapshots, taking a core the loop or another run could
  // use (a second thread made cases/hard-disk-eos 1.4x slower beside another job, docs/edmd.md
  // "Threads"). So [run] threads = 0 means one thread here, unless OMP_NUM_THREADS is set.
  if (lc->solver == "edmd" && lc->threads == 0 && std::getenv("OMP_NUM_THREADS") == nullptr) ctx.threads = 1;
  if (lc->solver == "edmd" && lc->threads > 1 && writer && !a.quiet)
    std::fprintf(stderr, "note: [run] threads = %d: the EDMD event loop runs on one thread; the others share only "
                         "the snapshot measurements (run replicas in parallel with grainbath sweep --set "
                         "run.seed=1,2,...)\n", lc->threads);
  ctx.quiet = a.quiet;
  ctx.case_text = lc->reader.source_text();
  ctx.resolved = lc->reader.resolved();
  ctx.stop_requested = &g_stop;
  ctx.checkpoint_dir = checkpoint_directory(out);
  ctx.resume = a.resume;
  ctx.decompose = !a.alone;
  ctx.quiet = a.quiet || !writer;
  {
    auto quote = [](const std::string& x) { return shell_quote(x); };
    // the binary that runs (a bare "grainbath" need not be on PATH), and the options as given
    std::error_code ec;
    const fs::path self = fs::read_symlink("/proc/self/exe", ec);
    std::string cmd = (split ? "mpirun -np " + std::to_string(mpi::world_size()) + " " : std::string()) +
                      quote(ec ? std::string("grainbath") : self.string()) + " run " + quote(a.case_dir);
    if (!a.out_dir.empty()) cmd += " --out " + quote(a.out_dir);
    if (a.quiet) cmd += " --quiet";
    for (const auto& o : a.overrides) cmd += " --set " + quote(o);
    ctx.resume_command = cmd + " --resume";
  }
  Summary summary;
  try {
    if (writer)
      std::fprintf(stderr, "grainbath %s: running %s (solver %s, seed %llu%s) -> %s\n", GRAINBATH_VERSION,
                   lc->reader.file().c_str(), lc->solver.c_str(), static_cast<unsigned long long>(lc->seed),
                   split ? (", " + std::to_string(mpi::world_size()) + " MPI ranks").c_str() : "", out.string().c_str());
    std::visit([&](const auto& cfg) { solver_run(cfg, ctx, summary); }, lc->config);
    if (!writer) return 0;
    summary.set("solver", lc->solver);  // every solver's summary names it (docs/OUTPUT.md)
    summary.set("run.seed", static_cast<std::int64_t>(lc->seed));
    summary.set("run.version", std::string(GRAINBATH_VERSION));
    summary.set("run.commit", std::string(build_commit()));  // the build's git commit
    write_file_atomic(dir->tmp() / "summary.json", summary.to_json());
    // said even with -q: an earlier result was moved, and an older one deleted (review 4)
    if (const std::string note = dir->commit(); !note.empty()) std::fprintf(stderr, "note: %s\n", note.c_str());
    const bool keep = std::visit([](const auto& cfg) { return keep_checkpoints(cfg); }, lc->config);
    std::error_code ec;
    if (!keep) fs::remove_all(ctx.checkpoint_dir, ec);
  } catch (const std::exception& e) {
    // a changed case or an end before the checkpoint on --resume (std::invalid_argument) is bad
    // input: exit 2, as for a bad case file; the checkpoints are kept
    const bool bad_input = dynamic_cast<const std::invalid_argument*>(&e) != nullptr;
    const bool interrupted = dynamic_cast<const RunInterrupted*>(&e) != nullptr;
    // an interruption is the same on every rank: said once; any other error may be one rank's
    if (writer || !interrupted)
      std::fprintf(stderr, "\nerror: %s\n(no output was moved into %s; any previous output there is untouched)\n",
                   error_text(e).c_str(), out.string().c_str());
    // after a failure (a full disk, a fault): say what survived, and leave no empty
    // checkpoint directory behind
    // (not after "no valid checkpoint": then none of them can be continued from)
    const bool none_valid = std::string(e.what()).rfind("--resume: no valid checkpoint", 0) == 0;
    if (writer && !interrupted && !bad_input && !none_valid) {
      std::error_code ec;
      if (count_checkpoints(ctx.checkpoint_dir) > 0)
        std::fprintf(stderr, "(the checkpoints in %s remain: once the cause is fixed, %s continues from the newest)\n",
                     ctx.checkpoint_dir.string().c_str(), ctx.resume_command.c_str());
      else if (fs::is_directory(ctx.checkpoint_dir, ec) && fs::is_empty(ctx.checkpoint_dir, ec))
        fs::remove(ctx.checkpoint_dir, ec);
    }
    // Remove the temporary directory, then leave without running HDF5's exit-time cleanup:
    // after a failed close (disk full) the library's atexit handler can crash.
    const int code = interrupted || g_stop.load() ? 130 : bad_input ? 2 : 1;
    dir.reset();
    std::fflush(nullptr);
    // every rank stopped at the same step, after the checkpoint's collectives: all leave
    // normally (MPI_Finalize in main). Rank 0 alone carries the code 130, which mpirun exits
    // with: a non-zero exit of another rank makes mpirun abort the job, rank 0 included,
    // while it may still be printing. A sweep's variant run in this process (alone) returns
    // its code to the sweep, which goes on with the other variants.
    if (interrupted && split && !writer) return 0;
    if (interrupted || a.alone) return code;
    if (split) mpi::abort(code);  // the other ranks wait in a collective call
    std::_Exit(code);
  }
  print_table(summary);
  std::printf("results: %s/results.h5, %s/summary.json\n", out.string().c_str(), out.string().c_str());
  return 0;
}

int command_list_models() {
  std::printf("Restitution laws ([restitution] law = ...):\n");
  for (const auto& m : restitution_models()) {
    std::printf("  %-10s %s\n", m.name.c_str(), m.summary.c_str());
    for (const auto& k : m.keys) std::printf("             - %s\n", k.c_str());
  }
  std::string kind;
  std::vector<ModelDescription> models = dsmc::dsmc_models();
  for (const auto& m : edmd::edmd_models()) {
    ModelDescription e = m;
    e.kind = "EDMD " + e.kind;
    models.push_back(e);
  }
  // one heading per kind: the models of a kind together, kinds in order of first appearance
  std::vector<std::string> kinds;
  for (const auto& m : models)
    if (std::find(kinds.begin(), kinds.end(), m.kind) == kinds.end()) kinds.push_back(m.kind);
  std::stable_sort(models.begin(), models.end(), [&](const ModelDescription& x, const ModelDescription& y) {
    return std::find(kinds.begin(), kinds.end(), x.kind) < std::find(kinds.begin(), kinds.end(), y.kind);
  });
  for (const auto& m : models) {
    if (m.kind != kind) {
      kind = m.kind;
      const bool um = kind.size() > 2 && kind.compare(kind.size() - 2, 2, "um") == 0;  // medium: media
      const std::string plural = kind.back() == 's'   ? kind
                                 : kind.back() == 'y' ? kind.substr(0, kind.size() - 1) + "ies"
                                 : um                 ? kind.substr(0, kind.size() - 2) + "a"
                                                      : kind + "s";
      std::printf("\n%c%s:\n", std::toupper(static_cast<unsigned char>(plural[0])), plural.substr(1).c_str());
    }
    std::printf("  %-14s %s\n", m.name.c_str(), m.summary.c_str());
    for (const auto& k : m.keys) std::printf("                 - %s\n", k.c_str());
  }
  std::printf("\nSolvers ([run] solver = ...):\n  dsmc           direct simulation Monte Carlo (homogeneous, or 1-3D with [domain])\n"
              "  edmd           event-driven hard disks (2D) / hard spheres (3D)\n");
  return 0;
}

int command_report(const ReportArgs& a) {
  std::error_code ec;
  const fs::path exe = fs::canonical("/proc/self/exe", ec).parent_path();
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("GRAINBATH_PYTHON_DIR"); env != nullptr && *env != '\0') {
    // the user's choice is taken or refused, never replaced by another copy silently
    if (!fs::is_regular_file(fs::path(env) / "report.py", ec)) {
      std::fprintf(stderr, "error: grainbath report: GRAINBATH_PYTHON_DIR=%s has no report.py (expected the python/ "
                           "directory of a grainbath source tree)\n", env);
      return 1;
    }
    candidates.push_back(fs::path(env) / "report.py");
  }
  candidates.push_back(exe / "../python/report.py");     // build/grainbath
  candidates.push_back(exe / "../../python/report.py");  // build/x/grainbath
  candidates.push_back(fs::path(GRAINBATH_PYTHON_SOURCE_DIR) / "report.py");  // the source tree it was built from
  fs::path script;
  for (const auto& cand : candidates)
    if (fs::is_regular_file(cand, ec)) {
      script = fs::weakly_canonical(cand, ec);
      break;
    }
  if (script.empty()) {
    std::string looked;
    for (const auto& cand : candidates) looked += "\n  " + cand.lexically_normal().string();
    std::fprintf(stderr, "error: grainbath report: python/report.py not found; looked in:%s\n(set GRAINBATH_PYTHON_DIR "
                         "to the python/ directory of a grainbath source tree)\n", looked.c_str());
    return 1;
  }
  // Debian's python3 has numpy, h5py and matplotlib; the first python3 on PATH may not
  const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  std::vector<std::string> args = {python, script.string(), a.dir};
  if (!a.out_dir.empty()) args.insert(args.end(), {"--out", a.out_dir});
  if (a.strict) args.push_back("--strict");
  if (!a.x_key.empty()) args.insert(args.end(), {"--x", a.x_key});
  std::vector<char*> argv;
  for (auto& x : args) argv.push_back(x.data());
  argv.push_back(nullptr);
  std::fflush(nullptr);
  const pid_t child = ::fork();
  if (child < 0) {
    std::fprintf(stderr, "error: grainbath report: cannot start %s: %s\n", python.c_str(), std::strerror(errno));
    return 1;
  }
  if (child == 0) {  // the arguments go to Python as they are: no shell, no quoting
    ::execvp(argv[0], argv.data());
    std::fprintf(stderr, "error: grainbath report: cannot run %s: %s\n", python.c_str(), std::strerror(errno));
    std::_Exit(127);
  }
  int status = 0;
  while (::waitpid(child, &status, 0) < 0)
    if (errno != EINTR) return 1;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  return 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

}  // namespace grainbath::cli
