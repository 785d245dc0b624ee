// The safe torque through the loop (tick(now) with synthetic times: the loop's simulated time, 1 ms
// per tick): a command naming some joints leaves the others to the safe torque, and the default
// safe torque (the braking hold) brings a fast-moving system to rest within 2 s of the last command.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "service/dynamics/joint_limits.h"
#include "service/runtime/service_loop.h"
#include "tests/support/daemon_test_util.h"

using namespace coopdyn;
using namespace coopdyn::daemon_test;
using runtime::Offer;
using runtime::ServiceConfig;
using runtime::ServiceLoop;

namespace {
constexpr long long kMs = 1000000;

struct Rig {
  System sys;
  ServiceConfig cfg;
  FakeBus bus;
  std::unique_ptr<ServiceLoop> loop;
  long long t = 0;   // monotonic ns of the next tick
  int64_t seq = 0;
  explicit Rig(const std::string& scene) : sys(load_scene(scene_path(scene))) {}
  void start() { loop = std::make_unique<ServiceLoop>(sys, cfg, bus); }
  // one tick under a fresh command (names empty: every DOF), as a 1 kHz sender's
  void tick_with(const std::vector<std::string>& names, const std::vector<double>& tau) {
    const auto b = io::encode_torque_command(runtime::realtime_us(), ++seq, names, tau);
    ASSERT_EQ(loop->commands().offer(b.data(), static_cast<int>(b.size()), t), Offer::kAccepted);
    loop->tick(t);
    t += kMs;
  }
  void tick() {
    loop->tick(t);
    t += kMs;
  }
  double max_speed() const { return loop->v().cwiseAbs().maxCoeff(); }
};

int index_of(const std::vector<std::string>& names, const std::string& n) {
  return static_cast<int>(std::find(names.begin(), names.end(), n) - names.begin());
}
}  // namespace

// A command naming arm1.q1 alone: q1 gets exactly its torque, every other joint the safe torque (at
// the first tick, the hold at q0), and the system stays up while q1 turns; the same command with
// the others commanded 0 (coopdyn send --others zero) lets both arms fall.
TEST(SafeTorque, ACommandNamingSomeJointsLeavesTheOthersToTheHold) {
  Rig r("two_puma_load");
  r.start();
  const auto& vn = r.sys.model.v_names;
  const int q1 = index_of(vn, "arm1.q1");
  ASSERT_LT(q1, r.sys.model.nv());
  // the hold at q0, from a loop without a command
  Rig ref("two_puma_load");
  ref.start();
  ref.tick();
  const io::DecodedOutput held = ref.bus.last_output();
  r.tick_with({"arm1.q1"}, {1.0});
  const io::DecodedOutput o = r.bus.last_output();
  EXPECT_EQ(o.input, static_cast<int>(io::Input::kCommand));
  for (int i = 0; i < r.sys.model.nv(); ++i)
    EXPECT_NEAR(o.tau[i], i == q1 ? 1.0 : held.tau[i], 1e-12) << vn[i];
  // 1 s of the pulse: q1 turns, the load neither falls nor speeds away
  const Eigen::VectorXd q0 = r.sys.q0;
  for (int k = 1; k < 1000; ++k) r.tick_with({"arm1.q1"}, {1.0});
  // the load's height (its platform's coordinates lead: load.x, .y, .z): q1 turns about the vertical,
  // dragging the box sideways, but nothing falls
  const double load_moved = (r.loop->q().head<3>() - q0.head<3>()).norm(), load_dz = r.loop->q()[2] - q0[2];
  const int q1_at = r.sys.model.bodies[static_cast<size_t>(r.sys.model.dof_body[static_cast<size_t>(q1)])].joint.idx_q;
  const double turned = r.loop->q()[q1_at] - q0[q1_at];
  std::printf("held: arm1.q1 turned %.4g rad, the load moved %.3g m (height %.3g m), max speed %.3g rad/s\n", turned,
              load_moved, load_dz, r.max_speed());
  EXPECT_GT(turned, 1e-3) << "the named joint moves, in the sense of its torque";
  EXPECT_LT(std::abs(load_dz), 1e-3) << "held: the load's height stays within 1 mm";
  EXPECT_LT(r.max_speed(), 1.0) << "rad/s";
  EXPECT_EQ(r.bus.last_output().status, static_cast<int>(Status::kOk));
  // every joint named, the others 0: the arms fall
  Rig z("two_puma_load");
  z.start();
  std::vector<double> tau(static_cast<size_t>(z.sys.model.nv()), 0.0);
  tau[static_cast<size_t>(q1)] = 1.0;
  for (int k = 0; k < 1000; ++k) z.tick_with({}, tau);
  EXPECT_GT((z.loop->q().head<3>() - q0.head<3>()).norm(), 0.1) << "zero torques: the arms fall and swing the load";
}

// From a fast-moving state (the arms fallen under 0.6 s of zero torques, then a random closing
// velocity of up to 10 rad/s per joint), the default safe torque stops the system: 2 s after the
// last command every speed is below 0.01 rad/s (or m/s), and the status never turns to an error.
TEST(SafeTorque, TheDefaultSafeTorqueBringsAFastSystemToRestWithin2s) {
  for (const std::string name : {"two_puma_load", "two_iiwa_load", "planar_arms_load"}) {
    SCOPED_TRACE(name);
    Rig r(name);
    ASSERT_EQ(r.cfg.safe_torque, runtime::SafeTorque::kHold);
    ASSERT_GT(r.cfg.time_constant, 0.0);
    r.start();
    std::vector<double> zero(static_cast<size_t>(r.sys.model.nv()), 0.0);
    for (int k = 0; k < 600; ++k) r.tick_with({}, zero);
    const double falling = r.max_speed();
    // and a random closing velocity on top (a controller gone wild), through reset_to_state
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-10.0, 10.0);
    Eigen::VectorXd v = r.loop->v();
    for (Eigen::Index i = 0; i < v.size(); ++i) v[i] += u(rng);
    v = closing_velocity(r.sys, r.loop->q(), v);
    const Eigen::VectorXd q = r.loop->q();
    const auto b = io::encode_control(runtime::realtime_us(), 1, io::ControlAction::kResetToState, stdvec(q), stdvec(v));
    ASSERT_EQ(r.loop->controls().offer(b.data(), static_cast<int>(b.size()), r.t), Offer::kAccepted);
    r.tick_with({}, zero);  // the last command
    const long long last = r.t - kMs;
    const double start = r.max_speed();
    std::printf("%s: %.2f rad/s after the fall, %.2f rad/s at the last command\n", name.c_str(), falling, start);
    EXPECT_GT(start, 5.0) << "a fast-moving state";
    double slowest_half = 0;
    while (r.t <= last + 2000 * kMs) {
      r.tick();
      ASSERT_NE(r.bus.last_output().status, static_cast<int>(Status::kError)) << "at " << (r.t - last) / kMs << " ms";
      if (r.t > last + 1000 * kMs) slowest_half = std::max(slowest_half, r.max_speed());
    }
    EXPECT_EQ(r.bus.last_output().input, static_cast<int>(io::Input::kCommandExpired));
    std::printf("%s: max speed %.3g over the second second, %.3g at 2 s\n", name.c_str(), slowest_half, r.max_speed());
    EXPECT_LT(r.max_speed(), 1e-2) << "still 2 s after the last command";
  }
}

// Joint limits through the loop: two iiwa arms (URDF limits: 1.31-2.36 rad/s) held by the safe
// torque stay within every limit; commanded zero torques they fall, their joints pass their speed
// limits, and the loop flags those joints in its output record and counts the ticks.
TEST(SafeTorque, TheLoopFlagsAndCountsJointLimitsExceeded) {
  Rig held("two_iiwa_load");
  held.start();
  for (int k = 0; k < 500; ++k) held.tick();
  EXPECT_EQ(held.loop->limit_ticks(), 0);
  EXPECT_EQ(held.loop->limits().exceeded, 0);
  Rig r("two_iiwa_load");
  r.start();
  std::vector<double> zero(static_cast<size_t>(r.sys.model.nv()), 0.0);
  int first = -1;
  for (int k = 0; k < 1000; ++k) {
    r.tick_with({}, zero);
    if (first < 0 && r.loop->limit_ticks() > 0) first = k;
  }
  ASSERT_GE(first, 0) << "falling, the arms pass their speed limits";
  EXPECT_GT(r.loop->limit_ticks(2), 0) << "velocity";
  EXPECT_EQ(r.loop->limit_ticks(3), 0) << "zero torques exceed no effort limit";
  // the flags are the published state's: each flagged joint is past its limit there
  const LimitData& ld = r.loop->limits();
  const io::DecodedOutput o = r.bus.last_output();
  int flagged = 0;
  for (int d = 0; d < r.sys.model.nv(); ++d) {
    if (!(ld.mask[d] & kLimitVelocity)) {
      EXPECT_LE(std::abs(o.v[d]), r.sys.v_limit[d]) << r.sys.model.v_names[d];
      continue;
    }
    ++flagged;
    EXPECT_GT(std::abs(o.v[d]), r.sys.v_limit[d]) << r.sys.model.v_names[d];
  }
  EXPECT_EQ(flagged > 0, (ld.any & kLimitVelocity) != 0);
  std::printf("first limit at tick %d; ticks over a limit %lld (position %lld, velocity %lld)\n", first,
              static_cast<long long>(r.loop->limit_ticks()), static_cast<long long>(r.loop->limit_ticks(1)),
              static_cast<long long>(r.loop->limit_ticks(2)));
}
