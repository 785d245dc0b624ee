// LCM behind the Bus interface, plus a receive thread.
//
// Publishing: lcm_publish() of raw bytes from the caller's thread. With udpm:// that is one
// sendmsg() on a non-blocking-in-practice UDP socket into the kernel (fragmenting messages above
// the MTU), no heap allocation in LCM 1.3's udpm path; the kernel delivers the datagram to every
// subscriber on the host and wakes it inside that call. coopdynd's fixed-rate loop hands its bytes
// to a publisher thread that calls this (runtime/publisher_thread.h); on arrival the loop calls it
// itself. memq:// (tests) copies each message on the heap: fine for tests, not for a real-time loop.
// Receiving: a thread runs lcm_handle_timeout() and calls the raw handlers; the loop never
// touches lcm_handle.
#pragma once

#include <time.h>

#include <atomic>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "service/io/transport/bus.h"

typedef struct _lcm_t lcm_t;

namespace coopdyn::io {

class LcmBus : public Bus {
 public:
  // raw message: bytes, length, receive time (CLOCK_MONOTONIC ns, taken by the receive thread)
  using Handler = std::function<void(const void* data, int len, long long recv_ns)>;

  // Throws std::runtime_error with a hint (multicast route, URL) when LCM cannot start.
  explicit LcmBus(const std::string& url);
  ~LcmBus() override;
  LcmBus(const LcmBus&) = delete;
  LcmBus& operator=(const LcmBus&) = delete;

  int publish(const char* channel, const void* data, int len) override;

  // Subscribe before start(); the handler runs on the receive thread. channel is a regex in LCM's
  // sense (the whole channel name must match).
  void subscribe(const std::string& channel, Handler h);
  // Starts the receive thread. busy_poll: it never sleeps, a whole CPU (yielded to any other
  // runnable thread between two polls), as a real-time controller that polls each cycle. On a
  // udpm URL it then reads its own socket in the group (udpm_socket.h) and LCM's wire format
  // (lcm_wire.h: LC02, LC03 reassembled), so that a message is handled as soon as the kernel has it,
  // without the wake-up of liblcm's read thread; on other URLs it polls lcm_handle_timeout(0).
  void start(bool busy_poll = false);
  void stop();   // joins it (also done by the destructor)
  lcm_t* raw() { return lcm_; }

 private:
  struct Subscription;
  static void on_message(const void* rbuf, const char* channel, void* user);
  void poll_socket();  // the busy-poll reader on a udpm URL
  std::string url_;
  lcm_t* lcm_ = nullptr;
  std::vector<std::unique_ptr<Subscription>> subs_;
  int fd_ = -1;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// clock id's time in ns, -1 if it cannot be read (a CPU-time clock of a process or thread gone)
long long clock_ns(clockid_t id);
long long monotonic_ns();  // CLOCK_MONOTONIC
long long wall_us();       // CLOCK_REALTIME, microseconds since the epoch (LCM's utime)

}  // namespace coopdyn::io
