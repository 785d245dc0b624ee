// Real-time settings for the calling thread (SCHED_FIFO, by default when the process may; CPU
// affinity) and the process (mlockall, cpu_dma_latency). Each returns a line saying what happened; a
// refusal is not fatal (the loop still runs, with worse jitter), so the caller logs it as a warning.
#pragma once

#include <string>
#include <vector>

#include "service/runtime/config.h"

namespace coopdyn::runtime {

struct RealtimeResult {
  bool ok;
  std::string line;
};

std::vector<RealtimeResult> apply_realtime(const RealtimeOptions& o);

// The calling thread's scheduling policy is SCHED_FIFO (one system call).
bool runs_fifo();
// Thread or process pid (0: the calling thread) to SCHED_OTHER: the guard's step down
// (fifo_guard.h). No allocation, no lock, no throw; false if the kernel refused.
bool demote_to_other(int pid = 0);

}  // namespace coopdyn::runtime
