// What every datagram on the daemon's inputs goes through before any decoder sees it, wherever it
// is read: in the isolated receive process (rx_isolated.h, the default) or on the loop's own thread
// (rx_in_loop.h, `realtime.receive_in_loop`). One code path, so both refuse the same datagrams for the same
// reasons and count them in the same counters:
//   - the socket (open_input_socket): udpm_socket.h's, with the buffer asked for and, before it is
//     bound, a classic BPF filter that lets through only LC02 datagrams whose channel is an input
//     channel and whose payload starts with that channel's type fingerprint, and LC03 fragments;
//   - each datagram (InputGate::admit): LCM's wire format parsed and fragments reassembled by
//     lcm_wire.h (every length and offset checked; refused datagrams counted by reason in
//     malformed_by), the channel and fingerprint checked again (a first fragment before it takes a
//     reassembly slot; `filtered`), a complete message's fields walked up to the MAC field (junk
//     after a fingerprint: Reject::kDecode), and with authentication on its MAC and the replay rule
//     (below), each refusal counted by channel and reason in rejected_by;
//   - reading (InputGate::read_batch): recvmmsg of up to kBatch datagrams without waiting.
// The replay rule: a signed message is refused as replayed when its utime is not above the window of
// its channel (RxCounters::accepted_utime: the utime of the last input the daemon accepted there, or
// the daemon's start; ReceiverCounters::open_window, note_accepted), or equals the utime of the
// last message this gate let through on it (a datagram delivered twice, a flood of one recording).
// Only the daemon moves the window, once it has accepted the input: a signed input it refuses (a
// utime in the future or stale by its clock, a NaN) never locks the channel's later inputs out.
// Everything is allocated by the constructors and set_auth_key; admit and read_batch allocate
// nothing, lock nothing, log nothing and throw nothing (they run on the loop's thread in-loop).
#pragma once

#include <netinet/in.h>
#include <sys/socket.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "service/io/transport/auth.h"
#include "service/io/transport/lcm_wire.h"
#include "service/io/codec/messages.h"

namespace coopdyn::io {

constexpr int kRxChannels = 8;  // channels one receive path accepts at most

// The receive path's counters. Written by the one thread that receives (in the receive process they
// live in the memory it shares with the daemon), read by any thread.
struct RxCounters {
  std::atomic<uint64_t> dropped{0};       // messages the receive process could not queue (too large, ring full)
  std::atomic<uint64_t> received{0};      // complete messages received on the input channels' socket
  std::atomic<uint64_t> filtered{0};      // refused: not a coopdyn message of an input channel
  std::atomic<uint64_t> socket_drops{0};  // the kernel's drop count of the receive socket (filter + overflow)
  std::atomic<int64_t> rcvbuf{0};         // SO_RCVBUF as the kernel reports it (twice a request it granted)
  std::atomic<int64_t> filter{0};         // 1: socket filter attached; < 0: not (-1 no socket (not udpm), -2 refused)
  // datagrams refused as malformed LCM (lcm_wire.h), by reason (WireStatus)
  std::atomic<uint64_t> malformed_by[wire::kWireStatuses] = {};
  // messages rejected by channel (the order given) and reason (Reject: malformed, and with
  // authentication unauthenticated, bad_mac, replayed)
  std::atomic<uint64_t> rejected_by[kRxChannels][kRejectKinds] = {};
  // the replay window of each channel (authentication on): the utime (us) of the last input the
  // daemon accepted there, or the daemon's start before that; written by the daemon only
  std::atomic<int64_t> accepted_utime[kRxChannels] = {};
};
static_assert(std::atomic<uint64_t>::is_always_lock_free, "the counters must be lock-free across processes");

// What the daemon reads of its receive path, either kind (any thread).
class ReceiverCounters {
 public:
  virtual ~ReceiverCounters() = default;
  virtual long long restarts() const { return 0; }  // receive processes that died (0 in-loop)
  virtual long long socket_drops() const;           // dropped by the kernel at the receive socket (filter + overflow)
  long long dropped() const;       // not queued for the loop (too large for a slot, ring full)
  long long filtered() const;      // refused: not a coopdyn message of its channel
  long long malformed() const;     // datagrams refused by the wire parser (every reason)
  long long malformed(wire::WireStatus why) const;
  long long rejected(int channel, Reject why) const;  // messages of channel k (the order given) rejected for why
  long long socket_buffer() const;  // SO_RCVBUF the kernel reports (0 until known)
  int filter_state() const;         // 1 attached, 0 not yet, -1 no receive socket, -2 refused
  // The replay window (input_gate.h, authentication on). open_window: every channel's at utime_us
  // (the daemon's start: nothing stamped before it is accepted; before the receive path starts).
  // note_accepted: the daemon accepted an input of channel k stamped utime_us (the thread that
  // offers the inputs; no allocation, lock or throw). window(k): the current one.
  void open_window(int64_t utime_us);
  void note_accepted(int channel, int64_t utime_us);
  int64_t window(int channel) const;

 protected:
  RxCounters* counters_ = nullptr;  // set by the derived class's constructor
};

// An input channel: its name, its type's fingerprint (big-endian, as on the wire) and that type.
struct InputChannel {
  std::string channel;
  unsigned char hash[8] = {};
  MessageType type = MessageType::kUnknown;
};
// channels[k] with fingerprints[k]; throws std::invalid_argument if the counts differ or exceed kRxChannels
std::vector<InputChannel> input_channels(const std::vector<std::string>& channels, const std::vector<int64_t>& fingerprints);

// The receive socket on u's group and port with the channels' filter and the buffer asked for
// (rcvbuf > 0; else the URL's recv_buf_size, else the OS default); the filter's state and the
// buffer granted go to c. The fd, or -1 with *why.
int open_input_socket(const wire::UdpmUrl& u, long rcvbuf, const std::vector<InputChannel>& channels, RxCounters* c,
                      std::string* why);
uint64_t kernel_drops(int fd);  // SO_MEMINFO's drop count of a socket (0 if unknown)

class InputGate {
 public:
  static constexpr int kBatch = 16;                      // datagrams per recvmmsg
  static constexpr int kDatagramBytes = 65536;           // the largest UDP datagram
  static constexpr int kReassemblySlots = 8;             // partial messages kept at once (one per sender)
  static constexpr long long kReassemblyNs = 100000000;  // a partial message's life: 100 ms

  // max_message_bytes: the largest input message (larger ones are refused, kTooLarge); c: the counters.
  InputGate(std::vector<InputChannel> channels, int max_message_bytes, RxCounters* c);
  ~InputGate();
  InputGate(const InputGate&) = delete;
  InputGate& operator=(const InputGate&) = delete;

  // Authentication on: each complete message's MAC and the replay rule are checked (before the first datagram).
  void set_auth_key(const AuthKey& key);

  // Reads up to kBatch datagrams from sock without waiting; returns how many (0 if none or on an
  // error). The receive time of the batch is batch_ns() (CLOCK_MONOTONIC).
  int read_batch(int sock);
  long long batch_ns() const { return batch_ns_; }
  // Datagram i of the last batch through the gate: the index of its input channel with *out the
  // complete message (valid until the next read_batch), or -1 (refused and counted, or a fragment kept).
  int admit(int i, wire::Message* out);

  // Reads one batch and hands each admitted message to h(channel, data, len, recv_ns). Returns the
  // datagrams read.
  template <class H>
  int receive(int sock, H&& h) {
    const int n = read_batch(sock);
    wire::Message m;
    for (int i = 0; i < n; ++i)
      if (const int k = admit(i, &m); k >= 0) h(k, m.data, m.len, batch_ns_);
    return n;
  }

  const std::vector<InputChannel>& channels() const { return channels_; }

 private:
  struct Auth;
  int accepted(const char* channel, int channel_len, const uint8_t* data, int len) const;
  int admit_datagram(const uint8_t* buf, size_t len, const sockaddr_in& from, wire::Message* out);
  std::vector<InputChannel> channels_;
  RxCounters* c_;
  wire::Reassembler reasm_;
  std::unique_ptr<Auth> auth_;  // nullptr: authentication off
  std::vector<uint8_t> bufs_;   // kBatch x kDatagramBytes
  std::vector<mmsghdr> msgs_;
  std::vector<iovec> iov_;
  std::vector<sockaddr_in> from_;
  long long batch_ns_ = 0;
};

}  // namespace coopdyn::io
