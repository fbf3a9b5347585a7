// What `run --out` and `sweep --out` may move aside or delete (new-user review, 2026-11-26):
// the previous output is moved to OUT.previous and the one before deleted, so only a
// directory grainbath wrote (summary.json, results.h5, sweep.md, variant-*) or an empty one
// may be taken; a case directory, the current directory, a file, a link or a directory of
// the user's own are refused at start-up, before any work, with nothing changed.
#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

#include "tests/cli/cli_harness.hpp"

using namespace grainbath::testing;

namespace {

const std::string kBinary = GRAINBATH_BINARY;

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
  ASSERT_EQ(run(out).code, 0);
  ASSERT_EQ(run(out).code, 0);
  EXPECT_TRUE(fs::exists(out / "summary.json"));
  EXPECT_TRUE(fs::exists(tmp / "out.previous" / "summary.json"));
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
  r = sweep("3,4,5");
  ASSERT_EQ(r.code, 0) << r.describe();
  EXPECT_NE(r.err.find("moved to"), std::string::npos) << r.err;
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
    std::vector<std::string> cols;  // "", quantity, mean, standard error, per-run stderr, ""
    std::istringstream cells(line);
    for (std::string cell; std::getline(cells, cell, '|');) cols.push_back(cell);
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
