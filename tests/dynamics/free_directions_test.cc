// The free directions of an over-constrained system's multipliers, as vectors: they are the null
// space of G^T (they move no body), orthonormal, grouped by what they move; each reported wrench
// changes along one exactly as the wrenches of lambda + that direction do; a rigid car on four
// wheels has the analytic diagonal load-transfer mode and the lateral splits of its two axles.
#include <gtest/gtest.h>

#include "service/dynamics/free_directions.h"
#include "service/dynamics/wrenches.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

namespace {
int output_index(const System& s, const std::string& name) {
  for (size_t k = 0; k < s.wrenches.outputs.size(); ++k)
    if (s.wrenches.outputs[k].name == name) return static_cast<int>(k);
  return -1;
}

// Identities that do not use the grouping: G^T d = 0 (d moves no body: Q d = 0 with M > 0),
// orthonormal columns, and W(lambda + d) - W(lambda) = free_W d for every reported wrench.
void expect_free_directions_are_free(const System& sys, const Eigen::VectorXd& tau, int expect) {
  Workspace ws(sys);
  evaluate(sys, ws, sys.q0, sys.v0, tau);
  ASSERT_EQ(ws.diag.indeterminate, expect) << sys.name;
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  ASSERT_EQ(wd.num_free, expect) << sys.name;
  const auto F = wd.free_lambda.leftCols(wd.num_free);
  EXPECT_LT((F.transpose() * F - Eigen::MatrixXd::Identity(expect, expect)).cwiseAbs().maxCoeff(), 1e-12) << sys.name;
  const double g = ws.cd.G.cwiseAbs().maxCoeff();
  EXPECT_LT((ws.cd.G.transpose() * F).cwiseAbs().maxCoeff(), 1e-12 * g) << sys.name;
  for (int d = 0; d < wd.num_free; ++d) {
    Workspace moved = ws;
    moved.lambda += 10.0 * wd.free_lambda.col(d);
    WrenchData wm(sys);
    compute_wrenches(sys, moved, wm);
    for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k) {
      const Vec6 change = (wm.W[k] - wd.W[k]) / 10.0;
      const Vec6 free = wd.free_W.block<6, 1>(6 * static_cast<Eigen::Index>(k), d);
      EXPECT_LT((change - free).cwiseAbs().maxCoeff(), 1e-9 * (1 + wd.W[k].cwiseAbs().maxCoeff()))
          << sys.name << " direction " << d << " " << sys.wrenches.outputs[k].name;
    }
    EXPECT_FALSE(free_direction_reading(sys, wd, d).empty());
  }
}
}  // namespace

TEST(FreeDirections, FourWheelCarHasTheDiagonalModeAndTheAxleSplits) {
  const System sys = load_scene_string(
      replace_once(rigid_car_scene(), "mass: 1200, inertia", "mass: 1200, com: [0.2, 0.05, 0.25], inertia") + "reactions: all\n",
      "car.yaml");
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
  Workspace ws(sys);
  evaluate(sys, ws, sys.q0, sys.v0, tau);
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  ASSERT_EQ(wd.num_free, 3);
  // first the normal forces: the diagonal mode (fl, rr) against (fr, rl), 1/2 each (unit norm),
  // the first wheel's component positive
  EXPECT_EQ(wd.free_class[0], FreeClass::kWheelNormal);
  const char* wheels[4] = {"fl", "fr", "rl", "rr"};
  const double diagonal[4] = {0.5, -0.5, -0.5, 0.5};
  for (int w = 0; w < 4; ++w) {
    const int k = output_index(sys, wheels[w]);
    ASSERT_GE(k, 0);
    const Vec6 x = wd.free_W.block<6, 1>(6 * k, 0);
    EXPECT_NEAR(x[5], diagonal[w], 1e-12) << wheels[w];
    EXPECT_LT(x.head<5>().cwiseAbs().maxCoeff(), 1e-12) << wheels[w] << ": the mode moves normal forces only";
  }
  EXPECT_NE(free_direction_reading(sys, wd, 0).find("diagonal load transfer between the four wheels"), std::string::npos)
      << free_direction_reading(sys, wd, 0);
  // then the lateral forces: their span is that of the two axles' splits, fl - fr and rl - rr
  EXPECT_EQ(wd.free_class[1], FreeClass::kWheelLateral);
  EXPECT_EQ(wd.free_class[2], FreeClass::kWheelLateral);
  Eigen::MatrixXd lat(4, 2), axles(4, 2);
  for (int w = 0; w < 4; ++w)
    for (int d = 0; d < 2; ++d) lat(w, d) = wd.free_W(6 * output_index(sys, wheels[w]) + 4, 1 + d);
  axles << 1, 0, -1, 0, 0, 1, 0, -1;
  axles /= std::sqrt(2.0);
  const Eigen::MatrixXd proj = lat * (lat.transpose() * lat).inverse() * lat.transpose();
  EXPECT_LT((proj * axles - axles).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NE(free_direction_reading(sys, wd, 1).find("lateral forces shift between the wheels"), std::string::npos);
  expect_free_directions_are_free(sys, tau, 3);
}

TEST(FreeDirections, AreFreeOnEveryOverConstrainedShippedScene) {
  for (const char* name : {"planar_arms_load", "two_wheel_vehicle"}) {
    const System sys = load_with_reactions(name);
    Eigen::VectorXd tau(sys.model.nv());
    for (int i = 0; i < tau.size(); ++i) tau[i] = sys.tau_limit[i] > 0 ? 0.3 * std::sin(1.0 + i) : 0.0;
    expect_free_directions_are_free(sys, tau, name == std::string("planar_arms_load") ? 3 : 1);
  }
  // and a determinate scene has none
  const System sys = load("two_puma_load");
  Workspace ws(sys);
  evaluate(sys, ws, sys.q0, sys.v0, Eigen::VectorXd::Zero(sys.model.nv()));
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  EXPECT_EQ(wd.num_free, 0);
}
