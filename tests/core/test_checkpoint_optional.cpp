// CheckpointArrays::optional (core/checkpoint.hpp): an array added to a solver's state after
// checkpoints were first written (the DSMC a3 series, 2026-12-06) is written, but a file
// without it -- written by an earlier build, whose checksum does not cover it -- still loads,
// on one process and through the several-process reader (CheckpointPart), the array empty.
// A missing array that is not optional still makes the file unusable.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>

#include "core/checkpoint.hpp"

namespace fs = std::filesystem;
using namespace grainbath;

namespace {
struct Files {
  fs::path dir;
  RunContext ctx;
  explicit Files(const std::string& name) {
    dir = fs::temp_directory_path() / ("grainbath-ck-optional-" + name + "-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    ctx.case_text = "[run]\n";
    ctx.resolved = {{"run.seed", "1"}};
  }
  ~Files() { fs::remove_all(dir); }
};
bool never(const std::string&) { return false; }

// one process, or the several-process path with a single process (whole arrays only)
fs::path load(const Files& f, CheckpointArrays a, bool parts, std::string& warning) {
  CheckpointPart part;
  part.range = [](const std::string&, std::uint64_t&, std::uint64_t&) { return false; };
  part.in_order = [](ChecksumToken t, const std::function<void(ChecksumToken&)>& turn) {
    turn(t);
    return t;
  };
  part.agree = [](const std::string& mine) { return mine; };
  return read_newest_checkpoint_file(
      f.dir, f.ctx, "test", never, "nothing", [&] { return a; }, [] {}, warning, parts ? &part : nullptr);
}
}  // namespace

TEST(CheckpointOptional, AFileWithoutAnOptionalArrayLoadsWithItEmpty) {
  for (bool parts : {false, true}) {
    Files f(parts ? "parts" : "whole");
    std::vector<double> x = {1.0, 2.0, 3.0};
    std::vector<std::uint64_t> k = {7, 8};
    CheckpointArrays old;  // the earlier build's list
    old.add("series/x", x);
    old.add("series/k", k);
    write_checkpoint_file(f.dir, 1, old, f.ctx, "test");

    std::vector<double> rx, ry = {9.0}, rz = {9.0};
    std::vector<std::uint64_t> rk;
    CheckpointArrays now;  // this build's: y added later, optional
    now.add("series/x", rx);
    now.add("series/y", ry);
    now.add("series/k", rk);
    now.optional = {"series/y"};
    std::string warning;
    EXPECT_FALSE(load(f, now, parts, warning).empty()) << warning;
    EXPECT_EQ(rx, x);
    EXPECT_EQ(rk, k);
    EXPECT_TRUE(ry.empty());

    // written with y, it is read back with it (and the checksum covers it)
    ry = {4.0, 5.0};
    write_checkpoint_file(f.dir, 2, now, f.ctx, "test");
    rx.clear(), ry.clear(), rk.clear();
    EXPECT_FALSE(load(f, now, parts, warning).empty()) << warning;
    EXPECT_EQ(ry, (std::vector<double>{4.0, 5.0}));
    EXPECT_EQ(rx, x);

    // not optional: the older file cannot be used (both files lack z)
    CheckpointArrays strict = now;
    strict.add("series/z", rz);
    warning.clear();
    bool loaded = false;
    try {
      loaded = !load(f, strict, parts, warning).empty();
    } catch (const std::exception&) {
    }
    EXPECT_FALSE(loaded);
  }
}
