// The in-loop receive path (service/io/transport/rx_in_loop.h, realtime.receive_in_loop) over real udpm on a
// private port (ttl=0): the loop's thread reads the input socket itself, sleeping in ppoll on it or
// polling it. Valid states arrive interleaved with hostile datagrams (liblcm 1.3.1's crash fragment,
// junk after the state fingerprint, random fragments, non-LCM junk): every valid state is taken,
// every hostile datagram is refused and counted by its reason, the loop allocates nothing. With
// authentication on, unsigned, bad-MAC and replayed states are refused by the gate, each counted
// with its reason, and the signed ones applied.
#include "tests/support/counting_allocator.h"

#include <gtest/gtest.h>

#include <sys/stat.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <mutex>
#include <random>
#include <thread>

#include "service/io/transport/auth.h"
#include "service/io/codec/codec.h"
#include "service/io/transport/lcm_bus.h"
#include "service/io/transport/rx_in_loop.h"
#include "service/runtime/realtime.h"
#include "service/runtime/service_loop.h"
#include "service/runtime/socket_arrivals.h"
#include "tests/support/child_process.h"
#include "tests/support/daemon_test_util.h"
#include "tests/support/raw_udp.h"

using namespace coopdyn;
using namespace coopdyn::daemon_test;
using coopdyn::testing::AllocationCounter;
using coopdyn::testing::kCountingAvailable;

namespace {

// What the daemon's source in this mode offers to (service/daemon/receive.cc offer_input, without its log
// counters): controls to the control inbox, states to the state inbox; an accepted one moves its
// channel's replay window (channel 1 the control channel).
runtime::SocketArrivals<std::function<void(const void*, int, long long)>> socket_source(io::InLoopReceiver& rx,
                                                                                      runtime::ServiceLoop& loop) {
  return {rx, [&loop, &rx](const void* d, int n, long long t) {
            const bool control = io::identify(d, n) == io::MessageType::kControl;
            const runtime::Offer r = control ? loop.controls().offer(d, n, t) : loop.states().offer(d, n, t);
            if (r == runtime::Offer::kAccepted) rx.note_accepted(control ? 1 : 0, io::raw_utime(d, n));
          }};
}

std::string key_file(const std::string& name, const std::string& hex) {
  const std::string p = tmp_path(name);
  std::remove(p.c_str());
  std::ofstream(p) << hex;
  chmod(p.c_str(), 0600);
  return p;
}

runtime::ServiceConfig on_arrival(bool busy_poll) {
  runtime::ServiceConfig cfg;
  cfg.mode = runtime::ServiceMode::kEstimate;
  cfg.trigger = runtime::Trigger::kArrival;
  cfg.realtime.busy_poll = busy_poll;
  cfg.realtime.receive_in_loop = true;
  cfg.stats_period_s = 0.05;
  cfg.watchdog_ms = 20;
  return cfg;
}

std::unique_ptr<io::InLoopReceiver> in_loop_receiver(const std::string& url, const runtime::ServiceConfig& cfg) {
  try {
    return std::make_unique<io::InLoopReceiver>(
        url, std::vector<std::string>{cfg.state_channel, cfg.control_channel},
        std::vector<int64_t>{io::fingerprint(io::MessageType::kMeasuredState), io::fingerprint(io::MessageType::kControl)},
        cfg.receive_max_bytes, 0);
  } catch (const std::exception&) {
    return nullptr;
  }
}

// Junk that carries measured_state_t's fingerprint, so that it passes the socket filter: LC02 on
// the state channel, the 8-byte hash, then garbage.
std::vector<uint8_t> fingerprinted_junk(std::mt19937& rng, const std::string& channel) {
  std::vector<uint8_t> b;
  put32(b, 0x4c433032);
  put32(b, rng());
  b.insert(b.end(), channel.begin(), channel.end());
  b.push_back(0);
  const uint64_t h = static_cast<uint64_t>(io::fingerprint(io::MessageType::kMeasuredState));
  for (int s = 56; s >= 0; s -= 8) b.push_back(static_cast<uint8_t>(h >> s));
  const size_t n = 8 + rng() % 600;
  for (size_t i = 0; i < n; ++i) b.push_back(static_cast<uint8_t>(rng()));
  return b;
}

void hostile_and_valid_states_in_the_loop(bool busy_poll) {
  const System sys = load_scene(scene_path("two_puma_load"));
  runtime::ServiceConfig cfg = on_arrival(busy_poll);
  cfg.watchdog_ms = 1000;  // the last state stays fresh: no heartbeat replaces its output in the fake bus
  const std::string url = private_udpm_url(busy_poll ? 5 : 6, "239.255.76.98");
  std::unique_ptr<io::LcmBus> out = try_bus(url);
  auto rx = in_loop_receiver(url, cfg);
  if (!out || !rx) GTEST_SKIP() << "LCM udpm unavailable (no multicast route?)";
  EXPECT_EQ(rx->filter_state(), 1);
  SharedFakeBus bus;
  runtime::ServiceLoop loop(sys, cfg, bus);
  auto source = socket_source(*rx, loop);
  loop.take_arrivals_from(&source);
  RawUdp raw(url);
  std::mt19937 rng(27);
  Eigen::VectorXd v = sys.v0;
  for (int i = 0; i < v.size(); ++i) v[i] = 0.05 * std::sin(i + 1.0);
  v = closing_velocity(sys, sys.q0, v);
  const Eigen::VectorXd tau = some_torque(sys, 3);
  std::atomic<bool> stop{false};
  std::atomic<long> allocations{-1};
  std::thread loop_thread([&] {
    AllocationCounter c;
    loop.run(stop);
    allocations = c.count();
  });
  int crafted = 0, junk = 0, random_fragments = 0, not_lcm = 0;
  // each state and its hostile datagrams once the loop has taken the one before (on a loaded
  // machine a burst would overflow the socket's default buffer while the loop waits for a CPU)
  int taken = 0;
  for (int k = 1; k <= 200; ++k) {
    if (!coopdyn::testing::wait_until([&] { return loop.states().counters().received.load() >= k - 1; })) break;
    taken = k;
    const auto b = io::encode_measured_state(runtime::realtime_us(), k, sys.model.q_names, stdvec(sys.q0), sys.model.v_names,
                                             stdvec(v * (1 + k % 7)), stdvec(tau));
    out->publish(cfg.state_channel.c_str(), b.data(), static_cast<int>(b.size()));
    // between two states: the crash fragment, fingerprinted junk, a random fragment, a non-LCM datagram
    crafted += raw.send(lc03(1, 100, 0xFFFFFF00u, 0, 2, cfg.state_channel, 324));
    junk += raw.send(fingerprinted_junk(rng, cfg.state_channel));
    random_fragments += raw.send(lc03(rng(), 200 + rng() % 100000, rng() % 1000, 0, static_cast<uint16_t>(1 + rng() % 4),
                                      k % 2 ? cfg.state_channel : "X", 40 + rng() % 1000));
    std::vector<uint8_t> noise(20 + rng() % 200);
    for (auto& x : noise) x = static_cast<uint8_t>(rng());
    not_lcm += raw.send(noise);
  }
  EXPECT_EQ(taken, 200) << "state " << taken - 1 << " never reached the inbox";
  // the last state's output is out, and every datagram after it refused and counted
  EXPECT_TRUE(coopdyn::testing::wait_until([&] {
    return bus.last_input_seq() == 200 && rx->rejected(0, io::Reject::kDecode) >= junk &&
           rx->malformed(io::wire::WireStatus::kOutOfRange) >= crafted && rx->socket_drops() >= not_lcm;
  }));
  stop = true;
  loop_thread.join();
  EXPECT_EQ(allocations.load(), 0);
  const runtime::InputCounters& c = loop.states().counters();
  EXPECT_EQ(c.accepted.load(), 200) << "of " << c.received.load() << " received (udpm on loopback)";
  EXPECT_EQ(c.received.load(), 200) << "nothing hostile reached the inbox";
  EXPECT_EQ(crafted, 200);
  // the crash fragment: beyond its message's size (as some of the random fragments are)
  EXPECT_GE(rx->malformed(io::wire::WireStatus::kOutOfRange), crafted);
  EXPECT_EQ(rx->rejected(0, io::Reject::kDecode), junk) << "junk after the fingerprint: its fields do not walk";
  // a random fragment is refused (counted as malformed), kept until it expires, or filtered (fragment 0 of channel X)
  EXPECT_GE(rx->malformed() + rx->filtered(), crafted);
  EXPECT_LE(rx->malformed() + rx->filtered(), crafted + random_fragments);
  EXPECT_GE(rx->socket_drops(), not_lcm) << "non-LCM datagrams: dropped by the kernel's filter";
  // one output per tick; the last (no heartbeat after it: the last state stays fresh) equals the offline
  // evaluation of what it carries
  EXPECT_EQ(bus.count("COOPDYN_OUTPUT"), loop.ticks());
  const io::DecodedOutput o = bus.last_output();
  EXPECT_EQ(o.input_seq, 200);
  expect_matches_offline(sys, o);
  runtime::Event e;
  while (loop.events().pop(&e)) {
  }
}

}  // namespace

TEST(RxInLoop, HostileDatagramsRefusedAndCountedValidStatesTakenSleeping) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  hostile_and_valid_states_in_the_loop(false);
}

TEST(RxInLoop, HostileDatagramsRefusedAndCountedValidStatesTakenPolling) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  hostile_and_valid_states_in_the_loop(true);
}

// Authentication on (the gate holds the key, as the receive process does; the inbox verifies
// again): an unsigned state, one signed with another key and a signed one sent again are each
// refused by the gate with its reason; the signed ones are applied.
TEST(RxInLoop, WithAuthenticationUnsignedBadMacAndReplayedRefusedByReason) {
  const System sys = load_scene(scene_path("two_puma_load"));
  runtime::ServiceConfig cfg = on_arrival(false);
  const std::string key_hex(64, 'a'), other_hex(64, '7');
  cfg.auth_key_file = key_file("rx_in_loop_key", key_hex);
  const io::AuthKey key = io::parse_key(key_hex, "test key"), other = io::parse_key(other_hex, "other key");
  const std::string url = private_udpm_url(4, "239.255.76.98");
  std::unique_ptr<io::LcmBus> out = try_bus(url);
  auto rx = in_loop_receiver(url, cfg);
  if (!out || !rx) GTEST_SKIP() << "LCM udpm unavailable (no multicast route?)";
  rx->set_auth_key(key);
  SharedFakeBus bus;
  runtime::ServiceLoop loop(sys, cfg, bus);
  auto source = socket_source(*rx, loop);
  loop.take_arrivals_from(&source);
  std::atomic<bool> stop{false};
  std::thread loop_thread([&] { loop.run(stop); });
  std::vector<uint8_t> first;
  auto state = [&](int64_t seq, const io::AuthKey* k) {
    auto b = io::encode_measured_state(io::wall_us(), seq, {}, stdvec(sys.q0), {}, stdvec(sys.v0), stdvec(some_torque(sys, 2)));
    if (k) io::sign(b, cfg.state_channel, *k, io::MessageType::kMeasuredState);
    return b;
  };
  auto send = [&](const std::vector<uint8_t>& b) {
    out->publish(cfg.state_channel.c_str(), b.data(), static_cast<int>(b.size()));
    std::this_thread::sleep_for(std::chrono::milliseconds(3));
  };
  first = state(1, &key);
  send(first);
  send(state(2, nullptr));
  send(state(3, &other));
  send(first);  // replayed
  send(state(4, &key));
  // the last signed state's output: everything before it has been through the gate
  EXPECT_TRUE(coopdyn::testing::wait_until([&] { return bus.last_input_seq() == 4; }));
  stop = true;
  loop_thread.join();
  EXPECT_EQ(rx->rejected(0, io::Reject::kUnauthenticated), 1);
  EXPECT_EQ(rx->rejected(0, io::Reject::kBadMac), 1);
  EXPECT_EQ(rx->rejected(0, io::Reject::kReplayed), 1);
  const runtime::InputCounters& c = loop.states().counters();
  EXPECT_EQ(c.received.load(), 2) << "only the signed states reach the inbox";
  EXPECT_EQ(c.accepted.load(), 2);
  EXPECT_EQ(bus.last_output().input_seq, 4);
  runtime::Event e;
  while (loop.events().pop(&e)) {
  }
}

// A flood in this mode, authentication on: one thread sends, as fast as it goes, junk after the
// state fingerprint, well-formed unsigned states, states signed with another key and a signed
// state's bytes again, in turn, while 300 signed states arrive at 100 Hz; the loop's thread reads
// all of it. Asserted: nothing of the junk reaches the inbox (every state the inbox receives is
// accepted, and the outputs carry only signed states' seqs), each kind is refused by the gate with
// its reason, the loop allocates nothing. The share of signed states applied depends on the machine
// (the junk and the loop share two CPUs here) and is printed, not judged.
TEST(RxInLoop, FloodWithAuthenticationRefusedByReasonNothingOfItApplied) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  const System sys = load_scene(scene_path("two_puma_load"));
  runtime::ServiceConfig cfg = on_arrival(false);
  cfg.watchdog_ms = 1000;
  const std::string key_hex(64, 'b');
  cfg.auth_key_file = key_file("rx_in_loop_flood_key", key_hex);
  const io::AuthKey key = io::parse_key(key_hex, "test key"), other = io::parse_key(std::string(64, '3'), "other key");
  const std::string url = private_udpm_url(3, "239.255.76.98");
  std::unique_ptr<io::LcmBus> out = try_bus(url);
  auto rx = in_loop_receiver(url, cfg);
  if (!out || !rx) GTEST_SKIP() << "LCM udpm unavailable (no multicast route?)";
  rx->set_auth_key(key);
  SharedFakeBus bus;
  runtime::ServiceLoop loop(sys, cfg, bus);
  auto source = socket_source(*rx, loop);
  loop.take_arrivals_from(&source);
  auto state = [&](int64_t seq, const io::AuthKey* k, int64_t ahead_us = 0) {
    auto b = io::encode_measured_state(io::wall_us() + ahead_us, seq, {}, stdvec(sys.q0), {}, stdvec(sys.v0),
                                       stdvec(some_torque(sys, 2)));
    if (k) io::sign(b, cfg.state_channel, *k, io::MessageType::kMeasuredState);
    return b;
  };
  // LC02 framing of a payload on the state channel (what liblcm sends)
  auto lc02 = [&](const std::vector<uint8_t>& payload, uint32_t seqno) {
    std::vector<uint8_t> b;
    put32(b, 0x4c433032);
    put32(b, seqno);
    b.insert(b.end(), cfg.state_channel.begin(), cfg.state_channel.end());
    b.push_back(0);
    b.insert(b.end(), payload.begin(), payload.end());
    return b;
  };
  std::mt19937 rng(5);
  const std::vector<uint8_t> junk = fingerprinted_junk(rng, cfg.state_channel), unsigned_state = lc02(state(100000, nullptr), 1),
                             forged = lc02(state(100001, &other, 60'000'000), 2);  // newer than any signed one: its MAC is checked
  std::atomic<bool> stop{false}, done{false};
  std::atomic<long> allocations{-1};
  std::thread loop_thread([&] {
    AllocationCounter c;
    loop.run(stop);
    allocations = c.count();
  });
  std::atomic<long> sent{0};
  std::vector<uint8_t> replayed;  // a signed state's bytes, once one went out
  std::mutex mu;
  std::thread flood([&] {
    RawUdp raw(url);
    for (long k = 0; !done.load(); ++k) {
      const int kind = static_cast<int>(k % 4);
      if (kind == 0) raw.send(junk);
      else if (kind == 1) raw.send(unsigned_state);
      else if (kind == 2) raw.send(forged);
      else {
        std::lock_guard<std::mutex> lk(mu);
        if (!replayed.empty()) raw.send(replayed);
      }
      sent.fetch_add(1, std::memory_order_relaxed);
    }
  });
  auto next = std::chrono::steady_clock::now();
  for (int seq = 1; seq <= 300; ++seq) {
    const auto b = state(seq, &key);
    out->publish(cfg.state_channel.c_str(), b.data(), static_cast<int>(b.size()));
    {
      std::lock_guard<std::mutex> lk(mu);
      replayed = lc02(b, 3);
    }
    next += std::chrono::milliseconds(10);
    std::this_thread::sleep_until(next);
  }
  done = true;
  flood.join();
  // after the flood, signed states until one is applied (the socket may still hold the flood, and a
  // full socket drops what arrives): the loop has read what the flood left
  int64_t last_sent = 300;
  EXPECT_TRUE(coopdyn::testing::wait_until([&] {
    if (bus.last_input_seq() > 300) return true;
    const auto b = state(++last_sent, &key);
    out->publish(cfg.state_channel.c_str(), b.data(), static_cast<int>(b.size()));
    return false;
  }, coopdyn::testing::kEventLimit, std::chrono::milliseconds(100)));
  stop = true;
  loop_thread.join();
  EXPECT_EQ(allocations.load(), 0);
  const runtime::InputCounters& c = loop.states().counters();
  EXPECT_EQ(c.received.load(), c.accepted.load()) << "only signed states reach the inbox";
  EXPECT_GT(rx->rejected(0, io::Reject::kDecode), 0);
  EXPECT_GT(rx->rejected(0, io::Reject::kUnauthenticated), 0);
  EXPECT_GT(rx->rejected(0, io::Reject::kBadMac), 0);
  EXPECT_GT(rx->rejected(0, io::Reject::kReplayed), 0);
  const io::DecodedOutput o = bus.last_output();
  EXPECT_GT(o.input_seq, 300) << "a signed state after the flood is the last applied";
  EXPECT_LE(o.input_seq, last_sent) << "an output carries a junk state's seq";
  std::printf("[flood in loop] %ld junk datagrams (%.0f/s) against 300 signed states at 100 Hz: %lld applied (with the "
              "%lld sent after the flood until one was); refused malformed %lld, unsigned %lld, bad MAC %lld, replayed %lld; "
              "socket drops %lld\n",
              sent.load(), sent.load() / 3.0, static_cast<long long>(c.accepted.load()),
              static_cast<long long>(last_sent - 300), rx->rejected(0, io::Reject::kDecode),
              rx->rejected(0, io::Reject::kUnauthenticated), rx->rejected(0, io::Reject::kBadMac),
              rx->rejected(0, io::Reject::kReplayed), rx->socket_drops());
  runtime::Event e;
  while (loop.events().pop(&e)) {
  }
}
