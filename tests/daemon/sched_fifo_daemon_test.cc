// realtime.sched_fifo against build/bin/coopdynd, as root (SCHED_FIFO needs root or CAP_SYS_NICE;
// the tests skip otherwise, saying so): the policy of each thread read from the kernel
// (sched_getscheduler of the thread, found by its name in /proc/PID/task/*/comm), not from the
// daemon's log.
//   - auto (the default) runs the loop thread at SCHED_FIFO `priority`, and with receive_priority the
//     receive thread and process at SCHED_FIFO below it; false leaves all of them SCHED_OTHER.
//   - auto steps a loop too heavy for its period down to SCHED_OTHER (tiago_pro_box at 10 kHz: a tick
//     takes some 0.3 ms): the test waits for the daemon's report of it, then reads the thread's policy.
//     The loop hogs a CPU at most one stats window (0.1 s) before it steps down: no other test
//     starves.
#include <gtest/gtest.h>
#include <dirent.h>
#include <sched.h>
#include <signal.h>
#include <unistd.h>

#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/child_process.h"
#include "tests/support/daemon_test_util.h"

using namespace coopdyn;
using namespace coopdyn::daemon_test;
using namespace std::chrono_literals;

namespace {

std::string read_line(const std::string& path) {
  std::ifstream in(path);
  std::string s;
  std::getline(in, s);
  return s;
}

// the threads of pid named `name` (their comm)
std::vector<pid_t> threads_named(pid_t pid, const std::string& name) {
  std::vector<pid_t> out;
  const std::string dir = "/proc/" + std::to_string(pid) + "/task";
  if (DIR* d = opendir(dir.c_str())) {
    while (dirent* e = readdir(d))
      if (e->d_name[0] != '.' && read_line(dir + "/" + e->d_name + "/comm") == name) out.push_back(std::atoi(e->d_name));
    closedir(d);
  }
  return out;
}

// the children of pid (any of its threads may have spawned them)
std::vector<pid_t> children_of(pid_t pid) {
  std::vector<pid_t> out;
  const std::string dir = "/proc/" + std::to_string(pid) + "/task";
  if (DIR* d = opendir(dir.c_str())) {
    while (dirent* e = readdir(d)) {
      if (e->d_name[0] == '.') continue;
      std::ifstream in(dir + "/" + e->d_name + "/children");
      for (pid_t c; in >> c;) out.push_back(c);
    }
    closedir(d);
  }
  return out;
}

struct Policy {
  int policy = -1, priority = -1;
};
Policy policy_of(pid_t tid) {
  Policy p;
  p.policy = sched_getscheduler(tid);
  sched_param sp{};
  if (sched_getparam(tid, &sp) == 0) p.priority = sp.sched_priority;
  return p;
}

// waits (at most `limit`) until the daemon's log holds `what`
bool log_says(const Child& d, const std::string& what, std::chrono::seconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    if (slurp(d.err).find(what) != std::string::npos) return true;
    std::this_thread::sleep_for(20ms);
  }
  return false;
}

std::string config_file(const std::string& name, const std::string& yaml) {
  const std::string path = tmp_path(name);
  std::ofstream(path) << yaml;
  return path;
}

bool may_take_fifo() { return geteuid() == 0; }
const char* kNoFifo = "SCHED_FIFO needs root (or CAP_SYS_NICE): this test checks the policy the kernel gives the "
                      "daemon's threads and runs as root only";

// The daemon with config `yaml` on two_puma_load until its loop runs; the policies of its loop
// thread, receive thread and receive process.
struct Running {
  Policy loop, rx_thread, rx_child;
  std::string log, summary;
};
void run_daemon(const std::string& yaml, Running* r) {
  const std::string cfg = config_file("fifo.yaml", yaml);
  Child d({COOPDYND_PATH, "--scene", scene_path("two_puma_load"), "--config", cfg, "--lcm-url", private_udpm_url(8),
           "--duration", "30"},
          "fifo");
  ASSERT_TRUE(log_says(d, "running; SIGINT or SIGTERM stops", 30s)) << slurp(d.err);
  // each thread names itself as it starts: wait until all are there
  std::vector<pid_t> loop, rx, kids;
  for (int i = 0; i < 1000 && (loop.size() != 1 || rx.size() != 1 || kids.size() != 1); ++i) {
    if (i > 0) std::this_thread::sleep_for(10ms);
    loop = threads_named(d.pid, "coopdynd-loop"), rx = threads_named(d.pid, "coopdynd-rx");
    kids = children_of(d.pid);
  }
  ASSERT_EQ(loop.size(), 1u) << "one thread named coopdynd-loop";
  ASSERT_EQ(rx.size(), 1u) << "one thread named coopdynd-rx";
  ASSERT_EQ(kids.size(), 1u) << "one receive process";
  r->loop = policy_of(loop[0]);
  r->rx_thread = policy_of(rx[0]);
  r->rx_child = policy_of(kids[0]);
  d.signal(SIGTERM);
  ASSERT_EQ(d.wait(), 0) << slurp(d.err);
  r->log = slurp(d.err);
  r->summary = slurp(d.out);
  std::remove(cfg.c_str());
}

}  // namespace

TEST(DaemonSchedFifo, AutoRunsTheLoopAtFifoAndTheReceivePathBelowIt) {
  if (!may_take_fifo()) GTEST_SKIP() << kNoFifo;
  Running r;
  run_daemon("realtime: {priority: 80, receive_priority: 70}\n", &r);
  if (HasFatalFailure()) return;
  EXPECT_EQ(r.loop.policy, SCHED_FIFO) << r.log;
  EXPECT_EQ(r.loop.priority, 80);
  EXPECT_EQ(r.rx_thread.policy, SCHED_FIFO);
  EXPECT_EQ(r.rx_thread.priority, 70);
  EXPECT_EQ(r.rx_child.policy, SCHED_FIFO);
  EXPECT_EQ(r.rx_child.priority, 70);
  EXPECT_NE(r.summary.find("SCHED_FIFO stepped down: loop 0, receive 0"), std::string::npos)
      << "an idle loop keeps its priority: " << r.summary;
}

// The default config (receive_priority 0): the loop at FIFO, the receive path SCHED_OTHER.
TEST(DaemonSchedFifo, DefaultConfigRunsOnlyTheLoopAtFifo) {
  if (!may_take_fifo()) GTEST_SKIP() << kNoFifo;
  Running r;
  run_daemon("", &r);
  if (HasFatalFailure()) return;
  EXPECT_EQ(r.loop.policy, SCHED_FIFO) << r.log;
  EXPECT_EQ(r.loop.priority, 80);
  EXPECT_EQ(r.rx_thread.policy, SCHED_OTHER);
  EXPECT_EQ(r.rx_child.policy, SCHED_OTHER);
}

TEST(DaemonSchedFifo, FalseLeavesEveryThreadSchedOther) {
  if (!may_take_fifo()) GTEST_SKIP() << kNoFifo;
  Running r;
  run_daemon("realtime: {sched_fifo: false, receive_priority: 70}\n", &r);
  if (HasFatalFailure()) return;
  EXPECT_EQ(r.loop.policy, SCHED_OTHER) << r.log;
  EXPECT_EQ(r.rx_thread.policy, SCHED_OTHER);
  EXPECT_EQ(r.rx_child.policy, SCHED_OTHER);
}

TEST(DaemonSchedFifo, AutoStepsALoopTooHeavyForItsPeriodDownToSchedOther) {
  if (!may_take_fifo()) GTEST_SKIP() << kNoFifo;
  const std::string cfg = config_file("heavy.yaml", "rate_hz: 10000\nstats_period_s: 0.1\n");
  Child d({COOPDYND_PATH, "--scene", scene_path("tiago_pro_box"), "--config", cfg, "--lcm-url", private_udpm_url(9),
           "--duration", "60"},
          "heavy");
  ASSERT_TRUE(log_says(d, "the loop stepped down from SCHED_FIFO to SCHED_OTHER", 60s)) << slurp(d.err);
  const auto loop = threads_named(d.pid, "coopdynd-loop");
  ASSERT_EQ(loop.size(), 1u);
  EXPECT_EQ(policy_of(loop[0]).policy, SCHED_OTHER);
  d.signal(SIGTERM);
  ASSERT_EQ(d.wait(), 0) << slurp(d.err);
  const std::string log = slurp(d.err), summary = slurp(d.out);
  EXPECT_NE(log.find("loop thread runs SCHED_FIFO priority 80"), std::string::npos) << "it had the priority first: " << log;
  EXPECT_NE(summary.find("SCHED_FIFO stepped down: loop 1, receive 0"), std::string::npos) << summary;
  std::remove(cfg.c_str());
}
