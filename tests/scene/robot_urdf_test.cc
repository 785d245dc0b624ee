// URDF robots without silent losses: an unreadable <inertial> is an error naming the file, line and
// link; a moving link without one, and links off the chain, are reported as warnings; xacro is refused.
#include <gtest/gtest.h>

#include <cstdio>
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

// planar_arms_load with its robot read from a URDF text written to a temporary file
System load_with_urdf(const std::string& urdf_text, const std::string& extra = "") {
  const std::string path = ::testing::TempDir() + "coopdyn_urdf_" + std::to_string(::getpid()) + ".urdf";
  std::ofstream(path) << urdf_text;
  const std::string dh = scene_text("planar_arms_load");
  const auto a = dh.find("  planar3r:\n"), b = dh.find("load:");
  const std::string scene = dh.substr(0, a) + "  planar3r: {urdf: " + path + extra + "}\n" + dh.substr(b);
  struct Rm {
    std::string p;
    ~Rm() { std::remove(p.c_str()); }
  } rm{path};
  return load_scene_string(scene, scene_path("planar_urdf"));
}

std::string error_of(const std::string& urdf_text, const std::string& extra = "") {
  try {
    load_with_urdf(urdf_text, extra);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

TEST(Urdf, TheShippedRobotLoadsWithoutWarnings) {
  const System s = load_with_urdf(planar3r());
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();  // its massless 'tool' hangs from a fixed flange
}

TEST(Urdf, AnInertialUrdfdomCannotReadIsAnError) {
  std::string t = planar3r();
  t.replace(t.find("<mass value=\"1.5\"/>"), 19, "<mass valeu=\"1.5\"/>");
  const std::string e = error_of(t);
  EXPECT_NE(e.find("link 'l2' has an <inertial> that urdfdom could not read"), std::string::npos) << e;
  EXPECT_NE(e.find("coopdyn_urdf_"), std::string::npos) << "names the URDF file: " << e;
  EXPECT_NE(e.find("line 10"), std::string::npos) << "and the line: " << e;
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
  std::string t = planar3r();
  t.insert(t.find("<link name=\"base\"/>"), "<xacro:property name=\"len\" value=\"0.5\"/>\n  ");
  const std::string e = error_of(t);
  EXPECT_NE(e.find("is a xacro macro: expand the file first"), std::string::npos) << e;
}

TEST(Urdf, TheShippedIiwaSceneHoldsItsBoxWithinTheUrdfLimits) {
  // two_iiwa_load: KUKA iiwa 14 arms from Drake's published URDF (config/robots/iiwa14.urdf)
  const System sys = load("two_iiwa_load");
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
