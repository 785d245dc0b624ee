// The configuration space of a model: integrate() against q_derivative(), on every joint type.
#include <gtest/gtest.h>

#include <random>

#include "service/model/model.h"
#include "tests/support/every_joint_model.h"

using namespace coopdyn;
using namespace coopdyn::testing;

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
