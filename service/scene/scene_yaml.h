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
};

[[noreturn]] void fail(const Ctx& c, const YAML::Node& n, const std::string& msg);
// every key of the mapping n is one of `allowed`, none twice
void check_keys(const Ctx& c, const YAML::Node& n, std::initializer_list<const char*> allowed, const std::string& what);
YAML::Node require(const Ctx& c, const YAML::Node& n, const char* key, const std::string& what);
double as_double(const Ctx& c, const YAML::Node& n, const std::string& what);  // finite; pi, -pi, pi/2, -pi/2
double get_double(const Ctx& c, const YAML::Node& n, const char* key, double def, const std::string& what);
std::string get_string(const Ctx& c, const YAML::Node& n, const char* key, const std::string& def);
bool get_bool(const Ctx& c, const YAML::Node& n, const char* key, bool def);
std::vector<double> as_list(const Ctx& c, const YAML::Node& n, int expect, const std::string& what);  // expect < 0: any length
Vec3 as_vec3(const Ctx& c, const YAML::Node& n, const std::string& what);
Transform get_pose(const Ctx& c, const YAML::Node& n, const std::string& what);  // {xyz, rpy}; absent = identity
// mass, com, inertia [ixx, iyy, izz, ixy, iyz, ixz] about the centre of mass
Inertia get_inertia(const Ctx& c, const YAML::Node& n, const std::string& what);
std::array<bool, 6> get_axes(const Ctx& c, const YAML::Node& n, const std::string& what);  // absent = all six
std::array<double, 6> get_compliance(const Ctx& c, const YAML::Node& n, const std::string& what);  // scalar or 6

// Bounded before yaml-cpp sees it (size, nesting pre-scan): its parser recurses per level.
void check_yaml_text(const std::string& text, const std::string& file);
YAML::Node load_yaml_file(const Ctx& c, const std::string& path, const YAML::Node& where);

}  // namespace coopdyn::scene_detail
