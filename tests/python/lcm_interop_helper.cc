// The C++ side of the Python tests (tests/python/*_test.py): what the daemon's codec writes and reads,
// as JSON with every double as a C99 hex float ("%a", exact; Python's float.fromhex).
//
//   lcm_interop_helper write-log SCENE LOG EXPECT.json [TICKS]
//     The daemon's loop (runtime::ServiceLoop, simulate mode, its own OutputEncoder and StatsEncoder)
//     ticks TICKS times (default 40, 1 kHz synthetic clock) with a bus that writes every message it
//     publishes into an LCM event log through LCM's C event-log API (lcm_eventlog_write_event, the
//     API lcm-logger uses); torque commands sent to the loop are logged on COOPDYN_COMMAND first.
//     EXPECT.json lists each event (eventnum, timestamp, channel) and its message as the C++ codec
//     decodes it (io::decode_output, io::decode_stats; the command as sent).
//   lcm_interop_helper scene SCENE
//     The scene's coordinate names, tau_limit, initial state and wrench outputs (what a Python
//     client would learn from coopdyn eval), to build messages for it.
//   lcm_interop_helper decode SCENE FILE...
//     Each FILE holds one encoded message (written by Python); prints, as JSON on stdout, what the
//     C++ codec makes of it: torque_command_t, measured_state_t and control_t through the daemon's
//     validating decoders for SCENE (io::CommandDecoder, StateDecoder, ControlDecoder: values in the
//     scene's order, or the reject), output_t and loop_stats_t through io::decode_output/decode_stats.
#include <lcm/eventlog.h>

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "service/io/transport/bus.h"
#include "service/io/codec/codec.h"
#include "service/runtime/config.h"
#include "service/runtime/inbox.h"
#include "service/runtime/service_loop.h"
#include "service/scene/scene.h"

using namespace coopdyn;

namespace {

// --- a minimal JSON writer: exact doubles as hex-float strings
std::string str(const std::string& s) {
  std::string o = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      o += '\\';
      o += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char b[8];
      std::snprintf(b, sizeof b, "\\u%04x", c);
      o += b;
    } else {
      o += c;
    }
  }
  return o + "\"";
}
std::string hex(double x) {
  char b[64];
  std::snprintf(b, sizeof b, "\"%a\"", x);
  return b;
}
std::string num(long long x) { return std::to_string(x); }
template <class T, class F>
std::string arr(const T& v, F f) {
  std::string o = "[";
  bool first = true;
  for (const auto& x : v) {
    if (!first) o += ", ";
    first = false;
    o += f(x);
  }
  return o + "]";
}
std::string hexes(const Eigen::VectorXd& v) {
  std::string o = "[";
  for (int i = 0; i < v.size(); ++i) o += (i ? ", " : "") + hex(v[i]);
  return o + "]";
}
const auto kHex = [](double x) { return hex(x); };
const auto kNum = [](long long x) { return num(x); };
const auto kStr = [](const std::string& s) { return str(s); };
const auto kHex6 = [](const std::array<double, 6>& w) { return arr(w, kHex); };

struct Obj {  // {"k": v, ...}
  std::string s = "{";
  Obj& add(const std::string& k, const std::string& v) {
    s += (s.size() > 1 ? ", " : "") + str(k) + ": " + v;
    return *this;
  }
  std::string end() const { return s + "}"; }
};

std::string output_json(const io::DecodedOutput& o) {
  Obj j;
  j.add("utime", num(o.utime)).add("tick", num(o.tick)).add("sim_time", hex(o.sim_time)).add("mode", num(o.mode));
  j.add("status", num(o.status)).add("reason", num(o.reason)).add("input", num(o.input));
  j.add("input_seq", num(o.input_seq)).add("input_utime", num(o.input_utime)).add("paused", num(o.paused));
  j.add("control_seq", num(o.control_seq)).add("control_action", num(o.control_action));
  j.add("control_result", num(o.control_result)).add("state_fitted", num(o.state_fitted));
  j.add("fit_iterations", num(o.fit_iterations)).add("closure", arr(o.closure, kHex));
  j.add("closure_constraint", arr(o.closure_constraint, kNum)).add("constraint_names", arr(o.constraint_names, kStr));
  j.add("rows", num(o.rows)).add("rank", num(o.rank)).add("indeterminate", num(o.indeterminate));
  j.add("condition", hex(o.condition)).add("residual", hex(o.residual));
  j.add("wrench_names", arr(o.wrench_names, kStr)).add("wrench_frames", arr(o.wrench_frames, kStr));
  j.add("wrench_by", arr(o.wrench_by, kStr)).add("wrench_kind", arr(o.wrench_kind, kNum));
  j.add("wrench", arr(o.wrench, kHex6)).add("constrained_mask", arr(o.constrained_mask, kNum));
  j.add("indeterminate_mask", arr(o.indeterminate_mask, kNum)).add("wrench_measured", arr(o.wrench_measured, kNum));
  j.add("wrench_residual", arr(o.wrench_residual, kHex6)).add("free_class", arr(o.free_class, kNum));
  j.add("sigma_source", num(o.sigma_source)).add("wrench_sigma", arr(o.wrench_sigma, kHex6));
  j.add("joint_losses", num(o.joint_losses)).add("friction_resting", num(o.friction_resting));
  j.add("wrench_bound", arr(o.wrench_bound, kHex6));
  j.add("free_direction", arr(o.free_direction, [](const std::vector<std::array<double, 6>>& d) { return arr(d, kHex6); }));
  j.add("contact_status", num(o.contact_status)).add("contact_names", arr(o.contact_names, kStr));
  j.add("contact_normal", arr(o.contact_normal, kHex));
  j.add("contact_friction_needed", arr(o.contact_friction_needed, kHex));
  j.add("contact_utilisation", arr(o.contact_utilisation, kHex)).add("contact_state", arr(o.contact_state, kNum));
  j.add("stress_names", arr(o.stress_names, kStr)).add("stress", arr(o.stress, kHex));
  j.add("q_names", arr(o.q_names, kStr)).add("q", arr(o.q, kHex));
  j.add("v_names", arr(o.v_names, kStr)).add("v", arr(o.v, kHex));
  j.add("tau", arr(o.tau, kHex)).add("vdot", arr(o.vdot, kHex));
  j.add("limits", num(o.limits)).add("limit_mask", arr(o.limit_mask, kNum));
  return j.end();
}

std::string stats_json(const io::StatsFrame& s) {
  Obj j;
  j.add("utime", num(s.utime)).add("tick", num(s.tick)).add("period_us", hex(s.period_us));
  j.add("window_ticks", num(s.window_ticks)).add("lateness_us", arr(s.lateness_us, kHex));
  j.add("compute_us", arr(s.compute_us, kHex)).add("overruns", num(s.overruns));
  j.add("skipped_periods", num(s.skipped_periods)).add("commands_received", num(s.received));
  j.add("commands_accepted", num(s.accepted)).add("commands_rejected", num(s.rejected));
  j.add("commands_out_of_order", num(s.out_of_order)).add("commands_expired", num(s.expired));
  j.add("numerical_errors", num(s.numerical_errors)).add("receiver_restarts", num(s.receiver_restarts));
  j.add("inputs_dropped", num(s.inputs_dropped)).add("commands_missed", num(s.missed));
  j.add("inputs_filtered", num(s.inputs_filtered)).add("closure_rejected", num(s.closure_rejected));
  j.add("inputs_malformed", num(s.inputs_malformed));
  for (const auto& [k, v] : {std::make_pair("controls_received", s.controls_received),
                             std::make_pair("controls_accepted", s.controls_accepted),
                             std::make_pair("controls_rejected", s.controls_rejected),
                             std::make_pair("controls_unauthenticated", s.controls_unauthenticated),
                             std::make_pair("controls_bad_mac", s.controls_bad_mac),
                             std::make_pair("controls_replayed", s.controls_replayed),
                             std::make_pair("outputs_dropped", s.outputs_dropped),
                             std::make_pair("limit_ticks", s.limit_ticks[0]),
                             std::make_pair("limit_ticks_position", s.limit_ticks[1]),
                             std::make_pair("limit_ticks_velocity", s.limit_ticks[2]),
                             std::make_pair("limit_ticks_effort", s.limit_ticks[3])})
    j.add(k, num(v));
  std::vector<std::string> keys;
  std::vector<long long> counts;
  for (int k = 1; k < io::kRejectKinds; ++k) {
    keys.emplace_back(io::reject_key(static_cast<io::Reject>(k)));
    counts.push_back(s.rejected_by_reason[k]);
  }
  j.add("reject_reasons", arr(keys, kStr)).add("rejected_by_reason", arr(counts, kNum));
  return j.end();
}

// The loop's bus: every publish becomes one event of the log (what lcm-logger would record).
class LogBus : public io::Bus {
 public:
  LogBus(lcm_eventlog_t* log, std::vector<std::string>* events) : log_(log), events_(events) {}
  int publish(const char* channel, const void* data, int len) override {
    lcm_eventlog_event_t e{};
    e.eventnum = n_++;
    e.timestamp = utime_;
    e.channellen = static_cast<int32_t>(std::strlen(channel));
    e.datalen = len;
    e.channel = const_cast<char*>(channel);
    e.data = const_cast<void*>(data);
    if (lcm_eventlog_write_event(log_, &e) != 0) return -1;
    Obj j;
    j.add("eventnum", num(e.eventnum)).add("timestamp", num(e.timestamp)).add("channel", str(channel));
    switch (io::identify(data, len)) {
      case io::MessageType::kOutput: {
        io::DecodedOutput o;
        if (!io::decode_output(data, len, &o)) return -1;
        j.add("type", str("output_t")).add("message", output_json(o));
        break;
      }
      case io::MessageType::kLoopStats: {
        io::StatsFrame s;
        if (!io::decode_stats(data, len, &s)) return -1;
        j.add("type", str("loop_stats_t")).add("message", stats_json(s));
        break;
      }
      default:
        j.add("type", str("command")).add("message", pending_);  // a command, as sent
    }
    events_->push_back(j.end());
    return 0;
  }
  int64_t utime_ = 0;       // the timestamp of the next event, us
  std::string pending_;     // the JSON of the command being logged
 private:
  lcm_eventlog_t* log_;
  std::vector<std::string>* events_;
  int64_t n_ = 0;
};

int write_log(const std::string& scene, const std::string& path, const std::string& expect, long ticks) {
  const System sys = load_scene(scene);
  runtime::ServiceConfig cfg;
  cfg.stats_period_s = 0.01;  // a loop_stats_t every 10 ticks
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
  if (!log) {
    std::fprintf(stderr, "lcm_interop_helper: cannot create %s\n", path.c_str());
    return 1;
  }
  std::vector<std::string> events;
  LogBus bus(log, &events);
  runtime::ServiceLoop loop(sys, cfg, bus);
  // a command on every actuated DOF from tick 5 on: a quarter of its limit (or 1 N*m), alternating sign
  std::vector<std::string> names;
  std::vector<double> tau;
  for (int i = 0; i < sys.model.nv(); ++i) {
    const double lim = sys.tau_limit[i];
    if (!(lim > 0)) continue;
    names.push_back(sys.model.v_names[static_cast<size_t>(i)]);
    tau.push_back((i % 2 ? -1 : 1) * (std::isfinite(lim) ? 0.25 * lim : 1.0) / 3.0);
  }
  const long long t0 = 1000000000LL, period = cfg.period_ns();
  const int64_t wall0 = runtime::realtime_us();
  int rc = 0;
  for (long k = 0; k < ticks && rc == 0; ++k) {
    bus.utime_ = wall0 + k * 1000;
    if (k == 5 && !names.empty()) {
      const int64_t seq = 7, utime = runtime::realtime_us();
      const std::vector<uint8_t> b = io::encode_torque_command(utime, seq, names, tau);
      bus.pending_ = Obj().add("utime", num(utime)).add("seq", num(seq)).add("names", arr(names, kStr))
                         .add("tau", arr(tau, kHex)).end();
      rc = bus.publish(cfg.command_channel.c_str(), b.data(), static_cast<int>(b.size()));
      io::Reject why = io::Reject::kNone;
      if (loop.commands().offer(b.data(), static_cast<int>(b.size()), t0 + k * period, &why) != runtime::Offer::kAccepted) {
        std::fprintf(stderr, "lcm_interop_helper: the command was refused (%s)\n", io::reject_name(why));
        rc = 1;
      }
    }
    loop.tick(t0 + k * period);
  }
  lcm_eventlog_destroy(log);
  std::ofstream out(expect);
  out << "{\"scene\": " << str(scene) << ", \"events\": [\n";
  for (size_t i = 0; i < events.size(); ++i) out << events[i] << (i + 1 < events.size() ? ",\n" : "\n");
  out << "]}\n";
  if (!out) {
    std::fprintf(stderr, "lcm_interop_helper: cannot write %s\n", expect.c_str());
    return 1;
  }
  if (rc) std::fprintf(stderr, "lcm_interop_helper: writing %s failed\n", path.c_str());
  return rc;
}

int scene_info(const std::string& scene) {
  const System sys = load_scene(scene);
  std::vector<std::string> wrenches;
  for (const auto& w : sys.wrenches.outputs) wrenches.push_back(w.name);
  Obj j;
  j.add("q_names", arr(sys.model.q_names, kStr)).add("v_names", arr(sys.model.v_names, kStr));
  j.add("tau_limit", hexes(sys.tau_limit)).add("q0", hexes(sys.q0)).add("v0", hexes(sys.v0));
  j.add("wrench_names", arr(wrenches, kStr));
  std::printf("%s\n", j.end().c_str());
  return 0;
}

int decode(const std::string& scene, const std::vector<std::string>& files) {
  const System sys = load_scene(scene);
  io::CommandDecoder cmd(sys);
  io::StateDecoder state(sys);
  io::ControlDecoder control(sys);
  std::printf("[\n");
  for (size_t f = 0; f < files.size(); ++f) {
    std::ifstream in(files[f], std::ios::binary);
    const std::vector<uint8_t> b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const int n = static_cast<int>(b.size());
    Obj j;
    j.add("file", str(files[f]));
    io::Reject r = io::Reject::kNone;
    switch (io::identify(b.data(), n)) {
      case io::MessageType::kTorqueCommand: {
        io::CommandSlot s;  // sized as the daemon's inbox sizes it (service_loop.cc)
        s.tau = Eigen::VectorXd::Zero(sys.model.nv());
        r = cmd.decode(b.data(), n, s);
        j.add("type", str("torque_command_t"));
        if (r == io::Reject::kNone) j.add("utime", num(s.utime)).add("seq", num(s.seq)).add("tau", hexes(s.tau));
        break;
      }
      case io::MessageType::kMeasuredState: {
        io::StateSlot s;
        s.q = sys.q0;
        s.v = sys.v0;
        s.tau = Eigen::VectorXd::Zero(sys.model.nv());
        s.has_wrench.assign(sys.wrenches.outputs.size(), 0);
        s.wrench.assign(sys.wrenches.outputs.size(), {});
        r = state.decode(b.data(), n, s);
        j.add("type", str("measured_state_t"));
        if (r == io::Reject::kNone) {
          j.add("utime", num(s.utime)).add("seq", num(s.seq)).add("q", hexes(s.q)).add("v", hexes(s.v));
          j.add("tau", hexes(s.tau)).add("has_wrench", arr(s.has_wrench, kNum)).add("wrench", arr(s.wrench, kHex6));
        }
        break;
      }
      case io::MessageType::kControl: {
        io::ControlSlot s;
        s.q = sys.q0;
        s.v = sys.v0;
        r = control.decode(b.data(), n, s);
        j.add("type", str("control_t"));
        if (r == io::Reject::kNone) {
          j.add("utime", num(s.utime)).add("seq", num(s.seq)).add("action", num(static_cast<int>(s.action)));
          j.add("has_state", num(s.has_state)).add("q", hexes(s.q)).add("v", hexes(s.v));
        }
        break;
      }
      case io::MessageType::kOutput: {
        io::DecodedOutput o;
        if (!io::decode_output(b.data(), n, &o)) r = io::Reject::kDecode;
        j.add("type", str("output_t"));
        if (r == io::Reject::kNone) j.add("message", output_json(o));
        break;
      }
      case io::MessageType::kLoopStats: {
        io::StatsFrame s;
        if (!io::decode_stats(b.data(), n, &s)) r = io::Reject::kDecode;
        j.add("type", str("loop_stats_t"));
        if (r == io::Reject::kNone) j.add("message", stats_json(s));
        break;
      }
      default:
        j.add("type", str("unknown"));
        r = io::Reject::kDecode;
    }
    j.add("reject", str(r == io::Reject::kNone ? "" : io::reject_key(r)));
    std::printf("%s%s\n", j.end().c_str(), f + 1 < files.size() ? "," : "");
  }
  std::printf("]\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string mode = argc > 1 ? argv[1] : "";
    if (mode == "write-log" && (argc == 5 || argc == 6))
      return write_log(argv[2], argv[3], argv[4], argc == 6 ? std::stol(argv[5]) : 40);
    if (mode == "scene" && argc == 3) return scene_info(argv[2]);
    if (mode == "decode" && argc >= 4) return decode(argv[2], std::vector<std::string>(argv + 3, argv + argc));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lcm_interop_helper: %s\n", e.what());
    return 1;
  }
  std::fprintf(stderr, "usage: lcm_interop_helper write-log SCENE LOG EXPECT.json [TICKS]\n"
                       "       lcm_interop_helper scene SCENE\n"
                       "       lcm_interop_helper decode SCENE FILE...\n");
  return 2;
}
