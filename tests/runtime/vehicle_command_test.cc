// A vehicle's driver commands through coopdynd: steer angles as lock targets in
// torque_command_t (validated like the torques: by name, locks with a target_limit only, finite,
// within the limit; expired with the watchdog), a real memq:// round trip in which a steer command
// moves the lock and the published contact wrenches equal the offline evaluation at that angle.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <thread>

#include "service/dynamics/contacts.h"
#include "service/io/transport/lcm_bus.h"
#include "service/runtime/service_loop.h"
#include "tests/support/daemon_test_util.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;
using namespace coopdyn::daemon_test;
using namespace std::chrono_literals;

namespace {

constexpr double kL = 2.66, kTrack = 1.565;

int lock_spec(const System& sys, const std::string& joint) {
  for (size_t k = 0; k < sys.constraints.specs.size(); ++k)
    if (sys.constraints.specs[k].kind == ConstraintKind::kLock &&
        sys.model.v_names[static_cast<size_t>(sys.constraints.specs[k].dof)] == joint)
      return static_cast<int>(k);
  ADD_FAILURE() << "no lock of " << joint;
  return 0;
}

}  // namespace

TEST(VehicleCommand, TargetsAreValidatedLikeTorques) {
  const System sys = load("four_wheel_car");
  io::CommandDecoder dec(sys);
  io::CommandSlot slot;
  slot.tau = Eigen::VectorXd::Zero(sys.model.nv());
  slot.lock_target = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(sys.constraints.specs.size()));
  const int fl = lock_spec(sys, "fl_steer"), fr = lock_spec(sys, "fr_steer");
  auto decode = [&](const std::vector<std::string>& names, const std::vector<double>& x) {
    const auto b = io::encode_torque_command(1, 1, {"rl_spin"}, {100.0}, names, x);
    return dec.decode(b.data(), static_cast<int>(b.size()), slot);
  };
  // accepted: the named lock gets its target, the other keeps the scene's angle; torques as before
  ASSERT_EQ(decode({"fl_steer"}, {0.1}), io::Reject::kNone);
  EXPECT_EQ(slot.lock_target[fl], 0.1);
  EXPECT_EQ(slot.lock_target[fr], 0.0);
  EXPECT_EQ(slot.tau[velocity_index_of(sys, "rl_spin")], 100.0);
  ASSERT_EQ(decode({"fr_steer", "fl_steer"}, {-0.6, 0.6}), io::Reject::kNone);  // at the limit, either order
  EXPECT_EQ(slot.lock_target[fl], 0.6);
  EXPECT_EQ(slot.lock_target[fr], -0.6);
  ASSERT_EQ(decode({}, {}), io::Reject::kNone);  // a command without targets: the scene's angles
  EXPECT_EQ(slot.lock_target[fl], 0.0);
  // rejected, each with its reason
  EXPECT_EQ(decode({"fl_steeer"}, {0.1}), io::Reject::kUnknownName);
  EXPECT_EQ(decode({"rl_spin"}, {0.1}), io::Reject::kNotLocked);  // a joint, but not a lock
  EXPECT_EQ(decode({"chassis.wz"}, {0.1}), io::Reject::kNotLocked);  // the floating chassis
  EXPECT_EQ(decode({"fl_steer", "fl_steer"}, {0.1, 0.1}), io::Reject::kDuplicateName);
  EXPECT_EQ(decode({"fl_steer"}, {std::nan("")}), io::Reject::kNonFinite);
  EXPECT_EQ(decode({"fl_steer"}, {-INFINITY}), io::Reject::kNonFinite);
  EXPECT_EQ(decode({"fl_steer"}, {0.6000001}), io::Reject::kOverTargetLimit);
  EXPECT_EQ(decode({"fr_steer"}, {-0.7}), io::Reject::kOverTargetLimit);
  EXPECT_STREQ(io::reject_key(io::Reject::kNotLocked), "not_locked");
  EXPECT_STREQ(io::reject_key(io::Reject::kOverTargetLimit), "over_target_limit");
  // hostile framing: targets counted past the end, or more of them than any scene has
  auto b = io::encode_torque_command(1, 1, {}, std::vector<double>(static_cast<size_t>(sys.model.nv()), 0.0), {"fl_steer"}, {0.1});
  std::vector<uint8_t> cut(b.begin(), b.end() - 8);  // the mac_len field and half the target gone
  EXPECT_EQ(dec.decode(cut.data(), static_cast<int>(cut.size()), slot), io::Reject::kDecode);
  // num_targets: before one name ("fl_steer\0"), one double and mac_len (0, no MAC)
  const size_t at = b.size() - 4 - 8 - (4 + 9) - 4;
  ASSERT_EQ(b[at + 3], 1);
  b[at + 1] = 0x10;  // 1048577 targets
  EXPECT_EQ(dec.decode(b.data(), static_cast<int>(b.size()), slot), io::Reject::kDecode);
  // a pseudo-joint without a target_limit cannot be commanded, nor any lock in the pseudo_joint
  // formulation (no lock rows: the Schur form holds them at the scene's q)
  const System fixed = load_scene_string(replace_once(scene_text("four_wheel_car"), "q: 0, target_limit: 0.6}", "q: 0}"),
                                         coopdyn::testing::scene_path("four_wheel_car"));
  io::CommandDecoder dec_fixed(fixed);
  const auto c1 = io::encode_torque_command(1, 1, {}, std::vector<double>(static_cast<size_t>(sys.model.nv()), 0.0), {"fl_steer"}, {0.1});
  EXPECT_EQ(dec_fixed.decode(c1.data(), static_cast<int>(c1.size()), slot), io::Reject::kNotLocked);
  const System schur = load("four_wheel_car", Formulation::kPseudoJointSchur);
  io::CommandDecoder dec_schur(schur);
  EXPECT_EQ(dec_schur.decode(c1.data(), static_cast<int>(c1.size()), slot), io::Reject::kNotLocked);
  // the scene's own checks: target_limit only on a pseudo-joint, > 0, and the scene's q within it
  const std::string base = scene_text("four_wheel_car");
  EXPECT_NE(scene_error(replace_once(base, "name: rl_spin}", "name: rl_spin, target_limit: 1}")).find("target_limit applies to a pseudo-joint"),
            std::string::npos);
  EXPECT_NE(scene_error(replace_once(base, "q: 0, target_limit: 0.6}", "q: 0, target_limit: -1}")).find("car.yaml:"), std::string::npos);
  EXPECT_NE(scene_error(replace_once(base, "q: 0, target_limit: 0.6}", "q: 0.7, target_limit: 0.6}")).find("beyond its target_limit"),
            std::string::npos);
}

// memq://: the loop at 1 kHz in its thread, commands in, outputs out. The steer joints are put at
// the commanded Ackermann angles by the next step's projection; then with drive torque the car pulls
// away on its circle. Every output under a command equals the offline evaluation with the locks at
// the command's targets (the first one after the command still at the old angle, the lock's error
// in its row); once the angles are there, the scene loaded at those angles; after the watchdog the
// locks go back to the scene's angles.
TEST(VehicleCommand, MemqSteerCommandsMoveTheLocksAndTheWrenchesEqualOffline) {
  const std::string text = scene_text("four_wheel_car");
  const System sys = load_scene_string(text, coopdyn::testing::scene_path("four_wheel_car"));
  const double R = 15.0, dl = std::atan(kL / (R - kTrack / 2)), dr = std::atan(kL / (R + kTrack / 2));
  const int fl = lock_spec(sys, "fl_steer"), fr = lock_spec(sys, "fr_steer");
  const int q_fl = sys.constraints.specs[static_cast<size_t>(fl)].q_index, q_fr = sys.constraints.specs[static_cast<size_t>(fr)].q_index;
  runtime::ServiceConfig cfg;
  io::LcmBus bus("memq://");
  runtime::ServiceLoop loop(sys, cfg, bus);
  bus.subscribe(cfg.command_channel, [&](const void* d, int n, long long t) { loop.commands().offer(d, n, t); });
  std::mutex mu;
  std::vector<io::DecodedOutput> outs;
  bus.subscribe(cfg.output_channel, [&](const void* d, int n, long long) {
    io::DecodedOutput o;
    if (!io::decode_output(d, n, &o)) return;
    std::lock_guard<std::mutex> lk(mu);
    outs.push_back(std::move(o));
  });
  bus.start();
  std::atomic<bool> stop{false};
  std::thread th([&] { loop.run(stop); });
  const std::vector<std::string> steer = {"fl_steer", "fr_steer"};
  const int nv = sys.model.nv();
  auto send = [&](int64_t seq, double drive, const std::vector<std::string>& names, const std::vector<double>& x) {
    std::vector<double> tau(static_cast<size_t>(nv), 0.0);
    tau[static_cast<size_t>(velocity_index_of(sys, "rl_spin"))] = tau[static_cast<size_t>(velocity_index_of(sys, "rr_spin"))] = drive;
    const auto b = io::encode_torque_command(io::wall_us(), seq, {}, tau, names, x);
    bus.publish(cfg.command_channel.c_str(), b.data(), static_cast<int>(b.size()));
  };
  // outputs seen so far that satisfy pred (the loop runs in its own thread: the test waits for the
  // outputs it needs, however fast the machine steps)
  auto count = [&](auto pred) {
    std::lock_guard<std::mutex> lk(mu);
    return std::count_if(outs.begin(), outs.end(), pred);
  };
  auto at_angle_now = [&](const io::DecodedOutput& o) {
    return o.input == static_cast<int>(io::Input::kCommand) && std::abs(o.q[static_cast<size_t>(q_fl)] - dl) < 1e-11 &&
           std::abs(o.q[static_cast<size_t>(q_fr)] - dr) < 1e-11;
  };
  constexpr int kMaxCommands = 20000;  // 100 s at 5 ms: only a machine that stopped reaches it
  int64_t seq = 0;
  for (int k = 0; k < kMaxCommands && (k < 40 || count(at_angle_now) <= 40); ++k, std::this_thread::sleep_for(5ms))
    send(++seq, 0.0, steer, {dl, dr});  // steer at rest, until 41 outputs at the angle
  const int64_t first_drive = seq + 1;
  auto moving_now = [&](const io::DecodedOutput& o) { return at_angle_now(o) && o.input_seq >= first_drive && o.v[3] > 1e-3; };
  for (int k = 0; k < kMaxCommands && (k < 40 || count(moving_now) <= 20); ++k, std::this_thread::sleep_for(5ms)) {
    send(++seq, 150.0, steer, {dl, dr});  // pull away, until 21 outputs moving at the angle
    if (k == 10) send(1000, 150.0, steer, {std::nan(""), dr});   // rejected: NaN
    if (k == 20) send(1001, 150.0, {"rl_spin"}, {0.1});          // rejected: not a lock
    if (k == 30) send(1002, 150.0, steer, {0.61, dr});           // rejected: over target_limit
  }
  // the watchdog expires the last command: wait for 21 outputs after it
  const auto expired_now = [](const io::DecodedOutput& o) { return o.input == static_cast<int>(io::Input::kCommandExpired); };
  for (int k = 0; k < kMaxCommands && count(expired_now) <= 20; ++k) std::this_thread::sleep_for(5ms);
  stop = true;
  th.join();
  bus.stop();
  const runtime::InputCounters& c = loop.commands().counters();
  EXPECT_EQ(c.by_reason[static_cast<int>(io::Reject::kNonFinite)].load(), 1);
  EXPECT_EQ(c.by_reason[static_cast<int>(io::Reject::kNotLocked)].load(), 1);
  EXPECT_EQ(c.by_reason[static_cast<int>(io::Reject::kOverTargetLimit)].load(), 1);

  std::lock_guard<std::mutex> lk(mu);
  const System at_angle = car_with_steer(dl, dr, text);  // the scene written at the commanded angles
  System targets = sys;                           // the scene with the command's targets
  targets.constraints.specs[static_cast<size_t>(fl)].q_target = dl;
  targets.constraints.specs[static_cast<size_t>(fr)].q_target = dr;
  int transient = 0, arrived = 0, moving = 0, expired = 0;
  double max_fl = 0;
  for (const io::DecodedOutput& o : outs) {
    ASSERT_LT(o.input_seq, 1000) << "a rejected command was applied";
    if (o.status == static_cast<int>(Status::kError)) ADD_FAILURE() << "error status at tick " << o.tick;
    max_fl = std::max(max_fl, o.q[static_cast<size_t>(q_fl)]);
    if (o.input == static_cast<int>(io::Input::kCommand)) {
      const bool there = std::abs(o.q[static_cast<size_t>(q_fl)] - dl) < 1e-11 && std::abs(o.q[static_cast<size_t>(q_fr)] - dr) < 1e-11;
      if (!there) {
        // on the way: the offline evaluation with the locks at the command's targets
        ++transient;
        expect_matches_offline(targets, o);
        continue;
      }
      ++arrived;
      if (o.input_seq >= first_drive && o.v[3] > 1e-3) ++moving;
      if (arrived % 4 != 0) continue;
      // arrived: the scene at that steer angle, and its contact report
      expect_matches_offline(at_angle, o);
      Workspace ws(at_angle);
      evaluate(at_angle, ws, vec(o.q), vec(o.v), vec(o.tau));
      ContactData cts(at_angle);
      compute_contacts(at_angle, ws, cts);
      ASSERT_EQ(o.contact_utilisation.size(), cts.spec.size());
      for (size_t i = 0; i < cts.spec.size(); ++i) {
        EXPECT_NEAR(o.contact_normal[i], cts.normal[i], 1e-9 * std::abs(cts.normal[i]));
        EXPECT_NEAR(o.contact_utilisation[i], cts.utilisation[i], 1e-9);
        EXPECT_EQ(o.contact_state[i], static_cast<int>(cts.state[i]));
      }
    } else if (o.input == static_cast<int>(io::Input::kCommandExpired)) {
      // the watchdog: no command, the locks hold the scene's angles (0) again
      if (expired++ % 10 == 0) expect_matches_offline(sys, o);
    }
  }
  EXPECT_NEAR(max_fl, dl, 1e-9);
  EXPECT_GE(transient, 1);
  EXPECT_GT(arrived, 40);
  EXPECT_GT(moving, 20);  // the steered car under drive, its wrenches equal to the offline ones
  EXPECT_GT(expired, 20);
  const io::DecodedOutput& last = outs.back();
  EXPECT_EQ(last.input, static_cast<int>(io::Input::kCommandExpired));
  EXPECT_LT(std::abs(last.q[static_cast<size_t>(q_fl)]), 0.01 * dl);  // back towards straight ahead
  std::printf("[ four_wheel_car ] memq://: steer %.5f / %.5f rad (Ackermann R %.0f m) reached; %d outputs on the way, "
              "%d at the angle (%d moving), %d after the watchdog; last fl_steer %.3g rad\n",
              dl, dr, R, transient, arrived, moving, expired, last.q[static_cast<size_t>(q_fl)]);
}
