// The holding torques (service/dynamics/holding_torque.h), the safe-torque policy `hold`.
#include <gtest/gtest.h>

#include <Eigen/QR>

#include <algorithm>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

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

// Every scene in config/scenes (the shipped ones: arms, the real robots with their URDF trees,
// the wheeled vehicles), and the real robots as the daemon loads them.
std::vector<std::string> shipped_scenes() {
  std::vector<std::string> v = all_scenes();
  for (const std::string& w : wheel_scenes()) v.push_back(w);
  v.push_back("pr2_box");
  v.push_back("tiago_pro_box");
  return v;
}

TEST(HoldingTorque, FactoredSolveIsTheSvdDefinitionOnEveryShippedScene) {
  // the loop's solve (h and G of its own evaluation, a pivoted Cholesky of Gs Gs^T and the Schur
  // complement of the unactuated rows) against the definition's two SVDs, at q0 and at random
  // states with velocities the constraints allow; where the residual says the system can be held,
  // the torques stop it: vdot = 0 at rest
  std::mt19937 rng(7);
  for (const std::string& name : shipped_scenes()) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    const int n = sys.model.nv();
    const bool wheel = std::find(wheel_scenes().begin(), wheel_scenes().end(), name) != wheel_scenes().end();
    HoldWorkspace hw(sys, default_actuated(sys));
    Workspace ws(sys);
    int factored = 0;
    double worst = 0;
    for (int k = 0; k < 6; ++k) {
      Eigen::VectorXd q = sys.q0, v = Eigen::VectorXd::Zero(n);
      if (k > 0) {
        random_state(sys, rng, 0.05, q, v);
        ASSERT_TRUE(begin_evaluation(sys, ws, q, Eigen::VectorXd::Zero(n)));
        v = k % 2 ? Eigen::VectorXd(0.3 * project_velocity(ws.cd.G, v)) : Eigen::VectorXd::Zero(n);
      }
      ASSERT_TRUE(begin_evaluation(sys, ws, q, v));
      Eigen::VectorXd tau(n), ref(n);
      ASSERT_TRUE(holding_torque(sys, hw, ws, tau));
      const bool fast = hw.factored;
      const double res = hw.residual;
      factored += fast;
      ASSERT_TRUE(holding_torque_svd(sys, hw, ws, ref));
      const double diff = (tau - ref).cwiseAbs().maxCoeff() / (1.0 + ref.cwiseAbs().maxCoeff());
      worst = std::max(worst, diff);
      // (the two solves round differently: 6e-10 relative at most over these states, the car's)
      EXPECT_LT(diff, 1e-9) << "state " << k << (fast ? " (factored)" : " (fallback)");
      EXPECT_NEAR(res, hw.residual, 1e-9 * (1.0 + ws.data.h.norm())) << "state " << k;
      for (int i = 0; i < n; ++i)
        if (std::find(hw.act.begin(), hw.act.end(), i) == hw.act.end()) {
          EXPECT_EQ(tau[i], 0.0) << sys.model.v_names[i];
        }
      // (the test's own evaluation of the torques: the accelerations vanish at rest; not asked of
      // the vehicles, whose compliant wheel rows and unactuated chassis are wheel_test.cc's)
      if (!wheel && v.isZero() && hw.residual < 1e-9 * (1.0 + ws.data.h.norm())) {
        Workspace we(sys);
        ASSERT_NE(evaluate(sys, we, q, v, tau).status, Status::kError);
        EXPECT_LT(we.vdot.cwiseAbs().maxCoeff(), 1e-8) << "state " << k << ": held, no acceleration";
      }
    }
    std::printf("%-20s %d of 6 states factored, largest difference from the SVDs %.2e (relative)\n", name.c_str(),
                factored, worst);
    if (name == "two_puma_load" || name == "pr2_box" || name == "tiago_pro_box" || name == "two_iiwa_load") {
      EXPECT_EQ(factored, 6) << "the loop's cheap path covers the arms and the real robots";
    }
  }
}

TEST(HoldingTorque, FallsBackToTheSvdsWhereTheActuatorsCannotHold) {
  // only three joints of one PUMA actuated: six motions to balance, three torques. The unactuated
  // columns of G (15 of them, 12 rows) cannot all be balanced, S is singular and the SVDs decide:
  // least squares, the residual says what is not held
  const System sys = load("two_puma_load");
  const int n = sys.model.nv();
  std::vector<unsigned char> act(static_cast<size_t>(n), 0);
  for (int i = 6; i < 9; ++i) act[static_cast<size_t>(i)] = 1;
  HoldWorkspace hw(sys, act);
  Eigen::VectorXd tau(n), ref(n);
  ASSERT_TRUE(holding_torque(sys, hw, sys.q0, sys.v0, tau));
  EXPECT_FALSE(hw.factored);
  const double res = hw.residual;
  EXPECT_GT(res, 1.0) << "N*m: not held";
  ASSERT_TRUE(holding_torque_svd(sys, hw, hw.ws, ref));
  EXPECT_EQ(tau, ref);
  EXPECT_EQ(res, hw.residual);
  // and with every joint actuated again, the factored path holds it
  HoldWorkspace all(sys, default_actuated(sys));
  ASSERT_TRUE(holding_torque(sys, all, sys.q0, sys.v0, tau));
  EXPECT_TRUE(all.factored);
  EXPECT_LT(all.residual, 1e-9);
}

TEST(HoldingTorque, EvaluationHalvesAndTheStepAfterThemAreEvaluateAndStepBitForBit) {
  // the loop's hold tick: begin_evaluation, the torque from it, finish_evaluation, step_evaluated;
  // a commanded tick: step(). Same numbers to the last bit (friction, wheels, locks included)
  std::mt19937 rng(11);
  for (const std::string& name : shipped_scenes()) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    const int n = sys.model.nv();
    HoldWorkspace hw(sys, default_actuated(sys));
    Stepper a(sys), b(sys);
    Eigen::VectorXd q, v;
    random_state(sys, rng, 0.02, q, v);
    ASSERT_TRUE(begin_evaluation(sys, a.ws, q, Eigen::VectorXd::Zero(n)));
    v = 0.1 * project_velocity(a.ws.cd.G, v);
    Eigen::VectorXd qa = q, va = v, qb = q, vb = v, tau(n);
    for (int k = 0; k < 3; ++k) {
      ASSERT_TRUE(begin_evaluation(sys, a.ws, qa, va));
      ASSERT_TRUE(holding_torque(sys, hw, a.ws, tau));
      const Diagnostics& da = finish_evaluation(sys, a.ws, va, tau);
      const Diagnostics& db = evaluate(sys, b.ws, qb, vb, tau);
      EXPECT_EQ(da.status, db.status);
      EXPECT_EQ(da.rank, db.rank);
      EXPECT_EQ(a.ws.vdot, b.ws.vdot);
      EXPECT_EQ(a.ws.lambda, b.ws.lambda);
      step_evaluated(sys, a, Integrator::kRk4, 1e-3, tau, qa, va);
      step(sys, b, Integrator::kRk4, 1e-3, tau, qb, vb);
      EXPECT_EQ(qa, qb);
      EXPECT_EQ(va, vb);
    }
  }
}

// The braking hold: at a moving state, the braking torque's accelerations are the hold's less v / T
// (both balance h along the free motions; the brake adds M (-v / T), and G (-v / T) = 0 for a
// closing v), on every arm scene; and mass_times is M v of crba's dense M.
TEST(HoldingTorque, BrakingAddsMinusVOverTToTheHoldsAccelerations) {
  for (const char* name : {"two_puma_load", "two_iiwa_load", "planar_arms_load"}) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    HoldWorkspace hw(sys, default_actuated(sys));
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-0.2, 0.2);
    Eigen::VectorXd v(sys.model.nv());
    for (Eigen::Index i = 0; i < v.size(); ++i) v[i] = u(rng);
    Workspace cw(sys);
    forward_kinematics(sys.model, cw.data, sys.q0, v);
    constraint_rows(sys.model, cw.data, sys.constraints, sys.q0, v, cw.cd);
    Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(cw.cd.G);
    v -= cod.solve(cw.cd.G * v);  // a closing velocity
    const double T = 0.1;
    Eigen::VectorXd th(sys.model.nv()), tb(sys.model.nv());
    ASSERT_TRUE(holding_torque(sys, hw, sys.q0, v, th));
    ASSERT_LT(hw.residual, 1e-8);
    ASSERT_TRUE(braking_torque(sys, hw, sys.q0, v, T, tb));
    ASSERT_LT(hw.residual, 1e-8);
    Workspace wh(sys), wb(sys);
    ASSERT_NE(evaluate(sys, wh, sys.q0, v, th).status, Status::kError);
    ASSERT_NE(evaluate(sys, wb, sys.q0, v, tb).status, Status::kError);
    const Eigen::VectorXd diff = wb.vdot - wh.vdot + v / T;
    EXPECT_LT(diff.cwiseAbs().maxCoeff(), 1e-7 * (1 + v.cwiseAbs().maxCoeff() / T)) << "rad/s^2";
    // M v from the path-compact rows equals the dense M's
    crba(sys.model, wb.data);
    Eigen::VectorXd Mv(sys.model.nv());
    mass_times(sys.model, wb.data, v, Mv);
    EXPECT_LT((Mv - wb.data.M * v).cwiseAbs().maxCoeff(), 1e-12 * (1 + (wb.data.M * v).cwiseAbs().maxCoeff()));
    // at rest the brake is the hold
    ASSERT_TRUE(braking_torque(sys, hw, sys.q0, Eigen::VectorXd::Zero(sys.model.nv()), T, tb));
    ASSERT_TRUE(holding_torque(sys, hw, sys.q0, Eigen::VectorXd::Zero(sys.model.nv()), th));
    EXPECT_LT((tb - th).cwiseAbs().maxCoeff(), 1e-9);
  }
}

}  // namespace
}  // namespace coopdyn::testing
