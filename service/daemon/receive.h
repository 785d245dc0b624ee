// coopdynd's inputs: the isolated receive process (or the loop's own socket under
// realtime.receive_in_loop), each input offered to the loop's inbox of its type, the receive
// process's counters fed to the loop's statistics, and the guard of its real-time priority.
#pragma once

#include <memory>
#include <string>

#include "service/daemon/reports.h"
#include "service/io/transport/rx_in_loop.h"
#include "service/io/transport/rx_isolated.h"
#include "service/runtime/config.h"
#include "service/runtime/fifo_guard.h"
#include "service/runtime/service_loop.h"

namespace coopdyn::daemon {

// inputs: received by a supervised child process, never by this one (the bus only publishes)
std::unique_ptr<coopdyn::io::IsolatedReceiver> make_receiver(const coopdyn::runtime::ServiceConfig& cfg);

// realtime.receive_in_loop: the input socket read by the loop's thread itself (io/transport/rx_in_loop.h),
// through the receive process's gate; estimate mode on arrival only (the config says so)
std::unique_ptr<coopdyn::io::InLoopReceiver> make_in_loop_receiver(const coopdyn::runtime::ServiceConfig& cfg);

// The receive process's counters into the loop's statistics (any thread): restarts, drops, refusals
// and its rejections by reason (malformed; with authentication on also unauthenticated, bad MAC,
// replayed), channel 0 the input, 1 the control channel
void feed_receiver_counters(coopdyn::runtime::ServiceLoop& loop, const coopdyn::io::ReceiverCounters& rx);

// One input from the receive path into the loop's inbox of its type; what is not applied is counted
// for the log; an accepted one moves its channel's replay window in rx (io/input_gate.h: the receive
// process refuses its utime and older ones from then on). Returns the offer's outcome. No allocation
// (the loop's thread runs it on arrival).
coopdyn::runtime::Offer offer_input(coopdyn::runtime::ServiceLoop& loop, bool simulate, RejectionReport& rejections,
                                    coopdyn::io::ReceiverCounters& rx, const void* d, int n, long long t);

// trigger: arrival: the loop drains the receive process's ring itself, woken by the bell the process
// rings (io/transport/rx_isolated.h drain_in_caller): no receive thread between a state's receipt and the loop
struct RingArrivals : coopdyn::runtime::ArrivalSource {
  coopdyn::io::IsolatedReceiver& rx;
  coopdyn::runtime::ServiceLoop& loop;
  RejectionReport& rejections;
  RingArrivals(coopdyn::io::IsolatedReceiver& r, coopdyn::runtime::ServiceLoop& l, RejectionReport& j)
      : rx(r), loop(l), rejections(j) {}
  uint32_t bell() const override { return rx.bell(); }
  void wait(uint32_t seen, long long deadline_ns) override { rx.wait_bell(seen, deadline_ns); }
  void drain() override {
    rx.drain([this](const void* d, int n, long long t) { offer_input(loop, false, rejections, rx, d, n, t); });
  }
};

// the receive thread: offers each input to the loop's inboxes, counts what is not applied (unless
// the loop drains the ring itself: then it only supervises); logs the receive process's deaths, and
// each subscription of a receive process (the first, and each one back after a restart)
void start_receiving(coopdyn::io::IsolatedReceiver& rx, coopdyn::runtime::ServiceLoop& loop,
                     const coopdyn::runtime::ServiceConfig& cfg, RejectionReport& rejections);

// How long the daemon waits for its first receive process to subscribe before it gives up.
constexpr double kReceiverStartLimitS = 10.0;

// The loop and the outputs start only once inputs are received: waits until the first receive process
// has subscribed (its line logged), then logs what its socket got and returns "". Gives up, returning
// why (naming the URL and channels that did not come up), when it does not within
// kReceiverStartLimitS or its process exits first (its own message is on stderr before).
std::string wait_for_receiver(const coopdyn::io::IsolatedReceiver& rx, const coopdyn::runtime::ServiceConfig& cfg);

// The receive process and thread at SCHED_FIFO (realtime.receive_priority), under realtime.sched_fifo
// auto, under the same guard as the loop (runtime/fifo_guard.h), watched from the main thread: each stats window, the CPU time
// each took; one that was busy more than the guard allows (a flood) steps both down to SCHED_OTHER
// for the rest of the run, a respawned child included.
struct ReceiveFifoGuard {
  coopdyn::io::IsolatedReceiver* rx = nullptr;
  coopdyn::runtime::FifoGuard child, thread;
  long long window_ns = 0, start = -1, child0 = -1, thread0 = -1;
  long long demotions = 0;
  void check(long long now);
};

}  // namespace coopdyn::daemon
