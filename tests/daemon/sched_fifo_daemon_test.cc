// realtime.sched_fifo against build/bin/coopdynd where the kernel grants SCHED_FIFO (root or
// CAP_SYS_NICE, and real-time CPU time: the tests probe it on a throwaway thread and skip otherwise,
// saying why): the policy of each thread read from the kernel
// (sched_getscheduler of the thread, found by its name in /proc/PID/task/*/comm), not from the
// daemon's log.
//   - auto (the default) runs the loop thread at SCHED_FIFO `priority`, and with receive_priority the
//     receive thread and process at SCHED_FIFO below it; false leaves all of them SCHED_OTHER.
//   - auto steps a loop too heavy for its period down to SCHED_OTHER (tiago_pro_box with a period a
//     quarter of its tick measured in the test, tests/support/heavy_loop.h): the test waits for the
//     daemon's report of it, then reads the thread's policy. The loop hogs a CPU at most one stats
//     window (0.1 s) before it steps down: no other test starves.
#include <gtest/gtest.h>
#include <dirent.h>
#include <sched.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/child_process.h"
#include "tests/support/daemon_test_util.h"
#include "tests/support/heavy_loop.h"

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

// What the tests need of the kernel, probed: SCHED_FIFO at the daemon's priority (80) granted to a
// throwaway thread, and real-time threads given CPU time. "" if so, else why not (root without
// CAP_SYS_NICE, an RLIMIT_RTPRIO below 80, a container without a real-time budget all refuse it).
std::string fifo_unavailable() {
  if (read_line("/proc/sys/kernel/sched_rt_runtime_us") == "0")
    return "kernel.sched_rt_runtime_us is 0: real-time threads get no CPU time";
  std::string why;
  std::thread([&why] {
    sched_param sp{};
    sp.sched_priority = 80;
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
    if (rc != 0) why = std::string("SCHED_FIFO priority 80 refused to a thread of this test: ") + std::strerror(rc);
    else if (sched_getscheduler(0) != SCHED_FIFO) why = "SCHED_FIFO granted but the thread does not run under it";
  }).join();
  return why.empty() ? why
                     : why + " (needs root or CAP_SYS_NICE and a real-time budget): this test checks the policy "
                             "the kernel gives the daemon's threads";
}

// The daemon with config `yaml` on two_puma_load until its loop runs; the policies of its loop
// thread, receive thread and receive process.
struct Running {
  Policy loop, rx_thread, rx_child;
  std::string log, summary;
};
void run_daemon(const std::string& yaml, Running* r) {
  const TempConfig cfg("fifo.yaml", yaml);
  Child d({COOPDYND_PATH, "--scene", scene_path("two_puma_load"), "--config", cfg.path(), "--lcm-url",
           private_udpm_url(8), "--duration", kDaemonDuration},
          "fifo");
  ASSERT_TRUE(log_says(d, kDaemonRunning, kEventLimit)) << slurp(d.err);
  // each thread names itself as it starts: wait until all are there
  std::vector<pid_t> loop, rx, kids;
  wait_until([&] {
    loop = threads_named(d.pid, "coopdynd-loop"), rx = threads_named(d.pid, "coopdynd-rx");
    kids = children_of(d.pid);
    return loop.size() == 1 && rx.size() == 1 && kids.size() == 1;
  }, kEventLimit, 10ms);
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
}

// A config and the policy (and priority, where FIFO) the kernel must report for the loop thread,
// the receive thread and the receive process.
struct Expected {
  const char* name;
  const char* yaml;
  Policy loop, rx_thread, rx_child;
};
// auto with receive_priority: the loop at FIFO 80, the receive path at FIFO 70 below it; the
// default config (receive_priority 0): the loop alone at FIFO; false: every thread SCHED_OTHER.
const Expected kExpected[] = {
    {"AutoRunsTheLoopAtFifoAndTheReceivePathBelowIt", "realtime: {priority: 80, receive_priority: 70}\n",
     {SCHED_FIFO, 80}, {SCHED_FIFO, 70}, {SCHED_FIFO, 70}},
    {"DefaultConfigRunsOnlyTheLoopAtFifo", "", {SCHED_FIFO, 80}, {SCHED_OTHER, 0}, {SCHED_OTHER, 0}},
    {"FalseLeavesEveryThreadSchedOther", "realtime: {sched_fifo: false, receive_priority: 70}\n", {SCHED_OTHER, 0},
     {SCHED_OTHER, 0}, {SCHED_OTHER, 0}},
};

// Every test here: skipped, saying why, where the kernel does not grant SCHED_FIFO.
class DaemonSchedFifo : public ::testing::TestWithParam<Expected> {
 protected:
  void SetUp() override {
    const std::string why = fifo_unavailable();
    if (!why.empty()) GTEST_SKIP() << why;
  }
};

void expect_policy(const Policy& got, const Policy& want, const char* what, const std::string& log) {
  EXPECT_EQ(got.policy, want.policy) << what << "\n" << log;
  EXPECT_EQ(got.priority, want.priority) << what;  // SCHED_OTHER's is 0
}

}  // namespace

// And an idle loop keeps its priority: nothing stepped down.
TEST_P(DaemonSchedFifo, ThreadsRunAsConfigured) {
  const Expected& e = GetParam();
  Running r;
  run_daemon(e.yaml, &r);
  if (HasFatalFailure()) return;
  expect_policy(r.loop, e.loop, "the loop thread", r.log);
  expect_policy(r.rx_thread, e.rx_thread, "the receive thread", r.log);
  expect_policy(r.rx_child, e.rx_child, "the receive process", r.log);
  EXPECT_NE(r.summary.find("SCHED_FIFO stepped down: loop 0, receive 0"), std::string::npos) << r.summary;
}

INSTANTIATE_TEST_SUITE_P(Config, DaemonSchedFifo, ::testing::ValuesIn(kExpected),
                         [](const ::testing::TestParamInfo<Expected>& i) { return std::string(i.param.name); });

TEST_F(DaemonSchedFifo, AutoStepsALoopTooHeavyForItsPeriodDownToSchedOther) {
  // the period a quarter of the scene's shortest warm tick here: every tick overruns by construction
  const System sys = load_scene(scene_path("tiago_pro_box"));
  const long long tick_ns = shortest_warm_tick_ns(sys, runtime::ServiceConfig());
  const double rate_hz = std::min(heavy_rate_hz(tick_ns), runtime::kMaxRateHz);
  if (tick_ns < 2e9 / rate_hz)
    GTEST_SKIP() << "a tiago_pro_box tick takes " << tick_ns / 1000.0 << " us here, less than twice the shortest period "
                 << "the daemon accepts (rate_hz " << runtime::kMaxRateHz << "): no period makes it too heavy";
  const TempConfig cfg("heavy.yaml", "rate_hz: " + std::to_string(rate_hz) + "\nstats_period_s: 0.1\n");
  Child d({COOPDYND_PATH, "--scene", scene_path("tiago_pro_box"), "--config", cfg.path(), "--lcm-url",
           private_udpm_url(9), "--duration", kDaemonDuration},
          "heavy");
  ASSERT_TRUE(log_says(d, "the loop stepped down from SCHED_FIFO to SCHED_OTHER", kEventLimit))
      << "a tick of " << tick_ns / 1000.0 << " us at rate_hz " << rate_hz << ":\n" << slurp(d.err);
  const auto loop = threads_named(d.pid, "coopdynd-loop");
  ASSERT_EQ(loop.size(), 1u);
  EXPECT_EQ(policy_of(loop[0]).policy, SCHED_OTHER);
  d.signal(SIGTERM);
  ASSERT_EQ(d.wait(), 0) << slurp(d.err);
  const std::string log = slurp(d.err), summary = slurp(d.out);
  EXPECT_NE(log.find("loop thread runs SCHED_FIFO priority 80"), std::string::npos) << "it had the priority first: " << log;
  EXPECT_NE(summary.find("SCHED_FIFO stepped down: loop 1, receive 0"), std::string::npos) << summary;
}
