// The automatic OpenMP thread count of `[run] threads = 0` (src/core/run_support.hpp): the
// cores other processes leave free, at least one, from the larger of the CPU time others used
// over a short window (in cores, rounded) and the other runnable tasks now.
#include <gtest/gtest.h>
#include <unistd.h>

#include "core/run_support.hpp"

using grainbath::automatic_threads;
using grainbath::busy_cores;
using grainbath::CoreUse;

TEST(AutomaticThreads, IdleMachineUsesEveryCore) {
  EXPECT_EQ(automatic_threads(CoreUse{2, 0.05, 0}), 2);
  EXPECT_EQ(automatic_threads(CoreUse{8, 0.4, 0}), 8);
}

TEST(AutomaticThreads, LeavesTheCoresOtherJobsUse) {
  EXPECT_EQ(automatic_threads(CoreUse{2, 1.0, 1}), 1);  // one other job on a 2-core machine
  EXPECT_EQ(automatic_threads(CoreUse{8, 2.6, 2}), 5);  // 2.6 cores' worth rounds to 3
  EXPECT_EQ(busy_cores(CoreUse{8, 2.6, 2}), 3);
}

TEST(AutomaticThreads, EitherMeasureOfAnotherJobCounts) {
  // a job runnable now that had little CPU time in the window (it just started)
  EXPECT_EQ(automatic_threads(CoreUse{2, 0.1, 1}), 1);
  // a job that used its core over the window but waits at this instant
  EXPECT_EQ(automatic_threads(CoreUse{4, 2.0, 0}), 2);
  // half a core's worth of other work does not take a core
  EXPECT_EQ(automatic_threads(CoreUse{2, 0.4, 0}), 2);
}

TEST(AutomaticThreads, AtLeastOneThreadOnAnOverloadedMachine) {
  EXPECT_EQ(automatic_threads(CoreUse{2, 7.5, 6}), 1);
  EXPECT_EQ(busy_cores(CoreUse{2, 7.5, 6}), 2);
  EXPECT_EQ(automatic_threads(CoreUse{1, 0.0, 0}), 1);
}

TEST(AutomaticThreads, ThisMachineGivesAPlausibleCount) {
  const CoreUse u = grainbath::core_use();
  EXPECT_GE(u.cores, 1);
  // the /proc fields read right: CPU time outside idle can be at most every online CPU's
  const double online = static_cast<double>(sysconf(_SC_NPROCESSORS_ONLN));
  EXPECT_LE(u.cores, online);
  EXPECT_GE(u.busy, 0.0);
  EXPECT_LE(u.busy, online * (1 + 1e-9));
  EXPECT_GE(u.other_runnable, 0);
  EXPECT_GE(automatic_threads(u), 1);
  EXPECT_LE(automatic_threads(u), u.cores);
}
