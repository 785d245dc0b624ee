// A URDF's whole tree (every branch: a torso shared by two arms, a base with its wheels), read as
// the chain reader reads its joints: each joint converted by urdf_chain_joint() (robot_chain.h),
// each link's <inertial> checked by check_link_inertial() (urdf_file.h). build_tree.cc places it in
// a `bodies` scene. Internal to the scene compiler.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "service/scene/robot_chain.h"
#include "service/scene/urdf_file.h"

namespace coopdyn::scene_detail {

// A <cylinder> of a link's <collision> or <visual>, in the link frame (its axis is the z axis of X_LG).
struct UrdfCylinder {
  Transform X_LG;
  double radius = 0;
  bool collision = true;  // from <collision> (else <visual>)
};

struct UrdfTreeJoint {
  ChainJoint j;          // the joint and its child link (name, origin in the parent link, axis, inertia, limits, source)
  std::string parent_link;
};

struct UrdfTree {
  std::shared_ptr<const UrdfFile> file;
  std::string root_link;
  Inertia root_inertia;               // the root link's <inertial> (zero when it has none)
  std::vector<UrdfTreeJoint> joints;  // every joint below the root, parents first (depth-first, in the file's order)
  std::map<std::string, std::vector<UrdfCylinder>> cylinders;  // per link: <collision> cylinders, then <visual> ones
  std::string branch_link;            // the first link with two or more children ("" for a chain)
  // The file's own free base: a massless root link (a `world`) whose only joint is floating or
  // planar; root_link is then that joint's child. root_joint "" (none), "floating" or "planar".
  std::string root_joint, root_joint_name, above_root_link;
  Transform X_above_root;                // the joint's origin in the link above
  Vec3 root_normal = Vec3::UnitZ();      // a planar joint's axis (the plane's normal), in the joint frame
};

// Reads the URDF at `path` whole; its errors (the file, an unreadable <inertial>, a joint type the
// scene cannot model) are errors at `where`, its findings (a moving link without mass) warnings.
// name: the robot's name in `robots` (for messages); repair_inertia: every non-PSD inertia repaired.
std::shared_ptr<const UrdfTree> read_urdf_tree(const Ctx& c, const YAML::Node& where, const std::string& path,
                                               std::vector<std::string>* warnings, const std::string& name = "<name>",
                                               bool repair_inertia = false);

// A wheel link's spin axis: the axis of the (moving) URDF joint above it, in the link frame; false
// for the root link and a link on a fixed joint.
bool urdf_spin_axis(const UrdfTree& t, const std::string& link, Vec3* axis);

// The radius of the wheel link's cylinder about `axle` (unit, link frame) through the link origin:
// the first such cylinder of its <collision> elements, else of its <visual> ones. 0 when there is
// none, with the reason in *why.
double urdf_wheel_radius(const UrdfTree& t, const std::string& link, const Vec3& axle, std::string* why);

}  // namespace coopdyn::scene_detail
