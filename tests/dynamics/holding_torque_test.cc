// The holding torques (service/dynamics/holding_torque.h), the safe-torque policy `hold`.
#include <gtest/gtest.h>

#include <Eigen/QR>

#include "service/dynamics/holding_torque.h"
#include "service/dynamics/integrators.h"
#include "service/dynamics/wrenches.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {

double total_weight(const Model& m) {
  double w = 0;
  for (const Body& b : m.bodies) w += b.inertia.m * m.gravity_W.norm();
  return w;
}

TEST(HoldingTorque, HoldsTwoPumasStillAndTheBasesCarryTheWeight) {
  const System sys = load("two_puma_load");
  const std::vector<unsigned char> act = default_actuated(sys);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(act[i], 0) << "the load's platform DOFs are not actuated";
  HoldWorkspace hw(sys, act);
  Eigen::VectorXd tau(sys.model.nv());
  ASSERT_TRUE(holding_torque(sys, hw, sys.q0, sys.v0, tau));
  EXPECT_LT(hw.residual, 1e-9);
  for (int i = 6; i < sys.model.nv(); ++i)
    EXPECT_LE(std::abs(tau[i]), sys.tau_limit[i]) << sys.model.v_names[i] << ": within the PUMA's torque limit";
  for (int i = 0; i < 6; ++i) EXPECT_EQ(tau[i], 0.0);
  Workspace ws(sys);
  ASSERT_NE(evaluate(sys, ws, sys.q0, sys.v0, tau).status, Status::kError);
  EXPECT_LT(ws.vdot.cwiseAbs().maxCoeff(), 1e-9) << "held: no acceleration";
  // the bases carry exactly the weight of arms and box (world z up)
  const double fz = base_vertical_force(sys, ws);
  EXPECT_NEAR(fz, total_weight(sys.model), 1e-8 * total_weight(sys.model));
}

TEST(HoldingTorque, ClampedToTheLimitsAsTheDaemonAppliesIt) {
  // a joint whose limit is below what holding needs holds its limit and the system moves; the
  // others keep their holding torques (coopdynd's safe torque, `coopdyn eval --hold`)
  System sys = load("two_puma_load");
  HoldWorkspace hw(sys, default_actuated(sys));
  Eigen::VectorXd tau(sys.model.nv());
  ASSERT_TRUE(holding_torque(sys, hw, sys.q0, sys.v0, tau));
  Eigen::Index k = 0;
  tau.cwiseAbs().maxCoeff(&k);
  const Eigen::VectorXd held = tau;
  sys.tau_limit[k] = 0.5 * std::abs(held[k]);
  EXPECT_EQ(clamp_to_torque_limits(sys, hw, tau), 1);
  for (Eigen::Index i = 0; i < tau.size(); ++i)
    EXPECT_EQ(tau[i], i == k ? std::copysign(sys.tau_limit[k], held[k]) : held[i]) << sys.model.v_names[i];
  Workspace ws(sys);
  ASSERT_NE(evaluate(sys, ws, sys.q0, sys.v0, tau).status, Status::kError);
  EXPECT_GT(ws.vdot.cwiseAbs().maxCoeff(), 1e-3) << "half the torque it needs: " << sys.model.v_names[k] << " cannot hold";
}

TEST(HoldingTorque, IsTheLimitWeightedMinimumNormBalance) {
  // an independent solve: min |W^-1 tau_a| (W = the joints' torque limits) subject to
  // N^T (S_a^T tau_a - h) = 0, N from the kernel of G
  std::mt19937 rng(31);
  for (const std::string name : {"two_puma_load", "planar_arms_load", "two_5dof_arms_load"}) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    const int n = sys.model.nv();
    HoldWorkspace hw(sys, default_actuated(sys));
    Eigen::VectorXd q, v;
    random_state(sys, rng, 0.0, q, v);
    Workspace ws(sys);
    evaluate(sys, ws, q, Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n));
    v = 0.3 * project_velocity(ws.cd.G, v);
    Eigen::VectorXd tau(n);
    ASSERT_TRUE(holding_torque(sys, hw, q, v, tau));
    evaluate(sys, ws, q, v, Eigen::VectorXd::Zero(n));
    Eigen::FullPivLU<Eigen::MatrixXd> lu(ws.cd.G);
    const Eigen::MatrixXd N = lu.kernel().householderQr().householderQ() * Eigen::MatrixXd::Identity(n, lu.kernel().cols());
    Eigen::MatrixXd Sa = Eigen::MatrixXd::Zero(n, static_cast<Eigen::Index>(hw.act.size()));
    Eigen::VectorXd W(static_cast<Eigen::Index>(hw.act.size()));
    for (size_t c = 0; c < hw.act.size(); ++c) {
      Sa(hw.act[c], static_cast<Eigen::Index>(c)) = 1;
      W[static_cast<Eigen::Index>(c)] = std::isfinite(sys.tau_limit[hw.act[c]]) ? sys.tau_limit[hw.act[c]] : 1.0;
    }
    const Eigen::MatrixXd A = N.transpose() * Sa * W.asDiagonal();
    const Eigen::VectorXd ta = W.asDiagonal() * A.completeOrthogonalDecomposition().solve(N.transpose() * ws.data.h);
    EXPECT_LT((Sa * ta - tau).norm(), 1e-8 * (1 + tau.norm()));
    EXPECT_LT(hw.residual, 1e-8 * (1 + ws.data.h.norm()));
    // and it balances: with these torques the constrained accelerations vanish (v = 0 here)
    evaluate(sys, ws, q, Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n));
    ASSERT_TRUE(holding_torque(sys, hw, q, Eigen::VectorXd::Zero(n), tau));
    evaluate(sys, ws, q, Eigen::VectorXd::Zero(n), tau);
    EXPECT_LT(ws.vdot.cwiseAbs().maxCoeff(), 1e-8);
  }
}

TEST(HoldingTorque, TenSecondsOfHoldKeepTheLoadWithinAMicrometre) {
  // the safe torque recomputed at every step, RK4 at 1 ms for 10 s of simulated time
  const System sys = load("two_puma_load");
  HoldWorkspace hw(sys, default_actuated(sys));
  Stepper st(sys);
  Eigen::VectorXd q = sys.q0, v = sys.v0, tau(sys.model.nv());
  double drift = 0, qdrift = 0;
  for (int k = 0; k < 10000; ++k) {
    ASSERT_TRUE(holding_torque(sys, hw, q, v, tau));
    ASSERT_NE(step(sys, st, Integrator::kRk4, 1e-3, tau, q, v).status, Status::kError);
    drift = std::max(drift, (q.head<3>() - sys.q0.head<3>()).norm());
    qdrift = std::max(qdrift, (q.tail(12) - sys.q0.tail(12)).cwiseAbs().maxCoeff());
  }
  std::printf("hold, 10 s: load moved at most %.3g m, joints at most %.3g rad\n", drift, qdrift);
  EXPECT_LT(drift, 1e-6);
  EXPECT_LT(qdrift, 1e-6);
}

TEST(HoldingTorque, NothingToHoldOnAFreeRollingVehicle) {
  // on flat ground gravity does no work along the motions the wheels allow: no torque needed
  const System sys = load("two_wheel_vehicle");
  HoldWorkspace hw(sys, default_actuated(sys));
  Eigen::VectorXd tau(sys.model.nv());
  ASSERT_TRUE(holding_torque(sys, hw, sys.q0, sys.v0, tau));
  EXPECT_LT(tau.norm(), 1e-9);
  EXPECT_EQ(hw.act.size(), 2u) << "the two spin joints";
}

}  // namespace
}  // namespace coopdyn::testing
