// The triple buffer between the loop and its readers: a reader sees whole values, the newest last.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "service/runtime/triple_buffer.h"

using namespace coopdyn;

TEST(TripleBuffer, ReaderSeesWholeNewestValues) {
  struct Pair {
    long a = 0, b = 0;
  };
  runtime::TripleBuffer<Pair> tb([](Pair&) {});
  std::atomic<bool> done{false}, reading{false};
  std::thread writer([&] {
    while (!reading.load()) std::this_thread::yield();
    for (long i = 1; i <= 200000; ++i) {
      Pair& p = tb.write_slot();
      p.a = i;
      p.b = -i;
      tb.publish();
    }
    done = true;
  });
  long last = 0, reads = 0, torn = 0, backwards = 0;
  reading = true;
  do {
    tb.update();
    const Pair& p = tb.read_slot();
    torn += p.a != -p.b;
    backwards += p.a < last;
    last = p.a;
    ++reads;
  } while (!done.load());
  writer.join();
  EXPECT_EQ(torn, 0) << "a read saw half of one write and half of another";
  EXPECT_EQ(backwards, 0) << "a read went back in time";
  tb.update();
  EXPECT_EQ(tb.read_slot().a, 200000);  // the newest value always arrives
  EXPECT_GT(reads, 0);
}
