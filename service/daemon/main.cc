// coopdynd: the real-time constrained-dynamics service.
//
//   coopdynd --scene FILE [--config FILE] [--lcm-url URL] [--mode simulate|estimate]
//            [--rate HZ] [--duration S]      (coopdynd --help: the options and their defaults)
//
// Processes and threads: the loop (ServiceLoop::run, thread coopdynd-loop; SCHED_FIFO as root under
// realtime.sched_fifo auto, stepped down if it hogs its CPU) never receives; at the fixed rate it
// hands its encoded outputs to the publisher thread (runtime/publisher_thread.h), which publishes them
// through LCM (realtime.publisher_thread; on arrival the loop publishes itself). Inputs arrive in a
// supervised child process (coopdynd --rx-child, io/transport/rx_isolated.h: its own UDP socket and LCM wire
// parser, no liblcm) that copies raw bytes into a shared ring, drained by the receive thread here
// (-> decode -> triple buffer), which also restarts the child when it dies (trigger: arrival: the
// loop drains the ring itself, woken by the child, and the receive thread only supervises). spdlog's
// async logger thread; and this main thread, which waits for a stop signal (or --duration), drains
// the loop's event ring into the log and prints the summary line at exit.
//
// This file is the orchestration: parse -> load (daemon/options.h) -> start (logging, bus, publisher,
// loop, receive path: daemon/receive.h, which waits for the receive process's subscription) -> run
// (logs `running; SIGINT or SIGTERM stops, as do SIGHUP and SIGQUIT`: inputs sent from then on are
// received) -> report (daemon/reports.h).
#include <signal.h>
#include <sys/prctl.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <future>
#include <string>
#include <system_error>
#include <thread>

#include "service/daemon/options.h"
#include "service/daemon/receive.h"
#include "service/daemon/reports.h"
#include "service/io/transport/lcm_bus.h"
#include "service/io/transport/rx_in_loop.h"
#include "service/io/transport/rx_isolated.h"
#include "service/runtime/config.h"
#include "service/runtime/publisher_thread.h"
#include "service/runtime/socket_arrivals.h"
#include "service/runtime/realtime.h"
#include "service/runtime/service_loop.h"

namespace {

using namespace coopdyn::daemon;

constexpr int kStopSignals[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};
std::atomic<bool> g_stop{false};
std::atomic<int> g_signal{0};
void on_signal(int sig) {
  g_signal.store(sig);
  g_stop.store(true);
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
  // SCHED_FIFO just below the loop when the loop asks for it: the processes loading the machine
  // cannot hold the outputs back (nice -20 could: bench/README.md, "Commands at 1 kHz and outputs
  // under load")
  const int fifo = runtime::loop_asks_fifo(cfg.realtime) ? std::max(1, cfg.realtime.priority - 1) : 0;
  try {
    p->start(cfg.realtime.cpu, fifo);
  } catch (const std::system_error& e) {  // no thread to be had (a process or cgroup limit)
    spdlog::warn("publisher thread not started ({}): the loop publishes its outputs itself", e.what());
    return nullptr;
  }
  while (!p->scheduled()) std::this_thread::yield();  // the thread has applied its priority
  spdlog::info("outputs published by a publisher thread{} ({} slots of {} bytes){}",
               cfg.realtime.cpu >= 0 ? " off the loop's CPU" : "", runtime::PublisherThread::kSlots, max_bytes,
               fifo == 0               ? std::string("")
               : p->priority_granted() ? fmt::format(", SCHED_FIFO priority {} (below the loop's)", fifo)
                                       : fmt::format(" (SCHED_FIFO {} refused: no privilege)", fifo));
  return p;
}

// SIGINT, SIGTERM, SIGHUP (a closed terminal or ssh session) and SIGQUIT each stop the daemon the
// same way: the loop ends, the log is flushed, the summary line is printed, exit 0
void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  for (const int sig : kStopSignals) sigaction(sig, &sa, nullptr);
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
  // after the receive process's subscription (main: wait_for_receiver): an input sent once this line
  // is out is received
  spdlog::info("running; SIGINT or SIGTERM stops, as do SIGHUP and SIGQUIT");

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

}  // namespace

// parse -> load -> start (logging, bus, loop, receive process) -> run -> report
int main(int argc, char** argv) {
  using namespace coopdyn;
  using namespace coopdyn::daemon;
  // the isolated receive process (io/transport/rx_isolated.h): this binary, exec'd by the daemon itself
  if (argc > 1 && std::strcmp(argv[1], "--rx-child") == 0) return io::rx_child_main(argc, argv);
  install_signal_handlers();  // from here on a stop signal ends the daemon cleanly, whatever it is doing
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
  std::unique_ptr<runtime::ServiceLoop> loop_owner;
  try {  // a scene the loop's parts refuse at construction (a state fit's plan, an allocation)
    loop_owner = std::make_unique<runtime::ServiceLoop>(sys, cfg, publisher ? static_cast<io::Bus&>(*publisher) : *bus);
  } catch (const std::exception& e) {
    spdlog::shutdown();
    std::fprintf(stderr, "coopdynd: scene '%s': %s\n", opt.scene_path.c_str(), e.what());
    return 1;
  }
  runtime::ServiceLoop& loop = *loop_owner;
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
  RejectionReport rejections;
  rejections.log_socket_drops = cfg.input_url() != cfg.lcm_url;
  std::unique_ptr<runtime::ArrivalSource> arrivals;
  if (in_loop) {
    io::InLoopReceiver& r = *in_loop;
    auto offer = [&loop, &rejections, &r](const void* d, int n, long long t) {
      offer_input(loop, false, rejections, r, d, n, t);
    };
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
    if (const std::string why = wait_for_receiver(*isolated, cfg); !why.empty()) {
      isolated->stop();
      spdlog::shutdown();
      std::fprintf(stderr, "coopdynd: %s; not starting\n", why.c_str());
      return 1;
    }
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
  print_summary(loop, cfg, rx, t_start, rx_guard.demotions, g_signal.load());
  return 0;
}
