#include "service/io/transport/lcm_bus.h"

#include <lcm/lcm.h>
#include <netinet/in.h>
#include <sched.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <regex>
#include <vector>

#include "service/io/transport/lcm_wire.h"
#include "service/io/transport/udpm_socket.h"

namespace coopdyn::io {

struct LcmBus::Subscription {
  std::string channel;
  std::regex whole;  // LCM's rule: the regex matches the whole channel name
  Handler handler;
};

long long clock_ns(clockid_t id) {
  timespec ts;
  if (clock_gettime(id, &ts) != 0) return -1;
  return static_cast<long long>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

long long monotonic_ns() { return clock_ns(CLOCK_MONOTONIC); }

long long wall_us() {
  timespec ts;
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<long long>(ts.tv_sec) * 1000000LL + ts.tv_nsec / 1000;
}

LcmBus::LcmBus(const std::string& url) : url_(url) {
  lcm_ = lcm_create(url.c_str());
  if (!lcm_) {
    std::string hint;
    if (url.rfind("udpm://", 0) == 0 || url.empty())
      hint = " (udpm needs a multicast route: 'ip route add 224.0.0.0/4 dev lo' as root for one machine)";
    throw std::runtime_error("cannot start LCM with URL '" + url + "'" + hint);
  }
}

LcmBus::~LcmBus() {
  stop();
  if (lcm_) lcm_destroy(lcm_);
}

int LcmBus::publish(const char* channel, const void* data, int len) {
  return lcm_publish(lcm_, channel, data, static_cast<unsigned>(len));
}

void LcmBus::on_message(const void* rbuf, const char* /*channel*/, void* user) {
  const lcm_recv_buf_t* b = static_cast<const lcm_recv_buf_t*>(rbuf);
  static_cast<Subscription*>(user)->handler(b->data, static_cast<int>(b->data_size), monotonic_ns());
}

void LcmBus::subscribe(const std::string& channel, Handler h) {
  subs_.push_back(std::make_unique<Subscription>(
      Subscription{channel, std::regex(channel, std::regex::extended), std::move(h)}));
}

// Datagrams read as they come (non-blocking, yielding between polls), messages reassembled,
// each handed to the subscriptions whose regex matches its whole channel.
void LcmBus::poll_socket() {
  wire::Reassembler reassembler(4, 1 << 22, 2000000000LL);
  std::vector<unsigned char> buf(65536);
  sockaddr_storage from{};
  while (!stop_.load(std::memory_order_relaxed)) {
    socklen_t fl = sizeof from;
    const ssize_t n = recvfrom(fd_, buf.data(), buf.size(), 0, reinterpret_cast<sockaddr*>(&from), &fl);
    if (n <= 0) {
      sched_yield();
      continue;
    }
    const long long now = monotonic_ns();
    const auto* in = reinterpret_cast<const sockaddr_in*>(&from);
    const uint64_t sender = static_cast<uint64_t>(in->sin_addr.s_addr) << 16 | in->sin_port;
    wire::Message m;
    if (reassembler.add(buf.data(), static_cast<size_t>(n), sender, now, &m) != wire::WireStatus::kComplete) continue;
    const std::string channel(m.channel, static_cast<size_t>(m.channel_len));
    for (const auto& sub : subs_)
      if (std::regex_match(channel, sub->whole)) sub->handler(m.data, m.len, now);
  }
}

void LcmBus::start(bool busy_poll) {
  if (thread_.joinable()) return;
  stop_ = false;
  wire::UdpmUrl u;
  std::string why;
  if (busy_poll && (url_.rfind("udpm://", 0) == 0 || url_.empty()) && wire::parse_udpm_url(url_, &u, &why)) {
    UdpmSocket s = open_udpm_socket(u, 0, nullptr);
    if (s.fd < 0) throw std::runtime_error("cannot read LCM URL '" + url_ + "' by polling: " + s.why);
    fd_ = s.fd;
    thread_ = std::thread([this] { poll_socket(); });
    return;
  }
  for (const auto& sub : subs_)
    lcm_subscribe(
        lcm_, sub->channel.c_str(),
        [](const lcm_recv_buf_t* rbuf, const char* ch, void* user) { on_message(rbuf, ch, user); }, sub.get());
  thread_ = std::thread([this, busy_poll] {
    while (!stop_.load(std::memory_order_relaxed)) {
      // polling: nothing waiting returns at once; the CPU goes to any other runnable thread between
      // two polls (liblcm's own read thread among them), never to the idle loop
      if (lcm_handle_timeout(lcm_, busy_poll ? 0 : 50) <= 0 && busy_poll) sched_yield();
    }
  });
}

void LcmBus::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (fd_ >= 0) close(fd_);
  fd_ = -1;
}

}  // namespace coopdyn::io
