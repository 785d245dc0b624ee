// Joint limits exceeded (joint_limits.h): the URDF's <limit> reaches every formulation by joint name,
// each limit is flagged just past it and not at it, and the unactuated DOFs carry no effort limit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "service/dynamics/joint_limits.h"
#include "service/scene/scene.h"
#include "tests/support/files.h"

using namespace coopdyn;

namespace {
System load(const std::string& scene, Formulation f = Formulation::kMobilePlatform) {
  SceneOverrides o;
  o.formulation = f;
  return load_scene(coopdyn::testing::scene_path(scene), o);
}
int index_of(const std::vector<std::string>& names, const std::string& n) {
  return static_cast<int>(std::find(names.begin(), names.end(), n) - names.begin());
}
}  // namespace

// iiwa14.urdf: joint 2 limits [-2.094, 2.094] rad, 1.484 rad/s, 320 N*m; the same by name in every
// formulation (mobile_platform reverses the arm's order and axes, not its coordinates)
TEST(JointLimits, TheUrdfLimitsReachEveryFormulationByName) {
  const System a = load("two_iiwa_load"), b = load("two_iiwa_load", Formulation::kClassic);
  const std::string j2 = "arm1.iiwa_joint_2";
  for (const System* s : {&a, &b}) {
    const int d = index_of(s->model.v_names, j2);
    ASSERT_LT(d, s->model.nv()) << j2;
    EXPECT_DOUBLE_EQ(s->q_lower[d], -2.09439510239);
    EXPECT_DOUBLE_EQ(s->q_upper[d], 2.09439510239);
    EXPECT_DOUBLE_EQ(s->v_limit[d], 1.4835298641951802);
    EXPECT_DOUBLE_EQ(s->tau_limit[d], 320);
  }
  for (int d = 0; d < a.model.nv(); ++d) {
    const int e = index_of(b.model.v_names, a.model.v_names[d]);
    ASSERT_LT(e, b.model.nv());
    EXPECT_EQ(a.q_lower[d], b.q_lower[e]) << a.model.v_names[d];
    EXPECT_EQ(a.q_upper[d], b.q_upper[e]);
    EXPECT_EQ(a.v_limit[d], b.v_limit[e]);
  }
}

TEST(JointLimits, EachLimitIsFlaggedPastItNotAtIt) {
  for (Formulation f : {Formulation::kMobilePlatform, Formulation::kClassic}) {
    SCOPED_TRACE(static_cast<int>(f));
    const System s = load("two_iiwa_load", f);
    LimitData ld(s);
    Eigen::VectorXd q = s.q0, v = Eigen::VectorXd::Zero(s.model.nv()), tau = Eigen::VectorXd::Zero(s.model.nv());
    EXPECT_EQ(check_joint_limits(s, ld, q, v, tau), 0) << "the shipped scene starts within its limits";
    const int d = index_of(s.model.v_names, "arm2.iiwa_joint_4");
    const int qi = s.model.bodies[s.model.dof_body[d]].joint.idx_q;
    const double up = s.q_upper[d], lo = s.q_lower[d];
    q[qi] = up;
    v[d] = -s.v_limit[d];
    tau[d] = s.tau_limit[d];
    EXPECT_EQ(check_joint_limits(s, ld, q, v, tau), 0) << "at each limit: within";
    q[qi] = std::nextafter(up, 10.0);
    EXPECT_EQ(check_joint_limits(s, ld, q, v, tau), 1);
    EXPECT_EQ(ld.mask[d], kLimitPosition);
    q[qi] = std::nextafter(lo, -10.0);
    v[d] = std::nextafter(-s.v_limit[d], -10.0);
    tau[d] = std::nextafter(s.tau_limit[d], 1e9);
    EXPECT_EQ(check_joint_limits(s, ld, q, v, tau), 1);
    EXPECT_EQ(ld.mask[d], kLimitPosition | kLimitVelocity | kLimitEffort);
    EXPECT_EQ(ld.any, kLimitPosition | kLimitVelocity | kLimitEffort);
    // back within: the mask clears
    q = s.q0;
    v.setZero();
    tau.setZero();
    EXPECT_EQ(check_joint_limits(s, ld, q, v, tau), 0);
    EXPECT_EQ(ld.mask[d], 0);
    EXPECT_EQ(ld.any, 0);
    // the load's floating DOFs (tau_limit 0: unactuated) carry no limit whatever their torque
    for (int i = 0; i < s.model.nv(); ++i)
      if (s.tau_limit[i] == 0) tau[i] = 1e6;
    EXPECT_EQ(check_joint_limits(s, ld, q, v, tau), 0);
  }
}

// A system built without limit vectors (sizes 0) has none, and a NaN is not a limit's business.
TEST(JointLimits, NoVectorsNoLimitsAndNaNPasses) {
  System s = load("two_iiwa_load");
  LimitData with(s);
  Eigen::VectorXd q = s.q0, v = Eigen::VectorXd::Constant(s.model.nv(), std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(check_joint_limits(s, with, q, v, v), 0);
  s.q_lower.resize(0);
  s.q_upper.resize(0);
  s.v_limit.resize(0);
  LimitData none(s);
  v.setConstant(1e3);
  int actuated = 0;
  for (int i = 0; i < s.model.nv(); ++i) actuated += s.tau_limit[i] > 0 && std::isfinite(s.tau_limit[i]);
  EXPECT_EQ(static_cast<int>(none.dofs.size()), actuated) << "only the effort limits remain";
  EXPECT_EQ(check_joint_limits(s, none, q, v, Eigen::VectorXd::Zero(s.model.nv())), 0);
}

// A DH link's `limits` and `v_limit` (the SCARA of scene_test.cc): angles and lengths as the link's
// others, and a bad one is an error at its line.
TEST(JointLimits, DhLinksDeclareTheirLimits) {
  const std::string head = R"(
name: two_scaras
gravity: [0, 0, -9.81]
formulation: classic
robots:
  scara:
    convention: standard_dh
    links:
)";
  const std::string rest = R"(
      - {a: 0.3, d: 0.0, alpha: 3.141592653589793, mass: 5.0, com: [-0.15, 0, 0], inertia: [0.01, 0.05, 0.05, 0, 0, 0]}
      - {type: prismatic, theta: 0.0, d: 0.05, mass: 1.5, com: [0, 0, -0.1], inertia: [0.005, 0.005, 0.001, 0, 0, 0],
         limits: [0, 0.2]}
      - {a: 0.0, d: 0.08, alpha: 0, mass: 0.5, com: [0, 0, 0.02], inertia: [0.001, 0.001, 0.001, 0, 0, 0]}
load:
  name: load
  mass: 2.0
  inertia: [0.01, 0.01, 0.01, 0, 0, 0]
  pose: {xyz: [0.35, 0.0, 0.05]}
arms:
  - {name: arm1, robot: scara, base: {xyz: [0, -0.45, 0]}, q: [0.9, 1.2, 0.1, 0.0], grasp: at_initial_state}
  - {name: arm2, robot: scara, base: {xyz: [0, 0.45, 0]}, q: [-0.9, -1.2, 0.1, 0.0], grasp: at_initial_state}
)";
  const std::string link1 = "      - {a: 0.4, d: 0.35, alpha: 0, mass: 8.0, com: [-0.2, 0, 0], "
                            "inertia: [0.02, 0.1, 0.1, 0, 0, 0], ";
  const System sys = load_scene_string(head + link1 + "limits: [-pi/2, pi/2], v_limit: 3.0}" + rest, "scara.yaml");
  const Model& m = sys.model;
  const int d1 = m.bodies[m.joint_index("arm2.q1")].joint.idx_v, d3 = m.bodies[m.joint_index("arm2.q3")].joint.idx_v;
  EXPECT_NEAR(sys.q_lower[d1], -M_PI / 2, 1e-15);
  EXPECT_NEAR(sys.q_upper[d1], M_PI / 2, 1e-15);
  EXPECT_EQ(sys.v_limit[d1], 3.0);
  EXPECT_EQ(sys.q_lower[d3], 0.0);
  EXPECT_EQ(sys.q_upper[d3], 0.2);
  EXPECT_TRUE(std::isinf(sys.v_limit[d3]));
  for (const auto& [bad, why] : std::vector<std::pair<std::string, std::string>>{
           {"limits: [1, -1]}", "limits must be [LOWER, UPPER] with LOWER < UPPER"},
           {"limits: [1]}", "limits must be [LOWER, UPPER]"},
           {"v_limit: 0}", "v_limit must be > 0"}}) {
    try {
      load_scene_string(head + link1 + bad + rest, "scara.yaml");
      ADD_FAILURE() << bad << ": loaded";
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find("scara.yaml:9:"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  }
}
