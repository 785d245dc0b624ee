#include "service/io/transport/udpm_socket.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace coopdyn::io {

namespace {

void ask_receive_buffer(int sock, long rcvbuf) {
  const int want = static_cast<int>(std::min<long>(rcvbuf, 1L << 30));
  setsockopt(sock, SOL_SOCKET, SO_RCVBUF, &want, sizeof want);
  int got = 0;
  socklen_t gl = sizeof got;
  // capped at net.core.rmem_max: with CAP_NET_ADMIN the buffer asked for all the same
  if (getsockopt(sock, SOL_SOCKET, SO_RCVBUF, &got, &gl) == 0 && got / 2 < want)
    setsockopt(sock, SOL_SOCKET, SO_RCVBUFFORCE, &want, sizeof want);
}

}  // namespace

UdpmSocket open_udpm_socket(const wire::UdpmUrl& u, long rcvbuf, const sock_fprog* filter) {
  UdpmSocket s;
  const int sock = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (sock < 0) {
    s.why = std::string("socket: ") + std::strerror(errno);
    return s;
  }
  const int one = 1, zero = 0;
  setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (filter) s.filter = setsockopt(sock, SOL_SOCKET, SO_ATTACH_FILTER, filter, sizeof *filter) == 0;
  if (rcvbuf <= 0) rcvbuf = u.recv_buf_size;
  if (rcvbuf > 0) ask_receive_buffer(sock, rcvbuf);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_ANY);
  addr.sin_port = htons(u.port);
  ip_mreq mreq{};
  mreq.imr_interface.s_addr = htonl(INADDR_ANY);
  setsockopt(sock, IPPROTO_IP, IP_MULTICAST_ALL, &zero, sizeof zero);
  if (inet_pton(AF_INET, u.group.c_str(), &mreq.imr_multiaddr) != 1 ||
      bind(sock, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
      setsockopt(sock, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mreq, sizeof mreq) != 0) {
    s.why = "cannot join " + u.group + ":" + std::to_string(u.port) + ": " + std::strerror(errno);
    close(sock);
    return s;
  }
  int got = 0;
  socklen_t gl = sizeof got;
  if (getsockopt(sock, SOL_SOCKET, SO_RCVBUF, &got, &gl) == 0) s.rcvbuf = got;
  s.fd = sock;
  return s;
}

}  // namespace coopdyn::io
