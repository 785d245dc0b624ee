// Values a user types: poses as rpy, quaternion or rotation matrix give the same system; angles in
// degrees are errors and lengths in millimetres, implausible inertias and joint values outside a
// URDF's limits are warnings, each with the file and line.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "service/algorithms/kinematics.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

namespace {
std::string replaced(std::string text, const std::string& a, const std::string& b) {
  const auto p = text.find(a);
  EXPECT_NE(p, std::string::npos) << a;
  if (p != std::string::npos) text.replace(p, a.size(), b);
  return text;
}
std::string error_of(const std::string& text) {
  try {
    load_scene_string(text, "values.yaml");
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}
std::string all_warnings(const System& s) {
  std::string w;
  for (const auto& x : s.warnings) w += x + "\n";
  return w;
}
std::string g17(double x) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", x);
  return b;
}

const char* kArm2Base = "base: {xyz: [2.2021844101119862, 0, 0], rpy: [0, 0, 3.141592653589793]}";

// vdot of a scene at its initial state under zero torque
Eigen::VectorXd vdot_of(const System& s) {
  Workspace ws(s);
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(s.model.nv());
  EXPECT_NE(evaluate(s, ws, s.q0, s.v0, tau).status, Status::kError);
  return ws.vdot;
}
}  // namespace

TEST(SceneValues, EveryShippedSceneLoadsWithoutWarnings) {
  for (const char* name : {"two_puma_load", "planar_arms_load", "two_5dof_arms_load", "four_bar", "two_wheel_vehicle", "unicycle", "two_iiwa_load"}) {
    const System s = load_scene(scene_path(name));
    EXPECT_TRUE(warnings_besides_dynamics(s).empty()) << name << ": " << all_warnings(s);
  }
}

TEST(SceneValues, PoseAsQuaternionOrMatrixEqualsRpy) {
  const std::string text = scene_text("planar_arms_load");
  ASSERT_NE(text.find(kArm2Base), std::string::npos);
  const System rpy = load_scene_string(text, "rpy.yaml");
  // Rz(pi): the quaternion [w x y z] = [0 0 0 1], the matrix diag(-1, -1, 1)
  const System quat = load_scene_string(
      replaced(text, kArm2Base, "base: {xyz: [2.2021844101119862, 0, 0], quat: [0, 0, 0, 1]}"), "quat.yaml");
  const System mat = load_scene_string(
      replaced(text, kArm2Base, "base: {xyz: [2.2021844101119862, 0, 0], R: [[-1, 0, 0], [0, -1, 0], [0, 0, 1]]}"), "R.yaml");
  const Eigen::VectorXd a = vdot_of(rpy);
  // rpy's cos(pi) is -1 + 0 and sin(pi) 1.2e-16: equal to round-off, not bit for bit
  EXPECT_LT((vdot_of(quat) - a).cwiseAbs().maxCoeff(), 1e-12 * (1 + a.cwiseAbs().maxCoeff()));
  EXPECT_LT((vdot_of(mat) - a).cwiseAbs().maxCoeff(), 1e-12 * (1 + a.cwiseAbs().maxCoeff()));
  EXPECT_LT((quat.q0 - rpy.q0).cwiseAbs().maxCoeff(), 1e-14);
}

TEST(SceneValues, GimbalLockPoseReadsBackFromItsMatrixAndQuaternion) {
  // at pitch = 90 deg roll and yaw share an axis: a pose from another tool must be taken as it is,
  // not through angles. The frame written as R (17 digits) and as a quaternion lands on R itself.
  const Mat3 R = rpy_matrix(Vec3(0.4, M_PI / 2, -0.7));
  const Quat qu(R);
  std::string rows = "[";
  for (int i = 0; i < 3; ++i)
    rows += std::string(i ? ", " : "") + "[" + g17(R(i, 0)) + ", " + g17(R(i, 1)) + ", " + g17(R(i, 2)) + "]";
  rows += "]";
  const std::string base = scene_text("four_bar");
  const std::string anchor = "frames:\n";
  ASSERT_NE(base.find(anchor), std::string::npos);
  auto frame_R = [&](const std::string& pose) {
    const System s = load_scene_string(
        replaced(base, anchor, anchor + "  - {name: probe, body: rocker, xyz: [0.1, 0.2, 0.3], " + pose + "}\n"), "gimbal.yaml");
    return s.model.frames[s.model.frame_index("probe")].X_BF.R;
  };
  EXPECT_LT((frame_R("R: " + rows) - R).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT((frame_R("quat: [" + g17(qu.w()) + ", " + g17(qu.x()) + ", " + g17(qu.y()) + ", " + g17(qu.z()) + "]") - R)
                .cwiseAbs()
                .maxCoeff(),
            1e-15);
  EXPECT_LT((frame_R("rpy: [0.4, pi/2, -0.7]") - R).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(SceneValues, BadRotationsAreErrorsAtTheirLine) {
  const std::string text = scene_text("planar_arms_load");
  const int line = [&] {
    std::istringstream is(text);
    std::string l;
    for (int n = 1; std::getline(is, l); ++n)
      if (l.find(kArm2Base) != std::string::npos) return n;
    return -1;
  }();
  std::string e = error_of(replaced(text, kArm2Base, "base: {xyz: [2.2, 0, 0], quat: [0, 0, 0, 2]}"));
  EXPECT_NE(e.find("values.yaml:" + std::to_string(line) + ":"), std::string::npos) << e;
  EXPECT_NE(e.find("has norm 2, not 1 (a unit quaternion, scalar first)"), std::string::npos) << e;
  e = error_of(replaced(text, kArm2Base, "base: {xyz: [2.2, 0, 0], R: [[1, 0, 0], [0, 1, 0], [0, 0, -1]]}"));
  EXPECT_NE(e.find("is not a rotation"), std::string::npos) << e;
  EXPECT_NE(e.find("det -1"), std::string::npos) << e;
  e = error_of(replaced(text, kArm2Base, "base: {xyz: [2.2, 0, 0], rpy: [0, 0, 3.14], quat: [0, 0, 0, 1]}"));
  EXPECT_NE(e.find("give the rotation once, as rpy, quat or R"), std::string::npos) << e;
}

TEST(SceneValues, AnglesInDegreesAreErrors) {
  const std::string text = scene_text("planar_arms_load");
  std::string e = error_of(replaced(text, kArm2Base, "base: {xyz: [2.2021844101119862, 0, 0], rpy: [0, 0, 180]}"));
  EXPECT_NE(e.find("rpy[2] = 180 rad is more than a full turn: angles are radians (degrees? 180 deg = 3.14159 rad"),
            std::string::npos)
      << e;
  // a DH twist of 90 (degrees) in a robot of the scene: the error is at that link's line
  e = error_of(replaced(text, "alpha: 0,", "alpha: 90,"));
  EXPECT_NE(e.find("alpha = 90 rad is more than a full turn"), std::string::npos) << e;
  EXPECT_EQ(e.find("values.yaml:"), 0u) << e;
}

TEST(SceneValues, ImplausibleValuesAreWarningsWithTheirLine) {
  const std::string text = scene_text("planar_arms_load");
  // principal moments 0.001, 0.001, 0.01: no rigid body (I1 + I2 >= I3)
  const std::string load_inertia = "inertia: [0.0048, 0.0048, 0.0048, 0, 0, 0]";
  System s = load_scene_string(replaced(text, load_inertia, "inertia: [0.001, 0.001, 0.01, 0, 0, 0]"), "values.yaml");
  std::string w = all_warnings(s);
  EXPECT_NE(w.find("values.yaml:"), std::string::npos) << w;
  EXPECT_NE(w.find("load: principal moments 0.001, 0.001, 0.01 kg m^2 break the triangle inequality"), std::string::npos) << w;
  // accepted with a reason: no warning; an empty reason is an error
  s = load_scene_string(replaced(text, load_inertia, "inertia: [0.001, 0.001, 0.01, 0, 0, 0]\n  accept_inertia: \"a test\""),
                        "values.yaml");
  EXPECT_TRUE(s.warnings.empty()) << all_warnings(s);
  EXPECT_NE(error_of(replaced(text, load_inertia, "inertia: [0.001, 0.001, 0.01, 0, 0, 0]\n  accept_inertia: \"\"")).find(
                "accept_inertia needs the reason as text"),
            std::string::npos);
  // a rotor-only model (one nonzero moment, as PUMA link 1's) is a published idealization: accepted
  s = load_scene_string(replaced(text, load_inertia, "inertia: [0, 0, 0.0048, 0, 0, 0]"), "values.yaml");
  EXPECT_EQ(all_warnings(s).find("triangle"), std::string::npos) << all_warnings(s);
  // grams and millimetres
  s = load_scene_string(replaced(text, load_inertia, "inertia: [0.0048, 0.0048, 0.0048, 0, 0, 0]\n  com: [0, 0, 1500]"),
                        "values.yaml");
  w = all_warnings(s);
  EXPECT_NE(w.find("load.com[2] = 1500 m is more than 1 km: lengths are metres (millimetres?)"), std::string::npos) << w;
  s = load_scene_string(replaced(scene_text("four_bar"), "mass: 0.7\n", "mass: 700000\n"), "values.yaml");
  w = all_warnings(s);
  EXPECT_NE(w.find("body 'rocker': mass 700000 kg is more than 100 t (masses are kg: grams?)"), std::string::npos) << w;
}

TEST(SceneValues, JointValuesOutsideUrdfLimitsAreWarnings) {
  // planar3r.urdf limits its joints to [-3, 3]; 3.2 is outside, and 400 is degrees (or turns)
  const std::string path = ::testing::TempDir() + "coopdyn_values_" + std::to_string(::getpid()) + ".urdf";
  {
    std::ifstream in(std::string(COOPDYN_SOURCE_DIR) + "/config/robots/planar3r.urdf");
    std::ofstream(path) << in.rdbuf();
  }
  std::string text = scene_text("planar_arms_load");
  const auto a = text.find("  planar3r:\n"), b = text.find("load:");
  text = text.substr(0, a) + "  planar3r: {urdf: " + path + "}\n" + text.substr(b);
  text = replaced(text, "q: [0.6, -1.0, 0.4]", "q: [0.6, -1.0, 3.2]");
  System s = load_scene_string(text, "values.yaml");
  std::string w = all_warnings(s);
  EXPECT_NE(w.find("arm 'arm1' joint j3 q = 3.2 is outside its limits [-3, 3] (URDF " + path + ":22)"), std::string::npos)
      << w;
  EXPECT_NE(w.find("values.yaml:"), std::string::npos) << w;
  std::remove(path.c_str());
}
