// Scene files (YAML) -> System. See config/scenes/README.md for the format.
//
// A scene declares only what the system has; the loader builds exactly that: no platform unless
// the scene has a load carried by arms in the mobile-platform form, no pseudo-joint locks unless it
// declares pseudo-joints, no stabilization unless it asks, no SVD workspace unless it selects the
// baseline. Every error names the file, the line and the reason (SceneError::what()).
#pragma once

#include <optional>
#include <stdexcept>
#include <string>

#include "service/dynamics/system.h"

namespace coopdyn {

class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SceneOverrides {
  std::optional<Formulation> formulation;  // replaces the scene's `formulation`
};

// Loads and compiles a scene. Throws SceneError with "file:line:col: reason" on any problem:
// missing file, YAML syntax, unknown keys or joints, negative masses, an initial state that does
// not close the constraints.
System load_scene(const std::string& path, const SceneOverrides& ov = {});
System load_scene_string(const std::string& yaml_text, const std::string& name_for_errors,
                         const SceneOverrides& ov = {});

}  // namespace coopdyn
