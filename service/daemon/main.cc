// coopdynd: the real-time constrained-dynamics service.
//
//   coopdynd --scene FILE [--config FILE] [--lcm-url URL] [--mode simulate|estimate]
//            [--rate HZ] [--duration S]      (coopdynd --help: the options and their defaults)
//
// Processes and threads: the loop (ServiceLoop::run, thread coopdynd-loop; SCHED_FIFO as root under
// realtime.sched_fifo auto, stepped down if it hogs its CPU) never receives; at the
// fixed rate it hands its encoded outputs to the publisher thread (runtime/publisher_thread.h), which
// publishes them through LCM (realtime.publisher_thread; on arrival the loop publishes itself); inputs arrive in a supervised child process (coopdynd --rx-child,
// io/rx_isolated.h: its own UDP socket and LCM wire parser, no liblcm) that copies raw bytes into a shared ring, drained by the receive thread here
// (-> decode -> triple buffer), which also restarts the child when it dies (trigger: arrival: the
// loop drains the ring itself, woken by the child, and the receive thread only supervises); spdlog's async logger
// thread; and this main
// thread, which waits for SIGINT/SIGTERM (or --duration), drains the loop's event ring into the log
// and prints the summary line at exit.
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>
#include <spdlog/async.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <future>
#include <string>
#include <system_error>
#include <thread>

#include "service/dynamics/constrained_dynamics.h"
#include "service/io/auth.h"
#include "service/io/codec.h"
#include "service/io/lcm_bus.h"
#include "service/io/rx_in_loop.h"
#include "service/io/rx_isolated.h"
#include "service/runtime/config.h"
#include "service/runtime/publisher_thread.h"
#include "service/runtime/socket_arrivals.h"
#include "service/runtime/realtime.h"
#include "service/runtime/service_loop.h"
#include "service/scene/scene.h"
#include "service/version.h"

namespace {

std::atomic<bool> g_stop{false};
std::atomic<int> g_signal{0};
void on_signal(int sig) {
  g_signal.store(sig);
  g_stop.store(true);
}

bool parse_double(const char* s, double* out) {
  char* end = nullptr;
  *out = std::strtod(s, &end);
  return end && *end == 0 && end != s && std::isfinite(*out);
}

// why a FifoGuard (runtime/fifo_guard.h) stepped a thread down; share: its busy share of the window
std::string fifo_verdict_text(int64_t verdict, double share) {
  using V = coopdyn::runtime::FifoGuard::Verdict;
  if (static_cast<V>(verdict) == V::kBusy)
    return fmt::format("busy {:.0f} % of a stats window (more than {:.0f} %)", 100 * share,
                       100 * coopdyn::runtime::FifoGuard::kMaxBusyShare);
  return fmt::format("at least {:.0f} % of its ticks overran in {} stats windows in a row",
                     100 * coopdyn::runtime::FifoGuard::kOverrunShare, coopdyn::runtime::FifoGuard::kOverrunWindows);
}

void log_event(const coopdyn::System& sys, const coopdyn::runtime::Event& e) {
  using coopdyn::runtime::EventCode;
  switch (e.code) {
    case EventCode::kCommandExpired:
      spdlog::warn("command seq {} expired after {} ms: applying the safe torque", e.a, e.b);
      break;
    case EventCode::kCommandResumed: spdlog::info("commands resumed (seq {})", e.a); break;
    case EventCode::kStateExpired:
      spdlog::warn("measured state seq {} expired after {} ms: publishing error status", e.a, e.b);
      break;
    case EventCode::kStateResumed: spdlog::info("measured states resumed (seq {})", e.a); break;
    case EventCode::kFault:
      spdlog::error("numerical failure at tick {} (t = {:.3f} s): {}; simulation stopped, publishing error status",
                    e.b, e.x, coopdyn::reason_text(static_cast<coopdyn::Reason>(e.a)));
      break;
    case EventCode::kControl:
      spdlog::info("control seq {}: {}: {}", e.a, coopdyn::io::control_action_name(static_cast<coopdyn::io::ControlAction>(e.b / 16)),
                   coopdyn::io::control_result_name(static_cast<coopdyn::io::ControlResult>(e.b % 16 - 1)));
      break;
    case EventCode::kClosureOpen: {
      const int kind = static_cast<int>(e.b / 65536), spec = static_cast<int>(e.b % 65536) - 1;
      const auto& specs = sys.constraints.specs;
      spdlog::warn("measured state seq {} does not close the constraints: {} residual {:.3g} {} at '{}' (above "
                   "closure_tolerance); publishing error status (REASON_CLOSURE) until a state closes",
                   e.a, coopdyn::closure_kind_name(kind), e.x, coopdyn::closure_kind_unit(kind),
                   spec >= 0 && spec < static_cast<int>(specs.size()) ? specs[spec].name : std::string("?"));
      break;
    }
    case EventCode::kClosureBack: spdlog::info("measured states close the constraints again (seq {})", e.a); break;
    case EventCode::kResetRejected: spdlog::warn("control seq {}: {}", e.a, coopdyn::runtime::reset_refusal_text(sys, e)); break;
    case EventCode::kFifoDemoted:
      if (e.a > 0)
        spdlog::warn("the loop stepped down from SCHED_FIFO to SCHED_OTHER at tick {}: {} (realtime.sched_fifo auto "
                     "never lets it hog its CPU; sched_fifo: true keeps the priority, on a CPU of its own)",
                     e.b, fifo_verdict_text(e.a, e.x));
      else
        spdlog::error("the loop should step down from SCHED_FIFO at tick {} ({}) but the kernel refused", e.b,
                      fifo_verdict_text(-e.a, e.x));
      break;
    case EventCode::kOverrun: break;  // aggregated by OverrunReport
  }
}

// Overruns come in bursts on a loaded machine: one warning per second at most, with the count.
struct OverrunReport {
  long bursts = 0;
  long long worst = 0, first_tick = -1;
  std::chrono::steady_clock::time_point last = std::chrono::steady_clock::now();
  void add(const coopdyn::runtime::Event& e) {
    if (e.code != coopdyn::runtime::EventCode::kOverrun) return;
    if (first_tick < 0) first_tick = e.b;
    ++bursts;
    worst = std::max<long long>(worst, e.a);
  }
  void flush(bool force) {
    const auto now = std::chrono::steady_clock::now();
    if (bursts == 0 || (!force && now - last < std::chrono::seconds(1))) return;
    spdlog::warn("{} overrun burst(s) since tick {} (worst {} period(s) behind); policy applied, see loop_stats_t",
                 bursts, first_tick, worst);
    bursts = 0;
    worst = 0;
    first_tick = -1;
    last = now;
  }
};

// The command line, as given (coopdynd --help lists the options).
struct Options {
  std::string scene_path, config_path, url_override, mode_override, trigger_override;
  double rate_override = 0;  // Hz; 0: the config's rate_hz
  double duration = -1;      // s; < 0: until SIGINT or SIGTERM
};

// parse: argv -> Options. Returns -1 to go on, else the exit code (0 after --help or --version, 2
// for a bad option).
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

// load: the config (with the command line's overrides) and the scene. Every problem stops here,
// with a clear message; returns -1 to go on, else the exit code.
int load(const Options& o, coopdyn::runtime::ServiceConfig* cfg_out, coopdyn::System* sys_out) {
  using namespace coopdyn;
  runtime::ServiceConfig& cfg = *cfg_out;
  try {
    if (!o.config_path.empty()) cfg = runtime::load_config(o.config_path);
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

// logging: asynchronous, never called from the loop thread
void start_logging(const coopdyn::runtime::ServiceConfig& cfg) {
  spdlog::init_thread_pool(1024, 1);
  auto logger = std::make_shared<spdlog::async_logger>(
      "coopdynd", std::make_shared<spdlog::sinks::stderr_color_sink_mt>(), spdlog::thread_pool(),
      spdlog::async_overflow_policy::overrun_oldest);
  spdlog::set_default_logger(logger);
  spdlog::set_level(spdlog::level::from_str(cfg.log_level));
  spdlog::set_pattern("[%H:%M:%S.%e] [coopdynd] [%^%l%$] %v");
}

// outputs: at the fixed rate from a publisher thread kept off the loop's CPU (realtime.publisher_thread);
// on arrival, or with it off, the loop publishes itself (nullptr)
std::unique_ptr<coopdyn::runtime::PublisherThread> make_publisher(const coopdyn::System& sys,
                                                                   const coopdyn::runtime::ServiceConfig& cfg,
                                                                   coopdyn::io::Bus& bus) {
  using namespace coopdyn;
  const bool arrival = cfg.mode == runtime::ServiceMode::kEstimate && cfg.trigger == runtime::Trigger::kArrival;
  if (!cfg.realtime.publisher_thread || arrival) {
    spdlog::info("outputs published by the loop thread{}", arrival && cfg.realtime.publisher_thread
                                                               ? " (on arrival: no wake-up between a state and its wrenches)"
                                                               : "");
    return nullptr;
  }
  const int max_bytes = runtime::ServiceLoop::max_message_bytes(sys);
  auto p = std::make_unique<runtime::PublisherThread>(bus, max_bytes);
  try {
    p->start(cfg.realtime.cpu);
  } catch (const std::system_error& e) {  // no thread to be had (a process or cgroup limit)
    spdlog::warn("publisher thread not started ({}): the loop publishes its outputs itself", e.what());
    return nullptr;
  }
  spdlog::info("outputs published by a publisher thread{} ({} slots of {} bytes)",
               cfg.realtime.cpu >= 0 ? " off the loop's CPU" : "", runtime::PublisherThread::kSlots, max_bytes);
  return p;
}

// inputs: received by a supervised child process, never by this one (the bus only publishes)
std::unique_ptr<coopdyn::io::IsolatedReceiver> make_receiver(const coopdyn::runtime::ServiceConfig& cfg) {
  using namespace coopdyn;
  // the receive process reads udpm only: a malformed udpm URL stops here, another transport is said
  io::wire::UdpmUrl u;
  std::string why;
  const std::string in = cfg.input_url();
  if (!io::wire::parse_udpm_url(in, &u, &why)) {
    if (in.empty() || in.rfind("udpm://", 0) == 0) throw std::runtime_error("input URL: " + why);
    spdlog::warn("inputs on '{}' are not received: the receive process reads udpm:// only (memq:// is in-process)", in);
  }
  char exe[4096];
  const ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (n <= 0) throw std::runtime_error("cannot find its own executable (/proc/self/exe)");
  exe[n] = 0;
  auto rx = std::make_unique<io::IsolatedReceiver>(
      exe, cfg.input_url(),
      std::vector<std::string>{cfg.mode == runtime::ServiceMode::kSimulate ? cfg.command_channel : cfg.state_channel,
                               cfg.control_channel},
      std::vector<int64_t>{io::fingerprint(cfg.mode == runtime::ServiceMode::kSimulate ? io::MessageType::kTorqueCommand
                                                                                        : io::MessageType::kMeasuredState),
                           io::fingerprint(io::MessageType::kControl)},
      cfg.receive_queue, cfg.receive_max_bytes, cfg.receive_socket_buffer);
  // authentication on: the receive process verifies MACs before its ring (a flood of forged inputs
  // cannot fill it); the inboxes verify again
  if (!cfg.auth_key_file.empty()) rx->set_auth_key(io::read_key_file(cfg.auth_key_file));
  return rx;
}

// realtime.receive_in_loop: the input socket read by the loop's thread itself (io/rx_in_loop.h),
// through the receive process's gate; estimate mode on arrival only (the config says so)
std::unique_ptr<coopdyn::io::InLoopReceiver> make_in_loop_receiver(const coopdyn::runtime::ServiceConfig& cfg) {
  using namespace coopdyn;
  auto rx = std::make_unique<io::InLoopReceiver>(
      cfg.input_url(), std::vector<std::string>{cfg.state_channel, cfg.control_channel},
      std::vector<int64_t>{io::fingerprint(io::MessageType::kMeasuredState), io::fingerprint(io::MessageType::kControl)},
      cfg.receive_max_bytes, cfg.receive_socket_buffer);
  if (!cfg.auth_key_file.empty()) rx->set_auth_key(io::read_key_file(cfg.auth_key_file));
  return rx;
}

// The receive process's counters into the loop's statistics (any thread): restarts, drops, refusals
// and its rejections by reason (malformed; with authentication on also unauthenticated, bad MAC,
// replayed), channel 0 the input, 1 the control channel
void feed_receiver_counters(coopdyn::runtime::ServiceLoop& loop, const coopdyn::io::ReceiverCounters& rx) {
  using namespace coopdyn;
  loop.set_receiver_counters(rx.restarts(), rx.dropped(), rx.filtered(), rx.malformed());
  int64_t input[io::kRejectKinds], control[io::kRejectKinds];
  for (int k = 0; k < io::kRejectKinds; ++k) {
    input[k] = rx.rejected(0, static_cast<io::Reject>(k));
    control[k] = rx.rejected(1, static_cast<io::Reject>(k));
  }
  loop.set_receiver_rejections(input, control);
}

void log_startup(const coopdyn::System& sys, const coopdyn::runtime::ServiceConfig& cfg, const std::string& scene_path) {
  using namespace coopdyn;
  int by_kind[5] = {0, 0, 0, 0, 0};
  for (const WrenchOutput& o : sys.wrenches.outputs) ++by_kind[static_cast<int>(o.kind)];
  spdlog::info("scene '{}' from {}: nq {}, nv {}, {} constraint rows, formulation {}", sys.name, scene_path,
               sys.model.nq(), sys.model.nv(), sys.constraints.rows, formulation_name(sys.options.formulation));
  spdlog::info("wrenches out: {} end-effector, {} base, {} tip, {} axle, {} joint reactions; {} pseudo-joint stresses",
               by_kind[0], by_kind[1], by_kind[2], by_kind[3], by_kind[4], sys.model.pseudo_dofs.size());
  if (cfg.trigger == runtime::Trigger::kArrival)
    spdlog::info("event-driven: each measured state is evaluated on arrival, taken by the loop {}; without a fresh "
                 "state the error status goes out at {} Hz",
                 cfg.realtime.receive_in_loop ? "from the input socket itself (realtime.receive_in_loop: no receive process)"
                                              : "from the receive process's ring itself",
                 cfg.rate_hz);
  if (cfg.realtime.busy_poll)
    spdlog::info("busy poll: the loop polls for measured states and takes a whole CPU{}", cfg.realtime.cpu >= 0 ? ""
                 : " (realtime.cpu not set: give it one of its own)");
  spdlog::info("mode {}, {} Hz ({} integrator), watchdog {} ms, max input age {}, safe torque {}, overrun policy {}",
               runtime::mode_name(cfg.mode), cfg.rate_hz, integrator_name(cfg.integrator), cfg.watchdog_ms,
               cfg.max_input_age_ms > 0 ? std::to_string(cfg.max_input_age_ms) + " ms by utime" : std::string("off"),
               cfg.safe_torque == runtime::SafeTorque::kZero   ? "zero"
               : cfg.safe_torque == runtime::SafeTorque::kHold ? "hold"
                                                               : "damping",
               cfg.overrun == runtime::OverrunPolicy::kSkip ? "skip"
                                                           : "catch_up (max " + std::to_string(cfg.max_catch_up) + ")");
  if (!cfg.auth_key_file.empty())
    spdlog::info("authentication on (key {}): inputs need an HMAC-SHA256 and a utime above the last accepted; "
                 "unsigned, bad-MAC and replayed ones are rejected", cfg.auth_key_file);
  else
    spdlog::info("authentication off: any host that reaches the input URL can command (auth.key_file turns it on)");
  spdlog::info("LCM in {}: {} {} ({}); out {}: {} (output), {} (stats every {} s)", cfg.input_url(),
               cfg.mode == runtime::ServiceMode::kSimulate ? "commands on" : "measured states on",
               cfg.mode == runtime::ServiceMode::kSimulate ? cfg.command_channel : cfg.state_channel,
               cfg.realtime.receive_in_loop
                   ? "read by the loop's thread, messages up to " + std::to_string(cfg.receive_max_bytes) + " bytes"
                   : "isolated receive process, queue " + std::to_string(cfg.receive_queue) + " x " +
                         std::to_string(cfg.receive_max_bytes) + " bytes",
               cfg.lcm_url, cfg.output_channel, cfg.stats_channel, cfg.stats_period_s);
}

void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

// Rejected inputs: counted per reason by the receive thread, logged by the main thread at most
// once per second with the counts since the last line.
struct RejectionReport {
  std::atomic<long long> rejected_by[coopdyn::io::kRejectKinds] = {};
  std::atomic<long long> out_of_order{0};
  long long missed_logged = 0, filtered_logged = 0;
  long long rx_rejected_logged[coopdyn::io::kRejectKinds] = {};  // by the receive process, before its ring
  long long malformed_logged[coopdyn::io::wire::kWireStatuses] = {};
  std::chrono::steady_clock::time_point last_report = std::chrono::steady_clock::now() - std::chrono::seconds(2);
  void flush(bool force, const coopdyn::runtime::ServiceLoop& loop, const coopdyn::io::ReceiverCounters& rx);
};

void RejectionReport::flush(bool force, const coopdyn::runtime::ServiceLoop& loop,
                            const coopdyn::io::ReceiverCounters& rx) {
  using namespace coopdyn;
  const auto now = std::chrono::steady_clock::now();
  if (!force && now - last_report < std::chrono::seconds(1)) return;
  std::string what;
  for (int r = 1; r < io::kRejectKinds; ++r) {
    const long long in_rx = rx.rejected(0, static_cast<io::Reject>(r)) + rx.rejected(1, static_cast<io::Reject>(r));
    const long long k = rejected_by[r].exchange(0) + in_rx - rx_rejected_logged[r];
    rx_rejected_logged[r] = in_rx;
    if (k) what += (what.empty() ? "" : ", ") + std::to_string(k) + " " + io::reject_name(static_cast<io::Reject>(r));
  }
  if (const long long k = out_of_order.exchange(0))
    what += (what.empty() ? "" : ", ") + std::to_string(k) + " out of order (seq not above the last accepted)";
  if (const long long m = loop.input_counters().missed.load(); m > missed_logged) {
    what += (what.empty() ? "" : ", ") + std::to_string(m - missed_logged) + " missing from the sender's seq (lost on the way)";
    missed_logged = m;
  }
  if (const long long f = rx.filtered(); f > filtered_logged) {
    what += (what.empty() ? "" : ", ") + std::to_string(f - filtered_logged) + " not coopdyn messages (refused by the receive path)";
    filtered_logged = f;
  }
  std::string wire;  // malformed datagrams, by the wire parser's reason
  for (int k = 0; k < io::wire::kWireStatuses; ++k) {
    const long long m = rx.malformed(static_cast<io::wire::WireStatus>(k));
    if (m > malformed_logged[k]) wire += (wire.empty() ? "" : ", ") + std::to_string(m - malformed_logged[k]) + " " +
                                         io::wire::wire_status_text(static_cast<io::wire::WireStatus>(k));
    malformed_logged[k] = m;
  }
  if (!wire.empty()) what += (what.empty() ? "" : ", ") + std::string("malformed LCM datagrams (") + wire + ")";
  if (what.empty()) return;
  spdlog::warn("inputs not applied: {}", what);
  last_report = now;
  }

// One input from the receive process's ring into the loop's inbox of its type; what is not applied is
// counted for the log. Returns the offer's outcome. No allocation (the loop's thread runs it on arrival).
coopdyn::runtime::Offer offer_input(coopdyn::runtime::ServiceLoop& loop, bool simulate, RejectionReport& rejections,
                                    const void* d, int n, long long t) {
  using namespace coopdyn;
  io::Reject why = io::Reject::kNone;
  runtime::Offer r;
  if (io::identify(d, n) == io::MessageType::kControl) r = loop.controls().offer(d, n, t, &why);
  else if (simulate) r = loop.commands().offer(d, n, t, &why);
  else r = loop.states().offer(d, n, t, &why);
  if (r == runtime::Offer::kRejected) rejections.rejected_by[static_cast<int>(why) % io::kRejectKinds].fetch_add(1);
  if (r == runtime::Offer::kOutOfOrder) rejections.out_of_order.fetch_add(1);
  return r;
}

// trigger: arrival: the loop drains the receive process's ring itself, woken by the bell the process
// rings (io/rx_isolated.h drain_in_caller): no receive thread between a state's receipt and the loop
struct RingArrivals : coopdyn::runtime::ArrivalSource {
  coopdyn::io::IsolatedReceiver& rx;
  coopdyn::runtime::ServiceLoop& loop;
  RejectionReport& rejections;
  RingArrivals(coopdyn::io::IsolatedReceiver& r, coopdyn::runtime::ServiceLoop& l, RejectionReport& j)
      : rx(r), loop(l), rejections(j) {}
  uint32_t bell() const override { return rx.bell(); }
  void wait(uint32_t seen, long long deadline_ns) override { rx.wait_bell(seen, deadline_ns); }
  void drain() override {
    rx.drain([this](const void* d, int n, long long t) { offer_input(loop, false, rejections, d, n, t); });
  }
};

// the receive thread: offers each input to the loop's inboxes, counts what is not applied (unless
// the loop drains the ring itself: then it only supervises); logs the receive process's deaths
void start_receiving(coopdyn::io::IsolatedReceiver& rx, coopdyn::runtime::ServiceLoop& loop,
                     const coopdyn::runtime::ServiceConfig& cfg, RejectionReport& rejections) {
  using namespace coopdyn;
  const bool simulate = cfg.mode == runtime::ServiceMode::kSimulate;
  rx.start(
      [simulate, &loop, &rx, &rejections](const void* d, int n, long long t) {  // they outlive the receiver
        const runtime::Offer r = offer_input(loop, simulate, rejections, d, n, t);
        if (!simulate && r == runtime::Offer::kAccepted) loop.doorbell().ring();  // event-driven mode wakes on it
        feed_receiver_counters(loop, rx);
      },
      [&loop, &rx](int status, long long restarts) {
        loop.set_receiver_counters(restarts, rx.dropped(), rx.filtered(), rx.malformed());
        if (WIFSIGNALED(status))
          spdlog::error("receive process killed by signal {} ({}): restart {}; the loop keeps running, inputs resume "
                        "when it is back",
                        WTERMSIG(status), strsignal(WTERMSIG(status)), restarts);
        else
          spdlog::error("receive process exited with status {}: restart {}", WEXITSTATUS(status), restarts);
      });
}

// what the receive socket got: its buffer and its filter
void log_receive_socket(const coopdyn::io::ReceiverCounters& rx, const coopdyn::runtime::ServiceConfig& cfg) {
  // what the kernel granted (it caps SO_RCVBUF at net.core.rmem_max and reports twice the request)
  long long rmem_max = -1;
  if (std::FILE* f = std::fopen("/proc/sys/net/core/rmem_max", "r")) {
    if (std::fscanf(f, "%lld", &rmem_max) != 1) rmem_max = -1;
    std::fclose(f);
  }
  const long long got = rx.socket_buffer();
  if (cfg.receive_socket_buffer > 0 && got < 2LL * cfg.receive_socket_buffer)
    spdlog::warn("receive socket buffer: asked for {} bytes, the kernel grants {} (SO_RCVBUF reports {}; "
                 "net.core.rmem_max = {} caps it: raise it with sysctl -w net.core.rmem_max={}); a flood's "
                 "bursts may overflow it and valid inputs are lost with the junk (counted)",
                 cfg.receive_socket_buffer, got / 2, got, rmem_max, cfg.receive_socket_buffer);
  else if (cfg.receive_socket_buffer > 0)
    spdlog::info("receive socket buffer: {} bytes as configured (SO_RCVBUF reports {}: the kernel doubles a request "
                 "for its bookkeeping)", cfg.receive_socket_buffer, got);
  else
    spdlog::info("receive socket buffer: SO_RCVBUF {} bytes (the OS default, net.core.rmem_default; "
                 "receive.socket_buffer_bytes sets it)", got);
  if (rx.filter_state() == 1)
    spdlog::info("receive socket filter: only coopdyn messages on the input channels reach the receive path");
  else
    spdlog::warn("receive socket filter not attached ({}): every datagram on the input URL reaches the receive path, "
                 "which still refuses what is not a coopdyn message",
                 rx.filter_state() == -1 ? "the input URL is not udpm" : "the kernel refused it");
}

// outputs start only once inputs are received: waits (bounded) for the receive process to
// subscribe, then logs what its socket got
void wait_for_receiver(const coopdyn::io::IsolatedReceiver& rx, const coopdyn::runtime::ServiceConfig& cfg) {
  for (int i = 0; i < 400 && !rx.child_ready(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  if (!rx.child_ready()) spdlog::warn("the receive process has not subscribed after 2 s; starting anyway");
  else log_receive_socket(rx, cfg);
}

// The receive process and thread at SCHED_FIFO (realtime.receive_priority), under realtime.sched_fifo
// auto, under the same guard as the loop (runtime/fifo_guard.h), watched from the main thread: each stats window, the CPU time
// each took; one that was busy more than the guard allows (a flood) steps both down to SCHED_OTHER
// for the rest of the run, a respawned child included.
struct ReceiveFifoGuard {
  coopdyn::io::IsolatedReceiver* rx = nullptr;
  coopdyn::runtime::FifoGuard child, thread;
  long long window_ns = 0, start = -1, child0 = -1, thread0 = -1;
  long long demotions = 0;
  void check(long long now) {
    if (!rx || window_ns <= 0) return;
    const long long c = rx->child_cpu_ns(), t = rx->thread_cpu_ns();
    if (start < 0 || c < child0 || t < thread0) {  // the first window, or a new child (its clock restarts)
      start = now, child0 = c, thread0 = t;
      return;
    }
    if (now - start < window_ns) return;
    using V = coopdyn::runtime::FifoGuard::Verdict;
    const V vc = child.window(now - start, c - child0, 0, 0), vt = thread.window(now - start, t - thread0, 0, 0);
    if (vc != V::kKeep || vt != V::kKeep) {
      rx->set_fifo_priority(0);
      const bool ok = coopdyn::runtime::demote_to_other(rx->child_pid()) & coopdyn::runtime::demote_to_other(rx->thread_tid());
      ++demotions;
      spdlog::warn("the receive {} stepped down from SCHED_FIFO to SCHED_OTHER{}: busy {:.0f} % of {:.1f} s (more than "
                   "{:.0f} %: a flood?); inputs are still read, the loop keeps its priority",
                   vc != V::kKeep ? "process" : "thread", ok ? "" : " (refused by the kernel)",
                   100.0 * static_cast<double>(vc != V::kKeep ? c - child0 : t - thread0) / static_cast<double>(now - start),
                   1e-9 * static_cast<double>(now - start), 100 * coopdyn::runtime::FifoGuard::kMaxBusyShare);
      rx = nullptr;  // once
      return;
    }
    start = now, child0 = c, thread0 = t;
  }
};

// what realtime.receive_priority got: the receive process's and thread's policy, from the kernel
void log_receive_priority(const coopdyn::io::IsolatedReceiver& rx, const coopdyn::runtime::ServiceConfig& cfg) {
  const int want = cfg.realtime.receive_priority;
  if (want <= 0 || !coopdyn::runtime::loop_asks_fifo(cfg.realtime)) return;
  for (int i = 0; i < 100 && rx.thread_tid() == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const pid_t child = rx.child_pid(), tid = rx.thread_tid();
  if (child > 0 && tid > 0 && sched_getscheduler(child) == SCHED_FIFO && sched_getscheduler(tid) == SCHED_FIFO)
    spdlog::info("receive process and thread run SCHED_FIFO priority {}{}", want,
                 cfg.realtime.sched_fifo == coopdyn::runtime::SchedFifo::kAuto
                     ? " (stepped down to SCHED_OTHER if a flood keeps either busy)"
                     : " (realtime.sched_fifo true: never stepped down)");
  else
    spdlog::warn("receive process and thread: SCHED_FIFO priority {} refused (needs root or CAP_SYS_NICE); they run "
                 "SCHED_OTHER", want);
}

// run: the loop in its thread (real-time options applied there); this thread drains the loop's
// events into the log until a signal or the duration. Returns when the loop has stopped.
std::chrono::steady_clock::time_point run(coopdyn::runtime::ServiceLoop& loop, const coopdyn::System& sys,
                                          const coopdyn::runtime::ServiceConfig& cfg, double duration,
                                          const coopdyn::io::ReceiverCounters& rx, coopdyn::io::IsolatedReceiver* isolated,
                                          RejectionReport& rejections, ReceiveFifoGuard& rx_guard) {
  using namespace coopdyn;
  std::promise<std::vector<runtime::RealtimeResult>> rt_promise;
  auto rt_future = rt_promise.get_future();
  std::thread loop_thread([&] {
    prctl(PR_SET_NAME, "coopdynd-loop", 0, 0, 0);  // ps -L, top -H, /proc/PID/task/*/comm
    auto results = runtime::apply_realtime(cfg.realtime);
    loop.guard_fifo(cfg.realtime.sched_fifo == runtime::SchedFifo::kAuto && runtime::runs_fifo());
    rt_promise.set_value(std::move(results));
    loop.run(g_stop);
  });
  for (const auto& r : rt_future.get()) {
    if (r.ok) spdlog::info("{}", r.line);
    else spdlog::warn("{}", r.line);
  }
  spdlog::info("running; SIGINT or SIGTERM stops");

  const auto t_start = std::chrono::steady_clock::now();
  runtime::Event e;
  OverrunReport overruns;
  // sched_fifo: true keeps every priority it gives (a lab's CPUs); auto guards the receive path as the loop
  if (isolated && cfg.realtime.sched_fifo == runtime::SchedFifo::kAuto && cfg.realtime.receive_priority > 0) {
    rx_guard.rx = isolated;
    rx_guard.window_ns = static_cast<long long>(cfg.stats_period_s * 1e9);
  }
  while (!g_stop.load()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    rx_guard.check(io::monotonic_ns());
    while (loop.events().pop(&e)) {
      log_event(sys, e);
      overruns.add(e);
    }
    overruns.flush(false);
    rejections.flush(false, loop, rx);
    // the receive process's counters also move without a message reaching the daemon (refused datagrams)
    feed_receiver_counters(loop, rx);
    if (duration >= 0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count() >= duration)
      g_stop.store(true);
  }
  loop_thread.join();
  if (isolated) isolated->stop();
  feed_receiver_counters(loop, rx);  // the summary line counts what the receive process did last
  rejections.flush(true, loop, rx);
  while (loop.events().pop(&e)) {
    log_event(sys, e);
    overruns.add(e);
  }
  overruns.flush(true);
  return t_start;
}

// report: the summary line on stdout (the tests and scripts read it)
void print_summary(const coopdyn::runtime::ServiceLoop& loop, const coopdyn::runtime::ServiceConfig& cfg,
                   const coopdyn::io::ReceiverCounters& rx, std::chrono::steady_clock::time_point t_start,
                   long long rx_demotions) {
  using namespace coopdyn;
  const io::StatsFrame s = loop.totals();
  const runtime::InputCounters& ic = loop.input_counters();
  const long long stale = ic.by_reason[static_cast<int>(io::Reject::kStale)].load() +
                          ic.by_reason[static_cast<int>(io::Reject::kFuture)].load();
  const int sig = g_signal.load();
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  spdlog::shutdown();
  std::printf(
      "coopdynd: stopped (%s) after %lld ticks in %.1f s: overruns %lld, skipped %lld; %s received %lld, accepted %lld, "
      "rejected %lld, out-of-order %lld, expired %lld, stale utime %lld, missed (seq gaps) %lld; receiver restarts %lld, "
      "inputs dropped %lld, filtered %lld, malformed %lld, socket drops (kernel filter and overflow) %lld; "
      "numerical errors %lld; lateness us p50 %.1f p99 %.1f p99.9 %.1f "
      "max %.1f; compute us p50 %.1f p99 %.1f p99.9 %.1f max %.1f; SCHED_FIFO stepped down: loop %lld, receive %lld\n",
      sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : "duration", static_cast<long long>(s.tick), secs,
      static_cast<long long>(s.overruns), static_cast<long long>(s.skipped_periods),
      cfg.mode == runtime::ServiceMode::kSimulate ? "commands" : "states", static_cast<long long>(s.received),
      static_cast<long long>(s.accepted), static_cast<long long>(s.rejected), static_cast<long long>(s.out_of_order),
      static_cast<long long>(s.expired), stale, static_cast<long long>(ic.missed.load()), rx.restarts(), rx.dropped(),
      rx.filtered(), rx.malformed(), rx.socket_drops(), static_cast<long long>(s.numerical_errors), s.lateness_us[0], s.lateness_us[1],
      s.lateness_us[2], s.lateness_us[3], s.compute_us[0], s.compute_us[1], s.compute_us[2], s.compute_us[3],
      static_cast<long long>(loop.fifo_demotions()), rx_demotions);
  std::fflush(stdout);
}

}  // namespace

// parse -> load -> start (logging, bus, loop, receive process) -> run -> report
int main(int argc, char** argv) {
  using namespace coopdyn;
  // the isolated receive process (io/rx_isolated.h): this binary, exec'd by the daemon itself
  if (argc > 1 && std::strcmp(argv[1], "--rx-child") == 0) return io::rx_child_main(argc, argv);
  Options opt;
  if (const int rc = parse_args(argc, argv, &opt); rc >= 0) return rc;
  runtime::ServiceConfig cfg;
  System sys;
  if (const int rc = load(opt, &cfg, &sys); rc >= 0) return rc;

  start_logging(cfg);
  std::unique_ptr<io::LcmBus> bus;
  try {
    bus = std::make_unique<io::LcmBus>(cfg.lcm_url);
  } catch (const std::exception& e) {
    spdlog::shutdown();
    std::fprintf(stderr, "coopdynd: %s\n", e.what());
    return 1;
  }
  for (const std::string& w : sys.warnings) spdlog::warn("scene: {}", w);
  std::unique_ptr<runtime::PublisherThread> publisher = make_publisher(sys, cfg, *bus);
  runtime::ServiceLoop loop(sys, cfg, publisher ? static_cast<io::Bus&>(*publisher) : *bus);
  std::unique_ptr<io::IsolatedReceiver> isolated;
  std::unique_ptr<io::InLoopReceiver> in_loop;
  try {
    if (cfg.realtime.receive_in_loop) in_loop = make_in_loop_receiver(cfg);
    else isolated = make_receiver(cfg);
  } catch (const std::exception& e) {
    spdlog::shutdown();
    std::fprintf(stderr, "coopdynd: %s\n", e.what());
    return 1;
  }
  const io::ReceiverCounters& rx = isolated ? static_cast<const io::ReceiverCounters&>(*isolated) : *in_loop;
  log_startup(sys, cfg, opt.scene_path);
  install_signal_handlers();
  RejectionReport rejections;
  std::unique_ptr<runtime::ArrivalSource> arrivals;
  if (in_loop) {
    auto offer = [&loop, &rejections](const void* d, int n, long long t) { offer_input(loop, false, rejections, d, n, t); };
    arrivals = std::make_unique<runtime::SocketArrivals<decltype(offer)>>(*in_loop, offer);
    loop.take_arrivals_from(arrivals.get());
    log_receive_socket(*in_loop, cfg);
  } else {
    isolated->avoid_cpu(cfg.realtime.cpu);  // the receive thread and process stay off the loop's CPU
    if (runtime::loop_asks_fifo(cfg.realtime)) isolated->set_fifo_priority(cfg.realtime.receive_priority);
    if (cfg.trigger == runtime::Trigger::kArrival && cfg.mode == runtime::ServiceMode::kEstimate) {
      isolated->drain_in_caller();
      arrivals = std::make_unique<RingArrivals>(*isolated, loop, rejections);
      loop.take_arrivals_from(arrivals.get());
    }
    start_receiving(*isolated, loop, cfg, rejections);
    wait_for_receiver(*isolated, cfg);
    log_receive_priority(*isolated, cfg);
  }

  ReceiveFifoGuard rx_guard;
  const auto t_start = run(loop, sys, cfg, opt.duration, rx, isolated.get(), rejections, rx_guard);
  if (publisher) {
    publisher->stop();  // what the loop queued last goes out
    if (publisher->dropped() > 0)
      spdlog::warn("publisher thread: {} message(s) dropped (every slot still waiting: the thread did not get a CPU "
                   "for {} ticks)", publisher->dropped(), runtime::PublisherThread::kSlots);
    if (publisher->failed() > 0)
      spdlog::warn("publisher thread: lcm_publish failed for {} message(s)", publisher->failed());
  }
  print_summary(loop, cfg, rx, t_start, rx_guard.demotions);
  return 0;
}
