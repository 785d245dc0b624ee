#include "service/runtime/config_fields.h"

#include <cmath>
#include <cstdio>
#include <type_traits>

namespace coopdyn::runtime {

namespace {

std::string printed(const char* format, double x) {
  char b[32];
  std::snprintf(b, sizeof b, format, x);
  return b;
}
std::string num(double x) { return printed("%g", x); }
std::string integer(double x) { return std::to_string(static_cast<long long>(x)); }

// A member of the config, or of its realtime options.
template <class C, class T>
auto& member(C& c, T ServiceConfig::*m) {
  return c.*m;
}
template <class C, class T>
auto& member(C& c, T RealtimeOptions::*m) {
  return c.realtime.*m;
}

// A member to and from the FieldValue slot its kind uses, so the table names each member once
// (COOPDYN_MEMBER).
template <auto M, auto Slot>
FieldValue get_member(const ServiceConfig& c) {
  FieldValue v;
  v.*Slot = static_cast<std::remove_reference_t<decltype(v.*Slot)>>(member(c, M));
  return v;
}
template <auto M, auto Slot>
void set_member(ServiceConfig& c, const FieldValue& v) {
  auto& m = member(c, M);
  m = static_cast<std::remove_reference_t<decltype(m)>>(v.*Slot);
}
#define COOPDYN_MEMBER(m, slot) get_member<&m, &FieldValue::slot>, set_member<&m, &FieldValue::slot>

template <int K>
FieldValue get_closure(const ServiceConfig& c) {
  FieldValue v;
  v.x = c.closure_tolerance[K];
  return v;
}
template <int K>
void set_closure(ServiceConfig& c, const FieldValue& v) {
  c.closure_tolerance[K] = v.x;
}

// An enum member as a choice: its word, and the word back to the enum (the word is one of the
// field's choices, in the order of the enum values listed here).
template <class E, auto M, E... Values>
FieldValue get_choice(const ServiceConfig& c, const char* const* words) {
  const E values[] = {Values...};
  FieldValue v;
  for (size_t k = 0; k < sizeof...(Values); ++k)
    if (values[k] == member(c, M)) v.s = words[k];
  return v;
}
template <class E, auto M, E... Values>
void set_choice(ServiceConfig& c, const FieldValue& v, const char* const* words) {
  const E values[] = {Values...};
  for (size_t k = 0; k < sizeof...(Values); ++k)
    if (v.s == words[k]) member(c, M) = values[k];
}

// the words are mode_name's and trigger_name's (config.cc), in the order of their enums
const char* const kModeWords[] = {mode_name(ServiceMode::kSimulate), mode_name(ServiceMode::kEstimate)};
const char* const kTriggerWords[] = {trigger_name(Trigger::kTick), trigger_name(Trigger::kArrival)};
const char* const kIntegratorWords[] = {"rk4", "semi_implicit_euler", "implicit_euler"};
const char* const kSafeTorqueWords[] = {"hold", "zero", "damping"};
const char* const kOverrunWords[] = {"catch_up", "skip"};
const char* const kSchedFifoWords[] = {"auto", "true", "false"};

// m: &ServiceConfig::x or &RealtimeOptions::x
#define COOPDYN_CHOICE_OF(E, m, words, ...)                                                   \
  [](const ServiceConfig& c) { return get_choice<E, m, __VA_ARGS__>(c, words); },           \
      [](ServiceConfig& c, const FieldValue& v) { set_choice<E, m, __VA_ARGS__>(c, v, words); }
#define COOPDYN_CHOICE(E, member, words, ...) COOPDYN_CHOICE_OF(E, &ServiceConfig::member, words, __VA_ARGS__)

// The checks: "" if ok, else the reason with the limits (from the table) and the value given.
std::string check_rate(const ConfigField& f, const FieldValue& v, const ServiceConfig&) {
  if (v.x >= f.lo && v.x <= f.hi) return "";
  return "rate_hz must be in [" + num(f.lo) + ", " + num(f.hi) + "] Hz, got " + num(v.x);
}
std::string check_url(const ConfigField& f, const FieldValue& v, const ServiceConfig&) {
  if (!v.s.empty() && v.s.size() <= static_cast<size_t>(f.hi)) return "";
  if (v.s.empty()) return std::string(f.key) + " is empty";
  return std::string(f.key) + " must be 1.." + integer(f.hi) + " characters, got " + std::to_string(v.s.size());
}
// "" or absent: the inputs come on lcm_url
std::string check_url_in(const ConfigField& f, const FieldValue& v, const ServiceConfig& c) {
  return v.s.empty() ? "" : check_url(f, v, c);
}
// the receive ring (io/transport/rx_isolated.h): slots and their size, bounded so the shared memory stays
// below 4096 x 4 MiB and a slot holds any command of a sane scene
std::string check_receive(const ConfigField& f, const FieldValue& v, const ServiceConfig&) {
  if (v.x >= f.lo && v.x <= f.hi && v.x == std::floor(v.x)) return "";
  const std::string what = f.what;  // "a number (unit)"
  const std::string unit = what.substr(what.find('(') + 1, what.size() - what.find('(') - 2);
  return std::string("receive.") + f.key + " must be an integer in [" + integer(f.lo) + ", " + integer(f.hi) + "] " + unit +
         ", got " + num(v.x);
}
std::string check_socket_buffer(const ConfigField& f, const FieldValue& v, const ServiceConfig&) {
  if (v.x == 0 || (v.x >= f.lo && v.x <= f.hi && v.x == std::floor(v.x))) return "";
  return "receive.socket_buffer_bytes must be 0 (the OS default) or an integer in [" + integer(f.lo) + ", " + integer(f.hi) +
         "] bytes, got " + num(v.x);
}
std::string check_channel(const ConfigField& f, const FieldValue& v, const ServiceConfig&) {
  if (!v.s.empty() && v.s.size() <= static_cast<size_t>(f.hi)) return "";
  if (v.s.empty()) return std::string("channel '") + f.key + "' is empty";
  return std::string("channel '") + f.key + "' must be 1.." + integer(f.hi) + " characters (LCM's limit), got " +
         std::to_string(v.s.size());
}
std::string check_trigger(const ConfigField&, const FieldValue& v, const ServiceConfig& c) {
  if (v.s == trigger_name(Trigger::kTick) || c.mode == ServiceMode::kEstimate) return "";
  return "trigger: arrival computes on arrival of a measured state and applies to mode estimate only (mode is simulate)";
}
std::string check_watchdog(const ConfigField& f, const FieldValue& v, const ServiceConfig&) {
  if (v.x >= f.lo && v.x <= f.hi) return "";
  return "watchdog_ms must be in [" + num(f.lo) + ", " + num(f.hi) + "] ms (1 ms to 1 hour), got " + num(v.x);
}
std::string check_input_age(const ConfigField& f, const FieldValue& v, const ServiceConfig&) {
  if (v.x == 0 || (v.x >= f.lo && v.x <= f.hi)) return "";
  return "max_input_age_ms must be off (or 0) or in [" + num(f.lo) + ", " + num(f.hi) + "] ms, got " + num(v.x);
}
std::string check_closure(const ConfigField& f, const FieldValue& v, const ServiceConfig&) {
  if (v.x > f.lo && v.x <= f.hi) return "";
  return std::string("closure_tolerance.") + f.key + " must be in (0, 1e6], got " + num(v.x);
}
// any finite damping is representable: the safe torque is clamped to tau_limit
std::string check_damping(const ConfigField&, const FieldValue& v, const ServiceConfig&) {
  if (v.x >= 0 && std::isfinite(v.x)) return "";
  return "safe_torque.damping must be finite and >= 0";
}
std::string check_time_constant(const ConfigField&, const FieldValue& v, const ServiceConfig&) {
  if (v.x >= 0 && v.x <= 1e3) return "";
  return "safe_torque.time_constant must be in [0, 1000] s, got " + num(v.x);
}
std::string check_catch_up(const ConfigField& f, const FieldValue& v, const ServiceConfig&) {
  if (v.n >= f.lo && v.n <= f.hi) return "";
  return "overrun.max_catch_up must be in [" + integer(f.lo) + ", " + integer(f.hi) + "] ticks, got " + std::to_string(v.n);
}
std::string check_stats_period(const ConfigField& f, const FieldValue& v, const ServiceConfig& c) {
  // at least one tick per window (1 / rate_hz, with slack for the rounding of that quotient)
  if (v.x <= f.hi && v.x * c.rate_hz >= 1.0 - 1e-9) return "";
  return "stats_period_s must be in [" + num(1.0 / c.rate_hz) + ", " + num(f.hi) + "] s (at least one tick at rate_hz " +
         num(c.rate_hz) + ", at most an hour), got " + num(v.x);
}
std::string check_priority(const ConfigField& f, const FieldValue& v, const ServiceConfig&) {
  if (v.n >= f.lo && v.n <= f.hi) return "";
  return "realtime.priority must be " + integer(f.lo) + ".." + integer(f.hi) + ", got " + std::to_string(v.n);
}
std::string check_receive_priority(const ConfigField& f, const FieldValue& v, const ServiceConfig& c) {
  if (v.n == 0 || (v.n >= f.lo && v.n < c.realtime.priority)) return "";
  return "realtime.receive_priority must be 0 (SCHED_OTHER) or " + integer(f.lo) + ".." +
         std::to_string(c.realtime.priority - 1) + " (below realtime.priority " + std::to_string(c.realtime.priority) +
         ": the loop preempts the receive path), got " + std::to_string(v.n);
}
std::string check_cpu(const ConfigField& f, const FieldValue& v, const ServiceConfig&) {
  if (v.n >= -1 && v.n <= f.hi) return "";
  return "realtime.cpu must be -1 (none) or a CPU number in [" + integer(f.lo) + ", " + integer(f.hi) + "], got " +
         std::to_string(v.n);
}
std::string check_spin(const ConfigField& f, const FieldValue& v, const ServiceConfig& c) {
  if (v.n >= f.lo && v.n <= f.hi && static_cast<double>(v.n) < 1e6 / c.rate_hz) return "";
  return "realtime.spin_us must be in [" + integer(f.lo) + ", " + integer(f.hi) + "] us and below the period (" +
         num(1e6 / c.rate_hz) + " us at rate_hz " + num(c.rate_hz) + "), got " + std::to_string(v.n);
}
std::string check_busy_poll(const ConfigField&, const FieldValue& v, const ServiceConfig& c) {
  if (!v.b || (c.mode == ServiceMode::kEstimate && c.trigger == Trigger::kArrival)) return "";
  return "realtime.busy_poll polls for measured states and applies to mode estimate with trigger arrival only (mode " +
         std::string(mode_name(c.mode)) + ", trigger " + trigger_name(c.trigger) + "); the fixed-rate loop has spin_us";
}

std::string check_receive_in_loop(const ConfigField&, const FieldValue& v, const ServiceConfig& c) {
  if (!v.b || (c.mode == ServiceMode::kEstimate && c.trigger == Trigger::kArrival)) return "";
  return "realtime.receive_in_loop reads measured states on the loop's thread and applies to mode estimate with trigger "
         "arrival only (mode " + std::string(mode_name(c.mode)) + ", trigger " + trigger_name(c.trigger) + ")";
}

constexpr double kNone = 0;

using K = FieldKind;
using S = ServiceConfig;
using R = RealtimeOptions;

// The keys in the order the loader reads them (the order of the reference page).
const std::vector<ConfigField> kFields = {
    {"", "rate_hz", K::kReal, "a number (Hz)", kMinRateHz, kMaxRateHz, "[{lo}, {hi}] Hz", {}, false,
     COOPDYN_MEMBER(S::rate_hz, x), check_rate, "",
     "loop rate; simulate integrates `dt = 1/rate_hz` per tick (`--rate` overrides)"},
    {"", "lcm_url", K::kText, "a string", 1, kMaxUrlChars, "", {}, false, COOPDYN_MEMBER(S::lcm_url, s),
     check_url, "",
     "outputs and stats (and inputs unless `lcm_url_in`); `ttl=0` keeps multicast on this machine, `ttl=1` one LAN "
     "segment (`--lcm-url` overrides)"},
    {"", "lcm_url_in", K::kText, "a string", 1, kMaxUrlChars, "", {}, false, COOPDYN_MEMBER(S::lcm_url_in, s), check_url_in, " (= `lcm_url`)",
     "commands, measured states and controls on a URL of their own (another port or group), so that the daemon's "
     "outputs and any flood on `lcm_url` never reach the receiver; senders then use that URL"},
    {"receive", "queue", K::kCount, "a number (messages)", 2, 4096, "{lo}..{hi}", {}, false,
     COOPDYN_MEMBER(S::receive_queue, x), check_receive, "",
     "messages the isolated receive process can queue for the loop (ring slots)"},
    {"receive", "max_message_bytes", K::kCount, "a number (bytes)", 256, 4194304, "{lo}..{hi}", {}, false,
     COOPDYN_MEMBER(S::receive_max_bytes, x), check_receive, "",
     "larger input messages are refused and counted (`inputs_malformed`); also the size of each of the receive "
     "process's 8 fragment reassembly slots"},
    {"receive", "socket_buffer_bytes", K::kCount, "a number (bytes)", kMinSocketBufferBytes, kMaxSocketBufferBytes,
     "0 or {lo}..{hi}", {}, false, COOPDYN_MEMBER(S::receive_socket_buffer, x),
     check_socket_buffer, " (16 MiB; 0: the OS default, `net.core.rmem_default`)",
     "`SO_RCVBUF` of the receive socket: room for a flood's bursts while the receive process waits for a CPU; the "
     "kernel caps it at `net.core.rmem_max` (212992 on Debian 12) unless the daemon has `CAP_NET_ADMIN` "
     "(`SO_RCVBUFFORCE`), and the log says what was granted"},
    {"channels", "command", K::kText, "a string", 1, kMaxChannelChars, "names {lo}..{hi} characters", {}, false,
     COOPDYN_MEMBER(S::command_channel, s), check_channel, "", "`torque_command_t` in (simulate)"},
    {"channels", "state", K::kText, "a string", 1, kMaxChannelChars, "", {}, false, COOPDYN_MEMBER(S::state_channel, s), check_channel, "", "`measured_state_t` in (estimate)"},
    {"channels", "output", K::kText, "a string", 1, kMaxChannelChars, "", {}, false, COOPDYN_MEMBER(S::output_channel, s), check_channel, "", "`output_t` out, every tick"},
    {"channels", "stats", K::kText, "a string", 1, kMaxChannelChars, "", {}, false, COOPDYN_MEMBER(S::stats_channel, s), check_channel, "", "`loop_stats_t` out, every `stats_period_s`"},
    {"channels", "control", K::kText, "a string", 1, kMaxChannelChars, "", {}, false, COOPDYN_MEMBER(S::control_channel, s), check_channel, "", "`control_t` in: reset, pause, resume, clear a fault"},
    // check_url_in: "" (off) or 1..hi characters
    {"auth", "key_file", K::kText, "a string (path)", 1, 4096, "a file of 64 hex digits, mode 0600 or stricter", {}, false,
     COOPDYN_MEMBER(S::auth_key_file, s), check_url_in, " (off)",
     "authenticated inputs: commands, states and controls must carry an HMAC-SHA256 under this key (docs/guide/"
     "service.md \"Authenticated inputs\"); unsigned, bad-MAC and replayed ones are rejected and counted. The daemon refuses to start "
     "if the file is missing, not a key, or readable or writable by group or others"},
    {"", "mode", K::kChoice, "a string", kNone, kNone, "", {kModeWords, kModeWords + 2}, true,
     COOPDYN_CHOICE(ServiceMode, mode, kModeWords, ServiceMode::kSimulate, ServiceMode::kEstimate), nullptr, "",
     "integrate under the latest command, or evaluate the latest measured state (`--mode` overrides)"},
    {"", "trigger", K::kChoice, "a string", kNone, kNone, "", {kTriggerWords, kTriggerWords + 2}, true,
     COOPDYN_CHOICE(Trigger, trigger, kTriggerWords, Trigger::kTick, Trigger::kArrival), check_trigger, "",
     "estimate mode only: compute at each tick, or on arrival of each measured state (`--trigger` overrides)"},
    {"", "integrator", K::kChoice, "a string", kNone, kNone, "", {kIntegratorWords, kIntegratorWords + 3}, true,
     COOPDYN_CHOICE(Integrator, integrator, kIntegratorWords, Integrator::kRk4, Integrator::kSemiImplicitEuler,
                    Integrator::kImplicitEuler),
     nullptr, "", "simulate mode"},
    {"", "watchdog_ms", K::kReal, "a number (ms)", kMinWatchdogMs, kMaxWatchdogMs, "[{lo}, {hi}]", {}, false,
     COOPDYN_MEMBER(S::watchdog_ms, x), check_watchdog, "",
     "a command (or measured state) older than this expires: the safe torque applies (simulate) or "
     "`REASON_STATE_STALE` (estimate)"},
    {"", "max_input_age_ms", K::kRealOrOff, "a number (ms) or off", kMinWatchdogMs, kMaxWatchdogMs, "`off` or [{lo}, {hi}]",
     {}, false, COOPDYN_MEMBER(S::max_input_age_ms, x), check_input_age, "",
     "reject a command, state or control whose `utime` is <= 0 or further than this from the daemon's wall clock"},
    {"closure_tolerance", "position_m", K::kReal, "a number", 0, 1e6, "(0, 1e6]", {}, false, get_closure<0>,
     set_closure<0>, check_closure, "",
     "estimate: the largest closure residual a measured state may have; above it `STATUS_ERROR`, `REASON_CLOSURE`, no "
     "wrenches"},
    {"closure_tolerance", "orientation_rad", K::kReal, "a number", 0, 1e6, "(0, 1e6]", {}, false, get_closure<1>,
     set_closure<1>, check_closure, "", "as above"},
    {"closure_tolerance", "linear_velocity_mps", K::kReal, "a number", 0, 1e6, "(0, 1e6]", {}, false, get_closure<2>,
     set_closure<2>, check_closure, "", "as above"},
    {"closure_tolerance", "angular_velocity_radps", K::kReal, "a number", 0, 1e6, "(0, 1e6]", {}, false,
     get_closure<3>, set_closure<3>, check_closure, "", "as above"},
    {"estimate", "compensate_joint_losses", K::kFlag, "true or false", kNone, kNone, "", {}, false,
     COOPDYN_MEMBER(S::compensate_joint_losses, b), nullptr, "",
     "estimate: take the joints' damping (`-b v`) and Coulomb friction (`-F sign(v)`) out of the measured torques "
     "from the measured velocity; a joint at rest has its friction solved as stiction and each wrench carries the "
     "interval that friction's bound allows (`wrench_bound`); false: the torques are taken as reaching the links"},
    {"safe_torque", "policy", K::kChoice, "a string", kNone, kNone, "", {kSafeTorqueWords, kSafeTorqueWords + 3}, false,
     COOPDYN_CHOICE(SafeTorque, safe_torque, kSafeTorqueWords, SafeTorque::kHold, SafeTorque::kZero,
                    SafeTorque::kDamping),
     nullptr, "",
     "applied when no command has arrived or the last one expired, and to the joints a command does not name: `hold` "
     "the least-squares actuator torques (in fractions of each joint's limit) that balance gravity and the velocity "
     "terms under the constraints and brake every motion to rest with the time constant `time_constant` (the "
     "acceleration `-v / time_constant`, the load's inertia included), minus `damping * v`, clamped to `tau_limit`; "
     "`zero`; `damping` (`tau = -damping * v` on joints with a finite `tau_limit`)"},
    {"safe_torque", "time_constant", K::kReal, "a number (s)", 0, 1e3, "[0, 1000]", {}, false,
     COOPDYN_MEMBER(S::time_constant, x), check_time_constant, "",
     "s, policy `hold`: every velocity decays as `exp(-t / time_constant)` while the joints' `tau_limit` allow it "
     "(two PUMAs holding a box stop from 14 rad/s within 2 s); 0: hold without braking"},
    {"safe_torque", "damping", K::kReal, "a number (N*m*s/rad)", kNone, kNone, "", {}, false, COOPDYN_MEMBER(S::damping, x), check_damping, "", "N*m*s/rad (N*s/m for prismatic joints)"},
    {"overrun", "policy", K::kChoice, "a string", kNone, kNone, "", {kOverrunWords, kOverrunWords + 2}, false,
     COOPDYN_CHOICE(OverrunPolicy, overrun, kOverrunWords, OverrunPolicy::kCatchUp, OverrunPolicy::kSkip), nullptr,
     "",
     "when a tick ends after the next deadline: run missed ticks back to back (at most `max_catch_up`, then skip the "
     "rest), or resume at the next deadline"},
    {"overrun", "max_catch_up", K::kInteger, "an integer (ticks)", 0, kMaxCatchUp, "[{lo}, {hi}] ticks", {}, false,
     COOPDYN_MEMBER(S::max_catch_up, n), check_catch_up, "", ""},
    {"", "stats_period_s", K::kReal, "a number (s)", kNone, kMaxStatsPeriodS, "[1/rate_hz, {hi}] s", {}, false,
     COOPDYN_MEMBER(S::stats_period_s, x), check_stats_period, "",
     "`loop_stats_t` period; its percentiles are over this window"},
    {"realtime", "sched_fifo", K::kChoice, "a string", kNone, kNone, "", {kSchedFifoWords, kSchedFifoWords + 3}, true,
     COOPDYN_CHOICE_OF(SchedFifo, &RealtimeOptions::sched_fifo, kSchedFifoWords, SchedFifo::kAuto, SchedFifo::kOn,
                       SchedFifo::kOff),
     nullptr, "",
     "`SCHED_FIFO` at `priority` for the loop thread: `auto` takes it when the process may (root or `CAP_SYS_NICE`; "
     "else logged, the loop runs `SCHED_OTHER`), not with `busy_poll` without a `cpu`, and steps the loop down to "
     "`SCHED_OTHER` (logged, `SCHED_FIFO stepped down` in the summary) when over a stats window its thread was busy "
     "(CPU time; with `busy_poll`, the ticks' compute time) more than half the time, or at least half its ticks "
     "overran for three windows in a row; `true` always, never stepped down; "
     "`false` never"},
    {"realtime", "priority", K::kInteger, "an integer", 1, 99, "{lo}..{hi}", {}, false, COOPDYN_MEMBER(R::priority, n), check_priority, "", "its priority"},
    {"realtime", "receive_priority", K::kInteger, "an integer", 1, 98, "0 or 1..`priority` - 1", {}, false,
     COOPDYN_MEMBER(R::receive_priority, n), check_receive_priority, " (`SCHED_OTHER`)",
     "when the loop asks for `SCHED_FIFO`: the receive process and thread at `SCHED_FIFO` this priority, below the "
     "loop's; each steps down to `SCHED_OTHER` when it keeps its CPU busy more than half a second in a second (a "
     "flood)"},
    {"realtime", "cpu", K::kInteger, "an integer", 0, kMaxCpu, "-1 or [{lo}, {hi}]", {}, false, COOPDYN_MEMBER(R::cpu, n), check_cpu, "",
     "pin the loop thread to this CPU (-1: no affinity); the receive thread and process and the publisher thread "
     "then run on the other CPUs"},
    {"realtime", "mlockall", K::kFlag, "true or false", kNone, kNone, "", {}, false, COOPDYN_MEMBER(R::mlockall, b), nullptr, "", "lock all pages (no page faults in the loop)"},
    {"realtime", "spin_us", K::kInteger, "an integer (us)", 0, 1000, "[{lo}, {hi}], below the period", {}, false,
     COOPDYN_MEMBER(R::spin_us, n), check_spin, "",
     "fixed rate: wake this many us before each deadline, evaluate the held state once to warm the caches "
     "(discarded), then busy-wait to the deadline; costs about `spin_us * rate_hz / 1e6` of a CPU"},
    {"realtime", "cpu_dma_latency_zero", K::kFlag, "true or false", kNone, kNone, "", {}, false,
     COOPDYN_MEMBER(R::cpu_dma_latency_zero, b), nullptr, "",
     "hold `/dev/cpu_dma_latency` at 0 while running (no deep idle states, so the loop wakes with its caches; "
     "root, else logged and ignored; the machine draws more power while the daemon runs)"},
    {"realtime", "busy_poll", K::kFlag, "true or false", kNone, kNone, "", {}, false,
     COOPDYN_MEMBER(R::busy_poll, b), check_busy_poll, "",
     "`trigger: arrival` only: the loop polls for measured states instead of sleeping (no wake-up between a "
     "state's receipt and its computation); takes a whole CPU at all times: give it `cpu` (isolated) and `sched_fifo`"},
    {"realtime", "receive_in_loop", K::kFlag, "true or false", kNone, kNone, "", {}, false,
     COOPDYN_MEMBER(R::receive_in_loop, b), check_receive_in_loop, " (the isolated receive process)",
     "`trigger: arrival` only: the loop's thread reads the input socket itself (sleeping in `ppoll` on it, or "
     "polling it with `busy_poll`) through the same bounded parser, checks and counters as the receive process, "
     "so that a state goes from the kernel to the loop with no other wake-up; no receive process then isolates "
     "the parser from the daemon (docs/guide/service.md, threat model). udpm inputs only"},
    {"realtime", "publisher_thread", K::kFlag, "true or false", kNone, kNone, "", {}, false,
     COOPDYN_MEMBER(R::publisher_thread, b), nullptr, "",
     "`trigger: tick`: the loop hands each encoded output to a thread of its own that publishes it (the `sendmsg` "
     "and its delivery to the host's subscribers off the loop's thread and, with `cpu`, its CPU; an output leaves "
     "one thread wake-up later; one that finds its 8 slots full is dropped and counted, `outputs_dropped`); false: "
     "the loop publishes itself. On arrival the loop always publishes itself"},
    {"", "log_level", K::kChoice, "a string", kNone, kNone, "", {"trace", "debug", "info", "warn", "error", "off"}, false,
     COOPDYN_MEMBER(S::log_level, s), nullptr, "", ""},
};

}  // namespace

const std::vector<ConfigField>& config_fields() { return kFields; }

std::string field_path(const ConfigField& f) {
  return *f.section ? std::string(f.section) + "." + f.key : std::string(f.key);
}

std::string choice_list(const ConfigField& f) {
  std::string s;
  for (size_t k = 0; k < f.choices.size(); ++k)
    s += std::string(k == 0 ? "" : k + 1 == f.choices.size() ? " or " : ", ") + f.choices[k];
  return s;
}

std::string number_text(double x) { return printed("%.15g", x); }

std::string field_text(const ConfigField& f, const FieldValue& v) {
  switch (f.kind) {
    case FieldKind::kReal:
    case FieldKind::kRealOrOff:
    case FieldKind::kCount:
      return number_text(v.x);
    case FieldKind::kInteger: return std::to_string(v.n);
    case FieldKind::kFlag: return v.b ? "true" : "false";
    case FieldKind::kText:
    case FieldKind::kChoice: break;
  }
  return v.s;
}

#undef COOPDYN_CHOICE
#undef COOPDYN_CHOICE_OF
#undef COOPDYN_MEMBER

}  // namespace coopdyn::runtime
