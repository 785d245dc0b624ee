// What coopdynd tells its user: the start-up lines, the loop's events, overruns and rejected inputs
// (at most a line a second), what the receive socket and priority got, and the summary line at exit.
// The main thread only: the loop never logs.
#pragma once

#include <atomic>
#include <chrono>
#include <string>

#include "service/dynamics/system.h"
#include "service/io/transport/input_gate.h"
#include "service/io/transport/lcm_wire.h"
#include "service/io/transport/rx_isolated.h"
#include "service/runtime/config.h"
#include "service/runtime/event_ring.h"
#include "service/runtime/service_loop.h"

namespace coopdyn::daemon {

// one event of the loop's ring in the log (the main thread)
void log_event(const coopdyn::System& sys, const coopdyn::runtime::Event& e);

// Overruns come in bursts on a loaded machine: one warning per second at most, with the count.
struct OverrunReport {
  long bursts = 0;
  long long worst = 0, first_tick = -1;
  std::chrono::steady_clock::time_point last = std::chrono::steady_clock::now();
  void add(const coopdyn::runtime::Event& e);
  void flush(bool force);
};

// what the daemon runs: the scene, the mode, the inputs and outputs
void log_startup(const coopdyn::System& sys, const coopdyn::runtime::ServiceConfig& cfg, const std::string& scene_path);

// Rejected inputs: counted per reason by the receive thread, logged by the main thread at most
// once per second with the counts since the last line.
struct RejectionReport {
  std::atomic<long long> rejected_by[coopdyn::io::kRejectKinds] = {};
  std::atomic<long long> out_of_order{0};
  long long missed_logged = 0, filtered_logged = 0, socket_drops_logged = 0;
  // the kernel's drops at the receive socket are logged only where the inputs have a URL of their own
  // (lcm_url_in): on the outputs' URL the daemon's own outputs loop back to that socket and its filter
  // drops every one, which is no input lost (the count stays in the summary, socket_drops)
  bool log_socket_drops = true;
  long long rx_rejected_logged[coopdyn::io::kRejectKinds] = {};  // by the receive process, before its ring
  long long malformed_logged[coopdyn::io::wire::kWireStatuses] = {};
  std::chrono::steady_clock::time_point last_report = std::chrono::steady_clock::now() - std::chrono::seconds(2);
  void flush(bool force, const coopdyn::runtime::ServiceLoop& loop, const coopdyn::io::ReceiverCounters& rx);
};

// what the receive socket got: its buffer and its filter
void log_receive_socket(const coopdyn::io::ReceiverCounters& rx, const coopdyn::runtime::ServiceConfig& cfg);

// what realtime.receive_priority got: the receive process's and thread's policy, from the kernel
void log_receive_priority(const coopdyn::io::IsolatedReceiver& rx, const coopdyn::runtime::ServiceConfig& cfg);

// report: the summary line on stdout (the tests and scripts read it); sig: the signal that stopped it (0: the duration)
void print_summary(const coopdyn::runtime::ServiceLoop& loop, const coopdyn::runtime::ServiceConfig& cfg,
                   const coopdyn::io::ReceiverCounters& rx, std::chrono::steady_clock::time_point t_start,
                   long long rx_demotions, int sig);

}  // namespace coopdyn::daemon
