// PublisherThread: every message reaches the inner bus once, in order, byte for byte, on its channel;
// publish() never waits for the inner bus (a full ring drops the newest message and counts it); stop()
// sends what was queued before it.
#include "service/runtime/publisher_thread.h"

#include <gtest/gtest.h>

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

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

// With a SCHED_FIFO priority, or a nice value, the thread that calls the inner bus runs at it
// (where the process may take it: root or CAP_SYS_NICE), so processes at SCHED_OTHER cannot hold the
// outputs back; without one, or refused, it runs SCHED_OTHER at nice 0 and says so. Every message
// still goes out.
TEST(PublisherThread, RunsAtThePriorityItIsGiven) {
  struct PolicyBus : RecordingBus {
    std::atomic<int> policy{-1}, priority{-1}, nice{100};
    int publish(const char* channel, const void* data, int len) override {
      sched_param p{};
      int pol = 0;
      pthread_getschedparam(pthread_self(), &pol, &p);
      policy.store(pol);
      priority.store(p.sched_priority);
      nice.store(getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid))));
      return RecordingBus::publish(channel, data, len);
    }
  };
  struct Asked {
    int fifo, nice;
  };
  for (const Asked asked : {Asked{0, 0}, Asked{79, 0}, Asked{0, -20}}) {
    SCOPED_TRACE(std::to_string(asked.fifo) + " " + std::to_string(asked.nice));
    PolicyBus inner;
    PublisherThread pub(inner, 5000);
    pub.start(-1, asked.fifo, asked.nice);
    while (!pub.scheduled()) std::this_thread::yield();
    const auto m = message(1);
    ASSERT_EQ(pub.publish("OUT", m.data(), static_cast<int>(m.size())), 0);
    pub.stop();
    ASSERT_EQ(inner.got.size(), 1u);
    const bool asked_any = asked.fifo > 0 || asked.nice != 0;
    EXPECT_EQ(inner.policy.load(), pub.priority_granted() && asked.fifo > 0 ? SCHED_FIFO : SCHED_OTHER);
    if (pub.priority_granted()) {
      EXPECT_TRUE(asked_any);
      if (asked.fifo > 0) EXPECT_EQ(inner.priority.load(), asked.fifo);
      else EXPECT_EQ(inner.nice.load(), asked.nice);
    } else if (asked_any) {  // refused only where the process may not raise a thread's priority
      std::thread probe([] { EXPECT_NE(setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), -20), 0); });
      probe.join();
    } else {
      EXPECT_EQ(inner.nice.load(), getpriority(PRIO_PROCESS, 0));  // the process's own
    }
  }
}
