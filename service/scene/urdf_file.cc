#include "service/scene/urdf_file.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <regex>

#include "service/text/input_limits.h"

namespace coopdyn::scene_detail {

namespace bounded = coopdyn::text;

UrdfFile read_urdf(const Ctx& c, const YAML::Node& where, const std::string& path) {
  UrdfFile f;
  f.path = path;
  std::string& xml = f.xml;
  std::string why;
  // bounded before urdfdom sees it: its TinyXML parser recurses per element without a limit
  if (!bounded::read_file(path, bounded::kMaxUrdfBytes, "URDF '" + path + "'", &xml, &why)) fail(c, where, why);
  if (const bounded::DepthExceeded d = bounded::xml_depth_exceeds(xml); d.exceeded)
    fail(c, where, "URDF '" + path + "' line " + std::to_string(d.line) + " column " + std::to_string(d.column) +
                       ": elements nested deeper than " + std::to_string(bounded::kMaxXmlDepth) +
                       " levels (the limit; URDF itself nests 5)");
  if (const size_t x = xml.find("xacro:"); x != std::string::npos)
    fail(c, where, "URDF '" + path + "' line " + std::to_string(line_of(xml, x)) +
                       " is a xacro macro: expand the file first (xacro FILE.urdf.xacro > FILE.urdf)");
  f.model = urdf::parseURDF(xml);
  if (!f.model) fail(c, where, "URDF '" + path + "' could not be parsed (see the urdfdom message above)");
  return f;
}

int line_of(const std::string& text, size_t pos) { return 1 + static_cast<int>(std::count(text.begin(), text.begin() + std::min(pos, text.size()), '\n')); }

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

Transform urdf_pose(const urdf::Pose& p) {
  double x, y, z, w;
  p.rotation.getQuaternion(x, y, z, w);
  return Transform(Quat(w, x, y, z).normalized().toRotationMatrix(), Vec3(p.position.x, p.position.y, p.position.z));
}

// a link's <inertial> in the link frame; a negative mass is an error
Inertia link_inertia(const Ctx& c, const YAML::Node& where, const urdf::Link& l) {
  const auto& in = *l.inertial;
  if (in.mass < 0) fail(c, where, "URDF link '" + l.name + "': negative mass");
  Mat3 Ic;
  Ic << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  const Transform X = urdf_pose(in.origin);
  return Inertia(in.mass, X.p, X.R * Ic * X.R.transpose());
}

// Nothing the file gives is lost silently: an <inertial> urdfdom could not read is an error, a
// moving link without one a warning.
void check_link_inertial(const Ctx& c, const YAML::Node& where, const UrdfFile& f, const urdf::Joint& jt, std::vector<std::string>* warnings) {
  const std::string& xml = f.xml;
  urdf::LinkConstSharedPtr child = f.model->getLink(jt.child_link_name);
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
    fail(c, where, "URDF '" + f.path + "' line " + std::to_string(line_of(xml, xml.find(text))) + ": link '" + child->name +
                       "' has an <inertial> that urdfdom could not read (see its message above: a misspelt attribute?); "
                       "its mass would be lost");
  if (given) return;
  const bool frame_only = jt.type == urdf::Joint::FIXED;  // a flange or tool frame: massless by design
  if (!frame_only)
    warnings->push_back("URDF '" + f.path + "': link '" + child->name + "' (after moving joint '" + jt.name +
                         "') has no <inertial>: it moves no mass");
}

}  // namespace coopdyn::scene_detail
