// Where this host's multicast to an LCM udpm:// URL leaves. With ttl=0 (liblcm's default) a message
// reaches this host only, through the kernel's loopback of what it sends by the route to the group.
// Without a multicast route on lo that route is the default one (eth0, MTU 1500 or less) or none:
// datagrams above its MTU are cut into IP fragments, which take several times their size in a
// receiver's buffer, so large messages (LCM sends them as 64 kB datagrams) are lost on this host,
// or nothing can be sent at all. Checked by a UDP socket's connect() to the group (nothing is sent;
// it fails without a route) and the main routing table's route to it (/proc/net/route, longest
// prefix: the source address alone does not tell, lo has no address of link scope). Not for the loop.
#pragma once

#include <string>

namespace coopdyn::io {

// The command that routes multicast by the loopback interface (run once, as root).
inline constexpr const char* kLoopbackRouteCommand = "ip route add 224.0.0.0/4 dev lo";

// "" when `url` is not udpm://, has a ttl above 0 (the LAN: the route is the network's business)
// or its group's multicast leaves by a loopback interface; else one line: what happens to the
// URL's messages on this host and the command that fixes it. "" as `url` reads LCM_DEFAULT_URL,
// as liblcm does. A malformed URL is not judged here ("": its user reports the error).
std::string loopback_multicast_problem(const std::string& url);

}  // namespace coopdyn::io
