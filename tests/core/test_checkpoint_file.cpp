// The shared checkpoint file (src/core/checkpoint.cpp) on small hand-made states: what a file
// holds, which file --resume takes, what it refuses and how, and what a fresh run moves aside
// (docs/reviews/mutation-audit-checkpoints.md). The solvers' restart tests cover the same
// code end to end; these pin what they cannot see: the checksum function itself (files
// written by earlier builds must still verify), the provenance, the refusals' messages.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <hdf5.h>

#include "core/checkpoint.hpp"
#include "core/h5.hpp"

namespace fs = std::filesystem;
using namespace grainbath;

namespace {

struct Scratch {
  fs::path dir;
  explicit Scratch(const std::string& name) {
    dir = fs::temp_directory_path() / ("grainbath-ck-file-" + name + "-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::remove_all(fs::path(dir.string() + ".previous"));
  }
  ~Scratch() {
    fs::remove_all(dir);
    fs::remove_all(fs::path(dir.string() + ".previous"));
  }
};

RunContext context(std::uint64_t seed = 3) {
  RunContext ctx;
  ctx.seed = seed;
  ctx.case_text = "[run]\nseed = " + std::to_string(seed) + "\n";
  ctx.resolved = {{"dsmc.dt", "0.01"}};
  return ctx;
}

bool never(const std::string&) { return false; }

// A state of one real and one integer array: `value` marks which checkpoint it came from.
struct State {
  std::vector<double> x;
  std::vector<std::uint64_t> k;
  CheckpointArrays arrays() {
    CheckpointArrays a;
    a.add("state/x", x);
    a.add("state/k", k);
    return a;
  }
};

void write(const fs::path& dir, std::uint64_t index, double value, const RunContext& ctx,
           const std::string& solver = "dsmc") {
  State s{{value, 2.0 * value, 0.5}, {index, 7}};
  write_checkpoint_file(dir, index, s.arrays(), ctx, solver);
}

// Loads the newest valid checkpoint of `dir` into `out`; returns the file's name ("" if none).
std::string load(const fs::path& dir, State& out, const RunContext& ctx, std::string& warning,
                 const std::string& solver = "dsmc", std::uint64_t* bytes = nullptr,
                 const CheckpointPart* part = nullptr) {
  const fs::path p = read_newest_checkpoint_file(
      dir, ctx, solver, never, "nothing", [&] { return out.arrays(); }, [] {}, warning, part, bytes);
  return p.filename().string();
}

std::vector<std::string> names_in(const fs::path& dir) {
  std::vector<std::string> n;
  for (const auto& e : fs::directory_iterator(dir)) n.push_back(e.path().filename().string());
  std::sort(n.begin(), n.end());
  return n;
}

std::uint64_t fnv1a(const std::string& s) {
  Fnv1a f;
  f.add(s.data(), s.size());
  return f.h;
}

}  // namespace

// The checksum is FNV-1a's xor-then-multiply by the 64-bit FNV prime, started from
// 1469598103934665603: the published offset basis 14695981039346656037 without its last
// digit. Every checkpoint written so far (and every background.file_checksum recorded in a
// results.h5 or a checkpoint) is sealed with this start, so it must stay: another start, or
// the FNV-1 order, would refuse them all as corrupt or as changed files. The sums below are
// worked out by hand from the definition (h = (h xor byte) * 1099511628211 mod 2^64); the
// file's sum is each array's length (8 bytes, little-endian here) then its elements, in
// list order.
TEST(CheckpointFile, TheChecksumIsFnv1aFromItsOwnStartOverEachArraysLengthAndElements) {
  constexpr std::uint64_t start = 1469598103934665603ull, prime = 1099511628211ull;
  EXPECT_EQ(fnv1a(""), start);
  EXPECT_EQ(fnv1a("a"), (start ^ 0x61u) * prime);
  EXPECT_EQ(fnv1a("ab"), (((start ^ 0x61u) * prime) ^ 0x62u) * prime);
  EXPECT_EQ(fnv1a("foobar"), 9870438755804841970ull);  // as the code gave on 2026-12-06
  State s{{1.5, -2.0}, {9}};
  std::string bytes;
  auto put = [&](const void* p, std::size_t n) { bytes.append(static_cast<const char*>(p), n); };
  const std::uint64_t n2 = 2, n1 = 1;
  put(&n2, 8), put(s.x.data(), 16), put(&n1, 8), put(s.k.data(), 8);
  EXPECT_EQ(s.arrays().checksum(), fnv1a(bytes));
}

// The file holds the state, the case text, the parameters and the provenance (seed, solver,
// version) beside the checksum: what a reader needs to know what it continues.
TEST(CheckpointFile, HoldsTheCaseTheParametersTheSeedTheSolverAndTheVersion) {
  Scratch s("provenance");
  const RunContext ctx = context(41);
  write(s.dir, 12, 1.0, ctx, "edmd");
  const fs::path file = s.dir / "checkpoint-000000000012.h5";
  ASSERT_TRUE(fs::exists(file)) << "no " << file;
  H5File h(file.string(), H5File::Mode::read);
  EXPECT_EQ(h.read_string("/case/case.toml"), ctx.case_text);
  EXPECT_EQ(h.read_attribute("/parameters", "dsmc.dt"), "0.01");
  EXPECT_EQ(h.read_attribute("/", "seed"), "41");
  EXPECT_EQ(h.read_attribute("/", "solver"), "edmd");
  EXPECT_EQ(h.read_attribute("/", "grainbath_version"), std::string(GRAINBATH_VERSION));
  EXPECT_EQ(h.read_doubles("/state/x"), (std::vector<double>{1.0, 2.0, 0.5}));
  EXPECT_EQ(h.read_u64("/state/k"), (std::vector<std::uint64_t>{12, 7}));
  EXPECT_TRUE(names_in(s.dir) == std::vector<std::string>{"checkpoint-000000000012.h5"});  // no .partial left
}

// Each new checkpoint keeps itself and the newest before it; --resume takes the newest by
// index, whatever the width of the names (a name of another width sorts elsewhere as text),
// and reports how many bytes of arrays it read.
TEST(CheckpointFile, TheNewestByIndexIsLoadedAndTheOneBeforeItKept) {
  Scratch s("newest");
  const RunContext ctx = context();
  for (std::uint64_t i : {8u, 9u, 10u, 11u}) write(s.dir, i, static_cast<double>(i), ctx);
  EXPECT_EQ(names_in(s.dir), (std::vector<std::string>{"checkpoint-000000000010.h5", "checkpoint-000000000011.h5"}));
  // names of another width: as text "checkpoint-2.h5" sorts after the others, yet its index
  // (2) is the oldest; index 11 is the newest
  fs::rename(s.dir / "checkpoint-000000000011.h5", s.dir / "checkpoint-11.h5");
  fs::copy_file(s.dir / "checkpoint-000000000010.h5", s.dir / "checkpoint-2.h5");
  State got;
  std::string warning;
  std::uint64_t bytes = 0;
  EXPECT_EQ(load(s.dir, got, ctx, warning, "dsmc", &bytes), "checkpoint-11.h5") << warning;
  EXPECT_EQ(got.x, (std::vector<double>{11.0, 22.0, 0.5}));
  EXPECT_EQ(got.k, (std::vector<std::uint64_t>{11, 7}));
  EXPECT_EQ(bytes, 3u * 8u + 2u * 8u);
  EXPECT_TRUE(warning.empty()) << warning;
}

// A write that fails only when the file is flushed (a full disk: here a file-size limit in a
// child process, SIGXFSZ ignored, as a full disk sends no signal) is an error before the
// rename: no checkpoint-2.h5 appears, and the checkpoint before it is kept and still loads.
TEST(CheckpointFile, AWriteThatFailsAtTheFlushIsAnErrorAndThePreviousCheckpointStays) {
  Scratch s("full");
  const RunContext ctx = context();
  write(s.dir, 1, 1.0, ctx);
  // half the size of a file like it: its data blocks are written as they come (the limit
  // passes them), its metadata only when the file is flushed and closed (the limit stops it)
  const rlim_t bytes = fs::file_size(s.dir / "checkpoint-000000000001.h5") / 2;
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{bytes, bytes};
    if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) ::_exit(3);
    int code = 1;  // written without an error
    try {
      write(s.dir, 2, 2.0, ctx);
    } catch (const std::runtime_error&) {
      code = 0;
    } catch (...) {
      code = 2;
    }
    ::_exit(code);  // not exit(): HDF5's own clean-up of a failed file is not under test
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "the writer died of signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 0) << "1: the failed write went unnoticed; 2: not a runtime_error; 3: no limit";
  EXPECT_FALSE(fs::exists(s.dir / "checkpoint-000000000002.h5"));
  State got;
  std::string warning;
  EXPECT_EQ(load(s.dir, got, ctx, warning), "checkpoint-000000000001.h5") << warning;
  EXPECT_EQ(got.x, (std::vector<double>{1.0, 2.0, 0.5}));
  EXPECT_TRUE(warning.empty()) << warning;
}

// A file named like a checkpoint with an index too large for 64 bits is not one of ours: it
// is left alone, and neither writing nor reading trips over it.
TEST(CheckpointFile, ANameWithMoreThanNineteenDigitsIsNoCheckpoint) {
  Scratch s("digits");
  const RunContext ctx = context();
  fs::create_directories(s.dir);
  const fs::path odd = s.dir / ("checkpoint-" + std::string(25, '9') + ".h5");
  std::ofstream(odd) << "not a checkpoint";
  EXPECT_NO_THROW(write(s.dir, 5, 5.0, ctx));
  EXPECT_TRUE(fs::exists(odd));
  State got;
  std::string warning;
  EXPECT_EQ(load(s.dir, got, ctx, warning), "checkpoint-000000000005.h5") << warning;
}

// The move into place is checked: a checkpoint that could not be renamed is an error that
// names the file, not a run that believes it has a checkpoint.
TEST(CheckpointFile, AFailedMoveIntoPlaceIsAnErrorNamingTheFile) {
  Scratch s("rename");
  const RunContext ctx = context();
  const fs::path in_the_way = s.dir / "checkpoint-000000000004.h5";
  fs::create_directories(in_the_way / "something");  // a non-empty directory under the final name
  try {
    write(s.dir, 4, 4.0, ctx);
    ADD_FAILURE() << "the checkpoint was not moved into place, and nothing said so";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(in_the_way.string() + ": cannot move the checkpoint into place"), std::string::npos) << what;
  }
}

// Written with another seed or by another solver: a changed case (std::invalid_argument, the
// CLI's bad input that keeps the checkpoints), saying what was and what is. A file without a
// solver attribute was written before it existed, by the DSMC.
TEST(CheckpointFile, AnotherSeedOrSolverIsAChangedCaseSaidAsSuch) {
  Scratch s("seed");
  write(s.dir, 1, 1.0, context(5), "edmd");
  State got;
  std::string warning;
  auto refusal = [&](const RunContext& ctx, const std::string& solver) {
    try {
      load(s.dir, got, ctx, warning, solver);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_NE(refusal(context(6), "edmd").find("the checkpoint was written with seed 5, the case now has 6"),
            std::string::npos)
      << refusal(context(6), "edmd");
  EXPECT_NE(refusal(context(5), "dsmc").find("the checkpoint was written by solver edmd, the case now runs dsmc"),
            std::string::npos)
      << refusal(context(5), "dsmc");
  {
    const fs::path file = s.dir / "checkpoint-000000000001.h5";
    const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    ASSERT_GE(H5Adelete_by_name(f, "/", "solver", H5P_DEFAULT), 0);
    H5Fclose(f);
  }
  EXPECT_NE(refusal(context(5), "edmd").find("the checkpoint was written by solver dsmc, the case now runs edmd"),
            std::string::npos)
      << refusal(context(5), "edmd");
  EXPECT_EQ(load(s.dir, got, context(5), warning, "dsmc"), "checkpoint-000000000001.h5") << warning;
  EXPECT_TRUE(warning.empty()) << warning;
}

// A file's checksum (CaseReader::record_file_checksum, "<key>_checksum") that the checkpoint
// does not hold was not recorded yet (before 2026-12-04): not compared. One that differs
// names the file whose contents changed.
TEST(CheckpointFile, AFileChecksumIsComparedOnlyWhenTheCheckpointHasOne) {
  Scratch s("filesum");
  const RunContext before = context();
  write(s.dir, 1, 1.0, before);
  RunContext now = before;
  now.resolved["background.file_checksum"] = "00ff";
  State got;
  std::string warning;
  EXPECT_EQ(load(s.dir, got, now, warning), "checkpoint-000000000001.h5") << warning;
  write(s.dir, 2, 2.0, now);
  RunContext changed = now;
  changed.resolved["background.file_checksum"] = "0100";
  try {
    load(s.dir, got, changed, warning);
    ADD_FAILURE() << "a changed file was accepted";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("background.file names a file whose contents changed (background.file_checksum was 00ff, "
                        "now 0100)"),
              std::string::npos)
        << what;
  }
}

// The several-process reader (CheckpointPart) says a changed case as the one-process reader
// does: std::invalid_argument, not a corrupt file to skip. (Here with one process.)
TEST(CheckpointFile, TheSeveralProcessReaderReportsAChangedCaseAsSuch) {
  Scratch s("parts");
  write(s.dir, 1, 1.0, context(5));
  CheckpointPart part;
  part.range = [](const std::string&, std::uint64_t&, std::uint64_t&) { return false; };
  part.in_order = [](ChecksumToken t, const std::function<void(ChecksumToken&)>& turn) {
    turn(t);
    return t;
  };
  part.agree = [](const std::string& mine) { return mine; };
  State got;
  std::string warning;
  EXPECT_EQ(load(s.dir, got, context(5), warning, "dsmc", nullptr, &part), "checkpoint-000000000001.h5") << warning;
  EXPECT_EQ(got.x, (std::vector<double>{1.0, 2.0, 0.5}));
  EXPECT_THROW(load(s.dir, got, context(6), warning, "dsmc", nullptr, &part), std::invalid_argument);
}

// A fresh run moves an earlier run's checkpoints to DIR.previous: all of them (one, or a
// leftover .partial), replacing an older DIR.previous of checkpoints; it refuses, touching
// nothing, a DIR that is a symbolic link (dangling or not) and a DIR.previous that holds
// anything else.
TEST(CheckpointFile, AFreshRunSetsEveryEarlierCheckpointAsideAndRefusesWhatIsNotOurs) {
  Scratch s("aside");
  const fs::path previous = s.dir.string() + ".previous";
  const RunContext ctx = context();
  write(s.dir, 1, 1.0, ctx);  // one checkpoint
  std::string note = set_aside_checkpoints(s.dir);
  EXPECT_NE(note.find("held 1 checkpoint(s) of an earlier run (the newest: checkpoint-000000000001.h5)"),
            std::string::npos)
      << note;
  EXPECT_FALSE(fs::exists(s.dir));
  EXPECT_TRUE(fs::exists(previous / "checkpoint-000000000001.h5"));
  // a leftover .partial (a run killed while writing) is ours: set aside too, replacing the
  // older DIR.previous
  fs::create_directories(s.dir);
  std::ofstream(s.dir / "checkpoint-000000000007.h5.partial") << "half";
  note = set_aside_checkpoints(s.dir);
  EXPECT_NE(note.find("held 0 checkpoint(s)"), std::string::npos) << note;
  EXPECT_TRUE(fs::exists(previous / "checkpoint-000000000007.h5.partial"));
  EXPECT_FALSE(fs::exists(previous / "checkpoint-000000000001.h5"));
  // DIR.previous holding the user's file: refused, nothing moved
  write(s.dir, 2, 2.0, ctx);
  std::ofstream(previous / "notes.txt") << "mine";
  try {
    set_aside_checkpoints(s.dir);
    ADD_FAILURE() << "a DIR.previous holding notes.txt was replaced";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(previous.string() + ": holds notes.txt, which is not a checkpoint"),
              std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(fs::exists(previous / "notes.txt"));
  EXPECT_TRUE(fs::exists(s.dir / "checkpoint-000000000002.h5"));
  // DIR a symbolic link, to checkpoints or to nothing: refused, the link left as it is
  fs::remove_all(previous);
  const fs::path real = s.dir.string() + ".real";
  fs::rename(s.dir, real);
  for (const fs::path& target : {real, fs::path(s.dir.string() + ".nowhere")}) {
    fs::create_directory_symlink(target, s.dir);
    try {
      set_aside_checkpoints(s.dir);
      ADD_FAILURE() << "a symbolic link to " << target << " was accepted";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(s.dir.string() + ": is a symbolic link"), std::string::npos) << e.what();
    }
    EXPECT_TRUE(fs::is_symlink(fs::symlink_status(s.dir)));
    EXPECT_FALSE(fs::exists(previous));
    fs::remove(s.dir);
  }
  fs::remove_all(real);
}
