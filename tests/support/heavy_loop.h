// A loop too heavy for its period by construction, for the tests of realtime.sched_fifo auto's step
// down (runtime/fifo_guard.h): the period follows from a tick of the scene measured here, now, so
// that the condition holds on any machine, not only on one as fast as the one the test was written on.
#pragma once

#include <chrono>

#include "service/runtime/service_loop.h"
#include "tests/support/daemon_test_util.h"

namespace coopdyn::daemon_test {

// The shortest of `ticks` ServiceLoop::tick() calls of sys under cfg, after as many to warm it
// (ns): what a tick costs at least on this machine (load only lengthens a tick, never shortens it).
inline long long shortest_warm_tick_ns(const System& sys, const runtime::ServiceConfig& cfg, int ticks = 200) {
  FakeBus bus;
  runtime::ServiceLoop loop(sys, cfg, bus);
  long long shortest = -1;
  for (int k = 0; k < 2 * ticks; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    loop.tick(k * cfg.period_ns());
    const long long t = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0).count();
    if (k >= ticks && (shortest < 0 || t < shortest)) shortest = t;
  }
  return shortest;
}

// The period for a loop whose ticks take `tick_ns` at least: a quarter of it, so that every tick
// overruns and, the overrun skipped, the loop computes at least 4/5 of its wall time, over the
// guard's kMaxBusyShare (1/2) whatever the machine's speed. As a rate (Hz).
inline double heavy_rate_hz(long long tick_ns) { return 4e9 / static_cast<double>(tick_ns); }

}  // namespace coopdyn::daemon_test
