// The velocity columns of each wrench's sigma as tangents (service/dynamics/sigma/wrench_sigma_velocity.h)
// against differences of the residuals they linearize (tests/dynamics/sigma/wrench_sigma_reference.cc):
// the generalized-force change (X0), the constraint right-hand side's (Gm) and the wrenches' own
// change (Cd), column by column. The solve after them is the torque columns' (wrench_sigma_fast_test.cc).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "service/dynamics/sigma/wrench_sigma.h"
#include "tests/dynamics/sigma/wrench_sigma_case.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {

// the largest difference of the velocity columns of X0, Gm and Cd, relative to each matrix's
// largest entry over those columns
struct Diff {
  double x0 = 0, gm = 0, cd = 0;
};
Diff velocity_columns_diff(const SigmaCase& c) {
  const WrenchSigmaData &a = c.fast, &b = c.ref;
  const int na = c.na, nq = c.nq, nv = c.nv;
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

// The round-off of a central difference of step h, relative to each matrix's largest entry over the
// velocity columns (ref's, as in velocity_columns_diff): each residual entry is a sum of terms of
// magnitude up to T (generalized forces: tau, the bias forces tau - tau_c, |G^T| |lambda|; the
// constraint right-hand side: gamma, |G| |vdot|; the wrenches: their largest entry), so r(v +- h)
// carry errors of order eps T, and the column (r(v + h) - r(v - h)) Sv / 2h of order eps T Sv / 2h.
Diff central_roundoff(const SigmaCase& c, double h) {
  const Workspace& ws = c.ws;
  const Eigen::MatrixXd& G = ws.cd.G;
  const Eigen::ArrayXd Gl = (G.cwiseAbs().transpose() * ws.lambda.cwiseAbs()).array();  // (nv) |G^T| |lambda|
  const Eigen::ArrayXd Gv = (G.cwiseAbs() * ws.vdot.cwiseAbs()).array();                 // (rows) |G| |vdot|
  const double t_tau = (c.tau.array().abs() + (c.tau - ws.tau_c).array().abs() + Gl).maxCoeff();
  const double t_g = (ws.cd.gamma.array().abs() + Gv).maxCoeff();
  WrenchData wd(c.sys);
  compute_wrenches(c.sys, ws, wd);
  double t_w = 0.0;
  for (const Vec6& W : wd.W) t_w = std::max(t_w, W.cwiseAbs().maxCoeff());
  const double f = std::numeric_limits<double>::epsilon() * c.ref.Sv.cwiseAbs().maxCoeff() / (2.0 * h);
  const int vcols = c.na + c.nq;  // the first velocity column of X0 and Gm (of Cd: nq)
  Diff r;
  r.x0 = f * t_tau / c.ref.X0.middleCols(vcols, c.nv).cwiseAbs().maxCoeff();
  r.gm = f * t_g / c.ref.Gm.middleCols(vcols, c.nv).cwiseAbs().maxCoeff();
  r.cd = f * t_w / c.ref.Cd.middleCols(c.nq, c.nv).cwiseAbs().maxCoeff();
  return r;
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
// difference of any step h has no truncation error there, only round-off, eps T Sv / 2h relative
// (central_roundoff); the rolling-resistance arm's smoothed sign is not, but its h^2 term is below
// that round-off at these speeds (0.3 m/s against kRollingResistanceSpeed 1e-3): measured, |diff| h
// is the same at every step from 3e-1 to 1e-4 on both cars (5.9e-12 on their generalized forces), as
// round-off alone makes it. So the tangents must agree with the central differences within a bound
// derived from the round-off term: asserted below 32 eps T Sv / 2h (a sum of some tens of terms, each
// rounded), where the measured differences are 0.001-2.3 times eps T Sv / 2h over the eight scenes,
// four steps and three matrices (at least 13x margin; the car's generalized forces 0.43, 75x). A
// missing or wrong term shows at every step (a missing dV x J below the moved joint was 2e-1, against
// bounds of 1e-12..4e-6 here).
TEST(WrenchSigmaVelocity, EqualCentralDifferencesOfAnyStep) {
  int compared = 0;
  for (const Scene& c : kScenes) {
    SCOPED_TRACE(std::string(c.name) + " " + c.extra);
    SigmaCase s(noisy_scene(c.name, c.extra));
    ASSERT_TRUE(s.evaluated && s.fast.valid);
    ASSERT_GT(s.nv, 0);
    for (double h : {1e-1, 1e-2, 1e-3, 1e-4}) {
      const reference::ScopedStep step(reference::velocity_step, h);
      s.compute_reference();
      const Diff d = velocity_columns_diff(s);
      const Diff e = central_roundoff(s, h);
      constexpr double kRoundings = 32;
      ASSERT_TRUE(std::isfinite(e.x0) && std::isfinite(e.gm) && std::isfinite(e.cd)) << "a velocity column of zeros";
      EXPECT_LT(d.x0, kRoundings * e.x0) << "generalized forces, step " << h;
      EXPECT_LT(d.gm, kRoundings * e.gm) << "constraint right-hand side, step " << h;
      EXPECT_LT(d.cd, kRoundings * e.cd) << "wrenches, step " << h;
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
    SigmaCase s(noisy_scene(c.name, c.extra));
    ASSERT_TRUE(s.evaluated && s.fast.valid);
    {
      const reference::ScopedStep step(reference::velocity_step, -1.0);
      s.compute_reference();
    }
    const Diff d = velocity_columns_diff(s);
    EXPECT_LT(std::max({d.x0, d.gm, d.cd}), 5e-4);
  }
}

}  // namespace
}  // namespace coopdyn::testing
