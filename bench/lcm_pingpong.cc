// The transport's share of coopdynd's event-driven latency: two processes that only talk LCM.
//
//   lcm_pingpong echo URL SECONDS [--busy-poll]      republish each PING at once as a PONG of the same size
//   lcm_pingpong ping URL BYTES COUNT [--busy-poll]  COUNT PINGs of BYTES at 100 Hz (random phase), each
//                                                    timed from its publish to the receipt of its PONG
//
// Both ends publish with lcm_publish and receive through io::LcmBus (liblcm's receive thread, then
// the handler thread), as `coopdyn send --measure-latency` does at its end; with --busy-poll that
// end's thread polls the group's socket itself without sleeping (LcmBus::start(true), `coopdyn send
// --busy-poll`: no liblcm read thread). The round trip is two
// liblcm receipts with no computation: what remains of coopdynd's publish-to-wrenches latency when
// its compute and handoff are taken out is one such receipt plus the receive process's own
// (bench/loop_timing.sh prints it next to the daemon's rows).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "service/io/transport/lcm_bus.h"

using coopdyn::io::LcmBus;
using coopdyn::io::monotonic_ns;

namespace {

int echo(const std::string& url, double seconds, bool busy_poll) {
  LcmBus bus(url);
  bus.subscribe("PINGPONG_PING", [&bus](const void* d, int n, long long) { bus.publish("PINGPONG_PONG", d, n); });
  bus.start(busy_poll);
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  bus.stop();
  return 0;
}

int ping(const std::string& url, int bytes, int count, bool busy_poll) {
  LcmBus bus(url);
  std::mutex mu;
  std::vector<double> rtt_us;
  bus.subscribe("PINGPONG_PONG", [&](const void* d, int n, long long recv_ns) {
    long long sent = 0;
    if (n < static_cast<int>(sizeof sent)) return;
    std::memcpy(&sent, d, sizeof sent);
    std::lock_guard<std::mutex> lk(mu);
    rtt_us.push_back(static_cast<double>(recv_ns - sent) * 1e-3);
  });
  bus.start(busy_poll);
  std::vector<unsigned char> msg(static_cast<size_t>(std::max<int>(bytes, 8)), 0x5a);
  std::mt19937_64 rng(12345);
  std::uniform_int_distribution<long long> phase(0, 999999);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the echo subscribed
  long long next = monotonic_ns();
  for (int i = 0; i < count; ++i) {
    next += 10000000;  // 100 Hz, each at a random phase within its millisecond
    std::this_thread::sleep_until(std::chrono::steady_clock::time_point(std::chrono::nanoseconds(next + phase(rng))));
    const long long t = monotonic_ns();
    std::memcpy(msg.data(), &t, sizeof t);
    bus.publish("PINGPONG_PING", msg.data(), static_cast<int>(msg.size()));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  bus.stop();
  std::lock_guard<std::mutex> lk(mu);
  if (rtt_us.empty()) {
    std::fprintf(stderr, "lcm_pingpong: no PONG came back (is the echo running on %s?)\n", url.c_str());
    return 1;
  }
  std::sort(rtt_us.begin(), rtt_us.end());
  const auto pct = [&](double q) { return rtt_us[static_cast<size_t>(q * static_cast<double>(rtt_us.size() - 1))]; };
  std::printf("lcm_pingpong: round trip over %zu of %d messages of %d bytes: min %.1f us, p50 %.1f us, p99 %.1f us\n",
              rtt_us.size(), count, bytes, rtt_us.front(), pct(0.5), pct(0.99));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const bool poll = argc > 1 && std::strcmp(argv[argc - 1], "--busy-poll") == 0;
  const int n = poll ? argc - 1 : argc;
  if (n == 4 && std::strcmp(argv[1], "echo") == 0) return echo(argv[2], std::atof(argv[3]), poll);
  if (n == 5 && std::strcmp(argv[1], "ping") == 0) return ping(argv[2], std::atoi(argv[3]), std::atoi(argv[4]), poll);
  std::fprintf(stderr, "usage: lcm_pingpong echo URL SECONDS [--busy-poll] | lcm_pingpong ping URL BYTES COUNT [--busy-poll]\n");
  return 2;
}
