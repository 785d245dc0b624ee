// Whole robots: a URDF's whole tree as a robot entry of `bodies` (service/scene/urdf_tree.cc,
// build_tree.cc). Two arms on a shared torso holding a box (Newton-Euler of the box and of the
// torso; the same wrenches as the system written body by body), the same M and h as the chain
// reader on an unbranched URDF, every link's mass kept, a wheeled base on wheels whose axles and
// radii come from the URDF, and the errors.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <unistd.h>

#include "service/dynamics/holding_torque.h"
#include "service/dynamics/wrenches.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {

std::string data_path(const std::string& file) { return std::string(COOPDYN_SOURCE_DIR) + "/tests/scene/data/" + file; }

int output_index(const System& sys, const std::string& name) {
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k)
    if (sys.wrenches.outputs[k].name == name) return static_cast<int>(k);
  ADD_FAILURE() << "no output " << name;
  return 0;
}

int spec_index(const System& sys, const std::string& name) {
  for (size_t s = 0; s < sys.constraints.specs.size(); ++s)
    if (sys.constraints.specs[s].name == name) return static_cast<int>(s);
  ADD_FAILURE() << "no constraint " << name;
  return 0;
}

double model_mass(const Model& m, const std::string& prefix) {
  double M = 0;
  for (const Body& b : m.bodies)
    if (b.name.rfind(prefix, 0) == 0) M += b.inertia.m;
  return M;
}

// output k's wrench as a force and a moment about point o, world coordinates
struct WorldWrench {
  Vec3 f, m;
};
WorldWrench in_world(const System& sys, const Workspace& ws, const WrenchData& wd, const std::string& name, const Vec3& o) {
  const int k = output_index(sys, name);
  const Transform X = wrench_frame_pose(sys, ws.data, k);
  const Vec3 f = X.R * wd.W[k].tail<3>();
  return {f, X.R * wd.W[k].head<3>() + (X.p - o).cross(f)};
}

std::string error_of(const std::string& text, const std::string& file) {
  try {
    load_scene_string(text, file);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "(loaded)";
}

TEST(UrdfTree, TwoArmsOnASharedTorsoHoldABox) {
  const System s = load_scene(data_path("two_arm_torso_box.yaml"));
  const System e = load_scene(data_path("two_arm_torso_box_bodies.yaml"));  // the same, body by body
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  ASSERT_EQ(s.model.nv(), 9 + 6);  // the lift, 2 x 4 arm joints, the box
  ASSERT_EQ(s.model.v_names, e.model.v_names);
  EXPECT_EQ(s.model.nbodies(), 1 + 1 + 2 * 5 + 1);  // every URDF link a body (hands on fixed joints too), the box
  EXPECT_GE(s.model.frame_index("duo.arm_left_3_link"), 0);  // and a frame
  // the holding torques (the box at rest in both hands): the world carries robot and box through
  // the root link's weld (the reaction `duo`), 36 + 2 kg
  HoldWorkspace hw(s, default_actuated(s));
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(s.model.nv());
  ASSERT_TRUE(holding_torque(s, hw, s.q0, s.v0, tau));
  {
    Workspace w0(s);
    evaluate(s, w0, s.q0, s.v0, tau);
    EXPECT_LT(w0.vdot.cwiseAbs().maxCoeff(), 1e-9);
    WrenchData wd0(s);
    compute_wrenches(s, w0, wd0);
    const WorldWrench root = in_world(s, w0, wd0, "duo", Vec3::Zero());
    EXPECT_NEAR(root.f.z(), 38.0 * 9.81, 1e-9 * 38.0 * 9.81);
    EXPECT_LT(root.f.head<2>().norm(), 1e-9);
  }
  // then a push on every actuated joint
  for (int i = 0; i < 9; ++i) tau[i] += 0.7 * std::sin(1.0 + i);
  Workspace ws(s), we(e);
  ASSERT_EQ(evaluate(s, ws, s.q0, s.v0, tau).status, Status::kOk);  // 12 independent grasp rows
  ASSERT_EQ(evaluate(e, we, e.q0, e.v0, tau).status, Status::kOk);
  EXPECT_EQ(ws.diag.rank, 12);
  WrenchData wd(s), wde(e);
  compute_wrenches(s, ws, wd);
  compute_wrenches(e, we, wde);
  EXPECT_LT((ws.vdot - we.vdot).norm(), 1e-12 * (1 + ws.vdot.norm()));
  for (const std::string h : {"left_hand", "right_hand"}) {
    const Vec6 a = wd.W[output_index(s, h)], b = wde.W[output_index(e, h)];
    EXPECT_LT((a - b).norm(), 1e-12 * (1 + a.norm())) << h << ": tree " << a.transpose() << " bodies " << b.transpose();
    std::printf("[ two_arm_torso_box ] %s: |W| %.6f, tree - bodies %.2e\n", h.c_str(), a.norm(), (a - b).norm());
    EXPECT_GT(a.tail<3>().norm(), 1.0) << h << " carries the box";
  }
  {  // and in motion (a velocity the grasps allow): the same accelerations and hands' wrenches
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> U(-1, 1);
    Eigen::VectorXd v(s.model.nv());
    for (int i = 0; i < v.size(); ++i) v[i] = U(rng);
    Workspace w1(s), w2(e);
    evaluate(s, w1, s.q0, v, tau);  // G at q0
    v = project_velocity(w1.cd.G, v);
    ASSERT_EQ(evaluate(s, w1, s.q0, v, tau).status, Status::kOk);
    ASSERT_EQ(evaluate(e, w2, e.q0, v, tau).status, Status::kOk);
    WrenchData x1(s), x2(e);
    compute_wrenches(s, w1, x1);
    compute_wrenches(e, w2, x2);
    EXPECT_LT((w1.vdot - w2.vdot).norm(), 1e-12 * (1 + w1.vdot.norm()));
    for (const std::string h : {"left_hand", "right_hand"}) {
      const Vec6 a = x1.W[output_index(s, h)], b = x2.W[output_index(e, h)];
      EXPECT_LT((a - b).norm(), 1e-12 * (1 + a.norm())) << h << " in motion";
    }
  }
  const Model& m = s.model;
  const Vec3 g = m.gravity_W;
  {  // Newton-Euler of the box: the hands' wrenches on it (the negated tip wrenches) and its weight
    const int box = m.body_index("box");
    const Transform& Xb = ws.data.X_WB[box];
    const Inertia& I = m.bodies[box].inertia;  // centre of mass at the box origin
    Vec3 F = I.m * g, M = Vec3::Zero();
    for (const std::string h : {"left_hand", "right_hand"}) {
      const WorldWrench w = in_world(s, ws, wd, h, Xb.p);
      F -= w.f;
      M -= w.m;
    }
    const int iv = m.bodies[box].joint.idx_v;  // body-frame [w; v] rates; at v = 0 the accelerations
    const Vec3 wdot = Xb.R * ws.vdot.segment<3>(iv), a = Xb.R * ws.vdot.segment<3>(iv + 3);
    EXPECT_LT((F - I.m * a).norm(), 1e-9) << "F " << F.transpose() << " m a " << (I.m * a).transpose();
    EXPECT_LT((M - Xb.R * I.Ic * Xb.R.transpose() * wdot).norm(), 1e-9);
    EXPECT_GT(a.norm(), 1e-3) << "the push accelerates the box";
    std::printf("[ two_arm_torso_box ] box: |F - m a| %.2e N, |M - I wdot| %.2e N*m\n", (F - I.m * a).norm(),
                (M - Xb.R * I.Ic * Xb.R.transpose() * wdot).norm());
  }
  {  // Newton-Euler of the torso: the lift joint's reaction on it, the arms' first joints' reactions
     // (the torso's on the arms, negated) and its weight move it along the lift (no rotation)
    const int t = m.body_index("duo.torso");
    const Transform& Xt = ws.data.X_WB[t];
    const Inertia& I = m.bodies[t].inertia;
    const WorldWrench lift = in_world(s, ws, wd, "duo.torso_lift_joint", Xt.p);
    const WorldWrench l1 = in_world(s, ws, wd, "duo.arm_left_1_joint", Xt.p);
    const WorldWrench r1 = in_world(s, ws, wd, "duo.arm_right_1_joint", Xt.p);
    const Vec3 c = Xt.R * I.c;
    const Vec3 F = lift.f - l1.f - r1.f + I.m * g, M = lift.m - l1.m - r1.m + c.cross(I.m * g);
    const Vec3 a = ws.vdot[m.bodies[t].joint.idx_v] * Vec3::UnitZ();
    EXPECT_LT((F - I.m * a).norm(), 1e-9) << "F " << F.transpose() << " m a " << (I.m * a).transpose();
    EXPECT_LT((M - c.cross(I.m * a)).norm(), 1e-9);
    EXPECT_GT(l1.f.norm(), 1.0);
    std::printf("[ two_arm_torso_box ] torso: |F - m a| %.2e N, |M - c x m a| %.2e N*m\n", (F - I.m * a).norm(),
                (M - c.cross(I.m * a)).norm());
  }
}

// M and h of robot `decl` (a `robots` entry) as an arm of `arms` (the chain reader) and as a robot
// entry of `bodies` (the tree reader) at the same placement, q and a random v
void expect_same_dynamics(const std::string& chain_decl, const std::string& tree_decl, const std::string& q, int n) {
  const std::string where = "{xyz: [0.1, -0.2, 0.3], rpy: [0.1, 0.2, 0.3]}";
  const System chain = load_scene_string("name: chain\nrobots:\n  r: " + chain_decl + "\narms:\n  - {name: a, robot: r, base: " +
                                             where + ", q: " + q + "}\n",
                                         scene_path("chain"));
  const System tree = load_scene_string("name: tree\nrobots:\n  r: " + tree_decl + "\nbodies:\n  - {name: a, robot: r, placement: " +
                                            where + ", q: " + q + "}\n",
                                        scene_path("tree"));
  ASSERT_EQ(chain.model.nv(), n);
  ASSERT_EQ(chain.model.v_names, tree.model.v_names);
  EXPECT_EQ(chain.q0, tree.q0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1, 1);
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = U(rng);
  Data dc(chain.model), dt(tree.model);
  for (auto [sys, d] : {std::pair<const System*, Data*>{&chain, &dc}, {&tree, &dt}}) {
    forward_kinematics(sys->model, *d, sys->q0, v);
    crba(sys->model, *d);
    rnea_bias(sys->model, *d);
  }
  EXPECT_LT((dc.M - dt.M).norm(), 1e-12 * dc.M.norm()) << dc.M - dt.M;
  EXPECT_LT((dc.h - dt.h).norm(), 1e-12 * dc.h.norm()) << (dc.h - dt.h).transpose();
  std::printf("[ %s ] chain vs tree: |dM| %.2e, |dh| %.2e\n", tree_decl.c_str(), (dc.M - dt.M).norm(), (dc.h - dt.h).norm());
}

TEST(UrdfTree, TheWholeTreeOfAChainIsTheChainReadersRobot) {
  // an unbranched URDF read by both readers; and the published iiwa14, whose chain ends at a tip
  // (its other leaf a massless frame), read whole
  expect_same_dynamics("{urdf: ../robots/planar3r.urdf}", "{urdf: ../robots/planar3r.urdf}", "[0.4, -0.7, 0.3]", 3);
  expect_same_dynamics("{urdf: ../robots/iiwa14.urdf, tip: iiwa_link_ee}", "{urdf: ../robots/iiwa14.urdf}",
                       "[0.3, -0.5, 0.7, -1.1, 0.4, 0.9, -0.6]", 7);
  // and every link's mass, the root's included, in a branched tree: 20 + 8 + 2 (1.5 + 1.2 + 0.8 + 0.2 + 0.3) kg
  EXPECT_NEAR(model_mass(load_scene(data_path("two_arm_torso_box.yaml")).model, "duo."), 36.0, 1e-12);
}

TEST(UrdfTree, AWheeledBaseWithArmsStandsOnItsWheels) {
  const System s = load_scene(data_path("mobile_two_arm.yaml"));
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  // axles from the wheel joints, radii from the cylinders (the right wheel's in <visual> only)
  for (const auto& [w, r] : std::vector<std::pair<std::string, double>>{{"wheel_l", 0.1}, {"wheel_r", 0.1}, {"caster_f", 0.05}, {"caster_b", 0.05}}) {
    const ConstraintSpec& c = s.constraints.specs[spec_index(s, w)];
    EXPECT_EQ(c.radius, r) << w;
    EXPECT_EQ(c.axle, Vec3::UnitY()) << w;
  }
  // at rest, held by the holding torques: the wheels carry the whole weight
  // (30 + 2 x 1 + 2 x (0.2 + 0.3) + 8 + 2 x 4 kg)
  const double M = model_mass(s.model, "mob.");
  EXPECT_NEAR(M, 49.0, 1e-12);
  HoldWorkspace hw(s, default_actuated(s));
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(s.model.nv());
  ASSERT_TRUE(holding_torque(s, hw, s.q0, s.v0, tau));
  Workspace ws(s);
  evaluate(s, ws, s.q0, s.v0, tau);
  ASSERT_NE(ws.diag.status, Status::kError);
  EXPECT_LT(ws.vdot.cwiseAbs().maxCoeff(), 1e-9) << ws.vdot.transpose();
  double normal = 0;
  for (const std::string w : {"wheel_l", "wheel_r", "caster_f", "caster_b"}) {
    const Vec6 f = tip_wrench(s, ws, spec_index(s, w));
    EXPECT_GT(f[5], 0.0) << w;
    normal += f[5];  // the contact frame's z is the ground normal
  }
  std::printf("[ mobile_two_arm ] normal forces sum %.12f N, weight %.12f N\n", normal, M * 9.81);
  EXPECT_NEAR(normal, M * 9.81, 1e-9 * M * 9.81);
}

TEST(UrdfTree, ErrorsNameTheProblemAndItsLine) {
  const std::string box = slurp(data_path("two_arm_torso_box.yaml")), mob = slurp(data_path("mobile_two_arm.yaml"));
  const std::string fb = data_path("two_arm_torso_box.yaml"), fm = data_path("mobile_two_arm.yaml");
  // an unknown joint in q, at its line
  std::string e = error_of(replace_once(box, "arm_left_1_joint: -0.3", "arm_left_9_joint: -0.3"), fb);
  EXPECT_NE(e.find("two_arm_torso_box.yaml:15:"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown joint 'arm_left_9_joint'"), std::string::npos) << e;
  EXPECT_NE(e.find("arm_left_1_joint"), std::string::npos) << "lists the joints: " << e;
  // a fixed URDF joint takes no value; a list of values needs a chain
  e = error_of(replace_once(box, "arm_left_1_joint: -0.3", "arm_left_tool_joint: 0.1"), fb);
  EXPECT_NE(e.find("joint 'arm_left_tool_joint' is fixed in the URDF"), std::string::npos) << e;
  e = error_of(replace_once(replace_once(box, "    q: {torso_lift_joint: 0.1,", "    q: [0.1]\n    qq: {"), "    qq: {", "    v: {"), fb);
  EXPECT_NE(e.find("a list needs the moving joints on one chain, but joints 'arm_left_4_joint' and 'arm_right_1_joint' are on "
                   "different branches: give a mapping {joint: value}"), std::string::npos) << e;
  // a rolling body without a cylinder, and without a radius
  e = error_of(mob + "  - {name: fork, type: rolling, body: mob.caster_front_link}\n", fm);
  EXPECT_NE(e.find("mobile_two_arm.yaml:21:"), std::string::npos) << e;
  EXPECT_NE(e.find("constraint 'fork': missing 'radius', and it cannot be read from the URDF"), std::string::npos) << e;
  EXPECT_NE(e.find("link 'caster_front_link' has no <cylinder>"), std::string::npos) << e;
  // a cylinder about another axis is not the wheel; a radius given is taken as given
  e = error_of(replace_once(mob, "body: mob.wheel_left_link}", "body: mob.wheel_left_link, axle: [1, 0, 0]}"), fm);
  EXPECT_NE(e.find("has no <cylinder> about its spin axis [1, 0, 0]"), std::string::npos) << e;
  const System r = load_scene_string(replace_once(mob, "body: mob.wheel_left_link}", "body: mob.wheel_left_link, radius: 0.1}"), fm);
  EXPECT_EQ(r.constraints.specs[0].radius, 0.1);
  // a branched URDF without tip in `arms` is still refused, with the way out
  e = error_of("robots:\n  duo: {urdf: two_arm_torso.urdf}\narms:\n  - {name: a, robot: duo, base: {xyz: [0, 0, 0]}, q: [0]}\n", fb);
  EXPECT_NE(e.find("branches below 'torso': give robots.<name>.tip, or load the whole tree in `bodies:`"), std::string::npos) << e;
  // root and tool
  e = error_of(replace_once(box, "root: fixed", "root: wheeled"), fb);
  EXPECT_NE(e.find("root must be fixed"), std::string::npos) << e;
  e = error_of(replace_once(box, "root: fixed", "root_v: [0, 0, 0, 0, 0, 0]"), fb);
  EXPECT_NE(e.find("root_v applies to a floating root"), std::string::npos) << e;
}

TEST(UrdfTree, AMimicJointInATreeIsCoupled) {
  // arm_right_4 mimics arm_left_4 (multiplier -1; the scene's -0.2 and 0.2 satisfy it): a coupling
  // row in the tree holding the box, the right wrist's accelerations the left's negated, the
  // coupling's force reported as the right wrist's stress; a mimic of a fixed joint holds its follower
  std::string urdf = slurp(data_path("two_arm_torso.urdf"));
  const std::string j = "<joint name=\"arm_right_4_joint\" type=\"revolute\">";
  const std::string path = ::testing::TempDir() + "coopdyn_tree_" + std::to_string(::getpid()) + ".urdf";
  const std::string scene = replace_once(slurp(data_path("two_arm_torso_box.yaml")), "{urdf: two_arm_torso.urdf}", "{urdf: " + path + "}");
  std::ofstream(path) << replace_once(urdf, j, j + "<mimic joint=\"arm_left_4_joint\" multiplier=\"-1\"/>");
  const System s = load_scene_string(scene, data_path("two_arm_torso_box.yaml"));
  const int l4 = velocity_index_of(s, "duo.arm_left_4_joint"), r4 = velocity_index_of(s, "duo.arm_right_4_joint");
  ASSERT_GE(l4, 0);
  ASSERT_GE(r4, 0);
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(s.model.nv());
  for (int i = 0; i < s.model.nv(); ++i) tau[i] = s.tau_limit[i] > 0 ? 0.3 * std::cos(1.0 + i) : 0.0;
  Workspace ws(s);
  ASSERT_NE(evaluate(s, ws, s.q0, s.v0, tau).status, Status::kError);
  EXPECT_NEAR(ws.vdot[r4], -ws.vdot[l4], 1e-10 * (1 + std::abs(ws.vdot[l4])));
  ASSERT_EQ(num_stresses(s), 1);
  EXPECT_EQ(stress_name(s, 0), "duo.arm_right_4_joint");
  std::ofstream(path) << replace_once(urdf, j, j + "<mimic joint=\"arm_left_tool_joint\"/>");
  const std::string e = error_of(scene, data_path("two_arm_torso_box.yaml"));
  std::remove(path.c_str());
  // a mimic of a joint the file makes fixed: the follower held at m * 0 + o (a warning), the file loads
  EXPECT_EQ(e, "(loaded)") << e;
}

TEST(UrdfTree, AFloatingRootMovesFreely) {
  // the two-arm robot unsupported in space (no gravity): a floating root, its velocity root_v; the
  // total momentum of the free tree is conserved, so its rate is zero under joint torques alone
  std::string t = slurp(data_path("two_arm_torso_box.yaml"));
  t = replace_once(t, "gravity: [0, 0, -9.81]", "gravity: [0, 0, 0]");
  t = replace_once(t, "root: fixed", "root: floating\n    root_v: [0.1, -0.2, 0.3, 0.5, 0, -0.4]");
  t = t.substr(0, t.find("  - name: box")) + "reactions: all\n";
  const System s = load_scene_string(t, data_path("two_arm_torso_box.yaml"));
  ASSERT_EQ(s.model.nv(), 6 + 9);
  EXPECT_EQ(s.model.v_names[0], "duo.wx");
  EXPECT_EQ(s.v0[2], 0.3);
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(15);
  for (int i = 6; i < 15; ++i) tau[i] = std::cos(0.5 * i);
  Workspace ws(s);
  ASSERT_EQ(evaluate(s, ws, s.q0, s.v0, tau).status, Status::kOk);
  const double h = 1e-5;
  auto P = [&](double x) {
    Eigen::VectorXd q(s.model.nq());
    integrate(s.model, s.q0, s.v0 * x + 0.5 * x * x * ws.vdot, 1.0, q);
    return total_momentum(s.model, q, Eigen::VectorXd(s.v0 + x * ws.vdot));
  };
  const Vec6 dP = (P(h) - P(-h)) / (2 * h);
  EXPECT_LT(dP.norm(), 1e-6) << dP.transpose();
  for (const WrenchOutput& o : s.wrenches.outputs) EXPECT_NE(o.name, "duo") << "a floating root transmits nothing";
}

}  // namespace
}  // namespace coopdyn::testing
