// Joint limits on the wire: a real LCM round trip (memq://) through the running loop. Two iiwa arms
// (URDF speed limits 1.31-2.36 rad/s) are reset by a control_t to a state moving far faster; the
// output_t of that state carries LIMIT_VELOCITY on exactly the joints whose published |v| passes
// their v_limit, and loop_stats_t counts the ticks past a limit, by kind. (output_t LIMIT_* are
// joint_limits.h's bits: a static_assert in codec.cc.)
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <mutex>
#include <random>
#include <thread>
#include <vector>

#include "service/dynamics/joint_limits.h"
#include "service/io/transport/lcm_bus.h"
#include "service/runtime/service_loop.h"
#include "tests/support/daemon_test_util.h"
#include "tests/support/wait.h"

using namespace coopdyn;
using namespace coopdyn::daemon_test;

namespace {

struct Sink {
  std::mutex mu;
  std::vector<io::DecodedOutput> outs;
  io::StatsFrame stats;
  long stats_frames = 0;
};

}  // namespace

TEST(LimitsOnTheWire, MemqOutputCarriesTheBitsAndStatsCountTheTicks) {
  const System sys = load_scene(scene_path("two_iiwa_load"));
  runtime::ServiceConfig cfg;
  cfg.stats_period_s = 0.05;
  io::LcmBus bus("memq://");
  runtime::ServiceLoop loop(sys, cfg, bus);
  bus.subscribe(cfg.control_channel, [&](const void* d, int n, long long t) { loop.controls().offer(d, n, t); });
  Sink sink;
  bus.subscribe(cfg.output_channel, [&](const void* d, int n, long long) {
    io::DecodedOutput o;
    if (!io::decode_output(d, n, &o)) return;
    std::lock_guard<std::mutex> lk(sink.mu);
    sink.outs.push_back(std::move(o));
  });
  bus.subscribe(cfg.stats_channel, [&](const void* d, int n, long long) {
    io::StatsFrame f;
    if (!io::decode_stats(d, n, &f)) return;
    std::lock_guard<std::mutex> lk(sink.mu);
    sink.stats = f;
    ++sink.stats_frames;
  });
  bus.start();
  std::atomic<bool> stop{false};
  std::thread th([&] { loop.run(stop); });

  // held still by the safe torque first: no limit passed (outputs say 0, not unknown)
  const bool held = coopdyn::testing::wait_until([&] {
    std::lock_guard<std::mutex> lk(sink.mu);
    return sink.outs.size() >= 5 && sink.stats_frames > 0;
  });
  // q0 with a closing velocity of up to 10 rad/s per joint
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  Eigen::VectorXd v(sys.model.nv());
  for (Eigen::Index i = 0; i < v.size(); ++i) v[i] = u(rng);
  v = closing_velocity(sys, sys.q0, v);
  const auto b = io::encode_control(io::wall_us(), 1, io::ControlAction::kResetToState, stdvec(sys.q0), stdvec(v));
  bus.publish(cfg.control_channel.c_str(), b.data(), static_cast<int>(b.size()));
  // the output of the reset state, then a loop_stats_t published after it
  int64_t reset_tick = -1;
  const bool got = coopdyn::testing::wait_until([&] {
    std::lock_guard<std::mutex> lk(sink.mu);
    for (const auto& o : sink.outs)
      if (reset_tick < 0 && o.control_seq == 1 && o.control_result == static_cast<int>(io::ControlResult::kOk))
        reset_tick = o.tick;
    return reset_tick >= 0 && sink.stats_frames > 0 && sink.stats.tick > reset_tick;
  });
  stop = true;
  th.join();
  bus.stop();
  ASSERT_TRUE(held) << "no output or stats from the loop";
  ASSERT_TRUE(got) << "no output of the reset state, or no stats after it";

  std::lock_guard<std::mutex> lk(sink.mu);
  EXPECT_EQ(sink.outs.front().limits, 0);
  EXPECT_EQ(sink.outs.front().limit_mask, std::vector<int>(static_cast<size_t>(sys.model.nv()), 0));
  const io::DecodedOutput* first = nullptr;
  long past = 0, past_v = 0, past_q = 0, past_tau = 0;
  for (const auto& o : sink.outs) {
    if (o.tick == reset_tick) first = &o;
    if (o.tick >= sink.stats.tick) continue;
    past += o.limits != 0;
    past_q += (o.limits & kLimitPosition) != 0;
    past_v += (o.limits & kLimitVelocity) != 0;
    past_tau += (o.limits & kLimitEffort) != 0;
  }
  ASSERT_NE(first, nullptr);
  const io::DecodedOutput& o = *first;
  EXPECT_EQ(o.missing, 0u);
  EXPECT_EQ(o.status, static_cast<int>(Status::kOk)) << "limits are reported, never enforced";
  ASSERT_EQ(o.limit_mask.size(), static_cast<size_t>(sys.model.nv()));
  int any = 0, flagged = 0;
  for (int d = 0; d < sys.model.nv(); ++d) {
    const int bits = o.limit_mask[static_cast<size_t>(d)];
    any |= bits;
    // velocity: exactly the joints whose published speed passes their limit
    EXPECT_EQ((bits & kLimitVelocity) != 0, std::abs(o.v[d]) > sys.v_limit[d]) << o.v_names[d];
    EXPECT_EQ(bits & kLimitEffort, 0) << "the hold is clamped to tau_limit: " << o.v_names[d];
    flagged += (bits & kLimitVelocity) != 0;
  }
  EXPECT_GT(flagged, 0) << "a reset to up to 10 rad/s passes some speed limit";
  EXPECT_EQ(o.limits, any) << "limits is the union of limit_mask";
  // the stats count every tick past a limit; the outputs received before its tick are some of them
  const io::StatsFrame& s = sink.stats;
  EXPECT_EQ(s.missing, 0u);
  EXPECT_GE(s.limit_ticks[0], 1);
  EXPECT_GE(s.limit_ticks[0], past);
  EXPECT_GE(s.limit_ticks[2], past_v);
  EXPECT_GE(s.limit_ticks[2], 1);
  EXPECT_GE(s.limit_ticks[1], past_q);
  EXPECT_EQ(s.limit_ticks[3], 0);
  EXPECT_EQ(past_tau, 0);
  for (int k = 1; k < 4; ++k) EXPECT_LE(s.limit_ticks[k], s.limit_ticks[0]) << k;
  // and equal them when the bus dropped none
  if (s.outputs_dropped == 0) EXPECT_EQ(s.limit_ticks[0], past) << "ticks past a limit, stats and outputs";
  std::printf("%d joints past their speed limit at the reset; %lld ticks past a limit (velocity %lld) by tick %lld\n",
              flagged, static_cast<long long>(s.limit_ticks[0]), static_cast<long long>(s.limit_ticks[2]),
              static_cast<long long>(s.tick));
}
