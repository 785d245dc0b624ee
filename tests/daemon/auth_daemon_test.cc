// Authenticated inputs (service/io/transport/auth.h) over real LCM: memq:// through the loop running in this
// process (a signed command applied; an unsigned, a bad-MAC, a tampered, a replayed and a
// wrong-channel one each rejected with its reason in loop_stats_t; a signed PAUSE applied, an
// unsigned RESUME rejected), and udpm:// against build/bin/coopdynd with `auth.key_file`, driven by
// `coopdyn send` and `coopdyn control` with and without --key-file. The key file's checks (mode,
// length, hex) by the library, the daemon and the clients.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <future>
#include <limits>
#include <memory>
#include <mutex>
#include <thread>

#include "service/io/transport/auth.h"
#include "service/io/transport/lcm_bus.h"
#include "service/runtime/service_loop.h"
#include "tests/support/child_process.h"
#include "tests/support/counting_allocator.h"
#include "tests/support/daemon_test_util.h"

using namespace coopdyn;
using namespace coopdyn::daemon_test;
using namespace std::chrono_literals;

namespace {

const char* kKeyHex = "00112233445566778899aabbccddeeff0123456789abcdef0f1e2d3c4b5a6978";

std::string write_file(const std::string& name, const std::string& text, mode_t mode) {
  const std::string p = tmp_path(name);
  std::remove(p.c_str());
  std::ofstream(p) << text;
  chmod(p.c_str(), mode);
  return p;
}

io::AuthKey test_key() { return io::parse_key(kKeyHex, "test key"); }

// The outputs and loop statistics a bus carries, decoded.
struct Sink {
  std::mutex mu;
  std::vector<io::DecodedOutput> outs;
  std::vector<io::StatsFrame> stats;
  void attach(io::LcmBus& bus) {
    bus.subscribe("COOPDYN_OUTPUT", [this](const void* d, int n, long long) {
      io::DecodedOutput o;
      if (!io::decode_output(d, n, &o)) return;
      std::lock_guard<std::mutex> lk(mu);
      outs.push_back(std::move(o));
    });
    bus.subscribe("COOPDYN_STATS", [this](const void* d, int n, long long) {
      io::StatsFrame s;
      if (!io::decode_stats(d, n, &s)) return;
      std::lock_guard<std::mutex> lk(mu);
      stats.push_back(s);
    });
  }
  template <class Pred>
  bool wait_output(Pred p, std::chrono::milliseconds limit) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < end) {
      {
        std::lock_guard<std::mutex> lk(mu);
        for (const auto& o : outs)
          if (p(o)) return true;
      }
      std::this_thread::sleep_for(5ms);
    }
    return false;
  }
  // the first loop_stats_t that satisfies p (false: none within limit)
  template <class Pred>
  bool wait_stats(Pred p, std::chrono::milliseconds limit, io::StatsFrame* got) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < end) {
      {
        std::lock_guard<std::mutex> lk(mu);
        for (const auto& s : stats)
          if (p(s)) {
            *got = s;
            return true;
          }
      }
      std::this_thread::sleep_for(10ms);
    }
    return false;
  }
  bool any_output(int64_t seq) {
    std::lock_guard<std::mutex> lk(mu);
    for (const auto& o : outs)
      if (o.input_seq == seq) return true;
    return false;
  }
};

int64_t by(const io::StatsFrame& s, io::Reject r) { return s.rejected_by_reason[static_cast<int>(r)]; }

}  // namespace

TEST(AuthKeyFile, GoodKeyReadsItsBytesWithOrWithoutNewline) {
  const io::AuthKey k = io::read_key_file(write_file("key_ok", std::string(kKeyHex) + "\n", 0600));
  EXPECT_EQ(k[0], 0x00);
  EXPECT_EQ(k[1], 0x11);
  EXPECT_EQ(k[15], 0xff);
  EXPECT_EQ(k[31], 0x78);
  EXPECT_EQ(io::read_key_file(write_file("key_ok2", kKeyHex, 0400)), k);
}

TEST(AuthKeyFile, GroupOrOtherAccessWrongLengthOrNotHexRefusedNamingTheFile) {
  for (const mode_t m : {0644, 0640, 0604, 0620, 0602}) {
    const std::string p = write_file("key_mode", kKeyHex, m);
    try {
      io::read_key_file(p);
      ADD_FAILURE() << "mode " << std::oct << m << " accepted";
    } catch (const io::KeyError& e) {
      const std::string w = e.what();
      EXPECT_NE(w.find(p), std::string::npos) << w;
      EXPECT_NE(w.find("group or others"), std::string::npos) << w;
      EXPECT_NE(w.find("chmod 600"), std::string::npos) << w;
    }
  }
  const std::pair<std::string, const char*> bad[] = {
      {std::string(kKeyHex).substr(0, 62), "expected 64 hex digits"},          // 31 bytes
      {std::string(kKeyHex) + "00", "expected 64 hex digits"},                 // 33 bytes
      {std::string(kKeyHex) + "\n\n", "expected 64 hex digits"},               // two newlines
      {"", "expected 64 hex digits"},                                          // empty
      {std::string(kKeyHex).replace(10, 1, "g"), "character 11 is not a hex digit"},
      {std::string(kKeyHex).replace(63, 1, " "), "character 64 is not a hex digit"},
  };
  for (const auto& [text, why] : bad) {
    const std::string p = write_file("key_bad", text, 0600);
    try {
      io::read_key_file(p);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const io::KeyError& e) {
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(io::read_key_file(tmp_path("key_missing_file")), io::KeyError);
}

// The MAC is the documented HMAC-SHA256: the RFC 4231 test case 2 vector through libsodium, and a
// signed command verified on its bytes; any changed byte, or another channel, fails.
TEST(AuthMac, SignedMessageVerifiesAndAnyChangeFails) {
  const io::AuthKey key = test_key();
  auto msg = io::encode_torque_command(1700000000000000, 7, {}, {1.0, 2.0});
  const size_t unsigned_len = msg.size();
  io::sign(msg, "COOPDYN_COMMAND", key, io::MessageType::kTorqueCommand);
  ASSERT_EQ(msg.size(), unsigned_len + io::kMacBytes);
  // the MAC is HMAC-SHA256(key, channel NUL bytes[0, len - 36)) computed independently here
  unsigned char expect[io::kMacBytes];
  std::vector<uint8_t> input = {'C', 'O', 'O', 'P', 'D', 'Y', 'N', '_', 'C', 'O', 'M', 'M', 'A', 'N', 'D', 0};
  input.insert(input.end(), msg.begin(), msg.begin() + static_cast<long>(unsigned_len - 4));
  crypto_auth_hmacsha256(expect, input.data(), input.size(), key.data());
  EXPECT_EQ(std::memcmp(expect, msg.data() + unsigned_len, io::kMacBytes), 0);
  const io::Verifier v(key, "COOPDYN_COMMAND", io::MessageType::kTorqueCommand);
  EXPECT_EQ(v.check(msg.data(), static_cast<int>(msg.size())), io::Reject::kNone);
  for (size_t i = 0; i < msg.size(); ++i) {
    auto m = msg;
    m[i] ^= 0x01;
    const io::Reject r = v.check(m.data(), static_cast<int>(m.size()));
    EXPECT_NE(r, io::Reject::kNone) << "byte " << i << " changed and still verified";
  }
  const io::Verifier other(key, "COOPDYN_COMMAND2", io::MessageType::kTorqueCommand);
  EXPECT_EQ(other.check(msg.data(), static_cast<int>(msg.size())), io::Reject::kBadMac);
  const auto plain = io::encode_torque_command(1700000000000000, 7, {}, {1.0, 2.0});
  EXPECT_EQ(v.check(plain.data(), static_cast<int>(plain.size())), io::Reject::kUnauthenticated);
  // RFC 4231 test case 2: key "Jefe", data "what do ya want for nothing?"
  unsigned char out[32];
  crypto_auth_hmacsha256_state st;
  crypto_auth_hmacsha256_init(&st, reinterpret_cast<const unsigned char*>("Jefe"), 4);
  crypto_auth_hmacsha256_update(&st, reinterpret_cast<const unsigned char*>("what do ya want for nothing?"), 28);
  crypto_auth_hmacsha256_final(&st, out);
  const unsigned char rfc[32] = {0x5b, 0xdc, 0xc1, 0x46, 0xbf, 0x60, 0x75, 0x4e, 0x6a, 0x04, 0x24, 0x26, 0x08, 0x95, 0x75, 0xc7,
                                 0x5a, 0x00, 0x3f, 0x08, 0x9d, 0x27, 0x39, 0x83, 0x9d, 0xec, 0x58, 0xb9, 0x64, 0xec, 0x38, 0x43};
  EXPECT_EQ(std::memcmp(out, rfc, 32), 0);
}

// The receive thread's side with authentication on allocates nothing once warm: MAC check, replay
// rule and decode of accepted, unsigned, bad-MAC and replayed commands (the counting heap).
TEST(AuthMac, OfferWithAuthAllocatesNothing) {
  if (!coopdyn::testing::kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  const System sys = load_scene(scene_path("two_puma_load"));
  runtime::ServiceConfig cfg;
  cfg.auth_key_file = write_file("key_alloc", kKeyHex, 0600);
  FakeBus bus;
  runtime::ServiceLoop loop(sys, cfg, bus);
  const Eigen::VectorXd tau = some_torque(sys, 5);
  std::vector<std::vector<uint8_t>> msgs;
  const int64_t t0 = runtime::realtime_us();
  for (int k = 0; k < 40; ++k) {
    auto b = io::encode_torque_command(t0 + k, k + 1, {}, stdvec(tau));
    if (k % 4 != 1) io::sign(b, cfg.command_channel, test_key(), io::MessageType::kTorqueCommand);  // 1: unsigned
    if (k % 4 == 2) b[40] ^= 1;                                                                      // 2: bad MAC
    msgs.push_back(b);
  }
  msgs.push_back(msgs[0]);  // replayed
  loop.commands().offer(msgs[0].data(), static_cast<int>(msgs[0].size()), 0);  // warm: first decode sizes the message
  long allocations = 0;
  for (size_t k = 1; k < msgs.size(); ++k) {
    coopdyn::testing::AllocationCounter c;
    loop.commands().offer(msgs[k].data(), static_cast<int>(msgs[k].size()), 0);
    allocations += c.count();
  }
  EXPECT_EQ(allocations, 0);
  const runtime::InputCounters& n = loop.commands().counters();
  EXPECT_EQ(n.accepted.load(), 20);  // k % 4 == 0 or 3
  EXPECT_EQ(n.by_reason[static_cast<int>(io::Reject::kUnauthenticated)].load(), 10);
  EXPECT_EQ(n.by_reason[static_cast<int>(io::Reject::kBadMac)].load(), 10);
  EXPECT_EQ(n.by_reason[static_cast<int>(io::Reject::kReplayed)].load(), 1);
}

// memq://: the loop runs in this process with auth on; each kind of forgery is rejected with its
// own reason, counted in loop_stats_t, and never applied; the signed commands are. Controls: an
// unsigned, a replayed and a forged one rejected, counted in loop_stats_t's controls_* fields.
TEST(AuthRoundTrip, MemqForgedUnsignedReplayedRejectedSignedApplied) {
  const System sys = load_scene(scene_path("two_puma_load"));
  runtime::ServiceConfig cfg;
  cfg.auth_key_file = write_file("key_memq", kKeyHex, 0600);
  cfg.stats_period_s = 0.1;
  io::LcmBus bus("memq://");
  runtime::ServiceLoop loop(sys, cfg, bus);
  bus.subscribe(cfg.command_channel, [&](const void* d, int n, long long t) { loop.commands().offer(d, n, t); });
  bus.subscribe(cfg.control_channel, [&](const void* d, int n, long long t) { loop.controls().offer(d, n, t); });
  Sink sink;
  sink.attach(bus);
  bus.start();
  std::atomic<bool> stop{false};
  std::thread th([&] { loop.run(stop); });
  const io::AuthKey key = test_key(), wrong = io::parse_key(std::string(64, '7'), "other key");
  const Eigen::VectorXd tau = some_torque(sys, 3);
  auto command = [&](int64_t seq, const io::AuthKey* k, const std::string& signed_for) {
    auto b = io::encode_torque_command(io::wall_us(), seq, {}, stdvec(tau));
    if (k) io::sign(b, signed_for, *k, io::MessageType::kTorqueCommand);
    return b;
  };
  auto send = [&](const std::vector<uint8_t>& b, const std::string& channel = "COOPDYN_COMMAND") {
    bus.publish(channel.c_str(), b.data(), static_cast<int>(b.size()));
    std::this_thread::sleep_for(3ms);
  };
  const auto first = command(1, &key, "COOPDYN_COMMAND");
  send(first);
  ASSERT_TRUE(sink.wait_output([](const io::DecodedOutput& o) { return o.input_seq == 1; }, kEventLimit));
  send(command(2, nullptr, ""));                         // unsigned
  send(command(3, &wrong, "COOPDYN_COMMAND"));           // another key
  send(command(4, &key, "COOPDYN_CONTROL"));             // signed for another channel
  auto tampered = command(5, &key, "COOPDYN_COMMAND");   // a torque changed after signing
  tampered[40] ^= 0x40;
  send(tampered);
  send(first);                                           // the accepted one's bytes again
  std::this_thread::sleep_for(5ms);
  send(command(6, &key, "COOPDYN_COMMAND"));
  ASSERT_TRUE(sink.wait_output([](const io::DecodedOutput& o) { return o.input_seq == 6; }, kEventLimit));
  // controls: a signed PAUSE applied, an unsigned RESUME rejected (the simulation stays paused)
  auto pause = io::encode_control(io::wall_us(), 100, io::ControlAction::kPause);
  io::sign(pause, "COOPDYN_CONTROL", key, io::MessageType::kControl);
  send(pause, "COOPDYN_CONTROL");
  ASSERT_TRUE(sink.wait_output([](const io::DecodedOutput& o) { return o.control_seq == 100 && o.paused == 1; }, kEventLimit));
  send(io::encode_control(io::wall_us(), 101, io::ControlAction::kResume), "COOPDYN_CONTROL");
  send(pause, "COOPDYN_CONTROL");  // replayed
  auto forged_resume = io::encode_control(io::wall_us(), 102, io::ControlAction::kResume);
  io::sign(forged_resume, "COOPDYN_CONTROL", wrong, io::MessageType::kControl);
  send(forged_resume, "COOPDYN_CONTROL");
  io::StatsFrame s;
  const bool counted = sink.wait_stats(
      [](const io::StatsFrame& x) { return x.received >= 7 && x.controls_received >= 4; }, kEventLimit, &s);
  // a tick after the one that counted them has taken (or refused) every control
  EXPECT_TRUE(counted && sink.wait_output([&](const io::DecodedOutput& o) { return o.tick > s.tick + 1; }, kEventLimit));
  stop = true;
  th.join();
  bus.stop();
  ASSERT_TRUE(counted);
  EXPECT_EQ(s.received, 7);
  EXPECT_EQ(s.accepted, 2);
  EXPECT_EQ(s.rejected, 5);
  EXPECT_EQ(by(s, io::Reject::kUnauthenticated), 1);
  EXPECT_EQ(by(s, io::Reject::kBadMac), 3);  // another key, another channel, tampered
  EXPECT_EQ(by(s, io::Reject::kReplayed), 1);
  for (int64_t seq = 2; seq <= 5; ++seq) EXPECT_FALSE(sink.any_output(seq)) << "seq " << seq << " was applied";
  EXPECT_TRUE(sink.any_output(6));
  const runtime::InputCounters& c = loop.controls().counters();
  EXPECT_EQ(c.accepted.load(), 1);
  EXPECT_EQ(c.by_reason[static_cast<int>(io::Reject::kUnauthenticated)].load(), 1);
  EXPECT_EQ(c.by_reason[static_cast<int>(io::Reject::kReplayed)].load(), 1);
  EXPECT_EQ(c.by_reason[static_cast<int>(io::Reject::kBadMac)].load(), 1);
  // the controls' rejections in loop_stats_t, apart from the commands'
  EXPECT_EQ(s.controls_received, 4);
  EXPECT_EQ(s.controls_accepted, 1);
  EXPECT_EQ(s.controls_rejected, 3);
  EXPECT_EQ(s.controls_unauthenticated, 1);
  EXPECT_EQ(s.controls_bad_mac, 1);
  EXPECT_EQ(s.controls_replayed, 1);
  std::lock_guard<std::mutex> lk(sink.mu);
  EXPECT_EQ(sink.outs.back().paused, 1) << "the unsigned RESUME was applied";
}

// Estimate mode: measured states are checked the same way (their own channel's name in the MAC).
TEST(AuthRoundTrip, MemqEstimateSignedStateAppliedUnsignedRejected) {
  const System sys = load_scene(scene_path("two_puma_load"));
  runtime::ServiceConfig cfg;
  cfg.mode = runtime::ServiceMode::kEstimate;
  cfg.auth_key_file = write_file("key_estimate", kKeyHex, 0600);
  io::LcmBus bus("memq://");
  runtime::ServiceLoop loop(sys, cfg, bus);
  bus.subscribe(cfg.state_channel, [&](const void* d, int n, long long t) { loop.states().offer(d, n, t); });
  Sink sink;
  sink.attach(bus);
  bus.start();
  std::atomic<bool> stop{false};
  std::thread th([&] { loop.run(stop); });
  auto state = [&](int64_t seq, bool sign, const std::string& signed_for) {
    auto b = io::encode_measured_state(io::wall_us(), seq, {}, stdvec(sys.q0), {}, stdvec(sys.v0), stdvec(some_torque(sys, 2)));
    if (sign) io::sign(b, signed_for, test_key(), io::MessageType::kMeasuredState);
    bus.publish("COOPDYN_STATE", b.data(), static_cast<int>(b.size()));
    std::this_thread::sleep_for(3ms);
  };
  state(1, false, "");
  state(2, true, "COOPDYN_COMMAND");  // signed for another channel
  state(3, true, "COOPDYN_STATE");
  const bool got = sink.wait_output([](const io::DecodedOutput& o) { return o.input_seq == 3; }, kEventLimit);
  stop = true;
  th.join();
  bus.stop();
  ASSERT_TRUE(got);
  EXPECT_FALSE(sink.any_output(1));
  EXPECT_FALSE(sink.any_output(2));
  const runtime::InputCounters& c = loop.states().counters();
  EXPECT_EQ(c.accepted.load(), 1);
  EXPECT_EQ(c.by_reason[static_cast<int>(io::Reject::kUnauthenticated)].load(), 1);
  EXPECT_EQ(c.by_reason[static_cast<int>(io::Reject::kBadMac)].load(), 1);
}

// udpm:// against coopdynd with auth.key_file: `coopdyn send --key-file` applied, `coopdyn send`
// without it rejected as unauthenticated (exit 4, the reason printed), `coopdyn track --key-file`
// applied, `coopdyn control --key-file pause` acknowledged, without the key no acknowledgement.
TEST(AuthDaemon, UdpmSignedClientsAppliedUnsignedRejected) {
  const std::string url = private_udpm_url(3);
  auto bus = try_bus(url);
  if (!bus) GTEST_SKIP() << "LCM udpm unavailable (no multicast route? 'ip route add 224.0.0.0/4 dev lo')";
  const std::string key = write_file("key_udpm", std::string(kKeyHex) + "\n", 0600);
  const std::string config = write_file("auth_config.yaml", "auth:\n  key_file: " + key + "\n", 0600);
  Sink sink;
  sink.attach(*bus);
  bus->start();
  Child d({COOPDYND_PATH, "--scene", scene_path("two_puma_load"), "--config", config, "--lcm-url", url, "--duration",
           kDaemonDuration},
          "auth_daemon");
  ASSERT_TRUE(sink.wait_output([](const io::DecodedOutput&) { return true; }, kEventLimit)) << slurp(d.err);
  auto send = [&](bool with_key, const std::string& name, const char* seq) {
    std::vector<std::string> argv = {COOPDYN_PATH, "send", "--scene", scene_path("two_puma_load"), "--lcm-url", url,
                                     "--rate", "100", "--duration", "0.3", "--torque", "arm1.q1:constant:0.1", "--seq", seq};
    if (with_key) argv.insert(argv.end(), {"--key-file", key});
    Child c(argv, name);
    const int rc = c.wait();
    return std::make_pair(rc, slurp(c.out) + slurp(c.err));
  };
  auto [rc_signed, out_signed] = send(true, "send_signed", "1");
  EXPECT_EQ(rc_signed, 0) << out_signed;
  auto [rc_plain, out_plain] = send(false, "send_plain", "101");  // seqs of its own: none of them used
  EXPECT_EQ(rc_plain, 4) << out_plain;
  EXPECT_NE(out_plain.find("the daemon used 0 of 31 commands"), std::string::npos) << out_plain;
  EXPECT_NE(out_plain.find("unauthenticated (no MAC) 31"), std::string::npos) << out_plain;
  // the reference controller signs its commands too: the daemon applies them (its seqs start at the
  // wall clock in microseconds, above any seq sent here before)
  Child track({COOPDYN_PATH, "track", "--scene", scene_path("two_puma_load"), "--lcm-url", url, "--duration", "0.5",
               "--key-file", key},
              "track_signed");
  EXPECT_EQ(track.wait(), 0) << slurp(track.err);
  EXPECT_TRUE(sink.wait_output(
      [](const io::DecodedOutput& o) { return o.input == static_cast<int>(io::Input::kCommand) && o.input_seq > 1000000000; },
      kEventLimit))
      << "no output under a command of coopdyn track --key-file";
  auto control = [&](bool with_key, const std::string& name) {
    std::vector<std::string> argv = {COOPDYN_PATH, "control", "--action", "pause", "--lcm-url", url};
    // signed: wait as long as any event (a loaded machine); unsigned: the default 2 s for an
    // acknowledgement that must never come
    if (with_key) argv.insert(argv.end(), {"--key-file", key, "--timeout", std::to_string(std::chrono::duration_cast<std::chrono::seconds>(kEventLimit).count())});
    Child c(argv, name);
    const int rc = c.wait();
    return std::make_pair(rc, slurp(c.out) + slurp(c.err));
  };
  auto [rc_c1, out_c1] = control(false, "control_plain");
  EXPECT_EQ(rc_c1, 1) << out_c1;  // rejected: no acknowledgement
  EXPECT_NE(out_c1.find("no acknowledgement"), std::string::npos) << out_c1;
  auto [rc_c2, out_c2] = control(true, "control_signed");
  EXPECT_EQ(rc_c2, 0) << out_c2;
  EXPECT_NE(out_c2.find("ok; the simulation is paused"), std::string::npos) << out_c2;
  // the unsigned control, rejected by the receive process before its ring, is in loop_stats_t
  io::StatsFrame st;
  EXPECT_TRUE(sink.wait_stats(
      [](const io::StatsFrame& x) { return x.controls_unauthenticated == 1 && x.controls_accepted == 1; }, kEventLimit,
      &st))
      << "the unsigned control is not counted in loop_stats_t";
  EXPECT_EQ(st.controls_received, 2);
  EXPECT_EQ(st.controls_rejected, 1);
  d.signal(SIGTERM);
  EXPECT_EQ(d.wait(), 0) << slurp(d.err);
  bus->stop();
  const std::string log = slurp(d.err);
  EXPECT_NE(log.find("authentication on"), std::string::npos) << log;
  EXPECT_NE(log.find("unauthenticated (no MAC)"), std::string::npos) << log;
  const std::string summary = slurp(d.out);
  EXPECT_NE(summary.find("rejected 31,"), std::string::npos) << summary;  // the unsigned send's, no other
}

// The daemon and the clients refuse a key file others can read, naming it, before anything starts.
TEST(AuthDaemon, KeyFileReadableByOthersRefusedAtStart) {
  const std::string key = write_file("key_0644", kKeyHex, 0644);
  const std::string config = write_file("auth_config_0644.yaml", "auth:\n  key_file: " + key + "\n", 0600);
  const Result d = run_command({COOPDYND_PATH, "--scene", scene_path("two_puma_load"), "--config", config, "--duration", "1"},
                              "auth_daemon_0644");
  EXPECT_EQ(d.rc, 2) << d.err;
  EXPECT_NE(d.err.find("auth.key_file: " + key + ": the key file is readable or writable by group or others (mode 0644)"),
            std::string::npos)
      << d.err;
  const std::string short_key = write_file("key_short", "abcd\n", 0600);
  for (const auto& [k, why] : {std::make_pair(key, "mode 0644"), std::make_pair(short_key, "expected 64 hex digits")}) {
    for (const char* cmd : {"send", "control"}) {
      std::vector<std::string> argv = {COOPDYN_PATH, cmd, "--lcm-url", "memq://", "--key-file", k};
      if (std::string(cmd) == "send")
        argv.insert(argv.end(), {"--scene", scene_path("two_puma_load"), "--torque", "arm1.q1:constant:0.1"});
      else argv.insert(argv.end(), {"--action", "pause"});
      const Result c = run_command(argv, std::string("auth_client_") + cmd);
      EXPECT_EQ(c.rc, 2) << cmd << ": " << c.err;
      EXPECT_NE(c.err.find(k), std::string::npos) << c.err;
      EXPECT_NE(c.err.find(why), std::string::npos) << c.err;
    }
  }
}

namespace {

// coopdynd with authentication on a private udpm URL (and the config lines extra), started once its
// outputs arrive at sink.
std::unique_ptr<Child> start_auth_daemon(const std::string& url, const std::string& key, const std::string& tag,
                                         Sink& sink, const std::string& extra = "") {
  const std::string config = write_file(tag + "_config.yaml", "auth:\n  key_file: " + key + "\n" + extra, 0600);
  auto d = std::make_unique<Child>(std::vector<std::string>{COOPDYND_PATH, "--scene", scene_path("two_puma_load"),
                                                            "--config", config, "--lcm-url", url, "--duration",
                                                            kDaemonDuration},
                                   tag);
  {
    std::lock_guard<std::mutex> lk(sink.mu);
    sink.outs.clear();
    sink.stats.clear();
  }
  EXPECT_TRUE(sink.wait_output([](const io::DecodedOutput&) { return true; }, kEventLimit)) << slurp(d->err);
  return d;
}

std::vector<uint8_t> signed_command(const System& sys, int64_t utime, int64_t seq) {
  auto b = io::encode_torque_command(utime, seq, {}, stdvec(some_torque(sys, 3, 0.1)));
  io::sign(b, "COOPDYN_COMMAND", test_key(), io::MessageType::kTorqueCommand);
  return b;
}

}  // namespace

// A signed command stamped 10 s ahead and one stamped INT64_MAX, sent first, are refused by the
// daemon (future_utime) and lock nothing out: the valid signed commands sent after them through
// the real receive process are applied (at least 99 of 100; none refused as replayed).
TEST(AuthDaemon, FutureStampedSignedCommandsLockNothingOut) {
  const std::string url = private_udpm_url(6);
  auto bus = try_bus(url);
  if (!bus) GTEST_SKIP() << "LCM udpm unavailable (no multicast route? 'ip route add 224.0.0.0/4 dev lo')";
  const System sys = load_scene(scene_path("two_puma_load"));
  const std::string key = write_file("key_future", std::string(kKeyHex) + "\n", 0600);
  Sink sink;
  sink.attach(*bus);
  bus->start();
  auto d = start_auth_daemon(url, key, "auth_future", sink);
  auto send = [&](const std::vector<uint8_t>& b) {
    bus->publish("COOPDYN_COMMAND", b.data(), static_cast<int>(b.size()));
    std::this_thread::sleep_for(2ms);
  };
  send(signed_command(sys, io::wall_us() + 10000000, 1));
  send(signed_command(sys, std::numeric_limits<int64_t>::max(), 2));
  const int kValid = 100;
  for (int k = 0; k < kValid; ++k) send(signed_command(sys, io::wall_us(), 3 + k));
  io::StatsFrame s;
  const bool counted =
      sink.wait_stats([&](const io::StatsFrame& x) { return x.received >= kValid + 2; }, kEventLimit, &s);
  d->signal(SIGTERM);
  EXPECT_EQ(d->wait(), 0) << slurp(d->err);
  bus->stop();
  ASSERT_TRUE(counted) << "the valid commands never reached the daemon's inbox (refused as replayed?)";
  EXPECT_EQ(by(s, io::Reject::kFuture), 2);
  EXPECT_EQ(by(s, io::Reject::kReplayed), 0);
  EXPECT_GE(s.accepted, 99) << "of " << kValid << " valid signed commands after the future-stamped ones";
}

// No replay across restarts: 50 signed commands recorded while one daemon runs, resent byte for
// byte to a daemon started after it stopped, are all refused as replayed (stamped before its
// start) and counted, whatever max_input_age_ms allows (60 s here: the staleness rule alone would
// accept them); a new signed command is applied.
TEST(AuthDaemon, RecordedCommandsRefusedAfterARestart) {
  const std::string url = private_udpm_url(6);
  auto bus = try_bus(url);
  if (!bus) GTEST_SKIP() << "LCM udpm unavailable (no multicast route? 'ip route add 224.0.0.0/4 dev lo')";
  const System sys = load_scene(scene_path("two_puma_load"));
  const std::string key = write_file("key_restart", std::string(kKeyHex) + "\n", 0600);
  Sink sink;
  sink.attach(*bus);
  bus->start();
  const int kRecorded = 50;
  std::vector<std::vector<uint8_t>> recorded;
  auto send = [&](const std::vector<uint8_t>& b) {
    bus->publish("COOPDYN_COMMAND", b.data(), static_cast<int>(b.size()));
    std::this_thread::sleep_for(2ms);
  };
  {
    auto first = start_auth_daemon(url, key, "auth_restart1", sink, kPatientInputs);
    for (int k = 0; k < kRecorded; ++k) {
      recorded.push_back(signed_command(sys, io::wall_us(), 1 + k));
      send(recorded.back());
    }
    io::StatsFrame s;
    EXPECT_TRUE(sink.wait_stats([&](const io::StatsFrame& x) { return x.received >= kRecorded; }, kEventLimit, &s));
    EXPECT_GE(s.accepted, 1);  // the recording is of commands the first daemon applied
    first->signal(SIGTERM);
    EXPECT_EQ(first->wait(), 0) << slurp(first->err);
  }
  auto second = start_auth_daemon(url, key, "auth_restart2", sink, kPatientInputs);
  for (const auto& b : recorded) send(b);
  send(signed_command(sys, io::wall_us(), 1000));
  io::StatsFrame s;
  const bool counted =
      sink.wait_stats([&](const io::StatsFrame& x) { return x.received >= kRecorded + 1 && x.accepted >= 1; },
                      kEventLimit, &s);
  second->signal(SIGTERM);
  EXPECT_EQ(second->wait(), 0) << slurp(second->err);
  bus->stop();
  ASSERT_TRUE(counted) << "the new command was not applied after the recorded ones";
  EXPECT_EQ(s.accepted, 1) << "a recorded command of the first run was applied by the second";
  EXPECT_EQ(by(s, io::Reject::kReplayed), kRecorded);
  EXPECT_TRUE(sink.any_output(1000));
  for (int64_t seq = 1; seq <= kRecorded; ++seq)
    EXPECT_FALSE(sink.any_output(seq)) << "recorded seq " << seq << " applied";
}

namespace {

// read_key_file's verdict on path: "" (a key read) or its message
std::string key_verdict(const std::string& path) {
  try {
    io::read_key_file(path);
    return "";
  } catch (const io::KeyError& e) {
    return e.what();
  }
}

}  // namespace

// The key-file matrix: a regular file and a symlink chain to one (a Kubernetes secret volume's
// layout: key -> ..data/key -> ..2026_12_07/key) read; a FIFO (no writer: a read would wait
// forever), a directory, a symlink to a file others can read, a long, a short key and a file
// others can read each refused at once, the message naming the file and what is wrong (the length
// the file has, not the length read).
TEST(AuthKeyFile, MatrixOfKindsAndSizesEachReadOrRefusedNamingTheFile) {
  const std::string dir = tmp_path("keydir");
  std::system(("rm -rf '" + dir + "'").c_str());
  ASSERT_EQ(mkdir(dir.c_str(), 0700), 0);
  auto file = [&](const std::string& name, const std::string& text, mode_t mode) {
    const std::string p = dir + "/" + name;
    std::ofstream(p) << text;
    chmod(p.c_str(), mode);
    return p;
  };
  const std::string regular = file("regular", std::string(kKeyHex) + "\n", 0600);
  EXPECT_EQ(key_verdict(regular), "");
  // a secret volume: the file is a symlink into ..data, itself a symlink to the timestamped folder
  ASSERT_EQ(mkdir((dir + "/..2026_12_07").c_str(), 0700), 0);
  file("..2026_12_07/key", kKeyHex, 0400);
  ASSERT_EQ(symlink("..2026_12_07", (dir + "/..data").c_str()), 0);
  ASSERT_EQ(symlink("..data/key", (dir + "/key").c_str()), 0);
  EXPECT_EQ(key_verdict(dir + "/key"), "");
  const std::string fifo = dir + "/fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const std::string open_key = file("open_key", kKeyHex, 0644);
  const std::string link_to_open = dir + "/link_to_open";
  ASSERT_EQ(symlink(open_key.c_str(), link_to_open.c_str()), 0);
  const std::pair<std::string, std::string> refused[] = {
      {fifo, fifo + ": the key file is a FIFO (named pipe), not a regular file"},
      {dir + "/..2026_12_07", dir + "/..2026_12_07: the key file is a directory, not a regular file"},
      {link_to_open, link_to_open + ": the key file is readable or writable by group or others (mode 0644)"},
      {open_key, open_key + ": the key file is readable or writable by group or others (mode 0644)"},
      {file("long", std::string(kKeyHex) + std::string(36, 'a'), 0600), "found 100 characters"},
      {file("huge", std::string(10000, 'a'), 0600), "found 10000 bytes"},
      {file("short", "abcd\n", 0600), "expected 64 hex digits (32 bytes) and at most a newline, found 4 characters"},
      {dir + "/missing", dir + "/missing: cannot open the key file: No such file or directory"},
  };
  for (const auto& [path, why] : refused) {
    // a refusal that waited (the FIFO without a writer) would never come back: read on another thread
    auto verdict = std::async(std::launch::async, key_verdict, path);
    ASSERT_EQ(verdict.wait_for(kEventLimit), std::future_status::ready) << path << ": read_key_file blocks";
    const std::string w = verdict.get();
    EXPECT_NE(w.find(path), std::string::npos) << w;
    EXPECT_NE(w.find(why), std::string::npos) << "expected '" << why << "' in: " << w;
  }
  std::system(("rm -rf '" + dir + "'").c_str());
}

// coopdynd resolves a relative auth.key_file against its config file's folder (not its working
// directory), and refuses a FIFO as the key file at start (exit 2, naming the file), as it
// refuses any other bad key file.
TEST(AuthDaemon, RelativeKeyFileIsTheConfigFoldersAndAFifoIsRefusedAtStart) {
  const std::string dir = tmp_path("keycfg");
  std::system(("rm -rf '" + dir + "'").c_str());
  ASSERT_EQ(mkdir(dir.c_str(), 0700), 0);
  {
    std::ofstream(dir + "/rel.key") << kKeyHex;
    chmod((dir + "/rel.key").c_str(), 0600);
    std::ofstream(dir + "/rel.yaml") << "auth:\n  key_file: rel.key\n";
  }
  const Result ok = run_command({COOPDYND_PATH, "--scene", scene_path("two_puma_load"), "--config", dir + "/rel.yaml",
                                 "--lcm-url", "memq://", "--duration", "0.2"},
                                "auth_relative");
  EXPECT_EQ(ok.rc, 0) << ok.err;
  EXPECT_NE(ok.err.find("authentication on"), std::string::npos) << ok.err;
  EXPECT_NE(ok.err.find(dir + "/rel.key"), std::string::npos) << ok.err;
  ASSERT_EQ(mkfifo((dir + "/fifo.key").c_str(), 0600), 0);
  std::ofstream(dir + "/fifo.yaml") << "auth:\n  key_file: fifo.key\n";
  const Result fifo = run_command({COOPDYND_PATH, "--scene", scene_path("two_puma_load"), "--config",
                                   dir + "/fifo.yaml", "--lcm-url", "memq://", "--duration", "0.2"},
                                  "auth_fifo");
  EXPECT_EQ(fifo.rc, 2) << fifo.err;
  EXPECT_NE(fifo.err.find("auth.key_file: " + dir + "/fifo.key: the key file is a FIFO"), std::string::npos)
      << fifo.err;
  std::system(("rm -rf '" + dir + "'").c_str());
}
