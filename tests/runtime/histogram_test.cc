// The loop's timing histogram: percentiles within a bucket's resolution.
#include <gtest/gtest.h>

#include <cstdint>

#include "service/runtime/histogram.h"

using namespace coopdyn;

TEST(Histogram, PercentilesWithinBucketResolution) {
  runtime::Histogram h;
  for (int i = 1; i <= 100000; ++i) h.record(i * 10);  // uniform 10 ns .. 1 ms
  EXPECT_EQ(h.total(), 100000);
  EXPECT_EQ(h.max(), 1000000);
  for (double p : {0.5, 0.99, 0.999}) {
    const double exact = p * 1e6;
    EXPECT_NEAR(static_cast<double>(h.percentile(p)), exact, exact / 64 + 10) << p;
  }
  for (int64_t v : {0LL, 1LL, 127LL, 128LL, 1000LL, 123456789LL}) {
    const int i = runtime::Histogram::index(static_cast<uint64_t>(v));
    EXPECT_LE(v, runtime::Histogram::upper(i));
    if (i > 0) {
      EXPECT_GT(v, runtime::Histogram::upper(i - 1));
    }
  }
}
