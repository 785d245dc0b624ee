// What a scene declares before its tree: its settings (the solver's options) and its robots.
// Internal to the scene compiler.
#pragma once

#include <map>
#include <string>

#include "service/dynamics/system.h"
#include "service/scene/robot_chain.h"
#include "service/scene/scene.h"
#include "service/scene/scene_yaml.h"

namespace coopdyn::scene_detail {

// Both read root through a non-const handle (YAML::Node shares its data): an absent key looked up
// there reads back later as an undefined node rather than an invalid one, as the passes expect.
// `name`, `gravity`, `formulation` (ov.formulation replaces it), `redundancy`, `stabilization` and
// `solver` into sys.
void read_settings(const Ctx& c, YAML::Node root, const SceneOverrides& ov, System& sys);

// `robots`: each a URDF file, a robot file or standard DH links in the scene (robot_chain.h); in a
// scene without `arms` a URDF declared without base and tip is read whole (Robot::tree).
std::map<std::string, Robot> read_robots(const Ctx& c, YAML::Node root);

}  // namespace coopdyn::scene_detail
