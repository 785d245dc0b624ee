// The daemon's receive path: its own UDP socket in a supervised child process; no liblcm.
//
// liblcm 1.3.1's fragment reassembly writes out of bounds on a crafted LC03 datagram, so nothing of
// the daemon receives with liblcm. A child process (`coopdynd --rx-child`) reads the inbound URL's
// group and port, parses datagrams with lcm_wire.h under input_gate.h's checks and puts complete
// messages of the input channels, fingerprint-checked (and MAC- and replay-checked with
// set_auth_key), as raw bytes into a shared-memory ring; the daemon drains the ring (a receive
// thread, or the loop itself with drain_in_caller()) and decodes (codec.h). Refusals are counted by
// reason and channel (loop_stats_t). The child reports readiness once its socket has joined the
// group (on_ready, children_ready), is respawned with a backoff when it dies (on_restart), dies with
// the daemon and ignores stop signals meant for it. A kernel BPF filter drops other channels'
// datagrams before they take buffer space (counted with the overflow drops, `socket_drops`).
// Start-up, supervision, floods and authentication in full: docs/reference/internals.md,
// "The isolated receive process".
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
