// LCM's UDP wire format, parsed and reassembled without liblcm: the daemon's receive path.
//
// A datagram is one of (big-endian, LCM's udpm transport):
//   LC02 short message: u32 magic 0x4c433032, u32 seqno, channel (NUL-terminated), payload
//   LC03 fragment:      u32 magic 0x4c433033, u32 seqno, u32 msg_size, u32 fragment_offset,
//                       u16 fragment_no, u16 n_fragments; fragment 0 then has the channel
//                       (NUL-terminated); then the fragment's payload bytes, which go to
//                       [fragment_offset, fragment_offset + n) of the message's payload.
// liblcm sends a message as LC02 when it fits one datagram (65,499 bytes with the header and the
// channel) and as LC03 fragments of up to 65,423 bytes otherwise.
//
// parse_datagram checks every length and offset against the datagram and the message size; it
// reads nothing outside [buf, buf + len) and allocates nothing. Reassembler puts fragments
// together in a fixed number of slots, one per sender (address and port, as liblcm does), each of
// at most max_message_bytes, all allocated by the constructor: a fragment is refused (with its
// reason) when it repeats a fragment number, disagrees with the slot's msg_size or n_fragments,
// overlaps what the slot holds, or finds every slot busy; a partial message expires timeout_ns
// after its first fragment, and one a sender leaves for a new seqno is abandoned (counted).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace coopdyn::io::wire {

constexpr uint32_t kShortMagic = 0x4c433032, kFragmentMagic = 0x4c433033;
constexpr int kShortHeader = 8, kFragmentHeader = 20;
constexpr int kMaxChannel = 63;  // LCM's limit on a channel name, bytes

// What becomes of a datagram: a complete message, a fragment kept, or a refusal with its reason.
// COOPDYN_WIRE_STATUS(enumerator, key, text)
#define COOPDYN_WIRE_STATUSES(X)                                                                         \
  X(kComplete, complete, "a complete message")                                                          \
  X(kPending, pending, "a fragment kept for its message")                                                \
  X(kTruncated, truncated, "shorter than its header")                                                   \
  X(kBadMagic, bad_magic, "not an LCM datagram (magic)")                                                \
  X(kBadChannel, bad_channel, "channel missing, empty, unterminated or longer than 63 bytes")          \
  X(kBadFragmentHeader, bad_fragment_header, "fragment number not below the count, or no fragments")   \
  X(kTooLarge, too_large, "message larger than receive.max_message_bytes")                              \
  X(kOutOfRange, out_of_range, "fragment beyond the message's size")                                    \
  X(kInconsistent, inconsistent, "fragment disagrees with its message's size or fragment count")       \
  X(kDuplicate, duplicate, "fragment received twice")                                                    \
  X(kOverlap, overlap, "fragments overlap or leave a gap")                                               \
  X(kTooManyFragments, too_many_fragments, "more fragments than the receive path keeps for a message") \
  X(kNoSlot, no_slot, "every reassembly slot busy with a partial message")

enum class WireStatus : uint8_t {
#define COOPDYN_WIRE_ENUM(e, key, text) e,
  COOPDYN_WIRE_STATUSES(COOPDYN_WIRE_ENUM)
#undef COOPDYN_WIRE_ENUM
};
constexpr int kWireStatuses = 0
#define COOPDYN_WIRE_COUNT(e, key, text) +1
    COOPDYN_WIRE_STATUSES(COOPDYN_WIRE_COUNT)
#undef COOPDYN_WIRE_COUNT
    ;
const char* wire_status_key(WireStatus s);
const char* wire_status_text(WireStatus s);
inline bool refused(WireStatus s) { return s != WireStatus::kComplete && s != WireStatus::kPending; }

// One datagram's header fields and where its channel and payload bytes are (inside the datagram).
struct Datagram {
  bool fragment = false;
  uint32_t seqno = 0;
  const char* channel = nullptr;  // NUL-terminated inside the datagram; nullptr in fragments but the first
  int channel_len = 0;
  const uint8_t* data = nullptr;
  int data_len = 0;
  // LC03 only
  uint32_t msg_size = 0, fragment_offset = 0;
  uint16_t fragment_no = 0, n_fragments = 0;
};

// kComplete (LC02), kPending (a well-formed LC03, not yet checked against a message) or a refusal.
WireStatus parse_datagram(const void* buf, size_t len, Datagram* out);

// A complete message: its channel (NUL-terminated) and payload, valid until the next call that
// produced it.
struct Message {
  const char* channel = nullptr;
  int channel_len = 0;
  const uint8_t* data = nullptr;
  int len = 0;
};

// An LCM udpm URL, udpm://GROUP:PORT?opt=value&..., by liblcm's rules: GROUP defaults to
// 239.255.76.67, PORT to 7667; of the options only recv_buf_size (SO_RCVBUF, bytes) concerns
// receiving. An empty URL is LCM_DEFAULT_URL's, else the default group and port.
struct UdpmUrl {
  std::string group = "239.255.76.67";
  uint16_t port = 7667;
  int recv_buf_size = 0;  // 0: not given
};
// false (with *why) when the URL is not udpm or its group, port or recv_buf_size is malformed.
bool parse_udpm_url(const std::string& url, UdpmUrl* out, std::string* why);

class Reassembler {
 public:
  // slots: partial messages kept at once (one per sender); max_message_bytes: the largest message;
  // timeout_ns: a partial message's life from its first fragment. Allocates everything here.
  Reassembler(int slots, int max_message_bytes, long long timeout_ns);

  // One datagram from sender (e.g. IPv4 address << 16 | port) received at now_ns: kComplete with
  // *out set, kPending, or the reason it was refused. Allocation-free.
  WireStatus add(const void* buf, size_t len, uint64_t sender, long long now_ns, Message* out);

  int max_fragments() const { return max_fragments_; }
  long long expired() const { return expired_; }      // partial messages dropped by the timeout
  long long abandoned() const { return abandoned_; }  // partial messages replaced by the sender's next
  int busy_slots() const;

 private:
  struct Slot {
    bool busy = false;
    uint64_t sender = 0;
    uint32_t seqno = 0, msg_size = 0, bytes = 0;
    uint16_t n_fragments = 0, received = 0;
    long long started_ns = 0;
    int channel_len = -1;  // -1 until fragment 0 arrives
    char channel[kMaxChannel + 1] = {};
    std::vector<uint8_t> data, seen;              // max_message_bytes; a bit per fragment number
    std::vector<uint32_t> offset, length;         // per fragment number
    std::vector<uint16_t> order;                  // scratch for the final coverage check
  };
  Slot* slot_for(const Datagram& d, uint64_t sender, long long now_ns, WireStatus* why);
  WireStatus finish(Slot& s, Message* out);
  std::vector<Slot> slots_;
  int max_bytes_, max_fragments_;
  long long timeout_ns_, expired_ = 0, abandoned_ = 0;
};

}  // namespace coopdyn::io::wire
