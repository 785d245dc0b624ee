// The LCM wire parser and reassembler (service/io/transport/lcm_wire.h) on datagrams built from the format
// (fragmented as liblcm 1.3.1 does; tests/daemon receives liblcm's own datagrams through udpm),
// every refusal checked with its reason.
#include "service/io/transport/lcm_wire.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

using namespace coopdyn::io::wire;

namespace {

void put32(std::vector<uint8_t>& b, uint32_t x) {
  for (int s = 24; s >= 0; s -= 8) b.push_back(static_cast<uint8_t>(x >> s));
}
void put16(std::vector<uint8_t>& b, uint16_t x) {
  b.push_back(static_cast<uint8_t>(x >> 8));
  b.push_back(static_cast<uint8_t>(x));
}
std::vector<uint8_t> lc02(uint32_t seq, const std::string& channel, const std::vector<uint8_t>& payload) {
  std::vector<uint8_t> b;
  put32(b, kShortMagic);
  put32(b, seq);
  b.insert(b.end(), channel.begin(), channel.end());
  b.push_back(0);
  b.insert(b.end(), payload.begin(), payload.end());
  return b;
}
std::vector<uint8_t> lc03(uint32_t seq, uint32_t size, uint32_t offset, uint16_t no, uint16_t count, const std::string& channel,
                          const uint8_t* data, size_t n) {
  std::vector<uint8_t> b;
  put32(b, kFragmentMagic);
  put32(b, seq);
  put32(b, size);
  put32(b, offset);
  put16(b, no);
  put16(b, count);
  if (no == 0) b.insert(b.end(), channel.begin(), channel.end()), b.push_back(0);
  b.insert(b.end(), data, data + n);
  return b;
}
// liblcm's fragmentation of a message: fragment 0 carries the channel and fragment - channel - 1
// payload bytes, the others `fragment` bytes each
std::vector<std::vector<uint8_t>> fragments(uint32_t seq, const std::string& channel, const std::vector<uint8_t>& msg,
                                            size_t fragment) {
  std::vector<std::pair<size_t, size_t>> parts;
  size_t at = 0, first = fragment - channel.size() - 1;
  parts.push_back({0, std::min(first, msg.size())});
  at = parts.back().second;
  while (at < msg.size()) {
    parts.push_back({at, std::min(fragment, msg.size() - at)});
    at += parts.back().second;
  }
  std::vector<std::vector<uint8_t>> out;
  for (size_t k = 0; k < parts.size(); ++k)
    out.push_back(lc03(seq, static_cast<uint32_t>(msg.size()), static_cast<uint32_t>(parts[k].first), static_cast<uint16_t>(k),
                       static_cast<uint16_t>(parts.size()), channel, msg.data() + parts[k].first, parts[k].second));
  return out;
}
std::vector<uint8_t> pattern(size_t n, uint8_t salt) {
  std::vector<uint8_t> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = static_cast<uint8_t>(i * 31 + salt + (i >> 8));
  return v;
}
WireStatus add(Reassembler& r, const std::vector<uint8_t>& d, Message* m, uint64_t sender = 1, long long now = 0) {
  return r.add(d.data(), d.size(), sender, now, m);
}

}  // namespace

TEST(LcmWire, ShortMessageGivesChannelAndPayload) {
  Reassembler r(2, 1000, 1000000);
  Message m;
  const auto payload = pattern(100, 3);
  const auto datagram = lc02(7, "COOPDYN_COMMAND", payload);  // the message points into it
  ASSERT_EQ(add(r, datagram, &m), WireStatus::kComplete);
  EXPECT_EQ(std::string(m.channel), "COOPDYN_COMMAND");
  EXPECT_EQ(m.channel_len, 15);
  ASSERT_EQ(m.len, 100);
  EXPECT_EQ(std::vector<uint8_t>(m.data, m.data + m.len), payload);
  // an empty payload is a message too (the decoders refuse it)
  EXPECT_EQ(add(r, lc02(8, "X", {}), &m), WireStatus::kComplete);
  EXPECT_EQ(m.len, 0);
}

TEST(LcmWire, MalformedHeadersAreRefusedWithTheirReason) {
  Reassembler r(2, 1000, 1000000);
  Message m;
  auto good = lc02(1, "CH", pattern(10, 1));
  for (size_t n = 0; n < 8; ++n) EXPECT_EQ(r.add(good.data(), n, 1, 0, &m), WireStatus::kTruncated) << n;
  EXPECT_EQ(r.add(good.data(), 8, 1, 0, &m), WireStatus::kBadChannel);   // no channel at all
  EXPECT_EQ(r.add(good.data(), 10, 1, 0, &m), WireStatus::kBadChannel);  // channel without its NUL
  auto bad = good;
  bad[3] = 0x31;
  EXPECT_EQ(add(r, bad, &m), WireStatus::kBadMagic);
  EXPECT_EQ(add(r, lc02(1, "", {1, 2}), &m), WireStatus::kBadChannel);
  EXPECT_EQ(add(r, lc02(1, std::string(64, 'c'), {1, 2}), &m), WireStatus::kBadChannel);
  EXPECT_EQ(add(r, lc02(1, std::string(63, 'c'), {1, 2}), &m), WireStatus::kComplete);
  EXPECT_EQ(add(r, lc02(1, "CH", pattern(1001, 0)), &m), WireStatus::kTooLarge);
  const uint8_t d[4] = {1, 2, 3, 4};
  auto frag = lc03(1, 8, 0, 0, 2, "CH", d, 4);
  EXPECT_EQ(r.add(frag.data(), 19, 1, 0, &m), WireStatus::kTruncated);
  EXPECT_EQ(add(r, lc03(1, 8, 0, 2, 2, "CH", d, 4), &m), WireStatus::kBadFragmentHeader);  // number not below count
  EXPECT_EQ(add(r, lc03(1, 8, 0, 0, 0, "CH", d, 4), &m), WireStatus::kBadFragmentHeader);  // no fragments
  EXPECT_EQ(add(r, lc03(1, 0, 0, 1, 2, "", d, 4), &m), WireStatus::kBadFragmentHeader);    // size 0
  EXPECT_EQ(add(r, lc03(1, 8, 4, 0, 2, "CH", d, 4), &m), WireStatus::kOutOfRange);         // first fragment not at 0
  EXPECT_EQ(add(r, lc03(1, 8, 5, 1, 2, "", d, 4), &m), WireStatus::kOutOfRange);           // past the message
  EXPECT_EQ(add(r, lc03(1, 8, 4, 1, 2, "", d, 0), &m), WireStatus::kOutOfRange);           // empty
  EXPECT_EQ(add(r, lc03(1, 1001, 4, 1, 2, "", d, 4), &m), WireStatus::kTooLarge);
  EXPECT_EQ(add(r, lc03(1, 1000, 4, 1, 1000, "", d, 4), &m), WireStatus::kTooManyFragments);
  EXPECT_EQ(r.busy_slots(), 0) << "nothing refused holds a slot";
}

// The fragment that crashes liblcm 1.3.1 (offset 0xFFFFFF00, 324 bytes): refused, nothing written.
TEST(LcmWire, LiblcmCrashFragmentIsRefused) {
  Reassembler r(2, 65536, 1000000);
  Message m;
  const std::vector<uint8_t> junk(300, 0xab);
  EXPECT_EQ(add(r, lc03(1, 100, 0xFFFFFF00u, 0, 2, "COOPDYN_COMMAND", junk.data(), junk.size() - 16), &m),
            WireStatus::kOutOfRange);
  EXPECT_EQ(add(r, lc03(1, 100, 0xFFFFFF00u, 1, 2, "", junk.data(), junk.size()), &m), WireStatus::kOutOfRange);
  EXPECT_EQ(add(r, lc03(1, 0xFFFFFFFFu, 0xFFFFFF00u, 1, 2, "", junk.data(), junk.size()), &m), WireStatus::kOutOfRange);
  EXPECT_EQ(add(r, lc03(1, 0xFFFFFFFFu, 0xFFFF0000u, 1, 2, "", junk.data(), junk.size()), &m), WireStatus::kTooLarge);
  EXPECT_EQ(r.busy_slots(), 0);
}

TEST(LcmWire, FragmentsReassembleInAnyOrderPerSender) {
  Reassembler r(2, 200000, 1000000);
  const auto a = pattern(150000, 1), b = pattern(70000, 2);
  const auto fa = fragments(5, "COOPDYN_STATE", a, 65423), fb = fragments(9, "COOPDYN_COMMAND", b, 65423);
  ASSERT_EQ(fa.size(), 3u);
  ASSERT_EQ(fb.size(), 2u);
  Message m;
  // interleaved, from two senders, out of order
  EXPECT_EQ(add(r, fa[2], &m, 10), WireStatus::kPending);
  EXPECT_EQ(add(r, fb[1], &m, 20), WireStatus::kPending);
  EXPECT_EQ(add(r, fa[0], &m, 10), WireStatus::kPending);
  EXPECT_EQ(add(r, fa[0], &m, 10), WireStatus::kDuplicate);
  ASSERT_EQ(add(r, fb[0], &m, 20), WireStatus::kComplete);
  EXPECT_EQ(std::string(m.channel), "COOPDYN_COMMAND");
  EXPECT_EQ(std::vector<uint8_t>(m.data, m.data + m.len), b);
  ASSERT_EQ(add(r, fa[1], &m, 10), WireStatus::kComplete);
  EXPECT_EQ(std::string(m.channel), "COOPDYN_STATE");
  EXPECT_EQ(std::vector<uint8_t>(m.data, m.data + m.len), a);
  EXPECT_EQ(r.busy_slots(), 0);
}

TEST(LcmWire, InconsistentOverlappingAndGappedFragmentsAreRefused) {
  Reassembler r(2, 10000, 1000000);
  Message m;
  const auto d = pattern(100, 7);
  // size or count changed within a message
  ASSERT_EQ(add(r, lc03(1, 100, 0, 0, 2, "CH", d.data(), 50), &m), WireStatus::kPending);
  EXPECT_EQ(add(r, lc03(1, 101, 50, 1, 2, "", d.data(), 50), &m), WireStatus::kInconsistent);
  EXPECT_EQ(add(r, lc03(1, 100, 50, 1, 3, "", d.data(), 50), &m), WireStatus::kInconsistent);
  // more bytes than the message: an overlap, the partial message dropped
  EXPECT_EQ(add(r, lc03(1, 100, 40, 1, 2, "", d.data(), 60), &m), WireStatus::kOverlap);
  EXPECT_EQ(r.busy_slots(), 0);
  // the right byte count but a gap and an overlap (0..50, 40..90 of 100 with a third at 90)
  ASSERT_EQ(add(r, lc03(2, 100, 0, 0, 3, "CH", d.data(), 50), &m), WireStatus::kPending);
  ASSERT_EQ(add(r, lc03(2, 100, 40, 1, 3, "", d.data(), 40), &m), WireStatus::kPending);
  EXPECT_EQ(add(r, lc03(2, 100, 90, 2, 3, "", d.data(), 10), &m), WireStatus::kOverlap);
  EXPECT_EQ(r.busy_slots(), 0);
  // and then the same message well formed
  ASSERT_EQ(add(r, lc03(3, 100, 0, 0, 2, "CH", d.data(), 50), &m), WireStatus::kPending);
  ASSERT_EQ(add(r, lc03(3, 100, 50, 1, 2, "", d.data() + 50, 50), &m), WireStatus::kComplete);
  EXPECT_EQ(std::vector<uint8_t>(m.data, m.data + m.len), d);
}

TEST(LcmWire, SlotsAreBoundedExpireAndAreReplacedBySendersNextMessage) {
  Reassembler r(2, 10000, 1000);  // partial messages live 1000 ns
  Message m;
  const auto d = pattern(100, 9);
  ASSERT_EQ(add(r, lc03(1, 100, 0, 0, 2, "CH", d.data(), 50), &m, 1, 0), WireStatus::kPending);
  ASSERT_EQ(add(r, lc03(1, 100, 0, 0, 2, "CH", d.data(), 50), &m, 2, 0), WireStatus::kPending);
  EXPECT_EQ(add(r, lc03(1, 100, 0, 0, 2, "CH", d.data(), 50), &m, 3, 500), WireStatus::kNoSlot);
  // sender 1's next message replaces its partial one
  ASSERT_EQ(add(r, lc03(2, 100, 0, 0, 2, "CH", d.data(), 50), &m, 1, 600), WireStatus::kPending);
  EXPECT_EQ(r.abandoned(), 1);
  // sender 2's partial message has expired by 1500 ns: sender 3 gets its slot
  ASSERT_EQ(add(r, lc03(1, 100, 0, 0, 2, "CH", d.data(), 50), &m, 3, 1500), WireStatus::kPending);
  EXPECT_EQ(r.expired(), 1);
  // sender 2's second half now starts a new partial message that never completes alone
  EXPECT_EQ(add(r, lc03(1, 100, 50, 1, 2, "", d.data() + 50, 50), &m, 2, 1500), WireStatus::kNoSlot);
  // sender 1 (started at 600) completes in time
  EXPECT_EQ(add(r, lc03(2, 100, 50, 1, 2, "", d.data() + 50, 50), &m, 1, 1500), WireStatus::kComplete);
  EXPECT_EQ(std::vector<uint8_t>(m.data, m.data + m.len), d);
}

TEST(LcmWire, EveryStatusHasAKeyAndAText) {
  for (int s = 0; s < kWireStatuses; ++s) {
    EXPECT_STRNE(wire_status_key(static_cast<WireStatus>(s)), "?");
    EXPECT_STRNE(wire_status_text(static_cast<WireStatus>(s)), "?");
  }
}

TEST(LcmWire, UdpmUrlsParseByLiblcmsRules) {
  UdpmUrl u;
  std::string why;
  ASSERT_TRUE(parse_udpm_url("udpm://239.255.76.99:7701?ttl=0&recv_buf_size=2097152", &u, &why)) << why;
  EXPECT_EQ(u.group, "239.255.76.99");
  EXPECT_EQ(u.port, 7701);
  EXPECT_EQ(u.recv_buf_size, 2097152);
  ASSERT_TRUE(parse_udpm_url("udpm://", &u, &why)) << why;
  EXPECT_EQ(u.group, "239.255.76.67");
  EXPECT_EQ(u.port, 7667);
  ASSERT_TRUE(parse_udpm_url("udpm://239.1.2.3?ttl=1", &u, &why)) << why;
  EXPECT_EQ(u.group, "239.1.2.3");
  EXPECT_EQ(u.port, 7667);
  for (const char* bad : {"memq://", "udpm://10.0.0.1:7667", "udpm://239.1.2.3:0", "udpm://239.1.2.3:70000",
                          "udpm://239.1.2.3:76x", "udpm://host:7667", "udpm://239.1.2.3:7667?recv_buf_size=-1"}) {
    EXPECT_FALSE(parse_udpm_url(bad, &u, &why)) << bad;
    EXPECT_FALSE(why.empty()) << bad;
  }
}
