// Kinematics and Jacobians against finite differences, on every joint type and every scene.
#include <limits>

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

// The joint placements forward_kinematics takes by their form (Body::placement_rotation: the
// identity, a rotation about x as a Denavit-Hartenberg twist, any rotation; and a zero offset)
// skip only products by exact zeros: each joint frame equals the parent's pose times the
// placement by the general product, to round-off (4 eps: entries of rotations, offsets under 1 m).
// In the Release build the two agree bit for bit (the golden outputs are byte-identical to the
// build before the forms); at other optimization levels the compiler may fuse a multiply-add in
// one and not the other, a last-bit difference. A product skipped that was not zero errs by the
// size of an entry. A chain of welds, so that X_WB is X_WJ.
TEST(Kinematics, PlacementFormsGiveTheGeneralProduct) {
  auto about_x = [](double c, double s) {
    Mat3 R;
    R << 1, 0, 0, 0, c, -s, 0, s, c;
    return R;
  };
  const double half_pi = 1.5707963267948966;  // as the DH tables write it: cos gives 6.1e-17, not 0
  const std::vector<std::pair<Transform, PlacementRotation>> placements = {
      {Transform(about_x(std::cos(half_pi), std::sin(half_pi)), Vec3(0.4318, 0, 0)), PlacementRotation::kAboutX},
      {Transform(Mat3::Identity(), Vec3::Zero()), PlacementRotation::kIdentity},
      {Transform(about_x(std::cos(-half_pi), std::sin(-half_pi)), Vec3::Zero()), PlacementRotation::kAboutX},
      {Transform(exp_so3(Vec3(0.3, -0.7, 0.2)), Vec3(0.1, -0.2, 0.05)), PlacementRotation::kGeneral},
      {Transform(about_x(std::cos(0.3), std::sin(0.3)), Vec3(0, 0.15005, 0.02)), PlacementRotation::kAboutX},
      {Transform(Mat3::Identity(), Vec3(-0.0203, 0, 0.1)), PlacementRotation::kIdentity},
  };
  Model m;
  Joint fl;
  fl.type = JointType::kFloating;
  int parent = m.add_body("base", -1, Transform(), fl, Inertia(2.0, Vec3(0.1, 0, 0), Mat3::Identity() * 0.1));
  for (size_t k = 0; k < placements.size(); ++k) {
    Joint fx;
    fx.type = JointType::kFixed;
    parent = m.add_body("w" + std::to_string(k), parent, placements[k].first, fx,
                        Inertia(0.5, Vec3(0, 0.1, 0), Mat3::Identity() * 0.01));
    EXPECT_EQ(m.bodies[parent].placement_rotation, placements[k].second) << k;
    EXPECT_EQ(m.bodies[parent].placement_at_origin, placements[k].first.p.isZero(0.0)) << k;
  }
  std::mt19937 rng(3);
  for (int trial = 0; trial < 4; ++trial) {
    Eigen::VectorXd q, v;
    random_qv(m, rng, q, v);
    Data d(m);
    forward_kinematics(m, d, q, v);
    for (int i = 1; i < m.nbodies(); ++i) {
      const Transform& X_WP = d.X_WB[m.bodies[i].parent];
      const Transform& X_PJ = m.bodies[i].X_PJ;
      Mat3 R;
      R.noalias() = X_WP.R * X_PJ.R;
      Vec3 p;
      p.noalias() = X_WP.R * X_PJ.p;
      p += X_WP.p;
      constexpr double tol = 4 * std::numeric_limits<double>::epsilon();
      EXPECT_LE((d.X_WB[i].R - R).cwiseAbs().maxCoeff(), tol) << i;
      EXPECT_LE((d.X_WB[i].p - p).cwiseAbs().maxCoeff(), tol) << i;
    }
  }
}
