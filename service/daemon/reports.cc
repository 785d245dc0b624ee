#include "service/daemon/reports.h"

#include <sched.h>
#include <signal.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <thread>

#include "service/dynamics/constrained_dynamics.h"
#include "service/io/codec/codec.h"
#include "service/io/transport/multicast_route.h"
#include "service/runtime/fifo_guard.h"

namespace coopdyn::daemon {

namespace {

// why a FifoGuard (runtime/fifo_guard.h) stepped a thread down; share: its busy share of the window
std::string fifo_verdict_text(int64_t verdict, double share) {
  using V = coopdyn::runtime::FifoGuard::Verdict;
  if (static_cast<V>(verdict) == V::kBusy)
    return fmt::format("busy {:.0f} % of a stats window (more than {:.0f} %)", 100 * share,
                       100 * coopdyn::runtime::FifoGuard::kMaxBusyShare);
  return fmt::format("at least {:.0f} % of its ticks overran in {} stats windows in a row",
                     100 * coopdyn::runtime::FifoGuard::kOverrunShare, coopdyn::runtime::FifoGuard::kOverrunWindows);
}

}  // namespace

void OverrunReport::add(const coopdyn::runtime::Event& e) {
  if (e.code != coopdyn::runtime::EventCode::kOverrun) return;
  if (first_tick < 0) first_tick = e.b;
  ++bursts;
  worst = std::max<long long>(worst, e.a);
}

void OverrunReport::flush(bool force) {
  const auto now = std::chrono::steady_clock::now();
  if (bursts == 0 || (!force && now - last < std::chrono::seconds(1))) return;
  spdlog::warn("{} overrun burst(s) since tick {} (worst {} period(s) behind); policy applied, see loop_stats_t",
               bursts, first_tick, worst);
  bursts = 0;
  worst = 0;
  first_tick = -1;
  last = now;
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
    case EventCode::kLimitPassed: {
      const int d = static_cast<int>(e.a);
      std::string kinds;
      for (int k = 0; k < 3; ++k)
        if (e.b & (1 << k))
          kinds += (kinds.empty() ? "" : " and ") + std::string(limit_word(static_cast<LimitBit>(1 << k)));
      spdlog::warn("t = {:.3f} s: joint {} passes its {} limit (the first time; loop_stats_t counts every tick over a "
                   "limit)", e.x, d >= 0 && d < sys.model.nv() ? sys.model.v_names[d] : std::string("?"), kinds);
      break;
    }
    case EventCode::kOverrun: break;  // aggregated by OverrunReport
  }
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
    spdlog::info("authentication on (key {}): inputs need an HMAC-SHA256 and a utime above the last accepted and "
                 "the daemon's start; unsigned, bad-MAC and replayed ones are rejected", cfg.auth_key_file);
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
  // a ttl=0 URL whose multicast leaves by eth0 (no route on lo) loses large messages on this host
  if (const std::string why = io::loopback_multicast_problem(cfg.lcm_url); !why.empty()) spdlog::warn("{}", why);
  if (cfg.input_url() != cfg.lcm_url)
    if (const std::string why = io::loopback_multicast_problem(cfg.input_url()); !why.empty()) spdlog::warn("{}", why);
}

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
  if (const long long k = rx.socket_drops(); log_socket_drops && k > socket_drops_logged) {
    what += (what.empty() ? "" : ", ") + std::to_string(k - socket_drops_logged) +
            " dropped by the kernel at the receive socket (not coopdyn messages of the input channels, or its buffer full)";
    socket_drops_logged = k;
  }
  if (what.empty()) return;
  spdlog::warn("inputs not applied: {}", what);
  last_report = now;
}

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

void print_summary(const coopdyn::runtime::ServiceLoop& loop, const coopdyn::runtime::ServiceConfig& cfg,
                   const coopdyn::io::ReceiverCounters& rx, std::chrono::steady_clock::time_point t_start,
                   long long rx_demotions, int sig) {
  using namespace coopdyn;
  const io::StatsFrame s = loop.totals();
  const runtime::InputCounters& ic = loop.input_counters();
  const long long stale = ic.by_reason[static_cast<int>(io::Reject::kStale)].load() +
                          ic.by_reason[static_cast<int>(io::Reject::kFuture)].load();
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  spdlog::shutdown();
  std::printf(
      "coopdynd: stopped (%s) after %lld ticks in %.1f s: overruns %lld, skipped %lld; %s received %lld, accepted %lld, "
      "rejected %lld, out-of-order %lld, expired %lld, stale utime %lld, missed (seq gaps) %lld; receiver restarts %lld, "
      "inputs dropped %lld, filtered %lld, malformed %lld, "
      "socket filter discards (other channels, own outputs included) and overflow %lld; "
      "numerical errors %lld; lateness us p50 %.1f p99 %.1f p99.9 %.1f "
      "max %.1f; compute us p50 %.1f p99 %.1f p99.9 %.1f max %.1f; SCHED_FIFO stepped down: loop %lld, receive %lld\n",
      sig == SIGINT    ? "SIGINT"
      : sig == SIGTERM ? "SIGTERM"
      : sig == SIGHUP  ? "SIGHUP"
      : sig == SIGQUIT ? "SIGQUIT"
                       : "duration",
      static_cast<long long>(s.tick), secs,
      static_cast<long long>(s.overruns), static_cast<long long>(s.skipped_periods),
      cfg.mode == runtime::ServiceMode::kSimulate ? "commands" : "states", static_cast<long long>(s.received),
      static_cast<long long>(s.accepted), static_cast<long long>(s.rejected), static_cast<long long>(s.out_of_order),
      static_cast<long long>(s.expired), stale, static_cast<long long>(ic.missed.load()), rx.restarts(), rx.dropped(),
      rx.filtered(), rx.malformed(), rx.socket_drops(), static_cast<long long>(s.numerical_errors), s.lateness_us[0], s.lateness_us[1],
      s.lateness_us[2], s.lateness_us[3], s.compute_us[0], s.compute_us[1], s.compute_us[2], s.compute_us[3],
      static_cast<long long>(loop.fifo_demotions()), rx_demotions);
  std::fflush(stdout);
}

}  // namespace coopdyn::daemon
