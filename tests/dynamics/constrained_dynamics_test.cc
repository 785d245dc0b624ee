// Constrained dynamics: the README's invariants on every scene, agreement of the formulations,
// pseudo-joint identities, statics, momentum balance, over-constrained handling.
#include <gtest/gtest.h>

#include "service/algorithms/crba.h"
#include "service/algorithms/kinematics.h"
#include "service/algorithms/rnea.h"
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

namespace {

// Evaluates at a random constraint-consistent state; returns the (q, v, tau) used.
struct Eval {
  Eigen::VectorXd q, v, tau;
};
Eval consistent_state(const System& sys, std::mt19937& rng, double spread, bool moving) {
  Eval e;
  e.q = sys.q0;  // configurations must satisfy the position constraints, so stay at q0
  const Model& m = sys.model;
  std::uniform_real_distribution<double> U(-1, 1);
  Eigen::VectorXd v(m.nv());
  for (int i = 0; i < m.nv(); ++i) v[i] = moving ? spread * U(rng) : 0.0;
  Data d(m);
  ConstraintData cd(m, sys.constraints);
  forward_kinematics(m, d, e.q, v);
  constraint_rows(m, d, sys.constraints, e.q, v, cd);
  e.v = project_velocity(cd.G, v);
  e.tau.resize(m.nv());
  for (int i = 0; i < m.nv(); ++i) e.tau[i] = 5.0 * U(rng);
  for (int dof : m.pseudo_dofs) e.tau[dof] = 0.0;
  for (const Body& b : m.bodies)  // the platform is not actuated
    if (b.joint.type == JointType::kFloating) e.tau.segment(b.joint.idx_v, 6).setZero();
  return e;
}


// velocity vector of system b re-ordered into the coordinates of system a, by name
Eigen::VectorXd by_name(const System& a, const System& b, const Eigen::VectorXd& xb) {
  Eigen::VectorXd xa(a.model.nv());
  for (int i = 0; i < a.model.nv(); ++i) {
    const int j = index_of(b.model.v_names, a.model.v_names[i]);
    EXPECT_GE(j, 0) << a.model.v_names[i];
    xa[i] = j >= 0 ? xb[j] : NAN;
  }
  return xa;
}
Eigen::VectorXd q_by_name(const System& a, const System& b, const Eigen::VectorXd& xb) {
  Eigen::VectorXd xa(a.model.nq());
  for (int i = 0; i < a.model.nq(); ++i) xa[i] = xb[index_of(b.model.q_names, a.model.q_names[i])];
  return xa;
}

}  // namespace

TEST(ConstrainedDynamics, Section9InvariantsOnEveryScene) {
  std::mt19937 rng(21);
  for (const auto& name : all_scenes()) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    Workspace ws(sys);
    for (int k = 0; k < 5; ++k) {
      const Eval e = consistent_state(sys, rng, 1.0, true);
      const Diagnostics& d = evaluate(sys, ws, e.q, e.v, e.tau);
      ASSERT_NE(d.status, Status::kError) << reason_text(d.reason);
      // residual: G vdot + Gdot v = 0 to machine precision relative to its terms
      const double scale = 1 + (ws.cd.G.cwiseAbs() * ws.vdot.cwiseAbs()).maxCoeff() + ws.cd.Gdot_v.cwiseAbs().maxCoeff();
      EXPECT_LT(d.residual, 1e-10 * scale);
      EXPECT_LT((ws.cd.G * ws.vdot + ws.cd.Gdot_v).cwiseAbs().maxCoeff(), 1e-9 * scale);
      // constraint forces do no work on a consistent velocity
      const double power = ws.lambda.dot(ws.cd.G * e.v);
      EXPECT_LT(std::abs(power), 1e-9 * (1 + ws.lambda.norm() * e.v.norm()));
      // equations of motion hold: M vdot + h = tau + tau_loss + G^T lambda, tau_loss the joints'
      // damping and friction (two_iiwa_load: its URDF's damping) (evaluate() leaves the dense M out)
      crba(sys.model, ws.data);
      const Eigen::VectorXd r = ws.data.M * ws.vdot + ws.data.h - e.tau - ws.tau_loss - ws.cd.G.transpose() * ws.lambda;
      EXPECT_LT(r.cwiseAbs().maxCoeff(), 1e-9 * (1 + ws.data.h.cwiseAbs().maxCoeff() + e.tau.cwiseAbs().maxCoeff()));
      EXPECT_TRUE(ws.vdot.allFinite());
      EXPECT_TRUE(ws.lambda.allFinite());
    }
  }
}

TEST(ConstrainedDynamics, AgreesWithAPlainKktSolve) {
  std::mt19937 rng(22);
  for (const auto& name : all_scenes()) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    Workspace ws(sys);
    const Eval e = consistent_state(sys, rng, 1.0, true);
    const Diagnostics& d = evaluate(sys, ws, e.q, e.v, e.tau);
    ASSERT_NE(d.status, Status::kError);
    Eigen::VectorXd vdot, lambda;
    crba(sys.model, ws.data);
    Eigen::VectorXd loss = Eigen::VectorXd::Zero(sys.model.nv());  // the joints' damping -b v (no scene has friction)
    for (const Body& b : sys.model.bodies)
      for (int k = 0; k < b.joint.nv; ++k) loss[b.joint.idx_v + k] = -b.joint.damping * e.v[b.joint.idx_v + k];
    kkt_solve(ws.data.M, ws.cd.G, e.tau - ws.data.h + loss, ws.cd.gamma, vdot, lambda);
    EXPECT_LT((vdot - ws.vdot).norm(), 1e-8 * (1 + vdot.norm()));
    if (d.indeterminate == 0) {
      EXPECT_LT((lambda - ws.lambda).norm(), 1e-7 * (1 + lambda.norm()));
    } else {
      EXPECT_LT((ws.cd.G.transpose() * (lambda - ws.lambda)).norm(), 1e-7 * (1 + lambda.norm()));
    }
  }
}

TEST(ConstrainedDynamics, MobilePlatformClassicAndSvdAgreeOnArmScenes) {
  // same physical state in the load-rooted tree (mobile platform) and the world-rooted tree
  // (classic (11)): the accelerations agree coordinate by coordinate; the SVD baseline too
  std::mt19937 rng(23);
  for (const std::string name : {"two_puma_load", "two_5dof_arms_load", "planar_arms_load"}) {
    SCOPED_TRACE(name);
    const System mp = load(name, Formulation::kMobilePlatform);
    const System cl = load(name, Formulation::kClassic);
    const System sv = load(name, Formulation::kSvdBaseline);
    Workspace wmp(mp), wcl(cl), wsv(sv);
    for (int k = 0; k < 3; ++k) {
      const Eval e = consistent_state(mp, rng, 1.0, true);
      evaluate(mp, wmp, e.q, e.v, e.tau);
      const Eigen::VectorXd qc = q_by_name(cl, mp, e.q), vc = by_name(cl, mp, e.v), tc = by_name(cl, mp, e.tau);
      evaluate(cl, wcl, qc, vc, tc);
      evaluate(sv, wsv, qc, vc, tc);  // the SVD baseline is rooted as the classic form
      ASSERT_NE(wmp.diag.status, Status::kError);
      ASSERT_NE(wcl.diag.status, Status::kError);
      ASSERT_NE(wsv.diag.status, Status::kError);
      const Eigen::VectorXd a_cl = by_name(mp, cl, wcl.vdot);
      EXPECT_LT((a_cl - wmp.vdot).norm(), 1e-8 * (1 + wmp.vdot.norm()));
      if (wsv.diag.dropped == 0) {  // where it drops a direction it integrates other dynamics (svd_baseline_test)
        EXPECT_LT((by_name(mp, sv, wsv.vdot) - wmp.vdot).norm(), 1e-8 * (1 + wmp.vdot.norm()));
      }
      EXPECT_EQ(wcl.diag.rank, wmp.diag.rank);
      if (wmp.diag.indeterminate == 0 && wsv.diag.dropped == 0) {  // the grasp wrenches, as the classic form's
        EXPECT_LT((wsv.lambda - wcl.lambda).norm(), 1e-7 * (1 + wcl.lambda.norm()));
      }
    }
  }
}

TEST(ConstrainedDynamics, ForcesPropagateIdenticallyThroughBothTrees) {
  // The wrench the world exerts on an arm's base (a tip in the mobile-platform form) equals the
  // force transmitted across joint 1 in the classic form; the wrench the load exerts on an
  // end-effector (a tip in the classic form) equals the force transmitted across the fixed
  // joint between platform and last link in the mobile-platform form. Both via RNEA.
  std::mt19937 rng(24);
  const System mp = load("two_puma_load", Formulation::kMobilePlatform);
  const System cl = load("two_puma_load", Formulation::kClassic);
  Workspace wmp(mp), wcl(cl);
  const Eval e = consistent_state(mp, rng, 1.0, true);
  evaluate(mp, wmp, e.q, e.v, e.tau);
  evaluate(cl, wcl, q_by_name(cl, mp, e.q), by_name(cl, mp, e.v), by_name(cl, mp, e.tau));
  auto body_forces = [](const System& s, const Workspace& w) {
    std::vector<Vec6> f(s.model.nbodies(), Vec6::Zero());
    for (size_t c = 0; c < s.constraints.specs.size(); ++c) {
      const ConstraintSpec& sp = s.constraints.specs[c];
      if (sp.kind != ConstraintKind::kWeld) continue;
      const Vec6 wA = tip_wrench(s, w, static_cast<int>(c));
      const Frame& FA = s.model.frames[sp.frame_a];
      f[FA.body] += FA.X_BF.act_force(wA);
      if (sp.frame_b >= 0) {
        const Frame& FB = s.model.frames[sp.frame_b];
        const Transform X_WA = frame_pose(s.model, w.data, sp.frame_a);
        const Vec6 w_W = X_WA.act_force(wA);
        f[FB.body] -= w.data.X_WB[FB.body].inv_act_force(w_W);
      }
    }
    return f;
  };
  for (auto* pr : {&mp, &cl}) {
    const System& s = *pr;
    Workspace& w = pr == &mp ? wmp : wcl;
    const Eigen::VectorXd q = pr == &mp ? e.q : q_by_name(cl, mp, e.q);
    const Eigen::VectorXd v = pr == &mp ? e.v : by_name(cl, mp, e.v);
    const Eigen::VectorXd tau = pr == &mp ? e.tau : by_name(cl, mp, e.tau);
    forward_kinematics(s.model, w.data, q, v);
    std::vector<Vec6> fext = body_forces(s, w);
    Eigen::VectorXd tau_rnea(s.model.nv());
    rnea(s.model, w.data, w.vdot, &fext, tau_rnea);
    // inverse dynamics with the constraint forces reproduces the applied torques
    EXPECT_LT((tau_rnea - tau).norm(), 1e-8 * (1 + tau.norm()));
  }
  for (const std::string arm : {"arm1", "arm2"}) {
    // base wrench: MP tip vs classic joint-1 transmission (in the base frame)
    int spec = -1;
    for (size_t c = 0; c < mp.constraints.specs.size(); ++c)
      if (mp.constraints.specs[c].name == arm + ".base") spec = static_cast<int>(c);
    ASSERT_GE(spec, 0);
    const Vec6 w_base = tip_wrench(mp, wmp, spec);
    const int l1 = cl.model.body_index(arm + ".link1");
    const Transform X_W_base = mp.constraints.specs[spec].X_WA_target;
    const Vec6 f_l1_W = wcl.data.X_WB[l1].act_force(wcl.data.f[l1]);
    EXPECT_LT((X_W_base.inv_act_force(f_l1_W) - w_base).norm(), 1e-7 * (1 + w_base.norm())) << arm;
    // end-effector wrench: classic tip vs MP fixed-joint transmission (world coordinates)
    int cspec = -1;
    for (size_t c = 0; c < cl.constraints.specs.size(); ++c)
      if (cl.constraints.specs[c].name == arm + ".ee") cspec = static_cast<int>(c);
    const Vec6 w_ee = tip_wrench(cl, wcl, cspec);
    const Transform X_W_ee = frame_pose(cl.model, wcl.data, cl.constraints.specs[cspec].frame_a);
    const int l6 = mp.model.body_index(arm + ".link6");
    const Vec6 f_l6_W = wmp.data.X_WB[l6].act_force(wmp.data.f[l6]);
    EXPECT_LT((f_l6_W - X_W_ee.act_force(w_ee)).norm(), 1e-7 * (1 + w_ee.norm())) << arm;
  }
}

TEST(ConstrainedDynamics, MomentumBalanceOnMobilePlatformScenes) {
  // With the platform floating, the world acts only through the tips: the sum of the tip wrenches
  // and gravity equals the rate of change of total momentum (finite differences along the motion).
  std::mt19937 rng(25);
  for (const std::string name : {"two_puma_load", "two_5dof_arms_load", "planar_arms_load"}) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    const Model& m = sys.model;
    Workspace ws(sys);
    const Eval e = consistent_state(sys, rng, 1.0, true);
    evaluate(sys, ws, e.q, e.v, e.tau);
    const double eps = 1e-6;
    Eigen::VectorXd qp(m.nq()), qm(m.nq());
    integrate(m, e.q, e.v, eps, qp);
    integrate(m, e.q, e.v, -eps, qm);
    const Vec6 hdot = (total_momentum(m, qp, e.v + eps * ws.vdot) - total_momentum(m, qm, e.v - eps * ws.vdot)) / (2 * eps);
    Vec6 F = Vec6::Zero();
    double mass = 0;
    Vec3 mc = Vec3::Zero();
    for (int i = 0; i < m.nbodies(); ++i) {
      const Inertia& I = m.bodies[i].inertia;
      mass += I.m;
      mc += I.m * (ws.data.X_WB[i].R * I.c + ws.data.X_WB[i].p);
    }
    F.tail<3>() = mass * m.gravity_W;
    F.head<3>() = mc.cross(m.gravity_W);
    for (size_t c = 0; c < sys.constraints.specs.size(); ++c) {
      const ConstraintSpec& sp = sys.constraints.specs[c];
      if (sp.kind != ConstraintKind::kWeld) continue;
      F += frame_pose(m, ws.data, sp.frame_a).act_force(tip_wrench(sys, ws, static_cast<int>(c)));
    }
    EXPECT_LT((hdot - F).norm(), 1e-5 * (1 + F.norm()));
  }
}

TEST(ConstrainedDynamics, HoldingTorquesMakeTheTipsCarryExactlyTheTotalWeight) {
  // Joint torques that hold two_puma_load still: tau = h - G^T lambda with lambda the minimum-norm
  // solution of the platform rows (the platform is unactuated). Then vdot = 0 and the base
  // forces sum to the total weight, the base moments balance gravity's moment.
  const System sys = load("two_puma_load");
  const Model& m = sys.model;
  Workspace ws(sys);
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(m.nv());
  evaluate(sys, ws, sys.q0, v0, Eigen::VectorXd::Zero(m.nv()));
  const Eigen::MatrixXd Gp_t = ws.cd.G.leftCols(6).transpose();  // platform columns
  const Eigen::VectorXd lam = Gp_t.completeOrthogonalDecomposition().solve(ws.data.h.head(6));
  Eigen::VectorXd tau = ws.data.h - ws.cd.G.transpose() * lam;
  ASSERT_LT(tau.head(6).norm(), 1e-9);
  tau.head(6).setZero();
  const Diagnostics& d = evaluate(sys, ws, sys.q0, v0, tau);
  ASSERT_EQ(d.status, Status::kOk);
  EXPECT_LT(ws.vdot.cwiseAbs().maxCoeff(), 1e-9);
  double mass = 0;
  for (const Body& b : m.bodies) mass += b.inertia.m;
  Vec3 f_sum = Vec3::Zero();
  for (size_t c = 0; c < sys.constraints.specs.size(); ++c)
    f_sum += frame_pose(m, ws.data, sys.constraints.specs[c].frame_a).R * tip_wrench(sys, ws, static_cast<int>(c)).tail<3>();
  EXPECT_NEAR(f_sum.z(), mass * 9.81, 1e-9 * mass * 9.81);
  EXPECT_NEAR(f_sum.x(), 0.0, 1e-9);
  EXPECT_NEAR(f_sum.y(), 0.0, 1e-9);
  EXPECT_NEAR(mass, 5.0 + 2 * (17.4 + 4.8 + 0.82 + 0.34 + 0.09), 1e-12);
}

TEST(ConstrainedDynamics, PlanarArmsReportTheirIndeterminateDirections) {
  const System sys = load("planar_arms_load");
  Workspace ws(sys);
  std::mt19937 rng(26);
  const Eval e = consistent_state(sys, rng, 1.0, true);
  const Diagnostics& d = evaluate(sys, ws, e.q, e.v, e.tau);
  EXPECT_EQ(d.status, Status::kIndeterminate);
  EXPECT_EQ(d.rows, 12);
  EXPECT_EQ(d.rank, 9);
  EXPECT_EQ(d.indeterminate, 3);
  // the out-of-plane components (wx, wy, vz of each base) are flagged, the in-plane ones are not
  for (int c = 0; c < 2; ++c) {
    unsigned mask = 0;
    tip_wrench(sys, ws, c, &mask);
    EXPECT_EQ(mask, (1u << 0) | (1u << 1) | (1u << 5)) << "tip " << c;
  }
  // minimum norm: each arm carries half of the weight of the symmetric system
  double mass = 0;
  for (const Body& b : sys.model.bodies) mass += b.inertia.m;
  EXPECT_NEAR(tip_wrench(sys, ws, 0)[5] + tip_wrench(sys, ws, 1)[5], mass * 9.81, 1e-9 * mass);
}

TEST(ConstrainedDynamics, ComplianceRuleMovesOnlyTheIndeterminatePart) {
  // Compliance-weighted split: same accelerations, same equilibrium (G^T lambda), different and
  // stiffer-biased split of the vertical load (arm 1 is twice as stiff as arm 2 in the scene).
  System mn = load("planar_arms_load");
  System cp = mn;
  cp.options.redundancy = Redundancy::kCompliance;
  Workspace a(mn), b(cp);
  const Eigen::VectorXd v = Eigen::VectorXd::Zero(mn.model.nv()), tau = v;
  evaluate(mn, a, mn.q0, v, tau);
  evaluate(cp, b, cp.q0, v, tau);
  EXPECT_LT((a.vdot - b.vdot).norm(), 1e-9);
  EXPECT_LT((a.cd.G.transpose() * (a.lambda - b.lambda)).norm(), 1e-8 * a.lambda.norm());
  const double fz1 = tip_wrench(cp, b, 0)[5], fz2 = tip_wrench(cp, b, 1)[5];
  EXPECT_GT(fz1, fz2 + 1.0);  // the stiffer support carries more
  EXPECT_NEAR(fz1 + fz2, tip_wrench(mn, a, 0)[5] + tip_wrench(mn, a, 1)[5], 1e-8);
}

TEST(PseudoJoints, SchurFormEqualsLockMultipliersOfTheCombinedSolve) {
  // (24)-(26) with d4^-1 vs the locks as rows of one solve: same accelerations, same stresses; and
  // the SVD baseline's lock multipliers are the same stresses
  std::mt19937 rng(27);
  const System comb = load("four_bar");
  const System schur = load("four_bar", Formulation::kPseudoJointSchur);
  const System svd = load("four_bar", Formulation::kSvdBaseline);
  ASSERT_EQ(comb.model.pseudo_dofs.size(), 2u);
  Workspace wc(comb), ws(schur), wsvd(svd);
  for (int k = 0; k < 5; ++k) {
    const Eval e = consistent_state(comb, rng, 1.0, true);
    const Diagnostics& dc = evaluate(comb, wc, e.q, e.v, e.tau);
    const Diagnostics& dsch = evaluate(schur, ws, e.q, e.v, e.tau);
    ASSERT_EQ(dc.status, Status::kOk);
    ASSERT_EQ(dsch.status, Status::kOk) << reason_text(dsch.reason);
    EXPECT_LT((wc.vdot - ws.vdot).norm(), 1e-8 * (1 + wc.vdot.norm()));
    EXPECT_LT((wc.stress - ws.stress).norm(), 1e-8 * (1 + wc.stress.norm()));
    ASSERT_NE(evaluate(svd, wsvd, e.q, e.v, e.tau).status, Status::kError);
    EXPECT_GT(wc.stress.norm(), 1e-6);
    EXPECT_LT((wc.stress - wsvd.stress).norm(), 1e-8 * (1 + wc.stress.norm()));
    for (int dof : comb.model.pseudo_dofs) EXPECT_NEAR(ws.vdot[dof], 0.0, 1e-9);
    EXPECT_LT((tip_wrench(comb, wc, 0) - tip_wrench(schur, ws, 0)).norm(), 1e-8 * (1 + wc.lambda.norm()));
  }
}

TEST(PseudoJoints, StaticStressesBalanceTheStructure) {
  // At rest in the four-bar with the holding torque at j1: the crank's mid-span bending moment
  // equals the moment of the outboard forces about that point; computed independently from the
  // joint-2 force of RNEA, the weight of crank_b and the geometry.
  System sys = load("four_bar");
  const Model& m = sys.model;
  Workspace ws(sys);
  const Eigen::VectorXd v = Eigen::VectorXd::Zero(m.nv());
  // find the j1 torque that holds the mechanism still (1 DOF: vdot is linear in tau_j1)
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(m.nv());
  const int j1 = m.bodies[m.joint_index("j1")].joint.idx_v;
  evaluate(sys, ws, sys.q0, v, tau);
  const Eigen::VectorXd a0 = ws.vdot;
  tau[j1] = 1.0;
  evaluate(sys, ws, sys.q0, v, tau);
  const Eigen::VectorXd a1 = ws.vdot - a0;
  tau[j1] = -a0.dot(a1) / a1.squaredNorm();
  evaluate(sys, ws, sys.q0, v, tau);
  ASSERT_LT(ws.vdot.norm(), 1e-9);
  // moment balance of crank_b about its joint: M_bend + (r_A x F_A) + (r_c x m g) = 0, with F_A the
  // force the coupler exerts on the crank tip = -(force transmitted into coupler_a1), from RNEA
  std::vector<Vec6> fext(m.nbodies(), Vec6::Zero());
  const ConstraintSpec& cut = sys.constraints.specs[0];
  const Vec6 wA = tip_wrench(sys, ws, 0);
  fext[m.frames[cut.frame_a].body] += m.frames[cut.frame_a].X_BF.act_force(wA);
  const Transform X_WA = frame_pose(m, ws.data, cut.frame_a);
  const int bB = m.frames[cut.frame_b].body;
  fext[bB] -= ws.data.X_WB[bB].inv_act_force(X_WA.act_force(wA));
  Eigen::VectorXd tr(m.nv());
  rnea(m, ws.data, ws.vdot, &fext, tr);
  const int cb = m.body_index("crank_b"), c1 = m.body_index("coupler_a1");
  // force on crank_b from coupler_a1 (in crank_b frame): minus what crank_b transmits to it
  const Transform X_PB = ws.data.X_WB[m.bodies[c1].parent].inverse() * ws.data.X_WB[c1];
  const Vec6 F_tip = -X_PB.act_force(ws.data.f[c1]);
  const Vec3 g_b = ws.data.X_WB[cb].R.transpose() * m.gravity_W * m.bodies[cb].inertia.m;
  const double moment = F_tip[2] + m.bodies[cb].inertia.c.cross(g_b).z();
  // the lock at the crank_bend joint supplies the rest: stress + moment = 0
  EXPECT_NEAR(ws.stress[0] + moment, 0.0, 1e-9);
  EXPECT_NEAR(tr[m.pseudo_dofs[0]], ws.stress[0], 1e-9);
  // and the coupler slider's axial force is what RNEA transmits along the coupler at the slider
  const int ca2 = m.body_index("coupler_a2");
  EXPECT_NEAR(ws.data.f[ca2][3], ws.stress[1], 1e-9);
}

TEST(PseudoJoints, DependentLocksAreADesignErrorNotANaN) {
  // The paper's Fig. 4 choice: lock two real joints of the four-bar (j2 and j3). Their locks
  // depend on the loop: d4 is singular. The Schur form says so; the combined solve reports the
  // dependency as indeterminate. Neither produces NaN.
  System sys = load("four_bar");
  std::string text;
  {
    std::ifstream f(scene_path("four_bar"));
    std::stringstream ss;
    ss << f.rdbuf();
    text = ss.str();
  }
  auto replace = [&](const std::string& a, const std::string& b) {
    const auto p = text.find(a);
    ASSERT_NE(p, std::string::npos) << a;
    text.replace(p, a.size(), b);
  };
  // a plain four-bar (the mid-crank and coupler pseudo-joints welded shut) ...
  replace("{type: revolute, axis: [0, 0, 1], name: crank_bend, pseudo: true, q: 0}", "{type: fixed}");
  replace("{type: prismatic, axis: [1, 0, 0], name: coupler_axial, pseudo: true, q: 0}", "{type: fixed}");
  // ... with joints 2 and 3 declared pseudo
  replace("name: j2,", "name: j2, pseudo: true,");
  replace("name: j3,", "name: j3, pseudo: true,");
  const System comb = load_scene_string(text, "four_bar_fig4.yaml");
  SceneOverrides ov;
  ov.formulation = Formulation::kPseudoJointSchur;
  const System schur = load_scene_string(text, "four_bar_fig4.yaml", ov);
  Workspace wc(comb), ws(schur);
  const Eigen::VectorXd v = Eigen::VectorXd::Zero(comb.model.nv()), tau = v;
  const Diagnostics& ds = evaluate(schur, ws, schur.q0, v, tau);
  EXPECT_EQ(ds.status, Status::kError);
  EXPECT_EQ(ds.reason, Reason::kPseudoBlockSingular);
  EXPECT_TRUE(ws.vdot.allFinite());
  const Diagnostics& dc = evaluate(comb, wc, comb.q0, v, tau);
  EXPECT_EQ(dc.status, Status::kIndeterminate);
  EXPECT_GE(dc.indeterminate, 1);
  EXPECT_TRUE(wc.vdot.allFinite() && wc.lambda.allFinite());
}

TEST(ConstrainedDynamics, BadInputGivesAnErrorStatusNotANaN) {
  const System sys = load("two_puma_load");
  Workspace ws(sys);
  Eigen::VectorXd q = sys.q0, v = sys.v0, tau = Eigen::VectorXd::Zero(sys.model.nv());
  tau[7] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(evaluate(sys, ws, q, v, tau).reason, Reason::kNonFiniteInput);
  EXPECT_TRUE(ws.vdot.allFinite());
  tau[7] = 0;
  q[3] = 2.0;  // quaternion far from unit
  EXPECT_EQ(evaluate(sys, ws, q, v, tau).reason, Reason::kNonFiniteInput);
  Eigen::VectorXd short_v = Eigen::VectorXd::Zero(3);
  EXPECT_EQ(evaluate(sys, ws, sys.q0, short_v, tau).reason, Reason::kNonFiniteInput);
}

// The condition diagnostic with a nominal base-link inertia: an arm in the mobile-platform
// form whose joint 1 has no armature moves only its base link with joint 1, and that link carries
// a nominal rotational inertia I_n (no mass) so that M is regular. The base weld holds it, so the
// results do not depend on I_n, and the condition reported must not either: it is measured with
// the direction that does work on joint 1 eliminated. Checked on planar_arms_load (rank path) and
// on two PUMAs without joint-1 armature (fast path), with I_n = 1e-3 (the builder's), 1e-6 and 1,
// against the eigenvalue condition of Q restricted, by an independent QR, to the rows that do no
// work on any joint 1.
namespace {

struct NominalRun {
  Diagnostics d;
  Eigen::VectorXd vdot, lambda, eig_condition_raw, reduced_eigs;
};

NominalRun run_with_nominal(const System& base, double I_n) {
  System sys = base;
  for (const System::NominalBase& nb : sys.nominal_bases) sys.model.bodies[nb.body].inertia = Inertia(0.0, Vec3::Zero(), I_n * Mat3::Identity());
  Workspace ws(sys);
  std::mt19937 rng(7);
  const Eval e = consistent_state(sys, rng, 0.3, true);
  NominalRun r;
  r.d = evaluate(sys, ws, e.q, e.v, e.tau);
  r.vdot = ws.vdot;
  r.lambda = ws.lambda;
  // Q = G M^-1 G^T at the evaluated state, formed here from the dense M (the solve may have factored
  // R Q R^T only)
  crba(sys.model, ws.data);
  const Eigen::MatrixXd Q = ws.cd.G * ws.data.M.ldlt().solve(ws.cd.G.transpose());
  // Q's eigenvalues, and those of Q on the complement of the joint-1 columns of G (QR of them)
  const int m = sys.constraints.rows;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Q);
  r.eig_condition_raw = es.eigenvalues();
  Eigen::MatrixXd U = Eigen::MatrixXd::Zero(m, static_cast<Eigen::Index>(ws.nominal_rows.size()));
  for (size_t a = 0; a < ws.nominal_rows.size(); ++a) {
    const auto [dof, r0] = ws.nominal_rows[a];
    U.block(r0, static_cast<Eigen::Index>(a), 6, 1) = ws.cd.G.block(r0, dof, 6, 1);
  }
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(U);
  const Eigen::MatrixXd Qf = qr.householderQ() * Eigen::MatrixXd::Identity(m, m);
  const Eigen::MatrixXd N = Qf.rightCols(m - U.cols());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> er(N.transpose() * Q * N);
  r.reduced_eigs = er.eigenvalues();
  return r;
}

// lambda_max / lambda_min over the eigenvalues above rank_tol * lambda_max (Q's range)
double eig_condition(const Eigen::VectorXd& ev) {
  const double mx = ev.maxCoeff();
  double mn = mx;
  for (int i = 0; i < ev.size(); ++i)
    if (ev[i] > 1e-10 * mx) mn = std::min(mn, ev[i]);
  return mx / mn;
}

}  // namespace

TEST(ConstrainedDynamics, ConditionDoesNotDependOnTheNominalBaseInertia) {
  // two PUMAs whose joint 1 has no armature (the shipped robot has the motor's 0.784 kg m^2)
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("coopdyn_nominal_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::string robot;
  {
    std::ifstream in(std::string(COOPDYN_SOURCE_DIR) + "/config/robots/puma560.yaml");
    std::stringstream ss;
    ss << in.rdbuf();
    robot = ss.str();
  }
  const size_t at = robot.find("armature: 0.7840");
  ASSERT_NE(at, std::string::npos);
  robot.replace(at, 16, "armature: 0.0");
  { std::ofstream(dir / "puma_no_arm1.yaml") << robot; }
  std::string scene;
  {
    std::ifstream in(scene_path("two_puma_load"));
    std::stringstream ss;
    ss << in.rdbuf();
    scene = ss.str();
  }
  const size_t f = scene.find("../robots/puma560.yaml");
  ASSERT_NE(f, std::string::npos);
  scene.replace(f, 22, (dir / "puma_no_arm1.yaml").string());
  EXPECT_TRUE(load("two_puma_load").nominal_bases.empty()) << "joint 1 has armature: no nominal direction";

  const std::vector<std::pair<std::string, System>> cases = {
      {"planar_arms_load", load("planar_arms_load")},
      {"two PUMAs without joint-1 armature", load_scene_string(scene, (dir / "two_puma_no_arm1.yaml").string())}};
  for (const auto& [label, sys] : cases) {
    SCOPED_TRACE(label);
    ASSERT_EQ(sys.nominal_bases.size(), 2u);
    const NominalRun a = run_with_nominal(sys, 1e-3), b = run_with_nominal(sys, 1e-6), c = run_with_nominal(sys, 1.0);
    ASSERT_NE(a.d.status, Status::kError);
    // where the factor with the nominal directions last fails the fast-path test (forced: fast_tol 1),
    // Q itself is formed and the rank path solves it: the same rank and solution (the minimum-norm
    // one where Q is singular, the planar arms; the unique one for the PUMAs)
    System forced = sys;
    forced.options.fast_tol = 1.0;
    const NominalRun f = run_with_nominal(forced, 1e-3);
    EXPECT_EQ(f.d.rank, a.d.rank);
    EXPECT_LT((f.vdot - a.vdot).cwiseAbs().maxCoeff(), 1e-9 * (1 + a.vdot.cwiseAbs().maxCoeff()));
    EXPECT_LT((f.lambda - a.lambda).cwiseAbs().maxCoeff(), 1e-9 * (1 + a.lambda.cwiseAbs().maxCoeff()));
    EXPECT_TRUE(std::isfinite(f.d.condition) && f.d.condition >= 1.0);
    // the results do not depend on I_n ...
    EXPECT_LT((a.vdot - b.vdot).cwiseAbs().maxCoeff(), 1e-6 * (1 + a.vdot.cwiseAbs().maxCoeff()));
    EXPECT_LT((a.lambda - c.lambda).cwiseAbs().maxCoeff(), 1e-6 * (1 + a.lambda.cwiseAbs().maxCoeff()));
    // ... Q's own condition does, by the factor of I_n ...
    EXPECT_GT(eig_condition(b.eig_condition_raw), 100 * eig_condition(a.eig_condition_raw));
    // ... the reported one does not: the same to O(I_n / the links' inertias) between 1e-3 and 1e-6
    // (measured: PUMAs 29.57 / 29.61 (fast path: the unpivoted pivot ratio), planar arms, links of 0.0017-0.042 kg m^2 about their axes, 58.4 / 60.7; Q's own
    // condition 3.2e4 / 3.2e7 and 4.6e3 / 4.6e6)
    std::printf("%s: reported condition %.6g (I_n = 1e-3), %.6g (1e-6), %.6g (1); Q's eigenvalue condition %.3g, %.3g, %.3g\n",
                label.c_str(), a.d.condition, b.d.condition, c.d.condition, eig_condition(a.eig_condition_raw),
                eig_condition(b.eig_condition_raw), eig_condition(c.eig_condition_raw));
    EXPECT_NEAR(a.d.condition / b.d.condition, 1.0, 0.05);
    // and it estimates the reduced Q's eigenvalue condition (pivot ratio: within a factor rows)
    const double truth = eig_condition(b.reduced_eigs);
    const int m = sys.constraints.rows;
    EXPECT_LE(b.d.condition, m * truth);
    EXPECT_GE(b.d.condition, truth / m);
    EXPECT_NEAR(eig_condition(a.reduced_eigs) / truth, 1.0, 0.05);
  }
  std::filesystem::remove_all(dir);
}

// Compliance on the grasps: in the classic form an arm's `compliance` weights its grasp
// weld's rows, and the compliance rule's split of the indeterminate forces is the elastic solution
// of the load resting on two springs of stiffness K_i = C_i^-1 at the grasps, the arms rigid in
// those directions (Menabrea: the rigid-support split minimizing lambda^T C lambda is the one of
// least complementary energy). planar_arms_load at rest: the out-of-plane rows (wx, wy, vz of each
// grasp) carry the load's weight and are free; solved here independently as a 3-DOF spring problem
// for the load's small displacement (wx, wy, vz) and compared with the solver's multipliers.
TEST(ConstrainedDynamics, GraspComplianceSplitIsTheElasticSolution) {
  System sys = load("planar_arms_load", Formulation::kClassic);
  sys.options.redundancy = Redundancy::kCompliance;
  Workspace ws(sys);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(sys.model.nv());
  const Diagnostics d = evaluate(sys, ws, sys.q0, zero, zero);
  ASSERT_EQ(d.status, Status::kIndeterminate);
  ASSERT_EQ(d.indeterminate, 3);
  const ConstraintSet& cs = sys.constraints;
  ASSERT_EQ(cs.specs.size(), 2u);
  const int L = sys.model.body_index("load");
  ASSERT_GE(L, 0);
  const int sel[3] = {0, 1, 5};  // wx, wy, vz: of the grasp frames and of the load frame
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  std::vector<Eigen::Matrix3d> B(2), K(2);
  for (int i = 0; i < 2; ++i) {
    const ConstraintSpec& s = cs.specs[i];
    for (int k = 0; k < 6; ++k)  // the free rows are the out-of-plane ones, and only they
      EXPECT_EQ(ws.qs.row_indeterminate[cs.row_offset[i] + k] != 0, k == 0 || k == 1 || k == 5) << s.name << " row " << k;
    ASSERT_EQ(sys.model.frames[s.frame_b].body, L);
    const Mat6 Ad = sys.model.frames[s.frame_b].X_BF.inverse().motion_matrix();  // load twist -> grasp frame
    K[i].setZero();
    for (int r = 0; r < 3; ++r) {
      K[i](r, r) = 1.0 / s.compliance[sel[r]];
      for (int c = 0; c < 3; ++c) B[i](r, c) = Ad(sel[r], sel[c]);
    }
    A += B[i].transpose() * K[i] * B[i];
  }
  // the load's weight about its origin, in load coordinates (the load frame is level)
  const Inertia& I = sys.model.bodies[L].inertia;
  const Mat3 R_WL = ws.data.X_WB[L].R;
  ASSERT_LT((R_WL - Mat3::Identity()).norm(), 1e-12);
  const Vec3 f = I.m * sys.model.gravity_W, n = I.c.cross(f);
  const Eigen::Vector3d W(n.x(), n.y(), f.z());
  // the springs' wrench on the load is -K B delta each; the load's wrench on the end-effector is
  // lambda_i = +K B delta, and the load balances: sum B^T (-lambda_i) + W = 0
  const Eigen::Vector3d delta = A.ldlt().solve(W);
  double total = 0.0;
  for (int i = 0; i < 2; ++i) {
    const Eigen::Vector3d lam_elastic = K[i] * B[i] * delta;
    Eigen::Vector3d lam;
    for (int r = 0; r < 3; ++r) lam[r] = ws.lambda[cs.row_offset[i] + sel[r]];
    std::printf("grasp %d: solver (%.9g, %.9g, %.9g), springs (%.9g, %.9g, %.9g)\n", i, lam[0], lam[1], lam[2],
                lam_elastic[0], lam_elastic[1], lam_elastic[2]);
    EXPECT_LT((lam - lam_elastic).norm(), 1e-8 * (1 + lam.norm()));
    total += lam[2];
  }
  EXPECT_NEAR(total, I.m * sys.model.gravity_W.z(), 1e-8) << "the load presses on the end-effectors with its weight";
}
