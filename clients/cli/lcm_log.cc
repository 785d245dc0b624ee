#include "clients/cli/lcm_log.h"

#include <lcm/lcm-cpp.hpp>
#include <sys/stat.h>

#include <stdexcept>

namespace coopdyn::cli {

void read_lcm_log(const std::string& path, const std::function<bool(const LogMessage&)>& f) {
  struct stat st{};
  // LogFile opens a directory (fopen "r" succeeds on Linux) and then reads nothing: say so instead
  if (stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) throw std::runtime_error("cannot read '" + path + "' as an LCM log");
  lcm::LogFile log(path, "r");
  if (!log.good()) throw std::runtime_error("cannot read '" + path + "' as an LCM log");
  std::string channel;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    channel = ev->channel;
    const LogMessage m{channel, ev->timestamp, ev->data, ev->datalen, io::identify(ev->data, ev->datalen)};
    if (!f(m)) break;
  }
}

}  // namespace coopdyn::cli
