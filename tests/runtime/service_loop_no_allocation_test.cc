// The loop's step path allocates nothing: thousands of ServiceLoop::tick() calls (dynamics, input
// handoff, watchdog, lock targets of the commands, output and stats encoding, publish, a refused
// publish counted) of every scene in both modes, and run() with its absolute-deadline sleeps, under
// the counting heap. Inputs are offered between ticks outside the count (the receive thread is not
// the loop).
#define COOPDYN_COUNTING_ALLOCATOR_IMPL
#include "tests/support/counting_allocator.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "service/dynamics/sigma/state_fit_sigma.h"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "service/io/transport/lcm_bus.h"
#include "service/io/transport/rx_isolated.h"
#include "service/runtime/publisher_thread.h"
#include "service/runtime/service_loop.h"
#include "tests/support/child_process.h"
#include "tests/support/daemon_test_util.h"
#include "tests/support/heavy_loop.h"

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
      // commands carry lock targets where the scene lets them be commanded (a vehicle's steer
      // angles), changing from one command to the next: the targets' path through the loop too
      std::vector<std::string> tn;
      for (const ConstraintSpec& sp : sys.constraints.specs)
        if (sp.kind == ConstraintKind::kLock && sp.target_limit > 0) tn.push_back(sys.model.v_names[static_cast<size_t>(sp.dof)]);
      const auto cmd = [&](int64_t seq) {
        const double x = seq % 2 ? 0.02 : -0.01;
        return io::encode_torque_command(runtime::realtime_us(), seq, {}, stdvec(tau), tn, std::vector<double>(tn.size(), x));
      };
      // full states, joints-only states (the load's pose and twist fitted: state_fit.h) and states
      // that do not close (refused with REASON_CLOSURE), in turn
      const StateFitPlan plan = plan_state_fit(sys);
      std::vector<std::string> jq, jv;
      std::vector<double> jqv, jvv, jtau;
      for (int i = 0; i < sys.model.nq(); ++i)
        if (std::find(plan.fit_q.begin(), plan.fit_q.end(), i) == plan.fit_q.end()) {
          jq.push_back(sys.model.q_names[i]);
          jqv.push_back(sys.q0[i]);
        }
      for (int i = 0; i < sys.model.nv(); ++i)
        if (std::find(plan.fit_v.begin(), plan.fit_v.end(), i) == plan.fit_v.end()) {
          jv.push_back(sys.model.v_names[i]);
          jvv.push_back(sys.v0[i]);
          jtau.push_back(tau[i]);
        }
      Eigen::VectorXd q_far = sys.q0;
      if (!plan.fit_q.empty()) q_far[plan.fit_q[2]] += 1.0;  // z: a metre above where the constraints hold it
      const auto state = [&](int64_t seq) {
        if (seq % 3 == 1 && plan.q_fittable && plan.v_fittable)
          return io::encode_measured_state(runtime::realtime_us(), seq, jq, jqv, jv, jvv, jtau);
        if (seq % 3 == 2)
          return io::encode_measured_state(runtime::realtime_us(), seq, {}, stdvec(q_far), {}, stdvec(sys.v0), stdvec(tau));
        return io::encode_measured_state(runtime::realtime_us(), seq, {}, stdvec(sys.q0), {}, stdvec(sys.v0), stdvec(tau));
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
      if (mode == runtime::ServiceMode::kEstimate && !plan.fit_q.empty()) {
        EXPECT_GT(loop.closure_rejections(), 0);
      }
      runtime::Event e;
      while (loop.events().pop(&e)) {
      }
    }
  }
}

namespace {

// Ticks at 1 ms, a fresh state offered before every fifth (encode(k): its bytes, encoded outside the
// count; none when empty); the allocations the ticks made.
template <class Encode>
long tick_allocations(runtime::ServiceLoop& loop, int ticks, Encode&& encode) {
  long allocations = 0;
  const long long ms = 1000000;
  for (int k = 0; k < ticks; ++k) {
    if (k % 5 == 0) {
      const std::vector<uint8_t> st = encode(k);
      if (!st.empty()) loop.states().offer(st.data(), static_cast<int>(st.size()), k * ms);
    }
    AllocationCounter c;
    loop.tick(k * ms);
    allocations += c.count();
  }
  return allocations;
}

}  // namespace

// A scene that declares torque, position and velocity noise: every tick also computes each wrench's
// sigma (wrench_sigma.h), in both modes, without allocating; the published output_t carries it
// (simulate: SIGMA_TAU, estimate: SIGMA_TAU | SIGMA_Q | SIGMA_V), equal to the sigma of the same
// evaluation computed here.
TEST(LoopNoAllocation, TickWithWrenchSigma) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  const System sys = load_scene_string(slurp(scene_path("two_puma_load")) + "\nnoise: {tau: 0.2, q: 1e-4, v: 1e-3}\n",
                                       scene_path("two_puma_load"));
  for (auto mode : {runtime::ServiceMode::kSimulate, runtime::ServiceMode::kEstimate}) {
    runtime::ServiceConfig cfg;
    cfg.mode = mode;
    FakeBus bus;
    runtime::ServiceLoop loop(sys, cfg, bus);
    EXPECT_EQ(tick_allocations(loop, 1000, [&](int k) {
                if (mode != runtime::ServiceMode::kEstimate) return std::vector<uint8_t>();
                return io::encode_measured_state(runtime::realtime_us(), k, {}, stdvec(sys.q0), {}, stdvec(sys.v0),
                                                 std::vector<double>(static_cast<size_t>(sys.model.nv()), 0.1));
              }),
              0);
    const io::DecodedOutput o = bus.last_output();
    SCOPED_TRACE(mode == runtime::ServiceMode::kSimulate ? "simulate" : "estimate");
    EXPECT_EQ(o.status, 0) << o.reason;
    const bool est = mode == runtime::ServiceMode::kEstimate;
    EXPECT_EQ(o.sigma_source, est ? 7 : 1);
    ASSERT_EQ(o.wrench_sigma.size(), sys.wrenches.outputs.size());
    Workspace ws(sys);
    WrenchData wd(sys);
    WrenchSigmaData sd(sys);
    evaluate(sys, ws, vec(o.q), vec(o.v), vec(o.tau));
    compute_wrenches(sys, ws, wd);
    if (est) compute_wrench_sigma(sys, ws, sd, vec(o.q), vec(o.v), vec(o.tau));
    else compute_wrench_sigma(sys, ws, sd);
    for (size_t k = 0; k < o.wrench_sigma.size(); ++k)
      for (int i = 0; i < 6; ++i) EXPECT_NEAR(o.wrench_sigma[k][i], sd.sigma[k][i], 1e-9 * (1.0 + sd.sigma[k][i]));
  }
}

// Estimate mode with states that omit the load's pose and twist (fitted from the joints): the sigma
// of position and velocity noise refits them per column (state_fit_sigma.h), without allocating;
// the published sigma is the one computed here with the same refit.
TEST(LoopNoAllocation, TickWithWrenchSigmaThroughTheFit) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  const System sys = load_scene_string(slurp(scene_path("two_puma_load")) + "\nnoise: {tau: 0.2, q: 1e-4, v: 1e-3}\n",
                                       scene_path("two_puma_load"));
  const StateFitPlan plan = plan_state_fit(sys);
  ASSERT_TRUE(plan.q_fittable && plan.v_fittable);
  std::vector<std::string> qn, vn;
  std::vector<double> qm, vm;
  for (int i = 0; i < sys.model.nq(); ++i)
    if (std::find(plan.fit_q.begin(), plan.fit_q.end(), i) == plan.fit_q.end()) {
      qn.push_back(sys.model.q_names[static_cast<size_t>(i)]);
      qm.push_back(sys.q0[i]);
    }
  for (int i = 0; i < sys.model.nv(); ++i)
    if (std::find(plan.fit_v.begin(), plan.fit_v.end(), i) == plan.fit_v.end()) {
      vn.push_back(sys.model.v_names[static_cast<size_t>(i)]);
      vm.push_back(sys.v0[i]);
    }
  runtime::ServiceConfig cfg;
  cfg.mode = runtime::ServiceMode::kEstimate;
  FakeBus bus;
  runtime::ServiceLoop loop(sys, cfg, bus);
  EXPECT_EQ(tick_allocations(loop, 500, [&](int k) {
              return io::encode_measured_state(runtime::realtime_us(), k, qn, qm, vn, vm,
                                               std::vector<double>(static_cast<size_t>(sys.model.nv()), 0.1));
            }),
            0);
  const io::DecodedOutput o = bus.last_output();
  EXPECT_EQ(o.status, 0) << o.reason;
  EXPECT_EQ(o.state_fitted, 3);
  EXPECT_EQ(o.sigma_source, 7);
  Workspace ws(sys);
  WrenchData wd(sys);
  WrenchSigmaData sd(sys), held(sys);
  FitRefit refit(sys, plan);
  refit.set(vec(o.q), true, true);
  sd.refit = &refit;
  evaluate(sys, ws, vec(o.q), vec(o.v), vec(o.tau));
  compute_wrenches(sys, ws, wd);
  compute_wrench_sigma(sys, ws, sd, vec(o.q), vec(o.v), vec(o.tau));
  compute_wrench_sigma(sys, ws, held, vec(o.q), vec(o.v), vec(o.tau));
  double differs = 0.0;
  ASSERT_EQ(o.wrench_sigma.size(), sys.wrenches.outputs.size());
  for (size_t k = 0; k < o.wrench_sigma.size(); ++k)
    for (int i = 0; i < 6; ++i) {
      EXPECT_NEAR(o.wrench_sigma[k][i], sd.sigma[k][i], 1e-9 * (1.0 + sd.sigma[k][i]));
      differs = std::max(differs, std::abs(held.sigma[k][i] - sd.sigma[k][i]));
    }
  EXPECT_GT(differs, 1e-6) << "the refit changes nothing: is the fit in the columns?";
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
  // realtime.spin_us: the warm-up evaluation and the busy wait before each deadline, both modes
  for (auto mode : {runtime::ServiceMode::kSimulate, runtime::ServiceMode::kEstimate}) {
    runtime::ServiceConfig spin = cfg;
    spin.mode = mode;
    spin.realtime.spin_us = 100;
    runtime::ServiceLoop spinning(sys, spin, bus);
    AllocationCounter c;
    spinning.run(stop, 100);
    EXPECT_EQ(c.count(), 0);
    EXPECT_EQ(spinning.ticks(), 100);
  }
}

// realtime.sched_fifo auto's guard (fifo_guard.h) in run(): a scene too heavy for the period
// (tiago_pro_box with a period a quarter of its shortest warm tick measured here: every tick
// overruns by construction, tests/support/heavy_loop.h) is stepped down, once, with an event for the
// daemon's log, and neither the watch nor the step down allocates. A stats window of 200 periods
// holds at most 50 ticks: the 400 ticks make 8 windows or more, as many as the guard needs however
// fast the machine. (The test's thread runs SCHED_OTHER: the step down is then a no-op the kernel
// accepts.)
TEST(LoopNoAllocation, RunStepsATooHeavyLoopDownOnce) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  const System sys = load_scene(scene_path("tiago_pro_box"));
  runtime::ServiceConfig cfg;
  cfg.rate_hz = heavy_rate_hz(shortest_warm_tick_ns(sys, cfg));
  cfg.stats_period_s = 200.0 / cfg.rate_hz;
  FakeBus bus;
  runtime::ServiceLoop loop(sys, cfg, bus);
  loop.guard_fifo(true);
  std::atomic<bool> stop{false};
  long allocations;
  {
    AllocationCounter c;
    loop.run(stop, 400);
    allocations = c.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(loop.fifo_demotions(), 1) << "rate_hz " << cfg.rate_hz << ", " << loop.ticks() << " ticks, " << loop.overruns()
                                      << " overruns";
  runtime::Event e;
  int demoted = 0;
  while (loop.events().pop(&e))
    if (e.code == runtime::EventCode::kFifoDemoted) {
      ++demoted;
      // busy (its CPU time over half the window) or, on a loaded machine that gives this SCHED_OTHER
      // test thread less than half a CPU, overrunning every tick for three windows
      const auto v = static_cast<runtime::FifoGuard::Verdict>(e.a);
      EXPECT_TRUE(v == runtime::FifoGuard::Verdict::kBusy || v == runtime::FifoGuard::Verdict::kOverruns) << e.a;
      if (v == runtime::FifoGuard::Verdict::kBusy) {
        EXPECT_GT(e.x, runtime::FifoGuard::kMaxBusyShare);
      }
    }
  EXPECT_EQ(demoted, 1);
}

// The daemon's fixed-rate loop publishes through a publisher thread (realtime.publisher_thread): the
// loop's side of it (the copy into a slot, the doorbell) allocates nothing either, and every output
// and stats message reaches the bus behind it or is counted as dropped.
TEST(LoopNoAllocation, RunThroughThePublisherThread) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  const System sys = load_scene(scene_path("two_puma_load"));
  runtime::ServiceConfig cfg;
  cfg.stats_period_s = 0.05;
  FakeBus bus;
  runtime::PublisherThread pub(bus, runtime::ServiceLoop::max_message_bytes(sys));
  pub.start();
  runtime::ServiceLoop loop(sys, cfg, pub);
  std::atomic<bool> stop{false};
  long allocations;
  {
    AllocationCounter c;
    loop.run(stop, 300);
    allocations = c.count();
  }
  pub.stop();
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(loop.ticks(), 300);
  const long outputs = bus.find(cfg.output_channel.c_str()) ? bus.find(cfg.output_channel.c_str())->count : 0;
  const long stats = bus.find(cfg.stats_channel.c_str()) ? bus.find(cfg.stats_channel.c_str())->count : 0;
  EXPECT_EQ(outputs + stats, pub.published());
  EXPECT_EQ(pub.published() + pub.dropped(), 300 + 300 / 50);
}

namespace {

// Waits until the publisher thread has handed on `handed` messages (published, dropped or failed).
// The 30 s limit only turns a stuck thread into a failure instead of a hang; nothing is timed (the
// thread takes microseconds per message even on a loaded machine).
::testing::AssertionResult wait_handed_on(const runtime::PublisherThread& pub, int64_t handed) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (pub.published() + pub.dropped() + pub.failed() < handed) {
    if (std::chrono::steady_clock::now() > give_up)
      return ::testing::AssertionFailure() << "the publisher thread handed on " << pub.published() + pub.dropped() + pub.failed()
                                           << " of " << handed << " messages in 30 s (published " << pub.published()
                                           << ", dropped " << pub.dropped() << ", failed " << pub.failed() << ")";
    std::this_thread::yield();
  }
  return ::testing::AssertionSuccess();
}

// Behind the loop, a bus that refuses every fourth message (publish() -1, as lcm_publish failing does
// where the loop publishes itself), and remembers how many it had refused when it took the last
// loop_stats_t. Fixed storage: publish() never allocates.
struct RefusingBus : io::Bus {
  explicit RefusingBus(const std::string& stats) : stats_channel(stats) {}
  int publish(const char* channel, const void* data, int len) override {
    if (++calls % 4 == 0) {
      ++refused;
      return -1;
    }
    if (stats_channel == channel) refused_before_last_stats = refused;
    return taken.publish(channel, data, len);
  }
  const std::string stats_channel;
  FakeBus taken;
  long calls = 0, refused = 0, refused_before_last_stats = -1;
};

// The inner bus of a publisher thread, held inside publish() until released: the thread without a CPU.
struct HeldBus : io::Bus {
  int publish(const char* channel, const void* data, int len) override {
    while (hold.load()) std::this_thread::yield();
    return taken.publish(channel, data, len);
  }
  std::atomic<bool> hold{true};
  FakeBus taken;
};

io::StatsFrame last_stats(const FakeBus& bus, const std::string& channel) {
  io::StatsFrame s;
  const FakeBus::Slot* slot = bus.find(channel.c_str());
  EXPECT_TRUE(slot && io::decode_stats(slot->data.data(), slot->len, &s)) << "no loop_stats_t on " << channel;
  return s;
}

}  // namespace

// The loop counts each message its bus refuses (outputs_dropped), without allocating: every message
// it made either reached the bus or is counted, and each loop_stats_t carries the refusals before it.
TEST(LoopNoAllocation, CountsTheMessagesItsBusRefuses) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  const System sys = load_scene(scene_path("two_puma_load"));
  runtime::ServiceConfig cfg;
  cfg.stats_period_s = 0.05;  // stats every 50 ticks at 1 kHz
  RefusingBus bus(cfg.stats_channel);
  runtime::ServiceLoop loop(sys, cfg, bus);
  long allocations = 0;
  for (int k = 0; k < 1000; ++k) {
    AllocationCounter c;
    loop.tick(k * 1000000LL);
    allocations += c.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(bus.calls, 1000 + 20);  // 1000 output_t, 20 loop_stats_t
  EXPECT_EQ(bus.refused, 255);  // every fourth: outputs and, of the stats (call 51 k), every fourth
  EXPECT_EQ(loop.outputs_dropped(), bus.refused);
  EXPECT_EQ(loop.totals().outputs_dropped, bus.refused);
  EXPECT_EQ(bus.taken.count(cfg.output_channel.c_str()) + bus.taken.count(cfg.stats_channel.c_str()) + bus.refused,
            bus.calls);
  ASSERT_GT(bus.refused_before_last_stats, 0);
  EXPECT_EQ(last_stats(bus.taken, cfg.stats_channel).outputs_dropped, bus.refused_before_last_stats);
}

// A publisher thread stuck in its inner publish: its ring takes kSlots messages, the loop counts every
// later one the ring refuses (exactly the thread's dropped()), without allocating; once the thread
// runs again, the next loop_stats_t that reaches the bus reports them.
TEST(LoopNoAllocation, CountsWhatAStuckPublisherThreadDrops) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  const System sys = load_scene(scene_path("two_puma_load"));
  runtime::ServiceConfig cfg;
  cfg.stats_period_s = 0.05;
  HeldBus inner;
  runtime::PublisherThread pub(inner, runtime::ServiceLoop::max_message_bytes(sys));
  pub.start();
  runtime::ServiceLoop loop(sys, cfg, pub);
  const auto handed = [&] { return static_cast<int64_t>(loop.ticks() + loop.ticks() / 50); };  // outputs + stats
  const auto drained = [&] { return wait_handed_on(pub, handed()); };
  long allocations = 0;
  for (int k = 0; k < 60; ++k) {  // 60 outputs and the stats of tick 50 while the thread is stuck
    AllocationCounter c;
    loop.tick(k * 1000000LL);
    allocations += c.count();
  }
  EXPECT_EQ(loop.outputs_dropped(), 61 - runtime::PublisherThread::kSlots);
  EXPECT_EQ(loop.outputs_dropped(), pub.dropped());
  inner.hold.store(false);
  for (int k = 60; k < 100; ++k) {  // the thread runs again: each message waited for before the next
    ASSERT_TRUE(drained()) << "tick " << k;
    AllocationCounter c;
    loop.tick(k * 1000000LL);
    allocations += c.count();
  }
  ASSERT_TRUE(drained());
  pub.stop();
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(loop.outputs_dropped(), 61 - runtime::PublisherThread::kSlots);
  EXPECT_EQ(pub.dropped(), loop.outputs_dropped());
  EXPECT_EQ(inner.taken.count(cfg.output_channel.c_str()), runtime::PublisherThread::kSlots + 40);
  EXPECT_EQ(inner.taken.count(cfg.stats_channel.c_str()), 1);
  const io::StatsFrame s = last_stats(inner.taken, cfg.stats_channel);
  EXPECT_EQ(s.tick, 100);
  EXPECT_EQ(s.outputs_dropped, 61 - runtime::PublisherThread::kSlots);
}

// The publisher thread's own send failing (its inner bus refuses every fourth message, as lcm_publish
// failing would): the thread counts each (failed()), and the loop's outputs_dropped and each
// loop_stats_t include them, without the loop allocating. Each tick waits until the thread has handed
// on what the tick made, so a loop_stats_t carries every failure before it but, at most, that of the
// output its own tick queued just before it (still in the thread's hands when the stats were filled).
TEST(LoopNoAllocation, CountsWhatThePublisherThreadFailsToSend) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  const System sys = load_scene(scene_path("two_puma_load"));
  runtime::ServiceConfig cfg;
  cfg.stats_period_s = 0.05;
  RefusingBus inner(cfg.stats_channel);
  runtime::PublisherThread pub(inner, runtime::ServiceLoop::max_message_bytes(sys));
  pub.start();
  runtime::ServiceLoop loop(sys, cfg, pub);
  long allocations = 0;
  for (int k = 0; k < 200; ++k) {
    AllocationCounter c;
    loop.tick(k * 1000000LL);
    allocations += c.count();
    ASSERT_TRUE(wait_handed_on(pub, loop.ticks() + loop.ticks() / 50)) << "tick " << k;  // outputs + stats
  }
  pub.stop();
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(pub.dropped(), 0);
  EXPECT_EQ(inner.calls, 200 + 4);
  EXPECT_EQ(inner.refused, 51);  // calls 4, 8, ..., 204
  EXPECT_EQ(pub.failed(), inner.refused);
  EXPECT_EQ(loop.outputs_dropped(), inner.refused);
  ASSERT_GT(inner.refused_before_last_stats, 0);
  const int64_t reported = last_stats(inner.taken, cfg.stats_channel).outputs_dropped;
  EXPECT_LE(reported, inner.refused_before_last_stats);
  EXPECT_GE(reported, inner.refused_before_last_stats - 1);
}

// Estimate mode on arrival: `first` states a millisecond apart, `silence` ms without any (expiry,
// heartbeats), `second` states, each sent once the loop has computed the one before; every fifth does
// not close (its error output). No allocation, every state offered is taken and computed, and one
// output per tick.
namespace {
void run_on_arrival_without_allocation(bool busy_poll, int first, int silence, int second) {
  const System sys = load_scene(scene_path("two_puma_load"));
  runtime::ServiceConfig cfg;
  cfg.mode = runtime::ServiceMode::kEstimate;
  cfg.trigger = runtime::Trigger::kArrival;
  cfg.realtime.busy_poll = busy_poll;
  cfg.stats_period_s = 0.05;
  cfg.watchdog_ms = 20;
  FakeBus bus;
  runtime::ServiceLoop loop(sys, cfg, bus);
  const Eigen::VectorXd tau = some_torque(sys, 1, 0.5);
  Eigen::VectorXd q_far = sys.q0;
  q_far[0] += 0.3;
  std::atomic<bool> stop{false};
  std::atomic<long> allocations{-1};
  std::thread loop_thread([&] {
    AllocationCounter c;
    loop.run(stop);
    allocations = c.count();
  });
  int sent = 0;
  for (int k = 0; k < first + silence + second; ++k) {
    if (k < first || k >= first + silence) {
      const auto b = io::encode_measured_state(runtime::realtime_us(), k + 1, {}, stdvec(k % 5 == 4 ? q_far : sys.q0), {},
                                               stdvec(sys.v0), stdvec(tau));
      const int64_t before = loop.ticks();
      if (loop.states().offer(b.data(), static_cast<int>(b.size()), io::monotonic_ns()) == runtime::Offer::kAccepted) {
        loop.doorbell().ring();
        ++sent;
        // the next state only once the loop has computed this one (however long it waits for a CPU)
        const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
        while (loop.ticks() == before && std::chrono::steady_clock::now() < give_up)
          std::this_thread::sleep_for(std::chrono::microseconds(50));
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(60));
  stop = true;
  loop_thread.join();
  EXPECT_EQ(allocations.load(), 0);
  EXPECT_EQ(sent, first + second);
  EXPECT_GE(loop.expirations(), 1);
  EXPECT_GT(loop.closure_rejections(), 0);  // every fifth state does not close
  EXPECT_GE(bus.count("COOPDYN_STATS"), 4);
  EXPECT_GE(loop.ticks(), first + second);  // every state computed, plus the heartbeats of the silence
  EXPECT_EQ(bus.count("COOPDYN_OUTPUT"), loop.ticks());
  runtime::Event e;
  while (loop.events().pop(&e)) {
  }
}
}  // namespace

// The event-driven estimate path (trigger: arrival): run() waiting on the doorbell, a tick per
// state rung in (full states and states that do not close, in turn), the heartbeat ticks while the
// state has expired, and the stats by wall time, under the counting heap on the loop's thread. The
// states are offered and rung from another thread, as the receive thread does.
TEST(LoopNoAllocation, RunOnArrivalOfStates) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  run_on_arrival_without_allocation(false, 150, 150, 100);
}

// The event-driven path polling its doorbell (realtime.busy_poll) instead of sleeping on it: no
// allocation either; states rung in are computed (those that do not close give their error
// output), the heartbeats go on while the state has expired, and run() returns on stop.
TEST(LoopNoAllocation, RunOnArrivalBusyPolling) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  run_on_arrival_without_allocation(true, 100, 100, 100);
}

namespace {
// The daemon's hand-off on arrival (service/daemon/receive.h RingArrivals): the loop drains the receive
// process's ring itself, woken by the bell the process rings.
struct RingSource : runtime::ArrivalSource {
  io::IsolatedReceiver& rx;
  runtime::ServiceLoop& loop;
  RingSource(io::IsolatedReceiver& r, runtime::ServiceLoop& l) : rx(r), loop(l) {}
  uint32_t bell() const override { return rx.bell(); }
  void wait(uint32_t seen, long long deadline_ns) override { rx.wait_bell(seen, deadline_ns); }
  void drain() override {
    rx.drain([this](const void* d, int n, long long t) {
      if (io::identify(d, n) == io::MessageType::kControl) loop.controls().offer(d, n, t);
      else loop.states().offer(d, n, t);
    });
  }
};

// States sent over udpm to a real receive process (coopdynd --rx-child) whose ring the loop drains
// on its own thread, decoding each state there (the allocation-free decoder): full states,
// joints-only states (names of other lengths), states with an unknown 300-byte name, controls,
// under the counting heap on the loop's thread, sleeping on the bell or polling it.
void run_on_arrival_from_the_ring_without_allocation(bool busy_poll) {
  const System sys = load_scene(scene_path("two_puma_load"));
  runtime::ServiceConfig cfg;
  cfg.mode = runtime::ServiceMode::kEstimate;
  cfg.trigger = runtime::Trigger::kArrival;
  cfg.realtime.busy_poll = busy_poll;
  cfg.stats_period_s = 0.05;
  cfg.watchdog_ms = 20;
  const std::string url = private_udpm_url(busy_poll ? 7 : 8);
  std::unique_ptr<io::LcmBus> out = try_bus(url);
  if (!out) GTEST_SKIP() << "LCM udpm unavailable (no multicast route?)";
  FakeBus bus;
  runtime::ServiceLoop loop(sys, cfg, bus);
  io::IsolatedReceiver rx(COOPDYND_PATH, url, {cfg.state_channel, cfg.control_channel},
                          {io::fingerprint(io::MessageType::kMeasuredState), io::fingerprint(io::MessageType::kControl)}, 64, 65536);
  rx.drain_in_caller();
  long handed_to_the_thread = 0;
  rx.start([&](const void*, int, long long) { ++handed_to_the_thread; }, [](int, long long) {});
  ASSERT_TRUE(coopdyn::testing::wait_until([&] { return rx.children_ready() > 0; })) << "the receive process never subscribed";
  RingSource source(rx, loop);
  loop.take_arrivals_from(&source);
  const StateFitPlan plan = plan_state_fit(sys);
  std::vector<std::string> jq, jv, hostile = sys.model.q_names;
  std::vector<double> qj, vj;
  for (int i = 0; i < sys.model.nq(); ++i)
    if (std::find(plan.fit_q.begin(), plan.fit_q.end(), i) == plan.fit_q.end()) jq.push_back(sys.model.q_names[i]), qj.push_back(sys.q0[i]);
  for (int i = 0; i < sys.model.nv(); ++i)
    if (std::find(plan.fit_v.begin(), plan.fit_v.end(), i) == plan.fit_v.end()) jv.push_back(sys.model.v_names[i]), vj.push_back(0.0);
  hostile[0] = std::string(300, 'z');
  std::atomic<bool> stop{false};
  std::atomic<long> allocations{-1};
  std::thread loop_thread([&] {
    AllocationCounter c;
    loop.run(stop);
    allocations = c.count();
  });
  int valid = 0;
  for (int k = 1; k <= 300; ++k) {
    std::vector<uint8_t> b;
    if (k % 4 == 1) b = io::encode_measured_state(runtime::realtime_us(), k, jq, qj, jv, vj, vj);
    else if (k % 4 == 2) b = io::encode_measured_state(runtime::realtime_us(), k, hostile, stdvec(sys.q0), {}, stdvec(sys.v0), stdvec(sys.v0));
    else if (k % 4 == 3) b = io::encode_control(runtime::realtime_us(), k, io::ControlAction::kClearFault);
    else b = io::encode_measured_state(runtime::realtime_us(), k, {}, stdvec(sys.q0), {}, stdvec(sys.v0), stdvec(sys.v0));
    valid += k % 4 == 1 || k % 4 == 0;
    out->publish(k % 4 == 3 ? cfg.control_channel.c_str() : cfg.state_channel.c_str(), b.data(), static_cast<int>(b.size()));
    // the next one once the loop has taken this one (a loaded machine may hold either thread longer
    // than the ring's 64 slots last at a fixed pace)
    coopdyn::testing::wait_until([&] {
      return loop.states().counters().received.load() + loop.controls().counters().received.load() >= k;
    }, coopdyn::testing::kEventLimit, std::chrono::milliseconds(1));
  }
  stop = true;
  loop_thread.join();
  rx.stop();
  EXPECT_EQ(allocations.load(), 0);
  EXPECT_EQ(handed_to_the_thread, 0);  // the receive thread only supervised
  const runtime::InputCounters& c = loop.states().counters();
  EXPECT_EQ(c.accepted.load(), valid) << "of " << c.received.load() << " received (udpm on loopback)";
  EXPECT_EQ(c.by_reason[static_cast<int>(io::Reject::kUnknownName)].load(), 75);
  EXPECT_EQ(loop.controls().counters().received.load(), 75);
  EXPECT_EQ(bus.count("COOPDYN_OUTPUT"), loop.ticks());
  runtime::Event e;
  while (loop.events().pop(&e)) {
  }
}
}  // namespace

TEST(LoopNoAllocation, RunOnArrivalDrainingTheReceiveProcessRing) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  run_on_arrival_from_the_ring_without_allocation(false);
}

TEST(LoopNoAllocation, RunOnArrivalPollingTheReceiveProcessRing) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  run_on_arrival_from_the_ring_without_allocation(true);
}

// The loop publishes from its own thread with lcm_publish over udpm: that path must not allocate
// either (LCM 1.3: one sendmsg per datagram; larger messages are fragmented in place).
TEST(LoopNoAllocation, UdpmPublishOfEncodedBytes) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  std::unique_ptr<io::LcmBus> bus;
  try {
    bus = std::make_unique<io::LcmBus>(daemon_test::private_udpm_url(0));
  } catch (const std::exception&) {
    GTEST_SKIP() << "LCM udpm unavailable (no multicast route?)";
  }
  std::vector<uint8_t> small(1500, 1), large(100000, 2);  // one datagram, and a fragmented one
  bus->publish("COOPDYN_WARMUP", small.data(), static_cast<int>(small.size()));
  bus->publish("COOPDYN_WARMUP", large.data(), static_cast<int>(large.size()));
  long allocations;
  {
    AllocationCounter c;
    for (int k = 0; k < 500; ++k) {
      bus->publish("COOPDYN_OUTPUT", small.data(), static_cast<int>(small.size()));
      if (k % 50 == 0) bus->publish("COOPDYN_OUTPUT", large.data(), static_cast<int>(large.size()));
    }
    allocations = c.count();
  }
  EXPECT_EQ(allocations, 0);
}
