// Exact continuation (Issue #8): a run of 2N steps equals a run of N steps, checkpoint,
// resume, N steps -- bitwise in results.h5 and in every summary.json number except the
// wall-clock performance block. Homogeneous and spatial. A corrupt newest checkpoint is
// detected by its checksum and the previous one is used.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>

#include <hdf5.h>

#include "core/checkpoint.hpp"
#include "dsmc/checkpoint.hpp"
#include "support.hpp"
#include "tests/checkpoint_tamper.hpp"

using grainbath::testing::run_dsmc;
namespace fs = std::filesystem;

namespace {

std::string file_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

void expect_same_physics(const grainbath::Summary& a, const grainbath::Summary& b) {
  for (const auto& [k, v] : a.entries()) {
    if (k.rfind("performance.", 0) == 0) continue;
    ASSERT_NE(b.get(k), nullptr) << k;
    EXPECT_EQ(v, *b.get(k)) << k;
  }
}

const char* kHomogeneous = R"(
[grains]
temperature = 1.4
drift = [0.4, 0.0, 0.0]
[background]
mass_ratio = 0.5
density = 1.0
temperature = 1.0
knudsen = 0.2
[restitution]
law = "power"
beta = 0.15
delta = 0.2
[dsmc]
particles = 20000
dt = 0.01
t_end = 1.0
[sampling]
every = 0.05
steady_from = 0.5
[checkpoint]
every = 0.25
keep = true
)";

const char* kSpatialHead = R"(
[domain]
dimensions = 2
length = [2.0, 1.0]
cells = [10, 5]
boundaries = ["periodic", "periodic", "diffuse", "specular"]
[grains]
temperature = 1.2
profile = "mode"
amplitude = 0.3
[background]
mass_ratio = 0.3
density = 1.0
temperature = 1.0
knudsen = 0.3
profile = "isobaric_sine"
amplitude = 0.2
[restitution]
law = "constant"
e = 0.9
)";
// run length, sampling and checkpoints shared by the spatial restart cases
const char* kSpatialRun = R"(
[dsmc]
particles = 20000
dt = 0.01
t_end = 1.0
[sampling]
every = 0.05
steady_from = 0.3
field_batches = 4
[checkpoint]
every = 0.25
keep = true
)";

// A fully periodic 3D box with a medium: the fused stream-sort-collide step
// (src/dsmc/fused.cpp) and the carried bath residual (particles/bath_hazard).
const char* kPeriodicHead = R"(
[domain]
dimensions = 3
length = [2.0, 2.0, 2.0]
cells = [6, 6, 6]
[grains]
temperature = 1.2
[background]
mass_ratio = 0.4
density = 1.0
temperature = 1.0
knudsen = 0.3
[restitution]
law = "constant"
e = 0.85
)";

// The same box without a medium: the fused step then predicts each step's cells at the end
// of the previous one (SortScratch::next_cell, not checkpointed); the resumed run's first
// step streams from x and v instead and must give the same cells.
const char* kPeriodicNoBathHead = R"(
[domain]
dimensions = 3
length = [2.0, 2.0, 2.0]
cells = [6, 6, 6]
[grains]
temperature = 1.2
[restitution]
law = "constant"
e = 0.85
)";

// Rough grains (issue #6): spins and the Trot series must be in the checkpoint; sliding
// (mu = 0.5), the medium acting on the translation.
// kHomogeneous with the power law replaced by Walton's rule
std::string rough_homogeneous() {
  std::string t = kHomogeneous;
  const std::string power = "law = \"power\"\nbeta = 0.15\ndelta = 0.2\n";
  t.replace(t.find(power), power.size(), "law = \"walton\"\ne = 0.85\nbeta0 = 0.6\nmu = 0.5\n");
  t.replace(t.find("[background]"), 12, "rotational_temperature = 0.3\n[background]");
  return t;
}

void check_exact_continuation(const std::string& toml, const std::string& tag) {
  const fs::path ck = fs::temp_directory_path() / ("grainbath-ck-" + tag + "-" + std::to_string(::getpid()));
  fs::remove_all(ck);
  const auto full = run_dsmc(toml, 21, 0, tag + "-full", ck);
  // the run kept the checkpoints at t = 0.5 and 0.75 (two newest); resume from t = 0.5
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(ck)) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  ASSERT_EQ(files.size(), 2u);
  fs::remove(files.back());
  const auto resumed = run_dsmc(toml, 21, 2, tag + "-resumed", ck, true);
  EXPECT_EQ(file_bytes(full.dir / "results.h5"), file_bytes(resumed.dir / "results.h5"));
  expect_same_physics(full.summary, resumed.summary);
  fs::remove_all(ck);
}

}  // namespace

TEST(DsmcRestart, HomogeneousContinuesBitwise) { check_exact_continuation(kHomogeneous, "hom"); }
TEST(DsmcRestart, SpatialContinuesBitwise) { check_exact_continuation(std::string(kSpatialHead) + kSpatialRun, "spa"); }
TEST(DsmcRestart, PeriodicBoxWithBathContinuesBitwise) { check_exact_continuation(std::string(kPeriodicHead) + kSpatialRun, "per"); }
TEST(DsmcRestart, PeriodicBoxWithoutBathContinuesBitwise) {
  check_exact_continuation(std::string(kPeriodicNoBathHead) + kSpatialRun, "pernb");
}
// A 1D periodic line in an isobaric temperature profile (cases/thermal-gradient in small):
// the fused step with a non-uniform medium, whose value at each grain is kept from one
// step's second half-substep for the next step's first (LocalBathCache, src/dsmc/driver.cpp,
// not checkpointed): the resumed run evaluates it afresh at its first step and must match.
const char* kIsobaricLine = R"(
[domain]
dimensions = 1
length = [2.0]
cells = [8]
boundaries = ["periodic"]
[grains]
temperature = 1.0
[background]
mass_ratio = 0.5
density = 1.0
temperature = 1.0
knudsen = 0.05
profile = "isobaric_sine"
amplitude = 0.3
wavenumber_index = 1
[restitution]
law = "elastic"
)";
TEST(DsmcRestart, PeriodicLineInIsobaricMediumContinuesBitwise) {
  // no rebalance step (which drops the cache) at the resume step 50: a stale cache would show
  std::string run = kSpatialRun;
  run.replace(run.find("[dsmc]\n"), 7, "[dsmc]\nrebalance_every = 0\n");
  check_exact_continuation(std::string(kIsobaricLine) + run, "iso");
}
// Checkpoints between samples (every 27 steps, samples every 5): with a medium the second
// bath half of the step before such a checkpoint is still owed (State::bath_half_pending,
// joined to the next step's first half, src/dsmc/driver.cpp); the checkpoint carries the flag
// and the resumed run must join the halves as the uninterrupted one did. (Checked to fail
// when the flag is not restored from the checkpoint.)
std::string checkpoints_between_samples(std::string toml) {
  const std::string every = "[checkpoint]\nevery = 0.25\n";
  toml.replace(toml.find(every), every.size(), "[checkpoint]\nevery = 0.27\n");
  return toml;
}
TEST(DsmcRestart, HomogeneousBetweenSamplesContinuesBitwise) {
  check_exact_continuation(checkpoints_between_samples(kHomogeneous), "hom27");
}
TEST(DsmcRestart, PeriodicBoxWithBathBetweenSamplesContinuesBitwise) {
  check_exact_continuation(checkpoints_between_samples(std::string(kPeriodicHead) + kSpatialRun), "per27");
}
TEST(DsmcRestart, RoughHomogeneousContinuesBitwise) { check_exact_continuation(rough_homogeneous(), "rough"); }

TEST(DsmcRestart, CorruptNewestCheckpointFallsBackToPrevious) {
  const fs::path ck = fs::temp_directory_path() / ("grainbath-ck-corrupt-" + std::to_string(::getpid()));
  fs::remove_all(ck);
  const auto full = run_dsmc(kHomogeneous, 5, 0, "corrupt-full", ck);
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(ck)) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  ASSERT_EQ(files.size(), 2u);
  // truncate the newest checkpoint half-way
  const auto size = fs::file_size(files.back());
  fs::resize_file(files.back(), size / 2);
  testing::internal::CaptureStderr();
  const auto resumed = run_dsmc(kHomogeneous, 5, 0, "corrupt-resumed", ck, true);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("corrupt"), std::string::npos) << err;
  EXPECT_EQ(file_bytes(full.dir / "results.h5"), file_bytes(resumed.dir / "results.h5"));
  fs::remove_all(ck);
}

TEST(DsmcRestart, ChangedCaseIsRefused) {
  const fs::path ck = fs::temp_directory_path() / ("grainbath-ck-changed-" + std::to_string(::getpid()));
  fs::remove_all(ck);
  run_dsmc(kHomogeneous, 5, 0, "changed-full", ck);
  std::string other = kHomogeneous;
  other.replace(other.find("beta = 0.15"), 11, "beta = 0.25");
  EXPECT_THROW(run_dsmc(other, 5, 0, "changed-resumed", ck, true), std::invalid_argument);
  fs::remove_all(ck);
}

// A checkpoint written before a key existed has no such parameter: its absence stands for the
// value that continues it exactly (core/checkpoint.cpp, kAddedLater). `with_old` is the case
// with that value, written by run 1; the key is then deleted from the first checkpoint. The
// default case is refused with a message that holds `refusal` and names the fix `hint`; the
// case with the old value resumes bitwise.
namespace {
void expect_old_checkpoint_resumes(const std::string& name, const std::string& with_old, const char* key,
                                   const std::string& refusal, const std::string& hint) {
  const fs::path ck = fs::temp_directory_path() / ("grainbath-ck-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(ck);
  const auto full = run_dsmc(with_old, 5, 0, name + "-full", ck);
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(ck)) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  ASSERT_EQ(files.size(), 2u);
  fs::remove(files.back());
  {  // make it an old checkpoint: the key absent from its parameters
    const hid_t f = H5Fopen(files.front().c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    ASSERT_GE(H5Adelete_by_name(f, "/parameters", key, H5P_DEFAULT), 0);
    H5Fclose(f);
  }
  try {
    run_dsmc(kHomogeneous, 5, 0, name + "-default", ck, true);
    ADD_FAILURE() << "the default " << key << " resumed an older checkpoint";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(refusal), std::string::npos) << what;
    EXPECT_NE(what.find(hint), std::string::npos) << what;
  }
  const auto resumed = run_dsmc(with_old, 5, 0, name + "-resumed", ck, true);
  EXPECT_EQ(file_bytes(full.dir / "results.h5"), file_bytes(resumed.dir / "results.h5"));
  fs::remove_all(ck);
}
}  // namespace

// `[dsmc] collision_group` (2026-11-26): an older checkpoint was one cell, collision_group = 0.
TEST(DsmcRestart, CheckpointWithoutCollisionGroupKeyResumesAsOneCell) {
  std::string one_cell = kHomogeneous;
  one_cell.replace(one_cell.find("[dsmc]\n"), 7, "[dsmc]\ncollision_group = 0\n");
  expect_old_checkpoint_resumes("oldkey", one_cell, "dsmc.collision_group", "dsmc.collision_group was 0, now 4096",
                                "--set dsmc.collision_group=0 continues it exactly");
}

// `[dsmc] bound` (2026-12-05): an older checkpoint ran Bird's bound, "bird".
TEST(DsmcRestart, CheckpointWithoutBoundKeyResumesWithBirdsBound) {
  std::string bird = kHomogeneous;
  bird.replace(bird.find("[dsmc]\n"), 7, "[dsmc]\nbound = \"bird\"\n");
  expect_old_checkpoint_resumes("oldbound", bird, "dsmc.bound", "dsmc.bound was \"bird\", now \"exact\"",
                                "--set dsmc.bound=\"bird\" continues it exactly");
}

// dsmc.t_end may change on --resume, but not to before the checkpoint (review 2, A1): that
// run did no step, reported the checkpoint's state as the one at t_end and then lost its
// checkpoints. Refused with std::invalid_argument (bad input: the CLI keeps the checkpoints),
// naming the key, both times and the remedy. A t_end exactly at a checkpoint taken at a
// sample point finishes (no step), equal to a run that ends there: the end checkpoint that
// keep = true writes, resumed with the same t_end, and an earlier one with t_end moved to
// it. One between two samples is refused (its end sample, and the medium's second half
// step, would be missing).
namespace {
std::string with_t_end(std::string toml, const std::string& t_end) {
  toml.replace(toml.find("t_end = 1.0"), 11, "t_end = " + t_end);
  return toml;
}
std::vector<fs::path> checkpoint_files(const fs::path& ck) {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(ck)) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}
}  // namespace

TEST(DsmcRestart, ResumeWithTEndBeforeTheCheckpointIsRefusedAndKeepsIt) {
  const fs::path ck = fs::temp_directory_path() / ("grainbath-ck-tend-" + std::to_string(::getpid()));
  fs::remove_all(ck);
  const auto full = run_dsmc(kHomogeneous, 5, 0, "tend-full", ck);  // keeps t = 0.75 and the end, 1.0
  auto files = checkpoint_files(ck);
  ASSERT_EQ(files.size(), 2u);
  ASSERT_EQ(files.back().filename().string(), "checkpoint-000000000100.h5");
  // the end checkpoint resumed with the same t_end: no step, the same results
  const auto again = run_dsmc(kHomogeneous, 5, 0, "tend-again", ck, true);
  EXPECT_EQ(file_bytes(full.dir / "results.h5"), file_bytes(again.dir / "results.h5"));
  expect_same_physics(full.summary, again.summary);
  EXPECT_EQ(checkpoint_files(ck), files);
  try {
    run_dsmc(with_t_end(kHomogeneous, "0.6"), 5, 0, "tend-early", ck, true);
    ADD_FAILURE() << "a t_end before the checkpoint was accepted";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("dsmc.t_end = 0.6 is before the checkpoint (t = 1, step 100): give dsmc.t_end >= 1 "),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("the run that wrote the checkpoint had dsmc.t_end = 1"), std::string::npos) << what;
    EXPECT_NE(what.find("are kept"), std::string::npos) << what;
  }
  EXPECT_EQ(checkpoint_files(ck), files);  // nothing removed or added
  // from t = 0.75 (a sample point, sampling every 5 steps)
  fs::remove(files.back());
  files.pop_back();
  try {
    run_dsmc(with_t_end(kHomogeneous, "0.6"), 5, 0, "tend-early", ck, true);
    ADD_FAILURE() << "a t_end before the checkpoint was accepted";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("dsmc.t_end = 0.6 is before the checkpoint (t = 0.75, step 75): give dsmc.t_end >= 0.75"),
              std::string::npos)
        << what;
  }
  EXPECT_EQ(checkpoint_files(ck), files);
  // t_end moved to the checkpoint: no step, the same results as a run of that length
  const fs::path short_ck = fs::temp_directory_path() / ("grainbath-ck-tend-short-" + std::to_string(::getpid()));
  const auto at_end = run_dsmc(with_t_end(kHomogeneous, "0.75"), 5, 0, "tend-at", ck, true);
  const auto short_run = run_dsmc(with_t_end(kHomogeneous, "0.75"), 5, 0, "tend-short", short_ck);
  EXPECT_EQ(file_bytes(short_run.dir / "results.h5"), file_bytes(at_end.dir / "results.h5"));
  expect_same_physics(short_run.summary, at_end.summary);
  // a later t_end extends the run
  const auto longer = run_dsmc(with_t_end(kHomogeneous, "1.2"), 5, 0, "tend-longer", ck, true);
  const auto t = longer.series("/timeseries/t");
  ASSERT_FALSE(t.empty());
  EXPECT_NEAR(t.back(), 1.2, 1e-9);
  fs::remove_all(ck);
  fs::remove_all(short_ck);
}

TEST(DsmcRestart, ResumeWithTEndAtACheckpointBetweenSamplesIsRefused) {
  const fs::path ck = fs::temp_directory_path() / ("grainbath-ck-tend-between-" + std::to_string(::getpid()));
  fs::remove_all(ck);
  std::string toml = kHomogeneous;
  toml.replace(toml.find("every = 0.05"), 12, "every = 0.1");  // samples every 10 steps: not at 75
  run_dsmc(toml, 5, 0, "between-full", ck);
  auto files = checkpoint_files(ck);
  ASSERT_EQ(files.size(), 2u);  // t = 0.75 and the end
  fs::remove(files.back());
  files.pop_back();
  try {
    run_dsmc(with_t_end(toml, "0.75"), 5, 0, "between-at", ck, true);
    ADD_FAILURE() << "a t_end at a checkpoint between two samples was accepted";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("dsmc.t_end = 0.75 ends at the checkpoint (t = 0.75, step 75), which is not a sample point: "
                        "give dsmc.t_end > 0.75"),
              std::string::npos)
        << what;
  }
  try {
    run_dsmc(with_t_end(toml, "0.65"), 5, 0, "between-early", ck, true);
    ADD_FAILURE() << "a t_end before the checkpoint was accepted";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("give dsmc.t_end > 0.75"), std::string::npos) << what;
  }
  EXPECT_EQ(checkpoint_files(ck), files);
  fs::remove_all(ck);
}

// A --resume with a later dsmc.t_end samples the per-cell fields to the new end: the resumed
// run's fields are the fresh long run's (the same trajectory; the window's totals, summed in
// another grouping of batches: equal to rounding). Before 2026-12-05 the field window stayed
// the first run's, so the fields stopped at its t_end while the time series went on (checked:
// fails). The samples added get their own batches, of about the first run's batch length
// (FieldBatchSegment): 4 batches over the first run's 15 samples, 5 more over the 20 added.
TEST(DsmcRestart, ResumeWithALaterEndSamplesTheFieldsToTheNewEnd) {
  // mode_fit_to defaults to t_end, which would make the resume a changed case
  std::string first = std::string(kSpatialHead) + kSpatialRun;
  first.insert(first.find("field_batches = 4\n"), "mode_fit_to = 1.0\n");
  std::string longer = first;
  longer.replace(longer.find("t_end = 1.0"), 11, "t_end = 2.0");
  const fs::path ck = fs::temp_directory_path() / ("grainbath-ck-extend-" + std::to_string(::getpid()));
  fs::remove_all(ck);
  run_dsmc(first, 21, 0, "extend-first", ck);  // checkpoints kept at t = 0.75 and 1.0
  const auto resumed = run_dsmc(longer, 21, 0, "extend-resumed", ck, true);
  const auto fresh = run_dsmc(longer, 21, 0, "extend-fresh");
  grainbath::testing::expect_same_fields(resumed, fresh);
  auto window = [](const grainbath::testing::CaseRun& r) {
    return grainbath::H5File((r.dir / "results.h5").string(), grainbath::H5File::Mode::read)
        .read_attribute("/fields", "window");
  };
  EXPECT_NE(window(fresh).find("from 4 batches"), std::string::npos) << window(fresh);
  EXPECT_NE(window(resumed).find("from 9 batches"), std::string::npos) << window(resumed);
  fs::remove_all(ck);
}


// a3 (2026-12-06) was added to the checkpoint's series as an optional array: a checkpoint
// written before it (no series/a3) resumes. End to end, with the averaging window opening
// before the checkpoint: the samples before the resume carry NaN for a3, the later ones a3
// as the uninterrupted run has it, a3.mean is the plain mean of the window's finite samples,
// and every other output is bitwise that of the full run.
TEST(DsmcRestart, CheckpointWithoutTheA3SeriesResumesWithA3FromLaterSamples) {
  std::string toml = kHomogeneous;
  toml.replace(toml.find("steady_from = 0.5"), 17, "steady_from = 0.2");
  const fs::path ck = fs::temp_directory_path() / ("grainbath-ck-noa3-" + std::to_string(::getpid()));
  fs::remove_all(ck);
  const auto full = run_dsmc(toml, 21, 0, "noa3-full", ck);
  std::vector<fs::path> files = checkpoint_files(ck);
  ASSERT_EQ(files.size(), 2u);
  fs::remove(files.back());
  {  // make it the checkpoint an earlier build wrote: no a3 series, and a checksum without it
    const hid_t g = H5Fopen(files.front().c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(g, 0);
    ASSERT_GE(H5Ldelete(g, "/series/a3", H5P_DEFAULT), 0);
    H5Fclose(g);
    grainbath::testing::reseal_checkpoint(files.front(), grainbath::dsmc::checkpoint_array_names());
  }
  const auto resumed = run_dsmc(toml, 21, 0, "noa3-resumed", ck, true);
  const auto t = full.series("/timeseries/t");
  const auto a3_full = full.series("/timeseries/a3"), a3_resumed = resumed.series("/timeseries/a3");
  ASSERT_EQ(a3_full.size(), t.size());
  ASSERT_EQ(a3_resumed.size(), t.size());
  std::size_t first = 0;  // the first sample after the resume
  while (first < t.size() && std::isnan(a3_resumed[first])) ++first;
  EXPECT_GT(first, 5u);        // the samples up to the checkpoint (t = 0.75)
  EXPECT_LT(first, t.size());  // and a3 after it
  double sum = 0.0, sum_full = 0.0;
  int n = 0, n_full = 0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    EXPECT_TRUE(std::isfinite(a3_full[k])) << k;
    if (k >= first) {
      EXPECT_EQ(a3_resumed[k], a3_full[k]) << "t = " << t[k];
    }
    if (t[k] < 0.2 - 1e-9) continue;  // steady_from
    sum_full += a3_full[k], ++n_full;
    if (k >= first) sum += a3_full[k], ++n;
  }
  ASSERT_GT(n_full, n);  // the window holds samples without a3
  for (const char* name : {"/timeseries/temperature", "/timeseries/a2", "/timeseries/velocity"})
    EXPECT_EQ(full.series(name), resumed.series(name)) << name;
  for (const auto& [k, v] : full.summary.entries()) {
    if (k.rfind("performance.", 0) == 0) continue;
    ASSERT_NE(resumed.summary.get(k), nullptr) << k;
    if (k.rfind("a3.", 0) == 0 && k != "a3.final") continue;
    EXPECT_EQ(v, *resumed.summary.get(k)) << k;
  }
  EXPECT_NEAR(full.summary.number("a3.mean"), sum_full / n_full, 1e-12);
  EXPECT_NEAR(resumed.summary.number("a3.mean"), sum / n, 1e-12);
  fs::remove_all(ck);
}

// Checkpoints of the earlier scalar layouts (src/dsmc/checkpoint.cpp, unpack) resume bitwise:
// 12 integers (before the bath halves were joined; such files were written with both halves
// applied) and 13 (before the field batch segments: one segment, the whole window). Made
// here from a checkpoint at a sample point (no half step owed, one segment) by cutting its
// scalar integers to the earlier length and resealing it (tests/checkpoint_tamper.hpp).
TEST(DsmcRestart, CheckpointsOfTheEarlierScalarLayoutsResumeBitwise) {
  struct Layout {
    std::string toml;
    std::size_t integers;
    std::string tag;
  };
  for (const Layout& l : {Layout{kHomogeneous, 12, "u12"}, Layout{std::string(kSpatialHead) + kSpatialRun, 13, "u13"}}) {
    const fs::path ck = fs::temp_directory_path() / ("grainbath-ck-" + l.tag + "-" + std::to_string(::getpid()));
    fs::remove_all(ck);
    const auto full = run_dsmc(l.toml, 21, 0, l.tag + "-full", ck);
    auto files = checkpoint_files(ck);
    ASSERT_EQ(files.size(), 2u);
    fs::remove(files.back());
    auto u = grainbath::testing::checkpoint_integers(files.front(), "scalars/integer");
    ASSERT_GE(u.size(), 13u);
    ASSERT_EQ(u[12], 0u) << l.tag << ": a half step owed, which no file of the earlier layout had";
    if (l.integers == 13) {
      ASSERT_EQ(u.size(), 17u) << "one field batch segment";
    }
    u.resize(l.integers);
    grainbath::testing::rewrite_checkpoint_array(files.front(), grainbath::dsmc::checkpoint_array_names(),
                                                 "scalars/integer", u);
    const auto resumed = run_dsmc(l.toml, 21, 0, l.tag + "-resumed", ck, true);
    EXPECT_EQ(file_bytes(full.dir / "results.h5"), file_bytes(resumed.dir / "results.h5")) << l.tag;
    expect_same_physics(full.summary, resumed.summary);
    fs::remove_all(ck);
  }
}

// Field batch segments that do not tile the averaging window (their sample ranges must follow
// each other from 0 to the window's end, their batches likewise: batch_of relies on it) are
// refused, in a file that verifies (resealed): a partial segment, an empty one, one that
// ends before the window does. --resume warns with the reason and finds no valid checkpoint.
TEST(DsmcRestart, FieldBatchSegmentsThatDoNotTileTheWindowAreRefused) {
  const std::string toml = std::string(kSpatialHead) + kSpatialRun;
  const fs::path ck = fs::temp_directory_path() / ("grainbath-ck-tiles-" + std::to_string(::getpid()));
  const fs::path one = ck.string() + ".one";
  fs::remove_all(ck);
  run_dsmc(toml, 21, 0, "tiles-full", ck);
  const fs::path good = checkpoint_files(ck).back();
  const auto u = grainbath::testing::checkpoint_integers(good, "scalars/integer");
  ASSERT_EQ(u.size(), 17u);  // 13 and one segment: [0, window) in all the batches
  const std::uint64_t window = u[10], batches = u[8];
  ASSERT_GT(window, 1u);
  ASSERT_GT(batches, 1u);
  ASSERT_EQ(std::vector<std::uint64_t>(u.begin() + 13, u.end()), (std::vector<std::uint64_t>{0, window, 0, batches}));
  struct Damage {
    const char* what;
    const char* reason;
    std::vector<std::uint64_t> integers;
  };
  auto with = [&](std::vector<std::uint64_t> tail) {
    std::vector<std::uint64_t> v(u.begin(), u.begin() + 13);
    v.insert(v.end(), tail.begin(), tail.end());
    return v;
  };
  const std::vector<Damage> damages = {
      {"half a segment more", "checkpoint: wrong scalar layout", with({0, window, 0, batches, 0, 0})},
      {"an empty segment first", "checkpoint: field batch segments do not tile the window",
       with({0, 0, 0, 1, 0, window, 1, batches - 1})},
      {"a segment ending before the window", "checkpoint: field batch segments do not tile the window",
       with({0, window - 1, 0, batches})}};
  for (const Damage& d : damages) {
    fs::remove_all(one);
    fs::create_directories(one);
    const fs::path copy = one / good.filename();
    fs::copy_file(good, copy);
    grainbath::testing::rewrite_checkpoint_array(copy, grainbath::dsmc::checkpoint_array_names(), "scalars/integer",
                                                 d.integers);
    std::string err;
    testing::internal::CaptureStderr();
    try {
      run_dsmc(toml, 21, 0, "tiles-resumed", one, true);
      ADD_FAILURE() << d.what << " was accepted";
    } catch (const std::runtime_error& e) {
      err = e.what();
    }
    err += testing::internal::GetCapturedStderr();
    EXPECT_NE(err.find(std::string("is unreadable or corrupt (") + d.reason), std::string::npos) << d.what << ": " << err;
    EXPECT_NE(err.find("--resume: no valid checkpoint"), std::string::npos) << d.what << ": " << err;
  }
  fs::remove_all(ck);
  fs::remove_all(one);
}

// Open faces: grains leave the box, and the count of those removed and the energy they took
// (RunCounters::removed, removed_energy: the energy balance of summary.json) are in the
// checkpoint's scalars. The spatial case with its two x faces open continues bitwise.
TEST(DsmcRestart, OpenFacesContinueBitwise) {
  std::string toml = std::string(kSpatialHead) + kSpatialRun;
  const std::string faces = R"(boundaries = ["periodic", "periodic", "diffuse", "specular"])";
  toml.replace(toml.find(faces), faces.size(), R"(boundaries = ["open", "open", "diffuse", "specular"])");
  check_exact_continuation(toml, "open");
}

// The power law clamped to e = 0 (1 - 0.5 v_n < 0 for v_n > 2: often, at T = 1.4 with a
// drift): the count of clamped collisions (counters.restitution_clamped) is in the
// checkpoint's scalars and continues bitwise.
TEST(DsmcRestart, ClampedRestitutionCountContinuesBitwise) {
  std::string toml = kHomogeneous;
  const std::string law = "beta = 0.15\ndelta = 0.2\n";
  toml.replace(toml.find(law), law.size(), "beta = 0.5\ndelta = 1.0\n");
  testing::internal::CaptureStderr();  // the run warns of the clamping
  const double clamped = run_dsmc(toml, 21, 0, "clamp-probe").summary.number("counters.restitution_clamped");
  testing::internal::GetCapturedStderr();
  ASSERT_GT(clamped, 0.0);
  testing::internal::CaptureStderr();
  check_exact_continuation(toml, "clamp");
  testing::internal::GetCapturedStderr();
}
