// The SVD baseline as the paper states it (its (19)-(21)), checked against an independent
// SVD and against the mobile-platform method.
#include <gtest/gtest.h>

#include <Eigen/SVD>

#include "service/dynamics/wrenches.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {

// The arm's own tip Jacobian: the columns of the grasp weld's rows of G over the arm's joints.
Eigen::MatrixXd arm_jacobian(const System& sys, const Workspace& ws, int spec, const std::string& arm) {
  const int r0 = sys.constraints.row_offset[spec], nk = sys.constraints.row_count[spec];
  std::vector<int> cols;
  for (int c = 0; c < sys.model.nv(); ++c)
    if (sys.model.v_names[c].rfind(arm + ".", 0) == 0) cols.push_back(c);
  Eigen::MatrixXd J(nk, static_cast<Eigen::Index>(cols.size()));
  for (size_t k = 0; k < cols.size(); ++k) J.col(static_cast<Eigen::Index>(k)) = ws.cd.G.block(r0, cols[k], nk, 1);
  return J;
}

int spec_of(const System& sys, const std::string& name) {
  for (size_t s = 0; s < sys.constraints.specs.size(); ++s)
    if (sys.constraints.specs[s].name == name) return static_cast<int>(s);
  return -1;
}

TEST(SvdBaseline, KeepsTheRangeOfEachArmsOwnJacobianAndFlagsWhatItDrops) {
  // two_5dof_arms_load: joint 6 of each PUMA held, so each arm's own 6x5 Jacobian has rank 5 and
  // one force direction, N(J^T), is dropped per arm.
  const System sys = load("two_5dof_arms_load", Formulation::kSvdBaseline);
  Workspace ws(sys);
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
  const Diagnostics& d = evaluate(sys, ws, sys.q0, sys.v0, tau);
  EXPECT_EQ(d.status, Status::kIndeterminate);
  EXPECT_EQ(d.reason, Reason::kSvdDropped);
  EXPECT_EQ(d.dropped, 2);
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  int row = 0;  // rows of ws.R: each spec's kept directions, in spec order
  for (const std::string arm : {"arm1", "arm2"}) {
    const int s = spec_of(sys, arm + ".ee");
    ASSERT_GE(s, 0);
    const Eigen::MatrixXd J = arm_jacobian(sys, ws, s, arm);
    ASSERT_EQ(J.cols(), 5);
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(J, Eigen::ComputeFullU);
    const Eigen::MatrixXd Ur = svd.matrixU().leftCols(5);
    EXPECT_EQ(ws.tip_rank[s], 5);
    // the kept space: the projector onto the rows of R equals the one onto range(J)
    Eigen::MatrixXd Rk = Eigen::MatrixXd::Zero(5, 6);
    for (int i = 0; i < 5; ++i) Rk.row(i) = ws.R.row(row + i).segment(sys.constraints.row_offset[s], 6);
    row += 5;
    EXPECT_LT((Rk.transpose() * Rk - Ur * Ur.transpose()).norm(), 1e-10) << arm;
    // the dropped direction u = N(J^T): the baseline's grasp force has no component along it, and
    // the components it touches are flagged as not determined (never silently zero)
    const Eigen::VectorXd u = svd.matrixU().col(5);
    const Vec6 w = tip_wrench(sys, ws, s);
    EXPECT_LT(std::abs(u.dot(w)), 1e-10 * (1 + w.norm())) << arm;
    unsigned expect = 0;
    for (int k = 0; k < 6; ++k)
      if (std::abs(u[k]) > 1e-6) expect |= 1u << k;
    unsigned mask = 0;
    tip_wrench(sys, ws, s, &mask);
    EXPECT_NE(mask, 0u) << arm;
    EXPECT_EQ(mask & expect, expect) << arm;
    bool flagged = false;
    for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k)
      if (sys.wrenches.outputs[k].name == arm + ".ee") flagged = wd.indeterminate[k] != 0;
    EXPECT_TRUE(flagged) << arm << ".ee in the published wrenches";
  }
}

TEST(SvdBaseline, WhatItDropsTheRigidGraspCarries) {
  // The mobile-platform method keeps every direction: along u = N(J^T) it reports a nonzero grasp
  // force, and its accelerations keep the grasp rigid (G vdot = gamma); the baseline's let the grasp
  // open along u. Both facts are what the baseline loses.
  const System sv = load("two_5dof_arms_load", Formulation::kSvdBaseline);
  const System cl = load("two_5dof_arms_load", Formulation::kClassic);
  Workspace ws(sv), wc(cl);
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(sv.model.nv());
  evaluate(sv, ws, sv.q0, sv.v0, tau);
  ASSERT_EQ(evaluate(cl, wc, cl.q0, cl.v0, tau).status, Status::kOk);
  for (const std::string arm : {"arm1", "arm2"}) {
    const int s = spec_of(sv, arm + ".ee");
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(arm_jacobian(sv, ws, s, arm), Eigen::ComputeFullU);
    const Eigen::VectorXd u = svd.matrixU().col(5);
    const Vec6 w_rigid = tip_wrench(cl, wc, s);  // same tree, same rows as the baseline
    EXPECT_GT(std::abs(u.dot(w_rigid)), 1e-3) << arm << ": the rigid grasp carries force along u";
    const int r0 = sv.constraints.row_offset[s];
    const Eigen::VectorXd open = ws.cd.G.middleRows(r0, 6) * ws.vdot - ws.cd.gamma.segment(r0, 6);
    const Eigen::VectorXd closed = wc.cd.G.middleRows(r0, 6) * wc.vdot - wc.cd.gamma.segment(r0, 6);
    EXPECT_LT(closed.norm(), 1e-9);
    EXPECT_GT(std::abs(u.dot(open)), 1e-6) << arm << ": the baseline's grasp accelerates open along u";
  }
}

TEST(SvdBaseline, WhereNothingIsDroppedItIsTheAnalyticMethod) {
  // two_puma_load away from singularities: every arm Jacobian has rank 6, nothing is dropped, and
  // the baseline's accelerations and wrenches equal the classic form's (the same rows) to round-off.
  std::mt19937 rng(170);
  const System sv = load("two_puma_load", Formulation::kSvdBaseline);
  const System cl = load("two_puma_load", Formulation::kClassic);
  Workspace ws(sv), wc(cl);
  for (int trial = 0; trial < 5; ++trial) {
    Eigen::VectorXd q, v;
    random_state(cl, rng, 0.0, q, v);
    evaluate(cl, wc, q, Eigen::VectorXd::Zero(cl.model.nv()), Eigen::VectorXd::Zero(cl.model.nv()));
    v = project_velocity(wc.cd.G, v);
    const Eigen::VectorXd tau = Eigen::VectorXd::Random(cl.model.nv());
    ASSERT_EQ(evaluate(cl, wc, q, v, tau).status, Status::kOk);
    const Diagnostics& d = evaluate(sv, ws, q, v, tau);
    EXPECT_EQ(d.status, Status::kOk);
    EXPECT_EQ(d.dropped, 0);
    EXPECT_LT((ws.vdot - wc.vdot).norm(), 1e-9 * (1 + wc.vdot.norm()));
    EXPECT_LT((ws.lambda - wc.lambda).norm(), 1e-9 * (1 + wc.lambda.norm()));
  }
}

}  // namespace
}  // namespace coopdyn::testing
