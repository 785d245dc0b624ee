// LcmBus's polling reader (start(true) on a udpm URL reads the group's datagrams itself) against
// liblcm's own receive path: the same messages, byte for byte, short and fragmented, and the same
// channel rule (a regex matching the whole channel name). Skipped, saying why, where multicast does
// not leave by lo (io/transport/multicast_route.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "service/io/transport/lcm_bus.h"
#include "service/io/transport/multicast_route.h"
#include "tests/support/private_udpm_url.h"

using namespace coopdyn;

namespace {

struct Inbox {
  std::mutex mu;
  std::vector<std::string> got;
  io::LcmBus::Handler handler() {
    return [this](const void* d, int n, long long) {
      std::lock_guard<std::mutex> lk(mu);
      got.emplace_back(static_cast<const char*>(d), static_cast<size_t>(n));
    };
  }
  size_t size() {
    std::lock_guard<std::mutex> lk(mu);
    return got.size();
  }
};

std::string random_bytes(size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(rng() & 0xff);
  return s;
}

}  // namespace

TEST(LcmBus, PollingReaderReceivesWhatLiblcmReceives) {
  const std::string url = coopdyn::testing::private_udpm_url(7);
  // 200 kB in one burst needs the kernel's loopback of whole datagrams (a multicast route on lo)
  if (const std::string why = io::loopback_multicast_problem(url); !why.empty()) GTEST_SKIP() << why;
  // each bus: "PING_[0-9]+" into one inbox, "PING" into another
  io::LcmBus polled(url), slept(url), tx(url);
  Inbox polled_numbered, polled_plain, slept_numbered, slept_plain;
  polled.subscribe("PING_[0-9]+", polled_numbered.handler());
  polled.subscribe("PING", polled_plain.handler());
  slept.subscribe("PING_[0-9]+", slept_numbered.handler());
  slept.subscribe("PING", slept_plain.handler());
  polled.start(true);
  slept.start(false);
  // one short message (LC02), one of 200,000 bytes (LC03, four fragments), then a name that only
  // contains a subscribed one and must match neither, and the plain channel last: once the plain
  // inbox has its message, the ones before it have been delivered or lost
  const std::string small = random_bytes(300, 1), large = random_bytes(200000, 2), plain = random_bytes(40, 3);
  std::vector<std::string> numbered;
  for (int attempt = 0; attempt < 50 && (polled_plain.size() == 0 || slept_plain.size() == 0); ++attempt) {
    tx.publish("PING_1", small.data(), static_cast<int>(small.size()));
    tx.publish("PING_22", large.data(), static_cast<int>(large.size()));
    tx.publish("XPING_1", small.data(), static_cast<int>(small.size()));
    tx.publish("PING", plain.data(), static_cast<int>(plain.size()));
    for (int i = 0; i < 100 && (polled_plain.size() == 0 || slept_plain.size() == 0); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  polled.stop();
  slept.stop();
  ASSERT_GE(polled_plain.size(), 1u);
  ASSERT_GE(slept_plain.size(), 1u);
  for (Inbox* in : {&polled_plain, &slept_plain})
    for (const std::string& m : in->got) EXPECT_EQ(m, plain) << "only PING's messages, exactly";
  for (Inbox* in : {&polled_numbered, &slept_numbered}) {
    ASSERT_GE(in->got.size(), 2u);
    for (const std::string& m : in->got) EXPECT_TRUE(m == small || m == large) << "PING_1 and PING_22 only";
    EXPECT_NE(std::find(in->got.begin(), in->got.end(), large), in->got.end()) << "the fragmented message whole";
  }
}

// A group the socket cannot join: an error that names it, not a reader that never receives.
TEST(LcmBus, PollingReaderThatCannotJoinItsGroupSaysSo) {
  EXPECT_THROW(
      {
        io::LcmBus bus("udpm://10.0.0.1:7667?ttl=0");  // not a multicast group
        bus.subscribe("X", [](const void*, int, long long) {});
        bus.start(true);
      },
      std::runtime_error);
}
