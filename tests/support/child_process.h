// Child processes of the tests: one with its output in files, a command run to its end, temporary
// paths and files, an LCM bus that may be unavailable (no multicast route).
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "service/io/transport/lcm_bus.h"
#include "tests/support/files.h"
#include "tests/support/private_udpm_url.h"
#include "tests/support/wait.h"

extern char** environ;

namespace coopdyn::daemon_test {

using namespace std::chrono_literals;

using testing::private_udpm_url;
using testing::scene_path;
using testing::slurp;
using testing::wait_until;
using testing::kEventLimit;

inline std::string tmp_path(const std::string& what) {
  return (::testing::TempDir().empty() ? std::string("/tmp/") : ::testing::TempDir()) + "coopdynd_test_" +
         std::to_string(getpid()) + "_" + what;
}

// A file a test writes for a child process to read (a config, a scene): tmp_path(name) holding
// `text`, removed when it goes out of scope, however the test ends (an ASSERT returns early too).
class TempConfig {
 public:
  TempConfig(const std::string& name, const std::string& text) : path_(tmp_path(name)) { std::ofstream(path_) << text; }
  ~TempConfig() { std::remove(path_.c_str()); }
  TempConfig(const TempConfig&) = delete;
  TempConfig& operator=(const TempConfig&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// Starts argv (argv[0] a path) with the descriptors set_fds arranges; its pid, or -1.
inline pid_t spawn(const std::vector<std::string>& argv, const std::function<void(posix_spawn_file_actions_t*)>& set_fds) {
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  set_fds(&fa);
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = -1;
  if (posix_spawn(&pid, args[0], &fa, nullptr, args.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&fa);
  return pid;
}

// A child process with stdout and stderr to files.
struct Child {
  pid_t pid = -1;
  std::string out, err;
  Child(const std::vector<std::string>& argv, const std::string& name) : out(tmp_path(name + ".out")), err(tmp_path(name + ".err")) {
    pid = spawn(argv, [this](posix_spawn_file_actions_t* fa) {
      posix_spawn_file_actions_addopen(fa, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      posix_spawn_file_actions_addopen(fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    });
  }
  // exit code, or -signal; waits at most `limit` (a bound that only turns a hang into a failure)
  // and then kills
  int wait(std::chrono::milliseconds limit = kEventLimit) {
    const auto end = std::chrono::steady_clock::now() + limit;
    int st = 0;
    while (true) {
      const pid_t r = waitpid(pid, &st, WNOHANG);
      if (r == pid) break;
      if (std::chrono::steady_clock::now() > end) {
        kill(pid, SIGKILL);
        waitpid(pid, &st, 0);
        ADD_FAILURE() << "child did not exit in time";
        break;
      }
      std::this_thread::sleep_for(10ms);
    }
    pid = -1;
    return WIFEXITED(st) ? WEXITSTATUS(st) : -WTERMSIG(st);
  }
  void signal(int s) { kill(pid, s); }
  ~Child() {
    if (pid > 0) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
    }
    std::remove(out.c_str());
    std::remove(err.c_str());
  }
};

// Waits (at most `limit`, a bound that only turns a hang into a failure) until the child's stderr
// holds `what`: a daemon's log line saying it has reached a state the test needs.
inline bool log_says(const Child& c, const std::string& what, std::chrono::milliseconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    if (slurp(c.err).find(what) != std::string::npos) return true;
    std::this_thread::sleep_for(20ms);
  }
  return false;
}

// --duration of a daemon the test stops itself (SIGTERM or SIGINT once it has what it waits for):
// longer than the waits of a test (each up to kEventLimit), so that a loaded machine never sees the
// daemon stop on its own first; it only ends a daemon that a crashed test left behind.
inline const std::string kDaemonDuration = "600";

// Config lines for the tests that count what the daemon accepted and evaluated: a watchdog and a
// max input age longer than a loaded machine may hold an input on its way (sent, received,
// evaluated). With the defaults (100 ms, 1 s) an input held longer is evaluated as expired, or
// rejected as stale: the daemon's right answer, which those counts do not expect.
inline const char* const kPatientInputs = "watchdog_ms: 60000\nmax_input_age_ms: 60000\n";

// coopdynd logs this once its receive process has subscribed (it stops, exit 1, if it does not within
// 10 s) and its loop runs: inputs sent after it are received.
inline const char* const kDaemonRunning = "running; SIGINT or SIGTERM stops";

// A command run to its end (at most 60 s): its exit status and what it printed.
struct Result {
  int rc;
  std::string out, err;
};
inline Result run_command(const std::vector<std::string>& argv, const std::string& tag) {
  Child c(argv, tag);
  EXPECT_GT(c.pid, 0) << argv[0];
  Result r;
  r.rc = c.wait(std::chrono::seconds(60));
  r.out = slurp(c.out);
  r.err = slurp(c.err);
  return r;
}

inline std::unique_ptr<io::LcmBus> try_bus(const std::string& url) {
  try {
    return std::make_unique<io::LcmBus>(url);
  } catch (const std::exception&) {
    return nullptr;
  }
}

}  // namespace coopdyn::daemon_test
