// A Bus that publishes from a thread of its own: publish() copies the bytes into one of a few
// preallocated slots (a single-producer, single-consumer ring) and rings a Doorbell (an atomic add,
// and one FUTEX_WAKE only when the thread sleeps); the thread hands each slot, in order, to the inner
// bus (LcmBus: lcm_publish, one sendmsg). Used by coopdynd's fixed-rate loop (config
// realtime.publisher_thread): on UDP multicast the sendmsg also delivers the datagram to every
// subscriber on the host and wakes it, on the sending thread's CPU and inside its time (bench/README.md,
// "Loop timing"); here that is the publisher thread's, kept off the loop's CPU when the loop is
// pinned. What the loop keeps: the copy and the wake of this thread.
// publish() does not allocate, lock, block or throw; when every slot is still waiting (the thread has
// not run for kSlots messages) the message is dropped and counted, never waited for. A queued message
// the inner bus refuses is counted too (failed(), Bus::failed_after_accept()).
// Priority (start()): SCHED_FIFO (coopdynd: just below the loop) or a nice value, so that the
// processes loading the machine at SCHED_OTHER cannot hold the thread off for kSlots ticks (outputs
// dropped); it only ever runs for what the loop queued, so it cannot hog a CPU. What each costs the
// loop and saves: bench/README.md, "Commands at 1 kHz and outputs under load".
#pragma once

#include <atomic>
#include <cstdint>
#include <thread>
#include <vector>

#include "service/io/transport/bus.h"
#include "service/runtime/doorbell.h"

namespace coopdyn::runtime {

class PublisherThread : public io::Bus {
 public:
  static constexpr int kSlots = 8;
  static constexpr int kChannelChars = 64;  // channel names are 1..63 characters (config)
  // inner outlives this; max_bytes: the largest message publish() takes (larger ones: -1, counted)
  PublisherThread(io::Bus& inner, int max_bytes);
  ~PublisherThread() override;  // stop()
  PublisherThread(const PublisherThread&) = delete;
  PublisherThread& operator=(const PublisherThread&) = delete;

  // Starts the thread; avoid_cpu >= 0 keeps it off that CPU (the loop's) when another is allowed;
  // fifo_priority > 0: SCHED_FIFO at that priority, else nice != 0: SCHED_OTHER at that nice value
  // (either refused without the privilege: priority_granted() false).
  void start(int avoid_cpu = -1, int fifo_priority = 0, int nice = 0);
  // the priority asked of start() was granted (known once scheduled(): false before)
  bool priority_granted() const { return fifo_.load() > 0; }
  // whether the thread has applied its scheduling request (priority_granted() is then final)
  bool scheduled() const { return fifo_.load() != 0; }
  // Publishes what is queued, then joins the thread. Idempotent.
  void stop();
  // One producer thread (the loop's). Returns 0 when queued, -1 when dropped (ring full or too long).
  int publish(const char* channel, const void* data, int len) override;

  int64_t published() const { return published_.load(std::memory_order_relaxed); }
  int64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }
  // queued messages the inner bus then refused (its publish returned non-zero)
  int64_t failed() const { return failed_.load(std::memory_order_relaxed); }
  long long failed_after_accept() const override { return failed(); }

 private:
  struct Slot {
    char channel[kChannelChars];
    int len = 0;
    std::vector<uint8_t> bytes;  // max_bytes, sized once
  };
  void run();
  void drain();

  io::Bus& inner_;
  const int max_bytes_;
  Slot slots_[kSlots];
  alignas(64) std::atomic<uint64_t> head_{0};  // next slot the producer fills
  alignas(64) std::atomic<uint64_t> tail_{0};  // next slot the thread publishes
  alignas(64) std::atomic<int64_t> published_{0}, dropped_{0}, failed_{0};
  std::atomic<bool> stop_{false};
  std::atomic<int> fifo_{0};  // 0: not yet known, 1: the priority asked granted, -1: not (or none asked)
  Doorbell bell_;
  std::thread thread_;
};

}  // namespace coopdyn::runtime
