"""LCM's udpm transport for short messages, in pure Python: the part of the `lcm` module's API that
clients/python/examples/live_client.py uses (LCM(url), subscribe, publish, handle_timeout).

For the test python.live_client_udpm only: it lets the example run against coopdynd where LCM's own
Python module is not installed (Debian 12 has none). The wire format is LCM's: one UDP datagram per
message to the URL's multicast group and port, `uint32 0x4C433032 ("LC02") | uint32 sequence number |
channel | NUL | payload`, big-endian. Fragmented messages (above 64 KB) are not implemented: they are
dropped, and publish() refuses them.
"""
import re
import select
import socket
import struct

_SHORT = 0x4C433032
_MAX_SHORT = 65499


class LCM(object):
    def __init__(self, url):
        m = re.match(r"^udpm://([0-9.]+):(\d+)(?:\?ttl=(\d+))?$", url)
        if not m:
            raise ValueError("udpm stand-in: cannot read the URL %r (udpm://GROUP:PORT?ttl=N)" % url)
        self._group, self._port, ttl = m.group(1), int(m.group(2)), int(m.group(3) or 0)
        self._tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        self._tx.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, ttl)
        self._tx.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
        self._rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        self._rx.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        if hasattr(socket, "SO_REUSEPORT"):
            self._rx.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
        self._rx.bind(("", self._port))
        mreq = struct.pack("4s4s", socket.inet_aton(self._group), socket.inet_aton("0.0.0.0"))
        self._rx.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, mreq)
        self._subs = []
        self._seq = 0

    def subscribe(self, channel, handler):
        self._subs.append((re.compile("^(?:%s)$" % channel), handler))

    def publish(self, channel, data):
        packet = struct.pack(">II", _SHORT, self._seq) + channel.encode() + b"\0" + bytes(data)
        if len(packet) > _MAX_SHORT:
            raise ValueError("udpm stand-in: %d bytes need LCM's fragmentation, not implemented" % len(packet))
        self._seq = (self._seq + 1) & 0xFFFFFFFF
        self._tx.sendto(packet, (self._group, self._port))

    def handle_timeout(self, ms):
        """Dispatches at most one message; returns 1 if one came within ms milliseconds, else 0."""
        if not select.select([self._rx], [], [], ms / 1000.0)[0]:
            return 0
        packet = self._rx.recv(65536)
        if len(packet) < 9 or struct.unpack(">I", packet[:4])[0] != _SHORT:
            return 1  # a fragment or not LCM: dropped
        end = packet.index(b"\0", 8)
        channel, data = packet[8:end].decode(), packet[end + 1:]
        for pattern, handler in self._subs:
            if pattern.match(channel):
                handler(channel, data)
        return 1
