#include "service/io/transport/rx_in_loop.h"

#include <poll.h>
#include <time.h>
#include <unistd.h>

#include <stdexcept>

#include "service/io/transport/lcm_bus.h"

namespace coopdyn::io {

namespace {

wire::UdpmUrl udpm_or_throw(const std::string& url) {
  wire::UdpmUrl u;
  std::string why;
  if (!wire::parse_udpm_url(url, &u, &why))
    throw std::runtime_error("realtime.receive_in_loop reads udpm:// inputs only; input URL '" + url + "': " + why);
  return u;
}

}  // namespace

InLoopReceiver::InLoopReceiver(const std::string& url, const std::vector<std::string>& channels,
                               const std::vector<int64_t>& fingerprints, int max_message_bytes, int socket_buffer_bytes)
    : gate_(input_channels(channels, fingerprints), max_message_bytes, &counters_store_) {
  counters_ = &counters_store_;
  const wire::UdpmUrl u = udpm_or_throw(url);
  std::string why;
  fd_ = open_input_socket(u, socket_buffer_bytes, gate_.channels(), &counters_store_, &why);
  if (fd_ < 0) throw std::runtime_error("realtime.receive_in_loop: input URL '" + url + "': " + why);
}

InLoopReceiver::~InLoopReceiver() {
  if (fd_ >= 0) close(fd_);
}

void InLoopReceiver::wait_readable(long long deadline_ns) const {
  const long long left = deadline_ns - monotonic_ns();
  if (left <= 0) return;
  const timespec ts{static_cast<time_t>(left / 1000000000LL), static_cast<long>(left % 1000000000LL)};
  pollfd pfd{fd_, POLLIN, 0};
  ppoll(&pfd, 1, &ts, nullptr);
}

}  // namespace coopdyn::io
