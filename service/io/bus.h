// The loop's view of the message bus: publish raw, already-encoded bytes. LcmBus is the real one;
// tests use an in-memory fake. Implementations must not allocate or block for long in publish().
#pragma once

namespace coopdyn::io {

class Bus {
 public:
  virtual ~Bus() = default;
  // Returns 0 on success (the message may still be lost, as with UDP).
  virtual int publish(const char* channel, const void* data, int len) = 0;
};

}  // namespace coopdyn::io
