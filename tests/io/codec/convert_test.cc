// loop_stats_t as logs recorded before its last fields were appended (service/io/codec/stats_fields.def:
// each field's since, each older layout's fingerprint): such a message reads as the current one with
// those fields 0; identify() knows it.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "service/io/codec/codec.h"

using namespace coopdyn;

namespace {

io::StatsFrame some_stats() {
  io::StatsFrame s;
  s.utime = 1796331378501476;
  s.tick = 50;
  s.period_us = 1000;
  s.received = 9;
  s.accepted = 4;
  s.rejected = 5;
  s.rejected_by_reason[static_cast<int>(io::Reject::kBadMac)] = 3;
  s.rejected_by_reason[static_cast<int>(io::Reject::kReplayed)] = 2;
  s.inputs_malformed = 11;
  s.controls_received = 6;
  s.controls_accepted = 1;
  s.controls_rejected = 5;
  s.controls_unauthenticated = 2;
  s.controls_bad_mac = 2;
  s.controls_replayed = 1;
  s.outputs_dropped = 13;
  return s;
}

// the encoding of s with an older fingerprint, its last `dropped` bytes (appended int64 fields) cut
std::vector<uint8_t> as_before(const io::StatsFrame& s, uint64_t hash, int dropped) {
  io::StatsEncoder enc;
  std::vector<uint8_t> b(static_cast<size_t>(enc.max_size()));
  const int n = enc.encode(s, b.data(), static_cast<int>(b.size()));
  EXPECT_GT(n, dropped);
  b.resize(static_cast<size_t>(n - dropped));
  for (int i = 0; i < 8; ++i) b[static_cast<size_t>(i)] = static_cast<uint8_t>(hash >> (56 - 8 * i));
  return b;
}

}  // namespace

TEST(StatsLog, CurrentEncodingRoundTripsTheControlAndOutputCounts) {
  const io::StatsFrame s = some_stats();
  io::StatsEncoder enc;
  std::vector<uint8_t> b(static_cast<size_t>(enc.max_size()));
  const int n = enc.encode(s, b.data(), static_cast<int>(b.size()));
  io::StatsFrame back;
  ASSERT_TRUE(io::decode_stats(b.data(), n, &back));
  EXPECT_EQ(back.controls_received, 6);
  EXPECT_EQ(back.controls_accepted, 1);
  EXPECT_EQ(back.controls_rejected, 5);
  EXPECT_EQ(back.controls_unauthenticated, 2);
  EXPECT_EQ(back.controls_bad_mac, 2);
  EXPECT_EQ(back.controls_replayed, 1);
  EXPECT_EQ(back.rejected_by_reason[static_cast<int>(io::Reject::kBadMac)], 3);
  EXPECT_EQ(back.outputs_dropped, 13);
}

TEST(StatsLog, RecordedBeforeOutputsDroppedReadsItAsZero) {
  const io::StatsFrame s = some_stats();
  const auto b = as_before(s, 0x5f3a349535103d01ULL, (1 + 4) * 8);
  EXPECT_EQ(io::identify(b.data(), static_cast<int>(b.size())), io::MessageType::kLoopStats);
  io::StatsFrame back;
  ASSERT_TRUE(io::decode_stats(b.data(), static_cast<int>(b.size()), &back));
  EXPECT_EQ(back.tick, 50);
  EXPECT_EQ(back.inputs_malformed, 11);
  EXPECT_EQ(back.controls_received, 6);
  EXPECT_EQ(back.controls_replayed, 1);
  EXPECT_EQ(back.outputs_dropped, 0);
  // the same bytes under the current fingerprint are too short: refused, not misread
  auto cut = b;
  const uint64_t h = static_cast<uint64_t>(io::fingerprint(io::MessageType::kLoopStats));
  for (int i = 0; i < 8; ++i) cut[static_cast<size_t>(i)] = static_cast<uint8_t>(h >> (56 - 8 * i));
  EXPECT_FALSE(io::decode_stats(cut.data(), static_cast<int>(cut.size()), &back));
}

// A message as the daemon encoded it before outputs_dropped was appended (lcm-gen's encoder of that
// loop_stats_t.lcm; tick 50, commands 9 / 4 / 5, rejected replayed 2, inputs_malformed 11,
// controls_received 6, controls_replayed 1): its own fingerprint, not one this file made up.
TEST(StatsLog, AMessageOfTheTypeBeforeOutputsDroppedReads) {
  const std::string hex =
    "5f3a349535103d01000661c0fdb6e7640000000000000032408f40000000000000000000000000320000000000000000"
    "000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000"
    "000000000000000000000000000000000000000000000000000000000000000900000000000000040000000000000005"
    "000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000000"
    "000000000000000000000001000000097265706c61796564000000000000000002000000000000000000000000000000"
    "0b0000000000000006000000000000000000000000000000000000000000000000000000000000000000000000000000"
    "01";
  std::vector<uint8_t> b;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) b.push_back(static_cast<uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  ASSERT_EQ(b.size(), 289u);
  EXPECT_EQ(io::identify(b.data(), static_cast<int>(b.size())), io::MessageType::kLoopStats);
  io::StatsFrame back;
  ASSERT_TRUE(io::decode_stats(b.data(), static_cast<int>(b.size()), &back));
  EXPECT_EQ(back.utime, 1796331378501476);
  EXPECT_EQ(back.tick, 50);
  EXPECT_EQ(back.period_us, 1000);
  EXPECT_EQ(back.received, 9);
  EXPECT_EQ(back.accepted, 4);
  EXPECT_EQ(back.rejected, 5);
  EXPECT_EQ(back.rejected_by_reason[static_cast<int>(io::Reject::kReplayed)], 2);
  EXPECT_EQ(back.inputs_malformed, 11);
  EXPECT_EQ(back.controls_received, 6);
  EXPECT_EQ(back.controls_replayed, 1);
  EXPECT_EQ(back.outputs_dropped, 0);
}

TEST(StatsLog, RecordedBeforeTheControlCountsReadsThemAsZero) {
  const io::StatsFrame s = some_stats();
  const auto b = as_before(s, 0x48bcc81f9a071c5aULL, (7 + 4) * 8);
  EXPECT_EQ(io::identify(b.data(), static_cast<int>(b.size())), io::MessageType::kLoopStats);
  io::StatsFrame back;
  ASSERT_TRUE(io::decode_stats(b.data(), static_cast<int>(b.size()), &back));
  EXPECT_EQ(back.tick, 50);
  EXPECT_EQ(back.rejected, 5);
  EXPECT_EQ(back.rejected_by_reason[static_cast<int>(io::Reject::kReplayed)], 2);
  EXPECT_EQ(back.inputs_malformed, 11);
  EXPECT_EQ(back.controls_received, 0);
  EXPECT_EQ(back.controls_rejected, 0);
  EXPECT_EQ(back.controls_bad_mac, 0);
  EXPECT_EQ(back.outputs_dropped, 0);
}

TEST(StatsLog, RecordedBeforeInputsMalformedReadsItAndTheControlCountsAsZero) {
  const io::StatsFrame s = some_stats();
  const auto b = as_before(s, 0x7f11746fd02903b9ULL, (8 + 4) * 8);
  EXPECT_EQ(io::identify(b.data(), static_cast<int>(b.size())), io::MessageType::kLoopStats);
  io::StatsFrame back;
  ASSERT_TRUE(io::decode_stats(b.data(), static_cast<int>(b.size()), &back));
  EXPECT_EQ(back.accepted, 4);
  EXPECT_EQ(back.inputs_malformed, 0);
  EXPECT_EQ(back.controls_received, 0);
  EXPECT_EQ(back.outputs_dropped, 0);
  // the same bytes under the current fingerprint are too short: refused, not misread
  auto cut = b;
  const uint64_t h = static_cast<uint64_t>(io::fingerprint(io::MessageType::kLoopStats));
  for (int i = 0; i < 8; ++i) cut[static_cast<size_t>(i)] = static_cast<uint8_t>(h >> (56 - 8 * i));
  EXPECT_FALSE(io::decode_stats(cut.data(), static_cast<int>(cut.size()), &back));
}
