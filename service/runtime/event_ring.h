// Single-producer single-consumer ring of small fixed-size events: how the loop "logs" without
// logging. The loop pushes (wait-free, no allocation, drops and counts when full); the daemon's
// monitor thread pops and writes them through spdlog.
#pragma once

#include <atomic>
#include <cstdint>

namespace coopdyn::runtime {

enum class EventCode : int32_t {
  kCommandExpired,  // a: seq of the expired command, b: age ms
  kCommandResumed,  // a: seq
  kStateExpired,    // a: seq
  kStateResumed,    // a: seq
  kFault,           // a: reason code, b: tick
  kOverrun,         // a: periods behind, b: tick (first of a burst only)
  kControl,         // a: seq of the control_t handled, b: action * 16 + (result + 1)
  kClosureOpen,     // estimate: a measured state above closure_tolerance (first of a run): a: seq,
                    // b: closure kind * 65536 + constraint index + 1 (0: none), x: the residual
  kClosureBack,     // the first state back within tolerance: a: seq
  kResetRejected,   // a reset_to_state refused: a: seq of the control_t, b: (ResetRefusal * 4 + closure
                    // kind) * 65536 + constraint index + 1 (0: none), x: the closure residual (kClosure)
  kFifoDemoted,     // the loop stepped down from SCHED_FIFO to SCHED_OTHER (fifo_guard.h): a: the
                    // verdict (FifoGuard::Verdict), b: tick, x: the window's busy share; a < 0: the
                    // kernel refused the step down
  kLimitPassed,     // a joint passed a limit for the first time since start (or a reset): a: its
                    // velocity index, b: the LimitBit(s) newly passed (joint_limits.h), x: sim_time s
};

// Why a reset_to_state was refused.
enum class ResetRefusal : int {
  kNone = 0,
  kConfiguration = 1,  // q is not a valid configuration (non-finite, a quaternion not of unit norm)
  kVelocity = 2,       // v not finite
  kEvaluation = 3,     // the evaluation at (q, v) failed (singular, non-finite)
  kClosure = 4,        // (q, v) does not close the constraints to 1e-6 (m, rad, m/s, rad/s)
};

struct Event {
  EventCode code;
  int64_t a = 0, b = 0;
  double x = 0;
};

template <int N>
class EventRing {
  static_assert((N & (N - 1)) == 0, "power of two");

 public:
  bool push(const Event& e) {
    const uint32_t h = head_.load(std::memory_order_relaxed);
    if (h - tail_.load(std::memory_order_acquire) >= N) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    buf_[h & (N - 1)] = e;
    head_.store(h + 1, std::memory_order_release);
    return true;
  }
  bool pop(Event* e) {
    const uint32_t t = tail_.load(std::memory_order_relaxed);
    if (t == head_.load(std::memory_order_acquire)) return false;
    *e = buf_[t & (N - 1)];
    tail_.store(t + 1, std::memory_order_release);
    return true;
  }
  uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  Event buf_[N];
  std::atomic<uint32_t> head_{0}, tail_{0};
  std::atomic<uint64_t> dropped_{0};
};

}  // namespace coopdyn::runtime
