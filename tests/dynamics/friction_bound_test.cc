// The interval of every reported wrench over the unknown Coulomb friction of the joints at rest
// (service/dynamics/friction_bound.h): a hand-calculated pendulum, and on two arms carrying a load
// the identity with frictionless evaluations (the estimate is the frictionless one under the
// stiction torques; the bound is the largest departure over the friction box, attained at a corner).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "service/dynamics/friction_bound.h"
#include "service/dynamics/sigma/wrench_sigma.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {

Eigen::VectorXd vec1(double x) { return Eigen::VectorXd::Constant(1, x); }

// two_puma_load with every joint reaction reported, and with Coulomb friction F on every real joint
System two_arms(double F) {
  System sys = load_scene_string(without_reactions(scene_text("two_puma_load")) + "\nreactions: all\n",
                                 scene_path("two_puma_load"));
  for (Body& b : sys.model.bodies)
    if (b.joint.nv == 1 && !b.joint.pseudo) b.joint.friction = F;
  return sys;
}

std::vector<Vec6> wrenches_at(const System& sys, Workspace& ws, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                              const Eigen::VectorXd& tau) {
  EXPECT_NE(evaluate(sys, ws, q, v, tau).status, Status::kError);
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  return wd.W;
}

}  // namespace

// One link on a vertical axis (no gravity torque), Coulomb bound 1 N m, at rest under 0.5 N m: the
// joint is stuck, the estimate takes the friction -0.5 N m that holds it, so the joint's reaction
// along its axis (the torque reaching the link) is 0. The friction could be anything in [-1, 1]:
// that torque is then 0.5 + f in [-0.5, 1.5], at most 1.5 from the reported 0.
TEST(FrictionBound, PendulumAtRestHandCalculated) {
  const System sys = load_scene_string(
      "name: pendulum\ngravity: [0, 0, -9.81]\nformulation: classic\nbodies:\n"
      "  - name: link\n    parent: world\n    joint: {type: revolute, axis: [0, 0, 1], name: q, friction: 1}\n"
      "    mass: 1\n    com: [0, 0, 0]\n    inertia: [0.05, 0.05, 0.05, 0, 0, 0]\nreactions: all\n",
      "pendulum.yaml");
  Workspace ws(sys);
  FrictionBoundData fb(sys);
  ASSERT_TRUE(fb.possible);
  ASSERT_EQ(sys.wrenches.outputs.size(), 1u);
  const std::vector<Vec6> w = wrenches_at(sys, ws, sys.q0, vec1(0.0), vec1(0.5));
  compute_friction_bound(sys, ws, fb);
  EXPECT_EQ(fb.resting, 1);
  EXPECT_NEAR(w[0][2], 0.0, 1e-14);           // moment about the joint's z axis
  EXPECT_NEAR(fb.bound[0][2], 1.5, 1e-12);    // |0 - 0.5| + 1 * 1
  EXPECT_NEAR(fb.bound[0][0], 0.0, 1e-12);    // the bearings' components do not move with f
  EXPECT_NEAR(fb.bound[0][5], 0.0, 1e-12);
  // moving: its friction is known from the velocity, nothing is left to bound
  wrenches_at(sys, ws, sys.q0, vec1(0.2), vec1(0.5));
  compute_friction_bound(sys, ws, fb);
  EXPECT_EQ(fb.resting, 0);
  EXPECT_EQ(fb.bound[0].norm(), 0.0);
}

// Two arms with friction 2 N m on every joint at rest under small torques: the reported wrenches are
// the frictionless ones under the stiction forces f*; the bound is |sum W_j f*_j| + sum |W_j| F_j
// with W_j the frictionless response to a unit torque at joint j (finite differences of whole
// evaluations, exact for an affine map); every draw of the friction in the box stays inside it and
// a corner reaches it.
TEST(FrictionBound, TwoArmsAtRestMatchTheFrictionlessSolveOverTheBox) {
  const double F = 2.0;
  const System sys = two_arms(F), plain = two_arms(0.0);
  Workspace ws(sys), wp(plain);
  FrictionBoundData fb(sys);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
  for (int i = 0; i < sys.model.nv(); ++i)
    if (sys.tau_limit[i] > 0 && std::isfinite(sys.tau_limit[i])) tau[i] = 1.5 * U(rng);
  const std::vector<Vec6> w = wrenches_at(sys, ws, sys.q0, sys.v0, tau);
  ASSERT_GT(ws.friction_stuck, 0);
  compute_friction_bound(sys, ws, fb);
  const int k = fb.resting;
  ASSERT_EQ(k, static_cast<int>(ws.friction_dofs.size()));
  Eigen::VectorXd fstar = Eigen::VectorXd::Zero(sys.model.nv());
  for (int j = 0; j < k; ++j) fstar[ws.rest_dofs[j]] = ws.lcp.f[j];
  const std::vector<Vec6> w_star = wrenches_at(plain, wp, plain.q0, plain.v0, tau + fstar);
  const std::vector<Vec6> w0 = wrenches_at(plain, wp, plain.q0, plain.v0, tau);
  const size_t no = w.size();
  double scale = 1.0;
  for (const Vec6& x : w) scale = std::max(scale, x.cwiseAbs().maxCoeff());
  for (size_t o = 0; o < no; ++o) EXPECT_LE((w[o] - w_star[o]).cwiseAbs().maxCoeff(), 1e-9 * scale) << o;
  std::vector<Vec6> half(no, Vec6::Zero());
  for (int j = 0; j < k; ++j) {
    Eigen::VectorXd t = tau;
    t[ws.rest_dofs[j]] += 1.0;
    const std::vector<Vec6> wj = wrenches_at(plain, wp, plain.q0, plain.v0, t);
    for (size_t o = 0; o < no; ++o) half[o] += F * (wj[o] - w0[o]).cwiseAbs();
  }
  for (size_t o = 0; o < no; ++o) {
    const Vec6 expect = (w_star[o] - w0[o]).cwiseAbs() + half[o];
    EXPECT_LE((fb.bound[o] - expect).cwiseAbs().maxCoeff(), 1e-8 * scale) << sys.wrenches.outputs[o].name;
  }
  // draws inside the box stay inside; the corner chosen for a component reaches its bound
  double reached = 0.0;
  for (int draw = 0; draw < 40; ++draw) {
    Eigen::VectorXd f = Eigen::VectorXd::Zero(sys.model.nv());
    for (int j = 0; j < k; ++j) f[ws.rest_dofs[j]] = F * (draw % 2 ? U(rng) : (U(rng) > 0 ? 1.0 : -1.0));
    const std::vector<Vec6> wf = wrenches_at(plain, wp, plain.q0, plain.v0, tau + f);
    for (size_t o = 0; o < no; ++o)
      for (int c = 0; c < 6; ++c) EXPECT_LE(std::abs(wf[o][c] - w[o][c]), fb.bound[o][c] + 1e-8 * scale);
  }
  const size_t o = 0;  // arm1's end-effector force along z: the corner opposite the offset
  Eigen::VectorXd f = Eigen::VectorXd::Zero(sys.model.nv());
  const double off = w_star[o][5] - w0[o][5];
  for (int j = 0; j < k; ++j) {
    Eigen::VectorXd t = tau;
    t[ws.rest_dofs[j]] += 1.0;
    const double Wj = wrenches_at(plain, wp, plain.q0, plain.v0, t)[o][5] - w0[o][5];
    f[ws.rest_dofs[j]] = (off >= 0 ? -F : F) * (Wj >= 0 ? 1.0 : -1.0);
  }
  reached = std::abs(wrenches_at(plain, wp, plain.q0, plain.v0, tau + f)[o][5] - w[o][5]);
  EXPECT_NEAR(reached, fb.bound[o][5], 1e-8 * scale);
  EXPECT_GT(fb.bound[o][5], 0.1);
}

// Without joint-loss compensation the workspace takes the torques as reaching the links: the
// frictionless evaluation exactly, nothing at rest to bound.
TEST(FrictionBound, IgnoringJointLossesIsTheFrictionlessEvaluation) {
  System sys = two_arms(2.0);
  for (Body& b : sys.model.bodies)
    if (b.joint.nv == 1 && !b.joint.pseudo) b.joint.damping = 0.7;
  const System plain = two_arms(0.0);
  Workspace ws(sys), wp(plain);
  ws.ignore_joint_losses();
  FrictionBoundData fb(sys);
  Eigen::VectorXd v = sys.v0, tau = Eigen::VectorXd::Zero(sys.model.nv());
  for (int i = 6; i < sys.model.nv(); ++i) v[i] = 0.1 * (i % 3);  // some at rest, some moving
  const std::vector<Vec6> w = wrenches_at(sys, ws, sys.q0, v, tau), w0 = wrenches_at(plain, wp, plain.q0, v, tau);
  for (size_t o = 0; o < w.size(); ++o) EXPECT_EQ(w[o], w0[o]) << o;
  compute_friction_bound(sys, ws, fb);
  EXPECT_EQ(fb.resting, 0);
}

}  // namespace coopdyn::testing
