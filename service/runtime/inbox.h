// The receive side of one input channel: decode and validate on the receive thread, apply the
// sequence rule, hand the newest accepted value to the loop through a triple buffer.
//
// Sequence rule: a message whose seq is not above the last accepted one is dropped (out of order),
// unless the last accepted one is older than the watchdog: then any seq is accepted, so a sender
// that restarts (seq from 0) is followed again once its old commands have expired.
#pragma once

#include <atomic>
#include <cstdint>

#include "service/dynamics/system.h"
#include "service/io/codec.h"
#include "service/io/messages.h"
#include "service/runtime/triple_buffer.h"

namespace coopdyn::runtime {

struct InputCounters {
  std::atomic<int64_t> received{0}, accepted{0}, rejected{0}, out_of_order{0};
  std::atomic<int64_t> by_reason[io::kRejectKinds] = {};
};

enum class Offer { kAccepted, kRejected, kOutOfOrder };

template <class Slot, class Decoder>
class Inbox {
 public:
  template <class Init>
  Inbox(const System& sys, long long watchdog_ns, Init init) : decoder_(sys), buffer_(init), watchdog_ns_(watchdog_ns) {}

  // Receive thread (one writer). *why (optional) gets the reject reason.
  Offer offer(const void* data, int len, long long recv_ns, io::Reject* why = nullptr) {
    counters_.received.fetch_add(1, std::memory_order_relaxed);
    Slot& s = buffer_.write_slot();
    const io::Reject r = decoder_.decode(data, len, s);
    if (why) *why = r;
    if (r != io::Reject::kNone) {
      counters_.rejected.fetch_add(1, std::memory_order_relaxed);
      counters_.by_reason[static_cast<int>(r)].fetch_add(1, std::memory_order_relaxed);
      return Offer::kRejected;
    }
    if (have_last_ && s.seq <= last_seq_ && recv_ns - last_recv_ns_ <= watchdog_ns_) {
      counters_.out_of_order.fetch_add(1, std::memory_order_relaxed);
      return Offer::kOutOfOrder;
    }
    s.recv_ns = recv_ns;
    have_last_ = true;
    last_seq_ = s.seq;
    last_recv_ns_ = recv_ns;
    buffer_.publish();
    counters_.accepted.fetch_add(1, std::memory_order_relaxed);
    return Offer::kAccepted;
  }

  // Loop thread (one reader): true if a newer value arrived; latest() is the newest accepted.
  bool update() { return buffer_.update(); }
  const Slot& latest() const { return buffer_.read_slot(); }

  const InputCounters& counters() const { return counters_; }

 private:
  Decoder decoder_;
  TripleBuffer<Slot> buffer_;
  long long watchdog_ns_;
  bool have_last_ = false;
  int64_t last_seq_ = 0;
  long long last_recv_ns_ = 0;
  InputCounters counters_;
};

using CommandInbox = Inbox<io::CommandSlot, io::CommandDecoder>;
using StateInbox = Inbox<io::StateSlot, io::StateDecoder>;

}  // namespace coopdyn::runtime
