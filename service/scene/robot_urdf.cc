// A URDF file (urdf_file.h) compiled into a serial chain: the chain base..tip, each link's inertial
// checked, the links off the chain reported or kept rigidly, each joint converted.
#include <algorithm>
#include <functional>
#include <map>
#include <cmath>
#include <cstdlib>
#include <regex>
#include <set>
#include <sstream>

#include "service/scene/robot_chain.h"
#include "service/scene/urdf_file.h"

namespace coopdyn::scene_detail {

namespace {

// The joints from `base` down to `tip`, in order; an empty base is the root, an empty tip the only
// leaf below base (both filled in).
std::vector<urdf::JointConstSharedPtr> chain_joints(const Ctx& c, const YAML::Node& where, const UrdfFile& f,
                                                    std::string& base, std::string& tip) {
  const urdf::ModelInterfaceSharedPtr& u = f.model;
  if (base.empty()) base = u->getRoot()->name;
  urdf::LinkConstSharedPtr lk = u->getLink(tip.empty() ? base : tip);
  if (!u->getLink(base)) fail(c, where, urdf_at(f) + ": no link '" + base + "'");
  if (tip.empty()) {
    urdf::LinkConstSharedPtr l = u->getLink(base);
    while (l->child_links.size() == 1) l = l->child_links[0];
    if (!l->child_links.empty()) fail(c, where, urdf_at(f) + ": branches below '" + l->name + "': give robots.<name>.tip");
    tip = l->name;
    lk = l;
  }
  if (!lk) fail(c, where, urdf_at(f) + ": no link '" + tip + "'");
  std::vector<urdf::JointConstSharedPtr> chain;
  for (urdf::LinkConstSharedPtr l = lk; l && l->name != base; l = l->getParent()) {
    if (!l->parent_joint) fail(c, where, urdf_at(f) + ": '" + tip + "' is not below '" + base + "'");
    chain.push_back(l->parent_joint);
  }
  std::reverse(chain.begin(), chain.end());
  return chain;
}

// The links off the chain, reported as left out when one of them moves (a finger) or has mass; a
// bare frame is no loss.
void report_left_out_links(const UrdfFile& f, const std::set<std::string>& on_chain, const std::string& base,
                           const std::string& tip, Robot& r) {
  std::string left;
  double mass = 0;
  bool moving = false;
  std::vector<urdf::LinkConstSharedPtr> stack;
  for (const std::string& l : on_chain)
    for (const auto& ch : f.model->getLink(l)->child_links)
      if (!on_chain.count(ch->name)) stack.push_back(ch);
  while (!stack.empty()) {
    urdf::LinkConstSharedPtr l = stack.back();
    stack.pop_back();
    left += (left.empty() ? "" : ", ") + l->name;
    if (l->inertial) mass += l->inertial->mass;
    if (l->parent_joint && l->parent_joint->type != urdf::Joint::FIXED) moving = true;
    for (const auto& ch : l->child_links) stack.push_back(ch);
  }
  if (!left.empty() && (mass > 0 || moving)) {
    std::ostringstream os;
    os << urdf_at(f) << ": links off the chain " << base << " .. " << tip << " are left out: " << left << " ("
       << mass << " kg; robots.<name>.branches: keep adds them rigidly)";
    r.warnings.push_back(os.str());
  }
}

// branches: keep: each side subtree (a gripper's fingers) is added rigidly, its joints at zero, to
// the chain link it hangs from, so its mass and inertia count. Returns chain link -> the side
// subtrees' inertia in its frame.
std::map<std::string, Inertia> keep_side_branches(const Ctx& c, const YAML::Node& where, const UrdfFile& f,
                                                  const std::set<std::string>& on_chain, const std::string& base, Robot& r) {
  std::map<std::string, Inertia> side;
  std::function<void(const urdf::LinkConstSharedPtr&, const Transform&, Inertia&, double&, std::string&)> add;
  add = [&](const urdf::LinkConstSharedPtr& l, const Transform& X_CL, Inertia& acc, double& m, std::string& names) {
    check_urdf_inertial(c, where, f, l->name, &r.warnings);
    if (l->inertial) {
      acc += link_inertia(c, where, *l).transformed(X_CL);
      m += l->inertial->mass;
    }
    names += (names.empty() ? "" : ", ") + l->name;
    for (const auto& ch : l->child_links) add(ch, X_CL * urdf_pose(ch->parent_joint->parent_to_joint_origin_transform), acc, m, names);
  };
  for (const std::string& ln : on_chain)
    for (const auto& ch : f.model->getLink(ln)->child_links) {
      if (on_chain.count(ch->name)) continue;
      Inertia acc;
      double m = 0;
      std::string names;
      add(ch, urdf_pose(ch->parent_joint->parent_to_joint_origin_transform), acc, m, names);
      if (m <= 0) continue;
      side[ln] += acc;
      std::ostringstream os;
      os << urdf_at(f) << ": " << names << " (" << m << " kg) kept rigidly on '" << ln
         << "' with their joints at zero (branches: keep)";
      if (ln == base) os << "; on the base link it is carried by the base and moves nothing";
      r.warnings.push_back(os.str());
    }
  return side;
}

}  // namespace

// One joint of the chain with its child link's inertia (plus the side branches kept on it).
ChainJoint urdf_chain_joint(const Ctx& c, const YAML::Node& where, const UrdfFile& f, const urdf::Joint& jt,
                       const std::map<std::string, Inertia>& side) {
  urdf::LinkConstSharedPtr child = f.model->getLink(jt.child_link_name);
  Inertia I;
  if (child->inertial) I = link_inertia(c, where, *child);
  if (auto it = side.find(child->name); it != side.end()) I += it->second;
  ChainJoint j;
  j.name = jt.name;
  j.link_name = child->name;
  j.X_origin = urdf_pose(jt.parent_to_joint_origin_transform);
  j.axis = Vec3(jt.axis.x, jt.axis.y, jt.axis.z);
  j.I = I;
  switch (jt.type) {
    case urdf::Joint::REVOLUTE:
    case urdf::Joint::CONTINUOUS: break;
    case urdf::Joint::PRISMATIC: j.prismatic = true; break;
    case urdf::Joint::FIXED: j.fixed = true; break;
    default: fail(c, where, "URDF joint '" + jt.name + "': only revolute, continuous, prismatic and fixed joints");
  }
  if (!j.fixed && !(j.axis.norm() > 0)) fail(c, where, "URDF joint '" + jt.name + "': zero axis");
  if (!j.fixed && jt.limits && jt.limits->effort > 0) j.tau_limit = jt.limits->effort;
  // a continuous joint has no position limits; urdfdom leaves lower = upper = 0 when none is given
  if (jt.limits && jt.type != urdf::Joint::CONTINUOUS && !j.fixed && jt.limits->upper > jt.limits->lower) {
    j.lower = jt.limits->lower;
    j.upper = jt.limits->upper;
  }
  size_t at = 0, end = 0;
  j.source = urdf_element(f.xml, "joint", jt.name, &at, &end) ? urdf_at(f, at) : urdf_at(f);
  return j;
}


Robot parse_urdf(const Ctx& c, const YAML::Node& where, const std::string& path, const std::string& name,
                 std::string base, std::string tip, bool keep_branches) {
  const UrdfFile f = read_urdf(c, where, path);
  const std::vector<urdf::JointConstSharedPtr> chain = chain_joints(c, where, f, base, tip);
  Robot r;
  r.name = name;
  r.base_link = base;
  std::set<std::string> on_chain = {base};
  for (const auto& jt : chain) on_chain.insert(jt->child_link_name);
  for (const auto& jt : chain) check_link_inertial(c, where, f, *jt, &r.warnings);
  std::map<std::string, Inertia> side;
  if (keep_branches)
    side = keep_side_branches(c, where, f, on_chain, base, r);
  else
    report_left_out_links(f, on_chain, base, tip, r);
  for (const auto& jt : chain) r.joints.push_back(urdf_chain_joint(c, where, f, *jt, side));
  if (r.joints.empty()) fail(c, where, urdf_at(f) + ": no joints between '" + base + "' and '" + tip + "'");
  return r;
}

}  // namespace coopdyn::scene_detail
