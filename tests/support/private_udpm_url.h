// A udpm:// URL that no other test process on this host uses.
#pragma once

#include <unistd.h>

#include <string>

namespace coopdyn::testing {

// A private udpm URL on this host (ttl=0): port 20000 + 10 (pid % 3000) + k, k in [0, 10). Two test
// processes alive at once never share a port (their pids would have to differ by a multiple of
// 3000), and one test process has 10 ports of its own. The port, not the group, keeps tests apart:
// LCM binds INADDR_ANY:port, and Linux hands such a socket the datagrams of every group joined on
// the host (IP_MULTICAST_ALL).
inline std::string private_udpm_url(int k, const std::string& group = "239.255.76.67") {
  return "udpm://" + group + ":" + std::to_string(20000 + 10 * (getpid() % 3000) + k % 10) + "?ttl=0";
}

}  // namespace coopdyn::testing
