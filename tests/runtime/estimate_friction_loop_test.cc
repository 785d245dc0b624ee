// Estimate mode on a scene with joint friction, tick by tick (FakeBus): states at rest (friction
// bounded) and moving, the bound computed every tick without allocating (the counting heap of this
// executable, service_loop_no_allocation_test.cc), and what the output carries equal to the offline
// evaluation and bound of the same state; with compensation off, the frictionless evaluation.
#include "tests/support/counting_allocator.h"

#include <gtest/gtest.h>

#include <algorithm>

#include <Eigen/QR>

#include "service/algorithms/kinematics.h"
#include "service/dynamics/friction_bound.h"
#include "service/runtime/service_loop.h"
#include "tests/support/daemon_test_util.h"

using namespace coopdyn;
using namespace coopdyn::daemon_test;
using coopdyn::testing::AllocationCounter;
using coopdyn::testing::kCountingAvailable;

namespace {
System friction_scene() {
  return load_scene(std::string(COOPDYN_SOURCE_DIR) + "/bench/scenes/two_puma_friction.yaml");
}

// A velocity that closes the constraints at q0 with the DOFs in `rest` exactly at rest: v projected
// onto the null space of G with those columns removed (their entries stay 0).
Eigen::VectorXd closing_with_rest(const System& sys, Eigen::VectorXd v, const std::vector<int>& rest) {
  Workspace ws(sys);
  forward_kinematics(sys.model, ws.data, sys.q0, v);
  constraint_rows(sys.model, ws.data, sys.constraints, sys.q0, v, ws.cd);
  Eigen::MatrixXd G = ws.cd.G;
  for (int d : rest) {
    G.col(d).setZero();
    v[d] = 0.0;
  }
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(G);
  Eigen::VectorXd out = v - cod.solve(G * v);
  for (int d : rest) out[d] = 0.0;
  return out;
}
}  // namespace

TEST(EstimateFrictionLoop, BoundEveryTickWithoutAllocationEqualToOffline) {
  const System sys = friction_scene();
  Eigen::VectorXd v_moving = sys.v0;
  for (int i = 0; i < sys.model.nv(); ++i) v_moving[i] = 0.05 * ((i % 3) + 1) * (i % 2 ? -1 : 1);
  const auto dof = [&](const char* n) {
    return static_cast<int>(std::find(sys.model.v_names.begin(), sys.model.v_names.end(), n) - sys.model.v_names.begin());
  };
  const int rest1 = dof("arm1.q2"), rest2 = dof("arm2.q2");
  ASSERT_LT(rest2, sys.model.nv());
  v_moving = closing_with_rest(sys, v_moving, {rest1, rest2});  // joint 2 of each arm at rest
  const Eigen::VectorXd tau = some_torque(sys, 3, 0.2);
  for (bool compensate : {true, false}) {
    SCOPED_TRACE(compensate ? "compensated" : "ignored");
    runtime::ServiceConfig cfg;
    cfg.mode = runtime::ServiceMode::kEstimate;
    cfg.compensate_joint_losses = compensate;
    FakeBus bus;
    runtime::ServiceLoop loop(sys, cfg, bus);
    long allocations = 0;
    const long long ms = 1000000;
    for (int k = 0; k < 600; ++k) {
      if (k % 5 == 0) {  // fresh states (outside the count): at rest, then moving
        const Eigen::VectorXd& v = (k / 100) % 2 ? v_moving : sys.v0;
        const auto st = io::encode_measured_state(runtime::realtime_us(), k, {}, stdvec(sys.q0), {}, stdvec(v), stdvec(tau));
        loop.states().offer(st.data(), static_cast<int>(st.size()), k * ms);
      }
      AllocationCounter c;
      loop.tick(k * ms);
      allocations += c.count();
      if (k == 550 || k == 450) {  // at rest (450), moving (550): the output against offline
        const io::DecodedOutput o = bus.last_output();
        ASSERT_NE(o.status, static_cast<int>(Status::kError)) << o.reason;
        EXPECT_EQ(o.joint_losses, static_cast<int>(compensate ? io::JointLosses::kCompensated : io::JointLosses::kIgnored));
        Workspace ws(sys);
        if (!compensate) ws.ignore_joint_losses();
        WrenchData wd(sys);
        FrictionBoundData fb(sys);
        evaluate(sys, ws, vec(o.q), vec(o.v), vec(o.tau));
        compute_wrenches(sys, ws, wd);
        compute_friction_bound(sys, ws, fb);
        EXPECT_EQ(o.friction_resting, compensate ? fb.resting : 0);
        if (compensate) {
          EXPECT_EQ(fb.resting, k == 450 ? 12 : 2);
        }
        double bmax = 0;
        for (size_t t = 0; t < o.wrench.size(); ++t)
          for (int i = 0; i < 6; ++i) {
            EXPECT_NEAR(o.wrench[t][i], wd.W[t][i], 1e-9 * (1.0 + std::abs(wd.W[t][i])));
            EXPECT_NEAR(o.wrench_bound[t][i], compensate ? fb.bound[t][i] : 0.0, 1e-9 * (1.0 + fb.bound[t][i]));
            bmax = std::max(bmax, o.wrench_bound[t][i]);
          }
        if (compensate) {
          EXPECT_GT(bmax, 1.0);
        } else {
          EXPECT_EQ(bmax, 0.0);
        }
      }
    }
    if (kCountingAvailable) {
      EXPECT_EQ(allocations, 0);
    }
  }
}
