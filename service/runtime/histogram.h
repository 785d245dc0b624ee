// Fixed-size log-linear histogram of durations in nanoseconds (HdrHistogram's layout, simplified):
// 64 linear sub-buckets per power of two, so any percentile is within 1/64 (1.6 %) of the true
// value; the exact maximum is kept aside. record() is O(1) and allocation-free.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>

namespace coopdyn::runtime {

class Histogram {
 public:
  static constexpr int kSub = 64;
  static constexpr int kBuckets = kSub * 40;  // up to 2^45 ns (about 9.8 hours)

  void record(int64_t ns) {
    if (ns < 0) ns = 0;  // a wake-up before the deadline counts as on time
    ++count_[index(static_cast<uint64_t>(ns))];
    ++n_;
    max_ = std::max(max_, ns);
  }
  void reset() {
    count_.fill(0);
    n_ = 0;
    max_ = 0;
  }
  int64_t total() const { return n_; }
  int64_t max() const { return max_; }
  // value at quantile p in [0, 1] (upper edge of the bucket, capped by the max); 0 if empty
  int64_t percentile(double p) const {
    if (n_ == 0) return 0;
    if (p >= 1.0) return max_;
    const int64_t rank = static_cast<int64_t>(p * static_cast<double>(n_ - 1)) + 1;  // 1-based
    int64_t seen = 0;
    for (int i = 0; i < kBuckets; ++i) {
      seen += count_[i];
      if (seen >= rank) return std::min<int64_t>(upper(i), max_);
    }
    return max_;
  }

  static int index(uint64_t v) {
    if (v < 2 * kSub) return static_cast<int>(v);  // exact below 128 ns
    const int msb = 63 - __builtin_clzll(v);       // >= 7
    const int shift = msb - 6;                     // keep 7 significant bits
    const int i = (shift + 1) * kSub + static_cast<int>((v >> shift) & (kSub - 1));
    return std::min(i, kBuckets - 1);
  }
  static int64_t upper(int i) {  // largest value mapped to bucket i
    if (i < 2 * kSub) return i;
    const int shift = i / kSub - 1;
    const int64_t mant = kSub + (i % kSub);
    return ((mant + 1) << shift) - 1;
  }

 private:
  std::array<uint32_t, kBuckets> count_{};
  int64_t n_ = 0;
  int64_t max_ = 0;
};

}  // namespace coopdyn::runtime
