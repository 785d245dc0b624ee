#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <functional>
#include <map>
#include <cmath>
#include <cstdlib>
#include <regex>
#include <set>
#include <sstream>

#include "service/scene/robot_chain.h"
#include "service/text/input_limits.h"

namespace coopdyn::scene_detail {

namespace bounded = coopdyn::text;

namespace {
// The text of the <link name="NAME" ...> element of a URDF, "" if absent (a plain scan: enough to
// tell whether the file gave an <inertial> that urdfdom could not read).
std::string urdf_link_text(const std::string& xml, const std::string& name) {
  for (size_t p = xml.find("<link"); p != std::string::npos; p = xml.find("<link", p + 5)) {
    const size_t end_tag = xml.find('>', p);
    if (end_tag == std::string::npos) break;
    const std::string tag = xml.substr(p, end_tag - p);
    if (tag.find("name=\"" + name + "\"") == std::string::npos && tag.find("name='" + name + "'") == std::string::npos) continue;
    if (xml[end_tag - 1] == '/') return tag;
    const size_t close = xml.find("</link>", end_tag);
    return xml.substr(p, (close == std::string::npos ? xml.size() : close) - p);
  }
  return "";
}
int line_of(const std::string& text, size_t pos) { return 1 + static_cast<int>(std::count(text.begin(), text.begin() + std::min(pos, text.size()), '\n')); }
}  // namespace

Robot parse_urdf(const Ctx& c, const YAML::Node& where, const std::string& path, const std::string& name,
                 std::string base, std::string tip, bool keep_branches) {
  // bounded before urdfdom sees it: its TinyXML parser recurses per element without a limit
  std::string xml, why;
  if (!bounded::read_file(path, bounded::kMaxUrdfBytes, "URDF '" + path + "'", &xml, &why)) fail(c, where, why);
  if (const bounded::DepthExceeded d = bounded::xml_depth_exceeds(xml); d.exceeded)
    fail(c, where, "URDF '" + path + "' line " + std::to_string(d.line) + " column " + std::to_string(d.column) +
                       ": elements nested deeper than " + std::to_string(bounded::kMaxXmlDepth) +
                       " levels (the limit; URDF itself nests 5)");
  if (const size_t x = xml.find("xacro:"); x != std::string::npos)
    fail(c, where, "URDF '" + path + "' line " + std::to_string(line_of(xml, x)) +
                       " is a xacro macro: expand the file first (xacro FILE.urdf.xacro > FILE.urdf)");
  urdf::ModelInterfaceSharedPtr u = urdf::parseURDF(xml);
  if (!u) fail(c, where, "URDF '" + path + "' could not be parsed (see the urdfdom message above)");
  if (base.empty()) base = u->getRoot()->name;
  urdf::LinkConstSharedPtr lk = u->getLink(tip.empty() ? base : tip);
  if (!u->getLink(base)) fail(c, where, "URDF '" + path + "': no link '" + base + "'");
  if (tip.empty()) {
    urdf::LinkConstSharedPtr l = u->getLink(base);
    while (l->child_links.size() == 1) l = l->child_links[0];
    if (!l->child_links.empty()) fail(c, where, "URDF '" + path + "' branches below '" + l->name + "': give robots.<name>.tip");
    tip = l->name;
    lk = l;
  }
  if (!lk) fail(c, where, "URDF '" + path + "': no link '" + tip + "'");
  std::vector<urdf::JointConstSharedPtr> chain;
  for (urdf::LinkConstSharedPtr l = lk; l && l->name != base; l = l->getParent()) {
    if (!l->parent_joint) fail(c, where, "URDF '" + path + "': '" + tip + "' is not below '" + base + "'");
    chain.push_back(l->parent_joint);
  }
  std::reverse(chain.begin(), chain.end());
  auto pose = [](const urdf::Pose& p) {
    double x, y, z, w;
    p.rotation.getQuaternion(x, y, z, w);
    return Transform(Quat(w, x, y, z).normalized().toRotationMatrix(), Vec3(p.position.x, p.position.y, p.position.z));
  };
  Robot r;
  r.name = name;
  r.base_link = base;
  // nothing the file gives is lost silently: an <inertial> urdfdom could not read is an error, a
  // link without one and the links off the chain base..tip are reported
  std::set<std::string> on_chain = {base};
  for (const auto& jt : chain) on_chain.insert(jt->child_link_name);
  for (const auto& jt : chain) {
    urdf::LinkConstSharedPtr child = u->getLink(jt->child_link_name);
    const std::string text = urdf_link_text(xml, child->name);
    const bool given = text.find("<inertial") != std::string::npos;
    // urdfdom logs a malformed <inertial> (a misspelt attribute) and goes on with a zero mass: read
    // the <mass value=...> ourselves and require the two to agree
    static const std::regex mass_re("<mass\\s+value\\s*=\\s*[\"']([^\"']*)[\"']");
    std::smatch mm;
    const bool read = given && child->inertial && std::regex_search(text, mm, mass_re) &&
                      std::abs(std::strtod(mm[1].str().c_str(), nullptr) - child->inertial->mass) <=
                          1e-12 * std::max(1.0, std::abs(child->inertial->mass));
    if (given && !read)
      fail(c, where, "URDF '" + path + "' line " + std::to_string(line_of(xml, xml.find(text))) + ": link '" + child->name +
                         "' has an <inertial> that urdfdom could not read (see its message above: a misspelt attribute?); "
                         "its mass would be lost");
    if (given) continue;
    const bool frame_only = jt->type == urdf::Joint::FIXED;  // a flange or tool frame: massless by design
    if (!frame_only)
      r.warnings.push_back("URDF '" + path + "': link '" + child->name + "' (after moving joint '" + jt->name +
                           "') has no <inertial>: it moves no mass");
  }
  {
    std::string left;
    double mass = 0;
    bool moving = false;  // a left-out link that moves (a finger) or has mass is a loss; a bare frame is not
    std::vector<urdf::LinkConstSharedPtr> stack;
    for (const std::string& l : on_chain)
      for (const auto& ch : u->getLink(l)->child_links)
        if (!on_chain.count(ch->name)) stack.push_back(ch);
    while (!stack.empty()) {
      urdf::LinkConstSharedPtr l = stack.back();
      stack.pop_back();
      left += (left.empty() ? "" : ", ") + l->name;
      if (l->inertial) mass += l->inertial->mass;
      if (l->parent_joint && l->parent_joint->type != urdf::Joint::FIXED) moving = true;
      for (const auto& ch : l->child_links) stack.push_back(ch);
    }
    if (!left.empty() && (mass > 0 || moving) && !keep_branches) {
      std::ostringstream os;
      os << "URDF '" << path << "': links off the chain " << base << " .. " << tip << " are left out: " << left << " ("
         << mass << " kg; robots.<name>.branches: keep adds them rigidly)";
      r.warnings.push_back(os.str());
    }
  }
  // branches: keep: each side subtree (a gripper's fingers) is added rigidly, its joints at zero,
  // to the chain link it hangs from, so its mass and inertia count
  std::map<std::string, Inertia> side;  // chain link -> the side subtrees' inertia in its frame
  if (keep_branches) {
    std::function<void(const urdf::LinkConstSharedPtr&, const Transform&, Inertia&, double&, std::string&)> add;
    add = [&](const urdf::LinkConstSharedPtr& l, const Transform& X_CL, Inertia& acc, double& m, std::string& names) {
      if (l->inertial) {
        const auto& in = *l->inertial;
        if (in.mass < 0) fail(c, where, "URDF link '" + l->name + "': negative mass");
        Mat3 Ic;
        Ic << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
        const Transform X = pose(in.origin);
        acc += Inertia(in.mass, X.p, X.R * Ic * X.R.transpose()).transformed(X_CL);
        m += in.mass;
      }
      names += (names.empty() ? "" : ", ") + l->name;
      for (const auto& ch : l->child_links) add(ch, X_CL * pose(ch->parent_joint->parent_to_joint_origin_transform), acc, m, names);
    };
    for (const std::string& ln : on_chain)
      for (const auto& ch : u->getLink(ln)->child_links) {
        if (on_chain.count(ch->name)) continue;
        Inertia acc;
        double m = 0;
        std::string names;
        add(ch, pose(ch->parent_joint->parent_to_joint_origin_transform), acc, m, names);
        if (m <= 0) continue;
        side[ln] += acc;
        std::ostringstream os;
        os << "URDF '" << path << "': " << names << " (" << m << " kg) kept rigidly on '" << ln
           << "' with their joints at zero (branches: keep)";
        if (ln == base) os << "; on the base link it is carried by the base and moves nothing";
        r.warnings.push_back(os.str());
      }
  }
  for (const auto& jt : chain) {
    urdf::LinkConstSharedPtr child = u->getLink(jt->child_link_name);
    Inertia I;
    if (child->inertial) {
      const auto& in = *child->inertial;
      if (in.mass < 0) fail(c, where, "URDF link '" + child->name + "': negative mass");
      Mat3 Ic;
      Ic << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
      const Transform X = pose(in.origin);
      I = Inertia(in.mass, X.p, X.R * Ic * X.R.transpose());
    }
    if (auto it = side.find(child->name); it != side.end()) I += it->second;
    ChainJoint j;
    j.name = jt->name;
    j.link_name = child->name;
    j.X_origin = pose(jt->parent_to_joint_origin_transform);
    j.axis = Vec3(jt->axis.x, jt->axis.y, jt->axis.z);
    j.I = I;
    switch (jt->type) {
      case urdf::Joint::REVOLUTE:
      case urdf::Joint::CONTINUOUS: break;
      case urdf::Joint::PRISMATIC: j.prismatic = true; break;
      case urdf::Joint::FIXED: j.fixed = true; break;
      default: fail(c, where, "URDF joint '" + jt->name + "': only revolute, continuous, prismatic and fixed joints");
    }
    if (!j.fixed && !(j.axis.norm() > 0)) fail(c, where, "URDF joint '" + jt->name + "': zero axis");
    if (!j.fixed && jt->limits && jt->limits->effort > 0) j.tau_limit = jt->limits->effort;
    // a continuous joint has no position limits; urdfdom leaves lower = upper = 0 when none is given
    if (jt->limits && jt->type != urdf::Joint::CONTINUOUS && !j.fixed && jt->limits->upper > jt->limits->lower) {
      j.lower = jt->limits->lower;
      j.upper = jt->limits->upper;
    }
    {
      const size_t at = xml.find("name=\"" + jt->name + "\"");
      j.source = "URDF '" + path + "'" + (at == std::string::npos ? "" : " line " + std::to_string(line_of(xml, at)));
    }
    r.joints.push_back(j);
  }
  if (r.joints.empty()) fail(c, where, "URDF '" + path + "': no joints between '" + base + "' and '" + tip + "'");
  return r;
}

}  // namespace coopdyn::scene_detail
