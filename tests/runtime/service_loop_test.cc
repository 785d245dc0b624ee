// ServiceLoop driven tick by tick through an in-memory bus: outputs equal the offline evaluate()
// of the state they carry, the loop integrates like step(), the watchdog, rejected commands,
// sequence handling and numerical failures. Times are synthetic (tick(now) with chosen now).
#include <gtest/gtest.h>

#include <time.h>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <sstream>
#include <thread>

#include "service/dynamics/integrators.h"
#include "service/io/transport/lcm_bus.h"
#include "service/runtime/service_loop.h"
#include "tests/support/daemon_test_util.h"
#include "tests/support/wait.h"

using namespace coopdyn;
using namespace coopdyn::daemon_test;
using runtime::Offer;
using runtime::ServiceConfig;
using runtime::ServiceLoop;

namespace {
constexpr long long kMs = 1000000;

std::vector<uint8_t> command(int64_t seq, const Eigen::VectorXd& tau, const std::vector<std::string>& names = {}) {
  return io::encode_torque_command(runtime::realtime_us(), seq, names, stdvec(tau));  // a fresh utime
}

struct Rig {
  System sys;
  ServiceConfig cfg;
  FakeBus bus;
  std::unique_ptr<ServiceLoop> loop;
  explicit Rig(const std::string& scene, runtime::ServiceMode mode = runtime::ServiceMode::kSimulate) {
    sys = load_scene(scene_path(scene));
    cfg.mode = mode;
    loop = std::make_unique<ServiceLoop>(sys, cfg, bus);
  }
  void reset() { loop = std::make_unique<ServiceLoop>(sys, cfg, bus); }
  Offer send(const std::vector<uint8_t>& b, long long t, io::Reject* why = nullptr) {
    return loop->commands().offer(b.data(), static_cast<int>(b.size()), t, why);
  }
};
}  // namespace

// Commands in, wrenches out: every scene, each output equal to the offline evaluation of the state
// it carries, and the state advancing exactly like step() under the commanded torque.
TEST(ServiceLoop, SimulateOutputsEqualOfflineEvaluateAndStep) {
  const auto scenes = loadable_scenes();
  ASSERT_FALSE(scenes.empty());
  for (const auto& name : scenes) {
    SCOPED_TRACE(name);
    Rig r(name);
    const Eigen::VectorXd tau = some_torque(r.sys, 3);
    ASSERT_EQ(r.send(command(1, tau), 0), Offer::kAccepted);
    Stepper ref(r.sys);
    Eigen::VectorXd q = r.sys.q0, v = r.sys.v0;
    for (int k = 0; k < 20; ++k) {
      r.loop->tick(k * kMs);
      const io::DecodedOutput o = r.bus.last_output();
      EXPECT_EQ(o.tick, k);
      EXPECT_EQ(o.input, static_cast<int>(io::Input::kCommand));
      EXPECT_EQ(o.input_seq, 1);
      EXPECT_NEAR(o.sim_time, k * 1e-3, 1e-12);
      for (int i = 0; i < tau.size(); ++i) ASSERT_EQ(o.tau[i], tau[i]);
      for (int i = 0; i < q.size(); ++i) ASSERT_NEAR(o.q[i], q[i], 1e-12) << "q[" << i << "] at tick " << k;
      expect_matches_offline(r.sys, o);
      step(r.sys, ref, r.cfg.integrator, 1e-3, tau, q, v);
    }
    EXPECT_EQ(r.bus.count("COOPDYN_OUTPUT"), 20);
  }
}

// Named partial commands: the named DOFs get their torque, the others the safe torque (policy zero
// here: 0; the hold: tests/runtime/safe_torque_test.cc).
TEST(ServiceLoop, NamedCommandMapsByName) {
  Rig r("two_puma_load");
  r.cfg.safe_torque = runtime::SafeTorque::kZero;
  r.reset();
  const auto& names = r.sys.model.v_names;
  const int a = 7, b = 15;
  ASSERT_EQ(r.send(io::encode_torque_command(runtime::realtime_us(), 1, {names[b], names[a]}, {-3.0, 2.0}), 0), Offer::kAccepted);
  r.loop->tick(0);
  const io::DecodedOutput o = r.bus.last_output();
  for (int i = 0; i < r.sys.model.nv(); ++i) EXPECT_EQ(o.tau[i], i == a ? 2.0 : i == b ? -3.0 : 0.0) << names[i];
}

TEST(ServiceLoop, EstimateOutputsEqualOfflineEvaluate) {
  for (const auto& name : loadable_scenes()) {
    SCOPED_TRACE(name);
    Rig r(name, runtime::ServiceMode::kEstimate);
    r.loop->tick(0);
    io::DecodedOutput o = r.bus.last_output();
    EXPECT_EQ(o.input, static_cast<int>(io::Input::kNoState));
    EXPECT_EQ(o.status, static_cast<int>(Status::kError));
    EXPECT_EQ(o.reason, io::kReasonNoState);
    // a measured state with names in reverse order, a velocity, and measured torques
    const System& s = r.sys;
    std::mt19937 rng(11);
    std::normal_distribution<double> n01(0, 0.3);
    Eigen::VectorXd v = s.v0;
    for (int i = 0; i < v.size(); ++i) v[i] += n01(rng);
    v = closing_velocity(s, s.q0, v);
    const Eigen::VectorXd tau = some_torque(s, 5);
    std::vector<std::string> qn(s.model.q_names.rbegin(), s.model.q_names.rend());
    std::vector<std::string> vn(s.model.v_names.rbegin(), s.model.v_names.rend());
    std::vector<double> qr(s.q0.data(), s.q0.data() + s.q0.size()), vr = stdvec(v), tr = stdvec(tau);
    std::reverse(qr.begin(), qr.end());
    std::reverse(vr.begin(), vr.end());
    std::reverse(tr.begin(), tr.end());
    const auto msg = io::encode_measured_state(runtime::realtime_us(), 1, qn, qr, vn, vr, tr);
    ASSERT_EQ(r.loop->states().offer(msg.data(), static_cast<int>(msg.size()), 1 * kMs), Offer::kAccepted);
    r.loop->tick(2 * kMs);
    o = r.bus.last_output();
    EXPECT_EQ(o.input, static_cast<int>(io::Input::kState));
    EXPECT_EQ(o.input_seq, 1);
    for (int i = 0; i < v.size(); ++i) {
      EXPECT_EQ(o.v[i], v[i]);
      EXPECT_EQ(o.tau[i], tau[i]);
    }
    expect_matches_offline(s, o);
    // no integration in estimate mode: the same state gives the same output next tick
    r.loop->tick(3 * kMs);
    const io::DecodedOutput o2 = r.bus.last_output();
    EXPECT_EQ(o2.q, o.q);
    EXPECT_EQ(o2.wrench, o.wrench);
    // stale after the watchdog
    r.loop->tick(1 * kMs + r.cfg.watchdog_ns() + kMs);
    const io::DecodedOutput o3 = r.bus.last_output();
    EXPECT_EQ(o3.input, static_cast<int>(io::Input::kStateExpired));
    EXPECT_EQ(o3.status, static_cast<int>(Status::kError));
    EXPECT_EQ(o3.reason, io::kReasonStateStale);
    for (const auto& w : o3.wrench)
      for (double x : w) EXPECT_EQ(x, 0.0);
    EXPECT_EQ(r.loop->expirations(), 1);
  }
}

TEST(ServiceLoop, WatchdogAppliesSafeTorqueAndSaysSo) {
  Rig r("two_puma_load");
  r.cfg.safe_torque = runtime::SafeTorque::kZero;  // the policy `zero`: every safe torque is 0
  r.reset();
  const long long wd = r.cfg.watchdog_ns();
  r.loop->tick(0);
  io::DecodedOutput o = r.bus.last_output();
  EXPECT_EQ(o.input, static_cast<int>(io::Input::kNoCommand));
  EXPECT_EQ(o.input_seq, -1);
  for (double x : o.tau) EXPECT_EQ(x, 0.0);

  const Eigen::VectorXd tau = some_torque(r.sys, 1);
  r.send(command(1, tau), 10 * kMs);
  r.loop->tick(10 * kMs + wd);  // exactly at the watchdog: still fresh
  o = r.bus.last_output();
  EXPECT_EQ(o.input, static_cast<int>(io::Input::kCommand));
  EXPECT_EQ(o.tau[6], tau[6]);
  r.loop->tick(10 * kMs + wd + 1);  // 1 ns later: expired
  o = r.bus.last_output();
  EXPECT_EQ(o.input, static_cast<int>(io::Input::kCommandExpired));
  EXPECT_EQ(o.input_seq, 1);
  for (double x : o.tau) EXPECT_EQ(x, 0.0);
  EXPECT_EQ(r.loop->expirations(), 1);
  r.loop->tick(10 * kMs + 2 * wd);
  EXPECT_EQ(r.loop->expirations(), 1) << "one expiry, counted once";
  runtime::Event e;
  bool saw = false;
  while (r.loop->events().pop(&e)) saw = saw || e.code == runtime::EventCode::kCommandExpired;
  EXPECT_TRUE(saw);
  // a new command resumes
  r.send(command(2, tau), 10 * kMs + 2 * wd);
  r.loop->tick(10 * kMs + 2 * wd + kMs);
  o = r.bus.last_output();
  EXPECT_EQ(o.input, static_cast<int>(io::Input::kCommand));
  EXPECT_EQ(o.tau[6], tau[6]);
}

TEST(ServiceLoop, DampingSafeTorqueOnActuatedJointsOnly) {
  Rig r("two_puma_load");
  r.cfg.safe_torque = runtime::SafeTorque::kDamping;
  r.cfg.damping = 4.0;
  for (int i = 6; i < r.sys.model.nv(); ++i) r.sys.tau_limit[i] = 0.5;  // arm joints actuated, platform not
  r.reset();
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(r.sys.model.nv());
  for (int k = 0; k < 30; ++k) r.loop->tick(k * kMs);  // the arms fall under gravity: v != 0
  const Eigen::VectorXd v = r.loop->v();
  r.loop->tick(30 * kMs);
  const io::DecodedOutput o = r.bus.last_output();
  EXPECT_EQ(o.input, static_cast<int>(io::Input::kNoCommand));
  for (int i = 0; i < r.sys.model.nv(); ++i) {
    const double expect = i < 6 ? 0.0 : std::max(-0.5, std::min(0.5, -4.0 * v[i]));
    EXPECT_NEAR(o.tau[i], expect, 1e-15) << r.sys.model.v_names[i];
  }
}

TEST(ServiceLoop, MalformedCommandsAreRejectedCountedNeverApplied) {
  Rig r("two_puma_load");
  const int nv = r.sys.model.nv();
  r.sys.tau_limit[8] = 10.0;
  r.reset();
  const Eigen::VectorXd good = some_torque(r.sys, 2);
  ASSERT_EQ(r.send(command(1, good), 0), Offer::kAccepted);
  const auto& names = r.sys.model.v_names;
  Eigen::VectorXd nan = good, inf = good, big = good;
  nan[3] = std::nan("");
  inf[4] = -std::numeric_limits<double>::infinity();
  big[8] = 10.5;
  std::vector<uint8_t> valid = command(9, good);
  std::vector<uint8_t> truncated(valid.begin(), valid.end() - 5);
  std::vector<uint8_t> garbage(64, 0xAB);
  // a valid header whose names count claims 2^30 entries
  std::vector<uint8_t> hostile(valid.begin(), valid.begin() + 24);
  for (uint8_t b : {0x40, 0x00, 0x00, 0x00}) hostile.push_back(b);
  // one name of length 0 (LCM lengths count the NUL, so 0 is invalid)
  std::vector<uint8_t> zero_len(valid.begin(), valid.begin() + 24);
  for (uint8_t b : {0, 0, 0, 1, 0, 0, 0, 0}) zero_len.push_back(b);

  const std::vector<std::pair<std::vector<uint8_t>, io::Reject>> cases = {
      {io::encode_torque_command(0, 2, {}, std::vector<double>(nv - 1, 0.0)), io::Reject::kCount},
      {io::encode_torque_command(0, 3, {names[0], names[1]}, {1.0}), io::Reject::kCount},
      {io::encode_torque_command(0, 4, {"no_such_joint"}, {1.0}), io::Reject::kUnknownName},
      {io::encode_torque_command(0, 5, {names[7], names[7]}, {1.0, 2.0}), io::Reject::kDuplicateName},
      {command(6, nan), io::Reject::kNonFinite},
      {command(7, inf), io::Reject::kNonFinite},
      {command(8, big), io::Reject::kOverLimit},
      {truncated, io::Reject::kDecode},
      {garbage, io::Reject::kDecode},
      {hostile, io::Reject::kDecode},
      {zero_len, io::Reject::kDecode},
      {io::encode_measured_state(0, 10, {}, {}, {}, {}, {}), io::Reject::kDecode},  // another type
  };
  int n = 0;
  for (const auto& [bytes, reason] : cases) {
    SCOPED_TRACE(n);
    io::Reject why = io::Reject::kNone;
    EXPECT_EQ(r.send(bytes, kMs, &why), Offer::kRejected);
    EXPECT_EQ(why, reason) << io::reject_name(why);
    ++n;
    r.loop->tick(2 * kMs);
    const io::DecodedOutput o = r.bus.last_output();
    EXPECT_EQ(o.input_seq, 1) << "the last good command stays in force";
    for (int i = 0; i < nv; ++i) ASSERT_EQ(o.tau[i], good[i]);
  }
  const auto& c = r.loop->input_counters();
  EXPECT_EQ(c.rejected.load(), n);
  EXPECT_EQ(c.accepted.load(), 1);
  EXPECT_EQ(c.by_reason[static_cast<int>(io::Reject::kNonFinite)].load(), 2);
  // exactly at the limit is allowed
  big[8] = 10.0;
  EXPECT_EQ(r.send(command(20, big), 3 * kMs), Offer::kAccepted);
}

TEST(ServiceLoop, SequenceNumbersOutOfOrderDroppedResyncAfterExpiry) {
  Rig r("two_puma_load");
  const long long wd = r.cfg.watchdog_ns();
  Eigen::VectorXd t5 = some_torque(r.sys, 5), t3 = some_torque(r.sys, 3), t6 = some_torque(r.sys, 6);
  EXPECT_EQ(r.send(command(5, t5), 0), Offer::kAccepted);
  EXPECT_EQ(r.send(command(3, t3), kMs), Offer::kOutOfOrder);
  EXPECT_EQ(r.send(command(5, t3), kMs), Offer::kOutOfOrder);
  r.loop->tick(2 * kMs);
  io::DecodedOutput o = r.bus.last_output();
  EXPECT_EQ(o.input_seq, 5);
  EXPECT_EQ(o.tau[9], t5[9]);
  EXPECT_EQ(r.send(command(6, t6), 3 * kMs), Offer::kAccepted);
  r.loop->tick(4 * kMs);
  EXPECT_EQ(r.bus.last_output().input_seq, 6);
  // two commands between ticks: the newest wins
  EXPECT_EQ(r.send(command(7, t3), 5 * kMs), Offer::kAccepted);
  EXPECT_EQ(r.send(command(8, t5), 5 * kMs), Offer::kAccepted);
  r.loop->tick(6 * kMs);
  EXPECT_EQ(r.bus.last_output().input_seq, 8);
  // a restarted sender (seq 1) is followed once the loop has declared the last command expired:
  // past the watchdog but before a tick saw it, the restart is still out of order (no expiry
  // counted, so none may let a lower seq through)
  EXPECT_EQ(r.send(command(1, t3), 5 * kMs + wd), Offer::kOutOfOrder);
  EXPECT_EQ(r.send(command(1, t3), 5 * kMs + wd + 1), Offer::kOutOfOrder);
  EXPECT_EQ(r.loop->expirations(), 0);
  r.loop->tick(5 * kMs + wd + 2);  // expired: counted, safe torque
  EXPECT_EQ(r.loop->expirations(), 1);
  EXPECT_EQ(r.bus.last_output().input, static_cast<int>(io::Input::kCommandExpired));
  EXPECT_EQ(r.send(command(1, t3), 5 * kMs + wd + 3), Offer::kAccepted);
  r.loop->tick(5 * kMs + wd + 4);
  o = r.bus.last_output();
  EXPECT_EQ(o.input_seq, 1);
  EXPECT_EQ(o.input, static_cast<int>(io::Input::kCommand));
  // one expiry lets one restart through: the next lower seq is out of order again
  EXPECT_EQ(r.send(command(0, t3), 5 * kMs + 3 * wd), Offer::kOutOfOrder);
  EXPECT_EQ(r.loop->input_counters().out_of_order.load(), 5);
}

// A singular mass matrix (every body massless, no armature): error status with the core's reason,
// no NaN anywhere, the state frozen, latched on later ticks.
TEST(ServiceLoop, NumericalFailureLatchesSafeErrorState) {
  Rig r("two_puma_load");
  for (auto& b : r.sys.model.bodies) {
    b.inertia = Inertia();
    b.joint.armature = 0;
  }
  r.reset();
  for (int k = 0; k < 3; ++k) {
    r.loop->tick(k * kMs);
    const io::DecodedOutput o = r.bus.last_output();
    EXPECT_EQ(o.status, static_cast<int>(Status::kError));
    EXPECT_EQ(o.reason, static_cast<int>(Reason::kMassMatrixSingular));
    for (const auto& w : o.wrench)
      for (double x : w) EXPECT_EQ(x, 0.0);
    for (double x : o.vdot) EXPECT_EQ(x, 0.0);
    for (int i = 0; i < r.sys.model.nq(); ++i) EXPECT_EQ(o.q[i], r.sys.q0[i]);
  }
  EXPECT_TRUE(r.loop->faulted());
  EXPECT_EQ(r.loop->numerical_errors(), 1);
}

// Estimate mode: a measured state that evaluate() refuses (a non-unit platform quaternion) gives
// an error status and zeros, and the next good state is evaluated again (no latch).
TEST(ServiceLoop, EstimateBadStateIsAnErrorForThatStateOnly) {
  Rig r("two_puma_load", runtime::ServiceMode::kEstimate);
  std::vector<double> q = stdvec(r.sys.q0);
  q[3] = 2.0;  // quaternion w of the floating load
  auto bad = io::encode_measured_state(runtime::realtime_us(), 1, {}, q, {}, stdvec(r.sys.v0), std::vector<double>(r.sys.model.nv(), 0.0));
  ASSERT_EQ(r.loop->states().offer(bad.data(), static_cast<int>(bad.size()), 0), Offer::kAccepted);
  r.loop->tick(kMs);
  io::DecodedOutput o = r.bus.last_output();
  EXPECT_EQ(o.status, static_cast<int>(Status::kError));
  EXPECT_EQ(o.reason, static_cast<int>(Reason::kNonFiniteInput));
  for (double x : o.vdot) EXPECT_EQ(x, 0.0);
  auto good = io::encode_measured_state(runtime::realtime_us(), 2, {}, stdvec(r.sys.q0), {}, stdvec(r.sys.v0),
                                        std::vector<double>(r.sys.model.nv(), 0.0));
  ASSERT_EQ(r.loop->states().offer(good.data(), static_cast<int>(good.size()), 2 * kMs), Offer::kAccepted);
  r.loop->tick(3 * kMs);
  o = r.bus.last_output();
  EXPECT_NE(o.status, static_cast<int>(Status::kError));
  expect_matches_offline(r.sys, o);
}

TEST(ServiceLoop, StatsPublishedEveryPeriodWithCounters) {
  Rig r("two_puma_load");
  r.cfg.stats_period_s = 0.01;  // every 10 ticks at 1 kHz
  r.reset();
  r.send(command(1, some_torque(r.sys, 1)), 0);
  r.send(io::encode_torque_command(0, 2, {"nope"}, {1.0}), 0);
  for (int k = 0; k < 35; ++k) {
    r.loop->tick(k * kMs);
    r.loop->record_timing(1000 * (k % 5), 20000);
  }
  EXPECT_EQ(r.bus.count("COOPDYN_STATS"), 3);
  const auto* s = r.bus.find("COOPDYN_STATS");
  io::StatsFrame f;
  ASSERT_TRUE(io::decode_stats(s->data.data(), s->len, &f));
  EXPECT_EQ(f.tick, 30);
  EXPECT_EQ(f.window_ticks, 10);
  EXPECT_EQ(f.received, 2);
  EXPECT_EQ(f.accepted, 1);
  EXPECT_EQ(f.rejected, 1);
  EXPECT_DOUBLE_EQ(f.period_us, 1000.0);
  // the 30th tick's timing is recorded after it publishes: the window holds ticks 19..28
  EXPECT_NEAR(f.lateness_us[3], 4.0, 0.07);
  EXPECT_NEAR(f.compute_us[0], 20.0, 20.0 / 64);
}

// The overrun policy, with a bus that stalls one publish for 3.5 ms (lower bounds only: a slower
// machine can only add overruns, never remove the ones the stall forces).
namespace {
struct StallingBus : FakeBus {
  long n = 0, stall_at = 0;
  int publish(const char* ch, const void* d, int len) override {
    if (++n == stall_at) {
      timespec ts{0, 3500000};
      nanosleep(&ts, nullptr);
    }
    return FakeBus::publish(ch, d, len);
  }
};
}  // namespace

TEST(ServiceLoop, OverrunPolicySkipDropsPeriodsCatchUpRunsThem) {
  const System sys = load_scene(scene_path("four_bar"));
  for (auto policy : {runtime::OverrunPolicy::kSkip, runtime::OverrunPolicy::kCatchUp}) {
    ServiceConfig cfg;
    cfg.overrun = policy;
    cfg.max_catch_up = 1000;
    StallingBus bus;
    bus.stall_at = 10;
    ServiceLoop loop(sys, cfg, bus);
    std::atomic<bool> stop{false};
    loop.run(stop, 30);
    EXPECT_EQ(loop.ticks(), 30);
    EXPECT_GE(loop.overruns(), 1);
    EXPECT_GE(loop.totals().lateness_us[3], 0.0);
    if (policy == runtime::OverrunPolicy::kSkip) {
      EXPECT_GE(loop.skipped_periods(), 3) << "the stall passed at least 3 deadlines";
    } else {
      EXPECT_EQ(loop.skipped_periods(), 0) << "catch-up runs the missed ticks";
      EXPECT_GE(loop.totals().lateness_us[3], 2500.0) << "the caught-up ticks are late";
    }
    runtime::Event e;
    bool saw = false;
    while (loop.events().pop(&e)) saw = saw || e.code == runtime::EventCode::kOverrun;
    EXPECT_TRUE(saw);
  }
}

// A stop request ends run() within one sleep slice (10 ms) even at the lowest rate (1 Hz): every
// sleep of run() ends at most one slice after it began, so the loop looks at its stop flag at least
// once per slice, never only at the next deadline (1 s here). The slice is a property of the sleep
// plan, checked exactly; then run() at 1 Hz, stopped while it sleeps toward its first deadline,
// returns (the time it took is printed, not judged: a loaded machine may delay any thread).
TEST(ServiceLoop, StopEndsRunWithinASliceAtTheLowestRate) {
  constexpr long long kSlice = ServiceLoop::kStopSliceNs, kSecond = 1000000000LL;
  // toward a deadline 1 s away (1 Hz): slices of 10 ms, then the deadline itself
  long long now = 5 * kSecond;
  const long long deadline = now + kSecond;
  int sleeps = 0;
  while (now < deadline) {
    const long long end = ServiceLoop::sleep_end_ns(now, deadline);
    ASSERT_GT(end, now);
    ASSERT_LE(end - now, kSlice) << "a sleep longer than a slice at sleep " << sleeps;
    ASSERT_LE(end, deadline) << "a sleep past the deadline";
    now = end;
    ++sleeps;
  }
  EXPECT_EQ(now, deadline);
  EXPECT_EQ(sleeps, kSecond / kSlice);
  // at 1 kHz a period is shorter than a slice: one sleep, to the deadline
  EXPECT_EQ(ServiceLoop::sleep_end_ns(now, now + 1000000), now + 1000000);
  // a deadline already passed: no sleep beyond it
  EXPECT_EQ(ServiceLoop::sleep_end_ns(now, now - 5), now - 5);

  const System sys = load_scene(scene_path("four_bar"));
  ServiceConfig cfg;
  cfg.rate_hz = runtime::kMinRateHz;
  cfg.stats_period_s = 1.0;
  runtime::validate(cfg);
  FakeBus bus;
  ServiceLoop loop(sys, cfg, bus);
  std::atomic<bool> stop{false};
  std::chrono::steady_clock::time_point stopped_at, returned_at;
  std::thread th([&] {
    loop.run(stop);
    returned_at = std::chrono::steady_clock::now();
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  stopped_at = std::chrono::steady_clock::now();
  stop = true;
  th.join();
  const double ms = std::chrono::duration<double, std::milli>(returned_at - stopped_at).count();
  std::printf("run() returned %.2f ms after the stop request at 1 Hz\n", ms);
}

// Freshness by the sender's clock. With max_input_age_ms (default 1000) a
// command or state with utime <= 0, older than the limit or ahead of this host's wall clock by more
// than the limit is rejected and counted by reason, on the receive thread where it is decided.
namespace {
int64_t g_fake_wall_us = 0;
int64_t fake_wall_us() { return g_fake_wall_us; }
}  // namespace

TEST(ServiceLoop, StaleOrFutureUtimeRejectedAndCountedByReason) {
  Rig r("two_puma_load");
  EXPECT_EQ(r.cfg.max_input_age_ms, 1000.0);
  r.loop->commands().set_wall_clock(&fake_wall_us);
  g_fake_wall_us = 1'800'000'000'000'000;  // 2027, in us since the epoch
  const Eigen::VectorXd tau = some_torque(r.sys, 4);
  const long long max_us = r.cfg.max_input_age_us();
  ASSERT_EQ(max_us, 1000000);
  auto at = [&](int64_t utime, int64_t seq) { return io::encode_torque_command(utime, seq, {}, stdvec(tau)); };
  struct Case {
    int64_t utime;
    io::Reject why;
  };
  const std::vector<Case> cases = {
      {0, io::Reject::kStale},                              // never stamped
      {-1, io::Reject::kStale},                             // LCM's "none"
      {std::numeric_limits<int64_t>::min(), io::Reject::kStale},
      {g_fake_wall_us - 10'000'000, io::Reject::kStale},    // 10 s old
      {g_fake_wall_us - max_us - 1, io::Reject::kStale},    // 1 us past the limit
      {g_fake_wall_us + max_us + 1, io::Reject::kFuture},   // 1 us too far ahead
      {std::numeric_limits<int64_t>::max(), io::Reject::kFuture},
  };
  int64_t seq = 1;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.utime);
    io::Reject why = io::Reject::kNone;
    EXPECT_EQ(r.send(at(c.utime, seq++), kMs, &why), Offer::kRejected);
    EXPECT_EQ(why, c.why) << io::reject_name(why);
  }
  r.loop->tick(2 * kMs);
  EXPECT_EQ(r.bus.last_output().input, static_cast<int>(io::Input::kNoCommand)) << "none was applied";
  const auto& n = r.loop->input_counters();
  EXPECT_EQ(n.rejected.load(), 7);
  EXPECT_EQ(n.by_reason[static_cast<int>(io::Reject::kStale)].load(), 5);
  EXPECT_EQ(n.by_reason[static_cast<int>(io::Reject::kFuture)].load(), 2);
  // exactly at the limit, either way, is fresh
  EXPECT_EQ(r.send(at(g_fake_wall_us - max_us, seq++), 3 * kMs), Offer::kAccepted);
  EXPECT_EQ(r.send(at(g_fake_wall_us + max_us, seq++), 3 * kMs), Offer::kAccepted);
  r.loop->tick(4 * kMs);
  EXPECT_EQ(r.bus.last_output().input, static_cast<int>(io::Input::kCommand));
  EXPECT_EQ(r.bus.last_output().input_seq, seq - 1);
  // off: any utime is taken (a sender without a wall clock)
  r.cfg.max_input_age_ms = 0;
  r.reset();
  EXPECT_EQ(r.send(at(0, 1), 0), Offer::kAccepted);
  // estimate mode: the same rule for measured states
  Rig e("two_puma_load", runtime::ServiceMode::kEstimate);
  e.loop->states().set_wall_clock(&fake_wall_us);
  const auto st = io::encode_measured_state(g_fake_wall_us - 10'000'000, 1, {}, stdvec(e.sys.q0), {}, stdvec(e.sys.v0),
                                            stdvec(tau));
  io::Reject why = io::Reject::kNone;
  EXPECT_EQ(e.loop->states().offer(st.data(), static_cast<int>(st.size()), 0, &why), Offer::kRejected);
  EXPECT_EQ(why, io::Reject::kStale);
  e.loop->tick(kMs);
  EXPECT_EQ(e.bus.last_output().reason, io::kReasonNoState);
}

// Each valid command of a sender numbering 1, 2, 3, ... that is not applied is counted once, where
// it went: one that never arrived as a seq gap (commands_missed), one that arrived too late or too
// early as a rejection for its utime (stale_utime, future_utime), not as a gap too.
TEST(ServiceLoop, EveryCommandNotAppliedIsCountedOnceAsMissedOrByItsUtime) {
  Rig r("two_puma_load");
  r.loop->commands().set_wall_clock(&fake_wall_us);
  g_fake_wall_us = 1'800'000'000'000'000;
  const Eigen::VectorXd tau = some_torque(r.sys, 8);
  auto at = [&](int64_t utime, int64_t seq) { return io::encode_torque_command(utime, seq, {}, stdvec(tau)); };
  const int64_t fresh = g_fake_wall_us, late = g_fake_wall_us - 2'000'000, early = g_fake_wall_us + 2'000'000;
  // seqs 1..10 sent; 2, 6 and 9 lost on the way, 3 and 4 late, 7 early, 10 late and the last
  EXPECT_EQ(r.send(at(fresh, 1), 0), Offer::kAccepted);
  EXPECT_EQ(r.send(at(late, 3), kMs), Offer::kRejected);
  EXPECT_EQ(r.send(at(late, 4), kMs), Offer::kRejected);
  EXPECT_EQ(r.send(at(fresh, 5), kMs), Offer::kAccepted);
  EXPECT_EQ(r.send(at(early, 7), kMs), Offer::kRejected);
  EXPECT_EQ(r.send(at(fresh, 8), kMs), Offer::kAccepted);
  EXPECT_EQ(r.send(at(late, 10), kMs), Offer::kRejected);
  const auto& n = r.loop->input_counters();
  EXPECT_EQ(n.missed.load(), 3) << "seqs 2, 6 and 9";
  EXPECT_EQ(n.by_reason[static_cast<int>(io::Reject::kStale)].load(), 3) << "seqs 3, 4 and 10";
  EXPECT_EQ(n.by_reason[static_cast<int>(io::Reject::kFuture)].load(), 1) << "seq 7";
  EXPECT_EQ(n.accepted.load() + n.missed.load() + n.rejected.load(), 10) << "each of the 10 seqs counted once";
  // a late duplicate of an accepted seq is no gap either
  EXPECT_EQ(r.send(at(late, 5), kMs), Offer::kRejected);
  EXPECT_EQ(r.send(at(fresh, 11), kMs), Offer::kAccepted);
  EXPECT_EQ(n.missed.load(), 3);
}

namespace {
// An arrival source (runtime/arrival_source.h) that hands a state over the way a receive process can
// on a loaded machine: after the loop's wait has timed out at a deadline (the stats) and before the
// loop reads the bell again to mark what it has handled (the second bell() after wait() returned),
// the state goes into the "ring" and the bell moves. hand_over() does it the ordinary way, at once.
struct RacingSource : runtime::ArrivalSource {
  runtime::ServiceLoop& loop;
  std::vector<uint8_t> pending;                // the state to hand over (set before hand_over / arm)
  mutable std::atomic<uint32_t> count{0};      // the bell
  mutable std::atomic<bool> queued{false};     // pending is in the "ring"
  std::atomic<bool> armed{false};              // the next deadline wake-up races
  mutable int bells_since_wait = -1;           // loop thread only
  explicit RacingSource(runtime::ServiceLoop& l) : loop(l) {}
  uint32_t bell() const override {
    if (bells_since_wait >= 0 && ++bells_since_wait == 2) {
      bells_since_wait = -1;
      queued = true;
      count.fetch_add(1);
    }
    return count.load();
  }
  void wait(uint32_t seen, long long deadline_ns) override {
    while (count.load() == seen && io::monotonic_ns() < deadline_ns) std::this_thread::sleep_for(std::chrono::microseconds(100));
    if (count.load() == seen && armed.exchange(false)) bells_since_wait = 0;
  }
  void drain() override {
    if (queued.exchange(false)) loop.states().offer(pending.data(), static_cast<int>(pending.size()), io::monotonic_ns());
  }
  void hand_over() {
    queued = true;
    count.fetch_add(1);
  }
};
}  // namespace

// Event-driven estimate mode (trigger: arrival): a state handed over and rung between the wait's
// timeout and the loop's next read of the bell is evaluated at that wake-up (before, its ring was
// taken as handled with the state left in the inbox: no output for it until it expired, the
// expiry's error status carrying its seq; seen under load in the daemon tests on arrival).
TEST(ServiceLoop, OnArrivalAStateRungAsTheWaitTimesOutIsEvaluated) {
  const System sys = load_scene(scene_path("two_puma_load"));
  ServiceConfig cfg;
  cfg.mode = runtime::ServiceMode::kEstimate;
  cfg.trigger = runtime::Trigger::kArrival;
  // the held state stays fresh for 10 min: the wake-up after it is the next state's or a deadline's,
  // so an output for that state within kEventLimit is its evaluation at its arrival (before, it came
  // with the held state's expiry, at 10 min)
  cfg.watchdog_ms = 600000;
  cfg.stats_period_s = 0.005;  // a deadline every 5 ms: the wait times out there
  SharedFakeBus bus;
  ServiceLoop loop(sys, cfg, bus);
  RacingSource source(loop);
  loop.take_arrivals_from(&source);
  auto state = [&](int64_t seq) {
    return io::encode_measured_state(runtime::realtime_us(), seq, {}, stdvec(sys.q0), {}, stdvec(sys.v0), stdvec(sys.v0));
  };
  std::atomic<bool> stop{false};
  std::thread th([&] { loop.run(stop); });
  source.pending = state(1);
  source.hand_over();
  const bool first = coopdyn::testing::wait_until([&] { return bus.last_input_seq() == 1; });
  source.pending = state(2);
  source.armed = true;
  const bool second = first && coopdyn::testing::wait_until([&] { return bus.last_input_seq() == 2; });
  stop = true;
  th.join();
  ASSERT_TRUE(first) << "the state handed over at once was not evaluated";
  ASSERT_TRUE(second) << "no output for the state rung as the wait timed out";
  EXPECT_EQ(bus.last_output().input, static_cast<int>(io::Input::kState)) << "its output is its evaluation, not its expiry";
  EXPECT_EQ(loop.expirations(), 0);
  EXPECT_EQ(loop.states().counters().accepted.load(), 2);
}

// The expiry is decided once, by the loop, and the sequence rule follows that decision: under a
// real loop at 1 kHz and a sender that restarts its seq after silences near the watchdog (where
// the two threads' clock readings used to disagree), every restart the inbox let through is an
// expiry the loop counted.
TEST(ServiceLoop, EveryRestartLetThroughIsACountedExpiry) {
  const System sys = load_scene(scene_path("four_bar"));
  ServiceConfig cfg;
  cfg.watchdog_ms = 5;
  FakeBus bus;
  ServiceLoop loop(sys, cfg, bus);
  std::atomic<bool> stop{false};
  std::thread th([&] { loop.run(stop); });
  const Eigen::VectorXd tau = some_torque(sys, 2);
  std::mt19937 rng(4);
  std::uniform_int_distribution<int> gap_us(4000, 6000);  // silence around the 5 ms watchdog
  int64_t seq = 100, restarts_accepted = 0, restarts_dropped = 0, last_accepted = -1;
  for (int burst = 0; burst < 120; ++burst) {
    for (int k = 0; k < 3; ++k) {
      const auto b = command(++seq, tau);
      if (loop.commands().offer(b.data(), static_cast<int>(b.size()), io::monotonic_ns()) == Offer::kAccepted)
        last_accepted = seq;
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    std::this_thread::sleep_for(std::chrono::microseconds(gap_us(rng)));
    seq = burst % 2 ? 0 : 1;  // the sender restarts
    const auto b = command(seq, tau);
    const Offer o = loop.commands().offer(b.data(), static_cast<int>(b.size()), io::monotonic_ns());
    if (o == Offer::kAccepted) {
      ++restarts_accepted;
      last_accepted = seq;
    } else {
      ++restarts_dropped;
      seq = last_accepted;  // keep counting up from what the daemon follows
    }
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  stop = true;
  th.join();
  std::printf("restarts: %lld accepted, %lld dropped; expiries counted %lld\n", static_cast<long long>(restarts_accepted),
              static_cast<long long>(restarts_dropped), static_cast<long long>(loop.expirations()));
  EXPECT_LE(restarts_accepted, loop.expirations());
  EXPECT_GT(restarts_accepted, 0);
}

TEST(ServiceLoop, WithNoCommandTheDefaultSafeTorqueHoldsTheArmsStill) {
  // the built-in (and shipped) policy is hold: started with no command, two_puma_load stays put,
  // and every output says which input was used
  Rig r("two_puma_load");
  ASSERT_EQ(r.cfg.safe_torque, runtime::SafeTorque::kHold);
  for (int k = 0; k < 3000; ++k) r.loop->tick(k * kMs);
  const io::DecodedOutput o = r.bus.last_output();
  EXPECT_EQ(o.input, static_cast<int>(io::Input::kNoCommand));
  EXPECT_LT((r.loop->q() - r.sys.q0).cwiseAbs().maxCoeff(), 1e-9) << "3 s of hold";
  for (int i = 0; i < 6; ++i) EXPECT_EQ(o.tau[i], 0.0) << "no force on the load's platform";
  double arms = 0;
  for (int i = 6; i < r.sys.model.nv(); ++i) arms += std::abs(o.tau[i]);
  EXPECT_GT(arms, 10.0) << "the arms' joints carry their weight";
}

namespace {
Offer control(Rig& r, int64_t seq, io::ControlAction a, long long t, const Eigen::VectorXd* q = nullptr,
              const Eigen::VectorXd* v = nullptr) {
  const auto b = io::encode_control(runtime::realtime_us(), seq, a, q ? stdvec(*q) : std::vector<double>{},
                                    v ? stdvec(*v) : std::vector<double>{});
  return r.loop->controls().offer(b.data(), static_cast<int>(b.size()), t);
}
}  // namespace

TEST(ServiceLoop, ControlPausesResumesResetsAndAcknowledges) {
  Rig r("two_puma_load");
  r.cfg.safe_torque = runtime::SafeTorque::kZero;  // the arms fall: the state moves
  r.reset();
  long long t = 0;
  for (int k = 0; k < 50; ++k) r.loop->tick(t += kMs);
  ASSERT_GT((r.loop->q() - r.sys.q0).norm(), 1e-3) << "falling";
  ASSERT_EQ(control(r, 1, io::ControlAction::kPause, t), Offer::kAccepted);
  r.loop->tick(t += kMs);
  const Eigen::VectorXd held = r.loop->q();
  const double st = r.loop->sim_time();
  io::DecodedOutput o = r.bus.last_output();
  EXPECT_EQ(o.paused, 1);
  EXPECT_EQ(o.control_seq, 1);
  EXPECT_EQ(o.control_action, static_cast<int>(io::ControlAction::kPause));
  EXPECT_EQ(o.control_result, static_cast<int>(io::ControlResult::kOk));
  for (int k = 0; k < 20; ++k) r.loop->tick(t += kMs);
  EXPECT_EQ(r.loop->q(), held) << "paused: nothing is integrated";
  EXPECT_EQ(r.loop->sim_time(), st);
  o = r.bus.last_output();
  EXPECT_EQ(o.status, static_cast<int>(Status::kOk)) << "outputs go on, evaluated at the held state";
  EXPECT_NE(o.wrench[0][5], 0.0);
  expect_matches_offline(r.sys, o);
  // an old seq is out of order, never applied
  EXPECT_EQ(control(r, 1, io::ControlAction::kResume, t), Offer::kOutOfOrder);
  ASSERT_EQ(control(r, 2, io::ControlAction::kResume, t), Offer::kAccepted);
  for (int k = 0; k < 5; ++k) r.loop->tick(t += kMs);
  EXPECT_NE(r.loop->q(), held);
  EXPECT_EQ(r.bus.last_output().paused, 0);
  ASSERT_EQ(control(r, 3, io::ControlAction::kReset, t), Offer::kAccepted);
  r.loop->tick(t += kMs);
  o = r.bus.last_output();
  EXPECT_EQ(o.control_seq, 3);
  for (int i = 0; i < r.sys.model.nq(); ++i) EXPECT_EQ(o.q[i], r.sys.q0[i]) << "the output of the reset tick starts at q0";
  // reset to a given state: one that closes the constraints is taken, one that does not is refused
  Eigen::VectorXd q = r.sys.q0, v = r.sys.v0;
  ASSERT_EQ(control(r, 4, io::ControlAction::kResetToState, t, &q, &v), Offer::kAccepted);
  r.loop->tick(t += kMs);
  EXPECT_EQ(r.bus.last_output().control_result, static_cast<int>(io::ControlResult::kOk));
  q[2] += 0.1;  // the load 10 cm off its grasps
  ASSERT_EQ(control(r, 5, io::ControlAction::kResetToState, t, &q, &v), Offer::kAccepted);
  r.loop->tick(t += kMs);
  o = r.bus.last_output();
  EXPECT_EQ(o.control_seq, 5);
  EXPECT_EQ(o.control_result, static_cast<int>(io::ControlResult::kRejectedState));
  EXPECT_NE(r.loop->q()[2], q[2]) << "the rejected state is not taken";
  // the refusal says why: the closure's largest residual and the constraint it is in. The load
  // 10 cm up opens every grasp by 0.1 m (position) or turns no frame (orientation 0).
  runtime::Event e{};
  std::vector<runtime::Event> refusals;
  while (r.loop->events().pop(&e))
    if (e.code == runtime::EventCode::kResetRejected) refusals.push_back(e);
  ASSERT_EQ(refusals.size(), 1u);
  EXPECT_EQ(refusals[0].a, 5);
  EXPECT_EQ(refusals[0].b / 65536, static_cast<int>(runtime::ResetRefusal::kClosure) * 4 + kClosurePosition);
  EXPECT_NEAR(refusals[0].x, 0.1, 1e-9);
  const int spec = static_cast<int>(refusals[0].b % 65536) - 1;
  ASSERT_GE(spec, 0);
  const std::string text = runtime::reset_refusal_text(r.sys, refusals[0]);
  EXPECT_NE(text.find("position residual 0.1 m at '" + r.sys.constraints.specs[static_cast<size_t>(spec)].name + "'"),
            std::string::npos)
      << text;
  // a quaternion not of unit norm is refused for that reason (non-finite values never get this
  // far: the control decoder rejects them)
  Eigen::VectorXd qbad = r.sys.q0;
  qbad[3] = 2.0;  // load.qw
  ASSERT_EQ(r.sys.model.q_names[3], "load.qw");
  ASSERT_EQ(control(r, 7, io::ControlAction::kResetToState, t, &qbad, &v), Offer::kAccepted);
  r.loop->tick(t += kMs);
  EXPECT_EQ(r.bus.last_output().control_result, static_cast<int>(io::ControlResult::kRejectedState));
  refusals.clear();
  while (r.loop->events().pop(&e))
    if (e.code == runtime::EventCode::kResetRejected) refusals.push_back(e);
  ASSERT_EQ(refusals.size(), 1u);
  EXPECT_EQ(refusals[0].b / 65536 / 4, static_cast<int>(runtime::ResetRefusal::kConfiguration));
  EXPECT_NE(runtime::reset_refusal_text(r.sys, refusals[0]).find("not a valid configuration"), std::string::npos);
  // a control with a state of the wrong size is a malformed message
  Eigen::VectorXd shortq = r.sys.q0.head(5);
  EXPECT_EQ(control(r, 6, io::ControlAction::kResetToState, t, &shortq, &v), Offer::kRejected);
}

TEST(ServiceLoop, ClearFaultLeavesALatchedFailureWithoutARestart) {
  Rig r("two_puma_load");
  r.cfg.safe_torque = runtime::SafeTorque::kZero;
  r.sys.options.max_speed = 1e-3;  // the first falling step trips the divergence detector
  r.reset();
  long long t = 0;
  for (int k = 0; k < 3; ++k) r.loop->tick(t += kMs);
  ASSERT_TRUE(r.loop->faulted());
  EXPECT_EQ(r.bus.last_output().reason, static_cast<int>(Reason::kDiverged));
  r.sys.options.max_speed = 1e4;  // the cause removed (in a lab: a command withdrawn)
  for (int k = 0; k < 3; ++k) r.loop->tick(t += kMs);
  EXPECT_TRUE(r.loop->faulted()) << "latched until cleared";
  ASSERT_EQ(control(r, 1, io::ControlAction::kClearFault, t), Offer::kAccepted);
  r.loop->tick(t += kMs);
  EXPECT_FALSE(r.loop->faulted());
  const io::DecodedOutput o = r.bus.last_output();
  EXPECT_EQ(o.status, static_cast<int>(Status::kOk));
  EXPECT_EQ(o.control_result, static_cast<int>(io::ControlResult::kOk));
  const double st = r.loop->sim_time();
  r.loop->tick(t += kMs);
  EXPECT_GT(r.loop->sim_time(), st) << "integrating again from the last good state";
}

TEST(ServiceLoop, ControlIsNotApplicableInEstimateMode) {
  Rig r("two_puma_load", runtime::ServiceMode::kEstimate);
  ASSERT_EQ(control(r, 1, io::ControlAction::kPause, 0), Offer::kAccepted);
  r.loop->tick(kMs);
  const io::DecodedOutput o = r.bus.last_output();
  EXPECT_EQ(o.control_seq, 1);
  EXPECT_EQ(o.control_result, static_cast<int>(io::ControlResult::kNotApplicable));
  EXPECT_EQ(o.paused, 0);
}

TEST(ServiceLoop, ForceOnTheUnactuatedLoadIsRejectedNeverAppliedAndTheLoopRuns) {
  // The load's platform DOFs take no command force (tau_limit 0) unless the scene declares
  // `load: {actuated: true}`. A command with force on load.vx, even 1e6 N or 1e308, is rejected as
  // "force on an unactuated DOF", counted, never applied; the loop keeps ticking on the last good
  // command with status ok.
  Rig r("two_puma_load");
  const int nv = r.sys.model.nv();
  const auto& v_names = r.sys.model.v_names;
  const int vx = static_cast<int>(std::find(v_names.begin(), v_names.end(), "load.vx") - v_names.begin());
  ASSERT_LT(vx, nv);
  const Eigen::VectorXd good = some_torque(r.sys, 5);
  ASSERT_EQ(good[vx], 0.0);
  ASSERT_EQ(r.send(command(1, good), 0), Offer::kAccepted);
  r.loop->tick(0);
  const auto& names = r.sys.model.v_names;
  int seq = 2;
  for (double f : {1.0, -1e-300, 1e6, 1e308}) {
    SCOPED_TRACE(f);
    Eigen::VectorXd t = good;
    t[vx] = f;
    io::Reject why = io::Reject::kNone;
    EXPECT_EQ(r.send(command(seq++, t), kMs, &why), Offer::kRejected);
    EXPECT_EQ(why, io::Reject::kUnactuated) << io::reject_name(why);
    EXPECT_EQ(r.send(command(seq++, Eigen::VectorXd::Constant(1, f), {names[vx]}), kMs, &why), Offer::kRejected);
    EXPECT_EQ(why, io::Reject::kUnactuated) << io::reject_name(why);
  }
  EXPECT_STREQ(io::reject_name(io::Reject::kUnactuated), "force on an unactuated DOF");
  for (int k = 1; k <= 50; ++k) {
    r.loop->tick(k * kMs);
    const io::DecodedOutput o = r.bus.last_output();
    ASSERT_EQ(o.tick, k) << "the loop keeps ticking and publishing";
    ASSERT_EQ(o.input, static_cast<int>(io::Input::kCommand));
    ASSERT_EQ(o.input_seq, 1) << "the last good command stays in force";
    ASSERT_NE(o.status, static_cast<int>(Status::kError));
    ASSERT_EQ(o.tau[vx], 0.0) << "never applied";
    for (int i = 0; i < nv; ++i) ASSERT_EQ(o.tau[i], good[i]);
  }
  const auto& c = r.loop->input_counters();
  EXPECT_EQ(c.by_reason[static_cast<int>(io::Reject::kUnactuated)].load(), 8);
  EXPECT_EQ(c.rejected.load(), 8);
  EXPECT_EQ(c.accepted.load(), 1);
  // exactly 0 (either sign) on the platform is a valid command
  Eigen::VectorXd z = good;
  z[vx] = -0.0;
  EXPECT_EQ(r.send(command(seq++, z), 60 * kMs), Offer::kAccepted);

  // declared actuated: the same force is accepted and applied, and it is what accelerates the load
  Rig a("two_puma_load");
  {
    std::ifstream f(scene_path("two_puma_load"));
    std::stringstream ss;
    ss << f.rdbuf();
    std::string t = ss.str();
    const std::string key = "load:\n  name: load\n";
    ASSERT_NE(t.find(key), std::string::npos);
    t.replace(t.find(key), key.size(), key + "  actuated: true\n");
    a.sys = load_scene_string(t, scene_path("two_puma_load"));
  }
  a.reset();
  Eigen::VectorXd push = good;
  push[vx] = 20.0;
  ASSERT_EQ(a.send(command(1, push), 0), Offer::kAccepted);
  a.loop->tick(0);
  const io::DecodedOutput o = a.bus.last_output();
  EXPECT_EQ(o.input_seq, 1);
  EXPECT_EQ(o.tau[vx], 20.0);
  expect_matches_offline(a.sys, o);
  Workspace ws0(a.sys), ws1(a.sys);
  evaluate(a.sys, ws0, a.sys.q0, a.sys.v0, good);
  evaluate(a.sys, ws1, a.sys.q0, a.sys.v0, push);
  EXPECT_GT(std::abs(ws1.vdot[vx] - ws0.vdot[vx]), 1e-3) << "the platform force acts on the load";
}

// ---------------------------------------------------------------------------------------------
// Estimation from joint measurements alone: a measured state with the arms' joints only.
namespace {
// the joint names and values of (q, v, tau) without the floating bodies' coordinates
struct JointsOnly {
  std::vector<std::string> qn, vn;
  std::vector<double> q, v, tau;
};
JointsOnly joints_only(const System& s, const Eigen::VectorXd& q, const Eigen::VectorXd& v, const Eigen::VectorXd& tau) {
  const StateFitPlan p = plan_state_fit(s);
  JointsOnly j;
  for (int i = 0; i < s.model.nq(); ++i)
    if (std::find(p.fit_q.begin(), p.fit_q.end(), i) == p.fit_q.end()) {
      j.qn.push_back(s.model.q_names[i]);
      j.q.push_back(q[i]);
    }
  for (int i = 0; i < s.model.nv(); ++i)
    if (std::find(p.fit_v.begin(), p.fit_v.end(), i) == p.fit_v.end()) {
      j.vn.push_back(s.model.v_names[i]);
      j.v.push_back(v[i]);
      j.tau.push_back(tau[i]);
    }
  return j;
}
}  // namespace

// Along a simulated trajectory (each state closed to round-off by projection), the output from the
// arms' joints alone equals the output from the full state: the same fitted load pose and twist,
// the same wrenches, stresses and accelerations; the residual is at round-off.
TEST(ServiceLoop, EstimateFromJointsOnlyEqualsFullState) {
  for (const char* scene : {"two_puma_load", "planar_arms_load"}) {
    SCOPED_TRACE(scene);
    Rig full(scene, runtime::ServiceMode::kEstimate), joints(scene, runtime::ServiceMode::kEstimate);
    System proj = full.sys;
    proj.options.projection_iterations = 20;
    Stepper sim(full.sys), pst(proj);
    Eigen::VectorXd q = full.sys.q0, v = full.sys.v0;
    const Eigen::VectorXd tau = some_torque(full.sys, 7, 1.0);
    for (int k = 1; k <= 30; ++k) {
      for (int n = 0; n < 10; ++n) step(full.sys, sim, runtime::ServiceConfig().integrator, 1e-3, tau, q, v);
      Eigen::VectorXd qc = q, vc = v;
      project_state(proj, pst, qc, vc);
      const auto bf = io::encode_measured_state(runtime::realtime_us(), k, full.sys.model.q_names, stdvec(qc),
                                                full.sys.model.v_names, stdvec(vc), stdvec(tau));
      const JointsOnly j = joints_only(full.sys, qc, vc, tau);
      const auto bj = io::encode_measured_state(runtime::realtime_us(), k, j.qn, j.q, j.vn, j.v, j.tau);
      ASSERT_EQ(full.loop->states().offer(bf.data(), static_cast<int>(bf.size()), k * kMs), Offer::kAccepted);
      io::Reject why = io::Reject::kNone;
      ASSERT_EQ(joints.loop->states().offer(bj.data(), static_cast<int>(bj.size()), k * kMs, &why), Offer::kAccepted)
          << io::reject_name(why);
      full.loop->tick(k * kMs);
      joints.loop->tick(k * kMs);
      const io::DecodedOutput of = full.bus.last_output(), oj = joints.bus.last_output();
      ASSERT_EQ(oj.status, of.status) << "reason " << oj.reason;
      ASSERT_NE(oj.status, static_cast<int>(Status::kError));
      EXPECT_EQ(of.state_fitted, 0);
      EXPECT_EQ(oj.state_fitted, 3);
      EXPECT_GE(oj.fit_iterations, 1);
      for (int c = 0; c < 4; ++c) EXPECT_LT(oj.closure[c], 1e-10) << "closure kind " << c;
      for (size_t i = 0; i < of.q.size(); ++i) ASSERT_NEAR(oj.q[i], of.q[i], 1e-11) << of.q_names[i] << " at k " << k;
      for (size_t i = 0; i < of.v.size(); ++i) ASSERT_NEAR(oj.v[i], of.v[i], 1e-10) << of.v_names[i] << " at k " << k;
      for (size_t t = 0; t < of.wrench.size(); ++t)
        for (int c = 0; c < 6; ++c)
          EXPECT_NEAR(oj.wrench[t][c], of.wrench[t][c], 1e-8 * (1 + std::abs(of.wrench[t][c]))) << of.wrench_names[t];
      for (size_t i = 0; i < of.vdot.size(); ++i) EXPECT_NEAR(oj.vdot[i], of.vdot[i], 1e-7 * (1 + std::abs(of.vdot[i])));
      expect_matches_offline(joints.sys, oj);
    }
  }
}

// A state that does not close (the load 1 m from where the arms hold it; a joint off by 0.1 rad)
// is an error with REASON_CLOSURE, naming the constraint and the residual; never OK with
// meaningless wrenches. The next state that closes is OK again.
TEST(ServiceLoop, EstimateRefusesAStateThatDoesNotClose) {
  Rig r("two_puma_load", runtime::ServiceMode::kEstimate);
  const System& s = r.sys;
  const StateFitPlan plan = plan_state_fit(s);
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(s.model.nv());
  Eigen::VectorXd q = s.q0;
  q[plan.fit_q[0]] += 1.0;  // load.x one metre off
  auto b = io::encode_measured_state(runtime::realtime_us(), 1, s.model.q_names, stdvec(q), s.model.v_names, stdvec(s.v0), stdvec(tau));
  ASSERT_EQ(r.loop->states().offer(b.data(), static_cast<int>(b.size()), kMs), Offer::kAccepted);
  r.loop->tick(kMs);
  io::DecodedOutput o = r.bus.last_output();
  EXPECT_EQ(o.status, static_cast<int>(Status::kError));
  EXPECT_EQ(o.reason, io::kReasonClosure);
  EXPECT_NEAR(o.closure[kClosurePosition], 1.0, 0.5) << "about a metre (in a tip frame's axes)";
  ASSERT_GE(o.closure_constraint[kClosurePosition], 0);
  EXPECT_NE(o.constraint_names[o.closure_constraint[kClosurePosition]].find("base"), std::string::npos)
      << o.constraint_names[o.closure_constraint[kClosurePosition]];
  for (const auto& w : o.wrench)
    for (double x : w) EXPECT_EQ(x, 0.0) << "no wrenches from a state that does not close";
  EXPECT_EQ(r.loop->closure_rejections(), 1);
  // joints only with one joint 0.1 rad off: the fit cannot close both arms
  JointsOnly j = joints_only(s, s.q0, s.v0, tau);
  j.q[0] += 0.1;
  b = io::encode_measured_state(runtime::realtime_us(), 2, j.qn, j.q, j.vn, j.v, j.tau);
  ASSERT_EQ(r.loop->states().offer(b.data(), static_cast<int>(b.size()), 2 * kMs), Offer::kAccepted);
  r.loop->tick(2 * kMs);
  o = r.bus.last_output();
  EXPECT_EQ(o.reason, io::kReasonClosure);
  EXPECT_EQ(o.state_fitted, 3);
  EXPECT_GT(std::max(o.closure[kClosurePosition] / r.cfg.closure_tolerance[0], o.closure[kClosureOrientation] / r.cfg.closure_tolerance[1]), 1.0);
  // the true joints: OK again
  j = joints_only(s, s.q0, s.v0, tau);
  b = io::encode_measured_state(runtime::realtime_us(), 3, j.qn, j.q, j.vn, j.v, j.tau);
  ASSERT_EQ(r.loop->states().offer(b.data(), static_cast<int>(b.size()), 3 * kMs), Offer::kAccepted);
  r.loop->tick(3 * kMs);
  o = r.bus.last_output();
  EXPECT_NE(o.status, static_cast<int>(Status::kError)) << o.reason;
  EXPECT_LT(o.closure[kClosurePosition], 1e-9);
  // the log events: one when it opened, one when it closed again
  int open = 0, back = 0;
  runtime::Event e;
  while (r.loop->events().pop(&e)) {
    open += e.code == runtime::EventCode::kClosureOpen;
    back += e.code == runtime::EventCode::kClosureBack;
  }
  EXPECT_EQ(open, 1);
  EXPECT_EQ(back, 1);
}

// What a state may omit: all of the floating bodies' coordinates (where the constraints fix them)
// or none; pseudo-joints. Anything else is refused as incomplete, and counted.
TEST(ServiceLoop, IncompleteStatesAreRefusedWithTheirReason) {
  auto offer = [](Rig& r, std::vector<std::string> qn, std::vector<double> q, std::vector<std::string> vn, std::vector<double> v) {
    const std::vector<double> tau(v.size(), 0.0);
    const auto b = io::encode_measured_state(runtime::realtime_us(), 1, qn, q, vn, v, tau);
    io::Reject why = io::Reject::kNone;
    r.loop->states().offer(b.data(), static_cast<int>(b.size()), kMs, &why);
    return why;
  };
  {
    Rig r("two_puma_load", runtime::ServiceMode::kEstimate);
    const System& s = r.sys;
    const JointsOnly j = joints_only(s, s.q0, s.v0, Eigen::VectorXd::Zero(s.model.nv()));
    // the load's x given, the rest of its pose omitted: refused
    std::vector<std::string> qn = j.qn;
    std::vector<double> q = j.q;
    qn.push_back("load.x");
    q.push_back(s.q0[0]);
    EXPECT_EQ(offer(r, qn, q, j.vn, j.v), io::Reject::kIncomplete);
    // an arm joint missing: refused
    EXPECT_EQ(offer(r, std::vector<std::string>(j.qn.begin() + 1, j.qn.end()), std::vector<double>(j.q.begin() + 1, j.q.end()), j.vn, j.v),
              io::Reject::kIncomplete);
    EXPECT_EQ(r.loop->states().counters().by_reason[static_cast<int>(io::Reject::kIncomplete)].load(), 2);
    EXPECT_STREQ(io::reject_name(io::Reject::kIncomplete), "incomplete state");
    // positions fitted, velocities given in full: accepted
    EXPECT_EQ(offer(r, j.qn, j.q, s.model.v_names, stdvec(s.v0)), io::Reject::kNone);
  }
  {
    // a vehicle cannot omit its chassis pose (the wheels do not fix it)
    Rig r("two_wheel_vehicle", runtime::ServiceMode::kEstimate);
    const System& s = r.sys;
    const JointsOnly j = joints_only(s, s.q0, s.v0, Eigen::VectorXd::Zero(s.model.nv()));
    EXPECT_EQ(offer(r, j.qn, j.q, s.model.v_names, stdvec(s.v0)), io::Reject::kIncomplete);
  }
}

namespace {
int position_of(const std::vector<std::string>& v, const std::string& x) {
  const auto it = std::find(v.begin(), v.end(), x);
  return it == v.end() ? -1 : static_cast<int>(it - v.begin());
}
}  // namespace

// Force/torque sensor readings with a measured state: the output carries measured - estimated for
// each measured wrench (0 and unflagged elsewhere), so the model can be checked on the real robot.
TEST(ServiceLoop, MeasuredWrenchesAreComparedWithTheEstimate) {
  Rig r("two_puma_load", runtime::ServiceMode::kEstimate);
  const System& s = r.sys;
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(s.model.nv());
  // the estimate first, without sensors
  auto b = io::encode_measured_state(runtime::realtime_us(), 1, s.model.q_names, stdvec(s.q0), s.model.v_names, stdvec(s.v0), stdvec(tau));
  ASSERT_EQ(r.loop->states().offer(b.data(), static_cast<int>(b.size()), kMs), Offer::kAccepted);
  r.loop->tick(kMs);
  const io::DecodedOutput o1 = r.bus.last_output();
  ASSERT_NE(o1.status, static_cast<int>(Status::kError));
  for (int m : o1.wrench_measured) EXPECT_EQ(m, 0);
  // a wrist sensor on arm2 reading the estimate plus an offset, and a base sensor reading it exactly
  const int ee2 = position_of(o1.wrench_names, "arm2.ee"), base1 = position_of(o1.wrench_names, "arm1.base");
  ASSERT_GE(ee2, 0);
  ASSERT_GE(base1, 0);
  const std::array<double, 6> offset{{0.01, -0.02, 0.03, 0.5, -1.5, 2.5}};
  std::array<double, 6> w_ee2, w_base1;
  for (int k = 0; k < 6; ++k) {
    w_ee2[k] = o1.wrench[ee2][k] + offset[k];
    w_base1[k] = o1.wrench[base1][k];
  }
  b = io::encode_measured_state(runtime::realtime_us(), 2, s.model.q_names, stdvec(s.q0), s.model.v_names, stdvec(s.v0), stdvec(tau),
                                {"arm2.ee", "arm1.base"}, {w_ee2, w_base1});
  ASSERT_EQ(r.loop->states().offer(b.data(), static_cast<int>(b.size()), 2 * kMs), Offer::kAccepted);
  r.loop->tick(2 * kMs);
  const io::DecodedOutput o2 = r.bus.last_output();
  for (size_t t = 0; t < o2.wrench_names.size(); ++t) {
    const bool measured = static_cast<int>(t) == ee2 || static_cast<int>(t) == base1;
    EXPECT_EQ(o2.wrench_measured[t], measured ? 1 : 0) << o2.wrench_names[t];
    for (int k = 0; k < 6; ++k)
      EXPECT_NEAR(o2.wrench_residual[t][k], static_cast<int>(t) == ee2 ? offset[k] : 0.0, 1e-9 * (1 + std::abs(o1.wrench[t][k])))
          << o2.wrench_names[t] << " " << k;
  }
  // bad readings are refused like any bad input
  io::Reject why = io::Reject::kNone;
  auto offer = [&](const std::vector<std::string>& names, const std::vector<std::array<double, 6>>& w, int64_t seq) {
    const auto m = io::encode_measured_state(runtime::realtime_us(), seq, s.model.q_names, stdvec(s.q0), s.model.v_names,
                                             stdvec(s.v0), stdvec(tau), names, w);
    r.loop->states().offer(m.data(), static_cast<int>(m.size()), 3 * kMs, &why);
    return why;
  };
  EXPECT_EQ(offer({"arm9.ee"}, {w_ee2}, 3), io::Reject::kUnknownName);
  EXPECT_EQ(offer({"arm2.ee", "arm2.ee"}, {w_ee2, w_ee2}, 4), io::Reject::kDuplicateName);
  std::array<double, 6> nan_w = w_ee2;
  nan_w[4] = std::nan("");
  EXPECT_EQ(offer({"arm2.ee"}, {nan_w}, 5), io::Reject::kNonFinite);
}
