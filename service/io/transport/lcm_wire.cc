#include "service/io/transport/lcm_wire.h"

#include <arpa/inet.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>

namespace coopdyn::io::wire {

namespace {

uint32_t be32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}
uint16_t be16(const uint8_t* p) { return static_cast<uint16_t>((p[0] << 8) | p[1]); }

// the NUL-terminated channel at p (at most n bytes available): its length, or -1
int channel_at(const uint8_t* p, size_t n) {
  const size_t lim = std::min<size_t>(n, kMaxChannel + 1);
  const void* z = std::memchr(p, 0, lim);
  if (!z) return -1;
  const int len = static_cast<int>(static_cast<const uint8_t*>(z) - p);
  return len > 0 ? len : -1;
}

}  // namespace

const char* wire_status_key(WireStatus s) {
  switch (s) {
#define COOPDYN_WIRE_KEY(e, key, text) \
  case WireStatus::e: return #key;
    COOPDYN_WIRE_STATUSES(COOPDYN_WIRE_KEY)
#undef COOPDYN_WIRE_KEY
  }
  return "?";
}

const char* wire_status_text(WireStatus s) {
  switch (s) {
#define COOPDYN_WIRE_TEXT(e, key, text) \
  case WireStatus::e: return text;
    COOPDYN_WIRE_STATUSES(COOPDYN_WIRE_TEXT)
#undef COOPDYN_WIRE_TEXT
  }
  return "?";
}

WireStatus parse_datagram(const void* buf, size_t len, Datagram* out) {
  const uint8_t* b = static_cast<const uint8_t*>(buf);
  *out = Datagram{};
  if (len < 4) return WireStatus::kTruncated;
  const uint32_t magic = be32(b);
  if (magic == kShortMagic) {
    if (len < static_cast<size_t>(kShortHeader)) return WireStatus::kTruncated;
    out->seqno = be32(b + 4);
    const int cl = channel_at(b + kShortHeader, len - kShortHeader);
    if (cl < 0) return WireStatus::kBadChannel;
    out->channel = reinterpret_cast<const char*>(b + kShortHeader);
    out->channel_len = cl;
    const size_t at = kShortHeader + static_cast<size_t>(cl) + 1;
    out->data = b + at;
    out->data_len = static_cast<int>(len - at);  // len is a datagram's: below 2^16
    return WireStatus::kComplete;
  }
  if (magic != kFragmentMagic) return WireStatus::kBadMagic;
  if (len < static_cast<size_t>(kFragmentHeader)) return WireStatus::kTruncated;
  out->fragment = true;
  out->seqno = be32(b + 4);
  out->msg_size = be32(b + 8);
  out->fragment_offset = be32(b + 12);
  out->fragment_no = be16(b + 16);
  out->n_fragments = be16(b + 18);
  if (out->n_fragments == 0 || out->fragment_no >= out->n_fragments || out->msg_size == 0)
    return WireStatus::kBadFragmentHeader;
  size_t at = kFragmentHeader;
  if (out->fragment_no == 0) {
    const int cl = channel_at(b + at, len - at);
    if (cl < 0) return WireStatus::kBadChannel;
    out->channel = reinterpret_cast<const char*>(b + at);
    out->channel_len = cl;
    at += static_cast<size_t>(cl) + 1;
    if (out->fragment_offset != 0) return WireStatus::kOutOfRange;  // the first fragment starts the message
  }
  out->data = b + at;
  out->data_len = static_cast<int>(len - at);
  if (out->data_len == 0) return WireStatus::kOutOfRange;  // an empty fragment covers nothing
  if (uint64_t{out->fragment_offset} + static_cast<uint64_t>(out->data_len) > out->msg_size) return WireStatus::kOutOfRange;
  return WireStatus::kPending;
}

bool parse_udpm_url(const std::string& given, UdpmUrl* out, std::string* why) {
  *out = UdpmUrl{};
  std::string url = given;
  if (url.empty()) {
    const char* env = std::getenv("LCM_DEFAULT_URL");
    url = env && *env ? env : "udpm://";
  }
  if (url.rfind("udpm://", 0) != 0) {
    *why = "not a udpm:// URL: '" + url + "'";
    return false;
  }
  const std::string rest = url.substr(7);
  const size_t q = rest.find('?');
  const std::string addr = rest.substr(0, q), opts = q == std::string::npos ? "" : rest.substr(q + 1);
  const size_t colon = addr.find(':');
  if (colon != 0 && !addr.empty()) out->group = addr.substr(0, colon);
  in_addr a{};
  if (inet_pton(AF_INET, out->group.c_str(), &a) != 1 || !IN_MULTICAST(ntohl(a.s_addr))) {
    *why = "the group '" + out->group + "' of '" + url + "' is not an IPv4 multicast address";
    return false;
  }
  if (colon != std::string::npos) {
    const std::string p = addr.substr(colon + 1);
    char* end = nullptr;
    const long port = std::strtol(p.c_str(), &end, 10);
    if (p.empty() || *end != 0 || port <= 0 || port > 65535) {
      *why = "the port '" + p + "' of '" + url + "' is not in 1..65535";
      return false;
    }
    out->port = static_cast<uint16_t>(port);
  }
  for (size_t at = 0; at < opts.size();) {
    const size_t amp = std::min(opts.find('&', at), opts.size());
    const std::string kv = opts.substr(at, amp - at);
    at = amp + 1;
    if (kv.rfind("recv_buf_size=", 0) != 0) continue;
    char* end = nullptr;
    const long n = std::strtol(kv.c_str() + 14, &end, 10);
    if (kv.size() == 14 || *end != 0 || n < 0 || n > (1L << 30)) {
      *why = "recv_buf_size of '" + url + "' is not a size in bytes";
      return false;
    }
    out->recv_buf_size = static_cast<int>(n);
  }
  return true;
}

Reassembler::Reassembler(int slots, int max_message_bytes, long long timeout_ns)
    : slots_(static_cast<size_t>(std::max(1, slots))),
      max_bytes_(std::max(1, max_message_bytes)),
      max_fragments_(std::min(65535, max_bytes_ / 256 + 2)),
      timeout_ns_(timeout_ns) {
  for (Slot& s : slots_) {
    s.data.assign(static_cast<size_t>(max_bytes_), 0);
    s.seen.assign(static_cast<size_t>(max_fragments_ + 7) / 8, 0);
    s.offset.assign(static_cast<size_t>(max_fragments_), 0);
    s.length.assign(static_cast<size_t>(max_fragments_), 0);
    s.order.assign(static_cast<size_t>(max_fragments_), 0);
  }
}

int Reassembler::busy_slots() const {
  int n = 0;
  for (const Slot& s : slots_) n += s.busy ? 1 : 0;
  return n;
}

// The slot of this fragment's message: the sender's (a new seqno abandons the old partial
// message), else a free or expired one. nullptr with *why when there is none or it disagrees.
Reassembler::Slot* Reassembler::slot_for(const Datagram& d, uint64_t sender, long long now_ns, WireStatus* why) {
  Slot* free_slot = nullptr;
  Slot* mine = nullptr;
  for (Slot& s : slots_) {
    if (s.busy && now_ns - s.started_ns > timeout_ns_) {
      s.busy = false;
      ++expired_;
    }
    if (s.busy && s.sender == sender) mine = &s;
    if (!s.busy && !free_slot) free_slot = &s;
  }
  if (mine && mine->seqno == d.seqno) {
    if (mine->msg_size != d.msg_size || mine->n_fragments != d.n_fragments) {
      *why = WireStatus::kInconsistent;
      return nullptr;
    }
    return mine;
  }
  if (mine) {  // liblcm keeps one partial message per sender: its next message replaces it
    mine->busy = false;
    ++abandoned_;
    free_slot = mine;
  }
  if (!free_slot) {
    *why = WireStatus::kNoSlot;
    return nullptr;
  }
  Slot& s = *free_slot;
  s.busy = true;
  s.sender = sender;
  s.seqno = d.seqno;
  s.msg_size = d.msg_size;
  s.n_fragments = d.n_fragments;
  s.received = 0;
  s.bytes = 0;
  s.started_ns = now_ns;
  s.channel_len = -1;
  std::fill(s.seen.begin(), s.seen.begin() + (d.n_fragments + 7) / 8, 0);
  return &s;
}

// every fragment is in: they must tile [0, msg_size) exactly (their sizes add up to msg_size, so
// a gap means an overlap)
WireStatus Reassembler::finish(Slot& s, Message* out) {
  s.busy = false;
  for (uint16_t k = 0; k < s.n_fragments; ++k) s.order[k] = k;
  std::sort(s.order.begin(), s.order.begin() + s.n_fragments,
            [&s](uint16_t a, uint16_t b) { return s.offset[a] < s.offset[b]; });
  uint32_t next = 0;
  for (uint16_t k = 0; k < s.n_fragments; ++k) {
    if (s.offset[s.order[k]] != next) return WireStatus::kOverlap;
    next += s.length[s.order[k]];
  }
  if (next != s.msg_size || s.channel_len < 0) return WireStatus::kOverlap;
  out->channel = s.channel;
  out->channel_len = s.channel_len;
  out->data = s.data.data();
  out->len = static_cast<int>(s.msg_size);
  return WireStatus::kComplete;
}

WireStatus Reassembler::add(const void* buf, size_t len, uint64_t sender, long long now_ns, Message* out) {
  Datagram d;
  const WireStatus st = parse_datagram(buf, len, &d);
  if (st == WireStatus::kComplete) {
    if (d.data_len > max_bytes_) return WireStatus::kTooLarge;
    *out = Message{d.channel, d.channel_len, d.data, d.data_len};
    return st;
  }
  if (st != WireStatus::kPending) return st;
  if (d.msg_size > static_cast<uint32_t>(max_bytes_)) return WireStatus::kTooLarge;
  if (d.n_fragments > max_fragments_) return WireStatus::kTooManyFragments;
  WireStatus why = WireStatus::kPending;
  Slot* sp = slot_for(d, sender, now_ns, &why);
  if (!sp) return why;
  Slot& s = *sp;
  const uint16_t k = d.fragment_no;
  if (s.seen[k / 8] & (1u << (k % 8))) return WireStatus::kDuplicate;
  if (s.bytes + static_cast<uint32_t>(d.data_len) > s.msg_size) {  // more bytes than the message: overlap
    s.busy = false;
    return WireStatus::kOverlap;
  }
  s.seen[k / 8] = static_cast<uint8_t>(s.seen[k / 8] | (1u << (k % 8)));
  s.offset[k] = d.fragment_offset;
  s.length[k] = static_cast<uint32_t>(d.data_len);
  s.bytes += static_cast<uint32_t>(d.data_len);
  ++s.received;
  std::memcpy(s.data.data() + d.fragment_offset, d.data, static_cast<size_t>(d.data_len));  // in range: parse_datagram
  if (d.channel) {
    std::memcpy(s.channel, d.channel, static_cast<size_t>(d.channel_len));
    s.channel[d.channel_len] = 0;
    s.channel_len = d.channel_len;
  }
  if (s.received < s.n_fragments) return WireStatus::kPending;
  return finish(s, out);
}

}  // namespace coopdyn::io::wire
