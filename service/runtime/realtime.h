// Opt-in real-time settings for the calling thread (SCHED_FIFO, CPU affinity) and the process
// (mlockall). Each returns a line saying what happened; a refusal is not fatal (the loop still runs,
// with worse jitter), so the caller logs it as a warning.
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

}  // namespace coopdyn::runtime
