#include "service/io/lcm_bus.h"

#include <lcm/lcm.h>
#include <sched.h>
#include <time.h>

namespace coopdyn::io {

long long monotonic_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<long long>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

long long wall_us() {
  timespec ts;
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<long long>(ts.tv_sec) * 1000000LL + ts.tv_nsec / 1000;
}

LcmBus::LcmBus(const std::string& url) {
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
  (*static_cast<Handler*>(user))(b->data, static_cast<int>(b->data_size), monotonic_ns());
}

void LcmBus::subscribe(const std::string& channel, Handler h) {
  handlers_.push_back(std::make_unique<Handler>(std::move(h)));
  lcm_subscribe(
      lcm_, channel.c_str(),
      [](const lcm_recv_buf_t* rbuf, const char* ch, void* user) { on_message(rbuf, ch, user); },
      handlers_.back().get());
}

void LcmBus::start(bool busy_poll) {
  if (thread_.joinable()) return;
  stop_ = false;
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
}

}  // namespace coopdyn::io
