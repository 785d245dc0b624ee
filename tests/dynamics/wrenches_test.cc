// Forces everywhere (service/dynamics/wrenches.h, service/algorithms/joint_reactions.h): the
// end-effector, base, axle and joint-reaction wrenches, checked against identities that do not
// use the code under test: the other formulation's multipliers, Newton-Euler of each body alone
// (momentum rates by central differences), inverse dynamics, the joint torques, a four-bar cut
// elsewhere.
#include <gtest/gtest.h>

#include <map>

#include "service/algorithms/joint_reactions.h"
#include "service/dynamics/integrators.h"
#include "service/dynamics/wrenches.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {

struct State {
  Eigen::VectorXd q, v, tau;
};

// A random state that satisfies the constraints: q perturbed then projected onto the constraint
// manifold (Gauss-Newton), v random then projected onto the null space of G, tau random.
State random_consistent_state(const System& sys, std::mt19937& rng, double spread) {
  System s = sys;
  s.options.projection_iterations = 30;
  Stepper st(s);
  State e;
  random_state(s, rng, spread, e.q, e.v);
  project_state(s, st, e.q, e.v);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  e.tau = Eigen::VectorXd::Zero(s.model.nv());
  for (int i = 0; i < s.model.nv(); ++i)
    if (std::isfinite(s.tau_limit[i]) && s.tau_limit[i] > 0) e.tau[i] = 5.0 * U(rng);  // actuated DOFs
  return e;
}

Eigen::VectorXd remap(const std::vector<std::string>& to, const std::vector<std::string>& from, const Eigen::VectorXd& x) {
  Eigen::VectorXd y(static_cast<Eigen::Index>(to.size()));
  for (size_t i = 0; i < to.size(); ++i) y[static_cast<Eigen::Index>(i)] = x[index_of(from, to[i])];
  return y;
}

std::map<std::string, int> output_index(const System& sys) {
  std::map<std::string, int> m;
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k) m[sys.wrenches.outputs[k].name] = static_cast<int>(k);
  return m;
}

const WrenchOutput& output(const System& sys, const std::string& name) {
  for (const WrenchOutput& o : sys.wrenches.outputs)
    if (o.name == name) return o;
  ADD_FAILURE() << "no wrench output " << name;
  return sys.wrenches.outputs.front();
}

// Spatial momentum of body b about the world origin, world coordinates, at (q, v).
Vec6 body_momentum(const Model& m, int b, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  Data d(m);
  forward_kinematics(m, d, q, v);
  return d.X_WB[b].act_force(m.bodies[b].inertia * to_ref(d, d.X_WB[b]).inv_act(d.V_W[b]));
}
// Its rate along the motion (central differences) and the body's gravity wrench, about the origin.
Vec6 momentum_rate(const Model& m, int b, const State& e, const Eigen::VectorXd& vdot) {
  const double eps = 1e-6;
  Eigen::VectorXd qp(m.nq()), qm(m.nq());
  integrate(m, e.q, e.v, eps, qp);
  integrate(m, e.q, e.v, -eps, qm);
  return (body_momentum(m, b, qp, e.v + eps * vdot) - body_momentum(m, b, qm, e.v - eps * vdot)) / (2 * eps);
}
Vec6 gravity_wrench(const Model& m, const Data& d, int b) {
  const Inertia& I = m.bodies[b].inertia;
  const Vec3 c = d.X_WB[b].R * I.c + d.X_WB[b].p;
  Vec6 F;
  F << c.cross(I.m * m.gravity_W), I.m * m.gravity_W;
  return F;
}

// A wrench output in world coordinates about the world origin.
Vec6 world_wrench(const System& sys, const Data& d, const WrenchData& wd, const std::string& name) {
  const auto idx = output_index(sys);
  const auto it = idx.find(name);
  EXPECT_NE(it, idx.end()) << name;
  // the report frame's pose: for a link, its frame in the robot's chain (in the mobile-platform
  // tree not a body frame; the agreement with the classic form's body frames is tested above)
  return wrench_frame_pose(sys, d, it->second).act_force(wd.W[it->second]);
}

const std::vector<std::string> kArmScenes = {"two_puma_load", "two_5dof_arms_load", "planar_arms_load"};

TEST(Wrenches, EveryFormulationReportsTheSameEndEffectorBaseAndJointWrenches) {
  // The mobile-platform form reads the end-effector wrench off the reaction across the grasp and
  // the base wrench off a multiplier; the classic form the other way round. Both, and the pseudo-joint
  // and SVD forms (where it drops nothing), must agree at random consistent states (determinate components; planar_arms_load
  // is over-constrained and each form's rule splits its free part differently).
  std::mt19937 rng(180);
  for (const auto& name : kArmScenes) {
    SCOPED_TRACE(name);
    const System mp = load_with_reactions(name, Formulation::kMobilePlatform);
    const auto idx_mp = output_index(mp);
    for (int trial = 0; trial < 4; ++trial) {
      const State e = random_consistent_state(mp, rng, 0.3);
      Workspace wmp(mp);
      ASSERT_NE(evaluate(mp, wmp, e.q, e.v, e.tau).status, Status::kError);
      WrenchData dmp(mp);
      compute_wrenches(mp, wmp, dmp);
      for (auto f : {Formulation::kClassic, Formulation::kSvdBaseline}) {
        const System other = load_with_reactions(name, f);
        Workspace wo(other);
        ASSERT_NE(evaluate(other, wo, remap(other.model.q_names, mp.model.q_names, e.q),
                           remap(other.model.v_names, mp.model.v_names, e.v),
                           remap(other.model.v_names, mp.model.v_names, e.tau)).status,
                  Status::kError);
        // the SVD baseline integrates other dynamics where it drops a direction (two_5dof_arms_load:
        // one per arm; tests/dynamics/svd_baseline_test.cc); elsewhere it must agree
        if (wo.diag.dropped > 0) continue;
        WrenchData dot(other);
        compute_wrenches(other, wo, dot);
        ASSERT_EQ(other.wrenches.outputs.size(), mp.wrenches.outputs.size());
        int compared = 0;
        for (size_t k = 0; k < other.wrenches.outputs.size(); ++k) {
          const WrenchOutput& o = other.wrenches.outputs[k];
          const int j = idx_mp.at(o.name);
          EXPECT_EQ(mp.wrenches.outputs[j].frame, o.frame);
          EXPECT_EQ(mp.wrenches.outputs[j].by, o.by);
          EXPECT_EQ(mp.wrenches.outputs[j].kind, o.kind);
          EXPECT_EQ(static_cast<int>(k), j) << "listed in the same order";
          const double scale = 1.0 + dmp.W[j].norm();
          for (int c = 0; c < 6; ++c) {
            if ((dmp.indeterminate[j] | dot.indeterminate[k]) & (1u << c)) continue;
            EXPECT_NEAR(dot.W[k][c], dmp.W[j][c], 1e-9 * scale) << formulation_name(f) << " " << o.name << " " << c;
            ++compared;
          }
        }
        EXPECT_GT(compared, 6 * 4);
      }
    }
  }
}

TEST(Wrenches, EndEffectorWrenchesAndGravityMoveTheLoad) {
  // Newton-Euler of the load alone: the arms' wrenches on it (the negated end-effector wrenches)
  // plus its weight equal the rate of change of its momentum.
  std::mt19937 rng(181);
  for (const auto& name : kArmScenes)
    for (auto f : {Formulation::kMobilePlatform, Formulation::kClassic}) {
      SCOPED_TRACE(name + " " + formulation_name(f));
      const System sys = load(name, f);
      const Model& m = sys.model;
      const State e = random_consistent_state(sys, rng, 0.3);
      Workspace ws(sys);
      ASSERT_NE(evaluate(sys, ws, e.q, e.v, e.tau).status, Status::kError);
      WrenchData wd(sys);
      compute_wrenches(sys, ws, wd);
      const int L = m.body_index("load");
      Vec6 F = gravity_wrench(m, ws.data, L);
      int arms = 0;
      for (const WrenchOutput& o : sys.wrenches.outputs)
        if (o.kind == WrenchKind::kEndEffector) {
          F -= world_wrench(sys, ws.data, wd, o.name);
          ++arms;
        }
      EXPECT_EQ(arms, 2);
      const Vec6 hdot = momentum_rate(m, L, e, ws.vdot);
      EXPECT_LT((hdot - F).norm(), 1e-6 * (1 + F.norm())) << hdot.transpose() << " vs " << F.transpose();
    }
}

TEST(Wrenches, EveryLinkIsInBalanceUnderItsJointReactions) {
  // Newton-Euler of each link alone: the reaction at its own joint (on it), minus the reaction at
  // the next joint (the link's own on the next link), or the load's wrench at the end-effector for
  // the last link, plus its weight, equals its momentum rate.
  std::mt19937 rng(182);
  for (const auto& name : {"two_puma_load", "two_5dof_arms_load"})
    for (auto f : {Formulation::kMobilePlatform, Formulation::kClassic}) {
      SCOPED_TRACE(std::string(name) + " " + formulation_name(f));
      const System sys = load_with_reactions(name, f);
      const Model& m = sys.model;
      const State e = random_consistent_state(sys, rng, 0.3);
      Workspace ws(sys);
      ASSERT_NE(evaluate(sys, ws, e.q, e.v, e.tau).status, Status::kError);
      WrenchData wd(sys);
      compute_wrenches(sys, ws, wd);
      int links = 0;
      for (const std::string arm : {"arm1", "arm2"})
        for (int i = 1; i <= 6; ++i) {
          const std::string link = arm + ".link" + std::to_string(i);
          const int b = m.body_index(link);
          ASSERT_GE(b, 0) << link;
          Vec6 F = gravity_wrench(m, ws.data, b) + world_wrench(sys, ws.data, wd, arm + ".q" + std::to_string(i));
          F += i < 6 ? Vec6(-world_wrench(sys, ws.data, wd, arm + ".q" + std::to_string(i + 1)))
                     : world_wrench(sys, ws.data, wd, arm + ".ee");
          const Vec6 hdot = momentum_rate(m, b, e, ws.vdot);
          EXPECT_LT((hdot - F).norm(), 1e-6 * (1 + F.norm())) << link;
          ++links;
        }
      EXPECT_EQ(links, 12);
    }
}

TEST(Wrenches, AlongEachJointAxisTheReactionIsTheTorqueMinusTheArmatureTerm) {
  // Revolute joints of the arms (axis z of the link frame in DH) and of the four-bar: m_axis =
  // tau - armature * vdot; a pseudo-joint's axial component is its reported stress; a held joint
  // (fixed_joints) carries its whole torque in its bearing.
  std::mt19937 rng(183);
  for (const auto& name : {"two_puma_load", "two_5dof_arms_load", "planar_arms_load"})
    for (auto f : {Formulation::kMobilePlatform, Formulation::kClassic, Formulation::kSvdBaseline}) {
      SCOPED_TRACE(std::string(name) + " " + formulation_name(f));
      const System sys = load_with_reactions(name, f);
      const State e = random_consistent_state(sys, rng, 0.3);
      Workspace ws(sys);
      ASSERT_NE(evaluate(sys, ws, e.q, e.v, e.tau).status, Status::kError);
      WrenchData wd(sys);
      compute_wrenches(sys, ws, wd);
      int checked = 0;
      for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k) {
        const WrenchOutput& o = sys.wrenches.outputs[k];
        const int d = velocity_index_of(sys, o.name);
        if (o.kind != WrenchKind::kJoint || d < 0) continue;
        const double arm = sys.model.bodies[sys.model.dof_body[d]].joint.armature;
        EXPECT_EQ(o.constrained, 0x3b) << o.name;  // every component but mz
        EXPECT_NEAR(wd.W[k][2], e.tau[d] - arm * ws.vdot[d], 1e-9 * (1 + std::abs(e.tau[d]))) << o.name;
        ++checked;
      }
      EXPECT_GE(checked, 6);
    }
  for (auto f : {Formulation::kClassic, Formulation::kPseudoJointSchur, Formulation::kSvdBaseline}) {
    SCOPED_TRACE(std::string("four_bar ") + formulation_name(f));
    const System sys = load_with_reactions("four_bar", f);
    const State e = random_consistent_state(sys, rng, 0.0);
    State s = e;
    for (int dd : sys.model.pseudo_dofs) s.tau[dd] = 0;
    Workspace ws(sys);
    ASSERT_NE(evaluate(sys, ws, s.q, s.v, s.tau).status, Status::kError);
    WrenchData wd(sys);
    compute_wrenches(sys, ws, wd);
    const auto idx = output_index(sys);
    EXPECT_NEAR(wd.W[idx.at("crank_bend")][2], ws.stress[0], 1e-10 * (1 + std::abs(ws.stress[0])));  // revolute about z
    EXPECT_NEAR(wd.W[idx.at("coupler_axial")][3], ws.stress[1], 1e-10 * (1 + std::abs(ws.stress[1])));  // prismatic along x
    for (const std::string j : {"j1", "j2", "j3", "j4"}) EXPECT_NEAR(wd.W[idx.at(j)][2], 0.0, 1e-10) << j;  // unactuated pins
  }
}

TEST(Wrenches, HeldJointCarriesItsTorqueInItsBearing) {
  // two_5dof_arms_load holds joint 6 of each PUMA fixed: its reaction is reported, all six
  // components carried by the joint, and it balances the links around it like any other.
  const System sys = load_with_reactions("two_5dof_arms_load");
  const WrenchOutput& o = output(sys, "arm1.q6");
  EXPECT_EQ(o.constrained, 0x3f);
  EXPECT_EQ(velocity_index_of(sys, "arm1.q6"), -1);
}

TEST(Wrenches, JointReactionsEqualInverseDynamicsWithTheConstraintForces) {
  // The pass of joint_reactions.h (bias subtree sums reused, welded groups added at fixed joints)
  // against rnea() with each body's own inertia and the constraint forces as external forces: the
  // same transmitted force at every joint, and rnea's torques equal the applied ones plus the
  // locks' multipliers.
  std::mt19937 rng(184);
  for (const auto& name : {"two_puma_load", "two_5dof_arms_load", "planar_arms_load", "four_bar", "two_wheel_vehicle"}) {
    SCOPED_TRACE(name);
    const System sys = load_with_reactions(name);
    const Model& m = sys.model;
    const State e = random_consistent_state(sys, rng, std::string(name) == "four_bar" ? 0.0 : 0.3);
    Workspace ws(sys);
    ASSERT_NE(evaluate(sys, ws, e.q, e.v, e.tau).status, Status::kError);
    WrenchData wd(sys);
    compute_wrenches(sys, ws, wd);
    ASSERT_FALSE(sys.wrenches.pass.empty());
    Data d(m);
    forward_kinematics(m, d, e.q, e.v);
    std::vector<Vec6> fext(m.nbodies(), Vec6::Zero());  // in each body's frame B, as rnea() takes them
    for (int b : sys.wrenches.pass) fext[b] = to_ref(d, d.X_WB[b]).inv_act_force(wd.f_ext[b]);
    // constraint forces on bodies outside the pass (the load) matter for rnea's torques only
    Eigen::VectorXd tau_id(m.nv());
    rnea(m, d, ws.vdot, &fext, tau_id);
    for (int b : sys.wrenches.pass) {
      const Vec6 R_B = to_ref(ws.data, ws.data.X_WB[b]).inv_act_force(wd.R[b]);
      EXPECT_LT((R_B - d.f[b]).norm(), 1e-9 * (1 + d.f[b].norm())) << m.bodies[b].name;
    }
  }
}

TEST(Wrenches, FourBarCutAtTheCouplerAndAtTheRockerPinAgree) {
  // The same four-bar cut in two places. Scene A (shipped): cut in the middle of the coupler, a
  // weld (wz, vx, vy). Scene B: the coupler one chain (its halves welded where A cuts) and the loop
  // closed at the rocker pin j3 by a point constraint (vx, vy). B's cut force at the pin equals A's
  // reaction at j3, and A's cut wrench equals B's reaction across the coupler's weld.
  const System A = load_with_reactions("four_bar");
  std::string b = scene_text("four_bar");
  // coupler_b's frame has its origin at the rocker pin and x towards the cut (A's cut_b sits at
  // x = 0.5 with rpy pi and coincides with cut_a = coupler_a2 at x = 0.25): in coupler_a2 it is at
  // x = 0.75, turned by pi
  b = replace_once(b, "  - name: coupler_b\n    parent: rocker\n    placement: {xyz: [0.7, 0, 0]}\n"
                      "    joint: {type: revolute, axis: [0, 0, 1], name: j3, q: 2.1193206052359983}\n",
                   "  - name: coupler_b\n    parent: coupler_a2\n    placement: {xyz: [0.75, 0, 0], rpy: [0, 0, 3.141592653589793]}\n"
                   "    joint: {type: fixed, name: coupler_weld}\n");
  b = replace_once(b, "  - {name: cut_a, body: coupler_a2, xyz: [0.25, 0, 0]}\n  - {name: cut_b, body: coupler_b, xyz: [0.5, 0, 0], rpy: [0, 0, 3.141592653589793]}\n",
                   "  - {name: pin_c, body: coupler_b, xyz: [0, 0, 0]}\n  - {name: pin_r, body: rocker, xyz: [0.7, 0, 0]}\n");
  b = without_reactions(b);
  b = replace_once(b, "  - {name: coupler_cut, type: weld, frame: cut_a, to: cut_b, axes: [wz, vx, vy]}",
                   "  - {name: pin, type: weld, frame: pin_c, to: pin_r, axes: [vx, vy]}");
  const System B = load_scene_string(b + "\nreactions: all\n", scene_path("four_bar"));
  // the same state: A's joint coordinates, j3 dropped
  Workspace wa(A), wb(B);
  const Eigen::VectorXd tau_a = Eigen::VectorXd::Zero(A.model.nv()), tau_b = Eigen::VectorXd::Zero(B.model.nv());
  ASSERT_NE(evaluate(A, wa, A.q0, A.v0, tau_a).status, Status::kError);
  const Eigen::VectorXd qb = remap(B.model.q_names, A.model.q_names, A.q0);
  ASSERT_NE(evaluate(B, wb, qb, Eigen::VectorXd::Zero(B.model.nv()), tau_b).status, Status::kError);
  EXPECT_LT((remap(B.model.v_names, A.model.v_names, wa.vdot) - wb.vdot).norm(), 1e-9 * (1 + wa.vdot.norm()));
  WrenchData da(A), db(B);
  compute_wrenches(A, wa, da);
  compute_wrenches(B, wb, db);
  const auto ia = output_index(A), ib = output_index(B);
  // A's reaction at j3 (rocker on coupler_b, in coupler_b at the pin) vs B's pin force (rocker's
  // pin_r on coupler_b's pin_c, in pin_c = coupler_b's frame at the pin)
  const Vec6 r_j3 = da.W[ia.at("j3")], pin = db.W[ib.at("pin")];
  EXPECT_NEAR(r_j3[3], pin[3], 1e-9);
  EXPECT_NEAR(r_j3[4], pin[4], 1e-9);
  EXPECT_NEAR(r_j3[5], 0.0, 1e-12);
  // A's cut wrench (cut_b's side on cut_a, in cut_a) vs B's weld reaction (coupler_a2 on coupler_b,
  // in coupler_b): the same interaction seen from the other side, so world wrenches of opposite sign
  const Vec6 cut_W = frame_pose(A.model, wa.data, A.model.frame_index("cut_a")).act_force(da.W[ia.at("coupler_cut")]);
  const Vec6 weld_W = wb.data.X_WB[B.model.body_index("coupler_b")].act_force(db.W[ib.at("coupler_weld")]);
  EXPECT_LT((cut_W + weld_W).norm(), 1e-9 * (1 + cut_W.norm())) << cut_W.transpose() << " vs " << weld_W.transpose();
  // the stresses do not depend on where the loop is cut
  for (Eigen::Index k = 0; k < wa.stress.size(); ++k) EXPECT_NEAR(wa.stress[k], wb.stress[k], 1e-9);
}

TEST(Wrenches, WheelAxleCarriesTheDriveTorqueAndBalancesTheWheel) {
  // two_wheel_vehicle: each wheel hangs from the rod by its spin joint. Along the wheel's axle the
  // axle wrench is the drive torque (an upright wheel: the centre frame's y is the axle); the wheel
  // is in balance under its axle wrench, the ground's contact force and its weight; the split of
  // the lateral force between the wheels (a rigid axle) is flagged indeterminate in the axle too,
  // with the moment it makes about the wheel centre.
  std::mt19937 rng(185);
  const System sys = load("two_wheel_vehicle");
  const Model& m = sys.model;
  for (int trial = 0; trial < 3; ++trial) {
    State e = random_consistent_state(sys, rng, 0.0);
    e.tau.setZero();
    e.tau[velocity_index_of(sys, "left_spin")] = 1.0;
    e.tau[velocity_index_of(sys, "right_spin")] = -0.4;
    Workspace ws(sys);
    ASSERT_NE(evaluate(sys, ws, e.q, e.v, e.tau).status, Status::kError);
    WrenchData wd(sys);
    compute_wrenches(sys, ws, wd);
    for (const std::string w : {"left", "right"}) {
      const auto idx = output_index(sys);
      const WrenchOutput& ax = sys.wrenches.outputs[idx.at(w + ".axle")];
      EXPECT_EQ(ax.kind, WrenchKind::kAxle);
      EXPECT_EQ(ax.frame, w + ".centre");
      EXPECT_EQ(ax.by, "rod");
      const int d = velocity_index_of(sys, w + "_spin");
      EXPECT_NEAR(wd.W[idx.at(w + ".axle")][1], e.tau[d], 1e-9) << w;
      // free: the lateral force and the overturning moment it makes about the centre (lever r)
      EXPECT_EQ(wd.indeterminate[idx.at(w + ".axle")], (1u << 4) | (1u << 0)) << w;
      const int b = m.body_index(w + "_wheel");
      const ConstraintSpec& c = sys.constraints.specs[sys.wrenches.outputs[idx.at(w)].spec];
      ASSERT_EQ(c.name, w);
      const Transform X_WC = rolling_contact_frame(m, ws.data, c);
      const Transform X_Wctr(X_WC.R, ws.data.X_WB[b].p);
      const Vec6 F = gravity_wrench(m, ws.data, b) + X_WC.act_force(wd.W[idx.at(w)]) + X_Wctr.act_force(wd.W[idx.at(w + ".axle")]);
      const Vec6 hdot = momentum_rate(m, b, e, ws.vdot);
      EXPECT_LT((hdot - F).norm(), 1e-6 * (1 + F.norm())) << w;
    }
  }
}

TEST(Wrenches, ReactionsAreAskedForByName) {
  const std::string t = without_reactions(scene_text("two_puma_load"));
  const System none = load_scene_string(t, scene_path("two_puma_load"));
  for (const WrenchOutput& o : none.wrenches.outputs) EXPECT_NE(o.kind, WrenchKind::kJoint) << "default: none";
  const System two = load_scene_string(t + "\nreactions: [arm2.q3, arm1.q2]\n", scene_path("two_puma_load"));
  std::vector<std::string> joints;
  for (const WrenchOutput& o : two.wrenches.outputs)
    if (o.kind == WrenchKind::kJoint) joints.push_back(o.name);
  EXPECT_EQ(joints, (std::vector<std::string>{"arm1.q2", "arm2.q3"}));  // in the scene's order
  try {
    load_scene_string(t + "\nreactions: [arm1.q7]\n", scene_path("two_puma_load"));
    ADD_FAILURE() << "an unknown joint must be a scene error";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("two_puma_load.yaml:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("unknown joint 'arm1.q7'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(load_scene_string(t + "\nreactions: some\n", scene_path("two_puma_load")), SceneError);
  EXPECT_THROW(load_scene_string(t + "\nreactions: [arm1.q2, arm1.q2]\n", scene_path("two_puma_load")), SceneError);
  try {  // a key given twice is an error, not a silent choice of one
    load_scene_string(t + "\nreactions: all\nreactions: none\n", scene_path("two_puma_load"));
    ADD_FAILURE() << "a duplicate key must be a scene error";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("duplicate key 'reactions'"), std::string::npos) << e.what();
  }
}

TEST(Wrenches, FailedEvaluationReportsZeros) {
  const System sys = load_with_reactions("two_puma_load");
  Workspace ws(sys);
  Eigen::VectorXd v = sys.v0;
  v[0] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(evaluate(sys, ws, sys.q0, v, Eigen::VectorXd::Zero(sys.model.nv())).status, Status::kError);
  WrenchData wd(sys);
  for (auto& w : wd.W) w.setConstant(7.0);
  compute_wrenches(sys, ws, wd);
  for (const auto& w : wd.W) EXPECT_EQ(w, Vec6::Zero());
}

}  // namespace
}  // namespace coopdyn::testing
