// Where the event-driven loop (trigger: arrival) takes its inputs from when no receive thread hands
// them over: the loop waits on the source's bell (or polls it, realtime.busy_poll) and, once it
// moved, drains the source into its inboxes on its own thread. The daemon's sources: the receive
// process's ring (io/transport/rx_isolated.h, drain_in_caller; the default): the message goes from the
// process that received it to the loop with one wake-up, the loop's; or the input socket itself
// (io/transport/rx_in_loop.h, realtime.receive_in_loop): from the kernel to the loop with one wake-up (none when
// polling). Implementations must not allocate, lock, log or throw in any of the four calls.
#pragma once

#include <cstdint>

namespace coopdyn::runtime {

class ArrivalSource {
 public:
  virtual ~ArrivalSource() = default;
  virtual uint32_t bell() const = 0;                            // moves when inputs may be waiting
  virtual void wait(uint32_t seen, long long deadline_ns) = 0;  // until bell() != seen, the absolute monotonic deadline or a signal
  virtual void drain() = 0;  // every waiting input offered to the loop's inboxes (ServiceLoop::states(), controls())
  // realtime.busy_poll: called between two reads of bell() instead of wait(); a source whose bell
  // moves by itself (the ring's) has nothing to do, one that must read to know (a socket) reads here
  virtual void poll() {}
};

}  // namespace coopdyn::runtime
