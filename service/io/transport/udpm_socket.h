// A UDP socket in an LCM udpm group, opened as liblcm opens its own (bound to the URL's port with
// SO_REUSEADDR, so that lcm-logger and other subscribers on this host receive too; the group joined
// on any interface; IP_MULTICAST_ALL off, so only this group's datagrams arrive), non-blocking.
// Used by the daemon's receive path (input_gate.h: the receive process, or the loop with
// realtime.receive_in_loop) and by LcmBus's polling reader, which read LCM's wire format
// themselves (lcm_wire.h).
#pragma once

#include <linux/filter.h>

#include <string>

#include "service/io/transport/lcm_wire.h"

namespace coopdyn::io {

struct UdpmSocket {
  int fd = -1;           // -1: not opened (why says where it failed)
  bool filter = false;   // the filter asked for is attached
  int rcvbuf = 0;        // SO_RCVBUF as the kernel reports it (bytes, its doubled figure)
  std::string why;
};

// filter: a classic BPF program attached before bind (no datagram is queued unfiltered), nullptr
// for none. rcvbuf > 0: the receive buffer asked for (else the URL's recv_buf_size, else the OS
// default), by SO_RCVBUFFORCE when net.core.rmem_max caps it and the process may.
UdpmSocket open_udpm_socket(const wire::UdpmUrl& u, long rcvbuf, const sock_fprog* filter);

}  // namespace coopdyn::io
