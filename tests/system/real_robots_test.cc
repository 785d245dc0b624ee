// The real robots shipped as scenes (config/scenes/pr2_box.yaml, tiago_pro_box.yaml: published URDFs,
// whole trees, two arms on a shared torso lift holding a box; TIAGo Pro on its four wheels). Each
// loads with nothing of its file lost (every URDF mass, every <mimic> coupling), and under the
// holding torques (coopdynd's `hold`) the physics balances: the box's Newton-Euler with both hands'
// wrenches, the wheels' normal forces against the weight of robot and box. The masses and mimics
// are counted from the URDF text itself, independently of urdfdom and of the loader.
// The same scenes against Pinocchio's own URDF reader and constrained dynamics: bench/peers/pin_robots.
#include <gtest/gtest.h>

#include <string>

#include "service/dynamics/holding_torque.h"
#include "service/dynamics/wrenches.h"
#include "tests/support/files.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {

// the URDF text without its comments (a plain scan: std::regex recurses per character of a match,
// and a licence in a comment is 11 kB)
std::string urdf_text(const std::string& robot) {
  const std::string xml = slurp(std::string(COOPDYN_SOURCE_DIR) + "/config/robots/" + robot + ".urdf");
  std::string out;
  size_t p = 0;
  for (size_t c = xml.find("<!--"); c != std::string::npos; c = xml.find("<!--", p)) {
    out.append(xml, p, c - p);
    const size_t e = xml.find("-->", c + 4);
    p = e == std::string::npos ? xml.size() : e + 3;
  }
  out.append(xml, std::min(p, xml.size()), std::string::npos);
  return out;
}

double urdf_mass(const std::string& xml) {
  double m = 0;
  for (size_t p = xml.find("<mass"); p != std::string::npos; p = xml.find("<mass", p + 5)) {
    const size_t v = xml.find("value=\"", p);
    m += std::stod(xml.substr(v + 7, xml.find('"', v + 7) - v - 7));
  }
  return m;
}

int urdf_mimics(const std::string& xml) {
  int n = 0;
  for (size_t p = xml.find("<mimic"); p != std::string::npos; p = xml.find("<mimic", p + 6)) ++n;
  return n;
}

int output_index(const System& sys, const std::string& name) {
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k)
    if (sys.wrenches.outputs[k].name == name) return static_cast<int>(k);
  ADD_FAILURE() << "no output " << name;
  return 0;
}

struct Robot {
  const char* scene;
  const char* urdf;
  double box_mass;
  std::vector<const char*> wheels;
};

void PrintTo(const Robot& r, std::ostream* os) { *os << r.scene; }

class RealRobot : public ::testing::TestWithParam<Robot> {};

TEST_P(RealRobot, NothingOfTheFileIsLost) {
  const Robot& r = GetParam();
  const System sys = load_scene(scene_path(r.scene));
  const std::string xml = urdf_text(r.urdf);
  double m = 0;
  for (const Body& b : sys.model.bodies) m += b.inertia.m;
  EXPECT_NEAR(m, urdf_mass(xml) + r.box_mass, 1e-9) << "every link's mass, and the box";
  int couplings = 0;
  for (const ConstraintSpec& c : sys.constraints.specs) couplings += c.kind == ConstraintKind::kCouple;
  EXPECT_EQ(couplings, urdf_mimics(xml)) << "every <mimic> a coupling";
  EXPECT_GT(couplings, 0);
}

TEST_P(RealRobot, HeldStillTheHandsCarryTheBoxAndTheWheelsEverything) {
  const Robot& r = GetParam();
  const System sys = load_scene(scene_path(r.scene));
  HoldWorkspace hw(sys, default_actuated(sys));
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
  ASSERT_TRUE(holding_torque(sys, hw, sys.q0, sys.v0, tau));
  Workspace ws(sys);
  ASSERT_NE(evaluate(sys, ws, sys.q0, sys.v0, tau).status, Status::kError);
  EXPECT_LT(ws.vdot.cwiseAbs().maxCoeff(), 1e-7) << "held still";
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  // the box (its centre of mass at its frame's origin) at rest: the hands' wrenches on it, negated
  // (each output is what the box's grasp frame exerts on the hand), balance its weight
  const int box = sys.model.body_index("box");
  ASSERT_GE(box, 0);
  const Vec3 c = ws.data.X_WB[box].p;
  Vec3 f = Vec3::Zero(), mo = Vec3::Zero();
  for (const char* hand : {"left_hand", "right_hand"}) {
    const int k = output_index(sys, hand);
    const Transform X = wrench_frame_pose(sys, ws.data, k);
    const Vec3 fk = -(X.R * wd.W[k].tail<3>());
    f += fk;
    mo += -(X.R * wd.W[k].head<3>()) + (X.p - c).cross(fk);
  }
  const Vec3 weight = r.box_mass * sys.model.gravity_W;
  EXPECT_LT((f + weight).norm(), 1e-9 * weight.norm()) << f.transpose();
  EXPECT_LT(mo.norm(), 1e-9 * weight.norm()) << mo.transpose();
  if (r.wheels.empty()) return;
  double normal = 0;
  for (const char* w : r.wheels) normal += wd.W[output_index(sys, w)][5];
  const double total = (urdf_mass(urdf_text(r.urdf)) + r.box_mass) * sys.model.gravity_W.norm();
  EXPECT_NEAR(normal, total, 1e-9 * total) << "the wheels carry robot and box";
}

INSTANTIATE_TEST_SUITE_P(Shipped, RealRobot,
                         ::testing::Values(Robot{"pr2_box", "pr2", 3.0, {}},
                                           Robot{"tiago_pro_box", "tiago_pro", 2.0,
                                                 {"wheel_fl", "wheel_fr", "wheel_rl", "wheel_rr"}}),
                         [](const ::testing::TestParamInfo<Robot>& i) { return std::string(i.param.scene); });

}  // namespace
}  // namespace coopdyn::testing
