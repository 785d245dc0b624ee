#include "service/io/transport/multicast_route.h"

#include <arpa/inet.h>
#include <net/if.h>
#include <netinet/in.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "service/io/transport/lcm_wire.h"

namespace coopdyn::io {
namespace {

// the URL's ttl option (liblcm's default 0), -1 when malformed
long url_ttl(const std::string& url) {
  const size_t q = url.find('?');
  if (q == std::string::npos) return 0;
  const std::string opts = url.substr(q + 1);
  long ttl = 0;
  for (size_t at = 0; at < opts.size();) {
    const size_t amp = std::min(opts.find('&', at), opts.size());
    const std::string kv = opts.substr(at, amp - at);
    at = amp + 1;
    if (kv.rfind("ttl=", 0) != 0) continue;
    char* end = nullptr;
    ttl = std::strtol(kv.c_str() + 4, &end, 10);
    if (kv.size() == 4 || *end != 0 || ttl < 0) return -1;
  }
  return ttl;
}

// the interface of the main table's route to `group` (longest prefix, then lowest metric), as
// `ip route get` finds it without policy rules; "" when there is none
std::string route_interface(const in_addr& group) {
  std::FILE* f = std::fopen("/proc/net/route", "r");
  if (!f) return "";
  char line[512], name[64];
  unsigned dest = 0, gw = 0, flags = 0, refcnt = 0, use = 0, metric = 0, mask = 0;
  std::string best;
  long best_len = -1;
  unsigned best_metric = 0;
  if (std::fgets(line, sizeof line, f))  // the header
    while (std::fgets(line, sizeof line, f)) {
      if (std::sscanf(line, "%63s %x %x %x %u %u %u %x", name, &dest, &gw, &flags, &refcnt, &use, &metric, &mask) != 8)
        continue;
      if (!(flags & 1) || (group.s_addr & mask) != dest) continue;  // RTF_UP, and the group inside
      const long len = __builtin_popcount(mask);
      if (len > best_len || (len == best_len && metric < best_metric)) {
        best = name;
        best_len = len;
        best_metric = metric;
      }
    }
  std::fclose(f);
  return best;
}

// an interface's MTU (0: unknown) and whether it is a loopback one
void interface_facts(const std::string& name, int* mtu, bool* loopback) {
  *mtu = 0;
  *loopback = name == "lo";
  if (name.empty() || name.size() >= IFNAMSIZ) return;
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return;
  ifreq r{};
  std::memcpy(r.ifr_name, name.c_str(), name.size());
  if (ioctl(fd, SIOCGIFMTU, &r) == 0) *mtu = r.ifr_mtu;
  if (ioctl(fd, SIOCGIFFLAGS, &r) == 0) *loopback = (r.ifr_flags & IFF_LOOPBACK) != 0;
  close(fd);
}

}  // namespace

std::string loopback_multicast_problem(const std::string& given) {
  std::string url = given;
  if (url.empty()) {
    const char* env = std::getenv("LCM_DEFAULT_URL");
    url = env && *env ? env : "udpm://";
  }
  wire::UdpmUrl u;
  std::string why;
  if (!wire::parse_udpm_url(url, &u, &why) || url_ttl(url) != 0) return "";
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(u.port);
  if (inet_pton(AF_INET, u.group.c_str(), &to.sin_addr) != 1) return "";
  // the kernel's verdict first (no route: connect() fails), then the route's interface
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return "";
  const bool routed = connect(fd, reinterpret_cast<const sockaddr*>(&to), sizeof to) == 0;
  const int err = errno;
  close(fd);
  const std::string fix = std::string("; to fix (as root): ") + kLoopbackRouteCommand;
  if (!routed)
    return "LCM URL '" + url + "': this host has no route for multicast to " + u.group + " (" + std::strerror(err) +
           "): nothing can be sent on it" + fix;
  const std::string dev = route_interface(to.sin_addr);
  if (dev.empty()) return "";  // routed by a rule or table this check does not read: no verdict
  int mtu = 0;
  bool loopback = false;
  interface_facts(dev, &mtu, &loopback);
  if (loopback) return "";
  const std::string by = dev + (mtu > 0 ? " (MTU " + std::to_string(mtu) + ")" : std::string());
  return "LCM URL '" + url + "' has ttl=0 (this host only), but multicast to " + u.group + " leaves by " + by +
         ", not lo: datagrams above its MTU come back as IP fragments, which fill a receiver's buffer several times "
         "faster, and large messages are lost on this host" + fix;
}

}  // namespace coopdyn::io
