// Progress of a long client run on stderr (coopdyn sim, coopdyn log): on when asked (--progress) or when
// stderr is a terminal; a report at most every 200 ms on a terminal (one line rewritten in place), every
// second otherwise (one line each).
#pragma once

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>

namespace coopdyn::cli {

class Progress {
 public:
  Progress(const char* who, bool asked)
      : who_(who), tty_(isatty(STDERR_FILENO)), on_(asked || tty_), start_(clock::now()), next_(start_ + period()) {}

  bool on() const { return on_; }
  double wall_s() const { return std::chrono::duration<double>(clock::now() - start_).count(); }

  // Reports `what` (the position, e.g. "t = 1.000 of 60.000 s (2 %)") with the wall time and the time
  // left at fraction `frac` done, when a report is due.
  void report(double frac, const std::string& what) {
    if (!on_ || clock::now() < next_) return;
    const double wall = wall_s();
    std::fprintf(stderr, "%s%s: %s, %.1f s wall, %.0f s left%s", tty_ ? "\r" : "", who_, what.c_str(), wall,
                 frac > 0 ? wall * (1 - frac) / frac : 0.0, tty_ ? "" : "\n");
    std::fflush(stderr);
    reported_ = true;
    next_ = clock::now() + period();
  }
  // Ends the line a terminal report left open (before an error message, or the summary).
  void break_line() {
    if (reported_ && tty_) std::fprintf(stderr, "\n");
    reported_ = false;
  }
  // The summary line, e.g. "60001 steps in 2.27 s wall", when on.
  void done(const std::string& what) {
    if (!on_) return;
    break_line();
    std::fprintf(stderr, "%s: %s in %.2f s wall\n", who_, what.c_str(), wall_s());
  }

 private:
  using clock = std::chrono::steady_clock;
  std::chrono::milliseconds period() const { return std::chrono::milliseconds(tty_ ? 200 : 1000); }

  const char* who_;
  bool tty_, on_;
  bool reported_ = false;
  clock::time_point start_, next_;
};

}  // namespace coopdyn::cli
