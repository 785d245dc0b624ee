// Joint damping and Coulomb friction (Joint::damping, Joint::friction): the viscous force -b v, and
// the set-valued friction solved exactly (friction_lcp.h): stuck at rest while the bound holds
// (vdot exactly 0), sliding with the bound against the motion otherwise.
#include <gtest/gtest.h>

#include <cmath>

#include "service/dynamics/friction_lcp.h"
#include "service/dynamics/holding_torque.h"
#include "service/dynamics/integrators.h"
#include "service/dynamics/wrenches.h"
#include "service/scene/scene.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

namespace {
// One link on a revolute joint about z, its centre of mass on the axis, I_zz = 0.05 kg m^2. With
// `horizontal`, the axis is y and the centre of mass 0.2 m out along x (a pendulum under gravity,
// I_yy about the axis = 0.05 with the 1 kg at 0.2 m: 0.01 + 0.04).
std::string pendulum(const std::string& joint_extra, bool horizontal = false) {
  const std::string axis = horizontal ? "[0, 1, 0]" : "[0, 0, 1]";
  return "name: pendulum\ngravity: [0, 0, -9.81]\nformulation: classic\nbodies:\n"
         "  - name: link\n    parent: world\n"
         "    joint: {type: revolute, axis: " + axis + ", name: q" + joint_extra + "}\n"
         "    mass: 1\n" +
         (horizontal ? std::string("    com: [0.2, 0, 0]\n    inertia: [0.01, 0.01, 0.01, 0, 0, 0]\n")
                     : std::string("    com: [0, 0, 0]\n    inertia: [0.05, 0.05, 0.05, 0, 0, 0]\n"));
}
Eigen::VectorXd vec1(double x) { return Eigen::VectorXd::Constant(1, x); }
}  // namespace

TEST(Friction, DampingTwoAtOneRadPerSecondDeceleratesAtForty) {
  const System sys = load_scene_string(pendulum(", damping: 2, v: 1"), "pendulum.yaml");
  ASSERT_EQ(sys.model.nv(), 1);
  Workspace ws(sys);
  evaluate(sys, ws, sys.q0, sys.v0, vec1(0.0));
  EXPECT_NEAR(ws.vdot[0], -40.0, 1e-12);  // -b v / I = -2 / 0.05
  EXPECT_EQ(ws.tau_loss[0], -2.0);
  evaluate(sys, ws, sys.q0, vec1(-0.5), vec1(0.3));  // (0.3 + 1) / 0.05
  EXPECT_NEAR(ws.vdot[0], 26.0, 1e-12);
}

TEST(Friction, StictionHoldsWithinTheBoundAndSlidesBeyondIt) {
  const System sys = load_scene_string(pendulum(", friction: 1"), "pendulum.yaml");
  Workspace ws(sys);
  ASSERT_EQ(ws.friction_dofs.size(), 1u);
  for (double tau : {0.5, -0.5, 1.0, 0.0}) {
    evaluate(sys, ws, sys.q0, vec1(0.0), vec1(tau));
    EXPECT_EQ(ws.vdot[0], 0.0) << tau;  // stuck: exactly at rest
    EXPECT_NEAR(ws.tau_loss[0], -tau, 1e-15) << tau;
    EXPECT_EQ(ws.friction_stuck, 1);
    EXPECT_TRUE(ws.friction_converged);
  }
  evaluate(sys, ws, sys.q0, vec1(0.0), vec1(1.5));
  EXPECT_NEAR(ws.vdot[0], 10.0, 1e-12);  // (1.5 - 1) / 0.05
  EXPECT_EQ(ws.tau_loss[0], -1.0);
  EXPECT_EQ(ws.friction_stuck, 0);
  evaluate(sys, ws, sys.q0, vec1(0.0), vec1(-1.5));
  EXPECT_NEAR(ws.vdot[0], -10.0, 1e-12);
  // moving: the bound against the velocity, whatever the torque
  evaluate(sys, ws, sys.q0, vec1(0.1), vec1(0.5));
  EXPECT_NEAR(ws.vdot[0], -10.0, 1e-12);  // (0.5 - 1) / 0.05
  evaluate(sys, ws, sys.q0, vec1(-0.1), vec1(0.5));
  EXPECT_NEAR(ws.vdot[0], 30.0, 1e-12);
}

TEST(Friction, EnergyOfADampedPendulumDecreasesAtBTimesVSquared) {
  // released at 1 rad under gravity, b = 0.3: E(T) - E(0) = -int b v^2 dt (the integral by
  // Simpson's rule over the RK4 steps' end points, both to the integrator's accuracy)
  const double b = 0.3, dt = 1e-3;
  const System sys = load_scene_string(pendulum(", damping: 0.3, q: 1", true), "pendulum.yaml");
  Stepper st(sys);
  Eigen::VectorXd q = sys.q0, v = sys.v0;
  const double E0 = energy(sys, q, v);
  std::vector<double> p = {b * v[0] * v[0]};
  for (int i = 0; i < 2000; ++i) {
    ASSERT_EQ(step(sys, st, Integrator::kRk4, dt, vec1(0.0), q, v).status, Status::kOk);
    p.push_back(b * v[0] * v[0]);
  }
  double work = p.front() + p.back();
  for (size_t i = 1; i + 1 < p.size(); ++i) work += (i % 2 ? 4.0 : 2.0) * p[i];
  work *= dt / 3.0;
  const double dE = energy(sys, q, v) - E0;
  // the run is one where the damping matters (it took a good share of the energy: an identity
  // between a vanishing loss and a vanishing work would prove nothing), then the identity
  EXPECT_GT(work, 0.1 * std::abs(E0));
  EXPECT_NEAR(dE, -work, 1e-8 * work);
}

TEST(Friction, ASlidingJointStopsAtRestAndSticks) {
  // v0 = 2 rad/s against friction 1 N m under 0.5 N m: -10 rad/s^2 until it stops at t = 0.2 s,
  // after q = v0^2 / 20 = 0.2 rad; then 0.5 N m < 1 N m holds it, v exactly 0 from then on
  const System sys = load_scene_string(pendulum(", friction: 1, v: 2"), "pendulum.yaml");
  Stepper st(sys);
  Eigen::VectorXd q = sys.q0, v = sys.v0;
  for (int i = 0; i < 500; ++i) ASSERT_NE(step(sys, st, Integrator::kRk4, 1e-3, vec1(0.5), q, v).status, Status::kError);
  EXPECT_EQ(v[0], 0.0);
  EXPECT_NEAR(q[0], 0.2, 2e-3);  // the step in which it stops is cut at its end
  EXPECT_EQ(st.ws.vdot[0], 0.0);
}

TEST(Friction, AJointBreakingAwayFromRestStepsAlikeWhateverTheSignOfItsRoundOffVelocity) {
  // At rest with a velocity of round-off size (well below the 1e-9 rad/s rest threshold) and 1.5 N m
  // against a 1 N m bound: it breaks away at 10 rad/s^2 whichever sign that velocity has. The sign
  // of a resting joint's velocity says nothing; the step must not read it as a reversal and stop the
  // joint (it once did, which made a breakaway depend on the processor's round-off).
  const System sys = load_scene_string(pendulum(", friction: 1"), "pendulum.yaml");
  for (Integrator integ : {Integrator::kRk4, Integrator::kSemiImplicitEuler}) {
    Eigen::VectorXd v_end[2];
    for (int k = 0; k < 2; ++k) {
      Stepper st(sys);
      Eigen::VectorXd q = sys.q0, v = vec1(k == 0 ? 4e-16 : -4e-16);
      ASSERT_NE(step(sys, st, integ, 1e-3, vec1(1.5), q, v).status, Status::kError);
      v_end[k] = v;
    }
    EXPECT_NEAR(v_end[0][0], 10.0 * 1e-3, 1e-12) << static_cast<int>(integ);
    EXPECT_NEAR(v_end[1][0], v_end[0][0], 1e-15) << static_cast<int>(integ);
  }
}

TEST(Friction, BoxProblemMeetsCoulombsConditions) {
  // a 3-joint problem by hand: A = diag-dominant, bounds 1; b chosen so joint 0 sticks, joint 1
  // slides, joint 2 sticks (the conditions checked directly)
  FrictionLcp lcp(3);
  lcp.A << 4, 1, 0, 1, 3, 1, 0, 1, 2;
  lcp.b << 2, -9, 0.5;
  lcp.bound << 1, 1, 1;
  lcp.solve(3);
  ASSERT_TRUE(lcp.converged);
  EXPECT_EQ(lcp.state[1], 1);  // needs +3 > 1: at +F, accelerating in -
  EXPECT_EQ(lcp.f[1], 1.0);
  EXPECT_LT(lcp.a[1], 0.0);
  for (int i : {0, 2}) {
    EXPECT_EQ(lcp.state[i], 0);
    EXPECT_NEAR(lcp.a[i], 0.0, 1e-14);
    EXPECT_LE(std::abs(lcp.f[i]), 1.0);
  }
  // by hand: f1 = 1; 4 f0 + 1 + 2 = 0 -> f0 = -0.75; 1 + 2 f2 + 0.5 = 0 -> f2 = -0.75
  EXPECT_NEAR(lcp.f[0], -0.75, 1e-15);
  EXPECT_NEAR(lcp.f[2], -0.75, 1e-15);
  EXPECT_NEAR(lcp.a[1], -9 - 0.75 + 3 - 0.75, 1e-14);
  // a locked joint (zero column): its force indeterminate, minimum norm 0, counted
  FrictionLcp z(2);
  z.A << 2, 0, 0, 0;
  z.b << 1, 0;
  z.bound << 1, 1;
  z.solve(2);
  EXPECT_TRUE(z.converged);
  EXPECT_EQ(z.indeterminate, 1);
  EXPECT_EQ(z.f[1], 0.0);
  EXPECT_NEAR(z.f[0], -0.5, 1e-15);
}

namespace {
// Coulomb's law at every resting friction joint of an evaluation at rest: stuck (vdot 0, |f| <= F)
// or sliding with f = -F sign(vdot).
void expect_coulomb(const Workspace& ws) {
  for (int d : ws.friction_dofs) {
    const double f = ws.tau_loss[d], F = ws.friction[d];
    if (ws.vdot[d] == 0.0) {
      EXPECT_LE(std::abs(f), F * (1 + 1e-12)) << d;
    } else {
      EXPECT_NEAR(std::abs(f), F, 1e-12 * F) << d;
      EXPECT_LT(f * ws.vdot[d], 0.0) << d;
    }
  }
}
// component of output `name` along its joint's axis (z of the DH link frame: the moment's third)
double axial(const System& sys, const WrenchData& wd, const std::string& name) {
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k)
    if (sys.wrenches.outputs[k].name == name) return wd.W[k][2];
  ADD_FAILURE() << name;
  return 0.0;
}
}  // namespace

TEST(Friction, TwoArmsHoldTheirLoadByStictionAndLetGoBeyondIt) {
  // two PUMAs carrying a box (classic form), 2 N m of friction at every joint, held at rest by
  // the holding torques plus a perturbation of up to 1 N m per joint: friction can take all of it,
  // so nothing moves. 300 N m more at arm1.q2 is beyond what the loop's friction can hold: the
  // load moves, and every joint obeys Coulomb's law.
  System sys = load_with_reactions("two_puma_load", Formulation::kClassic);
  for (Body& b : sys.model.bodies)
    if (b.joint.nv == 1 && !b.joint.pseudo && b.name.rfind("arm", 0) == 0) b.joint.friction = 2.0;
  Workspace ws(sys);
  ASSERT_EQ(ws.friction_dofs.size(), 12u);
  HoldWorkspace hw(sys, default_actuated(sys));
  Eigen::VectorXd tau(sys.model.nv());
  ASSERT_TRUE(holding_torque(sys, hw, sys.q0, sys.v0, tau));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int d : ws.friction_dofs) tau[d] += u(rng);
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(sys.model.nv());
  ASSERT_NE(evaluate(sys, ws, sys.q0, v0, tau).status, Status::kError);
  EXPECT_TRUE(ws.friction_converged);
  EXPECT_EQ(ws.friction_stuck, 12);
  EXPECT_EQ(ws.friction_indeterminate, 6);  // 12 stuck joints, a load of 6 DOFs: the loop's share is free
  EXPECT_LT(ws.vdot.cwiseAbs().maxCoeff(), 1e-9);
  expect_coulomb(ws);
  // the joint reactions show the friction taken: along the axis, tau + friction - armature vdot
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  for (int d : ws.friction_dofs)
    EXPECT_NEAR(axial(sys, wd, sys.model.v_names[d]), tau[d] + ws.tau_loss[d], 1e-9) << sys.model.v_names[d];

  const int j = velocity_index_of(sys, "arm1.q2");
  tau[j] += 300.0;
  ASSERT_NE(evaluate(sys, ws, sys.q0, v0, tau).status, Status::kError);
  EXPECT_TRUE(ws.friction_converged);
  EXPECT_GT(ws.vdot.cwiseAbs().maxCoeff(), 1.0);
  EXPECT_NE(ws.vdot[j], 0.0);
  EXPECT_EQ(ws.tau_loss[j], -2.0);  // sliding forward, the bound against it
  expect_coulomb(ws);
  compute_wrenches(sys, ws, wd);
  for (int d : ws.friction_dofs) {
    const double arm = sys.model.bodies[sys.model.dof_body[d]].joint.armature;
    EXPECT_NEAR(axial(sys, wd, sys.model.v_names[d]), tau[d] + ws.tau_loss[d] - arm * ws.vdot[d], 1e-9)
        << sys.model.v_names[d];
  }
}

TEST(Friction, UrdfDynamicsAreReadAndBadSceneValuesRefused) {
  const System sys = load("two_iiwa_load");  // iiwa14.urdf: <dynamics damping="0.5"/> at every joint
  EXPECT_TRUE(sys.warnings.empty()) << sys.warnings.front();
  int damped = 0;
  for (const Body& b : sys.model.bodies)
    if (b.joint.nv == 1 && b.name.rfind("arm", 0) == 0) {
      EXPECT_EQ(b.joint.damping, 0.5) << b.name;
      EXPECT_EQ(b.joint.friction, 0.0) << b.name;
      ++damped;
    }
  EXPECT_EQ(damped, 14);
  // scene keys: refused at their line when negative or not finite
  for (const std::string bad : {", damping: -1", ", friction: .nan", ", friction: .inf", ", damping: -0.1"}) {
    const std::string e = scene_error(pendulum(bad));
    EXPECT_NE(e.find("car.yaml:7:"), std::string::npos) << e;
    EXPECT_TRUE(e.find("must be a finite number >= 0") != std::string::npos || e.find("must be finite") != std::string::npos) << e;
  }
  const std::string e = scene_error(pendulum(", pseudo: true, friction: 1"));
  EXPECT_NE(e.find("car.yaml:7:"), std::string::npos) << e;
  EXPECT_NE(e.find("friction applies to a real revolute or prismatic joint"), std::string::npos) << e;
}
