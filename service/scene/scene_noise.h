// The scene key `noise`: the declared standard deviation of the actuated joints' torques (System::
// tau_noise), propagated into every wrench's sigma (wrench_sigma.h). Internal to the scene compiler.
#pragma once

#include "service/dynamics/system.h"
#include "service/scene/scene_yaml.h"

namespace coopdyn::scene_detail {

// `noise: {tau: S, joints: {NAME: S_NAME, ...}}` after the tree is built (velocity names and torque
// limits known): S (N m or N) on every actuated DOF, NAME (a velocity name, e.g. arm1.q3) overriding
// its own. Refused at its line: a negative or non-finite value, an unknown or unactuated joint.
// Absent: tau_noise is all zero (no sigma is computed).
void read_noise(const Ctx& c, const YAML::Node& root, System& sys);

// `friction: {rest_speed: S}`: the speed (rad/s or m/s) at or below which a Coulomb friction joint is
// at rest (System::rest_speed; absent: System::kDefaultRestSpeed). Refused at its line: a negative or
// non-finite value, another key, not a mapping.
void read_friction_settings(const Ctx& c, const YAML::Node& root, System& sys);

}  // namespace coopdyn::scene_detail
