// The daemon's receive path: its own UDP socket in a supervised child process; no liblcm.
//
// Why: liblcm 1.3.1's fragment reassembly writes out of bounds on a crafted LC03 datagram (one
// 324-byte fragment with a huge offset; open upstream, in no release), and any process that
// subscribes with liblcm dies. So nothing of the daemon receives with liblcm (it only publishes:
// LCM's udpm transport opens its receive socket on the first subscribe). A child process
// (`coopdynd --rx-child`, the same binary, exec'd, so it shares nothing but what it is given)
// opens a UDP socket on the inbound URL's group and port (SO_REUSEADDR, as liblcm, so lcm-logger
// listens beside it), reads datagrams with recvmmsg in batches and parses them with lcm_wire.h
// (every length and offset checked, fragments reassembled in preallocated per-sender slots with a
// timeout; the checks are input_gate.h's, which the in-loop receive path, rx_in_loop.h, shares);
// a complete message on an input channel whose payload starts with that channel's type
// fingerprint goes as raw bytes into a shared-memory ring (single producer, single consumer, fixed
// slots); it decodes nothing. The daemon's receive thread drains the ring and hands the bytes to
// the decoders (bounds-checked, codec.h); with drain_in_caller() the loop drains it itself, woken
// by a futex word in the shared header (the event-driven hand-off, no receive thread in between). A refused datagram is counted by its reason
// (malformed_by, `inputs_malformed` in loop_stats_t). The child stays as defence in depth: what
// parses hostile bytes runs in a process that holds nothing but the ring.
//
// Start-up: the child sets `alive` to its pid in the shared header once its socket has joined the
// group (datagrams sent from then on are queued for it) and rings the eventfd; the receive thread
// sees it at that wake-up and reports it through the on_ready callback, once per child (the first
// and each respawned one), and counts it (children_ready). The daemon says it runs only after the
// first (daemon/receive.h wait_for_receiver).
//
// Supervision (the receive thread): the child is watched with waitpid(WNOHANG) at every wake-up
// (at least every 20 ms); when it dies it is counted, reported through the on_restart callback
// and respawned at once, then with a backoff doubling from 1 ms to 1 s while it keeps dying within
// a second of its start. The loop keeps ticking and publishing meanwhile; commands expire through
// the watchdog and the safe torque applies. The child dies with the daemon (PR_SET_PDEATHSIG) and
// ignores SIGINT, SIGTERM, SIGHUP and SIGQUIT (a stop signalled to the process group is the daemon's: it
// stops the child itself, and that is no restart). Messages larger than a slot, or arriving when
// the ring is full, are dropped and counted by the child in the shared header.
//
// Floods (README "Guarantees"): the child accepts only coopdyn messages. Its socket gets the
// configured SO_RCVBUF (0: the URL's recv_buf_size, else the OS default) and, before it is bound,
// a classic BPF socket filter: a short LCM datagram (LC02) passes only if its channel is one of the
// given channels and its payload starts with that channel's type fingerprint (the 8-byte hash of
// the generated type); fragments (LC03) pass (their channel is only in the first one; messages
// larger than a datagram need them); everything else is dropped by the kernel before it takes
// socket buffer space, CPU time in this process or a ring slot. The kernel counts those drops with
// the socket's overflow drops (SO_MEMINFO, `socket_drops`). The child checks the channel and
// fingerprint again (a fragment 0 before it takes a reassembly slot, complete messages, or a
// filter that could not be attached) and counts what it refuses as `filtered`.
//
// A complete message whose fields do not walk up to the MAC field (codec.h, mac_field_offset: junk
// after a type fingerprint) is rejected by the child as malformed (Reject::kDecode, counted in
// rejected_by as below), with or without authentication: it never takes a ring slot.
//
// Authentication (set_auth_key, auth.h): the child verifies each complete message's MAC under the
// key for its channel, then the replay rule (input_gate.h: its utime above the last one the daemon
// accepted on that channel, or the daemon's start; the daemon moves that window in the shared
// header, and a respawned child keeps it), before the message takes a ring slot; what fails is
// counted by channel and reason
// (rejected_by: malformed, unauthenticated, bad_mac, replayed) and never reaches the daemon, so a
// flood of unsigned, forged or replayed inputs cannot fill the ring ahead of the signed ones. The
// daemon verifies what arrives through the ring again (the inboxes, inbox.h). The key is handed over
// in the shared header; the child then holds the key, which a compromise of the child would reveal
// (its parser is bounded and fuzzed; the alternative, junk through the ring, lost a third of the
// valid commands under a flood: docs/guide/service.md, threat model).
#pragma once

#include <sched.h>
#include <sys/types.h>

#include <atomic>
#include <cstdint>
#include <cstring>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "service/io/transport/auth.h"
#include "service/io/transport/input_gate.h"
#include "service/io/transport/lcm_wire.h"
#include "service/io/codec/messages.h"

namespace coopdyn::io {

// The shared ring: a header, then `slots` slots of (len, recv_ns, bytes[slot_bytes]).
struct RxRingHeader {
  uint64_t magic;
  uint32_t slots, slot_bytes;
  std::atomic<uint64_t> head;     // next slot the child writes (producer)
  std::atomic<uint64_t> tail;     // next slot the daemon reads (consumer)
  std::atomic<uint64_t> alive;    // set by the child once subscribed
  // what the child's gate (input_gate.h) refused, by reason, and what it could not queue (dropped)
  RxCounters counters;
  // authentication on: the key (written by the daemon before the child starts)
  std::atomic<uint64_t> auth_on;
  unsigned char auth_key[kKeyBytes];
  // the loop drains the ring itself (IsolatedReceiver::drain_in_caller): set by the daemon before the
  // child starts. Then the child rings `bell` (a futex word shared by the two processes) after each
  // batch it queued, waking the waiter when `bell_waiting` says one sleeps, instead of the eventfd.
  std::atomic<uint32_t> caller_drains;
  std::atomic<uint32_t> bell;
  std::atomic<uint32_t> bell_waiting;
};
static_assert(sizeof(std::atomic<uint32_t>) == sizeof(uint32_t), "the shared futex word is the counter itself");

class IsolatedReceiver : public ReceiverCounters {
 public:
  // raw message: bytes, length, receive time (CLOCK_MONOTONIC ns, taken by the child)
  using Handler = std::function<void(const void* data, int len, long long recv_ns)>;
  // a restart: the child's exit status (wait(2) status) and the restart count so far
  using RestartHandler = std::function<void(int status, long long restarts)>;
  // a child has subscribed: its pid and the restarts before it (0: the first child)
  using ReadyHandler = std::function<void(pid_t pid, long long restarts)>;

  // exe: the coopdynd binary to exec with --rx-child (normally /proc/self/exe). Throws
  // std::runtime_error if the shared memory cannot be set up.
  // channels: received literally (not as LCM regular expressions), e.g. the input and the control channel
  // fingerprints: the type hash expected on each channel (same order). socket_buffer_bytes: SO_RCVBUF
  // to ask for on the receive socket; 0: the OS default.
  IsolatedReceiver(std::string exe, std::string url, std::vector<std::string> channels, std::vector<int64_t> fingerprints,
                   int slots, int slot_bytes, int socket_buffer_bytes = 0);
  ~IsolatedReceiver();
  IsolatedReceiver(const IsolatedReceiver&) = delete;
  IsolatedReceiver& operator=(const IsolatedReceiver&) = delete;

  // Keeps the receive thread and the child off this CPU (the loop's realtime.cpu): call before
  // start(). Ignored when it would leave no CPU.
  void avoid_cpu(int cpu) { avoid_cpu_ = cpu; }
  // SCHED_FIFO at this priority for the child (each one spawned) and the receive thread; 0:
  // SCHED_OTHER (the default). Before start(), or later to step them down (0 keeps a respawned
  // child at SCHED_OTHER too). A refusal (no privilege) leaves them SCHED_OTHER.
  void set_fifo_priority(int priority) { fifo_priority_.store(priority); }
  // CPU time consumed so far (ns) by the current child and by the receive thread; -1 if unknown.
  long long child_cpu_ns() const;
  long long thread_cpu_ns() const;
  // the receive thread's kernel id (0 before start()), for a scheduler change from outside
  pid_t thread_tid() const { return tid_.load(); }
  // Authentication on: the child verifies each message's MAC and the replay rule before the ring
  // (above). Call before start().
  void set_auth_key(const AuthKey& key);
  // The hand-off without the receive thread (trigger: arrival): the caller (the loop's thread) drains
  // the ring itself with drain(), waking on the child's bell (wait_bell) or polling it; the receive
  // thread only supervises the child (and never calls the handler given to start()). Before start().
  void drain_in_caller() { hdr_->caller_drains.store(1); }
  bool caller_drains() const { return hdr_->caller_drains.load(std::memory_order_relaxed) != 0; }
  // The caller's side (one thread): the bell's count (it moves after every batch the child queued);
  // a sleep until it is no longer `seen`, or the absolute CLOCK_MONOTONIC deadline (ns), or a signal;
  // and the messages waiting in the ring handed to h in order (returns how many). No allocation, no
  // lock: a futex on the shared word, atomics and memcpy.
  uint32_t bell() const { return hdr_->bell.load(std::memory_order_acquire); }
  void wait_bell(uint32_t seen, long long deadline_ns);
  template <class H>
  int drain(H&& h);
  // Starts the child and the receive thread; the handlers run on the receive thread.
  void start(Handler handler, RestartHandler on_restart, ReadyHandler on_ready = nullptr);
  void stop();  // stops the thread, kills and reaps the child (also done by the destructor)

  long long restarts() const override { return restarts_.load(std::memory_order_relaxed); }
  long long child_received() const;
  pid_t child_pid() const { return pid_.load(); }
  // true once the current child has subscribed
  bool child_ready() const;
  // how many children have subscribed and been reported (on_ready returned) so far: >= 1 once the
  // inputs are received; one more after each restart
  long long children_ready() const { return children_ready_.load(); }

 private:
  void spawn();
  void run();
  const unsigned char* slot(uint64_t i) const;
  std::string exe_, url_;
  std::vector<std::string> channels_;
  std::vector<int64_t> fingerprints_;
  int slots_, slot_bytes_, socket_buffer_bytes_;
  int shm_fd_ = -1, event_fd_ = -1;
  int avoid_cpu_ = -1;
  std::atomic<int> fifo_priority_{0};
  std::atomic<pid_t> tid_{0};
  bool other_cpus(cpu_set_t* set) const;  // every online CPU but avoid_cpu_; false if none or not set
  size_t shm_size_ = 0;
  RxRingHeader* hdr_ = nullptr;
  unsigned char* base_ = nullptr;
  std::atomic<pid_t> pid_{-1};
  std::atomic<long long> restarts_{0}, children_ready_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
  Handler handler_;
  RestartHandler on_restart_;
  ReadyHandler on_ready_;
};

// The messages the child published, [tail, head), to h(bytes, len, recv_ns), the tail advanced past
// each; a head that a child could not have written (garbage) resyncs the tail to it.
template <class H>
int IsolatedReceiver::drain(H&& h) {
  uint64_t tail = hdr_->tail.load(std::memory_order_relaxed);
  const uint64_t head = hdr_->head.load(std::memory_order_acquire);
  if (head < tail || head - tail > static_cast<uint64_t>(slots_)) {
    hdr_->tail.store(head, std::memory_order_release);
    return 0;
  }
  int n = 0;
  for (; tail < head; ++tail, ++n) {
    const unsigned char* s = slot(tail);
    uint32_t len;
    int64_t recv_ns;
    std::memcpy(&len, s, sizeof len);
    std::memcpy(&recv_ns, s + sizeof len, sizeof recv_ns);
    if (len <= static_cast<uint32_t>(slot_bytes_)) h(s + sizeof len + sizeof recv_ns, static_cast<int>(len), static_cast<long long>(recv_ns));
    hdr_->tail.store(tail + 1, std::memory_order_release);
  }
  return n;
}

// The child's main (coopdynd --rx-child URL SHM_FD EVENT_FD RCVBUF CHANNEL HASH [CHANNEL HASH]...;
// HASH in hex). Returns the exit status.
int rx_child_main(int argc, char** argv);

}  // namespace coopdyn::io
