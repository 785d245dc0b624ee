// FifoGuard (runtime/fifo_guard.h): when a SCHED_FIFO thread must step down, from a window's figures.
#include "service/runtime/fifo_guard.h"

#include <gtest/gtest.h>

using coopdyn::runtime::FifoGuard;
using V = FifoGuard::Verdict;

namespace {
constexpr int64_t kWindow = 1000000000;  // 1 s
}

// Busy more than half the window: step down at once; half or less: keep (a 1 kHz loop computing 20 us
// a tick is busy 2 %).
TEST(FifoGuard, BusyMoreThanHalfAWindowStepsDown) {
  FifoGuard g;
  EXPECT_EQ(g.window(kWindow, 20000 * 1000, 1000, 0), V::kKeep);
  EXPECT_EQ(g.window(kWindow, kWindow / 2, 1000, 0), V::kKeep);
  EXPECT_EQ(g.window(kWindow, kWindow / 2 + 1, 1000, 0), V::kBusy);
  // a thread without ticks (the receive process): only its busy share counts
  FifoGuard r;
  EXPECT_EQ(r.window(kWindow, kWindow / 3, 0, 0), V::kKeep);
  EXPECT_EQ(r.window(kWindow, kWindow, 0, 0), V::kBusy);
  EXPECT_EQ(r.window(0, 5, 0, 0), V::kKeep) << "an empty window says nothing";
}

// Overruns step down only when they persist: at least half the ticks of kOverrunWindows windows in a
// row; a clean window (or one below the share) starts the count again.
TEST(FifoGuard, OverrunsStepDownOnlyWhenTheyPersist) {
  FifoGuard g;
  const int64_t idle = kWindow / 10;
  EXPECT_EQ(g.window(kWindow, idle, 1000, 500), V::kKeep);
  EXPECT_EQ(g.window(kWindow, idle, 1000, 600), V::kKeep);
  EXPECT_EQ(g.window(kWindow, idle, 1000, 499), V::kKeep) << "below half: the run is broken";
  EXPECT_EQ(g.window(kWindow, idle, 1000, 1000), V::kKeep);
  EXPECT_EQ(g.window(kWindow, idle, 1000, 1000), V::kKeep);
  EXPECT_EQ(g.window(kWindow, idle, 1000, 700), V::kOverruns) << "three windows in a row";
  static_assert(FifoGuard::kOverrunWindows == 3, "the sequence above has three windows in a row");
}
