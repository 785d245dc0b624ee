// Reading scene YAML: typed getters that fail with "file:line:col: reason" (SceneError), and the
// bounded loading of YAML files (size, nesting). Internal to the scene compiler.
#pragma once

#include <array>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include "service/model/model.h"
#include "service/scene/scene.h"

namespace coopdyn::scene_detail {

struct Ctx {
  std::string file;
  std::string dir;
  std::vector<std::string>* warnings = nullptr;  // System::warnings: plausibility findings land here
};

[[noreturn]] void fail(const Ctx& c, const YAML::Node& n, const std::string& msg);
// "file:line:col: msg" appended to the scene's warnings (printed by coopdyn, logged by coopdynd)
void warn(const Ctx& c, const YAML::Node& n, const std::string& msg);
// every key of the mapping n is one of `allowed`, none twice
void check_keys(const Ctx& c, const YAML::Node& n, std::initializer_list<const char*> allowed, const std::string& what);
YAML::Node require(const Ctx& c, const YAML::Node& n, const char* key, const std::string& what);
double as_double(const Ctx& c, const YAML::Node& n, const std::string& what);  // finite; pi, -pi, pi/2, -pi/2
double get_double(const Ctx& c, const YAML::Node& n, const char* key, double def, const std::string& what);
// A joint's `damping` (N*m*s/rad or N*s/m) or `friction` (Coulomb bound, N*m or N): 0 when absent,
// refused at its line unless a finite number >= 0.
double get_joint_loss(const Ctx& c, const YAML::Node& n, const char* key, const std::string& what);
std::string get_string(const Ctx& c, const YAML::Node& n, const char* key, const std::string& def);
bool get_bool(const Ctx& c, const YAML::Node& n, const char* key, bool def);
std::vector<double> as_list(const Ctx& c, const YAML::Node& n, int expect, const std::string& what);  // expect < 0: any length
Vec3 as_vec3(const Ctx& c, const YAML::Node& n, const std::string& what);
// A pose {xyz, and one of rpy | quat | R}; absent = identity. rpy: [roll, pitch, yaw] rad, R = Rz(yaw)
// Ry(pitch) Rx(roll); quat: [w, x, y, z] (scalar first, norm within 1e-6 of 1); R: the rotation matrix
// as three rows (orthonormal to 1e-6, det +1). Angles beyond 2 pi are an error (degrees?), lengths
// beyond 1 km a warning (millimetres?).
Transform get_pose(const Ctx& c, const YAML::Node& n, const std::string& what);
// the same pose fields read from a mapping that has other keys too (frames: name, body, xyz, rpy)
Transform read_pose_fields(const Ctx& c, const YAML::Node& n, const std::string& what);
// an angle in radians: beyond 2 pi in magnitude is an error naming degrees (no angle needs it)
double as_angle(const Ctx& c, const YAML::Node& n, const std::string& what);
// a length in metres: beyond 1 km in magnitude a warning naming millimetres
double as_length(const Ctx& c, const YAML::Node& n, const std::string& what);
// mass, com, inertia [ixx, iyy, izz, ixy, iyz, ixz] about the centre of mass. Negative mass or an
// inertia that is not positive semi-definite is an error; one that breaks the triangle inequality
// (no rigid body has it) or a mass above 1e5 kg is a warning (see plausibility_warnings).
Inertia get_inertia(const Ctx& c, const YAML::Node& n, const std::string& what);
// the warnings of an inertia the scene or a URDF gives (mass above 1e5 kg; principal moments that
// break the triangle inequality, except a rotor-only model with one nonzero moment); "" when none
std::string inertia_plausibility(double mass, const Mat3& I_com);
// whether a symmetric inertia tensor is positive semi-definite (to 1e-12 of its largest eigenvalue
// magnitude, at least 1e-12 kg m^2): what M needs, an error when a scene or a URDF breaks it
bool inertia_psd(const Mat3& I_com);
std::array<bool, 6> get_axes(const Ctx& c, const YAML::Node& n, const std::string& what);  // absent = all six
std::array<double, 6> get_compliance(const Ctx& c, const YAML::Node& n, const std::string& what);  // scalar or 6

// Bounded before yaml-cpp sees it (size, nesting pre-scan): its parser recurses per level.
void check_yaml_text(const std::string& text, const std::string& file);
YAML::Node load_yaml_file(const Ctx& c, const std::string& path, const YAML::Node& where);

}  // namespace coopdyn::scene_detail
