// The velocity columns of each wrench's sigma as tangents (service/dynamics/wrench_sigma_velocity.h)
// against differences of the residuals they linearize (tests/dynamics/wrench_sigma_reference.cc):
// the generalized-force change (X0), the constraint right-hand side's (Gm) and the wrenches' own
// change (Cd), column by column. The solve after them is the torque columns' (wrench_sigma_fast_test.cc).
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "service/dynamics/wrench_sigma.h"
#include "tests/dynamics/wrench_sigma_reference.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {

System noisy(const std::string& name, const std::string& extra = "") {
  std::string t = without_reactions(scene_text(name));
  if (!extra.empty()) {  // replaces the scene's ground
    const auto p = t.find("\nground:");
    if (p != std::string::npos) t.erase(p, t.find('\n', p + 1) - p);
  }
  return load_scene_string(t + "\nreactions: all\nnoise: {tau: 0.2, q: 1e-3, v: 1e-2}\n" + extra, scene_path(name));
}


// the largest difference of the velocity columns of X0, Gm and Cd, relative to each matrix's
// largest entry over those columns
struct Diff {
  double x0 = 0, gm = 0, cd = 0;
};
Diff velocity_columns_diff(const WrenchSigmaData& a, const WrenchSigmaData& b, int na, int nq, int nv) {
  auto rel = [](const auto& A, const auto& B) {
    const double s = std::max(B.cwiseAbs().maxCoeff(), 1e-300);
    return (A - B).cwiseAbs().maxCoeff() / s;
  };
  Diff d;
  d.x0 = rel(a.X0.middleCols(na + nq, nv), b.X0.middleCols(na + nq, nv));
  d.gm = rel(a.Gm.middleCols(na + nq, nv), b.Gm.middleCols(na + nq, nv));
  d.cd = rel(a.Cd.middleCols(nq, nv), b.Cd.middleCols(nq, nv));
  return d;
}

struct Scene {
  const char* name;
  std::string extra;
};
const Scene kScenes[] = {{"two_puma_load", ""},  // closed chain, mobile platform: frame welds
                         {"two_iiwa_load", ""},  // URDF damping
                         {"four_wheel_car", ""},  // rolling rows, steer locks (over-constrained)
                         {"four_wheel_car", "ground: {rolling_resistance: 0.02}\n"},  // the smoothed sign
                         {"trike", ""},
                         {"two_wheel_vehicle", ""},
                         {"pr2_box", ""},
                         {"tiago_pro_box", ""}};

// Gdot v, the bias forces and the joint reactions are quadratic in v, damping linear: a central
// difference of any step h has no truncation error there, only round-off (~eps |r| / h); the
// rolling-resistance arm's smoothed sign is not, its h^2 term is below round-off at these speeds
// (0.3 m/s against kRollingResistanceSpeed 1e-3). So the tangents must agree with the central
// differences at every step from 1e-1 to 1e-4, better as the step grows: measured |diff| * h at
// most 6e-12 (the car's generalized forces), 4e-15 on the PUMA pair, asserted below 1e-11 / h.
// A missing or wrong term shows at every step (a missing dV x J below the moved joint was 2e-1).
TEST(WrenchSigmaVelocity, EqualCentralDifferencesOfAnyStep) {
  int compared = 0;
  for (const Scene& c : kScenes) {
    SCOPED_TRACE(std::string(c.name) + " " + c.extra);
    const System sys = noisy(c.name, c.extra);
    Workspace ws(sys);
    WrenchSigmaData fast(sys), ref(sys);
    Eigen::VectorXd v, tau;
    reference::random_v_tau(sys, 3, v, tau);
    ASSERT_NE(evaluate(sys, ws, sys.q0, v, tau).status, Status::kError);
    compute_wrench_sigma(sys, ws, fast, sys.q0, v, tau);
    ASSERT_TRUE(fast.valid);
    const int na = static_cast<int>(fast.dofs.size()), nv = static_cast<int>(fast.v_dofs.size());
    const int nq = fast.ncols - na - nv;
    ASSERT_GT(nv, 0);
    for (double h : {1e-1, 1e-2, 1e-3, 1e-4}) {
      const reference::ScopedStep step(reference::velocity_step, h);
      reference::compute_wrench_sigma(sys, ws, ref, sys.q0, v, tau);
      const Diff d = velocity_columns_diff(fast, ref, na, nq, nv);
      EXPECT_LT(d.x0, 1e-11 / h) << "generalized forces, step " << h;
      EXPECT_LT(d.gm, 1e-11 / h) << "constraint right-hand side, step " << h;
      EXPECT_LT(d.cd, 1e-11 / h) << "wrenches, step " << h;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 32);
}

// The former definition, forward differences of step 1e-7, within its truncation error (O(1e-7
// |d2r/dv2|) plus round-off eps |r| / 1e-7, relative to the column's largest entry): the round-off
// dominates where the residual is large next to its change (the car's generalized forces): measured
// 4.5e-5 relative in the Release build and 1.2e-4 in the sanitizer build (other instructions, other
// rounding), 1e-7 on the PUMA pair; asserted below 5e-4. The exactness of the tangents is the
// central-difference test's above.
TEST(WrenchSigmaVelocity, EqualThePreviousForwardDifferencesWithinTheirTruncation) {
  for (const Scene& c : kScenes) {
    SCOPED_TRACE(std::string(c.name) + " " + c.extra);
    const System sys = noisy(c.name, c.extra);
    Workspace ws(sys);
    WrenchSigmaData fast(sys), ref(sys);
    Eigen::VectorXd v, tau;
    reference::random_v_tau(sys, 3, v, tau);
    ASSERT_NE(evaluate(sys, ws, sys.q0, v, tau).status, Status::kError);
    compute_wrench_sigma(sys, ws, fast, sys.q0, v, tau);
    {
      const reference::ScopedStep step(reference::velocity_step, -1.0);
      reference::compute_wrench_sigma(sys, ws, ref, sys.q0, v, tau);
    }
    const int na = static_cast<int>(fast.dofs.size()), nv = static_cast<int>(fast.v_dofs.size());
    const Diff d = velocity_columns_diff(fast, ref, na, fast.ncols - na - nv, nv);
    EXPECT_LT(std::max({d.x0, d.gm, d.cd}), 5e-4);
  }
}

}  // namespace
}  // namespace coopdyn::testing
