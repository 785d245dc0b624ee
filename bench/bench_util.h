// Timing helpers shared by the bench programs that time in-process calls themselves (outside Google
// Benchmark): the median of repetitions and the wall time per call of a loop.
#pragma once

#include <algorithm>
#include <chrono>
#include <vector>

namespace coopdyn::bench {

// The median (the mean of the two middle values when there is an even number).
inline double median(std::vector<double> x) {
  std::sort(x.begin(), x.end());
  const size_t n = x.size();
  return n % 2 ? x[n / 2] : 0.5 * (x[n / 2 - 1] + x[n / 2]);
}

// Microseconds per call of f over n back-to-back calls (steady_clock).
template <class F>
double per_call_us(int n, F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < n; ++i) f();
  return std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count() / n;
}

}  // namespace coopdyn::bench
