// What `run --out` and `sweep --out` may move aside or delete (new-user review, 2026-11-26):
// the previous output is moved to OUT.previous and the one before deleted, so only a
// directory grainbath wrote (summary.json, results.h5, sweep.md, variant-*) or an empty one
// may be taken; a case directory, the current directory, a file, a link or a directory of
// the user's own are refused at start-up, before any work, with nothing changed.
#include <fcntl.h>
#include <gtest/gtest.h>

#include <cmath>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "core/h5.hpp"
#include "tests/cli/cli_harness.hpp"

using namespace grainbath::testing;

namespace {

const std::string kBinary = GRAINBATH_BINARY;

// The cells of a Markdown table row, split at '|' (the first is the empty text before it).
std::vector<std::string> table_cells(const std::string& row) {
  std::vector<std::string> cols;
  std::istringstream cells(row);
  for (std::string cell; std::getline(cells, cell, '|');) cols.push_back(cell);
  return cols;
}

// a homogeneous DSMC case of a fraction of a second
const char* kCase = R"([run]
solver = "dsmc"
seed = 1
[grains]
density = 1.0
temperature = 1.0
[restitution]
law = "constant"
e = 0.9
[dsmc]
particles = 1000
dt = 0.01
t_end = 0.2
[sampling]
every = 0.05
steady_from = 0.1
)";

class OutputDir : public ::testing::Test {
 protected:
  TempDir tmp;
  fs::path case_dir() const { return tmp / "case"; }
  fs::path work() const { return tmp / "work"; }
  // the header line of a sweep's sweep.md table ("" if none)
  static std::string sweep_table_header(const fs::path& sweep) {
    const std::string md = read_text(sweep / "sweep.md");
    const std::size_t header = md.find("| variant |");
    return header == std::string::npos ? std::string() : md.substr(header, md.find('\n', header) - header);
  }
  void SetUp() override {
    write_text(case_dir() / "case.toml", kCase);
    fs::create_directories(work());
  }
  RunResult grainbath(std::vector<std::string> args, fs::path cwd = {}) {
    args.insert(args.begin(), kBinary);
    RunOptions opt;
    opt.cwd = cwd.empty() ? work() : cwd;
    return run_binary(args, opt);
  }
  // grainbath with every move to a path ending in `suffix` failing (EXDEV, as across file
  // systems; tests/cli/fail_rename.cpp), the only way to make a move fail for root
  RunResult grainbath_failing_moves_to(const std::string& suffix, std::vector<std::string> args) {
    args.insert(args.begin(), kBinary);
    RunOptions opt;
    opt.cwd = work();
    const char* asan = std::getenv("ASAN_OPTIONS");
    opt.env = {{"LD_PRELOAD", GRAINBATH_FAIL_RENAME},
               {"GRAINBATH_TEST_FAIL_RENAME_TO", suffix},
               // the shim is loaded before the sanitizer runtime of the ASan build
               {"ASAN_OPTIONS", std::string(asan ? asan : "") + (asan && *asan ? ":" : "") + "verify_asan_link_order=0"}};
    return run_binary(args, opt);
  }
  RunResult run(const fs::path& out, fs::path cwd = {}) {
    return grainbath({"run", case_dir().string(), "--out", out.string(), "--quiet", "--set", "run.threads=1"}, cwd);
  }
  // exit 2 at start-up with `what` in the message, and the temporary directory as it was
  // (`named`: the path the message names, if not out)
  void expect_refused(const fs::path& out, const std::string& what, fs::path cwd = {}, fs::path named = {}) {
    const auto before = listing(tmp.path());
    const RunResult r = run(out, cwd);
    EXPECT_TRUE(r.exited && r.code == 2) << r.describe();
    EXPECT_NE(r.err.find("error: " + (named.empty() ? out : named).string() + ": " + what), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("running"), std::string::npos) << "refused only after starting:\n" << r.err;
    EXPECT_EQ(listing(tmp.path()), before);
  }
};

TEST_F(OutputDir, CaseDirectoryIsRefused) {
  expect_refused(case_dir(), "would hold");
  expect_refused(tmp.path(), "would hold", "/");  // an ancestor of the case (run from elsewhere)
  EXPECT_TRUE(fs::exists(case_dir() / "case.toml"));
}

TEST_F(OutputDir, CurrentDirectoryOrAncestorIsRefused) {
  write_text(work() / "summary.json", "{}");  // grainbath output, but the run's own cwd
  expect_refused(".", "is the current directory or contains it");
  fs::create_directories(work() / "sub");
  expect_refused("..", "is the current directory or contains it", work() / "sub");
}

TEST_F(OutputDir, DirectoryOfTheUsersOwnIsRefused) {
  write_text(tmp / "notes" / "notes.txt", "mine");
  expect_refused(tmp / "notes", "exists and does not hold grainbath output");
  EXPECT_EQ(read_text(tmp / "notes" / "notes.txt"), "mine");
}

TEST_F(OutputDir, FileAndLinkAreRefused) {
  write_text(tmp / "file", "mine");
  expect_refused(tmp / "file", "exists and is not a directory");
  fs::create_directories(tmp / "target");
  fs::create_directory_symlink(tmp / "target", tmp / "link");
  expect_refused(tmp / "link", "is a symbolic link");
}

TEST_F(OutputDir, PreviousOutputIsKeptAndOnlyGrainbathsIsDeleted) {
  const fs::path out = tmp / "out";
  RunResult r = run(out);
  ASSERT_EQ(r.code, 0);
  EXPECT_EQ(r.err.find("was moved to"), std::string::npos) << r.err;  // nothing was there
  // each move is said, even with --quiet, and so is the deletion of an older .previous (review
  // 4: a third run deleted the first one's output without a word)
  r = run(out);
  ASSERT_EQ(r.code, 0);
  EXPECT_NE(r.err.find("note: the previous output in " + out.string() + " was moved to " + out.string() + ".previous\n"),
            std::string::npos)
      << r.err;
  r = run(out);
  ASSERT_EQ(r.code, 0);
  EXPECT_NE(r.err.find(".previous (the older output there was deleted)"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(out / "summary.json"));
  EXPECT_TRUE(fs::exists(tmp / "out.previous" / "summary.json"));
  // the build's git commit is recorded beside the version (review 4)
  EXPECT_NE(read_text(out / "summary.json").find("\"commit\": \""), std::string::npos);
  // a directory of the user's own where OUT.previous goes: refused (it would be deleted)
  fs::remove_all(tmp / "out.previous");
  write_text(tmp / "out.previous" / "notes.txt", "mine");
  expect_refused(out, "exists and does not hold grainbath output", {}, tmp / "out.previous");
  EXPECT_EQ(read_text(tmp / "out.previous" / "notes.txt"), "mine");
  // an empty directory is taken; "out/" names the same directory as "out"
  fs::remove_all(tmp / "out.previous");
  fs::create_directories(tmp / "empty");
  EXPECT_EQ(run(tmp / "empty").code, 0);
  EXPECT_EQ(run(out.string() + "/").code, 0);
  EXPECT_TRUE(fs::exists(tmp / "out.previous" / "summary.json"));
}

TEST_F(OutputDir, SweepMovesThePreviousSweepAsideAndFixedKeysAreNoAxes) {
  const fs::path out = tmp / "sweep";
  auto sweep = [&](const std::string& seeds) {
    return grainbath({"sweep", case_dir().string(), "--out", out.string(), "-j", "1", "--set", "run.seed=" + seeds,
                      "--set", "run.threads=1"});
  };
  RunResult r = sweep("1,2");
  ASSERT_EQ(r.code, 0) << r.describe();
  // run.threads has one value: a setting of every run, not an axis, so this is an ensemble
  EXPECT_TRUE(fs::exists(out / "variant-0_seed_1" / "summary.json"));
  EXPECT_TRUE(fs::exists(out / "ensemble.json"));
  EXPECT_NE(r.err.find("sweep: 2/2 done"), std::string::npos) << r.err;  // the progress lines
  // each with the variant's own wall time and the sweep's, labelled (review 4: "(30s)" was the
  // time since the sweep started, unlabelled)
  EXPECT_TRUE(std::regex_search(r.err, std::regex(R"(sweep: 2/2 done +variant-1_seed_2  \(variant [0-9.]+ s, sweep [0-9.]+ s elapsed\))")))
      << r.err;
  r = sweep("3,4,5");
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_NE(r.err.find("sweep: the previous sweep in " + out.string() + " was moved to"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out / "variant-0_seed_1"));
  EXPECT_TRUE(fs::exists(out / "variant-2_seed_5" / "summary.json"));
  EXPECT_TRUE(fs::exists(tmp / "sweep.previous" / "variant-0_seed_1" / "summary.json"));
  EXPECT_NE(read_text(out / "ensemble.md").find("mean over 3 replicas"), std::string::npos);
  // the same theory number in every replica: that number with a zero error, not rounding noise
  // (every "theory." row: the replicas share the case's parameters)
  std::size_t theory_rows = 0;
  std::istringstream md(read_text(out / "ensemble.md"));
  for (std::string line; std::getline(md, line);) {
    if (line.rfind("| theory.", 0) != 0) continue;
    ++theory_rows;
    const std::vector<std::string> cols = table_cells(line);  // "", quantity, mean, standard error, per-run
    ASSERT_GE(cols.size(), 4u) << line;
    EXPECT_EQ(cols[3], " 0 ") << line;
  }
  EXPECT_GE(theory_rows, 3u);
  // a directory of the user's own is refused before any run
  write_text(tmp / "notes" / "notes.txt", "mine");
  const auto before = listing(tmp.path());
  r = grainbath({"sweep", case_dir().string(), "--out", (tmp / "notes").string(), "--set", "run.seed=1,2"});
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_NE(r.err.find("does not hold grainbath output"), std::string::npos) << r.err;
  EXPECT_EQ(listing(tmp.path()), before);
}

// The ensemble's comparison column combines the runs' own errors as the error of a mean of R
// independent runs, sqrt(sum s_i^2)/R (before 2026-12-05: mean(s_i)/sqrt(R), low by Jensen's
// inequality, and blank for the quantities whose error is `key_stderr`); a seed given twice is
// refused before any run (it was run twice and counted as two replicas: the ensemble error
// sqrt(3) too small with 1,1,2,2).
TEST_F(OutputDir, EnsembleCombinesTheRunsOwnErrorsAndRefusesARepeatedSeed) {
  const fs::path out = tmp / "ens";
  RunResult r = grainbath({"sweep", case_dir().string(), "--out", out.string(), "-j", "1", "-q", "--set",
                           "run.seed=1,2,1", "--set", "run.threads=1"});
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_NE(r.err.find("run.seed=1,2,1: the value 1 is given twice"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  r = grainbath({"sweep", case_dir().string(), "--out", out.string(), "-j", "1", "-q", "--set", "run.seed=1,2,3",
                 "--set", "run.threads=1"});
  ASSERT_EQ(r.code, 0) << r.describe();
  // a2: this free-cooling case has no temperature.mean/stderr (since 2026-12-05)
  auto a2_stderr = [](const std::string& json) {  // "a2": {"mean": .., "stderr": x
    const std::size_t at = json.find("\"stderr\"", json.find("\"a2\""));
    return std::stod(json.substr(json.find(':', at) + 1));
  };
  double s2 = 0, s1 = 0;
  for (const char* v : {"variant-0_seed_1", "variant-1_seed_2", "variant-2_seed_3"}) {
    const double s = a2_stderr(read_text(out / v / "summary.json"));
    s2 += s * s;
    s1 += s;
  }
  // the test tells the two combinations apart only if the runs' errors differ enough
  std::printf("runs' errors combined: sqrt(sum s^2)/R = %.6g, mean(s)/sqrt(R) = %.6g\n", std::sqrt(s2) / 3.0,
              s1 / 3.0 / std::sqrt(3.0));
  ASSERT_GT(std::sqrt(s2) / 3.0 - s1 / 3.0 / std::sqrt(3.0), 3e-3 * std::sqrt(s2) / 3.0);
  std::istringstream md(read_text(out / "ensemble.md"));
  std::string row;
  for (std::string line; std::getline(md, line);)
    if (line.rfind("| a2.mean |", 0) == 0) row = line;
  const std::vector<std::string> cols = table_cells(row);  // "", quantity, mean, standard error, per-run
  ASSERT_GE(cols.size(), 5u) << row;
  EXPECT_NEAR(std::stod(cols[4]), std::sqrt(s2) / 3.0, 1e-3 * std::sqrt(s2) / 3.0) << row;
  EXPECT_EQ(read_text(out / "ensemble.md").find("_stderr |"), std::string::npos) << "an error merged as a quantity";
}

// `sweep --quiet`: no progress lines on stderr, the same sweep and its table on stdout (a failed
// variant would still be reported: the progress line is skipped only for a finished one).
TEST_F(OutputDir, QuietSweepPrintsNoProgressButTheTable) {
  const fs::path out = tmp / "quiet";
  RunResult r = grainbath({"sweep", case_dir().string(), "--out", out.string(), "-j", "1", "-q", "--set",
                           "run.seed=1,2", "--set", "run.threads=1"});
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_EQ(r.err.find("sweep:"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("table:"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(out / "variant-1_seed_2" / "summary.json"));
}

// Review of 2026-11-26: names alone do not make grainbath output (a user's variant-calls.vcf,
// a summary.json of their own); "link/../x" is x beside the link's target, as the kernel
// resolves it, and is checked there; "out/" keeps its checkpoints beside it, not inside.
TEST_F(OutputDir, NamesAloneAreNotGrainbathOutputAndLinkDotDotIsResolvedInOrder) {
  write_text(tmp / "mydata" / "notes.txt", "mine");
  write_text(tmp / "mydata" / "variant-calls.vcf", "mine");
  write_text(tmp / "mydata" / "summary.json", "{}");
  expect_refused(tmp / "mydata", "exists and does not hold grainbath output");
  fs::create_directories(tmp / "elsewhere" / "deep");
  write_text(tmp / "elsewhere" / "victim" / "mine.txt", "mine");
  write_text(tmp / "elsewhere" / "victim.previous" / "mydata.txt", "mine");
  fs::create_directory_symlink(tmp / "elsewhere" / "deep", tmp / "dl");
  const auto before = listing(tmp.path());
  const RunResult r = grainbath({"sweep", case_dir().string(), "--out", (tmp / "dl" / ".." / "victim").string(), "-j",
                                 "1", "--set", "run.seed=1,2"});
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_EQ(listing(tmp.path()), before);
  EXPECT_EQ(read_text(tmp / "elsewhere" / "victim.previous" / "mydata.txt"), "mine");
}

TEST_F(OutputDir, TrailingSlashKeepsCheckpointsBesideTheOutput) {
  write_text(case_dir() / "case.toml", std::string(kCase) + "[checkpoint]\nevery = 0.1\nkeep = true\n");
  const RunResult r = run(work().string() + "/o2/");
  EXPECT_EQ(r.code, 0) << r.describe();
  EXPECT_TRUE(fs::exists(work() / "o2" / "summary.json"));
  EXPECT_FALSE(fs::exists(work() / "o2" / ".checkpoints"));
}

}  // namespace

// ------------------------------------------------------------ a run's life: checkpoints, signals
// (second workflow review, 2026-11-27: /work/review2.md A2, A6, A7, A8, B1)

// A fresh run used to leave an earlier run's checkpoints in OUT.checkpoints, and the
// keep-two-newest rule then deleted the new run's lower-numbered checkpoint as it was written.
TEST_F(OutputDir, AFreshRunSetsAnEarlierRunsCheckpointsAside) {
  const fs::path out = tmp / "out";
  write_text(tmp / "out.checkpoints" / "checkpoint-000000009000.h5", "an earlier run's");
  write_text(tmp / "out.checkpoints" / "checkpoint-000000009174.h5", "an earlier run's, newer");
  RunResult r = grainbath({"run", case_dir().string(), "--out", out.string(), "--quiet", "--set", "run.threads=1",
                           "--set", "checkpoint.every=0.05", "--set", "checkpoint.keep=true"});
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_NE(r.err.find("held 2 checkpoint(s) of an earlier run (the newest: checkpoint-000000009174.h5)"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(read_text(tmp / "out.checkpoints.previous" / "checkpoint-000000009174.h5"), "an earlier run's, newer");
  // this run's own two newest are kept, nothing else (every 5 of its 20 steps; keep: the end)
  std::vector<std::string> mine;
  for (const auto& e : fs::directory_iterator(tmp / "out.checkpoints")) mine.push_back(e.path().filename().string());
  std::sort(mine.begin(), mine.end());
  EXPECT_EQ(mine, (std::vector<std::string>{"checkpoint-000000000015.h5", "checkpoint-000000000020.h5"}));
  // a directory of that name holding anything else is refused before any work
  write_text(tmp / "out.checkpoints" / "notes.txt", "mine");
  const auto before = listing(tmp.path());
  r = run(out);
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_NE(r.err.find("holds notes.txt, which is not a checkpoint"), std::string::npos) << r.err;
  EXPECT_EQ(listing(tmp.path()), before);
  // ... and so is a file of the user's where the earlier checkpoints would go (it was deleted)
  fs::remove(tmp / "out.checkpoints" / "notes.txt");
  fs::remove_all(tmp / "out.checkpoints.previous");
  write_text(tmp / "out.checkpoints.previous", "mine too");
  const auto before2 = listing(tmp.path());
  r = run(out);
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_NE(r.err.find("out.checkpoints.previous: is not a directory of checkpoints"), std::string::npos) << r.err;
  EXPECT_EQ(listing(tmp.path()), before2);
  EXPECT_EQ(read_text(tmp / "out.checkpoints.previous"), "mine too");
}

TEST_F(OutputDir, ResumeWithoutACheckpointOrWithAChangedCaseIsBadInput) {
  const fs::path out = tmp / "out";
  RunResult r = grainbath({"run", case_dir().string(), "--out", out.string(), "--quiet", "--resume"});
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_NE(r.err.find("--resume: no checkpoint in " + (tmp / "out.checkpoints").string() + ": nothing to resume"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(out));
  // a checkpoint, then a changed case on --resume: exit 2 (was 1), the checkpoint kept
  r = grainbath({"run", case_dir().string(), "--out", out.string(), "--quiet", "--set", "checkpoint.every=0.1",
                 "--set", "checkpoint.keep=true"});
  ASSERT_EQ(r.code, 0) << r.describe();
  const auto before = listing(tmp / "out.checkpoints");
  r = grainbath({"run", case_dir().string(), "--out", out.string(), "--quiet", "--resume", "--set",
                 "restitution.e=0.8", "--set", "checkpoint.every=0.1", "--set", "checkpoint.keep=true"});
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_NE(r.err.find("restitution.e was 0.9, now 0.8 (only dsmc.t_end, run.threads and [checkpoint] may change"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(listing(tmp / "out.checkpoints"), before);
}

// Review 2, A1: --resume with an end before the checkpoint used to do no step, exit 0 with the
// checkpoint's state reported as t_end, and delete the checkpoints. Now bad input (exit 2),
// the checkpoints kept; the end checkpoint (keep = true) resumed with the same t_end finishes.
TEST_F(OutputDir, ResumeWithAnEndBeforeTheCheckpointIsBadInputAndKeepsIt) {
  const fs::path out = tmp / "out";
  const std::vector<std::string> common = {"--quiet", "--set", "sampling.steady_from=0.05", "--set",
                                           "checkpoint.every=0.15", "--set", "checkpoint.keep=true"};
  auto with = [&](std::vector<std::string> args) {
    args.insert(args.end(), common.begin(), common.end());
    return grainbath(args);
  };
  RunResult r = with({"run", case_dir().string(), "--out", out.string()});  // checkpoints at steps 15, 20
  ASSERT_EQ(r.code, 0) << r.describe();
  const auto before = listing(tmp / "out.checkpoints");
  r = with({"run", case_dir().string(), "--out", out.string(), "--resume", "--set", "dsmc.t_end=0.12"});
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_NE(r.err.find("dsmc.t_end = 0.12 is before the checkpoint (t = 0.2, step 20): give dsmc.t_end >= 0.2 "
                       "(the run that wrote the checkpoint had dsmc.t_end = 0.2"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(listing(tmp / "out.checkpoints"), before);
  r = with({"run", case_dir().string(), "--out", out.string(), "--resume"});
  EXPECT_EQ(r.code, 0) << r.describe();
  EXPECT_NE(r.err.find("resuming from step 20"), std::string::npos) << r.err;
}

// SIGHUP (a closed terminal) is a stop request like SIGINT: checkpoint, exit 130, said at
// once; the same signal again stops at once, without a checkpoint, and the temporary output
// it leaves is removed by the next run into the same --out.
TEST_F(OutputDir, HangupStopsWithACheckpointAndADeadRunsTemporaryIsRemoved) {
  std::string long_case = kCase;
  long_case.replace(long_case.find("particles = 1000"), 16, "particles = 200000");
  long_case.replace(long_case.find("t_end = 0.2"), 11, "t_end = 500.0");
  write_text(case_dir() / "case.toml", long_case);
  const fs::path out = tmp / "out";
  RunOptions opt;
  opt.cwd = work();
  opt.send_signal = SIGHUP;
  opt.send_when = "running";
  RunResult r = run_binary({kBinary, "run", case_dir().string(), "--out", out.string(), "--set", "run.threads=1"}, opt);
  EXPECT_TRUE(r.exited && r.code == 130) << r.describe();
  EXPECT_NE(r.err.find("grainbath: stop requested"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::is_empty(tmp / "out.checkpoints"));
  EXPECT_FALSE(fs::exists(out));
  // the same request delivered twice at once (a closed terminal: the kernel's SIGHUP and the
  // shell's) is one request: still a checkpoint, exit 130 (review 3: it killed the run)
  fs::remove_all(tmp / "out.checkpoints");
  opt.send_again_when = "stop requested";
  r = run_binary({kBinary, "run", case_dir().string(), "--out", out.string(), "--set", "run.threads=1"}, opt);
  EXPECT_TRUE(r.exited && r.code == 130) << r.describe();
  EXPECT_FALSE(fs::is_empty(tmp / "out.checkpoints"));
  // a run killed outright leaves its temporary directory
  opt.send_signal = SIGKILL;
  opt.send_again_when.clear();
  r = run_binary({kBinary, "run", case_dir().string(), "--out", out.string(), "--set", "run.threads=1", "--resume"},
                 opt);
  EXPECT_FALSE(r.exited) << r.describe();
  std::vector<fs::path> temporaries;
  for (const auto& e : fs::directory_iterator(tmp.path()))
    if (e.path().filename().string().rfind("out.tmp-", 0) == 0) temporaries.push_back(e.path());
  ASSERT_EQ(temporaries.size(), 1u);
  EXPECT_NE(read_text(temporaries[0] / ".grainbath-output").find("temporary of the run on host"), std::string::npos);
  // the next run into out removes it (no process holds its lock) and says so
  write_text(case_dir() / "case.toml", kCase);
  r = run(out);
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_FALSE(fs::exists(temporaries[0]));
  EXPECT_NE(r.err.find("note: removed " + temporaries[0].string()), std::string::npos) << r.err;
  // results kept after a failed final move are re-marked as plain output: never removed
  const fs::path kept = tmp / "out.tmp-999999999";
  write_text(kept / ".grainbath-output", "written by grainbath (docs/OUTPUT.md): --out may replace this directory\n");
  r = run(out);
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_TRUE(fs::exists(kept));
  EXPECT_NE(r.err.find("holds the results of an earlier run"), std::string::npos) << r.err;
}

TEST_F(OutputDir, ABuildWithoutMpiRefusesToRunAsOneOfSeveralMpiProcesses) {
  RunOptions opt;
  opt.cwd = work();
  opt.env = {{"OMPI_COMM_WORLD_SIZE", "2"}, {"OMPI_COMM_WORLD_RANK", "0"}};
  const auto before = listing(tmp.path());
  RunResult r = run_binary({kBinary, "run", case_dir().string(), "--out", (tmp / "out").string()}, opt);
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_NE(r.err.find("this grainbath was built without MPI, but runs as one of 2 MPI processes"), std::string::npos)
      << r.err;
  EXPECT_EQ(listing(tmp.path()), before);
  // the other ranks refuse too, without repeating the message (one error per mpirun, not N)
  opt.env = {{"OMPI_COMM_WORLD_SIZE", "2"}, {"OMPI_COMM_WORLD_RANK", "1"}};
  r = run_binary({kBinary, "run", case_dir().string(), "--out", (tmp / "out").string()}, opt);
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_EQ(r.err, "") << r.err;
  EXPECT_EQ(listing(tmp.path()), before);
  // MPICH's and Slurm's launchers say it with PMI_SIZE / PMI_RANK; a sweep is refused as well
  opt.env = {{"PMI_SIZE", "3"}, {"PMI_RANK", "0"}};
  r = run_binary({kBinary, "sweep", case_dir().string(), "--set", "run.seed=1,2", "--out", (tmp / "sw").string()}, opt);
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_NE(r.err.find("runs as one of 3 MPI processes"), std::string::npos) << r.err;
  EXPECT_EQ(listing(tmp.path()), before);
  // one process under a launcher is a plain run
  opt.env = {{"OMPI_COMM_WORLD_SIZE", "1"}, {"OMPI_COMM_WORLD_RANK", "0"}};
  r = run_binary({kBinary, "run", case_dir().string(), "--out", (tmp / "out").string(), "--quiet"}, opt);
  EXPECT_EQ(r.code, 0) << r.describe();
  EXPECT_TRUE(fs::exists(tmp / "out" / "summary.json"));
}

// results.h5 is a function of case and seed alone: `cmp` of 1- and 2-thread runs (the file
// used to differ in the /parameters attribute run.threads; review 2, B7)
TEST_F(OutputDir, ResultsFileIsTheSameBytesAtOneAndTwoThreads) {
  for (const char* t : {"1", "2"}) {
    const RunResult r = grainbath({"run", case_dir().string(), "--out", (tmp / std::string("t").append(t)).string(),
                                   "--quiet", "--set", std::string("run.threads=").append(t)});
    ASSERT_EQ(r.code, 0) << r.describe();
  }
  EXPECT_EQ(read_text(tmp / "t1" / "results.h5"), read_text(tmp / "t2" / "results.h5"));
}

// An interrupted sweep (review 2, B9): Ctrl-C reaches the sweep, which passes it on to the
// running variant (checkpoint, stop), starts no other, says what happened and how to go on;
// `sweep --resume` keeps the finished variant, resumes the stopped one from its checkpoint
// (the same bytes as a straight run) and runs the rest. A different --set is refused.
TEST_F(OutputDir, InterruptedSweepResumes) {
  std::string c = kCase;
  c.replace(c.find("particles = 1000"), 16, "particles = 100000");  // about 2 s a variant (one thread)
  c.replace(c.find("t_end = 0.2"), 11, "t_end = 50.0");
  write_text(case_dir() / "case.toml", c);
  const fs::path out = tmp / "sweep";
  const std::vector<std::string> sweep = {kBinary, "sweep", case_dir().string(), "--out", out.string(), "-j", "1",
                                          "--set", "run.seed=1,2,3"};
  RunOptions opt;
  opt.cwd = work();
  opt.timeout_s = 120;
  opt.send_signal = SIGINT;
  opt.send_when = "sweep: 1/3 done";
  RunResult r = run_binary(sweep, opt);
  EXPECT_TRUE(r.exited && r.code == 130) << r.describe();
  EXPECT_NE(r.err.find("sweep: stop requested"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("sweep: interrupted: 1 of 3 variants finished, 1 stopped with a checkpoint, 1 not started;"),
            std::string::npos)
      << r.err;
  // a stopped variant is no progress: said without a count (review 4: "2/3 stopped")
  EXPECT_NE(r.err.find("sweep: stopped     variant-1_seed_2  (variant "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(", with a checkpoint\n"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("2/3"), std::string::npos) << r.err;
  // the command that continues it has every option the user gave
  EXPECT_NE(r.err.find(" sweep " + case_dir().string() + " --out " + out.string() + " -j 1 --set run.seed=1,2,3 --resume\n"),
            std::string::npos)
      << r.err;
  EXPECT_TRUE(fs::exists(out / "variant-0_seed_1" / "summary.json"));
  EXPECT_FALSE(fs::exists(out / "variant-1_seed_2"));
  EXPECT_FALSE(fs::exists(out / "variant-2_seed_3.log"));  // never started
  // --resume with another --set list is not the same sweep
  std::vector<std::string> other = sweep;
  other.back() = "run.seed=1,2";
  other.push_back("--resume");
  RunOptions plain;
  plain.cwd = work();
  plain.timeout_s = 120;
  r = run_binary(other, plain);
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_NE(r.err.find("differ from the sweep's"), std::string::npos) << r.err;
  // what differs, not only that something does (review 4)
  EXPECT_NE(r.err.find("the sweep's lines not in this command: 'run.seed=1,2,3'; this command's lines not in the "
                       "sweep: 'run.seed=1,2'"),
            std::string::npos)
      << r.err;
  const std::string first = read_text(out / "variant-0_seed_1" / "results.h5");
  std::vector<std::string> resume = sweep;
  resume.push_back("--resume");
  r = run_binary(resume, plain);
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_NE(r.err.find("resuming: 1 of 3 variants finished earlier"), std::string::npos) << r.err;
  EXPECT_EQ(read_text(out / "variant-0_seed_1" / "results.h5"), first);  // kept, not run again
  EXPECT_TRUE(fs::exists(out / "ensemble.json"));
  EXPECT_FALSE(fs::exists(out / "variant-1_seed_2.checkpoints"));
  // the stopped and resumed variant is the straight run, byte for byte
  r = run_binary({kBinary, "run", case_dir().string(), "--out", (tmp / "straight").string(), "--quiet", "--set",
                  "run.seed=2", "--set", "run.threads=1"},
                 plain);
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_EQ(read_text(tmp / "straight" / "results.h5"), read_text(out / "variant-1_seed_2" / "results.h5"));
}

// [checkpoint] keep = true keeps a checkpoint of the end, so a run extended with a longer
// t_end continues from there (review 2, B5: it re-ran from the last periodic checkpoint),
// and the extended run is byte for byte the straight run to the longer end.
TEST_F(OutputDir, KeptCheckpointsIncludeTheEndAndAnExtensionIsTheStraightRun) {
  const fs::path out = tmp / "out";
  RunResult r = grainbath({"run", case_dir().string(), "--out", out.string(), "--quiet", "--set",
                           "checkpoint.keep=true"});
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_TRUE(fs::exists(tmp / "out.checkpoints" / "checkpoint-000000000020.h5"));  // t_end = 0.2, dt = 0.01
  r = grainbath({"run", case_dir().string(), "--out", out.string(), "--quiet", "--set", "checkpoint.keep=true",
                 "--set", "dsmc.t_end=0.4", "--resume"});
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_NE(r.err.find("resuming from step 20"), std::string::npos) << r.err;
  r = grainbath({"run", case_dir().string(), "--out", (tmp / "straight").string(), "--quiet", "--set",
                 "checkpoint.keep=true", "--set", "dsmc.t_end=0.4"});
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_EQ(read_text(out / "results.h5"), read_text(tmp / "straight" / "results.h5"));
}

// run.threads may change on --resume (a run continued on another machine or with other cores
// free): a DSMC run's results do not depend on it (ResultsFileIsTheSameBytesAtOneAndTwoThreads),
// so a run checkpointed at 1 thread and extended at 2 is the straight 2-thread run byte for
// byte; an EDMD run resumes at another thread count too.
TEST_F(OutputDir, ResumeAtAnotherThreadCountContinuesTheRun) {
  const fs::path out = tmp / "out";
  RunResult r = grainbath({"run", case_dir().string(), "--out", out.string(), "--quiet", "--set", "run.threads=1",
                           "--set", "checkpoint.keep=true"});
  ASSERT_EQ(r.code, 0) << r.describe();
  const std::vector<std::string> longer = {"--quiet", "--set", "run.threads=2", "--set", "checkpoint.keep=true", "--set",
                                           "dsmc.t_end=0.3"};
  std::vector<std::string> resume = {"run", case_dir().string(), "--out", out.string(), "--resume"};
  resume.insert(resume.end(), longer.begin(), longer.end());
  r = grainbath(resume);
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_NE(r.err.find("resuming from step 20"), std::string::npos) << r.err;
  std::vector<std::string> straight = {"run", case_dir().string(), "--out", (tmp / "straight").string()};
  straight.insert(straight.end(), longer.begin(), longer.end());
  r = grainbath(straight);
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_EQ(read_text(out / "results.h5"), read_text(tmp / "straight" / "results.h5"));

  write_text(tmp / "edmd" / "case.toml", R"([run]
solver = "edmd"
[edmd]
dimensions = 2
particles = 400
packing_fraction = 0.1
equilibrate = 1
collisions = 20
[restitution]
law = "constant"
e = 0.9
[checkpoint]
keep = true
)");
  const fs::path edmd_out = tmp / "edmd-out";
  r = grainbath({"run", (tmp / "edmd").string(), "--out", edmd_out.string(), "--quiet", "--set", "run.threads=1"});
  ASSERT_EQ(r.code, 0) << r.describe();
  r = grainbath({"run", (tmp / "edmd").string(), "--out", edmd_out.string(), "--quiet", "--set", "run.threads=2",
                 "--set", "edmd.collisions=25", "--resume"});
  EXPECT_EQ(r.code, 0) << r.describe();
  EXPECT_NE(r.err.find("resuming at 20 collisions per particle"), std::string::npos) << r.err;
}

// A checkpoint that cannot be written stops a one-process run with the reason (here the test
// hook GRAINBATH_FAULT_CHECKPOINT_RANK=0 of src/dsmc/checkpoint.cpp), instead of a run that
// goes on as if it had one; nothing is left in OUT.checkpoints, no output is written.
TEST_F(OutputDir, ACheckpointThatCannotBeWrittenStopsTheRun) {
  RunOptions opt;
  opt.cwd = work();
  opt.env = {{"GRAINBATH_FAULT_CHECKPOINT_RANK", "0"}};
  const fs::path out = tmp / "out";
  const RunResult r = run_binary(
      {kBinary, "run", case_dir().string(), "--out", out.string(), "--quiet", "--set", "checkpoint.every=0.1"}, opt);
  EXPECT_TRUE(r.exited && r.code != 0 && r.code != 2) << r.describe();
  EXPECT_NE(r.err.find("checkpoint-000000000010.h5.partial: write failed (GRAINBATH_FAULT_CHECKPOINT_RANK test hook)"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(out));
  // (the hook fails before the directory is made: none is left; the removal of one made for
  // a failed write is FullDisk.AFailedFirstCheckpointLeavesNoCheckpointDirectory's)
  EXPECT_FALSE(fs::exists(tmp / "out.checkpoints"));
}

// A run writing OUT holds a lock on its temporary's marker: a second run into the same OUT
// meanwhile is refused before it touches anything (it set the first one's checkpoints aside
// and pruned them; review 3), and the lock, not a process id, decides that the temporary is
// alive (a process id says nothing across hosts or PID namespaces).
TEST_F(OutputDir, ASecondRunIntoAnOutThatALiveRunWritesIsRefused) {
  const fs::path out = tmp / "out";
  const fs::path live = tmp / "out.tmp-1";  // pid 1 exists here; it is the lock that counts
  write_text(live / ".grainbath-output",
             "written by grainbath (docs/OUTPUT.md): --out may replace this directory\n"
             "temporary of the run on host elsewhere process 4242\n");
  write_text(tmp / "out.checkpoints" / "checkpoint-000000000007.h5", "the live run's");
  const int fd = ::open((live / ".grainbath-output").c_str(), O_RDONLY);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::flock(fd, LOCK_EX | LOCK_NB), 0);
  const auto before = listing(tmp.path());
  RunResult r = run(out);
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_NE(r.err.find("another run is writing it now"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("temporary of the run on host elsewhere process 4242"), std::string::npos) << r.err;
  EXPECT_EQ(listing(tmp.path()), before);
  // that run ends without cleaning up (killed): its lock goes with it, and the next run
  // removes the temporary
  ::close(fd);
  r = run(out);
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_FALSE(fs::exists(live));
  EXPECT_NE(r.err.find("note: removed " + live.string()), std::string::npos) << r.err;
}

// A background grid changed in place under its name (profile = "file"): the run records a
// checksum of the values it read (results.h5 /parameters background.file_checksum), so
// --resume and `sweep --resume` refuse to continue with another medium (exit 2, the
// checkpoints and the finished variants kept); the unchanged grid resumes as before.
TEST_F(OutputDir, BackgroundFileChangedInPlaceIsNoticedOnResume) {
  const std::size_t cells = 8;
  auto write_grid = [&](double density) {
    grainbath::H5File f((case_dir() / "grid.h5").string(), grainbath::H5File::Mode::create);
    f.write("density", std::vector<double>(cells, density));
    f.write("temperature", std::vector<double>(cells, 1.0));
    f.write("velocity", std::vector<double>(3 * cells, 0.0));
  };
  write_grid(1.0);
  write_text(case_dir() / "case.toml", R"([run]
solver = "dsmc"
seed = 1
[domain]
dimensions = 1
length = [2.0]
cells = [8]
[grains]
temperature = 1.0
[background]
profile = "file"
file = "grid.h5"
mass_ratio = 0.4
knudsen = 0.2
[restitution]
law = "constant"
e = 0.9
[dsmc]
particles = 2000
dt = 0.01
t_end = 0.2
[sampling]
every = 0.05
steady_from = 0.1
)");
  const fs::path out = tmp / "out";
  const std::vector<std::string> keep = {"--quiet", "--set", "checkpoint.every=0.1", "--set", "checkpoint.keep=true"};
  auto run_case = [&](std::vector<std::string> args) {
    args.insert(args.end(), keep.begin(), keep.end());
    return grainbath(args);
  };
  RunResult r = run_case({"run", case_dir().string(), "--out", out.string()});
  ASSERT_EQ(r.code, 0) << r.describe();
  std::string recorded;
  {
    grainbath::H5File h((out / "results.h5").string(), grainbath::H5File::Mode::read);
    recorded = h.read_attribute("/parameters", "background.file_checksum");
  }
  EXPECT_EQ(recorded.rfind("\"fnv1a-", 0), 0u) << recorded;
  const auto before = listing(tmp / "out.checkpoints");
  write_grid(1.25);  // the same name, another medium
  r = run_case({"run", case_dir().string(), "--out", out.string(), "--resume"});
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_NE(r.err.find("background.file names a file whose contents changed (background.file_checksum was " +
                       recorded + ", now"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(listing(tmp / "out.checkpoints"), before);
  write_grid(1.0);  // the grid back as it was: the run resumes from its end checkpoint
  r = run_case({"run", case_dir().string(), "--out", out.string(), "--resume"});
  EXPECT_EQ(r.code, 0) << r.describe();
  EXPECT_NE(r.err.find("resuming from step 20"), std::string::npos) << r.err;

  // a sweep: finished, then its grid changed: --resume is not the same sweep
  const fs::path sweep_out = tmp / "sweep";
  const std::vector<std::string> sweep = {"sweep", case_dir().string(), "--out", sweep_out.string(), "-j", "1",
                                          "--set", "run.seed=1,2"};
  r = grainbath(sweep);
  ASSERT_EQ(r.code, 0) << r.describe();
  const std::string first = read_text(sweep_out / "variant-0_seed_1" / "results.h5");
  std::vector<std::string> resume = sweep;
  resume.push_back("--resume");
  write_grid(1.25);
  r = grainbath(resume);
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_NE(r.err.find("the case file, the files it names or the --set list differ from the sweep's"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(read_text(sweep_out / "variant-0_seed_1" / "results.h5"), first);
  write_grid(1.0);
  r = grainbath(resume);
  EXPECT_EQ(r.code, 0) << r.describe();
}

// The table `grainbath run` prints ends with each case's headline beside its theory: in free
// cooling Haff's law. EDMD's fitted Haff time (`haff.t0_measured`, the number
// cases/free-cooling-disks is about) and DSMC's second-Sonine Haff temperature were missing
// until 2026-12-06 (the EDMD table showed only Z).
TEST_F(OutputDir, TheRunTableShowsTheFreeCoolingHeadlines) {
  RunResult r = run(work() / "dsmc");
  ASSERT_TRUE(r.exited && r.code == 0) << r.describe();
  EXPECT_NE(r.out.find("theory: Haff T(t_end), Sonine 2"), std::string::npos) << r.out;
  write_text(tmp / "edmd" / "case.toml", R"([run]
solver = "edmd"
seed = 1
[edmd]
dimensions = 2
particles = 400
packing_fraction = 0.1
equilibrate = 1
collisions = 4
[restitution]
law = "constant"
e = 0.9
[sampling]
interval = 0.5
free_cooling = true
)");
  r = grainbath({"run", (tmp / "edmd").string(), "--out", (work() / "edmd").string(), "--quiet"});
  ASSERT_TRUE(r.exited && r.code == 0) << r.describe();
  for (const char* row : {"Haff time t0 (fit)", "theory: Haff t0, with a2", "theory: Haff t0, Maxwellian"})
    EXPECT_NE(r.out.find(row), std::string::npos) << row << " missing in:\n" << r.out;
}

// The run's table puts each theory value beside the measurement it predicts, with the
// distance in the measurement's errors where that error reached its plateau, and shows the
// expansion T0 + eps T1 (+ eps^2 T2) (review 4: only the closures' roots, no distance). A bath
// case with 2000 grains sampled every 0.1 (T correlated over ~0.1 at eps = 0.1): the T error of
// 201 samples passes the plateau test (seeds 3-6 all do), so the distance is printed and
// equals (T - theory)/stderr from summary.json.
TEST_F(OutputDir, TheRunTableGivesTheDistanceToTheoryInStandardErrors) {
  write_text(tmp / "bath" / "case.toml", R"([run]
solver = "dsmc"
seed = 3
[grains]
density = 1.0
[restitution]
law = "constant"
e = 0.9
[background]
density = 1.0
knudsen = 0.1
mass_ratio = 0.5
[dsmc]
particles = 2000
dt = 0.01
t_end = 21.0
[sampling]
every = 0.1
steady_from = 1.0
)");
  const fs::path out = work() / "bath";
  RunResult r = grainbath({"run", (tmp / "bath").string(), "--out", out.string(), "--quiet", "--set", "run.threads=1"});
  ASSERT_TRUE(r.exited && r.code == 0) << r.describe();
  for (const char* row : {"theory: T# Sonine", "theory: T0 + eps T1", "theory: + eps^2 T2, Maxwellian",
                          "theory: + eps^2 T2, Grad"})
    EXPECT_NE(r.out.find(row), std::string::npos) << row << " missing in:\n" << r.out;
  const std::string summary = read_text(out / "summary.json");
  auto number = [&](const std::string& key, std::size_t from) {
    const std::size_t at = summary.find("\"" + key + "\": ", from);
    EXPECT_NE(at, std::string::npos) << key;
    return at == std::string::npos ? NAN : std::stod(summary.substr(at + key.size() + 4));
  };
  const std::size_t temperature = summary.find("\"temperature\": {"), sonine = summary.find("\"sonine\": {");
  const double T = number("mean", temperature), se = number("stderr", temperature), th = number("T", sonine);
  ASSERT_EQ(summary.find("\"stderr_plateau\": true", temperature), summary.find("\"stderr_plateau\"", temperature))
      << "the case's premise: T's error on its plateau\n" << summary;
  const std::size_t line = r.out.find("theory: T# Sonine");
  ASSERT_NE(line, std::string::npos);
  const std::string text = r.out.substr(line, r.out.find('\n', line) - line);
  const std::size_t at = text.find("measured ");
  ASSERT_NE(at, std::string::npos) << text;
  EXPECT_NEAR(std::stod(text.substr(at + 9)), (T - th) / se, 0.051) << text;
}

// The sweep's plot is made by a shell command: a "'" in the sweep directory's path broke it
// ("sh: 1: Syntax error: Unterminated quoted string", no sweep.png) and could have run a command
// of its own, until 2026-12-06. Needs /usr/bin/python3 with matplotlib (as the plot does).
TEST_F(OutputDir, SweepPlotsIntoAPathWithAQuote) {
  if (run_binary({"/usr/bin/python3", "-c", "import matplotlib"}, {}).code != 0)
    GTEST_SKIP() << "no /usr/bin/python3 with matplotlib: the sweep makes no plot";
  const fs::path out = work() / "it's; touch pwned '";
  // (a medium: the plot needs a headline such as the steady temperature)
  const RunResult r = grainbath({"sweep", case_dir().string(), "--set", "run.seed=1,2", "--out", out.string(), "-j", "1",
                                 "-q", "--set", "run.threads=1", "--set", "background.density=1.0"});
  ASSERT_TRUE(r.exited && r.code == 0) << r.describe();
  EXPECT_TRUE(fs::exists(out / "sweep.png")) << r.out << r.err;
  EXPECT_EQ(r.err.find("Syntax error"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(work() / "pwned"));
}

// The EDMD sweep table shows Z beside its equation of state (theory.Z): until 2026-12-06 it
// had pressure.Z alone, with no theory column, so a packing-fraction scan (cases/hard-disk-eos
// style) could not be read off sweep.md.
TEST_F(OutputDir, EdmdSweepTableHasTheTheoryZColumn) {
  write_text(tmp / "edmd" / "case.toml", R"([run]
solver = "edmd"
seed = 1
[edmd]
dimensions = 2
particles = 100
packing_fraction = 0.2
equilibrate = 2
collisions = 6
)");
  const fs::path out = work() / "eos";
  const RunResult r = grainbath({"sweep", (tmp / "edmd").string(), "--set", "edmd.packing_fraction=0.2,0.4", "--out",
                                 out.string(), "-j", "1", "-q"});
  ASSERT_TRUE(r.exited && r.code == 0) << r.describe();
  const std::string head = sweep_table_header(out);
  ASSERT_FALSE(head.empty()) << read_text(out / "sweep.md");
  EXPECT_NE(head.find("| pressure.Z |"), std::string::npos) << head;
  EXPECT_NE(head.find("| theory.Z |"), std::string::npos) << head;
}

// A quiet sweep stopped: the command printed to continue it keeps -q (review 4: it dropped -q,
// so the resumed sweep printed progress lines the user had turned off), and the counts say
// what happened to each variant.
TEST_F(OutputDir, InterruptedQuietSweepSaysHowToContinueWithTheSameOptions) {
  std::string c = kCase;
  c.replace(c.find("particles = 1000"), 16, "particles = 100000");  // about 2 s a variant (one thread)
  c.replace(c.find("t_end = 0.2"), 11, "t_end = 50.0");
  write_text(case_dir() / "case.toml", c);
  const fs::path out = tmp / "quiet";
  RunOptions opt;
  opt.cwd = work();
  opt.timeout_s = 120;
  opt.send_signal = SIGINT;
  // 0.3 s after the first variant's log appears (the sweep's stop handlers are in place by
  // then; a fixed 0.3 s after the start killed a slow-starting sweep under ASan): the first
  // variant runs, the second waits
  opt.send_when = "";
  opt.send_when_exists = out / "variant-0_seed_1.log";
  const RunResult r = run_binary({kBinary, "sweep", case_dir().string(), "--out", out.string(), "-j", "1", "-q", "--set",
                                  "run.seed=1,2", "--set", "dsmc.dt=0.01"},
                                 opt);
  EXPECT_TRUE(r.exited && r.code == 130) << r.describe();
  EXPECT_NE(r.err.find("sweep: interrupted: 0 of 2 variants finished, 1 stopped with a checkpoint, 1 not started;"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("not started or failed"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(" sweep " + case_dir().string() + " --out " + out.string() +
                       " -j 1 -q --set run.seed=1,2 --set dsmc.dt=0.01 --resume\n"),
            std::string::npos)
      << r.err;
}

// sweep.md shows a theory column only beside its measured quantity, and no column that is
// empty in every variant (review 4: a homogeneous DSMC sweep had the hydrodynamic limit's
// theory.hydro.thermal_diffusion_exponent_kinetic, constant and about no measured number)
TEST_F(OutputDir, HomogeneousSweepTableLeavesOutTheHydroTheory) {
  const fs::path out = work() / "homogeneous";
  const RunResult r = grainbath({"sweep", case_dir().string(), "--set", "run.seed=1,2", "--out", out.string(), "-j", "1",
                                 "-q", "--set", "run.threads=1", "--set", "background.density=1.0"});
  ASSERT_TRUE(r.exited && r.code == 0) << r.describe();
  const std::string head = sweep_table_header(out);
  ASSERT_FALSE(head.empty()) << read_text(out / "sweep.md");
  EXPECT_NE(head.find("| temperature.mean |"), std::string::npos) << head;
  EXPECT_NE(head.find("| theory.equilibrium.sonine.T |"), std::string::npos) << head;
  EXPECT_EQ(head.find("theory.hydro."), std::string::npos) << head;
  EXPECT_EQ(head.find("mode."), std::string::npos) << head;
  EXPECT_EQ(head.find("theory.Z"), std::string::npos) << head;
  // sweep.tsv keeps every column
  EXPECT_NE(read_text(out / "sweep.tsv").find("theory.hydro.thermal_diffusion_exponent_kinetic"), std::string::npos);
}

// sweep -j unset runs as many variants at once as cores are free, as a run chooses its threads
// (review 4: all cores even on a busy machine), and says so. Every core is kept busy by a spin
// loop here, so one variant at a time whatever the machine.
TEST_F(OutputDir, SweepWithoutJobsRunsOneVariantPerFreeCore) {
  const long cores = std::max(1L, sysconf(_SC_NPROCESSORS_ONLN));
  std::vector<pid_t> spinners;
  for (long k = 0; k < cores; ++k) {
    const pid_t p = fork();
    if (p == 0) {
      volatile unsigned long spins = 0;
      for (;;) spins = spins + 1;
    }
    if (p > 0) spinners.push_back(p);
  }
  ::usleep(200000);  // let them show in /proc/stat
  const RunResult r = grainbath({"sweep", case_dir().string(), "--out", (work() / "busy").string(), "--set",
                                 "run.seed=1,2", "--set", "run.threads=1"});
  for (pid_t p : spinners) {
    ::kill(p, SIGKILL);
    ::waitpid(p, nullptr, 0);
  }
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_NE(r.err.find("sweep: 2 variants, 1 at a time"), std::string::npos) << r.err;
  if (cores > 1) {
    EXPECT_NE(r.err.find("cores busy with other processes: running 1 variant(s) at a time; -j N chooses"),
              std::string::npos)
        << r.err;
  }
}

// ------------------------------------------------------------ moves that fail, names too long
// A move of the output can fail where permissions would not stop it (another file system, a
// full directory); what was written must survive it: the earlier output where it was, the new
// results in the temporary directory, said. The moves are made to fail by
// tests/cli/fail_rename.cpp (EXDEV).

namespace {
// The directory a run that failed with "error: OUT: <failure> (Invalid cross-device link);
// the results of this run are kept in DIR" names ("" if it said nothing of the kind).
fs::path kept_results(const RunResult& r, const fs::path& out, const std::string& failure) {
  std::smatch kept;
  if (!std::regex_search(r.err, kept,
                         std::regex("error: " + out.string() + ": " + failure +
                                    R"( \(Invalid cross-device link\); the results of this run are kept in )"
                                    R"((\S+\.tmp-[0-9]+)\n)")))
    return {};
  return kept[1].str();
}
}  // namespace

TEST_F(OutputDir, AFailedMoveAsideKeepsTheEarlierOutputAndTheNewResults) {
  const fs::path out = tmp / "out";
  ASSERT_EQ(run(out).code, 0);
  const std::string first = read_text(out / "summary.json");
  const std::vector<std::string> args = {"run", case_dir().string(), "--out", out.string(), "--quiet",
                                         "--set", "run.threads=1", "--set", "run.seed=2"};
  RunResult r = grainbath_failing_moves_to("out.previous", args);
  EXPECT_TRUE(r.exited && r.code == 1) << r.describe();
  const fs::path kept_dir = kept_results(r, out, "cannot move the previous output aside");
  ASSERT_FALSE(kept_dir.empty()) << r.err;
  EXPECT_EQ(read_text(out / "summary.json"), first);  // the earlier output untouched
  EXPECT_NE(read_text(kept_dir / "summary.json").find("\"seed\": 2"), std::string::npos);
  EXPECT_TRUE(fs::exists(kept_dir / "results.h5"));
  EXPECT_FALSE(fs::exists(tmp / "out.previous"));
  // the next run says where those results are and leaves them
  r = run(out);
  EXPECT_EQ(r.code, 0) << r.describe();
  EXPECT_NE(r.err.find("note: " + kept_dir.string() + " holds the results of an earlier run that were not moved "
                       "into place"),
            std::string::npos)
      << r.err;
  EXPECT_TRUE(fs::exists(kept_dir / "summary.json"));
  EXPECT_EQ(read_text(tmp / "out.previous" / "summary.json"), first);
}

TEST_F(OutputDir, AFailedMoveIntoPlaceKeepsTheNewResults) {
  const fs::path out = tmp / "out";
  const RunResult r = grainbath_failing_moves_to(
      "/out", {"run", case_dir().string(), "--out", out.string(), "--quiet", "--set", "run.threads=1"});
  EXPECT_TRUE(r.exited && r.code == 1) << r.describe();
  const fs::path kept_dir = kept_results(r, out, "cannot move the new output into place");
  ASSERT_FALSE(kept_dir.empty()) << r.err;
  EXPECT_FALSE(fs::exists(out));
  EXPECT_TRUE(fs::exists(kept_dir / "summary.json"));
}

TEST_F(OutputDir, AFailedMoveOfTheEarlierSweepRunsNothing) {
  const fs::path out = tmp / "sweep";
  const std::vector<std::string> args = {"sweep", case_dir().string(), "--out", out.string(), "-j", "1",
                                         "--set", "run.seed=1,2", "--set", "run.threads=1"};
  ASSERT_EQ(grainbath(args).code, 0);
  const auto before = listing(tmp.path());
  const RunResult r = grainbath_failing_moves_to("sweep.previous", args);
  EXPECT_TRUE(r.exited && r.code == 2) << r.describe();
  EXPECT_NE(r.err.find("error: " + out.string() + ": cannot move the previous sweep aside to " + out.string() +
                       ".previous (Invalid cross-device link)"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("done"), std::string::npos) << "a variant ran:\n" << r.err;
  EXPECT_EQ(listing(tmp.path()), before);
}

TEST_F(OutputDir, AFailedMoveOfAnEarlierRunsCheckpointsRunsNothing) {
  const fs::path out = tmp / "out";
  write_text(tmp / "out.checkpoints" / "checkpoint-000000009000.h5", "an earlier run's");
  const auto before = listing(tmp.path());
  const RunResult r = grainbath_failing_moves_to(
      "out.checkpoints.previous", {"run", case_dir().string(), "--out", out.string(), "--quiet", "--set",
                                   "run.threads=1", "--set", "checkpoint.every=0.05"});
  EXPECT_TRUE(r.exited && r.code == 2) << r.describe();
  EXPECT_NE(r.err.find(": cannot move the earlier run's checkpoints aside (Invalid cross-device link)"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(read_text(tmp / "out.checkpoints" / "checkpoint-000000009000.h5"), "an earlier run's");
  EXPECT_EQ(listing(tmp.path()), before);
}

// A name that fits the file system alone but not with the siblings grainbath writes beside it
// (NAME.checkpoints.previous, 21 bytes more) is refused at start-up: before, a sweep into it
// ran, and the next one could not move it aside; a run's checkpoints could not be kept.
TEST_F(OutputDir, ANameTooLongForItsSiblingsIsRefusedAtStartUp) {
  const long name_max = ::pathconf(tmp.path().c_str(), _PC_NAME_MAX);
  ASSERT_GT(name_max, 30);
  const std::size_t longest = static_cast<std::size_t>(name_max) - 21;
  const fs::path too_long = tmp / std::string(longest + 1, 'o');
  const std::string said = "error: " + too_long.string() + ": its last name is " + std::to_string(longest + 1) +
                           " bytes long; grainbath writes siblings beside it (NAME.previous, NAME.tmp-PID, "
                           "NAME.checkpoints.previous) and this file system allows " + std::to_string(name_max) +
                           " bytes per name, so NAME may have at most " + std::to_string(longest) +
                           ": choose a shorter --out";
  expect_refused(too_long, "its last name is");
  const RunResult r = grainbath({"sweep", case_dir().string(), "--out", too_long.string(), "-j", "1", "--set",
                                 "run.seed=1,2"});
  EXPECT_EQ(r.code, 2) << r.describe();
  EXPECT_NE(r.err.find(said), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(too_long));
  // the longest name allowed: a run into it twice, with checkpoints kept, moves everything aside
  const fs::path longest_out = tmp / std::string(longest, 'o');
  for (int k = 0; k < 2; ++k) {
    const RunResult ok = grainbath({"run", case_dir().string(), "--out", longest_out.string(), "--quiet", "--set",
                                    "run.threads=1", "--set", "checkpoint.every=0.05", "--set", "checkpoint.keep=true"});
    ASSERT_EQ(ok.code, 0) << ok.describe();
  }
  fs::path previous = longest_out, checkpoints_previous = longest_out;
  previous += ".previous";
  checkpoints_previous += ".checkpoints.previous";
  EXPECT_TRUE(fs::exists(previous / "summary.json"));
  EXPECT_TRUE(fs::is_directory(checkpoints_previous));
}

// A sweep whose plot cannot be made says so, and why (review 5: only a missing "plot:" line
// told): a plot script that fails (its messages kept in OUT/plot.log), and no script beside
// the binary. The binary is copied into a tree of the test's own for both.
TEST_F(OutputDir, ASweepSaysWhyItMadeNoPlot) {
  fs::create_directories(tmp / "tree" / "bin");
  fs::copy_file(kBinary, tmp / "tree" / "bin" / "grainbath");
  fs::permissions(tmp / "tree" / "bin" / "grainbath", fs::perms::owner_all);
  const std::vector<std::string> tail = {"--set", "run.seed=1,2", "--set", "run.threads=1", "-j", "1"};
  auto sweep = [&](const fs::path& out) {
    std::vector<std::string> args = {(tmp / "tree" / "bin" / "grainbath").string(), "sweep", case_dir().string(),
                                     "--out", out.string()};
    args.insert(args.end(), tail.begin(), tail.end());
    RunOptions opt;
    opt.cwd = work();
    return run_binary(args, opt);
  };
  RunResult r = sweep(tmp / "s1");
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_NE(r.err.find("note: no sweep.png: scripts/plot_sweep.py is not beside this binary (looked in " +
                       (tmp / "tree" / "scripts").string() + ")"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.out.find("plot:"), std::string::npos) << r.out;
  write_text(tmp / "tree" / "scripts" / "plot_sweep.py", "import sys\nprint('no matplotlib here', file=sys.stderr)\nsys.exit(3)\n");
  r = sweep(tmp / "s2");
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_NE(r.err.find("note: no sweep.png: " + (tmp / "tree" / "scripts" / "plot_sweep.py").string() +
                       " failed (exit 3; its messages are in " + (tmp / "s2" / "plot.log").string() + ")"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(read_text(tmp / "s2" / "plot.log"), "no matplotlib here\n");
  EXPECT_TRUE(fs::exists(tmp / "s2" / "sweep.tsv"));
  // a script that works: the plot line, and no log left
  write_text(tmp / "tree" / "scripts" / "plot_sweep.py", "import sys\nopen(sys.argv[1] + '/sweep.png', 'w').write('png')\n");
  r = sweep(tmp / "s3");
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_NE(r.out.find("plot: " + (tmp / "s3").string() + "/sweep.png"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(tmp / "s3" / "plot.log"));
  EXPECT_EQ(r.err.find("no sweep.png"), std::string::npos) << r.err;
}
