// The position columns of each wrench's sigma as tangents (service/dynamics/sigma/wrench_sigma_position.h)
// against differences of the residuals they linearize (tests/dynamics/sigma/wrench_sigma_reference.cc):
// the generalized-force change (X0), the constraint right-hand side's (Gm) and the wrenches' own
// change (Cd), column by column. The solve after them is the torque columns' (wrench_sigma_fast_test.cc).
#include <gtest/gtest.h>

#include <algorithm>
#include <optional>
#include <random>

#include "service/dynamics/sigma/wrench_sigma.h"
#include "tests/dynamics/sigma/wrench_sigma_case.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {

// the largest difference of the position columns a with tangent[a] == want of X0, Gm and Cd,
// relative to each matrix's largest entry over those columns
struct Diff {
  double x0 = 0, gm = 0, cd = 0;
  int columns = 0;
};
Diff position_columns_diff(const SigmaCase& c, char want) {
  const WrenchSigmaData &a = c.fast, &b = c.ref;
  const int na = c.na, nq = c.nq;
  Diff d;
  double s[3] = {1e-300, 1e-300, 1e-300}, e[3] = {0, 0, 0};
  for (int j = 0; j < nq; ++j) {
    if (a.qt_tangent[static_cast<size_t>(j)] != want) continue;
    ++d.columns;
    s[0] = std::max(s[0], b.X0.col(na + j).cwiseAbs().maxCoeff());
    s[1] = std::max(s[1], b.Gm.col(na + j).cwiseAbs().maxCoeff());
    s[2] = std::max(s[2], b.Cd.col(j).cwiseAbs().maxCoeff());
    e[0] = std::max(e[0], (a.X0.col(na + j) - b.X0.col(na + j)).cwiseAbs().maxCoeff());
    e[1] = std::max(e[1], (a.Gm.col(na + j) - b.Gm.col(na + j)).cwiseAbs().maxCoeff());
    e[2] = std::max(e[2], (a.Cd.col(j) - b.Cd.col(j)).cwiseAbs().maxCoeff());
  }
  d.x0 = e[0] / s[0], d.gm = e[1] / s[1], d.cd = e[2] / s[2];
  return d;
}

struct Scene {
  const char* name;
  std::string extra;  // appended to the scene
  int tangents;       // position columns that are tangents (the others: differences)
  bool friction = false;  // Coulomb friction 2 N m on every measured joint (some stuck, some sliding)
  std::optional<Formulation> f = std::nullopt;  // replaces the scene's formulation
};
// (The wheeled scenes are over-constrained at these states, so without position columns: a rolling
// contact below a joint makes its column a difference, the forward one wrench_sigma_fast_test.cc
// compares where they have some.)
const Scene kScenes[] = {
    {"two_puma_load", "", 12},  // closed chain, mobile platform: frame welds to a free load; a link
                                // with rotational inertia and no mass
    {"two_puma_load", "", 12, true},
    {"two_puma_load", "stabilization: {baumgarte: {alpha: 20, beta: 0}}\n", 12},  // alpha G v
    {"two_puma_load", "stabilization: {baumgarte: {alpha: 20, beta: 100}}\n", 0},  // a weld's pose error: differences
    {"two_iiwa_load", "", 14},  // URDF damping
    {"two_5dof_arms_load", "", 10},
    {"four_bar", "", 4},        // classic, welds between two arms; the first body's joint a tangent too
    {"two_puma_load", "", 12, false, Formulation::kClassic},  // classic: the first arm's first joint is body 0's
    {"two_iiwa_load", "", 14, false, Formulation::kClassic},  // classic, the first body a fixed base
    {"pr2_box", "", 30},        // a mobile base, mimic couplings
    {"pr2_box", "stabilization: {baumgarte: {alpha: 20, beta: 100}}\n", 15},  // a coupling's position error
};

System scene_of(const Scene& c) {
  System sys = noisy_scene(c.name, c.extra, SceneOverrides{c.f});
  if (c.friction)
    for (Body& b : sys.model.bodies)
      if (b.joint.nv == 1 && !b.joint.pseudo) b.joint.friction = 2.0;
  return sys;
}

// The tangents are exact; a five-point central difference of step h has a truncation error
// O(h^4) and round-off ~eps |r| / h. So they must agree at every step from 1e-2 to 1e-4, better
// as the step shrinks towards ~1e-3: measured at most 5.9e-9 at 1e-2 (the classic iiwa pair), 3.3e-12 at
// 1e-3, 5.2e-11 at 1e-4 (the PR2), relative to each matrix's largest entry over the columns;
// asserted below h^4 + 1e-13 / h. A missing term shows at every step (the torque of a link's
// rotational inertia without mass, left out, was 8e-3). The columns that stay differences equal
// the forward differences of the reference to round-off (the same arithmetic).
TEST(WrenchSigmaPosition, EqualFivePointCentralDifferencesOfSeveralSteps) {
  int compared = 0;
  for (const Scene& c : kScenes) {
    SCOPED_TRACE(std::string(c.name) + " " + c.extra + (c.friction ? " friction" : ""));
    SigmaCase s(scene_of(c));
    ASSERT_TRUE(s.evaluated && s.fast.valid);
    ASSERT_EQ(s.ws.diag.indeterminate, 0);
    if (c.friction) {
      ASSERT_GT(s.ws.friction_dofs.size(), 0u);
    }
    const int nq = s.nq;
    ASSERT_GT(nq, 0);
    int couplings = 0;
    for (int a = 0; a < nq; ++a)
      for (int k : s.fast.qt_specs[static_cast<size_t>(a)])
        couplings += s.fast.qt_tangent[static_cast<size_t>(a)] && s.sys.constraints.specs[static_cast<size_t>(k)].kind == ConstraintKind::kCouple;
    if (std::string(c.name) == "pr2_box") {
      EXPECT_GT(couplings, 0);  // the gripper's mimic joints
    }
    for (double h : {1e-2, 1e-3, 1e-4}) {
      const reference::ScopedStep step(reference::position_step, h);
      s.compute_reference();
      const Diff d = position_columns_diff(s, 1);
      EXPECT_EQ(d.columns, c.tangents);
      const double tol = h * h * h * h + 1e-13 / h;
      EXPECT_LT(d.x0, tol) << "generalized forces, step " << h;
      EXPECT_LT(d.gm, tol) << "constraint right-hand side, step " << h;
      EXPECT_LT(d.cd, tol) << "wrenches, step " << h;
      const Diff e = position_columns_diff(s, 0);
      EXPECT_EQ(e.columns, nq - c.tangents);
      EXPECT_LT(std::max({e.x0, e.gm, e.cd}), 1e-12);
      compared += d.columns;
    }
  }
  EXPECT_EQ(compared, 3 * (12 * 3 + 14 + 10 + 4 + 12 + 14 + 30 + 15));
}

// The former definition, forward differences of step 1e-7 for every column, within its truncation
// error (O(1e-7 |d2r/dq2|) plus round-off eps |r| / 1e-7, relative to the columns' largest entry):
// measured at most 8.9e-8 (Release); asserted below 1e-5. The exactness is the test above's.
TEST(WrenchSigmaPosition, EqualThePreviousForwardDifferencesWithinTheirTruncation) {
  for (const Scene& c : kScenes) {
    SCOPED_TRACE(std::string(c.name) + " " + c.extra + (c.friction ? " friction" : ""));
    SigmaCase s(scene_of(c));
    ASSERT_TRUE(s.evaluated && s.fast.valid);
    {
      const reference::ScopedStep step(reference::position_step, -1.0);
      s.compute_reference();
    }
    const Diff d = position_columns_diff(s, 1);
    EXPECT_LT(std::max({d.x0, d.gm, d.cd}), 1e-5);
  }
}

}  // namespace
}  // namespace coopdyn::testing
