// A URDF file as the scene compiler reads it: the bounded text (kept for line numbers and for what
// urdfdom does not report) and urdfdom's model of it. robot_urdf.cc compiles it into a chain.
// Internal to the scene compiler.
#pragma once

#include <urdf_parser/urdf_parser.h>

#include <string>
#include <vector>

#include "service/scene/scene_yaml.h"

namespace coopdyn::scene_detail {

struct UrdfFile {
  std::string path;
  std::string xml;
  urdf::ModelInterfaceSharedPtr model;
};

// Reads and parses `path`; a file too large or nested too deep, a xacro macro and what urdfdom
// cannot parse are errors at `where`.
UrdfFile read_urdf(const Ctx& c, const YAML::Node& where, const std::string& path);

// the line (1-based) of position pos in text
int line_of(const std::string& text, size_t pos);
// The text of the <link name="NAME" ...> element of a URDF, "" if absent (a plain scan: enough to
// tell whether the file gave an <inertial> that urdfdom could not read).
std::string urdf_link_text(const std::string& xml, const std::string& name);

// a urdfdom pose as a Transform
Transform urdf_pose(const urdf::Pose& p);
// a link's <inertial> in the link frame; a negative mass is an error
Inertia link_inertia(const Ctx& c, const YAML::Node& where, const urdf::Link& l);
// Nothing the file gives is lost silently: an <inertial> urdfdom could not read (the child link of
// `jt`) is an error, a moving link without one a warning (into *warnings).
void check_link_inertial(const Ctx& c, const YAML::Node& where, const UrdfFile& f, const urdf::Joint& jt,
                         std::vector<std::string>* warnings);

}  // namespace coopdyn::scene_detail
