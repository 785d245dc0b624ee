// A URDF file as the scene compiler reads it: the bounded text (kept for line numbers and for what
// urdfdom does not report) and urdfdom's model of it. robot_urdf.cc compiles it into a chain.
// Internal to the scene compiler.
//
// Messages name the file in the compiler form "URDF PATH:LINE: reason", the path unquoted and whole
// (text::cut_values shortens quoted values only), so it can be copied.
#pragma once

#include <urdf_parser/urdf_parser.h>

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "service/scene/scene_yaml.h"

namespace coopdyn::scene_detail {

struct UrdfFile {
  std::string path;
  std::string xml;
  urdf::ModelInterfaceSharedPtr model;
  // where each <link> and <joint> element (children of <robot>, outside comments) is in xml:
  // name -> [begin, end), filled by read_urdf (one scan, so lookups stay linear in the file)
  std::map<std::string, std::pair<size_t, size_t>> link_at, joint_at;
  // A non-positive-semi-definite <inertia> whose most negative eigenvalue is within repair_limit
  // (kg*m^2) is replaced by the nearest positive semi-definite tensor (check_urdf_inertial), with a
  // warning; beyond it, an error naming repair_option. read_urdf sets the limit to
  // kInertiaRepairTolerance times the file's total mass times its size squared (the largest
  // distance of a link frame from the root link's frame, every joint at zero), or to infinity.
  double repair_limit = 0;
  std::string repair_option;
};

// the tolerance of a tiny non-PSD inertia, relative to the robot's mass times its size squared
constexpr double kInertiaRepairTolerance = 1e-6;

// Reads and parses `path` (repair_any: every non-PSD inertia is repaired, repair_option names the
// scene's key that asks for it); a file too large or nested too deep, a xacro macro (an element or an
// attribute in the xacro namespace outside comments and CDATA), what urdfdom cannot parse and a
// <mimic> element it would misread are errors at `where`.
UrdfFile read_urdf(const Ctx& c, const YAML::Node& where, const std::string& path, bool repair_any = false,
                   const std::string& repair_option = "robots.<name>.repair_inertia: true");

// the line (1-based) of position pos in text
int line_of(const std::string& text, size_t pos);
// "URDF PATH" and, with a position in the file's text, "URDF PATH:LINE" (for messages)
std::string urdf_at(const UrdfFile& f);
std::string urdf_at(const UrdfFile& f, size_t pos);

// Where the element <kind name="NAME" ...> (kind "link" or "joint", outside comments) is in the
// text: [*begin, *end) holds it whole; false if absent.
bool urdf_element(const std::string& xml, const std::string& kind, const std::string& name, size_t* begin, size_t* end);
// the same from read_urdf's index (UrdfFile::link_at, joint_at): kind "link" or "joint"
bool urdf_element(const UrdfFile& f, const std::string& kind, const std::string& name, size_t* begin, size_t* end);
// The text of the <link name="NAME" ...> element of a URDF (outside comments), "" if absent.
std::string urdf_link_text(const std::string& xml, const std::string& name);

// a urdfdom pose as a Transform
Transform urdf_pose(const urdf::Pose& p);
// a link's <inertial> in the link frame; a negative mass is an error
Inertia link_inertia(const Ctx& c, const YAML::Node& where, const urdf::Link& l);
// The <inertial> of link `link` read from the text and checked: an element or attribute urdfdom
// cannot read (a misspelt or missing <mass>, <inertia> or one of its six moments, a value that is not
// a number), numbers that urdfdom read otherwise, and an inertia that is not positive semi-definite
// beyond f.repair_limit are errors naming the file, line and link; within it the tensor is repaired
// (urdfdom's model holds the repaired one; one warning). A triangle-inequality violation or a mass
// above 1e5 kg is a warning (into *warnings). Returns whether the link has an <inertial>. Called
// once per link.
bool check_urdf_inertial(const Ctx& c, const YAML::Node& where, const UrdfFile& f, const std::string& link,
                         std::vector<std::string>* warnings);
// Nothing the file gives is lost silently: the child link of `jt` checked (check_urdf_inertial), a
// moving link without an <inertial> a warning (into *warnings).
void check_link_inertial(const Ctx& c, const YAML::Node& where, const UrdfFile& f, const urdf::Joint& jt,
                         std::vector<std::string>* warnings);

// A <mimic> of the file: joint `joint` follows q_joint = multiplier * q_mimicked + offset.
struct UrdfMimic {
  std::string joint, mimicked;
  double multiplier = 1, offset = 0;
  std::string source;  // "URDF PATH:LINE" of the <mimic> element
};
// Every <mimic> of the file, in file order (read_urdf has checked each element: an attribute urdfdom
// ignores, a misspelt multiplier that would be 1, or a value that is not a number is an error there).
std::vector<UrdfMimic> read_mimics(const UrdfFile& f);

}  // namespace coopdyn::scene_detail
