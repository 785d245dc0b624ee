#include "service/runtime/config.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace coopdyn::runtime {

const char* mode_name(ServiceMode m) { return m == ServiceMode::kSimulate ? "simulate" : "estimate"; }
bool parse_mode(const std::string& s, ServiceMode* m) {
  if (s == "simulate") *m = ServiceMode::kSimulate;
  else if (s == "estimate") *m = ServiceMode::kEstimate;
  else return false;
  return true;
}

namespace {
struct Ctx {
  std::string file;
  [[noreturn]] void fail(const YAML::Node& n, const std::string& why) const {
    std::ostringstream s;
    s << file;
    if (n.IsDefined() && n.Mark().line >= 0) s << ":" << n.Mark().line + 1 << ":" << n.Mark().column + 1;
    s << ": " << why;
    throw ConfigError(s.str());
  }
  void keys(const YAML::Node& n, const std::set<std::string>& allowed, const std::string& where) const {
    if (!n.IsMap()) fail(n, where + " must be a mapping");
    for (auto it = n.begin(); it != n.end(); ++it) {
      const std::string k = it->first.as<std::string>();
      if (!allowed.count(k)) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(it->first, "unknown key '" + k + "' in " + where + " (allowed: " + list + ")");
      }
    }
  }
  template <class T>
  T get(const YAML::Node& n, const char* key, T def, const char* what) const {
    const YAML::Node x = n[key];
    if (!x.IsDefined() || x.IsNull()) return def;
    try {
      return x.as<T>();
    } catch (const YAML::Exception&) {
      fail(x, std::string("'") + key + "' must be " + what);
    }
  }
};

ServiceConfig parse(const YAML::Node& root, const Ctx& c) {
  ServiceConfig cfg;
  if (!root.IsDefined() || root.IsNull()) return cfg;
  c.keys(root,
         {"rate_hz", "lcm_url", "channels", "mode", "integrator", "watchdog_ms", "safe_torque", "overrun",
          "stats_period_s", "realtime", "log_level"},
         "the service config");
  cfg.rate_hz = c.get<double>(root, "rate_hz", cfg.rate_hz, "a number (Hz)");
  if (!(cfg.rate_hz > 0 && cfg.rate_hz <= 20000)) c.fail(root["rate_hz"], "rate_hz must be in (0, 20000]");
  cfg.lcm_url = c.get<std::string>(root, "lcm_url", cfg.lcm_url, "a string");
  if (const YAML::Node ch = root["channels"]; ch.IsDefined()) {
    c.keys(ch, {"command", "state", "output", "stats"}, "channels");
    cfg.command_channel = c.get<std::string>(ch, "command", cfg.command_channel, "a string");
    cfg.state_channel = c.get<std::string>(ch, "state", cfg.state_channel, "a string");
    cfg.output_channel = c.get<std::string>(ch, "output", cfg.output_channel, "a string");
    cfg.stats_channel = c.get<std::string>(ch, "stats", cfg.stats_channel, "a string");
    for (const char* k : {"command", "state", "output", "stats"})
      if (ch[k].IsDefined() && ch[k].as<std::string>("").empty()) c.fail(ch[k], std::string("channel '") + k + "' is empty");
  }
  if (root["mode"].IsDefined() && !parse_mode(c.get<std::string>(root, "mode", "", "a string"), &cfg.mode))
    c.fail(root["mode"], "mode must be simulate or estimate");
  if (root["integrator"].IsDefined() && !parse_integrator(c.get<std::string>(root, "integrator", "", "a string"), &cfg.integrator))
    c.fail(root["integrator"], "integrator must be rk4 or semi_implicit_euler");
  cfg.watchdog_ms = c.get<double>(root, "watchdog_ms", cfg.watchdog_ms, "a number (ms)");
  if (!(cfg.watchdog_ms > 0) || !std::isfinite(cfg.watchdog_ms)) c.fail(root["watchdog_ms"], "watchdog_ms must be > 0");
  if (const YAML::Node st = root["safe_torque"]; st.IsDefined()) {
    c.keys(st, {"policy", "damping"}, "safe_torque");
    const std::string p = c.get<std::string>(st, "policy", "zero", "a string");
    if (p == "zero") cfg.safe_torque = SafeTorque::kZero;
    else if (p == "damping") cfg.safe_torque = SafeTorque::kDamping;
    else c.fail(st["policy"], "safe_torque.policy must be zero or damping");
    cfg.damping = c.get<double>(st, "damping", 0.0, "a number (N*m*s/rad)");
    if (!(cfg.damping >= 0) || !std::isfinite(cfg.damping)) c.fail(st["damping"], "safe_torque.damping must be >= 0");
  }
  if (const YAML::Node ov = root["overrun"]; ov.IsDefined()) {
    c.keys(ov, {"policy", "max_catch_up"}, "overrun");
    const std::string p = c.get<std::string>(ov, "policy", "catch_up", "a string");
    if (p == "catch_up") cfg.overrun = OverrunPolicy::kCatchUp;
    else if (p == "skip") cfg.overrun = OverrunPolicy::kSkip;
    else c.fail(ov["policy"], "overrun.policy must be catch_up or skip");
    cfg.max_catch_up = c.get<int>(ov, "max_catch_up", cfg.max_catch_up, "an integer");
    if (cfg.max_catch_up < 0 || cfg.max_catch_up > 1000) c.fail(ov["max_catch_up"], "overrun.max_catch_up must be in [0, 1000]");
  }
  cfg.stats_period_s = c.get<double>(root, "stats_period_s", cfg.stats_period_s, "a number (s)");
  if (!(cfg.stats_period_s > 0) || !std::isfinite(cfg.stats_period_s)) c.fail(root["stats_period_s"], "stats_period_s must be > 0");
  if (const YAML::Node rt = root["realtime"]; rt.IsDefined()) {
    c.keys(rt, {"sched_fifo", "priority", "cpu", "mlockall"}, "realtime");
    cfg.realtime.sched_fifo = c.get<bool>(rt, "sched_fifo", false, "true or false");
    cfg.realtime.priority = c.get<int>(rt, "priority", cfg.realtime.priority, "an integer");
    if (cfg.realtime.priority < 1 || cfg.realtime.priority > 99) c.fail(rt["priority"], "realtime.priority must be 1..99");
    cfg.realtime.cpu = c.get<int>(rt, "cpu", -1, "an integer");
    if (cfg.realtime.cpu < -1) c.fail(rt["cpu"], "realtime.cpu must be -1 (none) or a CPU number");
    cfg.realtime.mlockall = c.get<bool>(rt, "mlockall", false, "true or false");
  }
  cfg.log_level = c.get<std::string>(root, "log_level", cfg.log_level, "a string");
  static const std::set<std::string> levels = {"trace", "debug", "info", "warn", "error", "off"};
  if (!levels.count(cfg.log_level)) c.fail(root["log_level"], "log_level must be trace, debug, info, warn, error or off");
  return cfg;
}
}  // namespace

ServiceConfig load_config_string(const std::string& text, const std::string& name) {
  Ctx c{name};
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(name + ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1) + ": " + e.msg);
  }
  ServiceConfig cfg = parse(root, c);
  validate(cfg);
  return cfg;
}

ServiceConfig load_config(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw ConfigError(path + ": cannot open the service config");
  std::stringstream ss;
  ss << f.rdbuf();
  return load_config_string(ss.str(), path);
}

void validate(const ServiceConfig& c) {
  if (!(c.rate_hz > 0 && c.rate_hz <= 20000)) throw ConfigError("rate_hz must be in (0, 20000]");
  if (!(c.watchdog_ms > 0)) throw ConfigError("watchdog_ms must be > 0");
  if (c.lcm_url.empty()) throw ConfigError("lcm_url is empty");
  if (c.command_channel.empty() || c.state_channel.empty() || c.output_channel.empty() || c.stats_channel.empty())
    throw ConfigError("channel names must not be empty");
}

}  // namespace coopdyn::runtime
