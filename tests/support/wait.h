// Waiting for an event in a test: the condition that says it happened, polled, under a bound that only
// turns a hang into a failure (generous: a loaded machine may take seconds for what takes
// milliseconds alone). Never a fixed sleep standing in for the event.
#pragma once

#include <chrono>
#include <thread>

namespace coopdyn::testing {

// A bound no event of these tests needs on a loaded machine; reached only when the event never comes.
constexpr std::chrono::milliseconds kEventLimit{60000};

// Polls done() every `every` until it holds or `limit` has passed; returns its last value.
template <class Done>
bool wait_until(Done&& done, std::chrono::milliseconds limit = kEventLimit,
                std::chrono::milliseconds every = std::chrono::milliseconds(5)) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (!done()) {
    if (std::chrono::steady_clock::now() >= end) return done();
    std::this_thread::sleep_for(every);
  }
  return true;
}

}  // namespace coopdyn::testing
