// Latest-value handoff from one writer thread to one reader thread: three preallocated slots, an
// atomic index exchange, no locks and no allocation. The writer fills write_slot(), then
// publish(); the reader calls update() (true if a newer value arrived) and reads read_slot(),
// which stays valid and unchanged until its next update(). Values published between two reads are
// overwritten: the reader always gets the newest (drake-iiwa-driver's queue of one).
#pragma once

#include <atomic>
#include <cstdint>

namespace coopdyn::runtime {

template <class T>
class TripleBuffer {
 public:
  // init(slot) sizes each slot once (e.g. Eigen vectors to nv).
  template <class Init>
  explicit TripleBuffer(Init init) {
    for (T& s : slots_) init(s);
  }
  T& write_slot() { return slots_[back_]; }
  void publish() {
    const uint8_t old = middle_.exchange(static_cast<uint8_t>(back_ | kFresh), std::memory_order_acq_rel);
    back_ = old & kIndex;
  }
  bool update() {
    if (!(middle_.load(std::memory_order_acquire) & kFresh)) return false;
    const uint8_t old = middle_.exchange(front_, std::memory_order_acq_rel);
    front_ = old & kIndex;
    return true;
  }
  const T& read_slot() const { return slots_[front_]; }

 private:
  static constexpr uint8_t kIndex = 3, kFresh = 4;
  T slots_[3];
  uint8_t back_ = 0;                 // writer's slot
  std::atomic<uint8_t> middle_{1};   // shared slot index | kFresh when unread
  uint8_t front_ = 2;                // reader's slot
  static_assert(std::atomic<uint8_t>::is_always_lock_free, "lock-free handoff");
};

}  // namespace coopdyn::runtime
