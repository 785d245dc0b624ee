// The loop's step path allocates nothing: thousands of ServiceLoop::tick() calls (dynamics, input
// handoff, watchdog, output and stats encoding, publish) of every scene in both modes, and run()
// with its absolute-deadline sleeps, under the counting heap. Inputs are offered between ticks
// outside the count (the receive thread is not the loop).
#define COOPDYN_COUNTING_ALLOCATOR_IMPL
#include "tests/counting_allocator.h"

#include <gtest/gtest.h>

#include "service/runtime/service_loop.h"
#include "tests/daemon_test_util.h"

using namespace coopdyn;
using namespace coopdyn::daemon_test;
using coopdyn::testing::AllocationCounter;
using coopdyn::testing::kCountingAvailable;

TEST(LoopNoAllocation, TickOfEverySceneBothModes) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  for (const auto& name : loadable_scenes()) {
    for (auto mode : {runtime::ServiceMode::kSimulate, runtime::ServiceMode::kEstimate}) {
      SCOPED_TRACE(name + (mode == runtime::ServiceMode::kSimulate ? " simulate" : " estimate"));
      const System sys = load_scene(scene_path(name));
      runtime::ServiceConfig cfg;
      cfg.mode = mode;
      cfg.stats_period_s = 0.05;  // stats every 50 ticks, inside the count
      cfg.watchdog_ms = 20;       // expiries and resumptions inside the count too
      FakeBus bus;
      runtime::ServiceLoop loop(sys, cfg, bus);
      const Eigen::VectorXd tau = some_torque(sys, 1, 0.5);
      const auto cmd = [&](int64_t seq) { return io::encode_torque_command(0, seq, {}, stdvec(tau)); };
      const auto state = [&](int64_t seq) {
        return io::encode_measured_state(0, seq, {}, stdvec(sys.q0), {}, stdvec(sys.v0), stdvec(tau));
      };
      long allocations = 0;
      const long long ms = 1000000;
      for (int k = 0; k < 3000; ++k) {
        if (k % 7 == 0 && (k / 500) % 2 == 0) {  // commands for 500 ticks, then silence (expiry)
          const auto b = mode == runtime::ServiceMode::kSimulate ? cmd(k) : state(k);
          if (mode == runtime::ServiceMode::kSimulate) loop.commands().offer(b.data(), static_cast<int>(b.size()), k * ms);
          else loop.states().offer(b.data(), static_cast<int>(b.size()), k * ms);
        }
        AllocationCounter c;
        loop.tick(k * ms);
        loop.record_timing(1000, 20000);
        allocations += c.count();
      }
      EXPECT_EQ(allocations, 0);
      EXPECT_EQ(loop.ticks(), 3000);
      EXPECT_GE(loop.expirations(), 2);
      EXPECT_EQ(bus.count("COOPDYN_OUTPUT"), 3000);
      EXPECT_EQ(bus.count("COOPDYN_STATS"), 60);
      runtime::Event e;
      while (loop.events().pop(&e)) {
      }
    }
  }
}

TEST(LoopNoAllocation, RunWithDeadlineSleeps) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  const System sys = load_scene(scene_path("two_puma_load"));
  runtime::ServiceConfig cfg;
  cfg.stats_period_s = 0.05;
  FakeBus bus;
  runtime::ServiceLoop loop(sys, cfg, bus);
  std::atomic<bool> stop{false};
  long allocations;
  {
    AllocationCounter c;
    loop.run(stop, 300);  // 0.3 s at 1 kHz
    allocations = c.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(loop.ticks(), 300);
  EXPECT_EQ(loop.totals().window_ticks, 300);
}
