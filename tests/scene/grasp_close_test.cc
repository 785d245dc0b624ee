// Grasps that close themselves (arms + load): approximate joint angles and the grasp poses (or the
// load pose) are enough; the loader moves the arm joints by the least change until every grasp
// closes, says what moved, and refuses a grasp the arm cannot reach at the grasp's own line.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "service/dynamics/wrenches.h"
#include "service/scene/builder.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

namespace {

std::string error_of(const std::string& text, const std::string& name) {
  try {
    load_scene_string(text, name);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "(loaded)";
}

// the grasp frame of `arm` on the load, as a scene pose (read off the at_initial_state solution)
std::string grasp_yaml(const System& ref, const std::string& arm) {
  const Transform& X = ref.model.frames[ref.model.frame_index("load." + arm)].X_BF;
  const Eigen::Quaterniond u(X.R);
  char s[400];
  std::snprintf(s, sizeof s, "{xyz: [%.17g, %.17g, %.17g], quat: [%.17g, %.17g, %.17g, %.17g]}", X.p.x(), X.p.y(), X.p.z(),
                u.w(), u.x(), u.y(), u.z());
  return s;
}

// the scene text with each arm's `q:` and `grasp:` lines replaced (in the arms' order), and the
// load's `pose:` line dropped when drop_pose
std::string edited(const std::string& text, const std::vector<std::vector<double>>& qs, const std::vector<std::string>& grasps,
                   bool drop_pose = false) {
  std::stringstream in(text), out;
  std::string line;
  int arm = -1;
  bool in_load = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != ' ' && line[0] != '-') in_load = line.rfind("load:", 0) == 0;
    if (line.rfind("  - name: ", 0) == 0) ++arm;
    if (arm >= 0 && line.rfind("    q: ", 0) == 0) {
      std::ostringstream q;
      q.precision(17);
      q << "    q: [";
      for (size_t k = 0; k < qs[arm].size(); ++k) q << (k ? ", " : "") << qs[arm][k];
      line = q.str() + "]";
    }
    if (arm >= 0 && line.rfind("    grasp: ", 0) == 0) line = "    grasp: " + grasps[arm];
    if (drop_pose && in_load && line.rfind("  pose: ", 0) == 0) continue;
    out << line << "\n";
  }
  return out.str();
}

// every arm joint 0.1 rad off, alternating in sign (and opposite between the arms)
std::vector<std::vector<double>> perturbed(const std::vector<std::vector<double>>& qs) {
  std::vector<std::vector<double>> p = qs;
  for (size_t a = 0; a < p.size(); ++a)
    for (size_t k = 0; k < p[a].size(); ++k) p[a][k] += (k + a) % 2 ? -0.1 : 0.1;
  return p;
}

double constraint_error(const System& sys) {
  Data d(sys.model);
  ConstraintData cd(sys.model, sys.constraints);
  forward_kinematics(sys.model, d, sys.q0, sys.v0);
  constraint_rows(sys.model, d, sys.constraints, sys.q0, sys.v0, cd);
  return std::max(cd.err.cwiseAbs().maxCoeff(), cd.Gv.cwiseAbs().maxCoeff());
}

// Spatial momentum of body b about the world origin (world coordinates) at (q, v), and its rate
// along the motion (central differences).
Vec6 body_momentum(const Model& m, int b, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  Data d(m);
  forward_kinematics(m, d, q, v);
  return d.X_WB[b].act_force(m.bodies[b].inertia * to_ref(d, d.X_WB[b]).inv_act(d.V_W[b]));
}
Vec6 momentum_rate(const Model& m, int b, const Eigen::VectorXd& q, const Eigen::VectorXd& v, const Eigen::VectorXd& vdot) {
  const double eps = 1e-6;
  Eigen::VectorXd qp(m.nq()), qm(m.nq());
  integrate(m, q, v, eps, qp);
  integrate(m, q, v, -eps, qm);
  return (body_momentum(m, b, qp, v + eps * vdot) - body_momentum(m, b, qm, v - eps * vdot)) / (2 * eps);
}

// the closed q of one scene coordinate
double q_of(const System& sys, const std::string& name) { return sys.q0[index_of(sys.model.q_names, name)]; }

// the joint angles of `arm` (ARM.<joint>1 .. ARM.<joint>n, the robot's order)
std::vector<double> arm_q(const System& sys, const std::string& arm, const std::string& joint, int n) {
  std::vector<double> q;
  for (int j = 1; j <= n; ++j) q.push_back(q_of(sys, arm + "." + joint + std::to_string(j)));
  return q;
}

struct Case {
  std::string scene;
  int n;
  std::string joint;  // a joint name of the robot (the coordinate ARM.<joint>)
};
const std::vector<Case> kCases = {{"two_puma_load", 6, "q"}, {"two_iiwa_load", 7, "iiwa_joint_"}};

// the shipped scene (grasps at_initial_state), its arms' angles and explicit grasps
struct Reference {
  System sys;
  std::vector<std::vector<double>> q;
  std::vector<std::string> grasps;
};
Reference reference(const Case& k, Formulation f) {
  SceneOverrides ov;
  ov.formulation = f;
  Reference r{load_scene(scene_path(k.scene), ov), {}, {}};
  for (const std::string arm : {"arm1", "arm2"}) {
    r.q.push_back(arm_q(r.sys, arm, k.joint, k.n));
    r.grasps.push_back(grasp_yaml(r.sys, arm));
  }
  return r;
}

}  // namespace

// Explicit grasps and every arm joint 0.1 rad off: the loader closes the grasps to round-off, the
// load held at its pose (every formulation: pseudo_joint builds the mobile-platform tree, svd the
// classic one); the non-redundant PUMA returns to the angles the grasps were read at,
// the 7-DOF iiwa moves by no more than the perturbation; the warning lists what moved.
TEST(GraspClose, ArmsCloseTheirGraspsFromAnglesOff) {
  for (const Case& k : kCases)
    for (Formulation f : {Formulation::kMobilePlatform, Formulation::kClassic, Formulation::kPseudoJointSchur,
                          Formulation::kSvdBaseline}) {
      SCOPED_TRACE(k.scene + " " + formulation_name(f));
      const Reference ref = reference(k, f);
      const std::vector<std::vector<double>> off = perturbed(ref.q);
      SceneOverrides ov;
      ov.formulation = f;
      const System sys = load_scene_string(edited(scene_text(k.scene), off, ref.grasps), scene_path(k.scene), ov);
      EXPECT_LT(constraint_error(sys), 1e-10);
      ASSERT_EQ(warnings_besides_dynamics(sys).size(), 1u) << warnings_besides_dynamics(sys).back();
      const std::string w = warnings_besides_dynamics(sys)[0];
      EXPECT_NE(w.find("initial state: the constraints were open by "), std::string::npos) << w;
      EXPECT_NE(w.find("by moving every coordinate (least change) (load held where the scene puts it):"), std::string::npos) << w;
      EXPECT_NE(w.find(" arm1." + k.joint + "2 "), std::string::npos) << w;
      EXPECT_EQ(w.find(" load."), std::string::npos) << "the load did not move: " << w;
      for (const char* c : {"load.x", "load.y", "load.z", "load.qw", "load.qx", "load.qy", "load.qz"})
        EXPECT_EQ(q_of(sys, c), q_of(ref.sys, c)) << c;
      double moved2 = 0, off2 = 0;
      for (int a = 0; a < 2; ++a)
        for (int j = 0; j < k.n; ++j) {
          const std::string c = "arm" + std::to_string(a + 1) + "." + k.joint + std::to_string(j + 1);
          const double q = q_of(sys, c);
          if (k.n == 6) {
            EXPECT_NEAR(q, ref.q[a][j], 1e-6) << c;
          }
          moved2 += (q - off[a][j]) * (q - off[a][j]);
          off2 += (ref.q[a][j] - off[a][j]) * (ref.q[a][j] - off[a][j]);
        }
      EXPECT_LE(std::sqrt(moved2), std::sqrt(off2) * (1 + 1e-9)) << "least change: no more than the perturbation";
      EXPECT_GT(std::sqrt(moved2), 0.05);
    }
}

// No load pose: the load starts where the first arm's grasp puts it and closes with the arms. At
// exact angles nothing moves (the pose read off the first arm is the shipped one); from angles
// 0.1 rad off everything closes, and the load's Newton-Euler holds with eval's end-effector wrenches.
TEST(GraspClose, LoadPoseSolvedFromTheGrasps) {
  for (const Case& k : kCases)
    for (Formulation f : {Formulation::kMobilePlatform, Formulation::kClassic}) {
      SCOPED_TRACE(k.scene + " " + formulation_name(f));
      const Reference ref = reference(k, f);
      SceneOverrides ov;
      ov.formulation = f;
      const System exact = load_scene_string(edited(scene_text(k.scene), ref.q, ref.grasps, true), scene_path(k.scene), ov);
      EXPECT_TRUE(warnings_besides_dynamics(exact).empty()) << warnings_besides_dynamics(exact).front();
      for (int i = 0; i < exact.model.nq(); ++i) EXPECT_NEAR(exact.q0[i], ref.sys.q0[i], 1e-12) << exact.model.q_names[i];
      const System sys = load_scene_string(edited(scene_text(k.scene), perturbed(ref.q), ref.grasps, true), scene_path(k.scene), ov);
      EXPECT_LT(constraint_error(sys), 1e-10);
      ASSERT_EQ(warnings_besides_dynamics(sys).size(), 1u) << warnings_besides_dynamics(sys).back();
      EXPECT_NE(warnings_besides_dynamics(sys)[0].find("by moving every coordinate (least change):"), std::string::npos) << warnings_besides_dynamics(sys)[0];
      EXPECT_NE(warnings_besides_dynamics(sys)[0].find(" arm1." + k.joint), std::string::npos) << warnings_besides_dynamics(sys)[0];
      // Newton-Euler of the load at the solved state: the arms' wrenches on it plus its weight
      const Model& m = sys.model;
      Eigen::VectorXd tau = Eigen::VectorXd::Zero(m.nv());
      for (int i = 0; i < m.nv(); ++i)
        if (std::isfinite(sys.tau_limit[i]) && sys.tau_limit[i] > 0) tau[i] = 3.0 * std::sin(1.0 + i);
      Workspace ws(sys);
      ASSERT_NE(evaluate(sys, ws, sys.q0, sys.v0, tau).status, Status::kError);
      WrenchData wd(sys);
      compute_wrenches(sys, ws, wd);
      const int L = m.body_index("load");
      const Inertia& I = m.bodies[L].inertia;
      const Transform X = ws.data.X_WB[L];
      const Vec3 c = X.R * I.c + X.p;
      Vec6 F;
      F << c.cross(I.m * m.gravity_W), I.m * m.gravity_W;
      for (size_t o = 0; o < sys.wrenches.outputs.size(); ++o)
        if (sys.wrenches.outputs[o].kind == WrenchKind::kEndEffector)
          F -= wrench_frame_pose(sys, ws.data, static_cast<int>(o)).act_force(wd.W[o]);
      const Vec6 hdot = momentum_rate(m, L, sys.q0, sys.v0, ws.vdot);
      EXPECT_LT((hdot - F).norm(), 1e-6 * (1 + F.norm())) << hdot.transpose() << " vs " << F.transpose();
    }
}

// A grasp the arm cannot reach (the load 5 m away) is refused at the arm's grasp line with the miss
// per axis; with close_initial_state: false any miss is refused as given.
TEST(GraspClose, UnreachableGraspIsRefusedAtItsLine) {
  const Case& k = kCases[0];
  const Reference ref = reference(k, Formulation::kMobilePlatform);
  std::string text = edited(scene_text(k.scene), ref.q, ref.grasps);
  text = replace_once(text, "pose: {xyz: [0, 0, -0.0468]", "pose: {xyz: [0, 5, -0.0468]");
  const std::string e = error_of(text, scene_path(k.scene));
  // arm 1 stands at y = -0.75, 5.75 m from the load: it misses most
  const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<long>(text.find("    grasp: ")), '\n');
  EXPECT_NE(e.find(scene_path(k.scene) + ":" + std::to_string(line) + ":"), std::string::npos) << e;
  EXPECT_NE(e.find("arm 'arm1' cannot reach its grasp"), std::string::npos) << e;
  for (const char* ax : {" wx ", " wy ", " wz ", " vx ", " vy ", " vz "}) EXPECT_NE(e.find(ax), std::string::npos) << ax << e;
  // the residual is what the arm's reach leaves: metres, not round-off
  const auto p = e.find("misses the grasp by wx ");
  ASSERT_NE(p, std::string::npos) << e;
  double r[6];
  ASSERT_EQ(std::sscanf(e.c_str() + p, "misses the grasp by wx %lf wy %lf wz %lf vx %lf vy %lf vz %lf", &r[0], &r[1], &r[2], &r[3],
                        &r[4], &r[5]),
            6)
      << e;
  EXPECT_GT(Vec3(r[3], r[4], r[5]).norm(), 3.0) << e;
  // closing off: the given angles off by 0.1 rad are refused, with the miss per arm
  const std::string e2 = error_of("close_initial_state: false\n" + edited(scene_text(k.scene), perturbed(ref.q), ref.grasps),
                                  scene_path(k.scene));
  EXPECT_NE(e2.find("initial state does not close: arm 'arm1' end-effector misses its grasp on the load by "), std::string::npos) << e2;
  EXPECT_NE(e2.find("close_initial_state: false"), std::string::npos) << e2;
  // without a load pose every arm needs a grasp pose
  std::vector<std::string> g = ref.grasps;
  g[1] = "at_initial_state";
  const std::string e3 = error_of(edited(scene_text(k.scene), ref.q, g, true), scene_path(k.scene));
  EXPECT_NE(e3.find("arm 'arm2': grasp at_initial_state needs the load's 'pose'"), std::string::npos) << e3;
}

// A given velocity is projected onto the constraints at the closed state (as for explicit loops).
TEST(GraspClose, VelocityIsProjectedAtTheClosedState) {
  const Case& k = kCases[0];
  for (Formulation f : {Formulation::kMobilePlatform, Formulation::kClassic}) {
    SCOPED_TRACE(formulation_name(f));
    const Reference ref = reference(k, f);
    const std::string text = edited(scene_text(k.scene), perturbed(ref.q), ref.grasps);
    const auto p = text.find("    grasp: ");  // arm 1's
    SceneOverrides ov;
    ov.formulation = f;
    const System sys = load_scene_string(text.substr(0, p) + "    v: [0.2, 0.2, 0.2, 0.2, 0.2, 0.2]\n" + text.substr(p),
                                         scene_path(k.scene), ov);
    EXPECT_LT(constraint_error(sys), 1e-10);  // position and velocity
    ASSERT_EQ(warnings_besides_dynamics(sys).size(), 2u) << warnings_besides_dynamics(sys).back();
    EXPECT_NE(warnings_besides_dynamics(sys)[0].find("initial state: "), std::string::npos) << warnings_besides_dynamics(sys)[0];
    EXPECT_NE(warnings_besides_dynamics(sys)[1].find("initial velocity: projected onto the constraints"), std::string::npos) << warnings_besides_dynamics(sys)[1];
    EXPECT_GT(sys.v0.norm(), 0.01) << "the load and arm 2 follow arm 1, not everything stopped";
  }
}

// keep: a kept joint does not move, the others close the grasps (the iiwa has one joint to spare).
TEST(GraspClose, KeptJointsDoNotMove) {
  const Case& k = kCases[1];
  const Reference ref = reference(k, Formulation::kMobilePlatform);
  const std::vector<std::vector<double>> off = perturbed(ref.q);
  const std::string text = "close_initial_state: {keep: [arm1.iiwa_joint_1, arm2.iiwa_joint_3]}\n" +
                           edited(scene_text(k.scene), off, ref.grasps);
  const System sys = load_scene_string(text, scene_path(k.scene));
  EXPECT_LT(constraint_error(sys), 1e-10);
  EXPECT_EQ(q_of(sys, "arm1.iiwa_joint_1"), off[0][0]);
  EXPECT_EQ(q_of(sys, "arm2.iiwa_joint_3"), off[1][2]);
  EXPECT_NE(q_of(sys, "arm1.iiwa_joint_2"), off[0][1]);
  ASSERT_EQ(warnings_besides_dynamics(sys).size(), 1u) << warnings_besides_dynamics(sys).back();
  EXPECT_NE(warnings_besides_dynamics(sys)[0].find("every joint not in close_initial_state.keep (load held where the scene puts it)"), std::string::npos)
      << warnings_besides_dynamics(sys)[0];
}

// A grasp the joint limits forbid is refused at the binding joint's `q` entry, naming it, its limit
// and the limit's source: iiwa joint 6 given 2.05 rad would have to close at 2.15 rad (its grasp
// was read there), beyond its +-2.0944 limit, the other arm1 joints kept and the load held.
TEST(GraspClose, GraspTheLimitsForbidIsRefusedNamingTheJoint) {
  const Case& k = kCases[1];
  std::vector<std::vector<double>> q = {{0, 0.7, 0, -1.2, 0, 2.15, 0}, {0, 0.7, 0, -1.2, 0, 0.9, 0}};
  std::vector<std::string> at = {"at_initial_state", "at_initial_state"};
  const System beyond = load_scene_string(edited(scene_text(k.scene), q, at), scene_path(k.scene));
  ASSERT_EQ(warnings_besides_dynamics(beyond).size(), 1u);  // the given 2.15 is outside: warned as given
  EXPECT_NE(warnings_besides_dynamics(beyond)[0].find("q = 2.15 is outside its limits"), std::string::npos) << warnings_besides_dynamics(beyond)[0];
  const std::vector<std::string> grasps = {grasp_yaml(beyond, "arm1"), grasp_yaml(beyond, "arm2")};
  q[0][5] = 2.05;
  const std::string text = "close_initial_state: {keep: [arm1.iiwa_joint_1, arm1.iiwa_joint_2, arm1.iiwa_joint_3, "
                           "arm1.iiwa_joint_4, arm1.iiwa_joint_5, arm1.iiwa_joint_7]}\n" +
                           edited(scene_text(k.scene), q, grasps);
  // the line of arm1's `q:` (the first arm's)
  std::stringstream in(text);
  std::string line;
  int n = 0, q_line = 0;
  while (std::getline(in, line) && !q_line) q_line = (++n, line.rfind("    q: ", 0) == 0 ? n : 0);
  const std::string e = error_of(text, scene_path(k.scene));
  EXPECT_EQ(e.rfind(scene_path(k.scene) + ":" + std::to_string(q_line) + ":", 0), 0u) << e;
  EXPECT_NE(e.find("cannot close within the joint limits: joint arm1.iiwa_joint_6 binds at its upper limit 2.0944 (URDF "),
            std::string::npos) << e;
  EXPECT_NE(e.find("iiwa14.urdf:"), std::string::npos) << e;
  EXPECT_NE(e.find("(closing without limits would move it to 2.15)"), std::string::npos) << e;
}

// Closing is the bounded least change: with every arm joint free (the load held), the same grasps
// (read at joint 6 = 2.15, beyond its 2.0944 limit) from joint 6 = 2.08 close without limits only
// by moving joint 6 beyond 2.0944; with them the loader refuses, naming that joint.
TEST(GraspClose, ClosingStaysWithinTheJointLimits) {
  const Case& k = kCases[1];
  std::vector<std::vector<double>> q = {{0, 0.7, 0, -1.2, 0, 2.15, 0}, {0, 0.7, 0, -1.2, 0, 0.9, 0}};
  std::vector<std::string> at = {"at_initial_state", "at_initial_state"};
  const System beyond = load_scene_string(edited(scene_text(k.scene), q, at), scene_path(k.scene));
  const std::vector<std::string> grasps = {grasp_yaml(beyond, "arm1"), grasp_yaml(beyond, "arm2")};
  q[0][5] = 2.08;
  const std::string e = error_of(edited(scene_text(k.scene), q, grasps), scene_path(k.scene));
  EXPECT_NE(e.find("cannot close within the joint limits: joint arm1.iiwa_joint_6 binds at its upper limit 2.0944"),
            std::string::npos) << e;
  // the same closing without the limits: from the scene's values, joint 6 passes its limit
  const int i6 = index_of(beyond.model.v_names, "arm1.iiwa_joint_6");
  ASSERT_NEAR(beyond.q_upper[i6], 2.0944, 1e-4);
  System free = beyond;
  free.q0[index_of(free.model.q_names, "arm1.iiwa_joint_6")] = 2.08;
  free.q_lower.setConstant(-HUGE_VAL);
  free.q_upper.setConstant(HUGE_VAL);
  std::vector<std::string> w;
  const std::vector<unsigned char> given(free.model.nq(), 1);
  ASSERT_TRUE(scene_detail::close_initial_state(free, given, {}, &w, {free.model.body_index("load")}));
  EXPECT_LT(constraint_error(free), 1e-10);
  EXPECT_GT(q_of(free, "arm1.iiwa_joint_6"), beyond.q_upper[i6] + 1e-3);
}
