// Bounds-checked reading of LCM's big-endian wire format, used to vet untrusted bytes before the
// generated decoder sees them (it trusts counts and string lengths). Internal to service/io.
#pragma once

#include <cstdint>

namespace coopdyn::io::wire {

constexpr int32_t kMaxCount = 1 << 16;  // no coopdyn array is anywhere near this long
// An input's mac_len may be any length up to this: 32 for HMAC-SHA256 (auth.h); room for another algorithm
constexpr int32_t kMaxMacBytes = 64;

class Reader {
 public:
  Reader(const void* data, int len) : p_(static_cast<const uint8_t*>(data)), len_(len < 0 ? 0 : len) {}
  bool skip(long long n) {
    if (n < 0 || n > len_ - pos_) return false;
    pos_ += static_cast<int>(n);
    return true;
  }
  bool i32(int32_t* out) {
    if (len_ - pos_ < 4) return false;
    const uint8_t* b = p_ + pos_;
    *out = static_cast<int32_t>((uint32_t(b[0]) << 24) | (uint32_t(b[1]) << 16) | (uint32_t(b[2]) << 8) | uint32_t(b[3]));
    pos_ += 4;
    return true;
  }
  bool i64(int64_t* out) {
    int32_t hi, lo;
    if (!i32(&hi) || !i32(&lo)) return false;
    *out = static_cast<int64_t>((uint64_t(uint32_t(hi)) << 32) | uint32_t(lo));
    return true;
  }
  bool hash(int64_t expected) {
    int64_t h;
    return i64(&h) && h == expected;
  }
  bool count(int32_t* n) { return i32(n) && *n >= 0 && *n <= kMaxCount; }
  // n strings: each an int32 length that counts the terminating NUL (>= 1), then the bytes
  bool strings(int32_t n) {
    for (int32_t i = 0; i < n; ++i) {
      int32_t l;
      if (!i32(&l) || l < 1 || !skip(l) || p_[pos_ - 1] != 0) return false;
    }
    return true;
  }
  int pos() const { return pos_; }

 private:
  const uint8_t* p_;
  int len_;
  int pos_ = 0;
};

}  // namespace coopdyn::io::wire
