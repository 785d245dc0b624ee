// The stop signals against build/bin/coopdynd as a child process: SIGINT, SIGTERM, SIGHUP and
// SIGQUIT each end it cleanly (exit 0, the summary line naming the signal, every log line whole),
// its receive process with it.
#include <gtest/gtest.h>
#include <signal.h>

#include <string>
#include <utility>

#include "tests/support/child_process.h"
#include "tests/support/daemon_test_util.h"

using namespace coopdyn;
using namespace coopdyn::daemon_test;

namespace {

// the pids of pid's children (the receive process), from /proc
std::vector<pid_t> children_of(pid_t pid) {
  std::vector<pid_t> out;
  std::ifstream f("/proc/" + std::to_string(pid) + "/task/" + std::to_string(pid) + "/children");
  for (pid_t c; f >> c;) out.push_back(c);
  return out;
}

}  // namespace

TEST(DaemonSignals, EachStopSignalEndsTheDaemonCleanly) {
  const std::pair<int, const char*> signals[] = {{SIGINT, "SIGINT"}, {SIGTERM, "SIGTERM"}, {SIGHUP, "SIGHUP"}, {SIGQUIT, "SIGQUIT"}};
  for (const auto& [sig, name] : signals) {
    SCOPED_TRACE(name);
    const std::string url = private_udpm_url(7);
    if (!try_bus(url)) GTEST_SKIP() << "LCM udpm unavailable (no multicast route? 'ip route add 224.0.0.0/4 dev lo')";
    Child d({COOPDYND_PATH, "--scene", scene_path("two_puma_load"), "--lcm-url", url, "--duration", kDaemonDuration},
            std::string("signal_") + name);
    ASSERT_TRUE(log_says(d, kDaemonRunning, kEventLimit)) << slurp(d.err);
    const std::vector<pid_t> rx = children_of(d.pid);
    EXPECT_EQ(rx.size(), 1u) << "the receive process";
    d.signal(sig);
    EXPECT_EQ(d.wait(), 0) << slurp(d.err);
    const std::string out = slurp(d.out), err = slurp(d.err);
    EXPECT_NE(out.find(std::string("coopdynd: stopped (") + name + ") after "), std::string::npos) << out;
    ASSERT_FALSE(err.empty());
    EXPECT_EQ(err.back(), '\n') << "the log ends in a cut line: " << err;
    // the receive process is gone with the daemon (it ignores the stop signals; the daemon stops it)
    for (const pid_t p : rx) EXPECT_TRUE(wait_until([p] { return kill(p, 0) != 0; })) << "receive process " << p;
  }
}
