// When a real-time thread must step down to SCHED_OTHER: the guard that lets the loop (and the
// receive process) take SCHED_FIFO by default without ever hogging a CPU.
//
// A SCHED_FIFO thread runs until it blocks: one that computes most of the time (a scene too heavy
// for the period, an overrun policy catching up back to back, a receive process under a flood)
// leaves the other tasks of its CPU only what the kernel's real-time throttling keeps for them
// (sched_rt_runtime_us: 5 % by default). The guard is fed each window's busy time (the CPU time
// the thread or process took in it; a busy-polling loop's, whose polling is meant to hold its CPU,
// the sum of its ticks' compute time) and its ticks and overruns, and says when to step down:
//   - busy more than kMaxBusyShare of the window's wall time (the thread would hold half a CPU or
//     more at real-time priority), or
//   - at least kOverrunShare of the window's ticks overran, kOverrunWindows windows in a row (the
//     loop does not keep its period at this priority either: the priority only takes CPU from others).
// It is a decision on numbers, no clock, no system call, no allocation; the caller steps down
// (demote_to_other(), realtime.h) once and reports it through its event ring, never by logging.
// The same idea as RealtimeKit's canary (rtkit-daemon demotes every real-time thread to
// SCHED_OTHER when a canary thread at a lower priority starves) and the kernel's RLIMIT_RTTIME, but
// measured on the thread's own work so that a loop that only sleeps and computes briefly keeps its
// priority forever.
#pragma once

#include <cstdint>

namespace coopdyn::runtime {

class FifoGuard {
 public:
  static constexpr double kMaxBusyShare = 0.5;
  static constexpr double kOverrunShare = 0.5;
  static constexpr int kOverrunWindows = 3;

  enum class Verdict { kKeep, kBusy, kOverruns };

  // One window: its wall time, the thread's busy time in it (ns), its ticks and overruns (0, 0 for
  // a thread without ticks). kKeep, or why to step down.
  Verdict window(int64_t window_ns, int64_t busy_ns, int64_t ticks, int64_t overruns) {
    if (window_ns <= 0) return Verdict::kKeep;
    if (static_cast<double>(busy_ns) > kMaxBusyShare * static_cast<double>(window_ns)) return Verdict::kBusy;
    const bool overran = ticks > 0 && static_cast<double>(overruns) >= kOverrunShare * static_cast<double>(ticks);
    overrun_windows_ = overran ? overrun_windows_ + 1 : 0;
    return overrun_windows_ >= kOverrunWindows ? Verdict::kOverruns : Verdict::kKeep;
  }

 private:
  int overrun_windows_ = 0;  // consecutive windows with kOverrunShare of their ticks overrun
};

}  // namespace coopdyn::runtime
