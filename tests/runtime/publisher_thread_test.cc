// PublisherThread: every message reaches the inner bus once, in order, byte for byte, on its channel;
// publish() never waits for the inner bus (a full ring drops the newest message and counts it); stop()
// sends what was queued before it.
#include "service/runtime/publisher_thread.h"

#include <gtest/gtest.h>

#include <atomic>
#include <string>
#include <thread>
#include <vector>

using coopdyn::runtime::PublisherThread;

namespace {

// Records what reaches it (the publisher thread's side); publish() can be held until released.
struct RecordingBus : coopdyn::io::Bus {
  struct Message {
    std::string channel;
    std::vector<uint8_t> bytes;
  };
  std::vector<Message> got;  // written by the publisher thread only, read after stop()
  std::atomic<bool> hold{false}, inside{false};
  int publish(const char* channel, const void* data, int len) override {
    inside.store(true);
    while (hold.load()) std::this_thread::yield();
    const auto* p = static_cast<const uint8_t*>(data);
    got.push_back({channel, std::vector<uint8_t>(p, p + len)});
    return 0;
  }
};

// message k: its length and bytes follow from k, so a swapped, torn or repeated one shows
std::vector<uint8_t> message(int k) {
  std::vector<uint8_t> m(static_cast<size_t>(1 + (k * 37) % 5000));
  for (size_t i = 0; i < m.size(); ++i) m[i] = static_cast<uint8_t>(k * 131 + static_cast<int>(i));
  return m;
}

}  // namespace

TEST(PublisherThread, EveryMessageInOrderByteForByte) {
  RecordingBus inner;
  PublisherThread pub(inner, 5000);
  pub.start();
  const int n = 3000;
  for (int k = 0; k < n; ++k) {
    const std::vector<uint8_t> m = message(k);
    // the ring holds kSlots messages: when the thread is behind, wait for it (here; the loop drops)
    while (pub.publish(k % 3 ? "COOPDYN_OUTPUT" : "COOPDYN_STATS", m.data(), static_cast<int>(m.size())) != 0)
      std::this_thread::yield();
  }
  pub.stop();
  ASSERT_EQ(static_cast<int>(inner.got.size()), n);
  for (int k = 0; k < n; ++k) {
    EXPECT_EQ(inner.got[k].channel, k % 3 ? "COOPDYN_OUTPUT" : "COOPDYN_STATS") << k;
    ASSERT_EQ(inner.got[k].bytes, message(k)) << "message " << k;
  }
  EXPECT_EQ(pub.published(), n);
}

TEST(PublisherThread, NeverWaitsForTheInnerBusAndCountsWhatItDrops) {
  RecordingBus inner;
  inner.hold.store(true);
  PublisherThread pub(inner, 5000);
  pub.start();
  const std::vector<uint8_t> first = message(0);
  ASSERT_EQ(pub.publish("C", first.data(), static_cast<int>(first.size())), 0);
  while (!inner.inside.load()) std::this_thread::yield();  // the thread is stuck in the inner publish
  // the message in the inner bus still holds its slot: kSlots - 1 more fit, the next are dropped
  for (int k = 1; k < PublisherThread::kSlots + 5; ++k) {
    const std::vector<uint8_t> m = message(k);
    EXPECT_EQ(pub.publish("C", m.data(), static_cast<int>(m.size())), k < PublisherThread::kSlots ? 0 : -1) << k;
  }
  EXPECT_EQ(pub.dropped(), 5);
  const std::vector<uint8_t> too_long(5001, 7);
  EXPECT_EQ(pub.publish("C", too_long.data(), static_cast<int>(too_long.size())), -1);
  const std::string long_name(PublisherThread::kChannelChars, 'x');
  EXPECT_EQ(pub.publish(long_name.c_str(), first.data(), static_cast<int>(first.size())), -1);
  EXPECT_EQ(pub.dropped(), 7);
  inner.hold.store(false);
  pub.stop();  // sends the queued ones
  ASSERT_EQ(static_cast<int>(inner.got.size()), PublisherThread::kSlots);
  for (int k = 0; k < PublisherThread::kSlots; ++k) EXPECT_EQ(inner.got[k].bytes, message(k)) << k;
  EXPECT_EQ(pub.published(), PublisherThread::kSlots);
}
