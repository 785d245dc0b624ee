// The reference controller (clients/control/cooperative_controller.h) closed around the simulator offline,
// with the daemon's one-tick delay: the load follows the reference circle and the squeeze holds
// its set-point, within the torque limits.
#include <gtest/gtest.h>

#include <cmath>

#include "clients/control/cooperative_controller.h"
#include "service/dynamics/integrators.h"
#include "tests/support/test_util.h"

namespace coopdyn {
namespace {

TEST(CooperativeController, TracksTheCircleAndHoldsTheSqueeze) {
  const System sys = testing::load("two_puma_load");
  cli::TrackOptions opt;
  cli::CooperativeController ctl(sys, opt);
  Stepper st(sys);
  Eigen::VectorXd q = sys.q0, v = sys.v0, tau = Eigen::VectorXd::Zero(sys.model.nv());
  const double dt = 1e-3;
  double max_pos = 0, max_rot = 0, max_sq = 0, sum_pos2 = 0;
  int n = 0;
  WrenchData wd(sys);
  double s_meas = std::nan("");
  for (int k = 0; k < 5000; ++k) {
    const double t = k * dt;
    // the daemon: one step under the command it has (computed from the previous output)
    const Eigen::VectorXd q_pub = q, v_pub = v;
    const Diagnostics& d = step(sys, st, Integrator::kRk4, dt, tau, q, v);
    ASSERT_NE(d.status, Status::kError) << "t = " << t;
    compute_wrenches(sys, st.ws, wd);
    std::array<double, 6> e1, e2;
    for (int c = 0; c < 6; ++c) {
      e1[c] = wd.W[ctl.ee_output(0)][c];
      e2[c] = wd.W[ctl.ee_output(1)][c];
    }
    s_meas = ctl.squeeze(q_pub, e1, e2);
    // the controller: torques from the published state, applied from the next tick
    tau = ctl.compute(t, q_pub, v_pub, s_meas, dt);
    if (t > 1.5) {  // after the 1 s ramp and its transient
      max_pos = std::max(max_pos, ctl.position_error());
      max_rot = std::max(max_rot, ctl.orientation_error());
      max_sq = std::max(max_sq, std::abs(s_meas - opt.squeeze));
      sum_pos2 += ctl.position_error() * ctl.position_error();
      ++n;
    }
    EXPECT_FALSE(ctl.saturated()) << "t = " << t;
  }
  const double rms = std::sqrt(sum_pos2 / n);
  std::printf("tracking over 1.5..5 s: position error max %.3g m (rms %.3g), orientation max %.3g rad, squeeze max |s - %g| %.3g N\n",
              max_pos, rms, max_rot, opt.squeeze, max_sq);
  // measured 2.6e-6 m, 9.2e-6 rad, 1.1e-3 N: the model is exact here, only the delay remains
  EXPECT_LT(max_pos, 5e-5);
  EXPECT_LT(max_rot, 2e-4);
  EXPECT_LT(max_sq, 0.02);
}

}  // namespace
}  // namespace coopdyn
