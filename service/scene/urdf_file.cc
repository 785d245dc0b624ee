#include "service/scene/urdf_file.h"

#include <algorithm>

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

}  // namespace coopdyn::scene_detail
