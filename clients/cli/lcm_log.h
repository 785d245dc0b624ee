// Reading an lcm-logger file, event by event: the one log reader of the coopdyn clients (coopdyn log
// converts every channel to CSV, coopdyn view --log draws the output_t channel).
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "service/io/codec/codec.h"

namespace coopdyn::cli {

struct LogMessage {
  const std::string& channel;
  int64_t timestamp_us;   // the logger's receive time, microseconds since the epoch
  const void* data;
  int len;
  io::MessageType type;   // by the message's fingerprint (kUnknown: not a coopdyn message)
};

// Calls f on every event of the log, in order; f returns false to stop. Throws std::runtime_error
// "cannot read 'PATH' as an LCM log" when the file cannot be opened as one.
void read_lcm_log(const std::string& path, const std::function<bool(const LogMessage&)>& f);

}  // namespace coopdyn::cli
