// The scene compiler's shared state and its passes: arms on a load (build_arms.cc), a tree of
// bodies with frames and constraints (build_bodies.cc), the reported wrenches (scene_outputs.cc),
// the initial state closed onto the constraints (close_loops.cc). scene.cc runs them in order.
// Internal to the scene compiler.
#pragma once

#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "service/dynamics/system.h"
#include "service/scene/robot_chain.h"
#include "service/scene/scene_yaml.h"

namespace coopdyn::scene_detail {

// A robot placed in the scene: an arm of `arms`, or a robot subtree of `bodies`.
struct ArmSpec {
  std::string name;
  const Robot* robot = nullptr;
  Transform X_W_base;  // the robot's base frame in its parent (the world for arms)
  Transform tool;
  std::vector<double> q;
  std::vector<double> v;
  std::set<int> fixed;  // 1-based joint numbers held fixed
  bool grasp_given = false;
  Transform X_L_EE;
  std::array<double, 6> compliance{{0, 0, 0, 0, 0, 0}};
  YAML::Node node;
};

struct Builder {
  Ctx c;
  System sys;
  std::vector<double> q0, v0;  // indexed like the model as it grows
  std::vector<unsigned char> q_given;  // (nq) the scene gave this coordinate's initial value
  std::vector<double> tau_lim;
  std::vector<double> q_lo, q_hi, v_lim;  // per velocity index: System::q_lower, q_upper, v_limit
  std::vector<int> q_floating_idx;
  std::vector<std::pair<int, double>> target_limits;  // (velocity index, |target| allowed) of pseudo-joints
  // the bodies placed from a whole URDF tree (build_tree.cc): body name -> (the tree, its link), for
  // what a constraint reads off the URDF (a rolling wheel's axle and radius)
  std::map<std::string, std::pair<std::shared_ptr<const UrdfTree>, std::string>> urdf_links;
  std::vector<int> held_bodies;  // bodies whose joint close_initial_state never moves (a load at its given pose)
  std::vector<ArmSpec> arms;     // arms + load: the arms on the load (body load_body), for close_grasps_check
                                 // (their robots are compile_scene's: not to be used after it)
  int load_body = -1;

  // adds a body (Model::add_body) with its joint's initial q, v (missing entries 0, marked not given)
  // and torque limit; returns its index
  int add(const std::string& name, int parent, const Transform& X_PJ, const Joint& j, const Inertia& I,
          const std::vector<double>& jq, const std::vector<double>& jv, double tau_limit, const YAML::Node& where) {
    int id;
    try {
      id = sys.model.add_body(name, parent, X_PJ, j, I);
    } catch (const std::invalid_argument& e) {
      fail(c, where, e.what());
    }
    const Joint& jj = sys.model.bodies[id].joint;
    for (int k = 0; k < jj.nq; ++k) {
      q0.push_back(k < static_cast<int>(jq.size()) ? jq[k] : 0.0);
      q_given.push_back(k < static_cast<int>(jq.size()) ? 1 : 0);
    }
    for (int k = 0; k < jj.nv; ++k) {
      v0.push_back(k < static_cast<int>(jv.size()) ? jv[k] : 0.0);
      tau_lim.push_back(tau_limit);
      q_lo.push_back(-std::numeric_limits<double>::infinity());
      q_hi.push_back(std::numeric_limits<double>::infinity());
      v_lim.push_back(std::numeric_limits<double>::infinity());
    }
    return id;
  }
  // the position and speed limits of body id's joint, when it has one DOF (a held joint: none)
  void set_limits(int id, double lower, double upper, double v_limit) {
    const Joint& jj = sys.model.bodies[id].joint;
    if (jj.nv != 1) return;
    q_lo[static_cast<size_t>(jj.idx_v)] = lower;
    q_hi[static_cast<size_t>(jj.idx_v)] = upper;
    v_lim[static_cast<size_t>(jj.idx_v)] = v_limit;
  }
};

// The components of a joint's reaction its bearings carry (WrenchOutput::constrained): all but the
// axes its DOFs move along, when those are axes of the report frame (the child's frame).
uint8_t bearing_mask(JointType t, const Vec3& axis, const Vec3& axis2);
// a joint reaction output (WrenchKind::kJoint)
WrenchOutput joint_output(const std::string& name, const std::string& frame, const std::string& by, int body,
                          bool reversed, int frame_body, const Transform& X_BF, uint8_t mask);
// writes X as a floating joint's 7 coordinates at q[idx] (xyz, then the quaternion w x y z)
void set_floating_q(Eigen::VectorXd& q, int idx, const Transform& X);

// The robot `n["robot"]` names, from the scene's `robots`; an unknown name is an error at its line.
const Robot* find_robot(const Ctx& c, const YAML::Node& n, const std::map<std::string, Robot>& robots, const std::string& what);
// the end-effector (before the tool) in the robot base frame at the arm's q
Transform chain_forward(const ArmSpec& a);
// q, v (the joints that move, in order; warnings for turns and URDF limits) and fixed_joints of an
// arm's or robot subtree's node `a`, into s (s.robot and s.name set)
void parse_arm_joints(const Ctx& c, const YAML::Node& a, ArmSpec& s);
// Adds s's chain to the tree below body `parent` (-1: the world) at s.X_W_base (in the parent's
// frame), with every joint's reaction output (joint 1's 'by' = by_base) and the frames ARM.base
// and ARM.ee; base_output adds the base wrench (world-rooted arms). Returns the last link's body.
int add_chain(Builder& B, const ArmSpec& s, int parent, const std::string& by_base, bool base_output);

// `load` + `arms`: the paper's cooperating arms, in the mobile-platform form or rooted at the world
void build_arms(Builder& B, const YAML::Node& root, const std::map<std::string, Robot>& robots, bool mobile_platform);
// A robot entry of `bodies` whose robot is a whole URDF tree (Robot::tree; build_tree.cc), below body
// `parent` (-1: the world, named `by`): {name, robot, parent, placement, root: fixed | floating,
// root_v, q, v: {joint: value}, fixed_joints, tool}.
void add_robot_tree(Builder& B, const YAML::Node& b, const Robot& r, const std::string& name, int parent, const std::string& by);
// `bodies` + `frames` + `constraints`: any tree closed by welds, points and rolling wheels
// A body entry may be a robot instead: {robot: NAME, name: PREFIX, parent, placement, q, v,
// fixed_joints, tool}, its chain added below `parent` (robots from `robots`, DH or URDF).
void build_bodies(Builder& B, const YAML::Node& root, const std::map<std::string, Robot>& robots);
// Completes the wrench outputs (wrench_outputs.h): every constraint not yet reported becomes a tip,
// every wheel on a jointed parent an axle; `reactions: all | none | [joint, ...]` selects joint reactions.
void build_wrench_outputs(const Ctx& c, const YAML::Node& root, System& sys);

// The YAML entry of a constraint, by name (for errors); the scene's root if it has none of its own.
YAML::Node constraint_node(const YAML::Node& root, const std::string& name);
// Closes the loops of the initial state (Gauss-Newton on the position error, then the velocity
// projected onto the constraints); what moved is appended to `warnings`. The joints of `keep` (per
// body) and of the bodies `held` never move, nor pseudo-joints. Returns false and leaves q0 as it
// was when the constraints cannot be closed (the caller reports the constraint that stays open);
// then *q_closest (if given) is the closest state the solver found. Closing moves no joint beyond
// its limits (System::q_lower, q_upper; one given beyond a limit no further): when only the limits
// keep the constraints open, *beyond (if given) lists the DOFs held at a bound with the value each
// would take without limits (refuse_beyond_limits reports them).
bool close_initial_state(System& sys, const std::vector<unsigned char>& q_given, const std::vector<unsigned char>& keep,
                         std::vector<std::string>* warnings, const std::vector<int>& held = {},
                         Eigen::VectorXd* q_closest = nullptr, std::vector<std::pair<int, double>>* beyond = nullptr);
// A closing the joint limits forbid (`beyond` from close_initial_state, not empty): an error naming
// each binding joint, its limit and where it comes from, at the joint's `q` entry in the scene.
[[noreturn]] void refuse_beyond_limits(const Builder& B, const YAML::Node& root, const Eigen::VectorXd& q_closest,
                                       const std::vector<std::pair<int, double>>& beyond);
// arms + load, after the initial state was closed (q = sys.q0, closed) or not (q = the closest
// state found): an arm whose end-effector misses its grasp is an error at its `grasp` line with the
// miss per axis; a joint the closing moved outside its URDF limits is a warning.
void close_grasps_check(Builder& B, const Eigen::VectorXd& q, bool closed);

}  // namespace coopdyn::scene_detail
