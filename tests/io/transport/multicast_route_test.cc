// io::loopback_multicast_problem and the start-up warning of coopdynd and coopdyn send, each in a
// network namespace of the test's own: lo alone (no route for multicast at all); a veth as the
// default route with MTU 1400 and no multicast route (a fresh cloud machine: multicast leaves by
// eth0); then the multicast route on lo (nothing to say). The host's routes are never touched.
// Needs root (CAP_SYS_ADMIN) and iproute2: skipped, saying so, elsewhere.
#include <gtest/gtest.h>

#include <sched.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>

#include "service/io/transport/multicast_route.h"
#include "tests/support/private_udpm_url.h"

using coopdyn::io::kLoopbackRouteCommand;
using coopdyn::io::loopback_multicast_problem;

namespace {

const char* const kLoOnly = "ip link set lo up";
const char* const kEth0Default =
    "ip link set lo up && ip link add eth0 type veth peer name eth1 && ip link set eth0 mtu 1400 && "
    "ip link set eth1 mtu 1400 && ip link set eth1 up && ip link set eth0 up && "
    "ip addr add 10.231.7.2/24 dev eth0 && ip route add default via 10.231.7.1";
const std::string kWithLoRoute = std::string(kEth0Default) + " && " + kLoopbackRouteCommand;

// what() run in a child process in a new network namespace set up by the shell commands `setup`;
// "SKIP: why" where the machine forbids it
std::string in_private_net(const std::string& setup, const std::function<std::string()>& what) {
  int fds[2];
  if (pipe(fds) != 0) return "SKIP: pipe failed";
  const pid_t pid = fork();
  if (pid < 0) return "SKIP: fork failed";
  if (pid == 0) {
    close(fds[0]);
    std::string out;
    if (geteuid() != 0) out = "SKIP: not root: a network namespace of the test's own needs CAP_SYS_ADMIN";
    else if (unshare(CLONE_NEWNET) != 0)
      out = "SKIP: unshare(CLONE_NEWNET) refused (a container without CAP_SYS_ADMIN?)";
    else if (std::system(("{ " + setup + "; } >/dev/null 2>&1").c_str()) != 0)
      out = "SKIP: cannot set up the namespace with iproute2: " + setup;
    else out = what();
    for (size_t at = 0; at < out.size();) {
      const ssize_t n = write(fds[1], out.data() + at, out.size() - at);
      if (n <= 0) break;
      at += static_cast<size_t>(n);
    }
    _exit(0);
  }
  close(fds[1]);
  std::string got;
  char buf[4096];
  for (ssize_t n; (n = read(fds[0], buf, sizeof buf)) > 0;) got.append(buf, static_cast<size_t>(n));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  return got;
}

// a command's stdout and stderr
std::string output_of(const std::string& cmd) {
  std::string out;
  if (std::FILE* p = popen((cmd + " 2>&1").c_str(), "r")) {
    char buf[4096];
    for (size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
    pclose(p);
  }
  return out;
}

#define SKIP_IF_REFUSED(s) \
  if ((s).rfind("SKIP: ", 0) == 0) GTEST_SKIP() << (s).substr(6)

}  // namespace

TEST(MulticastRoute, NoRouteAtAllIsSaidWithTheFix) {
  const std::string url = coopdyn::testing::private_udpm_url(0);
  const std::string got = in_private_net(kLoOnly, [&] { return loopback_multicast_problem(url); });
  SKIP_IF_REFUSED(got);
  EXPECT_NE(got.find("no route for multicast to 239.255.76.67"), std::string::npos) << got;
  EXPECT_NE(got.find(kLoopbackRouteCommand), std::string::npos) << got;
}

TEST(MulticastRoute, LeavingByEth0IsSaidWithItsMtuAndTheFix) {
  const std::string url = coopdyn::testing::private_udpm_url(1);
  const std::string got = in_private_net(kEth0Default, [&] {
    // ttl=1 (the LAN) and URLs that are not udpm are none of its business
    return loopback_multicast_problem(url) + "|" + loopback_multicast_problem("udpm://239.255.76.67:7667?ttl=1") + "|" +
           loopback_multicast_problem("memq://");
  });
  SKIP_IF_REFUSED(got);
  EXPECT_NE(got.find("leaves by eth0 (MTU 1400), not lo"), std::string::npos) << got;
  EXPECT_NE(got.find(kLoopbackRouteCommand), std::string::npos) << got;
  EXPECT_EQ(got.substr(got.find('|')), "||") << "ttl=1 and memq:// are not judged: " << got;
}

TEST(MulticastRoute, RouteOnLoLeavesNothingToSay) {
  const std::string url = coopdyn::testing::private_udpm_url(2);
  // liblcm's default URL has ttl=0 too
  const std::string got = in_private_net(kWithLoRoute, [&] {
    return loopback_multicast_problem(url) + "|" + loopback_multicast_problem("udpm://239.255.76.67:7667");
  });
  SKIP_IF_REFUSED(got);
  EXPECT_EQ(got, "|");
}

// coopdynd and coopdyn send say it at start, with the command, and run on; with the route, silent
TEST(MulticastRoute, DaemonAndSendWarnAtStartWhereMulticastLeavesByEth0) {
  const std::string url = coopdyn::testing::private_udpm_url(3);
  const std::string scene = std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/two_puma_load.yaml";
  const std::string daemon =
      std::string(COOPDYND_PATH) + " --scene " + scene + " --duration 0.2 --lcm-url '" + url + "'";
  const std::string send = std::string(COOPDYN_PATH) + " send --scene " + scene +
                           " --torque arm1.q1:constant:0 --duration 0.05 --no-check --lcm-url '" + url + "'";
  const auto both = [&] { return output_of(daemon) + "\n=== send\n" + output_of(send); };
  const std::string eth0 = in_private_net(kEth0Default, both);
  SKIP_IF_REFUSED(eth0);
  const size_t split = eth0.find("\n=== send\n");
  ASSERT_NE(split, std::string::npos) << eth0;
  const std::string d = eth0.substr(0, split), s = eth0.substr(split);
  EXPECT_NE(d.find("leaves by eth0 (MTU 1400), not lo"), std::string::npos) << d;
  EXPECT_NE(d.find(kLoopbackRouteCommand), std::string::npos) << d;
  EXPECT_NE(d.find("coopdynd: stopped (duration)"), std::string::npos) << "the daemon runs on: " << d;
  EXPECT_NE(s.find("coopdyn send: warning: "), std::string::npos) << s;
  EXPECT_NE(s.find(kLoopbackRouteCommand), std::string::npos) << s;
  const std::string lo = in_private_net(kWithLoRoute, both);
  SKIP_IF_REFUSED(lo);
  EXPECT_EQ(lo.find(kLoopbackRouteCommand), std::string::npos) << lo;
  EXPECT_NE(lo.find("coopdynd: stopped (duration)"), std::string::npos) << lo;
}
