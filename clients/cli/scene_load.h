// The scene and state files given on the command line (--scene, --formulation, --state).
#pragma once

#include <string>

#include <Eigen/Core>

#include "clients/cli/commands.h"
#include "service/dynamics/holding_torque.h"
#include "service/dynamics/system.h"

namespace coopdyn::cli {

// Loads --scene (with an optional --formulation override) for subcommand `cmd`; prints the reason
// and returns the exit status (2 usage, 1 scene error) on failure, 0 on success.
int load_cli_scene(const SceneArgs& a, const char* cmd, System* sys);
// Reads q, v, tau (each optional) from a JSON or YAML state file, each a list in the scene's
// coordinate order (coordinates.q / coordinates.v of coopdyn eval) or an object by coordinate name
// ({"arm1.q1": 0.3}: the coordinates not named keep their value); prints the problem and returns
// false on a bad file.
bool read_state(const std::string& path, const System& sys, Eigen::VectorXd& q, Eigen::VectorXd& v, Eigen::VectorXd& tau);
// --hold: the holding torques at (q, v) as coopdynd's safe torque `hold` applies them (holding_torque.h,
// clamped to each joint's torque limit; without the daemon's damping term) into th. While *said is
// false, what they cannot do is said on stderr and *said set: the joints clamped (torque needed and
// limit), a residual above 1e-6 N*m or N. False (printed) on an invalid state.
bool holding_torques(const char* cmd, const System& sys, HoldWorkspace& hw, const Eigen::VectorXd& q,
                     const Eigen::VectorXd& v, Eigen::VectorXd& th, bool* said);

}  // namespace coopdyn::cli
