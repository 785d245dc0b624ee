// Kinematics and Jacobians against finite differences, on every joint type and every scene.
#include <gtest/gtest.h>

#include "service/algorithms/jacobians.h"
#include "service/algorithms/kinematics.h"
#include "tests/support/every_joint_model.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

namespace {

// Checks J_F v against the finite-difference body twist of the frame, and Jdot v against the
// finite difference of J(q(t)) v along q(t) = q (+) t v.
void check_frame(const Model& m, int f, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  Data d(m);
  forward_kinematics(m, d, q, v);
  Eigen::Matrix<double, 6, Eigen::Dynamic> J = Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, m.nv());
  frame_jacobian(m, d, f, m.frame_support(f), J);
  const Vec6 Jv = J * v;
  EXPECT_LT((Jv - frame_velocity(m, d, f)).norm(), 1e-12);
  const double eps = 1e-6;
  Eigen::VectorXd qp(m.nq()), qm(m.nq());
  integrate(m, q, v, eps, qp);
  integrate(m, q, v, -eps, qm);
  Data dp(m), dm(m);
  forward_kinematics(m, dp, qp, v);
  forward_kinematics(m, dm, qm, v);
  const Transform Xp = frame_pose(m, dp, f), Xm = frame_pose(m, dm, f);
  // body twist of F, second order in eps: the rotation vector of R(q-)^T R(q+), and the rate of the
  // origin in F's axes (pose_error's translation is not the SE(3) log: its error is first order in
  // eps |w| |v|, 1e-5 on the 7-joint chains of two_iiwa_load)
  const Transform X0 = frame_pose(m, d, f);
  Vec6 twist;
  twist.head<3>() = log_so3(Xm.R.transpose() * Xp.R) / (2 * eps);
  twist.tail<3>() = X0.R.transpose() * (Xp.p - Xm.p) / (2 * eps);
  EXPECT_LT((twist - Jv).norm(), 1e-6 * (1 + Jv.norm())) << "frame " << m.frames[f].name;
  const Vec6 Vp = frame_velocity(m, dp, f), Vm = frame_velocity(m, dm, f);
  const Vec6 jdotv_fd = (Vp - Vm) / (2 * eps);
  const Vec6 jdotv = frame_bias_acceleration(m, d, f);
  EXPECT_LT((jdotv_fd - jdotv).norm(), 1e-5 * (1 + jdotv.norm())) << "frame " << m.frames[f].name;
}

}  // namespace

TEST(Kinematics, FrameJacobianAndJdotVMatchFiniteDifferencesOnEveryJointType) {
  const Model m = every_joint_model();
  std::mt19937 rng(7);
  for (int k = 0; k < 10; ++k) {
    Eigen::VectorXd q, v;
    random_qv(m, rng, q, v);
    for (int f = 0; f < static_cast<int>(m.frames.size()); ++f) check_frame(m, f, q, v);
  }
}

TEST(Kinematics, FrameJacobiansMatchFiniteDifferencesOnEveryScene) {
  std::mt19937 rng(8);
  for (const auto& name : all_scenes()) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    for (int k = 0; k < 3; ++k) {
      Eigen::VectorXd q, v;
      random_state(sys, rng, 0.3, q, v);
      for (int f = 0; f < static_cast<int>(sys.model.frames.size()); ++f) check_frame(sys.model, f, q, v);
    }
  }
}

// forward_kinematics_subtree: after the kinematics at one state, redoing a subtree at a state that
// differs in the subtree's joints only gives every entry of the whole pass at the new state,
// bit for bit (the same operations on the same inputs), on every body of the every-joint model.
TEST(Kinematics, SubtreePassEqualsTheWholePass) {
  const Model m = every_joint_model();
  std::mt19937 rng(11);
  Eigen::VectorXd q0, v0, q1, v1;
  random_qv(m, rng, q0, v0);
  random_qv(m, rng, q1, v1);
  Data whole(m), part(m);
  int compared = 0;
  for (int root = 1; root < m.nbodies(); ++root) {
    Eigen::VectorXd q = q0, v = v0;  // the subtree's joints from (q1, v1)
    for (int i = root; i < m.nbodies(); ++i) {
      if (!m.is_ancestor(root, i)) continue;
      const Joint& j = m.bodies[i].joint;
      q.segment(j.idx_q, j.nq) = q1.segment(j.idx_q, j.nq);
      v.segment(j.idx_v, j.nv) = v1.segment(j.idx_v, j.nv);
    }
    forward_kinematics(m, part, q0, v0);
    forward_kinematics_subtree(m, part, q, v, root);
    forward_kinematics(m, whole, q, v);
    EXPECT_EQ(part.p_ref, whole.p_ref);
    EXPECT_EQ(part.S_W, whole.S_W) << root;
    for (int i = 0; i < m.nbodies(); ++i) {
      EXPECT_EQ(part.X_WB[i].R, whole.X_WB[i].R) << root << " " << i;
      EXPECT_EQ(part.X_WB[i].p, whole.X_WB[i].p) << root << " " << i;
      EXPECT_EQ(part.V_W[i], whole.V_W[i]) << root << " " << i;
      EXPECT_EQ(part.A0_W[i], whole.A0_W[i]) << root << " " << i;
      if (part.has_inertia[i]) {
        EXPECT_EQ(part.I_W[i].Io, whole.I_W[i].Io) << root << " " << i;
      }
    }
    compared += (q != q0);
  }
  EXPECT_GT(compared, 3);
}
