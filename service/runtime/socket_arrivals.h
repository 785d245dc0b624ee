// The event-driven loop's source (arrival_source.h) with realtime.receive_in_loop: the loop's own
// thread reads the input socket (io/transport/rx_in_loop.h), sleeping in ppoll on it (wait) or reading it at
// every poll (realtime.busy_poll); each message the gate admits goes to offer(data, len, recv_ns),
// which puts it into the loop's inboxes. Used by coopdynd and by the tests of this mode.
// drain() right after wait() or poll() reads nothing: they have just read the socket, and what came
// since waits there for the next wait() (ppoll returns at once) or poll(). No allocation, lock, log or
// throw (offer must keep to that too).
#pragma once

#include <cstdint>
#include <utility>

#include "service/io/transport/rx_in_loop.h"
#include "service/runtime/arrival_source.h"

namespace coopdyn::runtime {

template <class Offer>
class SocketArrivals : public ArrivalSource {
 public:
  SocketArrivals(io::InLoopReceiver& rx, Offer offer) : rx_(rx), offer_(std::move(offer)) {}
  uint32_t bell() const override { return rx_.bell(); }
  void wait(uint32_t seen, long long deadline_ns) override {
    if (rx_.bell() != seen) return;
    rx_.wait_readable(deadline_ns);
    read();
  }
  void poll() override { read(); }
  void drain() override {
    if (!just_read_) rx_.receive(offer_);
    just_read_ = false;
  }

 private:
  void read() {
    rx_.receive(offer_);
    just_read_ = true;
  }
  io::InLoopReceiver& rx_;
  Offer offer_;
  bool just_read_ = false;  // wait() or poll() read the socket since the last drain()
};

}  // namespace coopdyn::runtime
