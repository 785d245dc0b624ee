// A URDF file (urdf_file.h) read whole: every link below the root, parents first, each joint
// converted and each link checked as the chain reader does (robot_urdf.cc), and the cylinders a
// wheel's radius is read from.
#include "service/scene/urdf_tree.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace coopdyn::scene_detail {

namespace {

// the cylinders of a link's <collision>, then <visual>, elements
std::vector<UrdfCylinder> link_cylinders(const urdf::Link& l) {
  std::vector<UrdfCylinder> out;
  auto add = [&](const urdf::GeometrySharedPtr& g, const urdf::Pose& origin, bool collision) {
    if (!g || g->type != urdf::Geometry::CYLINDER) return;
    const auto* cy = dynamic_cast<const urdf::Cylinder*>(g.get());
    if (!cy) return;
    UrdfCylinder c;
    c.X_LG = urdf_pose(origin);
    c.radius = cy->radius;
    c.collision = collision;
    out.push_back(c);
  };
  for (const auto& k : l.collision_array)
    if (k) add(k->geometry, k->origin, true);
  for (const auto& v : l.visual_array)
    if (v) add(v->geometry, v->origin, false);
  return out;
}

}  // namespace

std::shared_ptr<const UrdfTree> read_urdf_tree(const Ctx& c, const YAML::Node& where, const std::string& path,
                                               std::vector<std::string>* warnings, const std::string& name,
                                               bool repair_inertia) {
  auto t = std::make_shared<UrdfTree>();
  auto file = std::make_shared<UrdfFile>(read_urdf(c, where, path, repair_inertia, "robots." + name + ".repair_inertia: true"));
  t->file = file;
  const UrdfFile& f = *file;
  urdf::LinkConstSharedPtr root = f.model->getRoot();
  if (root->child_links.size() == 1 && !(root->inertial && root->inertial->mass > 0) && root->child_links[0]->parent_joint &&
      (root->child_links[0]->parent_joint->type == urdf::Joint::FLOATING ||
       root->child_links[0]->parent_joint->type == urdf::Joint::PLANAR)) {  // the file's own free base
    const urdf::Joint& jt = *root->child_links[0]->parent_joint;
    t->root_joint = jt.type == urdf::Joint::FLOATING ? "floating" : "planar";
    t->root_joint_name = jt.name;
    t->above_root_link = root->name;
    t->X_above_root = urdf_pose(jt.parent_to_joint_origin_transform);
    const Vec3 n(jt.axis.x, jt.axis.y, jt.axis.z);
    if (jt.type == urdf::Joint::PLANAR && !(n.norm() > 0)) fail(c, where, urdf_at(f) + ": planar joint '" + jt.name + "': zero axis");
    if (jt.type == urdf::Joint::PLANAR) t->root_normal = n.normalized();
    root = root->child_links[0];
  }
  t->root_link = root->name;
  {  // the root link's <inertial> read as every other link's (a joint of type fixed: no warning without one)
    urdf::Joint above;
    above.type = urdf::Joint::FIXED;
    above.child_link_name = root->name;
    check_link_inertial(c, where, f, above, warnings);
  }
  if (root->inertial) t->root_inertia = link_inertia(c, where, *root);
  std::vector<urdf::LinkConstSharedPtr> stack;  // not {root}: GCC 12 warns (-Wfree-nonheap-object) on that form
  stack.push_back(root);
  while (!stack.empty()) {
    const urdf::LinkConstSharedPtr l = stack.back();
    stack.pop_back();
    t->cylinders[l->name] = link_cylinders(*l);
    if (l->child_links.size() > 1 && t->branch_link.empty()) t->branch_link = l->name;
    if (l != root) {
      const urdf::Joint& jt = *l->parent_joint;
      check_link_inertial(c, where, f, jt, warnings);
      t->joints.push_back({urdf_chain_joint(c, where, f, jt, {}), jt.parent_link_name});
    }
    std::vector<urdf::LinkConstSharedPtr> kids(l->child_links.begin(), l->child_links.end());
    std::vector<size_t> at;
    for (const auto& k : kids) {  // the children in the file's order (urdfdom's is by joint name)
      const auto p = f.joint_at.find(k->parent_joint->name);
      at.push_back(p == f.joint_at.end() ? f.xml.size() : p->second.first);
    }
    std::vector<size_t> order(kids.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return at[a] < at[b]; });
    for (auto it = order.rbegin(); it != order.rend(); ++it) stack.push_back(kids[*it]);  // the first child on top
  }
  return t;
}

bool urdf_spin_axis(const UrdfTree& t, const std::string& link, Vec3* axis) {
  for (const UrdfTreeJoint& tj : t.joints)
    if (tj.j.link_name == link) {
      if (tj.j.fixed) return false;
      *axis = tj.j.axis.normalized();
      return true;
    }
  return false;
}

double urdf_wheel_radius(const UrdfTree& t, const std::string& link, const Vec3& axle, std::string* why) {
  const auto it = t.cylinders.find(link);
  const std::string where = "URDF " + t.file->path + ": link '" + link + "'";
  if (it == t.cylinders.end() || it->second.empty()) {
    *why = where + " has no <cylinder> in its <collision> or <visual>";
    return 0;
  }
  for (const UrdfCylinder& cy : it->second) {
    // the cylinder's axis along the spin axis (to 1e-3 rad: files write pi/2 as 1.5708), its centre
    // on the axle through the link origin (to 1e-3 of its radius): the wheel the constraint rolls
    const Vec3 z = cy.X_LG.R.col(2);
    const Vec3 off = cy.X_LG.p - axle * axle.dot(cy.X_LG.p);
    if (z.cross(axle).norm() <= 1e-3 && off.norm() <= 1e-3 * cy.radius && cy.radius > 0) return cy.radius;
  }
  std::ostringstream os;
  os << where << " has no <cylinder> about its spin axis [" << axle.x() << ", " << axle.y() << ", " << axle.z()
     << "] through its origin (" << it->second.size() << " cylinder" << (it->second.size() == 1 ? "" : "s")
     << " elsewhere)";
  *why = os.str();
  return 0;
}

}  // namespace coopdyn::scene_detail
