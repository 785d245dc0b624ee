// A model with every joint type, and a random state of it.
#pragma once

#include <random>

#include <Eigen/Dense>

#include "service/model/model.h"

namespace coopdyn::testing {

// A tree with every joint type: floating root, revolute, prismatic, revolute2, fixed, two branches.
inline Model every_joint_model() {
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

inline void random_qv(const Model& m, std::mt19937& rng, Eigen::VectorXd& q, Eigen::VectorXd& v) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Eigen::VectorXd dv(m.nv());
  for (int i = 0; i < m.nv(); ++i) dv[i] = U(rng);
  q.resize(m.nq());
  integrate(m, m.neutral(), dv, 1.0, q);
  v.resize(m.nv());
  for (int i = 0; i < m.nv(); ++i) v[i] = U(rng);
}

}  // namespace coopdyn::testing
