#include "service/daemon/receive.h"

#include <sys/wait.h>
#include <unistd.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstring>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "service/io/transport/auth.h"
#include "service/io/codec/codec.h"
#include "service/io/transport/lcm_bus.h"
#include "service/io/transport/lcm_wire.h"
#include "service/runtime/realtime.h"

namespace coopdyn::daemon {

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
  rx->open_window(io::wall_us());  // nothing stamped before the daemon's start: no replay across restarts
  return rx;
}

std::unique_ptr<coopdyn::io::InLoopReceiver> make_in_loop_receiver(const coopdyn::runtime::ServiceConfig& cfg) {
  using namespace coopdyn;
  auto rx = std::make_unique<io::InLoopReceiver>(
      cfg.input_url(), std::vector<std::string>{cfg.state_channel, cfg.control_channel},
      std::vector<int64_t>{io::fingerprint(io::MessageType::kMeasuredState), io::fingerprint(io::MessageType::kControl)},
      cfg.receive_max_bytes, cfg.receive_socket_buffer);
  if (!cfg.auth_key_file.empty()) rx->set_auth_key(io::read_key_file(cfg.auth_key_file));
  rx->open_window(io::wall_us());
  return rx;
}

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

coopdyn::runtime::Offer offer_input(coopdyn::runtime::ServiceLoop& loop, bool simulate, RejectionReport& rejections,
                                    coopdyn::io::ReceiverCounters& rx, const void* d, int n, long long t) {
  using namespace coopdyn;
  io::Reject why = io::Reject::kNone;
  runtime::Offer r;
  const bool control = io::identify(d, n) == io::MessageType::kControl;
  if (control) r = loop.controls().offer(d, n, t, &why);
  else if (simulate) r = loop.commands().offer(d, n, t, &why);
  else r = loop.states().offer(d, n, t, &why);
  if (r == runtime::Offer::kRejected) rejections.rejected_by[static_cast<int>(why) % io::kRejectKinds].fetch_add(1);
  if (r == runtime::Offer::kOutOfOrder) rejections.out_of_order.fetch_add(1);
  if (r == runtime::Offer::kAccepted) rx.note_accepted(control ? 1 : 0, io::raw_utime(d, n));  // channel 1: control
  return r;
}

namespace {

// the input URL and the channels the receive process subscribes to, for its log lines
std::string subscription_text(const coopdyn::runtime::ServiceConfig& cfg) {
  using coopdyn::runtime::ServiceMode;
  return fmt::format("{} ({}, {})", cfg.input_url(),
                     cfg.mode == ServiceMode::kSimulate ? cfg.command_channel : cfg.state_channel, cfg.control_channel);
}

}  // namespace

void start_receiving(coopdyn::io::IsolatedReceiver& rx, coopdyn::runtime::ServiceLoop& loop,
                     const coopdyn::runtime::ServiceConfig& cfg, RejectionReport& rejections) {
  using namespace coopdyn;
  const bool simulate = cfg.mode == runtime::ServiceMode::kSimulate;
  rx.start(
      [simulate, &loop, &rx, &rejections](const void* d, int n, long long t) {  // they outlive the receiver
        const runtime::Offer r = offer_input(loop, simulate, rejections, rx, d, n, t);
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
      },
      [what = subscription_text(cfg)](pid_t pid, long long restarts) {
        if (restarts == 0) spdlog::info("receive process {} subscribed to {}", pid, what);
        else spdlog::info("receive process {} back after restart {}: subscribed to {}; inputs resume", pid, restarts, what);
      });
}

std::string wait_for_receiver(const coopdyn::io::IsolatedReceiver& rx, const coopdyn::runtime::ServiceConfig& cfg) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(kReceiverStartLimitS);
  while (rx.children_ready() == 0 && rx.restarts() == 0 && std::chrono::steady_clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  if (rx.children_ready() > 0) {
    log_receive_socket(rx, cfg);
    return "";
  }
  if (rx.restarts() > 0)
    return "the receive process exited before it subscribed to " + subscription_text(cfg) + ": its reason is above";
  return fmt::format("the receive process (pid {}) did not subscribe to {} within {:g} s", rx.child_pid(),
                     subscription_text(cfg), kReceiverStartLimitS);
}

void ReceiveFifoGuard::check(long long now) {
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

}  // namespace coopdyn::daemon
