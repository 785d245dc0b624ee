#include "service/runtime/publisher_thread.h"

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cstring>

#include "service/io/transport/lcm_bus.h"

namespace coopdyn::runtime {

PublisherThread::PublisherThread(io::Bus& inner, int max_bytes) : inner_(inner), max_bytes_(max_bytes) {
  for (Slot& s : slots_) s.bytes.resize(static_cast<size_t>(max_bytes));
}

PublisherThread::~PublisherThread() { stop(); }

void PublisherThread::start(int avoid_cpu, int fifo_priority, int nice) {
  if (thread_.joinable()) return;
  stop_.store(false);
  fifo_.store(0);
  thread_ = std::thread([this, avoid_cpu, fifo_priority, nice] {
    cpu_set_t set;
    if (avoid_cpu >= 0 && avoid_cpu < CPU_SETSIZE && sched_getaffinity(0, sizeof set, &set) == 0) {
      CPU_CLR(avoid_cpu, &set);
      if (CPU_COUNT(&set) > 0) pthread_setaffinity_np(pthread_self(), sizeof set, &set);
    }
    bool raised = false;
    if (fifo_priority > 0) {
      sched_param p{};
      p.sched_priority = fifo_priority;
      raised = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) == 0;  // refused without the privilege
    } else if (nice != 0) {
      raised = setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), nice) == 0;  // this thread only
    }
    fifo_.store(raised ? 1 : -1);
    run();
  });
}

void PublisherThread::stop() {
  if (!thread_.joinable()) return;
  stop_.store(true);
  bell_.ring();
  thread_.join();
}

int PublisherThread::publish(const char* channel, const void* data, int len) {
  const uint64_t head = head_.load(std::memory_order_relaxed);
  const size_t ch = std::strlen(channel);
  if (len < 0 || len > max_bytes_ || ch >= kChannelChars ||
      head - tail_.load(std::memory_order_acquire) >= static_cast<uint64_t>(kSlots)) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return -1;
  }
  Slot& s = slots_[head % kSlots];
  std::memcpy(s.channel, channel, ch + 1);
  std::memcpy(s.bytes.data(), data, static_cast<size_t>(len));
  s.len = len;
  head_.store(head + 1, std::memory_order_release);
  bell_.ring();
  return 0;
}

// every slot the producer has filled, in order
void PublisherThread::drain() {
  uint64_t tail = tail_.load(std::memory_order_relaxed);
  const uint64_t head = head_.load(std::memory_order_acquire);
  for (; tail != head; ++tail) {
    const Slot& s = slots_[tail % kSlots];
    if (inner_.publish(s.channel, s.bytes.data(), s.len) != 0)
      failed_.fetch_add(1, std::memory_order_relaxed);
    else
      published_.fetch_add(1, std::memory_order_relaxed);
    tail_.store(tail + 1, std::memory_order_release);
  }
}

void PublisherThread::run() {
  constexpr long long kSliceNs = 10000000;  // looks at stop_ at least every 10 ms
  for (;;) {
    const uint32_t seen = bell_.value();
    drain();
    if (stop_.load()) break;
    bell_.wait(seen, io::monotonic_ns() + kSliceNs);
  }
  drain();  // what was queued before stop()
}

}  // namespace coopdyn::runtime
