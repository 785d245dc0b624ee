// Serial robots as joint chains: standard DH (robot_dh.cc) and URDF (robot_urdf.cc) both compile to
// one chain that every formulation builds its tree from. Internal to the scene compiler.
#pragma once

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "service/scene/scene_yaml.h"
#include "service/scene/urdf_file.h"

namespace coopdyn::scene_detail {

struct UrdfTree;  // urdf_tree.h

// A serial robot as a chain of joints, URDF-style: joint i sits at X_origin (its frame in the
// previous link's frame, the robot base for i = 1), moves about `axis` (in the joint frame), and
// link i's frame is the joint frame after the motion. Standard DH and URDF both compile to this.
struct ChainJoint {
  std::string name;       // coordinate name suffix (DH: qK; URDF: the joint's name)
  std::string link_name;  // the child link (DH: linkK; URDF: the link's name)
  Transform X_origin;
  Vec3 axis = Vec3::UnitZ();
  bool prismatic = false;
  bool fixed = false;  // a fixed joint of the robot itself (URDF "fixed")
  Inertia I;           // link i, in link i's frame
  double armature = 0;
  double damping = 0, friction = 0;  // joint losses (Joint::damping, Joint::friction)
  double tau_limit = std::numeric_limits<double>::infinity();
  double lower = -std::numeric_limits<double>::infinity();  // joint limits (URDF <limit lower upper>)
  double upper = std::numeric_limits<double>::infinity();
  double v_limit = std::numeric_limits<double>::infinity();  // |v| allowed (URDF <limit velocity>), rad/s or m/s
  std::string source;  // where the joint was declared ("URDF PATH:LINE"), for messages
};
struct Robot {
  std::string name;
  std::vector<std::string> warnings;  // what the scene leaves out or finds missing (never silent)
  std::vector<ChainJoint> joints;
  Transform X_last_EE;  // the end-effector frame in the last link's frame
  std::string base_link = "link0";
  // the URDF's <mimic>s between joints of the chain (URDF joint names): each placement of the robot
  // couples its joints (add_joint_couplings, names prefixed with the arm's or body's name)
  std::vector<UrdfMimic> mimics;
  // A URDF declared without base and tip in a `bodies` scene: its whole tree (urdf_tree.h), placed by
  // a robot entry of `bodies` (joints then empty: there is no chain).
  std::shared_ptr<const UrdfTree> tree;
};

// the joint's motion X_JB(q): rotation about, or translation along, its axis
Transform chain_motion(const ChainJoint& j, double q);

// A robot given in the scene (or a robot file) as standard DH links.
Robot parse_robot(const Ctx& c, const YAML::Node& n, const std::string& name);

// One URDF joint as a ChainJoint with its child link's inertia (plus `side`: rigid subtrees kept on
// the child link, by link name): type, axis, effort and position limits, and its source line.
ChainJoint urdf_chain_joint(const Ctx& c, const YAML::Node& where, const UrdfFile& f, const urdf::Joint& jt,
                            const std::map<std::string, Inertia>& side);

// Joint couplings q_j = m q_i + o (URDF <mimic>s; ConstraintKind::kCouple) appended to cs, one per
// entry of `couplings`, whose joint and mimicked are the model's joint names (Joint::name, e.g.
// "arm1.finger_2"). Errors at `where`, naming each entry's source: a joint absent from the model
// or not a one-DOF moving joint (a fixed joint, one held by fixed_joints), a joint coupled twice,
// a joint that mimics itself or a loop of mimics (j follows i follows j).
void add_joint_couplings(const Ctx& c, const YAML::Node& where, const Model& model, const std::vector<UrdfMimic>& couplings,
                         ConstraintSet& cs);
// the robot's mimics with their joints named as placed: prefix + "." + the URDF joint name
std::vector<UrdfMimic> placed_mimics(const Robot& r, const std::string& prefix);

// A serial chain from a URDF file (urdfdom): from `base` link to `tip` link (defaults: the root and
// its only leaf). Revolute/continuous and prismatic joints move; fixed joints stay fixed. Nothing
// the file gives is lost silently: an unreadable <inertial> is an error with the URDF's line, a
// moving link without one and the links off the chain are warnings (Robot::warnings).
// keep_branches: the links off the chain are added rigidly (joints at zero; a joint that mimics
// another at m * 0 + o, following its chain of mimics) to the chain link they hang from, instead of
// reported as left out. A <mimic> between chain joints is kept in Robot::mimics; one that couples
// a chain joint with a joint off the chain, or mimics a fixed joint, is an error.
// repair_inertia: every non-PSD <inertia> repaired (urdf_file.h), not only a tiny one.
Robot parse_urdf(const Ctx& c, const YAML::Node& where, const std::string& path, const std::string& name,
                 std::string base, std::string tip, bool keep_branches, bool repair_inertia = false);

}  // namespace coopdyn::scene_detail
