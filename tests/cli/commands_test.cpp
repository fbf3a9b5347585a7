// The commands of src/cli/commands.cpp as a user meets them (the h5/XDMF/commands mutation
// audit, docs/reviews/mutation-audit-h5-xdmf-commands.md): every stop signal stops a run with a
// checkpoint, a signal ignored at the start stays ignored (nohup), a reader that goes away
// does not kill a run; what `run` prints and writes about itself, what it says after a
// failure, `check`'s line, `theory`'s about block, `list-models`' keys and `report`'s exit
// status. Each test runs the real binary on cases of a fraction of a second.
#include <gtest/gtest.h>

#include <csignal>
#include <regex>
#include <string>
#include <vector>

#include "tests/cli/cli_harness.hpp"

using namespace grainbath::testing;

namespace {

const std::string kBinary = GRAINBATH_BINARY;

// a homogeneous DSMC case; particles and t_end set per test
std::string dsmc_case(int particles, double t_end) {
  return "[run]\nsolver = \"dsmc\"\nseed = 7\n[grains]\ndensity = 1.0\ntemperature = 1.0\n[restitution]\n"
         "law = \"constant\"\ne = 0.9\n[dsmc]\nparticles = " + std::to_string(particles) + "\ndt = 0.01\nt_end = " +
         std::to_string(t_end) + "\n[sampling]\nevery = 0.05\nsteady_from = 0.1\n";
}

const char* kEdmdCase = R"([run]
solver = "edmd"
seed = 5
[edmd]
dimensions = 2
particles = 64
packing_fraction = 0.1
equilibrate = 1.0
collisions = 5.0
[restitution]
law = "constant"
e = 0.9
[heating]
model = "white_noise"
kick = 0.1
)";

class Commands : public ::testing::Test {
 protected:
  TempDir tmp;
  fs::path case_dir() const { return tmp / "case"; }
  fs::path out() const { return tmp / "out"; }
  void SetUp() override { fs::create_directories(tmp / "work"); }
  RunResult grainbath(std::vector<std::string> args, RunOptions opt = {}) {
    args.insert(args.begin(), kBinary);
    if (opt.cwd.empty()) opt.cwd = tmp / "work";
    return run_binary(args, opt);
  }
  std::vector<std::string> run_args(std::vector<std::string> extra = {}) const {
    std::vector<std::string> a = {"run", case_dir().string(), "--out", out().string(), "--set", "run.threads=1"};
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  }
};

}  // namespace

// SIGINT, SIGTERM, SIGUSR1 and SIGXCPU (batch systems' warning before a kill) each stop a run
// at its next step with a checkpoint and exit 130, saying so (SIGHUP: OutputDir.Hangup...).
TEST_F(Commands, EachStopSignalStopsTheRunWithACheckpoint) {
  write_text(case_dir() / "case.toml", dsmc_case(200000, 500.0));
  for (const int sig : {SIGINT, SIGTERM, SIGUSR1, SIGXCPU}) {
    SCOPED_TRACE(strsignal(sig));
    fs::remove_all(tmp / "out.checkpoints");
    RunOptions opt;
    opt.send_signal = sig;
    opt.send_when = "running";
    const RunResult r = grainbath(run_args(), opt);
    EXPECT_TRUE(r.exited && r.code == 130) << r.describe();
    EXPECT_NE(r.err.find("grainbath: stop requested: writing a checkpoint"), std::string::npos) << r.err;
    EXPECT_TRUE(fs::is_directory(tmp / "out.checkpoints") && !fs::is_empty(tmp / "out.checkpoints")) << r.err;
    EXPECT_FALSE(fs::exists(out()));
  }
}

// A stop request repeated within 2 s is the same request (delivered twice): the run still
// stops with a checkpoint; one repeated 2 s or more later stops it at once, without one
// (commands.cpp, on_signal). A DSMC run reaches its next step milliseconds after the first
// request, before any repeat arrives, so this needs an EDMD run, which honours the request
// at its next scheduled rebuild (10 collisions per particle): a dilute gas of disks (many
// cell crossings per collision) takes seconds to get there from its start. The later repeat
// is made 2.2 s later by holding the run (SIGSTOP) meanwhile, so that no speed of the machine
// lets the run reach its rebuild first; the repeat within 2 s comes 0.3 s after the first the
// same way. (Audit of the CLI commands, C01 and C02.)
TEST_F(Commands, ARepeatedStopRequestIsOneWithinTwoSecondsAndStopsAtOnceLater) {
  write_text(case_dir() / "case.toml", R"([run]
solver = "edmd"
seed = 5
[edmd]
dimensions = 2
particles = 10000
packing_fraction = 0.007
equilibrate = 0
collisions = 20.0
[restitution]
law = "elastic"
)");
  RunOptions opt;
  opt.send_signal = SIGINT;
  opt.send_when = "running";
  opt.send_again_when = "stop requested";
  opt.pause_before_again_s = 0.3;  // (sent at once, the repeat came within 2 ms, as a C01 window)
  RunResult r = grainbath(run_args(), opt);
  EXPECT_TRUE(r.exited && r.code == 130) << r.describe();
  EXPECT_NE(r.err.find("interrupted at 10 collisions per particle"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::is_directory(tmp / "out.checkpoints") && !fs::is_empty(tmp / "out.checkpoints")) << r.err;
  EXPECT_FALSE(fs::exists(out()));
  fs::remove_all(tmp / "out.checkpoints");
  opt.pause_before_again_s = 2.2;
  r = grainbath(run_args(), opt);
  EXPECT_TRUE(!r.exited && r.signal == SIGINT) << r.describe();  // the default action, at once
  EXPECT_TRUE(!fs::exists(tmp / "out.checkpoints") || fs::is_empty(tmp / "out.checkpoints")) << r.err;
  EXPECT_FALSE(fs::exists(out()));
}

// A run started with SIGHUP ignored (nohup) keeps it ignored: a closed terminal does not stop
// it. The case runs for a few seconds; the hang-up arrives 0.3 s after it starts.
TEST_F(Commands, ASignalIgnoredAtTheStartStaysIgnored) {
  write_text(case_dir() / "case.toml", dsmc_case(50000, 100.0));
  RunOptions opt;
  opt.ignored_signals = {SIGHUP};
  opt.send_signal = SIGHUP;
  opt.send_when = "running";
  const RunResult r = grainbath(run_args(), opt);
  EXPECT_TRUE(r.exited && r.code == 0) << r.describe();
  EXPECT_EQ(r.err.find("stop requested"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(out() / "summary.json"));
}

// The table on stdout is a copy of summary.json: a reader that went away (`| head`) leaves
// the run to finish and exit 0, not killed by SIGPIPE.
TEST_F(Commands, AReaderThatWentAwayDoesNotKillTheRun) {
  write_text(case_dir() / "case.toml", dsmc_case(1000, 0.2));
  RunOptions opt;
  opt.close_stdout = true;
  const RunResult r = grainbath(run_args({"--quiet"}), opt);
  EXPECT_TRUE(r.exited && r.code == 0) << r.describe();
  EXPECT_TRUE(fs::exists(out() / "summary.json"));
}

// A finished run names its files on stdout, and its summary.json names the solver, the seed,
// the version and the build's commit (docs/OUTPUT.md, "summary.json"). An EDMD case with
// threads > 1 is told its event loop runs on one thread, except with --quiet. The threads of
// an EDMD run (its snapshot measurements) are [run] threads where given, else one, or
// OMP_NUM_THREADS where set (performance.threads; OpenMP's own default would be every core,
// whose idle workers spin between snapshots).
TEST_F(Commands, ARunNamesItsFilesAndItself) {
  write_text(case_dir() / "case.toml", dsmc_case(1000, 0.2));
  RunResult r = grainbath(run_args({"--quiet"}));
  ASSERT_TRUE(r.exited && r.code == 0) << r.describe();
  EXPECT_NE(r.out.find("results: " + out().string() + "/results.h5, " + out().string() + "/summary.json\n"),
            std::string::npos)
      << r.out;
  const std::string summary = read_text(out() / "summary.json");
  EXPECT_NE(summary.find("\"solver\": \"dsmc\""), std::string::npos) << summary;
  EXPECT_TRUE(std::regex_search(summary, std::regex(R"("run": \{\s*"seed": 7,\s*"version": "[0-9.]+",\s*"commit": ")")))
      << summary;
  write_text(case_dir() / "case.toml", kEdmdCase);
  const std::regex two_threads(R"("performance": \{[^}]*"threads": 2\b)"), one_thread(R"("performance": \{[^}]*"threads": 1\b)");
  r = grainbath(run_args({"--set", "run.threads=2"}));
  ASSERT_TRUE(r.exited && r.code == 0) << r.describe();
  EXPECT_NE(r.err.find("note: [run] threads = 2: the EDMD event loop runs on one thread"), std::string::npos) << r.err;
  EXPECT_NE(read_text(out() / "summary.json").find("\"solver\": \"edmd\""), std::string::npos);
  EXPECT_TRUE(std::regex_search(read_text(out() / "summary.json"), two_threads)) << read_text(out() / "summary.json");
  r = grainbath(run_args({"--set", "run.threads=2", "--quiet"}));
  ASSERT_TRUE(r.exited && r.code == 0) << r.describe();
  EXPECT_EQ(r.err.find("note: [run] threads"), std::string::npos) << r.err;
  // without run.threads (run_args sets 1): the default, 0
  const std::vector<std::string> bare = {"run", case_dir().string(), "--out", out().string(), "--quiet"};
  if (std::getenv("OMP_NUM_THREADS") == nullptr) {  // the default: one thread, whatever the cores
    r = grainbath(bare);
    ASSERT_TRUE(r.exited && r.code == 0) << r.describe();
    EXPECT_TRUE(std::regex_search(read_text(out() / "summary.json"), one_thread)) << read_text(out() / "summary.json");
  }
  RunOptions omp2;
  omp2.env = {{"OMP_NUM_THREADS", "2"}};
  r = grainbath(bare, omp2);
  ASSERT_TRUE(r.exited && r.code == 0) << r.describe();
  EXPECT_TRUE(std::regex_search(read_text(out() / "summary.json"), two_threads)) << read_text(out() / "summary.json");
}

// A run that fails (here a non-finite sample, the test hook of core/run_support.hpp) says that
// no output was moved, which checkpoints remain, and the exact command that continues: the
// same case, --out, --quiet and --set options, and --resume.
TEST_F(Commands, AFailedRunSaysWhatSurvivedAndHowToContinue) {
  write_text(case_dir() / "case.toml", dsmc_case(1000, 0.2) + "[checkpoint]\nevery = 0.05\n");
  RunOptions opt;
  opt.env = {{"GRAINBATH_FAULT_NONFINITE_SAMPLE", "3"}};
  const RunResult r = grainbath(run_args({"--quiet"}), opt);
  EXPECT_TRUE(r.exited && r.code == 1) << r.describe();
  EXPECT_NE(r.err.find("(no output was moved into " + out().string() + "; any previous output there is untouched)"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("(the checkpoints in " + (tmp / "out.checkpoints").string() + " remain: once the cause is fixed, "),
            std::string::npos)
      << r.err;
  // (the paths of TempDir need no quotes)
  EXPECT_NE(r.err.find(" run " + case_dir().string() + " --out " + out().string() +
                       " --quiet --set run.threads=1 --resume continues from the newest)"),
            std::string::npos)
      << r.err;
}

// `check` names the solver and seed it read; a case with problems says each and their count.
TEST_F(Commands, CheckSaysTheSolverAndSeedOrHowManyProblems) {
  write_text(case_dir() / "case.toml", kEdmdCase);
  RunResult r = grainbath({"check", case_dir().string()});
  EXPECT_TRUE(r.exited && r.code == 0) << r.describe();
  EXPECT_EQ(r.out, (case_dir() / "case.toml").string() + ": OK (solver edmd, seed 5)\n");
  r = grainbath({"check", case_dir().string(), "--set", "edmd.particles=-1", "--set", "restitution.e=2"});
  EXPECT_TRUE(r.exited && r.code == 2) << r.describe();
  EXPECT_NE(r.err.find("\n2 problem(s); nothing was run.\n"), std::string::npos) << r.err;
}

// `theory` explains the expansion in eps only where there is one (a medium): a free-cooling
// case has none, so its about block has the units alone.
TEST_F(Commands, TheoryExplainsTheExpansionOnlyWhereThereIsOne) {
  write_text(case_dir() / "case.toml", dsmc_case(1000, 0.2));
  const RunResult r = grainbath({"theory", case_dir().string()});
  ASSERT_TRUE(r.exited && r.code == 0) << r.describe();
  EXPECT_NE(r.out.find("\"units\": \"DSMC units"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("\"expansion\""), std::string::npos) << r.out;
}

// list-models gives each restitution law's keys under it.
TEST_F(Commands, ListModelsGivesEachLawsKeys) {
  const RunResult r = grainbath({"list-models"});
  ASSERT_TRUE(r.exited && r.code == 0) << r.describe();
  EXPECT_NE(r.out.find("  constant   e constant\n             - e (required"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("             - beta0 (required"), std::string::npos) << r.out;
}

// theory, check and list-models make their standard output: when it cannot be written
// (here /dev/full, as a full disk under `> theory.json`) they fail with exit 1 and say why;
// they exited 0 with nothing written. A bad case stays exit 2.
TEST_F(Commands, TheoryCheckAndListModelsFailWhenTheirOutputCannotBeWritten) {
  write_text(case_dir() / "case.toml", dsmc_case(1000, 0.2));
  RunOptions full;
  full.stdout_to_dev_full = true;
  const std::vector<std::pair<std::string, std::vector<std::string>>> commands = {
      {"theory", {"theory", case_dir().string()}},
      {"check", {"check", case_dir().string()}},
      {"list-models", {"list-models"}}};
  for (const auto& [name, args] : commands) {
    SCOPED_TRACE(name);
    const RunResult r = grainbath(args, full);
    EXPECT_TRUE(r.exited && r.code == 1) << r.describe();
    EXPECT_EQ(r.err, "error: " + name + ": cannot write its output to standard output (No space left on device)\n");
  }
  const RunResult bad = grainbath({"theory", case_dir().string(), "--set", "restitution.e=2"}, full);
  EXPECT_TRUE(bad.exited && bad.code == 2) << bad.describe();
}

// `report` runs $GRAINBATH_PYTHON_DIR/report.py and returns its exit status as it is (2 bad
// input, 3 a module missing: python/README.md); a GRAINBATH_PYTHON_DIR without report.py is
// refused (exit 1), never replaced by another copy.
TEST_F(Commands, ReportReturnsTheScriptsStatusAndRefusesADirectoryWithoutIt) {
  write_text(tmp / "py" / "report.py", "import sys\nprint('args', sys.argv[1:])\nsys.exit(3)\n");
  RunOptions opt;
  opt.env = {{"GRAINBATH_PYTHON_DIR", (tmp / "py").string()}};
  RunResult r = grainbath({"report", (tmp / "somewhere").string(), "--strict"}, opt);
  EXPECT_TRUE(r.exited && r.code == 3) << r.describe();
  EXPECT_NE(r.out.find("args ['" + (tmp / "somewhere").string() + "', '--strict']"), std::string::npos) << r.out;
  fs::create_directories(tmp / "empty");
  opt.env = {{"GRAINBATH_PYTHON_DIR", (tmp / "empty").string()}};
  r = grainbath({"report", (tmp / "somewhere").string()}, opt);
  EXPECT_TRUE(r.exited && r.code == 1) << r.describe();
  EXPECT_NE(r.err.find("GRAINBATH_PYTHON_DIR=" + (tmp / "empty").string() + " has no report.py"), std::string::npos)
      << r.err;
}

// The run's table marks an error whose blocking reached no plateau (summary.json
// `stderr_plateau` false): a free-cooling gas drifts through its window, so a2's error there is
// a lower bound, "(no plateau: use replicas)".
TEST_F(Commands, TheRunTableMarksAnErrorWithoutAPlateau) {
  write_text(case_dir() / "case.toml", dsmc_case(20000, 20.0));
  const RunResult r = grainbath(run_args({"--quiet"}));
  ASSERT_TRUE(r.exited && r.code == 0) << r.describe();
  const std::string summary = read_text(out() / "summary.json");
  ASSERT_TRUE(std::regex_search(summary, std::regex(R"("a2": \{[^}]*"stderr_plateau": false)")))
      << "the case's premise: a2's error without a plateau\n" << summary;
  const std::size_t row = r.out.find("  a2 (window mean)");
  ASSERT_NE(row, std::string::npos) << r.out;
  const std::string line = r.out.substr(row, r.out.find('\n', row) - row);
  EXPECT_NE(line.find(" +- "), std::string::npos) << line;
  EXPECT_TRUE(line.ends_with(" (no plateau: use replicas)")) << line;
  // the headline beside it: the final temperature, summary.json's to the table's 8 digits
  std::smatch final_T;
  ASSERT_TRUE(std::regex_search(summary, final_T, std::regex(R"("temperature": \{[^}]*"final": ([-+.0-9eE]+))"))) << summary;
  const std::size_t at = r.out.find("  temperature (final)");
  ASSERT_NE(at, std::string::npos) << r.out;
  EXPECT_NEAR(std::stod(r.out.substr(at + 21)), std::stod(final_T[1]), 1e-7 * std::stod(final_T[1])) << r.out;
}
