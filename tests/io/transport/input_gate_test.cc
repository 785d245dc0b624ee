// The receive path's gate (service/io/transport/input_gate.h) on its own, shared by the receive process and
// the in-loop receiver: datagrams sent over loopback to a plain UDP socket, read in one batch and
// admitted or refused one by one, each refusal counted with its reason.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <string>
#include <vector>

#include "service/io/transport/auth.h"
#include "service/io/codec/codec.h"
#include "service/io/transport/input_gate.h"
#include "tests/support/raw_udp.h"

using namespace coopdyn;
using namespace coopdyn::daemon_test;

namespace {

// A UDP socket on 127.0.0.1 and a sender to it.
struct Loopback {
  int rx = -1, tx = -1;
  sockaddr_in addr{};
  Loopback() {
    rx = socket(AF_INET, SOCK_DGRAM, 0);
    tx = socket(AF_INET, SOCK_DGRAM, 0);
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bind(rx, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    socklen_t l = sizeof addr;
    getsockname(rx, reinterpret_cast<sockaddr*>(&addr), &l);
  }
  ~Loopback() {
    close(rx);
    close(tx);
  }
  void send(const std::vector<uint8_t>& b) const {
    sendto(tx, b.data(), b.size(), 0, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
  }
  // the next batch, once a datagram waits
  int read(io::InputGate& gate) const {
    pollfd p{rx, POLLIN, 0};
    poll(&p, 1, 2000);
    return gate.read_batch(rx);
  }
};

std::vector<uint8_t> lc02(const std::string& channel, const std::vector<uint8_t>& payload) {
  std::vector<uint8_t> b;
  put32(b, 0x4c433032);
  put32(b, 7);
  b.insert(b.end(), channel.begin(), channel.end());
  b.push_back(0);
  b.insert(b.end(), payload.begin(), payload.end());
  return b;
}

std::vector<io::InputChannel> state_and_control() {
  return io::input_channels({"COOPDYN_STATE", "COOPDYN_CONTROL"},
                            {io::fingerprint(io::MessageType::kMeasuredState), io::fingerprint(io::MessageType::kControl)});
}

// sends each datagram and admits it alone: the channel index or -1
int admit_one(const Loopback& lo, io::InputGate& gate, const std::vector<uint8_t>& d, io::wire::Message* m) {
  lo.send(d);
  EXPECT_EQ(lo.read(gate), 1);
  return gate.admit(0, m);
}

}  // namespace

// Authentication off: a state and a control admitted on their channels with their bytes; liblcm's
// crash fragment, junk after the fingerprint, another type's fingerprint on the state channel and a
// state on another channel refused, each counted where it belongs; a message in two fragments
// admitted once whole.
TEST(InputGate, AdmitsInputsOfItsChannelsAndCountsEveryRefusalByReason) {
  io::RxCounters c;
  io::InputGate gate(state_and_control(), 65536, &c);
  Loopback lo;
  io::wire::Message m;
  const auto state = io::encode_measured_state(123, 1, {"a"}, {0.5}, {"a"}, {0.1}, {0.2});
  ASSERT_EQ(admit_one(lo, gate, lc02("COOPDYN_STATE", state), &m), 0);
  EXPECT_EQ(std::vector<uint8_t>(m.data, m.data + m.len), state);
  const auto control = io::encode_control(123, 2, io::ControlAction::kPause);
  EXPECT_EQ(admit_one(lo, gate, lc02("COOPDYN_CONTROL", control), &m), 1);
  EXPECT_EQ(admit_one(lo, gate, lc03(1, 100, 0xFFFFFF00u, 0, 2, "COOPDYN_STATE", 324), &m), -1);
  EXPECT_EQ(c.malformed_by[static_cast<int>(io::wire::WireStatus::kOutOfRange)].load(), 1u);
  std::vector<uint8_t> junk(state.begin(), state.begin() + 8);  // the fingerprint, then garbage
  junk.insert(junk.end(), 40, 0xee);
  EXPECT_EQ(admit_one(lo, gate, lc02("COOPDYN_STATE", junk), &m), -1);
  EXPECT_EQ(c.rejected_by[0][static_cast<int>(io::Reject::kDecode)].load(), 1u);
  EXPECT_EQ(admit_one(lo, gate, lc02("COOPDYN_STATE", control), &m), -1);  // a control's fingerprint
  EXPECT_EQ(admit_one(lo, gate, lc02("OTHER", state), &m), -1);
  EXPECT_EQ(c.filtered.load(), 2u);
  // the state in two fragments (LC03: size, offset, number, count; the channel in the first)
  const uint32_t half = static_cast<uint32_t>(state.size() / 2);
  auto fragment = [&](uint16_t no) {
    std::vector<uint8_t> b;
    put32(b, 0x4c433033);
    put32(b, 9);
    put32(b, static_cast<uint32_t>(state.size()));
    put32(b, no == 0 ? 0 : half);
    put16(b, no);
    put16(b, 2);
    if (no == 0) b.insert(b.end(), {'C', 'O', 'O', 'P', 'D', 'Y', 'N', '_', 'S', 'T', 'A', 'T', 'E', 0});
    b.insert(b.end(), state.begin() + (no == 0 ? 0 : half), no == 0 ? state.begin() + half : state.end());
    return b;
  };
  EXPECT_EQ(admit_one(lo, gate, fragment(0), &m), -1);  // kept
  ASSERT_EQ(admit_one(lo, gate, fragment(1), &m), 0);
  EXPECT_EQ(std::vector<uint8_t>(m.data, m.data + m.len), state);
  EXPECT_EQ(c.received.load(), 6u);  // complete messages: all but the crash fragment and the first half
}

// Authentication on: a signed state admitted; unsigned, signed with another key, and the signed one
// again each refused with its reason.
TEST(InputGate, WithAKeyUnsignedBadMacAndReplayedRefusedByReason) {
  io::RxCounters c;
  io::InputGate gate(state_and_control(), 65536, &c);
  const io::AuthKey key = io::parse_key(std::string(64, 'c'), "key"), other = io::parse_key(std::string(64, 'd'), "other");
  gate.set_auth_key(key);
  Loopback lo;
  io::wire::Message m;
  auto state = [&](int64_t utime, const io::AuthKey* k) {
    auto b = io::encode_measured_state(utime, utime, {"a"}, {0.5}, {"a"}, {0.1}, {0.2});
    if (k) io::sign(b, "COOPDYN_STATE", *k, io::MessageType::kMeasuredState);
    return lc02("COOPDYN_STATE", b);
  };
  const auto signed_state = state(1000, &key);
  EXPECT_EQ(admit_one(lo, gate, signed_state, &m), 0);
  EXPECT_EQ(admit_one(lo, gate, state(2000, nullptr), &m), -1);
  EXPECT_EQ(admit_one(lo, gate, state(3000, &other), &m), -1);
  EXPECT_EQ(admit_one(lo, gate, signed_state, &m), -1);
  EXPECT_EQ(admit_one(lo, gate, state(4000, &key), &m), 0);
  const auto& r = c.rejected_by[0];
  EXPECT_EQ(r[static_cast<int>(io::Reject::kUnauthenticated)].load(), 1u);
  EXPECT_EQ(r[static_cast<int>(io::Reject::kBadMac)].load(), 1u);
  EXPECT_EQ(r[static_cast<int>(io::Reject::kReplayed)].load(), 1u);
}

namespace {

// The daemon's side of the replay window (what service/daemon/receive.cc does with the receive path's counters).
struct Window : io::ReceiverCounters {
  explicit Window(io::RxCounters* c) { counters_ = c; }
};

}  // namespace

// A signed state stamped in the future (10 s ahead, or INT64_MAX) passes the gate, but only the
// daemon moves the window, when it accepts: the state it refuses (future_utime) locks nothing out,
// and every later signed state is let through; once the daemon accepts one, its utime and older
// ones are refused as replayed.
TEST(InputGate, OnlyWhatTheDaemonAcceptsMovesTheReplayWindow) {
  io::RxCounters c;
  io::InputGate gate(state_and_control(), 65536, &c);
  Window daemon(&c);
  const io::AuthKey key = io::parse_key(std::string(64, 'c'), "key");
  gate.set_auth_key(key);
  Loopback lo;
  io::wire::Message m;
  auto state = [&](int64_t utime) {
    auto b = io::encode_measured_state(utime, 1, {"a"}, {0.5}, {"a"}, {0.1}, {0.2});
    io::sign(b, "COOPDYN_STATE", key, io::MessageType::kMeasuredState);
    return lc02("COOPDYN_STATE", b);
  };
  const int64_t now = 1700000000000000;
  EXPECT_EQ(admit_one(lo, gate, state(now + 10000000), &m), 0);  // the daemon refuses it: future_utime
  EXPECT_EQ(admit_one(lo, gate, state(INT64_MAX), &m), 0);        // and this one
  int admitted = 0;
  for (int k = 1; k <= 100; ++k) admitted += admit_one(lo, gate, state(now + k), &m) == 0;
  EXPECT_EQ(admitted, 100) << "a refused future utime locked the channel out";
  daemon.note_accepted(0, now + 100);  // the daemon accepted the last one
  EXPECT_EQ(admit_one(lo, gate, state(now + 100), &m), -1);
  EXPECT_EQ(admit_one(lo, gate, state(now + 50), &m), -1);
  EXPECT_EQ(admit_one(lo, gate, state(now + 101), &m), 0);
  daemon.note_accepted(0, now + 20);  // never moves back
  EXPECT_EQ(daemon.window(0), now + 100);
  EXPECT_EQ(c.rejected_by[0][static_cast<int>(io::Reject::kReplayed)].load(), 2u);
}

// The window opened at the daemon's start: a signed state stamped before it (a recording of an
// earlier run) is refused as replayed, on every channel; one stamped after it is let through.
TEST(InputGate, NothingStampedBeforeTheWindowOpenedIsLetThrough) {
  io::RxCounters c;
  io::InputGate gate(state_and_control(), 65536, &c);
  Window daemon(&c);
  const io::AuthKey key = io::parse_key(std::string(64, 'c'), "key");
  gate.set_auth_key(key);
  const int64_t start = 1700000000000000;
  daemon.open_window(start);
  Loopback lo;
  io::wire::Message m;
  auto state = [&](int64_t utime) {
    auto b = io::encode_measured_state(utime, 1, {"a"}, {0.5}, {"a"}, {0.1}, {0.2});
    io::sign(b, "COOPDYN_STATE", key, io::MessageType::kMeasuredState);
    return lc02("COOPDYN_STATE", b);
  };
  auto control = [&](int64_t utime) {
    auto b = io::encode_control(utime, 1, io::ControlAction::kPause);
    io::sign(b, "COOPDYN_CONTROL", key, io::MessageType::kControl);
    return lc02("COOPDYN_CONTROL", b);
  };
  for (const int64_t u : {start - 92000, start - 1, start}) {
    EXPECT_EQ(admit_one(lo, gate, state(u), &m), -1) << u;
    EXPECT_EQ(admit_one(lo, gate, control(u), &m), -1) << u;
  }
  EXPECT_EQ(c.rejected_by[0][static_cast<int>(io::Reject::kReplayed)].load(), 3u);
  EXPECT_EQ(c.rejected_by[1][static_cast<int>(io::Reject::kReplayed)].load(), 3u);
  EXPECT_EQ(admit_one(lo, gate, state(start + 1), &m), 0);
  EXPECT_EQ(admit_one(lo, gate, control(start + 1), &m), 1);
}
