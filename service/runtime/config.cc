#include "service/runtime/config.h"

#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>

#include "service/text/input_limits.h"

namespace coopdyn::runtime {

const char* mode_name(ServiceMode m) { return m == ServiceMode::kSimulate ? "simulate" : "estimate"; }
bool parse_mode(const std::string& s, ServiceMode* m) {
  if (s == "simulate") *m = ServiceMode::kSimulate;
  else if (s == "estimate") *m = ServiceMode::kEstimate;
  else return false;
  return true;
}

const char* trigger_name(Trigger t) { return t == Trigger::kTick ? "tick" : "arrival"; }
bool parse_trigger(const std::string& s, Trigger* t) {
  if (s == "tick") *t = Trigger::kTick;
  else if (s == "arrival") *t = Trigger::kArrival;
  else return false;
  return true;
}

namespace {

std::string num(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", x);
  return b;
}

// The range checks shared by the file loader (which adds file:line:col) and validate(): "" if ok,
// else the reason with the limits and the value given.
std::string check_rate(double r) {
  if (r >= kMinRateHz && r <= kMaxRateHz) return "";
  return "rate_hz must be in [" + num(kMinRateHz) + ", " + num(kMaxRateHz) + "] Hz, got " + num(r);
}
std::string check_watchdog(double ms) {
  if (ms >= kMinWatchdogMs && ms <= kMaxWatchdogMs) return "";
  return "watchdog_ms must be in [" + num(kMinWatchdogMs) + ", " + num(kMaxWatchdogMs) + "] ms (1 ms to 1 hour), got " +
         num(ms);
}
std::string check_input_age(double ms) {
  if (ms == 0 || (ms >= kMinWatchdogMs && ms <= kMaxWatchdogMs)) return "";
  return "max_input_age_ms must be off (or 0) or in [" + num(kMinWatchdogMs) + ", " + num(kMaxWatchdogMs) + "] ms, got " +
         num(ms);
}
std::string check_closure(const char* name, double x) {
  if (x > 0 && x <= 1e6) return "";
  return std::string("closure_tolerance.") + name + " must be in (0, 1e6], got " + num(x);
}

std::string check_stats_period(double s, double rate_hz) {
  // at least one tick per window (1 / rate_hz, with slack for the rounding of that quotient)
  const double lo = 1.0 / rate_hz;
  if (s <= kMaxStatsPeriodS && s * rate_hz >= 1.0 - 1e-9) return "";
  return "stats_period_s must be in [" + num(lo) + ", " + num(kMaxStatsPeriodS) + "] s (at least one tick at rate_hz " +
         num(rate_hz) + ", at most an hour), got " + num(s);
}
std::string check_catch_up(long long n) {
  if (n >= 0 && n <= kMaxCatchUp) return "";
  return "overrun.max_catch_up must be in [0, " + std::to_string(kMaxCatchUp) + "] ticks, got " + std::to_string(n);
}
std::string check_cpu(long long cpu) {
  if (cpu >= -1 && cpu <= kMaxCpu) return "";
  return "realtime.cpu must be -1 (none) or a CPU number in [0, " + std::to_string(kMaxCpu) + "], got " +
         std::to_string(cpu);
}
std::string check_priority(long long p) {
  if (p >= 1 && p <= 99) return "";
  return "realtime.priority must be 1..99, got " + std::to_string(p);
}
std::string check_spin(long long us, double rate_hz) {
  if (us >= 0 && us <= 1000 && static_cast<double>(us) < 1e6 / rate_hz) return "";
  return "realtime.spin_us must be in [0, 1000] us and below the period (" + num(1e6 / rate_hz) + " us at rate_hz " +
         num(rate_hz) + "), got " + std::to_string(us);
}
std::string check_trigger(Trigger t, ServiceMode m) {
  if (t == Trigger::kTick || m == ServiceMode::kEstimate) return "";
  return "trigger: arrival computes on arrival of a measured state and applies to mode estimate only (mode is simulate)";
}
std::string check_channel(const char* key, const std::string& name) {
  if (!name.empty() && name.size() <= static_cast<size_t>(kMaxChannelChars)) return "";
  if (name.empty()) return std::string("channel '") + key + "' is empty";
  return std::string("channel '") + key + "' must be 1.." + std::to_string(kMaxChannelChars) +
         " characters (LCM's limit), got " + std::to_string(name.size());
}
// the receive ring (io/rx_isolated.h): slots and their size, bounded so the shared memory stays
// below 4096 x 4 MiB and a slot holds any command of a sane scene
std::string check_receive(double queue, double bytes) {
  if (!(queue >= 2 && queue <= 4096 && queue == std::floor(queue)))
    return "receive.queue must be an integer in [2, 4096] messages, got " + num(queue);
  if (!(bytes >= 256 && bytes <= 4194304 && bytes == std::floor(bytes)))
    return "receive.max_message_bytes must be an integer in [256, 4194304] bytes, got " + num(bytes);
  return "";
}
std::string check_socket_buffer(double bytes) {
  if (bytes == 0 || (bytes >= kMinSocketBufferBytes && bytes <= kMaxSocketBufferBytes && bytes == std::floor(bytes)))
    return "";
  return "receive.socket_buffer_bytes must be 0 (the OS default) or an integer in [" + std::to_string(kMinSocketBufferBytes) +
         ", " + std::to_string(kMaxSocketBufferBytes) + "] bytes, got " + num(bytes);
}

std::string check_url(const std::string& url, const char* key = "lcm_url") {
  if (!url.empty() && url.size() <= static_cast<size_t>(kMaxUrlChars)) return "";
  if (url.empty()) return std::string(key) + " is empty";
  return std::string(key) + " must be 1.." + std::to_string(kMaxUrlChars) + " characters, got " + std::to_string(url.size());
}

struct Ctx {
  std::string file;
  [[noreturn]] void fail(const YAML::Node& n, const std::string& why) const {
    std::ostringstream s;
    s << file;
    if (n.IsDefined() && n.Mark().line >= 0) s << ":" << n.Mark().line + 1 << ":" << n.Mark().column + 1;
    s << ": " << why;
    throw ConfigError(text::cut_values(s.str()));
  }
  void check(const YAML::Node& n, const std::string& why) const {
    if (!why.empty()) fail(n, why);
  }
  void keys(const YAML::Node& n, const std::set<std::string>& allowed, const std::string& where) const {
    if (!n.IsMap()) fail(n, where + " must be a mapping");
    for (auto it = n.begin(); it != n.end(); ++it) {
      // `? [a, b]\n: 1` makes a key that is a list: as<std::string>() would throw
      if (!it->first.IsScalar()) fail(it->first, "a key in " + where + " must be a plain name, not a list or mapping");
      const std::string k = it->first.Scalar();
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
    if (!x.IsScalar()) fail(x, std::string("'") + key + "' must be " + what);
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
         {"rate_hz", "lcm_url", "lcm_url_in", "receive", "channels", "mode", "integrator", "watchdog_ms", "safe_torque",
          "overrun", "stats_period_s", "realtime", "log_level", "max_input_age_ms", "closure_tolerance", "trigger"},
         "the service config");
  cfg.rate_hz = c.get<double>(root, "rate_hz", cfg.rate_hz, "a number (Hz)");
  c.check(root["rate_hz"], check_rate(cfg.rate_hz));
  cfg.lcm_url = c.get<std::string>(root, "lcm_url", cfg.lcm_url, "a string");
  c.check(root["lcm_url"], check_url(cfg.lcm_url));
  if (root["lcm_url_in"].IsDefined()) {  // "" or absent: the inputs come on lcm_url
    cfg.lcm_url_in = c.get<std::string>(root, "lcm_url_in", "", "a string");
    if (!cfg.lcm_url_in.empty()) c.check(root["lcm_url_in"], check_url(cfg.lcm_url_in, "lcm_url_in"));
  }
  if (const YAML::Node rc = root["receive"]; rc.IsDefined()) {
    c.keys(rc, {"queue", "max_message_bytes", "socket_buffer_bytes"}, "receive");
    const double qn = c.get<double>(rc, "queue", cfg.receive_queue, "a number (messages)");
    const double mb = c.get<double>(rc, "max_message_bytes", cfg.receive_max_bytes, "a number (bytes)");
    c.check(rc["queue"], check_receive(qn, 65536));
    c.check(rc["max_message_bytes"], check_receive(64, mb));
    cfg.receive_queue = static_cast<int>(qn);
    cfg.receive_max_bytes = static_cast<int>(mb);
    const double sb = c.get<double>(rc, "socket_buffer_bytes", cfg.receive_socket_buffer, "a number (bytes)");
    c.check(rc["socket_buffer_bytes"], check_socket_buffer(sb));
    cfg.receive_socket_buffer = static_cast<int>(sb);
  }
  if (const YAML::Node ch = root["channels"]; ch.IsDefined()) {
    c.keys(ch, {"command", "state", "output", "stats", "control"}, "channels");
    cfg.control_channel = c.get<std::string>(ch, "control", cfg.control_channel, "a string");
    c.check(ch["control"], check_channel("control", cfg.control_channel));
    cfg.command_channel = c.get<std::string>(ch, "command", cfg.command_channel, "a string");
    cfg.state_channel = c.get<std::string>(ch, "state", cfg.state_channel, "a string");
    cfg.output_channel = c.get<std::string>(ch, "output", cfg.output_channel, "a string");
    cfg.stats_channel = c.get<std::string>(ch, "stats", cfg.stats_channel, "a string");
    c.check(ch["command"], check_channel("command", cfg.command_channel));
    c.check(ch["state"], check_channel("state", cfg.state_channel));
    c.check(ch["output"], check_channel("output", cfg.output_channel));
    c.check(ch["stats"], check_channel("stats", cfg.stats_channel));
  }
  if (root["mode"].IsDefined() && !parse_mode(c.get<std::string>(root, "mode", "", "a string"), &cfg.mode))
    c.fail(root["mode"], "mode must be simulate or estimate");
  if (root["trigger"].IsDefined() && !parse_trigger(c.get<std::string>(root, "trigger", "", "a string"), &cfg.trigger))
    c.fail(root["trigger"], "trigger must be tick or arrival");
  c.check(root["trigger"], check_trigger(cfg.trigger, cfg.mode));
  if (root["integrator"].IsDefined() && !parse_integrator(c.get<std::string>(root, "integrator", "", "a string"), &cfg.integrator))
    c.fail(root["integrator"], "integrator must be rk4, semi_implicit_euler or implicit_euler");
  cfg.watchdog_ms = c.get<double>(root, "watchdog_ms", cfg.watchdog_ms, "a number (ms)");
  c.check(root["watchdog_ms"], check_watchdog(cfg.watchdog_ms));
  if (const YAML::Node a = root["max_input_age_ms"]; a.IsDefined() && a.IsScalar() && a.Scalar() == "off")
    cfg.max_input_age_ms = 0;
  else
    cfg.max_input_age_ms = c.get<double>(root, "max_input_age_ms", cfg.max_input_age_ms, "a number (ms) or off");
  c.check(root["max_input_age_ms"], check_input_age(cfg.max_input_age_ms));
  if (const YAML::Node ct = root["closure_tolerance"]; ct.IsDefined()) {
    static const char* const names[4] = {"position_m", "orientation_rad", "linear_velocity_mps", "angular_velocity_radps"};
    c.keys(ct, {names[0], names[1], names[2], names[3]}, "closure_tolerance");
    for (int k = 0; k < 4; ++k) {
      cfg.closure_tolerance[k] = c.get<double>(ct, names[k], cfg.closure_tolerance[k], "a number");
      c.check(ct[names[k]], check_closure(names[k], cfg.closure_tolerance[k]));
    }
  }
  if (const YAML::Node st = root["safe_torque"]; st.IsDefined()) {
    c.keys(st, {"policy", "damping"}, "safe_torque");
    const std::string p = c.get<std::string>(st, "policy", "hold", "a string");
    if (p == "zero") cfg.safe_torque = SafeTorque::kZero;
    else if (p == "damping") cfg.safe_torque = SafeTorque::kDamping;
    else if (p == "hold") cfg.safe_torque = SafeTorque::kHold;
    else c.fail(st["policy"], "safe_torque.policy must be hold, zero or damping");
    // any finite damping is representable: the safe torque is clamped to tau_limit
    cfg.damping = c.get<double>(st, "damping", 0.0, "a number (N*m*s/rad)");
    if (!(cfg.damping >= 0) || !std::isfinite(cfg.damping)) c.fail(st["damping"], "safe_torque.damping must be finite and >= 0");
  }
  if (const YAML::Node ov = root["overrun"]; ov.IsDefined()) {
    c.keys(ov, {"policy", "max_catch_up"}, "overrun");
    const std::string p = c.get<std::string>(ov, "policy", "catch_up", "a string");
    if (p == "catch_up") cfg.overrun = OverrunPolicy::kCatchUp;
    else if (p == "skip") cfg.overrun = OverrunPolicy::kSkip;
    else c.fail(ov["policy"], "overrun.policy must be catch_up or skip");
    const long long n = c.get<long long>(ov, "max_catch_up", cfg.max_catch_up, "an integer (ticks)");
    c.check(ov["max_catch_up"], check_catch_up(n));
    cfg.max_catch_up = static_cast<int>(n);
  }
  cfg.stats_period_s = c.get<double>(root, "stats_period_s", cfg.stats_period_s, "a number (s)");
  c.check(root["stats_period_s"], check_stats_period(cfg.stats_period_s, cfg.rate_hz));
  if (const YAML::Node rt = root["realtime"]; rt.IsDefined()) {
    c.keys(rt, {"sched_fifo", "priority", "cpu", "mlockall", "spin_us", "cpu_dma_latency_zero"}, "realtime");
    cfg.realtime.sched_fifo = c.get<bool>(rt, "sched_fifo", false, "true or false");
    const long long prio = c.get<long long>(rt, "priority", cfg.realtime.priority, "an integer");
    c.check(rt["priority"], check_priority(prio));
    cfg.realtime.priority = static_cast<int>(prio);
    const long long cpu = c.get<long long>(rt, "cpu", -1, "an integer");
    c.check(rt["cpu"], check_cpu(cpu));
    cfg.realtime.cpu = static_cast<int>(cpu);
    cfg.realtime.mlockall = c.get<bool>(rt, "mlockall", false, "true or false");
    const long long spin = c.get<long long>(rt, "spin_us", 0, "an integer (us)");
    c.check(rt["spin_us"], check_spin(spin, cfg.rate_hz));
    cfg.realtime.spin_us = static_cast<int>(spin);
    cfg.realtime.cpu_dma_latency_zero = c.get<bool>(rt, "cpu_dma_latency_zero", false, "true or false");
  }
  cfg.log_level = c.get<std::string>(root, "log_level", cfg.log_level, "a string");
  static const std::set<std::string> levels = {"trace", "debug", "info", "warn", "error", "off"};
  if (!levels.count(cfg.log_level)) c.fail(root["log_level"], "log_level must be trace, debug, info, warn, error or off");
  return cfg;
}

std::string place(const std::string& name, const YAML::Mark& m) {
  if (m.line < 0) return name;
  return name + ":" + std::to_string(m.line + 1) + ":" + std::to_string(m.column + 1);
}

}  // namespace

ServiceConfig load_config_string(const std::string& yaml, const std::string& name) {
  Ctx c{name};
  // bounded before yaml-cpp sees it: its parser recurses per level (and stops at 500 with the
  // message "bad file")
  if (yaml.size() > text::kMaxConfigBytes)
    throw ConfigError(name + ": the service config is " + std::to_string(yaml.size()) + " bytes, more than the limit of " +
                      std::to_string(text::kMaxConfigBytes));
  if (const text::DepthExceeded d = text::yaml_depth_exceeds(yaml); d.exceeded)
    throw ConfigError(name + ":" + std::to_string(d.line) + ":" + std::to_string(d.column) + ": YAML nested deeper than " +
                      std::to_string(text::kMaxYamlDepth) + " levels (the limit for a config file)");
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::DeepRecursion& e) {
    throw ConfigError(name + ": YAML nested deeper than yaml-cpp's limit of " + std::to_string(e.depth()) + " levels");
  } catch (const YAML::Exception& e) {
    throw ConfigError(text::cut_values(place(name, e.mark) + ": " + e.msg));
  }
  // Nothing below may escape as anything but a ConfigError naming the file.
  ServiceConfig cfg;
  try {
    cfg = parse(root, c);
  } catch (const ConfigError&) {
    throw;
  } catch (const YAML::Exception& e) {
    throw ConfigError(text::cut_values(place(name, e.mark) + ": " + e.msg));
  } catch (const std::exception& e) {
    throw ConfigError(text::cut_values(name + ": " + e.what()));
  }
  try {
    validate(cfg);
  } catch (const ConfigError& e) {
    throw ConfigError(name + ": " + e.what());
  }
  return cfg;
}

ServiceConfig load_config(const std::string& path) {
  std::string yaml, why;
  if (!text::read_file(path, text::kMaxConfigBytes, "the service config", &yaml, &why)) throw ConfigError(path + ": " + why);
  return load_config_string(yaml, path);
}

void validate(const ServiceConfig& c) {
  for (const std::string& why :
       {check_rate(c.rate_hz), check_watchdog(c.watchdog_ms), check_input_age(c.max_input_age_ms), check_stats_period(c.stats_period_s, c.rate_hz),
        check_catch_up(c.max_catch_up), check_priority(c.realtime.priority), check_cpu(c.realtime.cpu),
        check_spin(c.realtime.spin_us, c.rate_hz), check_trigger(c.trigger, c.mode),
        check_url(c.lcm_url), c.lcm_url_in.empty() ? std::string() : check_url(c.lcm_url_in, "lcm_url_in"),
        check_receive(c.receive_queue, c.receive_max_bytes), check_socket_buffer(c.receive_socket_buffer), check_channel("command", c.command_channel), check_channel("control", c.control_channel), check_channel("state", c.state_channel),
        check_channel("output", c.output_channel), check_channel("stats", c.stats_channel)})
    if (!why.empty()) throw ConfigError(why);
  if (!(c.damping >= 0) || !std::isfinite(c.damping)) throw ConfigError("safe_torque.damping must be finite and >= 0");
  static const char* const names[4] = {"position_m", "orientation_rad", "linear_velocity_mps", "angular_velocity_radps"};
  for (int k = 0; k < 4; ++k)
    if (std::string why = check_closure(names[k], c.closure_tolerance[k]); !why.empty()) throw ConfigError(why);
}

}  // namespace coopdyn::runtime
