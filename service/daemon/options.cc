#include "service/daemon/options.h"

#include <spdlog/async.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>

#include "service/io/transport/auth.h"
#include "service/runtime/config.h"
#include "service/scene/scene.h"
#include "service/version.h"

namespace coopdyn::daemon {

namespace {

bool parse_double(const char* s, double* out) {
  char* end = nullptr;
  *out = std::strtod(s, &end);
  return end && *end == 0 && end != s && std::isfinite(*out);
}

}  // namespace

int parse_args(int argc, char** argv, Options* o) {
  using namespace coopdyn;
  std::string rate_arg, duration_arg;
  const runtime::ServiceConfig def;
  CLI::App app{"coopdynd " COOPDYN_VERSION
               ": the real-time constrained-dynamics service. Runs a scene at a fixed rate; LCM in (torque "
               "commands or measured states, controls) and out (wrenches, stresses, accelerations, loop statistics).",
               "coopdynd"};
  app.set_version_flag("--version", "coopdynd (coopdyn) " COOPDYN_VERSION, "print the version and exit");
  app.add_flag_callback(
      "--print-config-reference",
      [] {
        std::fputs(runtime::config_reference_markdown().c_str(), stdout);
        throw CLI::Success();
      },
      "print the service config's keys as the table of docs/reference/config.md and exit");
  app.add_option("--scene", o->scene_path, "scene file (YAML; config/scenes/)")->type_name("FILE")->required();
  app.add_option("--config", o->config_path, "service config (YAML; see config/coopdynd.yaml; default: the built-in values)")
      ->type_name("FILE");
  app.add_option("--lcm-url", o->url_override, "LCM URL of the outputs (and inputs, unless lcm_url_in); overrides the config")
      ->type_name("URL")
      ->default_str(def.lcm_url);
  app.add_option("--mode", o->mode_override, "simulate (torque commands in) or estimate (measured states in); overrides the config")
      ->type_name("MODE")
      ->default_str(runtime::mode_name(def.mode));
  app.add_option("--trigger", o->trigger_override,
                 "estimate mode: compute at each tick of the fixed rate (tick) or on arrival of each measured state "
                 "(arrival: its wrenches out within compute + transport); overrides the config")
      ->type_name("WHEN")
      ->default_str(runtime::trigger_name(def.trigger));
  app.add_option("--rate", rate_arg, "loop rate; overrides the config's rate_hz")
      ->type_name("HZ")
      ->default_str(std::to_string(static_cast<int>(def.rate_hz)));
  app.add_option("--duration", duration_arg, "stop by itself after S seconds (default: run until SIGINT or SIGTERM)")
      ->type_name("S");
  app.failure_message([](const CLI::App*, const CLI::Error& e) {
    return std::string("coopdynd: ") + e.what() + "\nRun 'coopdynd --help' for the options.\n";
  });
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: stdout, 0; errors: stderr, 2
  }
  if (!rate_arg.empty() && !parse_double(rate_arg.c_str(), &o->rate_override)) {
    std::fprintf(stderr, "coopdynd: --rate must be a number (Hz)\n");
    return 2;
  }
  if (!duration_arg.empty() && (!parse_double(duration_arg.c_str(), &o->duration) || o->duration < 0)) {
    std::fprintf(stderr, "coopdynd: --duration must be a number of seconds >= 0\n");
    return 2;
  }

  return -1;
}

int load(const Options& o, coopdyn::runtime::ServiceConfig* cfg_out, coopdyn::System* sys_out) {
  using namespace coopdyn;
  runtime::ServiceConfig& cfg = *cfg_out;
  try {
    if (!o.config_path.empty()) cfg = runtime::load_config(o.config_path);
    // a relative auth.key_file is the config's: resolved against the config file's folder
    if (!o.config_path.empty() && !cfg.auth_key_file.empty() && cfg.auth_key_file[0] != '/') {
      const size_t slash = o.config_path.rfind('/');
      if (slash != std::string::npos) cfg.auth_key_file = o.config_path.substr(0, slash + 1) + cfg.auth_key_file;
    }
    if (!o.url_override.empty()) cfg.lcm_url = o.url_override;
    if (o.rate_override > 0) cfg.rate_hz = o.rate_override;
    if (!o.mode_override.empty() && !runtime::parse_mode(o.mode_override, &cfg.mode))
      throw runtime::ConfigError("--mode must be simulate or estimate");
    if (!o.trigger_override.empty() && !runtime::parse_trigger(o.trigger_override, &cfg.trigger))
      throw runtime::ConfigError("--trigger must be tick or arrival");
    runtime::validate(cfg);
    if (!cfg.auth_key_file.empty()) io::read_key_file(cfg.auth_key_file);  // refused here, before anything starts
  } catch (const io::KeyError& e) {
    std::fprintf(stderr, "coopdynd: config error: auth.key_file: %s\n", e.what());
    return 2;
  } catch (const runtime::ConfigError& e) {
    std::fprintf(stderr, "coopdynd: config error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {  // load_config converts everything; this is the backstop
    std::fprintf(stderr, "coopdynd: config error: %s: %s\n", o.config_path.c_str(), e.what());
    return 2;
  }
  System& sys = *sys_out;
  try {
    sys = load_scene(o.scene_path);
  } catch (const SceneError& e) {
    std::fprintf(stderr, "coopdynd: scene error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "coopdynd: scene error: %s: %s\n", o.scene_path.c_str(), e.what());
    return 1;
  }
  return -1;
}

void start_logging(const coopdyn::runtime::ServiceConfig& cfg) {
  spdlog::init_thread_pool(1024, 1);
  auto logger = std::make_shared<spdlog::async_logger>(
      "coopdynd", std::make_shared<spdlog::sinks::stderr_color_sink_mt>(), spdlog::thread_pool(),
      spdlog::async_overflow_policy::overrun_oldest);
  spdlog::set_default_logger(logger);
  spdlog::set_level(spdlog::level::from_str(cfg.log_level));
  spdlog::set_pattern("[%H:%M:%S.%e] [coopdynd] [%^%l%$] %v");
}

}  // namespace coopdyn::daemon
