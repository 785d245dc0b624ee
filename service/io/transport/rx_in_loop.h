// The daemon's inputs read on the loop's own thread (`realtime.receive_in_loop`, estimate mode with
// `trigger: arrival` only): no receive process, no ring, no wake-up of another thread or process
// between the kernel and the loop. The loop sleeps in ppoll on the input socket (woken by the
// kernel when a datagram is queued) or, with `realtime.busy_poll`, reads it without waiting; each
// datagram goes through the same gate as in the isolated receive process (input_gate.h: the
// socket filter, the bounded wire parser and reassembler, channel and fingerprint, the field walk,
// with authentication the MAC and the replay rule, every refusal counted by reason in the same
// counters), then to the loop's inboxes.
//
// What it gives up: isolation. The bytes a hostile host sends are parsed in the daemon's process,
// on the loop's thread, by code that is bounded, fuzzed and shared with the receive process; a
// fault in it would stop the daemon instead of a supervised child (docs/guide/service.md, threat
// model). A flood is read by the loop's thread too: the time it takes is the loop's (at most
// kMaxBatches batches per call, so a state is computed between two reads of a flood).
//
// The constructor allocates everything (the gate's batch buffers and reassembly slots) and opens
// the socket; bell, wait_readable and receive allocate nothing, lock nothing, log nothing and throw
// nothing.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "service/io/transport/input_gate.h"

namespace coopdyn::io {

class InLoopReceiver : public ReceiverCounters {
 public:
  static constexpr int kMaxBatches = 4;  // recvmmsg batches of InputGate::kBatch per receive()

  // The socket on url's group and port (udpm:// only) for channels (received literally) with their
  // type fingerprints (same order); messages up to max_message_bytes; SO_RCVBUF socket_buffer_bytes
  // (0: the URL's recv_buf_size, else the OS default). Throws std::runtime_error naming the URL when
  // it is not udpm or the socket cannot join its group.
  InLoopReceiver(const std::string& url, const std::vector<std::string>& channels, const std::vector<int64_t>& fingerprints,
                 int max_message_bytes, int socket_buffer_bytes);
  ~InLoopReceiver() override;
  InLoopReceiver(const InLoopReceiver&) = delete;
  InLoopReceiver& operator=(const InLoopReceiver&) = delete;

  // Authentication on: the gate checks each message's MAC and the replay rule. Before the first receive().
  void set_auth_key(const AuthKey& key) { gate_.set_auth_key(key); }

  // The loop's thread only. bell(): moves after each receive() that handed a message over.
  uint32_t bell() const { return bell_; }
  // Sleeps until a datagram waits on the socket, the absolute CLOCK_MONOTONIC deadline (ns), or a signal.
  void wait_readable(long long deadline_ns) const;
  // What waits on the socket (at most kMaxBatches batches), read without waiting: each admitted
  // message to h(data, len, recv_ns). Returns how many were handed over.
  template <class H>
  int receive(H&& h);

  long long socket_drops() const override { return static_cast<long long>(kernel_drops(fd_)); }  // any thread

 private:
  RxCounters counters_store_;
  InputGate gate_;
  int fd_ = -1;
  uint32_t bell_ = 0;
};

template <class H>
int InLoopReceiver::receive(H&& h) {
  int handed = 0;
  for (int b = 0; b < kMaxBatches; ++b) {
    const int n = gate_.receive(fd_, [&](int, const uint8_t* data, int len, long long t) {
      h(static_cast<const void*>(data), len, t);
      ++handed;
    });
    if (n < InputGate::kBatch) break;
  }
  if (handed > 0) ++bell_;
  return handed;
}

}  // namespace coopdyn::io
