// coopdynd's command line, its config and scene, and its log: everything a start needs before the
// loop exists. Every problem the user can cause stops here with a message naming the file and place.
#pragma once

#include <string>

#include "service/dynamics/system.h"
#include "service/runtime/config.h"

namespace coopdyn::daemon {

// The command line, as given (coopdynd --help lists the options).
struct Options {
  std::string scene_path, config_path, url_override, mode_override, trigger_override;
  double rate_override = 0;  // Hz; 0: the config's rate_hz
  double duration = -1;      // s; < 0: until SIGINT or SIGTERM
};

// parse: argv -> Options. Returns -1 to go on, else the exit code (0 after --help or --version, 2
// for a bad option).
int parse_args(int argc, char** argv, Options* o);

// load: the config (with the command line's overrides) and the scene. Every problem stops here,
// with a clear message; returns -1 to go on, else the exit code.
int load(const Options& o, coopdyn::runtime::ServiceConfig* cfg_out, coopdyn::System* sys_out);

// logging: asynchronous, never called from the loop thread
void start_logging(const coopdyn::runtime::ServiceConfig& cfg);

}  // namespace coopdyn::daemon
