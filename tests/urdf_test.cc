// URDF robots without silent losses: an unreadable <inertial> is an error naming the file, line and
// link; a moving link without one, and links off the chain, are reported as warnings; xacro is refused.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "tests/test_util.h"

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
  EXPECT_NE(s.warnings[0].find("links off the chain base .. tool are left out: finger (0.25 kg)"), std::string::npos)
      << s.warnings[0];
}

TEST(Urdf, AnUnexpandedXacroIsRefused) {
  std::string t = planar3r();
  t.insert(t.find("<link name=\"base\"/>"), "<xacro:property name=\"len\" value=\"0.5\"/>\n  ");
  const std::string e = error_of(t);
  EXPECT_NE(e.find("is a xacro macro: expand the file first"), std::string::npos) << e;
}

}  // namespace
}  // namespace coopdyn::testing
