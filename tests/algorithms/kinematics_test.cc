// Kinematics and Jacobians against finite differences, on every joint type and every scene.
#include <gtest/gtest.h>

#include "service/algorithms/jacobians.h"
#include "service/algorithms/kinematics.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

namespace {

// A tree with every joint type: floating root, revolute, prismatic, revolute2, fixed, two branches.
Model every_joint_model() {
  Model m;
  auto I = [](double mass) { return Inertia(mass, Vec3(0.1, -0.05, 0.2), Vec3(0.02, 0.03, 0.04).asDiagonal()); };
  Joint fl;
  fl.type = JointType::kFloating;
  fl.name = "base";
  const int b = m.add_body("base", -1, Transform(), fl, I(3.0));
  Joint r;
  r.type = JointType::kRevolute;
  r.axis = Vec3(0.3, -0.2, 1.0);
  r.name = "r1";
  const int a1 = m.add_body("a1", b, Transform(exp_so3(Vec3(0.1, 0.2, 0.3)), Vec3(0.2, 0.1, 0)), r, I(1.0));
  Joint p;
  p.type = JointType::kPrismatic;
  p.axis = Vec3(1, 0.5, 0);
  p.name = "p1";
  const int a2 = m.add_body("a2", a1, Transform(exp_so3(Vec3(-0.2, 0.1, 0)), Vec3(0.3, 0, 0.1)), p, I(0.7));
  Joint r2;
  r2.type = JointType::kRevolute2;
  r2.axis = Vec3::UnitZ();
  r2.axis2 = Vec3::UnitX();
  r2.name = "u1";
  const int a3 = m.add_body("a3", a2, Transform(Mat3::Identity(), Vec3(0, 0.2, 0)), r2, I(0.5));
  Joint fx;
  fx.type = JointType::kFixed;
  const int a4 = m.add_body("a4", a3, Transform(exp_so3(Vec3(0, 0, 0.5)), Vec3(0.1, 0.1, 0.1)), fx, I(0.2));
  Joint rb;
  rb.type = JointType::kRevolute;
  rb.axis = Vec3::UnitY();
  rb.name = "b1";
  const int c1 = m.add_body("c1", b, Transform(Mat3::Identity(), Vec3(-0.3, 0, 0)), rb, I(1.2));
  m.add_frame("tip_a", a4, Transform(exp_so3(Vec3(0.3, 0, 0.1)), Vec3(0.05, 0.02, -0.1)));
  m.add_frame("tip_c", c1, Transform(Mat3::Identity(), Vec3(0.4, 0, 0)));
  m.add_frame("tip_u", a3, Transform());
  return m;
}

void random_qv(const Model& m, std::mt19937& rng, Eigen::VectorXd& q, Eigen::VectorXd& v) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Eigen::VectorXd dv(m.nv());
  for (int i = 0; i < m.nv(); ++i) dv[i] = U(rng);
  q.resize(m.nq());
  integrate(m, m.neutral(), dv, 1.0, q);
  v.resize(m.nv());
  for (int i = 0; i < m.nv(); ++i) v[i] = U(rng);
}

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

TEST(Kinematics, IntegrateFollowsTheVelocity) {
  // q(t) = q (+) t v has qdot = q_derivative(q, v) at t = 0 (embedding coordinates)
  const Model m = every_joint_model();
  std::mt19937 rng(9);
  Eigen::VectorXd q, v;
  random_qv(m, rng, q, v);
  Eigen::VectorXd qp(m.nq()), qm(m.nq()), qd(m.nq());
  const double eps = 1e-6;
  integrate(m, q, v, eps, qp);
  integrate(m, q, v, -eps, qm);
  q_derivative(m, q, v, qd);
  EXPECT_LT(((qp - qm) / (2 * eps) - qd).norm(), 1e-7);
}

TEST(Kinematics, ConstraintRowsAndTheirDerivativeMatchFiniteDifferences) {
  // G v is the constraint velocity and Gdot v its derivative along the motion, for welds to the
  // world (arms) and between frames (the four-bar cut)
  std::mt19937 rng(10);
  for (const auto& name : all_scenes()) {
    SCOPED_TRACE(name);
    for (auto f : {Formulation::kMobilePlatform, Formulation::kClassic}) {
      if (name == "four_bar" && f == Formulation::kMobilePlatform) continue;
      const System sys = load(name, f);
      const Model& m = sys.model;
      Eigen::VectorXd q, v;
      random_state(sys, rng, 0.3, q, v);
      Data d(m);
      ConstraintData cd(m, sys.constraints);
      forward_kinematics(m, d, q, v);
      constraint_rows(m, d, sys.constraints, q, v, cd);
      const Eigen::VectorXd Gv = cd.G * v;
      EXPECT_LT((Gv - cd.Gv).norm(), 1e-10);
      const double eps = 1e-6;
      Eigen::VectorXd qp(m.nq()), qm(m.nq());
      integrate(m, q, v, eps, qp);
      integrate(m, q, v, -eps, qm);
      Data dp(m), dm(m);
      ConstraintData cp(m, sys.constraints), cm(m, sys.constraints);
      forward_kinematics(m, dp, qp, v);
      forward_kinematics(m, dm, qm, v);
      constraint_rows(m, dp, sys.constraints, qp, v, cp);
      constraint_rows(m, dm, sys.constraints, qm, v, cm);
      const Eigen::VectorXd gdot_fd = (cp.G * v - cm.G * v) / (2 * eps);
      EXPECT_LT((gdot_fd - cd.Gdot_v).norm(), 1e-5 * (1 + cd.Gdot_v.norm()));
      // at the initial state (zero error) the position error moves with G v
      Eigen::VectorXd q0p(m.nq()), q0m(m.nq());
      integrate(m, sys.q0, v, eps, q0p);
      integrate(m, sys.q0, v, -eps, q0m);
      forward_kinematics(m, dp, q0p, v);
      forward_kinematics(m, dm, q0m, v);
      constraint_rows(m, dp, sys.constraints, q0p, v, cp);
      constraint_rows(m, dm, sys.constraints, q0m, v, cm);
      forward_kinematics(m, d, sys.q0, v);
      constraint_rows(m, d, sys.constraints, sys.q0, v, cd);
      const Eigen::VectorXd edot_fd = (cp.err - cm.err) / (2 * eps);
      EXPECT_LT((edot_fd - cd.G * v).norm(), 1e-6 * (1 + v.norm()));
    }
  }
}
