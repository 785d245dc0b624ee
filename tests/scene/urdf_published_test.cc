// Robots as published (service/scene/urdf_file.cc, robot_urdf.cc, build_tree.cc): what published
// URDFs hold and a reader must accept without an edit, each rule on a small file written here: a
// tiny non-positive-semi-definite inertia repaired to the nearest PSD tensor (beyond the tolerance
// refused, naming the option that repairs).
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <cstdlib>
#include <string>
#include <vector>

#include "service/scene/scene.h"
#include "tests/support/files.h"

namespace coopdyn::testing {
namespace {

// a directory of its own under the test's temporary directory, removed with its files at the end
class TempDir {
 public:
  TempDir() : dir_(std::filesystem::path(::testing::TempDir()) / ("coopdyn_published_" + std::to_string(::getpid()) + "_" +
                                                                   std::to_string(counter()++))) {
    std::filesystem::create_directories(dir_);
  }
  ~TempDir() { std::filesystem::remove_all(dir_); }
  std::string path() const { return dir_.string(); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(dir_ / name) << text;
    return (dir_ / name).string();
  }

 private:
  static int& counter() {
    static int n = 0;
    return n;
  }
  std::filesystem::path dir_;
};

// A two-link arm (2 kg + 1 kg, 1 m) and, on a fixed joint, a 1 mg antenna whose inertia is
// TIAGo's base_antenna_left_link's (products too large for its moments: eigenvalue -3.5e-8 kg*m^2).
std::string arm_with_antenna(const std::string& antenna_inertia, double antenna_mass = 1e-6) {
  return R"(<robot name="arm">
  <link name="base"><inertial><mass value="2"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="100" velocity="1"/></joint>
  <link name="l1"><inertial><origin xyz="0.5 0 0"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.08" izz="0.08" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j2" type="fixed"><parent link="l1"/><child link="tip"/><origin xyz="1 0 0"/></joint>
  <link name="tip"/>
  <joint name="antenna_joint" type="fixed"><parent link="base"/><child link="antenna"/><origin xyz="-0.2 0.1 0.2"/></joint>
  <link name="antenna"><inertial><mass value=")" +
         std::to_string(antenna_mass) + R"("/>
    <inertia )" + antenna_inertia + R"(/></inertial></link>
</robot>
)";
}
const char* kTiagoAntenna =
    R"(ixx="0.00000002371" ixy="0.00000006119" ixz="0.00000001179" iyy="0.00000002833" iyz="0.00000000774" izz="0.00000003849")";

std::string whole_scene(const std::string& urdf, const std::string& robot_extra = "", const std::string& body_extra = "") {
  return "robots:\n  arm: {urdf: " + urdf + robot_extra + "}\nbodies:\n  - {name: arm, robot: arm, root: fixed" + body_extra +
         "}\n";
}

std::string error_of(const std::string& text, const std::string& file) {
  try {
    load_scene_string(text, file);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "(loaded)";
}

Mat3 tensor(double xx, double yy, double zz, double xy, double xz, double yz) {
  Mat3 I;
  I << xx, xy, xz, xy, yy, yz, xz, yz, zz;
  return I;
}

// the repaired tensor is the nearest PSD one: the original's eigenvectors, its eigenvalues clipped at 0
void expect_nearest_psd(const Mat3& given, const Mat3& repaired) {
  const Eigen::SelfAdjointEigenSolver<Mat3> a(given), b(repaired);
  EXPECT_LT(a.eigenvalues()[0], 0.0);
  EXPECT_NEAR(b.eigenvalues()[0], 0.0, 1e-12 * a.eigenvalues().cwiseAbs().maxCoeff());
  for (int k = 1; k < 3; ++k) EXPECT_NEAR(b.eigenvalues()[k], a.eigenvalues()[k], 1e-12 * a.eigenvalues().cwiseAbs().maxCoeff());
  // the change is the negative eigenvalue's part alone: its norm is |lambda_min| (the Frobenius distance to the PSD cone)
  EXPECT_NEAR((repaired - given).norm(), -a.eigenvalues()[0], 1e-9 * -a.eigenvalues()[0]);
  const Vec3 v = a.eigenvectors().col(0);
  EXPECT_NEAR(v.dot(repaired * v), 0.0, 1e-12 * a.eigenvalues().cwiseAbs().maxCoeff());
}

TEST(UrdfPublished, TinyNonPsdInertiaIsRepairedToTheNearestPsdTensorWithOneWarning) {
  TempDir dir;
  const std::string urdf = dir.write("arm.urdf", arm_with_antenna(kTiagoAntenna));
  const System sys = load_scene_string(whole_scene(urdf), dir.path() + "/scene.yaml");
  int repairs = 0;
  for (const std::string& w : sys.warnings)
    if (w.find("not positive semi-definite") != std::string::npos) {
      ++repairs;
      EXPECT_NE(w.find("link 'antenna'"), std::string::npos) << w;
      EXPECT_NE(w.find("replaced by the nearest positive semi-definite tensor"), std::string::npos) << w;
      EXPECT_NE(w.find(" ixy "), std::string::npos) << w;  // the new tensor, in full
    }
  EXPECT_EQ(repairs, 1);
  const int b = sys.model.body_index("arm.antenna");
  ASSERT_GE(b, 0);
  const Inertia& I = sys.model.bodies[b].inertia;
  EXPECT_DOUBLE_EQ(I.m, 1e-6);  // the mass and centre as written
  EXPECT_EQ(I.c, Vec3::Zero());
  expect_nearest_psd(tensor(2.371e-8, 2.833e-8, 3.849e-8, 6.119e-8, 1.179e-8, 0.774e-8), I.Ic);
}

TEST(UrdfPublished, NonPsdInertiaBeyondTheToleranceIsRefusedNamingTheOptionThatRepairsIt) {
  TempDir dir;
  // a 0.5 kg link with a negative eigenvalue of -0.04 kg*m^2: the robot (3.5 kg, 1 m) gives a tolerance of 3.5e-6
  const std::string inertia = R"(ixx="0.01" iyy="0.01" izz="0.02" ixy="0.05" ixz="0" iyz="0")";
  const std::string urdf = dir.write("arm.urdf", arm_with_antenna(inertia, 0.5));
  const std::string e = error_of(whole_scene(urdf), dir.path() + "/scene.yaml");
  EXPECT_NE(e.find("link 'antenna': inertia tensor is not positive semi-definite"), std::string::npos) << e;
  EXPECT_NE(e.find("beyond the repair tolerance"), std::string::npos) << e;
  EXPECT_NE(e.find("robots.arm.repair_inertia: true"), std::string::npos) << e;
  EXPECT_NE(e.find("arm.urdf:10"), std::string::npos) << e;  // the file and line of the <inertial>
  // the option repairs it, with one warning; so for a chain
  for (const std::string& extra : {std::string(", repair_inertia: true")}) {
    const System sys = load_scene_string(whole_scene(urdf, extra), dir.path() + "/scene.yaml");
    const int b = sys.model.body_index("arm.antenna");
    ASSERT_GE(b, 0);
    expect_nearest_psd(tensor(0.01, 0.01, 0.02, 0.05, 0, 0), sys.model.bodies[b].inertia.Ic);
  }
}

}  // namespace
}  // namespace coopdyn::testing

// ---- every description of example-robot-data (a checkout's path in COOPDYN_EXAMPLE_ROBOT_DATA) ----

namespace coopdyn::testing {
namespace {

std::vector<std::string> example_robot_data_urdfs(const std::string& root) {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::recursive_directory_iterator(std::filesystem::path(root) / "robots"))
    if (e.is_regular_file() && e.path().extension() == ".urdf") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

TEST(UrdfPublished, EveryExampleRobotDataDescriptionLoadsWhole) {
  const char* root = std::getenv("COOPDYN_EXAMPLE_ROBOT_DATA");
  if (!root) GTEST_SKIP() << "COOPDYN_EXAMPLE_ROBOT_DATA (a checkout of example-robot-data) is not set";
  TempDir dir;
  int n = 0, refused = 0;
  for (const std::string& u : example_robot_data_urdfs(root)) {
    ++n;
    const std::string e = error_of(whole_scene(u), dir.path() + "/scene.yaml");
    if (e == "(loaded)" && std::getenv("PRINT_WARNINGS")) {
      const System sys = load_scene_string(whole_scene(u), dir.path() + "/scene.yaml");
      std::printf("%s nv %d\n", u.c_str(), sys.model.nv());
      for (const auto& w : sys.warnings) if (w.find("semi-definite") != std::string::npos) std::printf("  %s\n", w.c_str());
    }
    if (e != "(loaded)") {
      ++refused;
      ADD_FAILURE() << u << ": " << e;
    }
  }
  std::printf("%d of %d descriptions loaded whole\n", n - refused, n);
}

}  // namespace
}  // namespace coopdyn::testing
