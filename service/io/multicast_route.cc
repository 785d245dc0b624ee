#include "service/io/multicast_route.h"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "service/io/lcm_wire.h"

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

// the interface that holds `a` ("" if none does), its MTU in *mtu and whether it is a loopback one
std::string interface_of(const in_addr& a, int* mtu, bool* loopback) {
  ifaddrs* all = nullptr;
  if (getifaddrs(&all) != 0) return "";
  std::string name;
  for (ifaddrs* i = all; i; i = i->ifa_next) {
    if (!i->ifa_addr || i->ifa_addr->sa_family != AF_INET) continue;
    if (reinterpret_cast<const sockaddr_in*>(i->ifa_addr)->sin_addr.s_addr != a.s_addr) continue;
    name = i->ifa_name;
    *loopback = (i->ifa_flags & IFF_LOOPBACK) != 0;
    break;
  }
  freeifaddrs(all);
  *mtu = 0;
  if (name.empty() || name.size() >= IFNAMSIZ) return name;
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return name;
  ifreq r{};
  std::memcpy(r.ifr_name, name.c_str(), name.size());
  if (ioctl(fd, SIOCGIFMTU, &r) == 0) *mtu = r.ifr_mtu;
  close(fd);
  return name;
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
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return "";
  sockaddr_in from{};
  socklen_t len = sizeof from;
  const bool routed = connect(fd, reinterpret_cast<const sockaddr*>(&to), sizeof to) == 0 &&
                      getsockname(fd, reinterpret_cast<sockaddr*>(&from), &len) == 0;
  const int err = errno;
  close(fd);
  const std::string fix = std::string("; to fix (as root): ") + kLoopbackRouteCommand;
  if (!routed)
    return "LCM URL '" + url + "': this host has no route for multicast to " + u.group + " (" + std::strerror(err) +
           "): nothing can be sent on it" + fix;
  int mtu = 0;
  bool loopback = false;
  const std::string dev = interface_of(from.sin_addr, &mtu, &loopback);
  if (loopback || (ntohl(from.sin_addr.s_addr) >> 24) == 127) return "";
  char src[INET_ADDRSTRLEN] = {};
  inet_ntop(AF_INET, &from.sin_addr, src, sizeof src);
  const std::string by = dev.empty() ? std::string("the interface of ") + src
                                     : dev + (mtu > 0 ? " (MTU " + std::to_string(mtu) + ")" : std::string());
  return "LCM URL '" + url + "' has ttl=0 (this host only), but multicast to " + u.group + " leaves by " + by +
         ", not lo: datagrams above its MTU come back as IP fragments, which fill a receiver's buffer several times "
         "faster, and large messages are lost on this host" + fix;
}

}  // namespace coopdyn::io
