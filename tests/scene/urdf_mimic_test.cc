// URDF <mimic> joints honoured: q_j = m q_i + o as a coupling row (ConstraintKind::kCouple), its
// force reported with the stresses, in every formulation; refused where it would be lost.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <unistd.h>

#include "service/algorithms/crba.h"
#include "service/algorithms/kinematics.h"
#include "service/dynamics/integrators.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {

// A planar arm (axes z, gravity along -y in its plane): j1 and j2 move, j2 mimics j1 (2 q1 + 0.1);
// a fixed flange, then a side branch off l2 (a finger on jf, its twin on jg mimicking jf).
std::string mimic_urdf(const std::string& mimic = "<mimic joint=\"j1\" multiplier=\"2\" offset=\"0.1\"/>",
                       const std::string& side_mimic = "<mimic joint=\"jf\" multiplier=\"1\" offset=\"0.02\"/>") {
  return "<?xml version=\"1.0\"?>\n<robot name=\"m2\">\n  <link name=\"base\"/>\n"
         "  <link name=\"l1\"><inertial><origin xyz=\"0.25 0 0\"/><mass value=\"2\"/>\n"
         "    <inertia ixx=\"0.001\" iyy=\"0.04\" izz=\"0.04\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
         "  <link name=\"l2\"><inertial><origin xyz=\"0.2 0 0\"/><mass value=\"1.5\"/>\n"
         "    <inertia ixx=\"0.001\" iyy=\"0.02\" izz=\"0.02\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
         "  <link name=\"tool\"/>\n"
         "  <link name=\"f1\"><inertial><mass value=\"0.25\"/><inertia ixx=\"1e-4\" iyy=\"1e-4\" izz=\"1e-4\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
         "  <link name=\"f2\"><inertial><mass value=\"0.25\"/><inertia ixx=\"1e-4\" iyy=\"1e-4\" izz=\"1e-4\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
         "  <joint name=\"j1\" type=\"continuous\"><parent link=\"base\"/><child link=\"l1\"/><axis xyz=\"0 0 1\"/></joint>\n"
         "  <joint name=\"j2\" type=\"revolute\"><parent link=\"l1\"/><child link=\"l2\"/><origin xyz=\"0.5 0 0\"/><axis xyz=\"0 0 1\"/>\n"
         "    <limit lower=\"-3\" upper=\"3\" effort=\"50\" velocity=\"5\"/>" + mimic + "</joint>\n"
         "  <joint name=\"flange\" type=\"fixed\"><parent link=\"l2\"/><child link=\"tool\"/><origin xyz=\"0.4 0 0\"/></joint>\n"
         "  <joint name=\"jf\" type=\"prismatic\"><parent link=\"l2\"/><child link=\"f1\"/><origin xyz=\"0.3 0 0\"/><axis xyz=\"0 1 0\"/>\n"
         "    <limit lower=\"0\" upper=\"0.04\" effort=\"20\" velocity=\"0.2\"/></joint>\n"
         "  <joint name=\"jg\" type=\"prismatic\"><parent link=\"l2\"/><child link=\"f2\"/><origin xyz=\"0.3 0 0\"/><axis xyz=\"0 -1 0\"/>\n"
         "    <limit lower=\"0\" upper=\"0.04\" effort=\"20\" velocity=\"0.2\"/>" + side_mimic + "</joint>\n"
         "</robot>\n";
}

struct TmpUrdf {
  std::string path = ::testing::TempDir() + "coopdyn_mimic_" + std::to_string(::getpid()) + ".urdf";
  explicit TmpUrdf(const std::string& text) { std::ofstream(path) << text; }
  ~TmpUrdf() { std::remove(path.c_str()); }
};

// one arm on a bench, its chain base .. tool (the fingers kept rigidly or left out)
std::string bench_scene(const std::string& path, const std::string& q = "[0.3, 0.7]", const std::string& robot_extra = "") {
  return "name: mimic_bench\ngravity: [0, -9.81, 0]\nrobots:\n  m2: {urdf: " + path + ", tip: tool" + robot_extra +
         "}\narms:\n  - name: arm\n    robot: m2\n    base: {xyz: [0, 0, 0]}\n    q: " + q + "\n";
}

System bench(const std::string& urdf, const std::string& q = "[0.3, 0.7]", const std::string& extra = "") {
  TmpUrdf f(urdf);
  return load_scene_string(bench_scene(f.path, q, extra), scene_path("mimic_bench"));
}

std::string bench_error(const std::string& urdf, const std::string& extra = "") {
  try {
    bench(urdf, "[0.3, 0.7]", extra);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

// M vdot + h - tau at the workspace's evaluation (the generalized constraint force G^T lambda)
Eigen::VectorXd constraint_force(const System& sys, Workspace& ws, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                                 const Eigen::VectorXd& tau) {
  Data d(sys.model);
  forward_kinematics(sys.model, d, q, v);
  rnea_bias(sys.model, d);
  crba(sys.model, d);
  return d.M * ws.vdot + d.h - tau;
}

TEST(UrdfMimic, TheCoupledPairMovesAsItsMultiplierSays) {
  const System sys = bench(mimic_urdf());
  ASSERT_EQ(sys.model.nv(), 2);
  const int i = velocity_index_of(sys, "arm.j1"), j = velocity_index_of(sys, "arm.j2");
  ASSERT_GE(i, 0);
  ASSERT_GE(j, 0);
  ASSERT_EQ(sys.constraints.rows, 1);
  EXPECT_EQ(sys.constraints.specs[0].kind, ConstraintKind::kCouple);
  Workspace ws(sys);
  const Eigen::VectorXd tau = (Eigen::VectorXd(2) << 1.5, -0.7).finished();
  for (double w : {0.0, 1.3}) {  // at rest and in motion (v_j = 2 v_i)
    Eigen::VectorXd v(2);
    v[i] = w;
    v[j] = 2 * w;
    ASSERT_EQ(evaluate(sys, ws, sys.q0, v, tau).status, Status::kOk);
    EXPECT_NEAR(ws.vdot[j], 2 * ws.vdot[i], 1e-12 * (1 + std::abs(ws.vdot[i])));
    // the reduced system in the one free coordinate s (q_i = s, q_j = 2 s + 0.1, T = [1, 2]):
    //   (T^T M T) sdot = T^T (tau - h)
    Data d(sys.model);
    forward_kinematics(sys.model, d, sys.q0, v);
    rnea_bias(sys.model, d);
    crba(sys.model, d);
    Eigen::VectorXd T = Eigen::VectorXd::Zero(2);
    T[i] = 1;
    T[j] = 2;
    const double sdd = T.dot(tau - d.h) / T.dot(d.M * T);
    EXPECT_NEAR(ws.vdot[i], sdd, 1e-12 * (1 + std::abs(sdd)));
    // M vdot + h = tau + G^T lambda: the coupling applies lambda on j and -2 lambda on i, reported
    // as the stress of arm.j2
    const Eigen::VectorXd f = constraint_force(sys, ws, sys.q0, v, tau);
    const double lambda = ws.lambda[0];
    EXPECT_NEAR(f[j], lambda, 1e-12 * (1 + std::abs(lambda)));
    EXPECT_NEAR(f[i], -2 * lambda, 1e-12 * (1 + std::abs(lambda)));
    ASSERT_EQ(num_stresses(sys), 1);
    EXPECT_EQ(stress_name(sys, 0), "arm.j2");
    EXPECT_STREQ(stress_unit(sys, 0), "N*m");
    EXPECT_EQ(ws.stress[0], lambda);
    EXPECT_GT(std::abs(lambda), 0.1);  // gravity and tau load it
  }
}

TEST(UrdfMimic, ASimulationKeepsTheCoupling) {
  System sys = bench(mimic_urdf());
  sys.options.projection_iterations = 3;
  const int i = velocity_index_of(sys, "arm.j1"), j = velocity_index_of(sys, "arm.j2");
  Stepper st(sys);
  Eigen::VectorXd q = sys.q0, v = sys.v0;
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(2);
  double worst = 0, moved = 0;
  for (int k = 0; k < 2000; ++k) {  // 2 s of a swinging double pendulum, coupled
    ASSERT_NE(step(sys, st, Integrator::kRk4, 1e-3, tau, q, v).status, Status::kError);
    worst = std::max(worst, std::abs(q[sys.model.bodies[sys.model.dof_body[j]].joint.idx_q] -
                                     2 * q[sys.model.bodies[sys.model.dof_body[i]].joint.idx_q] - 0.1));
    worst = std::max(worst, std::abs(v[j] - 2 * v[i]));
    moved = std::max(moved, std::abs(v[i]));
  }
  EXPECT_LT(worst, 1e-10);
  EXPECT_GT(moved, 0.5) << "it swung";
}

TEST(UrdfMimic, AnInitialStateOffTheCouplingIsClosed) {
  const System sys = bench(mimic_urdf(), "[0.3, 0.9]");
  const int i = sys.model.bodies[sys.model.joint_index("arm.j1")].joint.idx_q;
  const int j = sys.model.bodies[sys.model.joint_index("arm.j2")].joint.idx_q;
  EXPECT_NEAR(sys.q0[j] - 2 * sys.q0[i] - 0.1, 0.0, 1e-10);
  std::string w;
  for (const auto& x : sys.warnings) w += x + "\n";
  EXPECT_NE(w.find("initial state: the constraints were open by 0.2"), std::string::npos) << w;
}

TEST(UrdfMimic, EveryFormulationCouplesTheSameWay) {
  // planar_arms_load with planar3r's j3 mimicking j2 (multiplier -0.4: both arms' q satisfy it)
  std::ifstream in(std::string(COOPDYN_SOURCE_DIR) + "/config/robots/planar3r.urdf");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string t = ss.str();
  t.insert(t.find("</joint>", t.find("name=\"j3\"")), "<mimic joint=\"j2\" multiplier=\"-0.4\"/>");
  TmpUrdf f(t);
  std::string dh = scene_text("planar_arms_load");
  const auto a = dh.find("  planar3r:\n"), b = dh.find("load:");
  dh = dh.substr(0, a) + "  planar3r: {urdf: " + f.path + "}\n" + dh.substr(b);
  std::vector<std::pair<std::string, Eigen::VectorXd>> vdots;
  for (const char* form : {"mobile_platform", "classic", "pseudo_joint", "svd"}) {
    const System sys = load_scene_string(replace_once(dh, "formulation: mobile_platform", std::string("formulation: ") + form),
                                         scene_path("planar_mimic"));
    int couples = 0;
    for (const auto& s : sys.constraints.specs) couples += s.kind == ConstraintKind::kCouple;
    EXPECT_EQ(couples, 2) << form;
    Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
    for (int k = 0; k < sys.model.nv(); ++k) {  // the same torques by joint name in every formulation
      const std::string& nm = sys.model.v_names[k];
      if (nm.size() == 7 && nm.compare(0, 3, "arm") == 0) tau[k] = 0.5 * std::sin(3.0 * (nm[3] - '0') + (nm[6] - '0'));
    }
    Workspace ws(sys);
    evaluate(sys, ws, sys.q0, sys.v0, tau);
    EXPECT_NE(ws.diag.status, Status::kError) << form;
    Eigen::VectorXd named(4);
    int n = 0;
    for (const char* jn : {"arm1.j2", "arm1.j3", "arm2.j2", "arm2.j3"}) named[n++] = ws.vdot[velocity_index_of(sys, jn)];
    EXPECT_NEAR(named[1], -0.4 * named[0], 1e-10) << form;
    EXPECT_NEAR(named[3], -0.4 * named[2], 1e-10) << form;
    vdots.emplace_back(form, named);
  }
  for (const auto& x : vdots)
    EXPECT_LT((x.second - vdots[0].second).cwiseAbs().maxCoeff(), 1e-9) << x.first << ": " << x.second.transpose() << " vs "
                                                                        << vdots[0].second.transpose();
}

TEST(UrdfMimic, AKeptSideBranchSitsAtItsMimicOffset) {
  // jg mimics jf with offset 0.02: kept rigidly, finger f2 sits 0.02 m along jg's axis (-y of l2),
  // so l2's first moment of mass differs from the offset-0 file's by 0.25 kg * 0.02 m along -y
  const System kept = bench(mimic_urdf(), "[0.3, 0.7]", ", branches: keep");
  const System zero = bench(mimic_urdf("<mimic joint=\"j1\" multiplier=\"2\" offset=\"0.1\"/>",
                                       "<mimic joint=\"jf\" multiplier=\"1\" offset=\"0\"/>"),
                            "[0.3, 0.7]", ", branches: keep");
  const int b = kept.model.body_index("arm.l2");
  ASSERT_GE(b, 0);
  const Inertia& ik = kept.model.bodies[b].inertia;
  const Inertia& iz = zero.model.bodies[b].inertia;
  const Vec3 dh = ik.m * ik.c - iz.m * iz.c;
  EXPECT_NEAR(dh.y(), -0.25 * 0.02, 1e-15);
  EXPECT_NEAR(dh.x(), 0.0, 1e-15);
  std::string w;
  for (const auto& x : kept.warnings) w += x + "\n";
  EXPECT_NE(w.find("with their joints at zero (a mimic joint at its offset) (branches: keep)"), std::string::npos) << w;
}

TEST(UrdfMimic, CouplingsThatWouldBeLostAreRefused) {
  // the mimicked joint off the chain (j2 mimics the finger joint jf)
  std::string e = bench_error(mimic_urdf("<mimic joint=\"jf\"/>"));
  EXPECT_NE(e.find("joint 'j2' mimics 'jf', which is off the chain base .. tool: the coupling would be lost"), std::string::npos) << e;
  EXPECT_NE(e.find(":13: joint 'j2'"), std::string::npos) << "the <mimic>'s line: " << e;
  // a fixed joint mimicked: j2 is held at m * 0 + o, so the chain has one moving joint (the bench's
  // two values are one too many; tests/scene/urdf_published_test.cc loads such files)
  e = bench_error(mimic_urdf("<mimic joint=\"flange\"/>"));
  EXPECT_NE(e.find("'arm'.q must have 1 entries, got 2"), std::string::npos) << e;
  // a joint the file does not have: j2 moves on its own (a warning), the file loads
  e = bench_error(mimic_urdf("<mimic joint=\"j9\"/>"));
  EXPECT_EQ(e, "") << e;
  // a misspelt attribute (urdfdom would take multiplier 1)
  e = bench_error(mimic_urdf("<mimic joint=\"j1\" multipler=\"2\"/>"));
  EXPECT_NE(e.find(":13: <mimic> attribute 'multipler' is not one of joint, multiplier, offset"), std::string::npos) << e;
  // a kept side branch that would have to follow a chain joint
  e = bench_error(mimic_urdf("", "<mimic joint=\"j2\"/>"), ", branches: keep");
  EXPECT_NE(e.find("joint 'jg' off the chain mimics chain joint 'j2'"), std::string::npos) << e;
  // a loop of mimics (j1 mimics j2 mimics j1) and a mimicked joint held by fixed_joints
  std::string t = mimic_urdf("<mimic joint=\"j1\"/>");
  t.insert(t.find("</joint>", t.find("name=\"j1\"")), "<mimic joint=\"j2\"/>");
  e = bench_error(t);
  EXPECT_NE(e.find("is in a loop of mimics"), std::string::npos) << e;
  TmpUrdf f(mimic_urdf());
  try {
    load_scene_string(bench_scene(f.path) + "    fixed_joints: [1]\n", scene_path("mimic_bench"));
    ADD_FAILURE() << "loaded";
  } catch (const SceneError& x) {
    EXPECT_NE(std::string(x.what()).find("but 'arm.j1' is not a moving one-DOF joint of the scene (a fixed joint, or one held by fixed_joints?)"),
              std::string::npos) << x.what();
  }
}

}  // namespace
}  // namespace coopdyn::testing
