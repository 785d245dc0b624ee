// A wake-up from the receive thread to the loop thread without a lock: a counter the receive thread
// increments (ring) and the loop thread waits on with an absolute CLOCK_MONOTONIC deadline (wait),
// through the Linux futex system call (FUTEX_WAIT_BITSET takes an absolute monotonic time). No
// allocation, no mutex, no condition variable: ring() is an atomic add and, only when the loop
// is asleep in wait(), one FUTEX_WAKE; wait() returns at once when the counter moved since `seen`.
// Used by the event-driven estimate mode (config `trigger: arrival`): the loop computes when a
// measured state arrives instead of at its next tick.
#pragma once

#include <linux/futex.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>

namespace coopdyn::runtime {

class Doorbell {
 public:
  // Any thread.
  void ring() {
    count_.fetch_add(1, std::memory_order_seq_cst);  // ordered before the load of sleeping_ (and wait()'s the other way round)
    if (sleeping_.load(std::memory_order_seq_cst))
      syscall(SYS_futex, reinterpret_cast<uint32_t*>(&count_), FUTEX_WAKE_PRIVATE, 1, nullptr, nullptr, 0);
  }
  uint32_t value() const { return count_.load(std::memory_order_acquire); }
  // One waiter (the loop thread). Returns when value() != seen, at the absolute CLOCK_MONOTONIC time
  // deadline_ns, or on a signal; the caller re-reads value() and the clock.
  void wait(uint32_t seen, long long deadline_ns) {
    sleeping_.store(true, std::memory_order_seq_cst);
    if (count_.load(std::memory_order_seq_cst) == seen) {
      timespec ts;
      ts.tv_sec = static_cast<time_t>(deadline_ns / 1000000000LL);
      ts.tv_nsec = static_cast<long>(deadline_ns % 1000000000LL);
      // returns EAGAIN at once if the counter is no longer `seen` (the kernel compares atomically)
      syscall(SYS_futex, reinterpret_cast<uint32_t*>(&count_), FUTEX_WAIT_BITSET_PRIVATE, seen, &ts, nullptr,
              FUTEX_BITSET_MATCH_ANY);
    }
    sleeping_.store(false, std::memory_order_relaxed);
  }

 private:
  std::atomic<uint32_t> count_{0};
  std::atomic<bool> sleeping_{false};
  static_assert(sizeof(std::atomic<uint32_t>) == sizeof(uint32_t), "the futex word is the counter itself");
};

}  // namespace coopdyn::runtime
