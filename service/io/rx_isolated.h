// Receive isolation: LCM's receive code runs in a supervised child process, never in the daemon.
//
// Why: liblcm 1.3.1's fragment reassembly writes out of bounds on a crafted LC03 datagram (one
// 324-byte fragment with a huge offset; open upstream, in no release), and any process that
// subscribes on the multicast group dies. So the daemon never subscribes: it only publishes (LCM's
// udpm transport opens its receive socket on the first subscribe). A child process
// (`coopdynd --rx-child`, the same binary, exec'd, so it shares nothing but what it is given)
// subscribes to the input channels (commands or states, and controls) on the inbound URL and copies each message's raw bytes into
// a shared-memory ring (single producer, single consumer, fixed slots); it decodes nothing. The
// daemon's receive thread drains the ring and hands the bytes to the same decoders as before
// (bounds-checked, codec.h), so a hostile datagram can at worst kill the child.
//
// Supervision (the receive thread): the child is watched with waitpid(WNOHANG) at every wake-up
// (at least every 20 ms); when it dies it is counted, reported through the on_restart callback
// and respawned at once, then with a backoff doubling from 1 ms to 1 s while it keeps dying within
// a second of its start. The loop keeps ticking and publishing meanwhile; commands expire through
// the watchdog and the safe torque applies. The child dies with the daemon (PR_SET_PDEATHSIG).
// Messages larger than a slot, or arriving when the ring is full, are dropped and counted by the
// child in the shared header.
#pragma once

#include <sys/types.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <thread>
#include <vector>

namespace coopdyn::io {

// The shared ring: a header, then `slots` slots of (len, recv_ns, bytes[slot_bytes]).
struct RxRingHeader {
  uint64_t magic;
  uint32_t slots, slot_bytes;
  std::atomic<uint64_t> head;     // next slot the child writes (producer)
  std::atomic<uint64_t> tail;     // next slot the daemon reads (consumer)
  std::atomic<uint64_t> dropped;  // messages the child could not queue (too large, ring full)
  std::atomic<uint64_t> received; // messages the child received on the channel
  std::atomic<uint64_t> alive;    // set by the child once subscribed
};
static_assert(std::atomic<uint64_t>::is_always_lock_free, "the ring's counters must be lock-free across processes");

class IsolatedReceiver {
 public:
  // raw message: bytes, length, receive time (CLOCK_MONOTONIC ns, taken by the child)
  using Handler = std::function<void(const void* data, int len, long long recv_ns)>;
  // a restart: the child's exit status (wait(2) status) and the restart count so far
  using RestartHandler = std::function<void(int status, long long restarts)>;

  // exe: the coopdynd binary to exec with --rx-child (normally /proc/self/exe). Throws
  // std::runtime_error if the shared memory cannot be set up.
  // channels: received literally (not as LCM regular expressions), e.g. the input and the control channel
  IsolatedReceiver(std::string exe, std::string url, std::vector<std::string> channels, int slots, int slot_bytes);
  ~IsolatedReceiver();
  IsolatedReceiver(const IsolatedReceiver&) = delete;
  IsolatedReceiver& operator=(const IsolatedReceiver&) = delete;

  // Starts the child and the receive thread; handler runs on the receive thread.
  void start(Handler handler, RestartHandler on_restart);
  void stop();  // stops the thread, kills and reaps the child (also done by the destructor)

  long long restarts() const { return restarts_.load(std::memory_order_relaxed); }
  long long dropped() const;
  long long child_received() const;
  pid_t child_pid() const { return pid_.load(); }
  // true once the current child has subscribed (tests wait for it)
  bool child_ready() const;

 private:
  void spawn();
  void run();
  std::string exe_, url_;
  std::vector<std::string> channels_;
  int slots_, slot_bytes_;
  int shm_fd_ = -1, event_fd_ = -1;
  size_t shm_size_ = 0;
  RxRingHeader* hdr_ = nullptr;
  unsigned char* base_ = nullptr;
  std::atomic<pid_t> pid_{-1};
  std::atomic<long long> restarts_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
  Handler handler_;
  RestartHandler on_restart_;
};

// The child's main (coopdynd --rx-child URL SHM_FD EVENT_FD CHANNEL...). Returns the exit status.
int rx_child_main(int argc, char** argv);

}  // namespace coopdyn::io
