// The receive side of one input channel: decode and validate on the receive thread, check the
// sender's clock, apply the sequence rule, hand the newest accepted value to the loop through a
// triple buffer.
//
// Freshness by the sender's clock: with max_input_age_us > 0, a message whose utime is <= 0, older
// than max_input_age_us by this host's CLOCK_REALTIME (Reject::kStale), or ahead of it by more than
// that (Reject::kFuture: a skewed clock, or a replay stamped in the future) is rejected and counted
// here, where the decision is made. The loop's watchdog then bounds how long an accepted message is
// used (by receive time), so no command acts later than max_input_age + watchdog after its stamp.
//
// Sequence rule: a message whose seq is not above the last accepted one is dropped (out of order),
// unless the loop has declared the last accepted one expired (note_expired(), called by the loop
// when it counts the expiry): then any seq is accepted, so a sender that restarts (seq from 0) is
// followed again once its old commands have expired. The expiry is decided once, by the loop, and
// the receive thread only reads that decision: every lower seq let through corresponds to an
// expiry the loop counted (before, each thread judged the watchdog by its own clock reading, and a
// restart arriving between the watchdog and the next tick was accepted with no expiry counted).
//
// Authentication (require_auth(), io/transport/auth.h): before decoding, the raw bytes' MAC is verified
// (Reject::kUnauthenticated, kBadMac), then the replay rule: an input whose utime is not strictly
// above the last accepted authenticated input's on this channel is Reject::kReplayed. A replay
// older than max_input_age is also refused by the staleness rule, so the window of utimes a
// recording could be replayed in is closed on both sides; the rule assumes one sender per channel
// (as the sequence rule does), whose utimes increase.
#pragma once

#include <time.h>

#include <atomic>
#include <cstdint>
#include <limits>

#include "service/dynamics/system.h"
#include "service/io/transport/auth.h"
#include "service/io/codec/codec.h"
#include "service/io/codec/direct_decoder.h"
#include "service/io/codec/messages.h"
#include "service/runtime/triple_buffer.h"

namespace coopdyn::runtime {

struct InputCounters {
  std::atomic<int64_t> received{0}, accepted{0}, rejected{0}, out_of_order{0};
  // seqs that never reached the checks: skipped between consecutive messages whose seq was read (the
  // accepted ones, and those rejected for their utime alone, stale or future, which arrived and are
  // counted there): the valid messages of a sender that numbers 1, 2, 3, ... that never arrived,
  // wherever they were lost (socket buffer, receive process, ring), each counted once. A sender
  // that numbers otherwise, or jumps, adds to it too (at most 2^40 per jump).
  std::atomic<int64_t> missed{0};
  std::atomic<int64_t> by_reason[io::kRejectKinds] = {};
};

enum class Offer { kAccepted, kRejected, kOutOfOrder };

inline int64_t realtime_us() {  // CLOCK_REALTIME in us, LCM's utime clock
  timespec ts;
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000 + ts.tv_nsec / 1000;
}

template <class Slot, class Decoder>
class Inbox {
 public:
  // max_input_age_us <= 0: no check of utime.
  template <class Init>
  Inbox(const System& sys, long long max_input_age_us, Init init)
      : decoder_(sys), buffer_(init), max_age_us_(max_input_age_us) {}

  // Receive thread (one writer). *why (optional) gets the reject reason.
  Offer offer(const void* data, int len, long long recv_ns, io::Reject* why = nullptr) {
    counters_.received.fetch_add(1, std::memory_order_relaxed);
    Slot& s = buffer_.write_slot();
    io::Reject r = authenticate(data, len);
    if (r == io::Reject::kNone) r = decoder_.decode(data, len, s);
    const bool decoded = r == io::Reject::kNone;  // s.seq is the sender's, whatever its utime
    if (r == io::Reject::kNone && max_age_us_ > 0) {
      if (s.utime <= 0) {
        r = io::Reject::kStale;  // never stamped (0, -1): checked first, so the difference cannot overflow
      } else {
        const int64_t age_us = wall_us_() - s.utime;
        if (age_us > max_age_us_) r = io::Reject::kStale;
        else if (age_us < -max_age_us_) r = io::Reject::kFuture;
      }
    }
    if (why) *why = r;
    if (r != io::Reject::kNone) {
      if (decoded) note_seq(s.seq);  // late or early, it arrived: no gap for it
      counters_.rejected.fetch_add(1, std::memory_order_relaxed);
      counters_.by_reason[static_cast<int>(r)].fetch_add(1, std::memory_order_relaxed);
      return Offer::kRejected;
    }
    if (have_last_ && s.seq <= last_seq_ && expired_id_.load(std::memory_order_acquire) != last_id_) {
      counters_.out_of_order.fetch_add(1, std::memory_order_relaxed);
      return Offer::kOutOfOrder;
    }
    note_seq(s.seq);
    last_seen_seq_ = s.seq;  // a restarted sender (a lower seq let through) is followed from here
    if (verifier_) last_auth_utime_ = s.utime;
    s.recv_ns = recv_ns;
    s.id = ++last_id_;
    have_last_ = true;
    last_seq_ = s.seq;
    buffer_.publish();
    counters_.accepted.fetch_add(1, std::memory_order_relaxed);
    return Offer::kAccepted;
  }

  // Loop thread (one reader): true if a newer value arrived; latest() is the newest accepted.
  bool update() { return buffer_.update(); }
  const Slot& latest() const { return buffer_.read_slot(); }
  // Loop thread: latest() has expired (the loop counted it); the sequence rule may restart.
  void note_expired() { expired_id_.store(latest().id, std::memory_order_release); }

  const InputCounters& counters() const { return counters_; }
  // Tests: replace the wall clock that utime is checked against.
  void set_wall_clock(int64_t (*now_us)()) { wall_us_ = now_us; }
  // Inputs must be signed (io/transport/auth.h); v outlives the inbox. Before the receive thread starts.
  void require_auth(const io::Verifier* v) { verifier_ = v; }

 private:
  // A message with this seq reached the checks: the seqs skipped since the newest one read are missed.
  void note_seq(int64_t seq) {
    if (have_seen_ && seq > last_seen_seq_) {  // unsigned: the difference of any two int64 fits
      const uint64_t gap = static_cast<uint64_t>(seq) - static_cast<uint64_t>(last_seen_seq_) - 1;
      if (gap > 0) counters_.missed.fetch_add(static_cast<int64_t>(gap < (1ULL << 40) ? gap : (1ULL << 40)), std::memory_order_relaxed);
    }
    if (!have_seen_ || seq > last_seen_seq_) last_seen_seq_ = seq;
    have_seen_ = true;
  }
  // the MAC and the replay rule (authentication on), before anything is decoded
  io::Reject authenticate(const void* data, int len) const {
    if (!verifier_) return io::Reject::kNone;
    const io::Reject r = verifier_->check(data, len);
    if (r != io::Reject::kNone) return r;
    return io::raw_utime(data, len) <= last_auth_utime_ ? io::Reject::kReplayed : io::Reject::kNone;
  }

  Decoder decoder_;
  TripleBuffer<Slot> buffer_;
  long long max_age_us_;
  int64_t (*wall_us_)() = &realtime_us;
  const io::Verifier* verifier_ = nullptr;
  // receive thread only
  int64_t last_auth_utime_ = std::numeric_limits<int64_t>::min();  // utime of the last accepted input (authentication on)
  bool have_last_ = false;
  int64_t last_seq_ = 0;
  bool have_seen_ = false;    // a seq was read (note_seq)
  int64_t last_seen_seq_ = 0;  // the newest seq read, or the last accepted after a restart
  int64_t last_id_ = 0;
  // written by the loop, read by the receive thread: id of the last slot the loop declared expired
  std::atomic<int64_t> expired_id_{-1};
  InputCounters counters_;
};

using CommandInbox = Inbox<io::CommandSlot, io::CommandDecoder>;
// states: decoded without allocating (direct_decoder.h), so the loop's thread may take them itself
using StateInbox = Inbox<io::StateSlot, io::DirectStateDecoder>;
using ControlInbox = Inbox<io::ControlSlot, io::ControlDecoder>;

}  // namespace coopdyn::runtime
