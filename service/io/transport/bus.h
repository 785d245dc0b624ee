// The loop's view of the message bus: publish raw, already-encoded bytes. LcmBus is the real one;
// tests use an in-memory fake. Implementations must not allocate or block for long in publish().
#pragma once

namespace coopdyn::io {

class Bus {
 public:
  virtual ~Bus() = default;
  // Returns 0 on success (the message may still be lost, as with UDP).
  virtual int publish(const char* channel, const void* data, int len) = 0;
  // Messages publish() accepted (returned 0) that a later stage could not send: a bus that queues and
  // sends from another thread (runtime::PublisherThread) counts its sends that failed. Any thread; no lock.
  virtual long long failed_after_accept() const { return 0; }
};

}  // namespace coopdyn::io
