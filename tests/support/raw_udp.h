// Raw LCM datagrams for the receive path's tests: a sender to a udpm URL's group and port (no
// liblcm), and LC03 fragments built field by field (hostile ones included).
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <string>
#include <vector>

namespace coopdyn::daemon_test {

// Sends raw datagrams to the group and port of a udpm URL (ttl 0: this machine only).
struct RawUdp {
  int fd = -1;
  sockaddr_in to{};
  explicit RawUdp(const std::string& url) {  // udpm://GROUP:PORT?...
    const auto colon = url.rfind(':'), q = url.find('?');
    const int port = std::stoi(url.substr(colon + 1, q - colon - 1));
    const std::string group = url.substr(7, colon - 7);
    fd = socket(AF_INET, SOCK_DGRAM, 0);
    unsigned char ttl = 0;
    setsockopt(fd, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
    to.sin_family = AF_INET;
    to.sin_port = htons(static_cast<uint16_t>(port));
    inet_pton(AF_INET, group.c_str(), &to.sin_addr);
  }
  ~RawUdp() { close(fd); }
  bool send(const std::vector<uint8_t>& b) {
    return sendto(fd, b.data(), b.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to) >= 0;
  }
};
inline void put32(std::vector<uint8_t>& b, uint32_t x) {
  for (int s = 24; s >= 0; s -= 8) b.push_back(static_cast<uint8_t>(x >> s));
}
inline void put16(std::vector<uint8_t>& b, uint16_t x) {
  b.push_back(static_cast<uint8_t>(x >> 8));
  b.push_back(static_cast<uint8_t>(x));
}
// An LCM fragment (LC03): magic, seqno, message size, fragment offset, fragment number, count; the
// channel after fragment 0's header, then payload.
inline std::vector<uint8_t> lc03(uint32_t seq, uint32_t size, uint32_t offset, uint16_t no, uint16_t count,
                                 const std::string& channel, size_t total) {
  std::vector<uint8_t> b;
  put32(b, 0x4c433033);
  put32(b, seq);
  put32(b, size);
  put32(b, offset);
  put16(b, no);
  put16(b, count);
  if (no == 0) b.insert(b.end(), channel.begin(), channel.end()), b.push_back(0);
  while (b.size() < total) b.push_back(0xab);
  return b;
}

}  // namespace coopdyn::daemon_test
