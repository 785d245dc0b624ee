#include "service/io/transport/input_gate.h"

#include <arpa/inet.h>
#include <linux/filter.h>
#include <linux/sock_diag.h>
#include <time.h>

#include <cstring>
#include <limits>
#include <stdexcept>

#include "service/io/transport/lcm_bus.h"
#include "service/io/transport/udpm_socket.h"

namespace coopdyn::io {

namespace {

constexpr uint32_t kLc02 = 0x4c433032, kLc03 = 0x4c433033;  // LCM's short message and fragment magic


// The classic BPF program of the receive socket. For a UDP socket the filter sees the datagram from
// the UDP header (8 bytes) on: LCM's header at 8 (magic, seqno), the channel and its NUL at 16, the
// payload (its 8-byte type hash first) after it. A load past the end of the datagram drops it.
std::vector<sock_filter> build_filter(const std::vector<InputChannel>& acc) {
  std::vector<sock_filter> f;
  auto stmt = [&](uint16_t code, uint32_t k) { f.push_back(sock_filter{code, 0, 0, k}); };
  auto jeq = [&](uint32_t k, uint8_t jt, uint8_t jf) { f.push_back(sock_filter{BPF_JMP | BPF_JEQ | BPF_K, jt, jf, k}); };
  stmt(BPF_LD | BPF_W | BPF_ABS, 8);
  jeq(kLc03, 0, 1);
  stmt(BPF_RET | BPF_K, 0xffffffffu);  // a fragment: accepted (the gate checks complete messages)
  jeq(kLc02, 1, 0);
  stmt(BPF_RET | BPF_K, 0);
  for (const InputChannel& a : acc) {
    // the bytes to match at offset 16: channel, NUL, hash
    std::vector<unsigned char> m(a.channel.begin(), a.channel.end());
    m.push_back(0);
    m.insert(m.end(), a.hash, a.hash + 8);
    // count the instructions of this entry (2 per compare, then the accept) to jump past it on a mismatch
    int compares = 0;
    for (size_t k = 0; k < m.size();) {
      const size_t n = m.size() - k >= 4 ? 4 : m.size() - k >= 2 ? 2 : 1;
      k += n;
      ++compares;
    }
    int left = 2 * compares + 1;  // instructions of this entry from the current one on
    for (size_t k = 0; k < m.size();) {
      const size_t n = m.size() - k >= 4 ? 4 : m.size() - k >= 2 ? 2 : 1;
      uint32_t v = 0;
      for (size_t b = 0; b < n; ++b) v = (v << 8) | m[k + b];
      stmt(BPF_LD | (n == 4 ? BPF_W : n == 2 ? BPF_H : BPF_B) | BPF_ABS, static_cast<uint32_t>(16 + k));
      left -= 1;
      // mismatch: to the first instruction after this entry's accept
      jeq(v, 0, static_cast<uint8_t>(left - 1));
      left -= 1;
      k += n;
    }
    stmt(BPF_RET | BPF_K, 0xffffffffu);
  }
  stmt(BPF_RET | BPF_K, 0);
  return f;
}

// Verifier::check's reasons that need no HMAC: kDecode (no mac_len field where it must be, or bytes
// after the MAC), kUnauthenticated (mac_len 0), kBadMac (a MAC of another length); else kNone
Reject mac_form(MessageType t, const uint8_t* data, int len) {
  const int at = mac_field_offset(t, data, len);
  if (at < 0 || len - at < 4) return Reject::kDecode;
  const int32_t mac_len = static_cast<int32_t>((uint32_t{data[at]} << 24) | (uint32_t{data[at + 1]} << 16) |
                                               (uint32_t{data[at + 2]} << 8) | uint32_t{data[at + 3]});
  const int rest = len - at - 4;
  if (mac_len == 0) return rest == 0 ? Reject::kUnauthenticated : Reject::kDecode;
  return mac_len == kMacBytes && rest == kMacBytes ? Reject::kNone : Reject::kBadMac;
}

}  // namespace

long long ReceiverCounters::dropped() const { return static_cast<long long>(counters_->dropped.load()); }
long long ReceiverCounters::filtered() const { return static_cast<long long>(counters_->filtered.load()); }
long long ReceiverCounters::malformed() const {
  long long n = 0;
  for (int k = 0; k < wire::kWireStatuses; ++k)
    if (wire::refused(static_cast<wire::WireStatus>(k))) n += static_cast<long long>(counters_->malformed_by[k].load());
  return n;
}
long long ReceiverCounters::malformed(wire::WireStatus why) const {
  return static_cast<long long>(counters_->malformed_by[static_cast<int>(why)].load());
}
long long ReceiverCounters::rejected(int channel, Reject why) const {
  if (channel < 0 || channel >= kRxChannels || static_cast<int>(why) < 0 || static_cast<int>(why) >= kRejectKinds) return 0;
  return static_cast<long long>(counters_->rejected_by[channel][static_cast<int>(why)].load(std::memory_order_relaxed));
}
long long ReceiverCounters::socket_drops() const { return static_cast<long long>(counters_->socket_drops.load()); }
long long ReceiverCounters::socket_buffer() const { return static_cast<long long>(counters_->rcvbuf.load()); }
int ReceiverCounters::filter_state() const { return static_cast<int>(counters_->filter.load()); }
void ReceiverCounters::open_window(int64_t utime_us) {
  for (auto& w : counters_->accepted_utime) w.store(utime_us, std::memory_order_release);
}
void ReceiverCounters::note_accepted(int channel, int64_t utime_us) {
  if (channel < 0 || channel >= kRxChannels) return;
  std::atomic<int64_t>& w = counters_->accepted_utime[channel];
  if (utime_us > w.load(std::memory_order_relaxed)) w.store(utime_us, std::memory_order_release);  // one writer
}
int64_t ReceiverCounters::window(int channel) const {
  return channel < 0 || channel >= kRxChannels ? 0 : counters_->accepted_utime[channel].load(std::memory_order_acquire);
}

std::vector<InputChannel> input_channels(const std::vector<std::string>& channels, const std::vector<int64_t>& fingerprints) {
  if (channels.size() != fingerprints.size()) throw std::invalid_argument("receive path: one fingerprint per channel");
  if (channels.size() > static_cast<size_t>(kRxChannels)) throw std::invalid_argument("receive path: too many channels");
  std::vector<InputChannel> acc(channels.size());
  for (size_t k = 0; k < channels.size(); ++k) {
    acc[k].channel = channels[k];
    const uint64_t h = static_cast<uint64_t>(fingerprints[k]);
    for (int b = 0; b < 8; ++b) acc[k].hash[b] = static_cast<unsigned char>(h >> (56 - 8 * b));
    acc[k].type = identify(acc[k].hash, 8);
  }
  return acc;
}

int open_input_socket(const wire::UdpmUrl& u, long rcvbuf, const std::vector<InputChannel>& channels, RxCounters* c,
                      std::string* why) {
  std::vector<sock_filter> prog = build_filter(channels);
  sock_fprog fp{static_cast<unsigned short>(prog.size()), prog.data()};
  const UdpmSocket s = open_udpm_socket(u, rcvbuf, &fp);
  c->filter.store(s.filter ? 1 : -2);
  if (s.fd < 0) {
    *why = s.why;
    return -1;
  }
  c->rcvbuf.store(s.rcvbuf);
  return s.fd;
}

uint64_t kernel_drops(int fd) {
#ifdef SO_MEMINFO
  uint32_t mi[SK_MEMINFO_VARS] = {};
  socklen_t l = sizeof mi;
  if (fd >= 0 && getsockopt(fd, SOL_SOCKET, SO_MEMINFO, mi, &l) == 0 && l > SK_MEMINFO_DROPS * sizeof(uint32_t))
    return mi[SK_MEMINFO_DROPS];
#else
  (void)fd;
#endif
  return 0;
}

// Authentication on: each accepted channel's verifier (its type from the channel's fingerprint), the
// window the daemon moves (RxCounters::accepted_utime) and the utime of the last message let through
// on each channel (the replay rule, input_gate.h).
struct InputGate::Auth {
  std::vector<Verifier> verifiers;
  std::vector<int64_t> last_passed;
  std::vector<bool> passed;
  const RxCounters* c;
  Auth(const AuthKey& key, const std::vector<InputChannel>& acc, const RxCounters* counters) : c(counters) {
    for (const InputChannel& a : acc) {
      verifiers.emplace_back(key, a.channel, a.type);
      last_passed.push_back(0);
      passed.push_back(false);
    }
  }
  // kNone: a signed message of channel k above its window and not the one let through last. The MAC
  // is computed last: a message without one, or whose utime no MAC can make acceptable, costs no
  // HMAC; such a message with a forged MAC counts as replayed. Only a message that verifies is
  // remembered; the window itself is the daemon's (it moves when the daemon accepts).
  Reject check(int k, MessageType t, const uint8_t* data, int len) {
    Reject r = mac_form(t, data, len);
    if (r != Reject::kNone) return r;
    const size_t i = static_cast<size_t>(k);
    const int64_t u = raw_utime(data, len);
    if (u <= c->accepted_utime[k].load(std::memory_order_acquire) || (passed[i] && u == last_passed[i]))
      return Reject::kReplayed;
    r = verifiers[i].check(data, len);
    if (r == Reject::kNone) last_passed[i] = u, passed[i] = true;
    return r;
  }
};

InputGate::InputGate(std::vector<InputChannel> channels, int max_message_bytes, RxCounters* c)
    : channels_(std::move(channels)),
      c_(c),
      reasm_(kReassemblySlots, max_message_bytes, kReassemblyNs),
      bufs_(static_cast<size_t>(kBatch) * kDatagramBytes),
      msgs_(kBatch),
      iov_(kBatch),
      from_(kBatch) {}

InputGate::~InputGate() = default;

void InputGate::set_auth_key(const AuthKey& key) { auth_ = std::make_unique<Auth>(key, channels_, c_); }

int InputGate::read_batch(int sock) {
  if (sock < 0) return 0;
  for (int k = 0; k < kBatch; ++k) {
    iov_[k] = iovec{bufs_.data() + static_cast<size_t>(k) * kDatagramBytes, kDatagramBytes};
    msgs_[k].msg_hdr = msghdr{&from_[k], sizeof from_[k], &iov_[k], 1, nullptr, 0, 0};
    msgs_[k].msg_len = 0;
  }
  const int n = recvmmsg(sock, msgs_.data(), kBatch, MSG_DONTWAIT, nullptr);
  batch_ns_ = monotonic_ns();
  return n > 0 ? n : 0;
}

int InputGate::admit(int i, wire::Message* out) {
  if (msgs_[i].msg_hdr.msg_flags & MSG_TRUNC) {  // a datagram over 64 KiB cannot be LCM's
    c_->malformed_by[static_cast<int>(wire::WireStatus::kTooLarge)].fetch_add(1, std::memory_order_relaxed);
    return -1;
  }
  return admit_datagram(static_cast<const uint8_t*>(iov_[i].iov_base), msgs_[i].msg_len, from_[i], out);
}

// A coopdyn message of one of the accepted channels: the channel literally, then the payload's
// first 8 bytes the type's fingerprint. Returns the channel's index, -1 if none.
int InputGate::accepted(const char* channel, int channel_len, const uint8_t* data, int len) const {
  for (size_t k = 0; k < channels_.size(); ++k) {
    const InputChannel& a = channels_[k];
    if (len >= 8 && std::memcmp(data, a.hash, 8) == 0 && a.channel.size() == static_cast<size_t>(channel_len) &&
        std::memcmp(a.channel.data(), channel, a.channel.size()) == 0)
      return static_cast<int>(k);
  }
  return -1;
}

// One datagram: parsed and reassembled (lcm_wire.h); a refused one counted by its reason, a
// fragment 0 or a complete message of another channel or type counted as filtered, a complete
// message that fails the field walk or (authentication on) the MAC or replay rule counted by
// channel and reason.
int InputGate::admit_datagram(const uint8_t* buf, size_t len, const sockaddr_in& from, wire::Message* out) {
  wire::Datagram d;
  wire::WireStatus st = wire::parse_datagram(buf, len, &d);
  if (st == wire::WireStatus::kPending && d.fragment_no == 0 && accepted(d.channel, d.channel_len, d.data, d.data_len) < 0) {
    c_->filtered.fetch_add(1, std::memory_order_relaxed);  // refused before it takes a slot
    return -1;
  }
  if (!wire::refused(st)) {
    const uint64_t sender = (uint64_t{ntohl(from.sin_addr.s_addr)} << 16) | ntohs(from.sin_port);
    st = reasm_.add(buf, len, sender, batch_ns_, out);
  }
  if (wire::refused(st)) {
    c_->malformed_by[static_cast<int>(st)].fetch_add(1, std::memory_order_relaxed);
    return -1;
  }
  if (st != wire::WireStatus::kComplete) return -1;
  c_->received.fetch_add(1, std::memory_order_relaxed);
  const int k = accepted(out->channel, out->channel_len, out->data, out->len);
  if (k < 0) {
    c_->filtered.fetch_add(1, std::memory_order_relaxed);
    return -1;
  }
  // authentication on: the MAC and the replay rule; off: a message whose fields do not walk up to
  // the MAC field is malformed (the decoders would refuse it: Reject::kDecode), refused here so
  // that junk after a fingerprint never reaches them
  const MessageType t = channels_[static_cast<size_t>(k)].type;
  const Reject r = auth_ ? auth_->check(k, t, out->data, out->len)
                         : mac_field_offset(t, out->data, out->len) < 0 ? Reject::kDecode : Reject::kNone;
  if (r != Reject::kNone) {
    c_->rejected_by[k][static_cast<int>(r)].fetch_add(1, std::memory_order_relaxed);
    return -1;
  }
  return k;
}

}  // namespace coopdyn::io
