// Constraint rows: G v and Gdot v against finite differences, on every scene.
#include <gtest/gtest.h>

#include <cstring>

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

namespace {

bool same_bits(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<size_t>(a.size())) == 0;
}

// every shipped kind of row: welds to the world and between frames, locks (pseudo-joint
// formulation), couplings (URDF mimic joints), rolling wheels
std::vector<System> systems_of_every_kind() {
  std::vector<System> out;
  for (const auto& name : all_scenes())
    for (auto f : {Formulation::kMobilePlatform, Formulation::kClassic, Formulation::kPseudoJointSchur})
      if (name != "four_bar" || f == Formulation::kClassic) out.push_back(load(name, f));
  for (const auto& name : wheel_scenes()) out.push_back(load(name));
  for (const char* name : {"pr2_box", "tiago_pro_box"}) out.push_back(load(name));
  return out;
}

}  // namespace

TEST(ConstraintRows, PositionErrorsSkippedLeaveEveryOtherOutputBitForBitAndTheErrorsNaN) {
  // PositionErrors::kSkip (an evaluation whose errors nobody reads) computes the same G, Gdot v,
  // G v, gamma and frames as kFill, and leaves err NaN, not a stale or zero value; with Baumgarte
  // stabilization gamma reads the errors, which are then filled whatever was asked
  std::mt19937 rng(29);
  int kinds[4] = {0, 0, 0, 0};
  for (System sys : systems_of_every_kind()) {
    const Model& m = sys.model;
    for (const ConstraintSpec& c : sys.constraints.specs) ++kinds[static_cast<int>(c.kind)];
    for (bool stabilize : {false, true}) {
      SCOPED_TRACE(sys.name + (stabilize ? " stabilized" : ""));
      ConstraintSet set = sys.constraints;
      set.stabilize = stabilize;
      set.baumgarte_alpha = stabilize ? 20.0 : 0.0;
      set.baumgarte_beta = stabilize ? 100.0 : 0.0;
      for (int trial = 0; trial < 3; ++trial) {
        Eigen::VectorXd q, v;
        random_state(sys, rng, 0.3, q, v);
        Data d(m);
        forward_kinematics(m, d, q, v);
        ConstraintData fill(m, set), skip(m, set);
        constraint_rows(m, d, set, q, v, fill);
        constraint_rows(m, d, set, q, v, skip, PositionErrors::kSkip);
        EXPECT_TRUE(same_bits(fill.G, skip.G));
        EXPECT_TRUE(same_bits(fill.Gdot_v, skip.Gdot_v));
        EXPECT_TRUE(same_bits(fill.Gv, skip.Gv));
        EXPECT_TRUE(same_bits(fill.gamma, skip.gamma));
        EXPECT_EQ(fill.rr_arm, skip.rr_arm);
        for (size_t s = 0; s < set.specs.size(); ++s) {
          EXPECT_TRUE(same_bits(fill.X_RS[s].R, skip.X_RS[s].R));
          EXPECT_TRUE(same_bits(fill.X_RS[s].p, skip.X_RS[s].p));
        }
        ASSERT_TRUE(fill.err.allFinite());
        if (set.rows > 0) {
          EXPECT_GT(fill.err.cwiseAbs().maxCoeff(), 1e-3);  // a state off the constraints
        }
        if (stabilize) {
          EXPECT_TRUE(same_bits(fill.err, skip.err));
        } else {
          EXPECT_TRUE(skip.err.array().isNaN().all());
        }
      }
    }
  }
  for (int k = 0; k < 4; ++k) EXPECT_GT(kinds[k], 0) << "no spec of kind " << k;  // weld, lock, rolling, couple
}
