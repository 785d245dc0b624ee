// Constraint rows: G v and Gdot v against finite differences, on every scene.
#include <gtest/gtest.h>

#include "service/algorithms/kinematics.h"
#include "service/constraints/constraints.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

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
