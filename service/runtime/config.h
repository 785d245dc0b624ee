// The service configuration (config/coopdynd.yaml): rate, LCM URL and channels, mode, watchdog,
// safe torque, overrun policy, real-time options. Checked completely at start-up.
#pragma once

#include <stdexcept>
#include <string>

#include "service/dynamics/integrators.h"

namespace coopdyn::runtime {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class ServiceMode { kSimulate, kEstimate };
enum class SafeTorque {
  kZero,     // tau = 0 on every DOF
  kHold,     // the braking hold (dynamics/holding_torque.h braking_torque): the least-squares actuator
             // torques that give the constrained motion the acceleration -v / time_constant at the
             // current state (gravity and velocity terms balanced: at rest it holds still), minus
             // damping * v on the same DOFs, clamped to tau_limit
  kDamping,  // tau = -damping * v on the DOFs with a finite tau_limit (the actuated joints),
             // clamped to the limit; 0 elsewhere
};
enum class OverrunPolicy {
  kCatchUp,  // run missed ticks back to back, at most max_catch_up, then skip the rest: simulated
             // time keeps pace with the wall clock after short stalls
  kSkip,     // drop missed periods and resume at the next deadline: sim time falls behind wall time
};

// When the loop computes in estimate mode.
enum class Trigger {
  kTick,     // at the fixed rate (the default): each tick evaluates the newest measured state
  kArrival,  // on arrival of a measured state (event-driven): the loop sleeps until the receive
             // thread hands it a state and publishes that state's wrenches at once, one output per
             // state the loop takes (a newer state arriving during a computation replaces any
             // waiting one: the newest wins, as at a tick). While no fresh state is held (none
             // yet, or the last one expired by the watchdog) it publishes the error status at
             // rate_hz as the fixed-rate path does. Estimate mode only.
};

// realtime.sched_fifo: whether the loop thread asks for SCHED_FIFO at `priority`.
enum class SchedFifo {
  kAuto,  // the default: SCHED_FIFO when the process may take it (root or CAP_SYS_NICE; else logged,
          // the loop runs SCHED_OTHER), except with busy_poll without a cpu of its own (a polling
          // loop at real-time priority would hold a shared CPU); the loop steps down to SCHED_OTHER
          // by itself when it would hog its CPU (runtime/fifo_guard.h). Fewer overruns on a loaded
          // machine than false (bench/README.md, "Loop timing")
  kOn,    // SCHED_FIFO at `priority`, never stepped down (a lab that gives the loop its own CPU)
  kOff,   // SCHED_OTHER
};

struct RealtimeOptions {
  SchedFifo sched_fifo = SchedFifo::kAuto;
  int priority = 80;        // 1..99
  // The receive process and the receive thread, when the loop asks for SCHED_FIFO: SCHED_FIFO at
  // this priority, below the loop's (0: SCHED_OTHER). Under sched_fifo auto both step down to
  // SCHED_OTHER when either would hog its CPU (a flood), as the loop does. 0 by default: a real-time
  // receive path made a state's publish to wrenches on arrival slower on a loaded machine, and it
  // spends what a flood from another host costs (bench/README.md, "Commands under a flood of junk").
  int receive_priority = 0;
  int cpu = -1;             // pin the loop thread to this CPU; -1: no affinity. The receive thread,
                            // the receive process and the publisher thread are then kept off this CPU
  bool mlockall = false;    // lock current and future pages (no page faults in the loop)
  // Fixed-rate loop: wake spin_us before each deadline, evaluate the held state once (warming the
  // caches and TLB after the sleep; the result is discarded) and poll the clock to the deadline (a
  // busy wait: the loop's CPU is ~spin_us * rate_hz / 1e6 busier, 5 % for 50 us at 1 kHz); 0: off.
  // [0, 1000] us and below the period.
  int spin_us = 0;
  // Hold /dev/cpu_dma_latency at 0 while running (the PM QoS request cyclictest makes: no deep
  // C-states, so no exit latency on wake-up and the loop's caches not flushed by a deep idle state
  // between ticks; needs root, else logged and ignored; the whole machine draws more power while the
  // daemon runs). On by default: it brings the in-place tick closer to the warm tick (bench/README.md,
  // "Loop timing").
  bool cpu_dma_latency_zero = true;
  // Event-driven estimate mode (trigger: arrival) only: the loop thread never sleeps waiting for a
  // state but polls for one, so no wake-up stands between a state's receipt and its computation.
  // It takes a whole CPU at all times: give it one (cpu, ideally isolated from the scheduler with
  // isolcpus), with sched_fifo. Off by default.
  bool busy_poll = false;
  // Event-driven estimate mode (trigger: arrival) only: the loop's thread reads the input socket
  // itself (io/transport/rx_in_loop.h) instead of taking states from the isolated receive process's ring; a
  // state then goes from the kernel to the loop with one wake-up (none with busy_poll), through the
  // same bounded parser and checks, but that parser runs in the daemon's process. Off by default.
  bool receive_in_loop = false;
  // Fixed-rate loop (trigger: tick): the loop encodes each output and hands the bytes to a publisher
  // thread (runtime/publisher_thread.h), which calls lcm_publish; the send and the kernel's delivery
  // to the host's subscribers (their wake-ups) leave the loop's thread and, with cpu, its CPU. Each
  // output then leaves one thread wake-up later. false: the loop publishes itself. On arrival
  // (trigger: arrival) the loop always publishes itself: no wake-up between a state and its wrenches.
  bool publisher_thread = true;
};

// What each value may be: the range the code can represent and the daemon can use. load_config and
// validate() reject anything outside with the limits in the message.
//   rate_hz         [1, 20000] Hz: the loop's period (1e9 / rate_hz ns) and dt = 1 / rate_hz; below
//                   1 Hz it is no control loop (a 1 s step), above 20 kHz an RK4 step of the largest
//                   shipped scene no longer fits a period (bench/README.md)
//   watchdog_ms     [1, 3600000] ms: watchdog_ns() stays far inside 64 bits; a command is never held
//                   for more than an hour, and a watchdog below 1 ms is below the receive jitter
//   stats_period_s  [1 / rate_hz, 3600] s: at least one tick per window, at most an hour (at most
//                   7.2e7 ticks per window, well inside the histograms' counters)
//   max_catch_up    [0, 1000] ticks
//   max_input_age_ms  0 (off) or [1, 3600000] ms, like watchdog_ms
//   realtime.receive_priority  0 (SCHED_OTHER) or 1..priority - 1
//   realtime.cpu    -1 or [0, CPU_SETSIZE - 1 = 1023]: the bit must exist in a cpu_set_t
//   realtime.spin_us  [0, 1000] us and below the period (1e6 / rate_hz us)
//   trigger         tick, or arrival in estimate mode only
//   realtime.busy_poll, realtime.receive_in_loop  with trigger arrival only
//   closure_tolerance.*  (0, 1e6] in m, rad, m/s, rad/s
//   receive.queue   [2, 4096] messages; receive.max_message_bytes [256, 4194304] bytes
//   receive.socket_buffer_bytes  0 (the OS default) or [4096, 268435456] bytes (SO_RCVBUF takes an
//                   int; the kernel caps a request at net.core.rmem_max unless the receive process may
//                   use SO_RCVBUFFORCE (CAP_NET_ADMIN), and the daemon logs what it got)
//   channel names   1..63 characters (LCM_MAX_CHANNEL_NAME_LENGTH); lcm_url 1..1024 characters
inline constexpr double kMinRateHz = 1.0, kMaxRateHz = 20000.0;
inline constexpr double kMinWatchdogMs = 1.0, kMaxWatchdogMs = 3600.0e3;
inline constexpr double kMaxStatsPeriodS = 3600.0;
inline constexpr int kMaxCatchUp = 1000;
inline constexpr int kMaxCpu = 1023;
inline constexpr int kMaxChannelChars = 63;
inline constexpr int kMaxUrlChars = 1024;
inline constexpr int kMinSocketBufferBytes = 4096, kMaxSocketBufferBytes = 268435456;

struct ServiceConfig {
  double rate_hz = 1000.0;
  std::string lcm_url = "udpm://239.255.76.67:7667?ttl=0";  // outputs and stats (and inputs, unless lcm_url_in)
  // Inputs (commands or measured states), received in the isolated child process (io/transport/rx_isolated.h).
  // Empty: lcm_url. Give it its own port or group so that the receiver never sees the daemon's
  // outputs and a flood on one URL cannot crowd out the other.
  std::string lcm_url_in;
  int receive_queue = 64;             // messages the child can queue for the daemon (ring slots)
  int receive_max_bytes = 65536;      // largest input message accepted, bytes (larger: dropped, counted)
  // SO_RCVBUF of the receive socket, bytes (16 MiB: some 10,000 small datagrams, so that a flood
  // does not overflow it while the receive process waits for a CPU on a loaded machine; 4 MiB did,
  // bench/README.md); 0: the URL's recv_buf_size, else the OS default
  int receive_socket_buffer = 16777216;
  std::string command_channel = "COOPDYN_COMMAND";
  std::string state_channel = "COOPDYN_STATE";
  std::string output_channel = "COOPDYN_OUTPUT";
  std::string stats_channel = "COOPDYN_STATS";
  std::string control_channel = "COOPDYN_CONTROL";  // control_t in (reset, pause, resume, clear fault)
  // Authenticated inputs (io/transport/auth.h): the shared key's file; "" = off. With a key, commands, states
  // and controls must carry a good HMAC and a utime above the last accepted one on their channel.
  std::string auth_key_file;
  ServiceMode mode = ServiceMode::kSimulate;
  Trigger trigger = Trigger::kTick;  // estimate mode: compute at each tick or on arrival of a state
  Integrator integrator = Integrator::kRk4;
  double watchdog_ms = 100.0;  // a command (state) older than this expires
  // A command (state) whose utime is <= 0 or differs from this host's wall clock by more than this
  // is rejected on arrival; 0: off (a sender without a wall clock). On by default: coopdyn send
  // and any LCM sender stamp utime with the wall clock, and 1 s is far above both the delivery
  // time (< 1 ms on one host) and the offset of NTP-synchronized hosts on a LAN (~1 ms).
  double max_input_age_ms = 1000.0;
  // Estimate mode: the largest closure residual (state_fit.h) a measured state may have for its
  // wrenches to be published; above, the output is STATUS_ERROR with REASON_CLOSURE and says which
  // constraint and how far. Order: position m, orientation rad, linear velocity m/s, angular
  // velocity rad/s. The defaults are a few times what joint encoders, a robot's calibration and
  // differentiated joint velocities give on a metre-size arm (1e-4 rad of encoder error is 0.1 mm
  // at 1 m); they flag a wrong joint, a wrong sign, a slipped grasp or a wrong robot file.
  double closure_tolerance[4] = {5e-3, 2e-2, 5e-2, 2e-1};
  // Estimate mode: the joints' damping and Coulomb friction (the scene's) taken out of the measured
  // torques from the measured velocity, at rest the friction's interval reported as each wrench's
  // bound (friction_bound.h); false: the measured torques taken as reaching the links.
  bool compensate_joint_losses = true;
  SafeTorque safe_torque = SafeTorque::kHold;
  double damping = 0.0;        // N*m*s/rad (or N*s/m) for kDamping, added to kHold's brake
  double time_constant = 0.1;  // s, kHold: every velocity decays as exp(-t / time_constant); 0: no brake
  OverrunPolicy overrun = OverrunPolicy::kCatchUp;
  int max_catch_up = 10;       // ticks
  double stats_period_s = 1.0;
  RealtimeOptions realtime;
  std::string log_level = "info";

  long long period_ns() const { return static_cast<long long>(1e9 / rate_hz + 0.5); }
  long long watchdog_ns() const { return static_cast<long long>(watchdog_ms * 1e6 + 0.5); }
  const std::string& input_url() const { return lcm_url_in.empty() ? lcm_url : lcm_url_in; }
  long long max_input_age_us() const { return static_cast<long long>(max_input_age_ms * 1e3 + 0.5); }
};

// Reads a config file; keys absent keep the defaults above. Throws ConfigError with
// "file:line:col: reason" on a missing file, YAML error, unknown key or bad value.
ServiceConfig load_config(const std::string& path);
ServiceConfig load_config_string(const std::string& yaml_text, const std::string& name_for_errors);
// Re-checks values (after command-line overrides); throws ConfigError.
void validate(const ServiceConfig& c);

// The table of keys of docs/reference/config.md (key, default, range, meaning), one row per key in
// the order of the loader; coopdynd --print-config-reference prints it.
std::string config_reference_markdown();

// Whether the loop thread asks for SCHED_FIFO under these options (sched_fifo true, or auto and not
// busy-polling without a cpu of its own); whether it gets it depends on the process's privileges.
bool loop_asks_fifo(const RealtimeOptions& o);

const char* mode_name(ServiceMode m);
bool parse_mode(const std::string& s, ServiceMode* m);
const char* trigger_name(Trigger t);
bool parse_trigger(const std::string& s, Trigger* t);

}  // namespace coopdyn::runtime
