// The subcommands of coopdyn: the options of each as a typed struct (CLI11 binds every option
// straight into its member, clients/cli/cli.h; a member's initial value is the option's default and
// what --help shows), register_NAME declaring them, cmd_NAME running the command on them.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "clients/control/cooperative_controller.h"

namespace coopdyn::cli {

// Defaults shared by the LCM subcommands (and shown in their --help).
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

// A whole number as typed: the command names the text it rejects (coopdyn sim --every).
struct WholeNumber {
  long value = 0;
  std::string text;
  bool whole = true;  // the text is all one integer (std::stol used all of it)
};

// --scene FILE and --formulation NAME (scene_options in cli.h), read by load_cli_scene.
struct SceneArgs {
  std::optional<std::string> scene, formulation;
};

// --torque PROFILE... and --steer PROFILE..., read by load_cli_profile and load_cli_targets.
struct ProfileArgs {
  std::vector<std::string> torque, steer;
};

struct EvalArgs : SceneArgs {
  std::optional<std::string> state;
  bool hold = false;
};

struct SimArgs : SceneArgs, ProfileArgs {
  double duration = 0, dt = 0;  // required
  std::string integrator = "rk4";
  std::optional<std::string> out;
  WholeNumber every{1, "1"};
  bool progress = false;
  bool hold = false;
};

struct SendArgs : SceneArgs, ProfileArgs {
  std::optional<std::string> states;
  bool joints_only = false;
  std::string others = "hold";  // the joints --torque does not name: the daemon's safe torque, or zero
  double rate = 100;
  std::optional<double> duration;  // 2 s, or with --states the file's time span
  double t0 = 0;
  long long seq = 1;
  std::string lcm_url = kDefaultLcmUrl;
  std::optional<std::string> channel;  // COOPDYN_COMMAND, or with --states COOPDYN_STATE
  std::string output_channel = "COOPDYN_OUTPUT";
  std::optional<std::string> output_url;
  std::string stats_channel = "COOPDYN_STATS";
  bool measure_latency = false, no_check = false, quiet = false;
  bool busy_poll = false;  // the read-back thread polls LCM without sleeping
  std::optional<std::string> key_file;  // sign with the daemon's auth key
};

struct LogArgs : SceneArgs {  // --scene only: a log has no --formulation
  std::string in;             // required
  std::string out;            // empty: the input's path without its extension, then _csv
  bool no_plot = false, progress = false;
  std::string python = "/usr/bin/python3";
};

struct ControlArgs : SceneArgs {
  std::string action;  // required
  std::optional<std::string> state;
  std::string lcm_url = kDefaultLcmUrl;
  std::optional<std::string> output_url;  // --lcm-url
  std::string channel = "COOPDYN_CONTROL";
  std::string output_channel = "COOPDYN_OUTPUT";
  std::optional<long long> seq;  // the wall clock in microseconds
  bool no_wait = false;
  double timeout = 2;  // s
  std::optional<std::string> key_file;
};

struct TrackArgs : SceneArgs {
  double duration = 6;
  TrackOptions control;  // --radius, --period, --squeeze; the rest as the controller's defaults
  std::optional<std::string> out;
  std::string lcm_url = kDefaultLcmUrl;
  std::optional<std::string> output_url;  // --lcm-url
  std::string channel = "COOPDYN_COMMAND";
  std::string output_channel = "COOPDYN_OUTPUT";
  std::optional<std::string> key_file;
};

struct ViewArgs : SceneArgs {
  std::optional<std::string> csv, log;
  bool live = false;
  std::optional<std::string> out;
  std::string channel = "COOPDYN_OUTPUT";
  int max_frames = 2000;
  std::string listen = "127.0.0.1:8765";
  std::string lcm_url = kDefaultLcmUrl;
  double rate = 50;
  int queue = 32;
  std::string three_js = "/usr/share/javascript/three/three.min.js";
  std::vector<std::string> package_path;  // where package://NAME/... meshes are looked for
  bool hold = false;                      // --scene alone: the wrenches with the holding torques
  bool capsules = false;                  // links as capsules, the URDFs' visuals not drawn
};

struct BenchArgs : SceneArgs {
  double min_time = 0.5;
  int repetitions = 15;
  bool json = false;
};

extern const char* const kLcmJar;      // where the build found LCM's Java library (spy.cc)
extern const char* const kJchart2dJar;  // Debian's libjchart2d-java
struct SpyArgs {
  std::string lcm_url = kDefaultLcmUrl;
  std::string types_jar;  // empty: coopdyn_types.jar of the build tree next to bin/, or the installed one
  std::string lcm_jar = kLcmJar;
  std::string jchart2d_jar = kJchart2dJar;
  std::string java;  // empty: $JAVA_HOME/bin/java, else java on PATH
  bool print = false;
};

class Cli;
// register_NAME(Cli&) of every command in commands.def (register_view: clients/view/view.cc)
#define COOPDYN_COMMAND(name, description) void register_##name(Cli& cli);
#include "clients/cli/commands.def"
#undef COOPDYN_COMMAND
int cmd_eval(const EvalArgs& a);
int cmd_sim(const SimArgs& a);
int cmd_send(const SendArgs& a);
int cmd_log(const LogArgs& a);
int cmd_control(const ControlArgs& a);
int cmd_track(const TrackArgs& a);
int cmd_view(const ViewArgs& a);  // clients/view/view.cc
int cmd_bench(const BenchArgs& a);
int cmd_spy(const SpyArgs& a);

}  // namespace coopdyn::cli
