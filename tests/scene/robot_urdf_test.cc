// URDF robots without silent losses: an unreadable <inertial> is an error naming the file, line and
// link; a moving link without one, and links off the chain, are reported as warnings; xacro is refused.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "service/dynamics/holding_torque.h"
#include "service/dynamics/wrenches.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {

std::string planar3r() {
  std::ifstream f(std::string(COOPDYN_SOURCE_DIR) + "/config/robots/planar3r.urdf");
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::string urdf_tmp_path() { return ::testing::TempDir() + "coopdyn_urdf_" + std::to_string(::getpid()) + ".urdf"; }

// planar_arms_load with its robot read from a URDF text written to a temporary file (`path`, by
// default urdf_tmp_path()), the arms' joint angles `q1` and `q2` when given
System load_with_urdf(const std::string& urdf_text, const std::string& extra = "", const std::string& path = urdf_tmp_path(),
                      const std::string& q1 = "", const std::string& q2 = "") {
  std::ofstream(path) << urdf_text;
  const std::string dh = scene_text("planar_arms_load");
  const auto a = dh.find("  planar3r:\n"), b = dh.find("load:");
  std::string scene = dh.substr(0, a) + "  planar3r: {urdf: " + path + extra + "}\n" + dh.substr(b);
  if (!q1.empty()) scene = replace_once(scene, "q: [0.6, -1.0, 0.4]", "q: " + q1);
  if (!q2.empty()) scene = replace_once(scene, "q: [-0.6, 1.0, -0.4]", "q: " + q2);
  struct Rm {
    std::string p;
    ~Rm() { std::remove(p.c_str()); }
  } rm{path};
  return load_scene_string(scene, scene_path("planar_urdf"));
}

std::string error_of(const std::string& urdf_text, const std::string& extra = "", const std::string& path = urdf_tmp_path()) {
  try {
    load_with_urdf(urdf_text, extra, path);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

std::string warnings_of(const System& s) {
  std::string w;
  for (const std::string& x : s.warnings) w += x + "\n";
  return w;
}

TEST(Urdf, JointDynamicsAreReadAndBadOnesRefusedAtTheirLine) {
  // planar3r.urdf's joint j2 (line 20) with <dynamics>: its damping and friction on both arms
  const std::string t = planar3r();
  const std::string at = "<origin xyz=\"0.5 0 0\"/><axis xyz=\"0 0 1\"/>";
  const System s = load_with_urdf(replace_once(t, at, at + "<dynamics damping=\"0.7\" friction=\"0.3\"/>"));
  EXPECT_TRUE(s.warnings.empty()) << warnings_of(s);
  for (const char* arm : {"arm1", "arm2"}) {
    const Joint& j = s.model.bodies[s.model.joint_index(std::string(arm) + ".j2")].joint;
    EXPECT_EQ(j.damping, 0.7);
    EXPECT_EQ(j.friction, 0.3);
    EXPECT_EQ(s.model.bodies[s.model.joint_index(std::string(arm) + ".j1")].joint.damping, 0.0);
  }
  for (const std::string bad : {"damping=\"-0.7\"", "friction=\"-1\""}) {
    const std::string e = error_of(replace_once(t, at, at + "<dynamics " + bad + "/>"));
    EXPECT_NE(e.find(".urdf:20"), std::string::npos) << e;
    EXPECT_NE(e.find("must be a finite number >= 0"), std::string::npos) << e;
  }
}

TEST(Urdf, TheShippedRobotLoadsWithoutWarnings) {
  const System s = load_with_urdf(planar3r());
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();  // its massless 'tool' hangs from a fixed flange
}

// planar3r.urdf's link l2: <link> on line 10, <inertial> with <origin> and <mass> on 11, <inertia> on 12
const char* kL2Inertia = "<inertia ixx=\"0.001\" iyy=\"0.02\" izz=\"0.02\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/>";

// each form of an <inertial> urdfdom cannot read (it zeroes the inertia or drops the mass, and goes
// on) is refused with the file, the line of the element and the link
void expect_refused(const std::string& from, const std::string& to, int line, const std::string& why) {
  std::string t = planar3r();
  ASSERT_NE(t.find(from), std::string::npos) << from;
  t.replace(t.find(from), from.size(), to);
  const std::string e = error_of(t);
  EXPECT_NE(e.find("URDF " + urdf_tmp_path() + ":" + std::to_string(line) + ": link 'l2': " + why), std::string::npos) << e;
  EXPECT_NE(e.find("urdfdom cannot read this <inertial>"), std::string::npos) << e;
}

TEST(Urdf, EveryInertialUrdfdomCannotReadIsRefusedWithItsLine) {
  // a misspelt moment (iyx for ixy): urdfdom zeroes the whole tensor
  expect_refused("ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial>\n  </link>\n  <link name=\"l3\">",
                 "iyx=\"0\" ixz=\"0\" iyz=\"0\"/></inertial>\n  </link>\n  <link name=\"l3\">", 12,
                 "<inertia> lacks ixy (given instead: iyx; misspelt?)");
  // a missing moment (ixz): the same
  expect_refused(kL2Inertia, "<inertia ixx=\"0.001\" iyy=\"0.02\" izz=\"0.02\" ixy=\"0\" iyz=\"0\"/>", 12, "<inertia> lacks ixz;");
  // a misspelt element: no inertia at all
  expect_refused(kL2Inertia, "<inertiaa ixx=\"0.001\" iyy=\"0.02\" izz=\"0.02\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/>", 12,
                 "element <inertiaa> is not one of <origin>, <mass>, <inertia> (misspelt?)");
  // no <inertia> element
  expect_refused(kL2Inertia, "", 11, "no <inertia> element");
  // a misspelt <mass> element and a misspelt value attribute (urdfdom drops the mass)
  expect_refused("<mass value=\"1.5\"/>", "<masss value=\"1.5\"/>", 11, "element <masss> is not one of");
  expect_refused("<mass value=\"1.5\"/>", "<mass valeu=\"1.5\"/>", 11, "<mass> has no value attribute (given: valeu)");
  // a moment that is not a number
  expect_refused(kL2Inertia, "<inertia ixx=\"0.001x\" iyy=\"0.02\" izz=\"0.02\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/>", 12,
                 "<inertia> ixx '0.001x' is not a number");
  // and a readable one in a comment before the link, or a link named like a joint, changes nothing
  std::string t = planar3r();
  t.insert(t.find("  <link name=\"l2\">"), "  <!-- <link name=\"l2\"><inertial><mass valeu=\"9\"/></inertial></link> -->\n");
  EXPECT_EQ(error_of(t), "");
}

TEST(Urdf, AJointsSourceLineIsItsElementsNotALinksOfTheSameName) {
  // link l1 renamed j2 (links and joints have separate names in URDF): joint j2's limit warning
  // names the joint's line (21), not the link's (6); a comment naming the joint changes nothing
  std::string t = planar3r();
  for (size_t p; (p = t.find("\"l1\"")) != std::string::npos;) t.replace(p, 4, "\"j2\"");
  t.insert(t.find("<robot"), "<!-- <joint name=\"j2\"> was here -->\n");
  const System s = load_with_urdf(t, "", urdf_tmp_path(), "[0.6, -3.1, 0.4]");
  const std::string w = warnings_of(s);
  EXPECT_NE(w.find("joint j2 q = -3.1 is outside its limits [-3, 3] (URDF " + urdf_tmp_path() + ":21)"), std::string::npos) << w;
}

TEST(Urdf, ANonPsdInertiaIsRefusedAndImplausibleOnesWarned) {
  // the same checks as a scene's inertia: not positive semi-definite is an error ...
  std::string t = planar3r();
  t.replace(t.find(kL2Inertia), std::strlen(kL2Inertia),
            "<inertia ixx=\"0.001\" iyy=\"0.02\" izz=\"0.02\" ixy=\"0.05\" ixz=\"0\" iyz=\"0\"/>");
  const std::string e = error_of(t);
  EXPECT_NE(e.find("URDF " + urdf_tmp_path() + ":11: link 'l2': inertia tensor is not positive semi-definite"), std::string::npos)
      << e;
  // ... a triangle-inequality violation (0.001 + 0.001 < 0.02) and a mass above 100 t warnings
  t = planar3r();
  t.replace(t.find(kL2Inertia), std::strlen(kL2Inertia),
            "<inertia ixx=\"0.001\" iyy=\"0.001\" izz=\"0.02\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/>");
  t.replace(t.find("<mass value=\"0.5\"/>"), 19, "<mass value=\"2e5\"/>");
  const std::string w = warnings_of(load_with_urdf(t));
  EXPECT_NE(w.find("URDF " + urdf_tmp_path() + ":11: link 'l2': principal moments 0.001, 0.001, 0.02 kg m^2 break the "
                   "triangle inequality"), std::string::npos) << w;
  EXPECT_NE(w.find("URDF " + urdf_tmp_path() + ":15: link 'l3': mass 200000 kg is more than 100 t"), std::string::npos) << w;
}

TEST(Urdf, ALongPathIsPrintedWhole) {
  // a URDF error in a file 300+ characters deep: the path appears whole (not cut in the middle)
  std::string dir = ::testing::TempDir() + "coopdyn_long_" + std::to_string(::getpid());
  const std::string top = dir;
  std::filesystem::create_directories(dir);
  while (dir.size() < 300) {
    dir += "/a_rather_long_directory_name_of_a_robot_description_package";
    std::filesystem::create_directories(dir);
  }
  const std::string path = dir + "/talos_left_arm.urdf";
  ASSERT_GT(path.size(), 300u);
  std::string t = planar3r();
  t.replace(t.find("<mass value=\"1.5\"/>"), 19, "<mass valeu=\"1.5\"/>");
  const std::string e = error_of(t, "", path);
  EXPECT_NE(e.find("URDF " + path + ":11: link 'l2': <mass> has no value attribute"), std::string::npos) << e;
  std::filesystem::remove_all(top);
}
TEST(Urdf, AMovingLinkWithoutMassIsReported) {
  std::string t = planar3r();
  const size_t p = t.find("  <link name=\"l2\">"), q = t.find("</link>", p) + 7;
  t.replace(p, q - p, "  <link name=\"l2\"/>");
  const System s = load_with_urdf(t);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("link 'l2' (after moving joint 'j2') has no <inertial>: it moves no mass"), std::string::npos)
      << s.warnings[0];
}

TEST(Urdf, LinksOffTheChainAreReportedWithTheirMass) {
  // a gripper finger branching off l3: the chain ends at 'tool', the finger is left out, and said so
  std::string t = planar3r();
  t.insert(t.find("</robot>"),
           "  <link name=\"finger\"><inertial><mass value=\"0.25\"/><inertia ixx=\"1e-4\" iyy=\"1e-4\" izz=\"1e-4\" "
           "ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
           "  <joint name=\"jf\" type=\"prismatic\"><parent link=\"l3\"/><child link=\"finger\"/><axis xyz=\"0 1 0\"/>"
           "<limit lower=\"0\" upper=\"0.04\" effort=\"20\" velocity=\"0.2\"/></joint>\n");
  EXPECT_NE(error_of(t).find("branches below 'l3': give robots.<name>.tip"), std::string::npos);
  const System s = load_with_urdf(t, ", tip: tool");
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("links off the chain base .. tool are left out: finger (0.25 kg; robots.<name>.branches: keep adds them rigidly)"), std::string::npos)
      << s.warnings[0];
}

TEST(Urdf, SideBranchesKeptRigidlyCountTheirMass) {
  // the finger off l3, kept (branches: keep) rigidly at its joint's zero, equals the same URDF read
  // with the finger as the chain's tip and its joint held at 0 (fixed_joints): the same rigid body
  std::string t = planar3r();
  t.insert(t.find("</robot>"),
           "  <link name=\"finger\"><inertial><origin xyz=\"0.05 0.02 0\"/><mass value=\"0.25\"/><inertia ixx=\"1e-4\" "
           "iyy=\"2e-4\" izz=\"2.5e-4\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
           "  <joint name=\"jf\" type=\"prismatic\"><parent link=\"l3\"/><child link=\"finger\"/><origin xyz=\"0.1 0 0\"/>"
           "<axis xyz=\"0 1 0\"/><limit lower=\"0\" upper=\"0.04\" effort=\"20\" velocity=\"0.2\"/></joint>\n");
  const System kept = load_with_urdf(t, ", tip: tool, branches: keep");
  ASSERT_EQ(kept.warnings.size(), 1u);
  EXPECT_NE(kept.warnings[0].find("finger (0.25 kg) kept rigidly on 'l3' with their joints at zero"), std::string::npos)
      << kept.warnings[0];
  double m_kept = 0, m_plain = 0;
  for (const Body& b : kept.model.bodies) m_kept += b.inertia.m;
  for (const Body& b : load_with_urdf(t, ", tip: tool").model.bodies) m_plain += b.inertia.m;
  EXPECT_NEAR(m_kept - m_plain, 2 * 0.25, 1e-12) << "both arms' fingers count";
  // the twin: finger on the chain, its joint held (planar_arms_load's q gain the finger's 0)
  const std::string path = ::testing::TempDir() + "coopdyn_urdf_twin_" + std::to_string(::getpid()) + ".urdf";
  std::ofstream(path) << t;
  std::string dh = scene_text("planar_arms_load");
  const auto a = dh.find("  planar3r:\n"), b = dh.find("load:");
  std::string scene = dh.substr(0, a) + "  planar3r: {urdf: " + path + ", tip: finger}\n" + dh.substr(b);
  scene = replace_once(scene, "q: [0.6, -1.0, 0.4]", "q: [0.6, -1.0, 0.4, 0]\n    fixed_joints: [4]");
  scene = replace_once(scene, "q: [-0.6, 1.0, -0.4]", "q: [-0.6, 1.0, -0.4, 0]\n    fixed_joints: [4]");
  const System twin = load_scene_string(scene, scene_path("planar_twin"));
  std::remove(path.c_str());
  ASSERT_EQ(twin.model.nv(), kept.model.nv());
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(kept.model.nv());
  for (int i = 6; i < tau.size(); ++i) tau[i] = 0.5 * std::sin(1.0 + i);
  Workspace wk(kept), wt(twin);
  evaluate(kept, wk, kept.q0, kept.v0, tau);
  evaluate(twin, wt, twin.q0, twin.v0, tau);
  EXPECT_LT((wk.vdot - wt.vdot).cwiseAbs().maxCoeff(), 1e-10 * (1 + wk.vdot.cwiseAbs().maxCoeff()));
}

TEST(Urdf, AnUnexpandedXacroIsRefused) {
  // an element in the xacro namespace (line 6), or an attribute in it under another prefix
  std::string t = planar3r();
  t.insert(t.find("<link name=\"base\"/>"), "<xacro:property name=\"len\" value=\"0.5\"/>\n  ");
  const std::string e = error_of(t);
  EXPECT_NE(e.find("URDF " + urdf_tmp_path() + ":5: the file is a xacro macro (an element or attribute in the xacro "
                   "namespace): expand it first (xacro FILE.urdf.xacro > FILE.urdf)"), std::string::npos) << e;
  t = planar3r();
  t.replace(t.find("<robot name=\"planar3r\">"), 22, "<robot name=\"planar3r\" xmlns:x=\"http://www.ros.org/wiki/xacro\">");
  t.replace(t.find("<link name=\"tool\"/>"), 19, "<link name=\"tool\" x:if=\"1\"/>");
  EXPECT_NE(error_of(t).find(":18: the file is a xacro macro"), std::string::npos) << error_of(t);
}

TEST(Urdf, XacroOutputWithXacroCallsInCommentsLoads) {
  // xacro's output: the namespace declared, calls and ${...} left in comments and CDATA, a ${ in a
  // name: no element or attribute in the namespace, so the file loads (as 14 of 69 published ones)
  std::string t = planar3r();
  t.replace(t.find("<robot name=\"planar3r\">"), 22, "<robot name=\"planar3r${suffix}\" xmlns:xacro=\"http://www.ros.org/wiki/xacro\">");
  t.insert(t.find("  <link name=\"l1\">"), "  <!-- <xacro:gripper prefix=\"left\" parent=\"${tool}\"/> -->\n  <!--\n"
                                              "  <xacro:arm/>\n  -->\n");
  const System s = load_with_urdf(t);
  EXPECT_TRUE(s.warnings.empty()) << warnings_of(s);
  // the same dynamics as the file without them
  const System plain = load_with_urdf(planar3r());
  ASSERT_EQ(s.model.nv(), plain.model.nv());
  Workspace a(s), b(plain);
  const Eigen::VectorXd tau = Eigen::VectorXd::Constant(s.model.nv(), 0.3);
  evaluate(s, a, s.q0, s.v0, tau);
  evaluate(plain, b, plain.q0, plain.v0, tau);
  EXPECT_EQ((a.vdot - b.vdot).cwiseAbs().maxCoeff(), 0.0);
}

TEST(Urdf, TheShippedIiwaSceneHoldsItsBoxWithinTheUrdfLimits) {
  // two_iiwa_load: KUKA iiwa 14 arms from Drake's published URDF (config/robots/iiwa14.urdf)
  const System sys = load("two_iiwa_load");
  // no warning: the URDF's joint damping (0.5 N*m*s/rad each) is modelled (Friction.* checks it)
  EXPECT_TRUE(sys.warnings.empty()) << sys.warnings.front();
  ASSERT_EQ(sys.model.nv(), 6 + 14);
  const double effort[7] = {320, 320, 176, 176, 110, 40, 40};  // the URDF's <limit effort>
  for (int a = 1; a <= 2; ++a)
    for (int k = 1; k <= 7; ++k) {
      const int i = index_of(sys.model.v_names, "arm" + std::to_string(a) + ".iiwa_joint_" + std::to_string(k));
      ASSERT_GE(i, 0);
      EXPECT_EQ(sys.tau_limit[i], effort[k - 1]);
    }
  // the masses of the URDF, summed by hand: links 0..7 = 5 + 5.76 + 6.35 + 3 x 3.5 + 1.8 + 1.2 kg per arm
  double m = 0;
  for (const Body& b : sys.model.bodies) m += b.inertia.m;
  EXPECT_NEAR(m, 2 * 30.61 + 4.0, 1e-12);
  // held still by the minimum-norm holding torques, within the efforts; the bases carry everything
  HoldWorkspace hw(sys, default_actuated(sys));
  Eigen::VectorXd tau(sys.model.nv());
  ASSERT_TRUE(holding_torque(sys, hw, sys.q0, sys.v0, tau));
  for (int i = 6; i < sys.model.nv(); ++i) EXPECT_LE(std::abs(tau[i]), sys.tau_limit[i]) << sys.model.v_names[i];
  Workspace ws(sys);
  ASSERT_EQ(evaluate(sys, ws, sys.q0, sys.v0, tau).status, Status::kOk);
  EXPECT_LT(ws.vdot.cwiseAbs().maxCoeff(), 1e-9);
  const double fz = base_vertical_force(sys, ws);
  EXPECT_NEAR(fz, (2 * 30.61 + 4.0) * 9.81, 1e-8 * fz);
}

}  // namespace
}  // namespace coopdyn::testing

namespace coopdyn::testing {
namespace {

TEST(Urdf, AFloatingJointInTheFileIsRefusedWithItsLineAndTheSceneWay) {
  // many descriptions hang the base from a `world` link by a floating joint: refused (coopdyn's free
  // base is the scene's), at the joint's line, naming the child link to load the robot from
  const std::string t = std::string("<robot name=\"f\"><link name=\"world\"/>\n") +
                        "<link name=\"base\"><inertial><mass value=\"1\"/><inertia ixx=\"0.1\" iyy=\"0.1\" izz=\"0.1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
                        "<joint name=\"float\" type=\"floating\"><parent link=\"world\"/><child link=\"base\"/></joint>\n" +
                        "<link name=\"l1\"><inertial><mass value=\"1\"/><inertia ixx=\"0.1\" iyy=\"0.1\" izz=\"0.1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
                        "<joint name=\"j1\" type=\"revolute\"><parent link=\"base\"/><child link=\"l1\"/><axis xyz=\"0 0 1\"/>"
                        "<limit effort=\"1\" lower=\"-1\" upper=\"1\" velocity=\"1\"/></joint></robot>\n";
  const std::string e = error_of(t, ", tip: l1");
  EXPECT_NE(e.find(urdf_tmp_path() + ":3: joint 'float' is floating"), std::string::npos) << e;
  EXPECT_NE(e.find("root: floating"), std::string::npos) << e;
  EXPECT_NE(e.find("child link ('base')"), std::string::npos) << e;
}

}  // namespace
}  // namespace coopdyn::testing
