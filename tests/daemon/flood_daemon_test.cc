// Flood: build/bin/coopdynd with its inputs on a private udpm URL of their own (lcm_url_in, ttl=0,
// loopback only; outputs on another port) receives 300 valid torque commands, at least 10 ms apart,
// interleaved with junk datagrams on the command channel from one sender thread as fast as it goes
// (each valid command waits until 20 more junk datagrams went out, so the flood is at least 20x the
// valid traffic whatever the machine's speed). The figures are printed ([flood] ...); without
// authentication the loss and the loop's rate under the flood depend on the machine and are measured
// by bench/flood.sh, not judged here; with authentication, >= 99 % of the signed commands must be
// applied where the receive path ran at SCHED_FIFO throughout (realtime.receive_priority, as root),
// and the share is only printed elsewhere. Every output's torque must be a valid command's (no junk applied).
//
// Asserted in every flood: every datagram sent to the inputs, junk or valid, is counted exactly once
// where it went (reached a check; refused or not queued by the receive process; dropped by the
// kernel at the socket); every lost valid command is counted (the daemon's `missed (seq gaps)`
// equals the commands that were not applied); every junk datagram that reaches the decoders is
// counted as rejected; none out of order; the commands sent after the flood are applied. The test
// waits for events only: the flood ends once every datagram of it is counted (a loaded machine may
// take seconds to read the backlog a flood leaves in the socket), the commands after it go into an
// empty socket, and the counts are read once they add up to what was sent.
//
// Random junk: random payloads of 8..600 bytes, which the kernel's socket filter drops.
//
// Fingerprinted junk (the second flood of the test): the same, but each junk payload starts with
// torque_command_t's hash, so it passes the socket filter; the receive process refuses it as
// malformed (its fields do not walk) before its ring; the same accounting holds.
//
// Crafted fragments: liblcm 1.3.1's crash fragment, refused by the receive process's wire parser;
// every one is counted (malformed, not coopdyn, or dropped at the socket), nothing restarts.
//
// Forged junk, authentication on: garbage, unsigned, forged-MAC and replayed commands in turn
// against signed valid commands; each rejected with its reason, none applied.
#include <gtest/gtest.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <chrono>
#include <fstream>
#include <mutex>
#include <random>
#include <regex>
#include <sstream>
#include <thread>

#include "service/io/transport/auth.h"
#include "service/io/transport/lcm_bus.h"
#include "tests/support/child_process.h"
#include "tests/support/daemon_test_util.h"
#include "tests/support/raw_udp.h"

extern char** environ;

using namespace coopdyn;
using namespace coopdyn::daemon_test;
using namespace std::chrono_literals;

namespace {
enum class Junk { kRandom, kFingerprinted, kForged, kFragments };
const char* kKeyHex = "00112233445566778899aabbccddeeff0123456789abcdef0f1e2d3c4b5a6978";
const char* kOtherKeyHex = "77112233445566778899aabbccddeeff0123456789abcdef0f1e2d3c4b5a6978";

struct FloodFigures {
  bool ran = false;
  long valid = 0, applied = 0, missed = 0, junk = 0;
};
const char* junk_name(Junk k) {
  return k == Junk::kRandom          ? "random"
         : k == Junk::kFingerprinted ? "fingerprinted"
         : k == Junk::kForged        ? "forged (authentication on)"
                                     : "crafted LC03 fragment";
}

struct Summary {
  long received = 0, accepted = 0, rejected = 0, out_of_order = 0, missed = 0, dropped = 0, filtered = 0, malformed = 0,
       socket_drops = 0;
};
bool parse_summary(const std::string& text, Summary* s) {
  std::smatch m;
  if (!std::regex_search(text, m, std::regex(R"(received (\d+), accepted (\d+), rejected (\d+), out-of-order (\d+))"))) return false;
  s->received = std::stol(m[1]);
  s->accepted = std::stol(m[2]);
  s->rejected = std::stol(m[3]);
  s->out_of_order = std::stol(m[4]);
  if (!std::regex_search(text, m, std::regex(R"(missed \(seq gaps\) (\d+))"))) return false;
  s->missed = std::stol(m[1]);
  const std::regex inputs(R"(inputs dropped (\d+), filtered (\d+), malformed (\d+), )"
                          R"(socket filter discards \(other channels, own outputs included\) and overflow (\d+))");
  if (!std::regex_search(text, m, inputs)) return false;
  s->dropped = std::stol(m[1]);
  s->filtered = std::stol(m[2]);
  s->malformed = std::stol(m[3]);
  s->socket_drops = std::stol(m[4]);
  return true;
}

// The last loop_stats_t seen on the output URL (published every 0.1 s in these floods).
struct LastStats {
  std::mutex mu;
  io::StatsFrame s;
  long frames = 0;
};

// The kernel's drops at the daemon's receive socket so far, as its log says them (the receive process
// reads the socket's count every 50 to 100 ms, the daemon logs what it has not logged yet at most
// once a second; loop_stats_t does not carry it).
long logged_socket_drops(const std::string& log) {
  static const std::regex drops(R"((\d+) dropped by the kernel at the receive socket)");
  long n = 0;
  for (auto it = std::sregex_iterator(log.begin(), log.end(), drops); it != std::sregex_iterator(); ++it) n += std::stol((*it)[1]);
  return n;
}

// The datagrams on the command channel the daemon has counted, wherever each one went: it reached a
// check (received: accepted, rejected or out of order), the receive process refused it (not a
// coopdyn message, malformed LCM), could not queue it (ring full), or the kernel dropped it at the
// socket (its filter, a full buffer). Each counter only grows: the sum reaches the datagrams sent
// once every one of them is counted, and exceeds it if one is counted twice.
long counted(const io::StatsFrame& st, long socket_drops) {
  return static_cast<long>(st.received + st.inputs_filtered + st.inputs_malformed + st.inputs_dropped) + socket_drops;
}

// Runs the flood, asserts what holds for every junk, returns the figures.
void run_flood(Junk kind, FloodFigures* fig) {
  // outputs on one port, inputs on another (lcm_url_in), so the test's output subscriber never sees
  // the junk
  const int port = kind == Junk::kForged ? 4 : kind == Junk::kFragments ? 6 : 0;
  const std::string url = private_udpm_url(port), url_in = private_udpm_url(port + 1, "239.255.76.68");
  auto rx = try_bus(url), valid_tx = try_bus(url_in), junk_tx = try_bus(url_in);
  if (!rx || !valid_tx || !junk_tx) GTEST_SKIP() << "LCM udpm unavailable (no multicast route? 'ip route add 224.0.0.0/4 dev lo')";
  fig->ran = true;
  const System sys = load_scene(scene_path("two_puma_load"));
  const bool auth = kind == Junk::kForged;
  const std::string config = tmp_path("flood.yaml"), key_file = tmp_path("flood.key");
  {
    // the receive process and thread at SCHED_FIFO 70, below the loop's 80 (as root, else refused and
    // logged, and they run SCHED_OTHER). With authentication, where the share applied is judged, held
    // through the flood (sched_fifo: true: no guard steps them down); for at most the flood's 3 s the
    // receive process then takes, at real-time priority, what one sending thread on this host makes
    // it read (it sleeps whenever the socket is empty). The other floods run sched_fifo auto, whose
    // guard steps a busy receive path down after a 0.1 s window. COOPDYN_FLOOD_REALTIME replaces the
    // realtime mapping (bench/flood.sh measures variants).
    const char* rt = std::getenv("COOPDYN_FLOOD_REALTIME");
    const char* rt_default = auth ? "{sched_fifo: true, receive_priority: 70}" : "{receive_priority: 70}";
    std::ofstream(config) << "lcm_url_in: \"" << url_in << "\"\nstats_period_s: 0.1\nrealtime: "
                          << (rt && *rt ? rt : rt_default) << "\n"
                          << (auth ? "auth:\n  key_file: " + key_file + "\n" : "");
    std::remove(key_file.c_str());
    std::ofstream(key_file) << kKeyHex << "\n";
    chmod(key_file.c_str(), 0600);
  }
  const io::AuthKey key = io::parse_key(kKeyHex, "key"), other_key = io::parse_key(kOtherKeyHex, "other key");

  std::mutex mu;
  int64_t first_tick = -1, last_tick = -1, outputs = 0, max_seq_applied = -1;
  long long t_first_ns = 0, t_last_ns = 0;
  long foreign_tau = 0;  // outputs under a command whose torque is not the valid one of its seq
  const Eigen::VectorXd base = some_torque(sys, 21);
  auto scale_of = [](int64_t seq) { return seq == 1 || seq > 301 ? 1.0 : 1.0 + 1e-3 * static_cast<double>(seq - 1); };
  LastStats stats;
  rx->subscribe("COOPDYN_STATS", [&](const void* d, int n, long long) {
    io::StatsFrame f;
    if (!io::decode_stats(d, n, &f)) return;
    std::lock_guard<std::mutex> lk(stats.mu);
    stats.s = f;
    ++stats.frames;
  });
  rx->subscribe("COOPDYN_OUTPUT", [&](const void* d, int n, long long t) {
    io::DecodedOutput o;
    if (!io::decode_output(d, n, &o)) return;
    std::lock_guard<std::mutex> lk(mu);
    if (first_tick < 0) {
      first_tick = o.tick;
      t_first_ns = t;
    }
    last_tick = o.tick;
    t_last_ns = t;
    ++outputs;
    if (o.input != static_cast<int>(io::Input::kCommand)) return;
    max_seq_applied = std::max<int64_t>(max_seq_applied, o.input_seq);
    const Eigen::VectorXd want = base * scale_of(o.input_seq);
    if (o.tau.size() != static_cast<size_t>(want.size()) || (vec(o.tau) - want).cwiseAbs().maxCoeff() > 1e-12) ++foreign_tau;
  });
  rx->start();
  Child d({COOPDYND_PATH, "--scene", scene_path("two_puma_load"), "--config", config, "--lcm-url", url, "--duration",
           kDaemonDuration},
          "flood");
  std::vector<uint8_t> first_signed;  // seq 1 as sent: replayed by the forged flood
  auto send_valid = [&](int seq, double scale) {
    auto msg = io::encode_torque_command(io::wall_us(), seq, {}, stdvec(base * scale));
    if (auth) io::sign(msg, "COOPDYN_COMMAND", key, io::MessageType::kTorqueCommand);
    if (seq == 1) first_signed = msg;
    return valid_tx->publish("COOPDYN_COMMAND", msg.data(), static_cast<int>(msg.size()));
  };
  auto seq_applied = [&](int64_t seq) {
    return wait_until([&] {
      std::lock_guard<std::mutex> lk(mu);
      return max_seq_applied >= seq;
    });
  };
  // every datagram sent to the inputs so far (`sent`) counted where it went: waits until the
  // daemon's counters add up to it (on a loaded machine the receive process may take seconds to read
  // the backlog a flood left in its socket; the bound only turns a datagram counted nowhere into a
  // failure); *st the loop_stats_t that did, *drops the socket drops its log said
  auto all_counted = [&](long sent, io::StatsFrame* st, long* drops) {
    return wait_until([&] {
      {
        std::lock_guard<std::mutex> lk(stats.mu);
        if (stats.frames == 0) return false;
        *st = stats.s;
      }
      *drops = logged_socket_drops(slurp(d.err));
      return counted(*st, *drops) >= sent;
    }, kEventLimit, 20ms);
  };
  // the daemon publishes once its receive process has subscribed; then seq 1, before the flood
  // (sent once: a resend would count as out of order): the path works, and every later loss is a
  // seq gap the daemon can count
  ASSERT_TRUE(wait_until([&] {
    std::lock_guard<std::mutex> lk(mu);
    return outputs > 0;
  })) << "the daemon never published: " << slurp(d.err);
  ASSERT_EQ(send_valid(1, 1.0), 0);
  ASSERT_TRUE(seq_applied(1)) << "the daemon did not apply a command sent before the flood: " << slurp(d.err);
  int64_t tick_before;
  {
    std::lock_guard<std::mutex> lk(mu);
    tick_before = last_tick;
  }

  // junk on the command channel (LCM-framed, so it reaches the filter and, if it passes, the
  // decoder), as fast as one thread can publish it
  std::atomic<bool> stop_junk{false};
  std::atomic<long> junk_sent{0};
  // forged: in turn garbage after the command fingerprint, a well-formed unsigned command, one signed
  // with another key, and seq 1's signed bytes again (a replay); each command of seq 10^9 + k and a
  // torque no valid command has (-base)
  std::vector<std::vector<uint8_t>> unsigned_cmds, forged_cmds;
  for (int k = 0; k < 16; ++k) {
    auto m = io::encode_torque_command(io::wall_us(), 1000000000 + k, {}, stdvec(-base));
    unsigned_cmds.push_back(m);
    io::sign(m, "COOPDYN_COMMAND", other_key, io::MessageType::kTorqueCommand);
    forged_cmds.push_back(m);
  }
  RawUdp raw(url_in);
  const std::vector<uint8_t> crafted = lc03(1, 100, 0xFFFFFF00u, 0, 2, "COOPDYN_COMMAND", 324);  // liblcm 1.3.1's crash
  std::thread junk([&] {
    std::mt19937 rng(11);
    std::vector<uint8_t> b(600), fresh;
    const int64_t h = io::fingerprint(io::MessageType::kTorqueCommand);
    for (long i = 0; !stop_junk.load(std::memory_order_relaxed); ++i) {
      const std::vector<uint8_t>* whole = nullptr;
      if (kind == Junk::kForged && i % 4 == 1) whole = &unsigned_cmds[static_cast<size_t>(i / 4) % 16];
      if (kind == Junk::kForged && i % 4 == 2) whole = &forged_cmds[static_cast<size_t>(i / 4) % 16];
      if (kind == Junk::kForged && i % 4 == 3) whole = &first_signed;
      if (kind == Junk::kFragments) {
        if (raw.send(crafted)) junk_sent.fetch_add(1, std::memory_order_relaxed);
        continue;
      }
      if (kind == Junk::kForged && i % 4 == 2) {  // forged: stamped now (+0.5 s), so the MAC must be computed
        fresh = *whole;
        const uint64_t u = static_cast<uint64_t>(io::wall_us() + 500000);
        for (int k = 0; k < 8; ++k) fresh[8 + static_cast<size_t>(k)] = static_cast<uint8_t>(u >> (56 - 8 * k));
        whole = &fresh;
      }
      int n = 0;
      if (whole) {
        n = static_cast<int>(whole->size());
      } else {
        n = 8 + static_cast<int>(rng() % 593);
        for (int k = 0; k < n; ++k) b[k] = static_cast<uint8_t>(rng());
        if (kind != Junk::kRandom)
          for (int k = 0; k < 8; ++k) b[k] = static_cast<uint8_t>(static_cast<uint64_t>(h) >> (56 - 8 * k));
      }
      if (junk_tx->publish("COOPDYN_COMMAND", whole ? whole->data() : b.data(), n) == 0)
        junk_sent.fetch_add(1, std::memory_order_relaxed);
    }
  });
  // valid: seqs 2..301, at most 100 Hz (absolute deadlines), each after 20 more junk datagrams
  const int kValid = 300, kJunkPerValid = 20;
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 1; i <= kValid; ++i) {
    std::this_thread::sleep_until(t0 + i * 10ms);
    while (junk_sent.load(std::memory_order_relaxed) < static_cast<long>(kJunkPerValid) * i)
      std::this_thread::sleep_for(100us);
    ASSERT_EQ(send_valid(1 + i, 1.0 + 1e-3 * i), 0);
  }
  const double flood_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  stop_junk = true;
  junk.join();
  const long junk_n = junk_sent.load();
  // the flood over once all of it is counted (its backlog read from the socket and the ring); then
  // 5 more valid commands, which an empty socket and ring cannot lose: all applied (the last one seen)
  io::StatsFrame st;
  long drops_logged = 0;
  EXPECT_TRUE(all_counted(junk_n + 1 + kValid, &st, &drops_logged))
      << "the flood's datagrams are not all counted: " << junk_n + 1 + kValid << " sent, " << counted(st, drops_logged)
      << " counted\n" << slurp(d.err);
  const int kAfter = 5, last_seq = 1 + kValid + kAfter;
  for (int seq = 2 + kValid; seq <= last_seq; ++seq) {
    std::this_thread::sleep_for(10ms);
    ASSERT_EQ(send_valid(seq, 1.0), 0);
  }
  seq_applied(last_seq);
  int64_t tick_after, applied, outs;
  long foreign;
  double out_rate_hz;
  {
    std::lock_guard<std::mutex> lk(mu);
    tick_after = last_tick;
    applied = max_seq_applied;
    outs = outputs;
    foreign = foreign_tau;
    out_rate_hz = (last_tick - first_tick) / ((t_last_ns - t_first_ns) * 1e-9);
  }
  // and the commands after it counted: st, the last loop_stats_t, then holds every count the summary
  // line prints at the stop (the receive process's copy of its socket's drop count included)
  EXPECT_TRUE(all_counted(junk_n + last_seq, &st, &drops_logged))
      << junk_n + last_seq << " sent, " << counted(st, drops_logged) << " counted\n" << slurp(d.err);
  kill(d.pid, SIGTERM);
  ASSERT_EQ(d.wait(), 0) << slurp(d.err);
  rx->stop();
  std::remove(config.c_str());
  std::remove(key_file.c_str());
  const std::string log = slurp(d.err);
  EXPECT_NE(log.find("receive socket filter: only coopdyn messages"), std::string::npos) << log;
  Summary s;
  ASSERT_TRUE(parse_summary(slurp(d.out), &s)) << slurp(d.out);
  const bool rx_fifo = log.find("receive process and thread run SCHED_FIFO priority") != std::string::npos;
  // with the test's realtime mapping (receive_priority 70) the daemon says either: granted, or
  // refused (then the share applied is not judged); never neither
  const char* rt_env = std::getenv("COOPDYN_FLOOD_REALTIME");
  const bool rt_default = !(rt_env && *rt_env);
  if (rt_default) {
    ASSERT_TRUE(rx_fifo || log.find("receive process and thread: SCHED_FIFO priority 70 refused") != std::string::npos)
        << "the log says neither that the receive path got SCHED_FIFO nor that it was refused: " << log;
  }
  std::smatch dm;
  const std::string out_text = slurp(d.out);
  // the step-down counts decide whether the share applied is judged: a summary without them fails
  ASSERT_TRUE(std::regex_search(out_text, dm, std::regex(R"(SCHED_FIFO stepped down: loop (\d+), receive (\d+))")))
      << "no step-down counts in the summary: " << out_text;
  const long loop_down = std::stol(dm[1]), rx_down = std::stol(dm[2]);
  // accepted: of the flood's valid commands (seq 1 and the kAfter after it excluded)
  const long accepted = s.accepted - 1 - kAfter;
  const long lost = kValid - accepted;
  auto by = [&](io::Reject r) { return static_cast<long>(st.rejected_by_reason[static_cast<int>(r)]); };
  // valid commands that the flood's backlog in the socket held past max_input_age (1 s): they
  // arrived, and are rejected for their utime (on a loaded machine a receive process stepped down
  // to SCHED_OTHER may read the backlog slower than one thread fills it)
  const long late = by(io::Reject::kStale) + by(io::Reject::kFuture);
  std::printf(
      "[flood] %s junk, %.2f s: %d valid commands at 100 Hz + %ld junk datagrams (%.0f /s, one thread); valid applied "
      "%ld, lost %ld (%.2f %%), counted as missed (seq gaps) %ld; the receive process: refused %ld (not coopdyn), %ld "
      "(malformed LCM), ring full or too large %ld; the kernel dropped %ld at the socket (filter and overflow, %.2f %% of the junk); "
      "rejected %ld (malformed %ld, unauthenticated %ld, bad MAC %ld, replayed %ld, stale or future utime %ld), out of "
      "order %ld; ticks during "
      "the flood %lld (%.1f per s), outputs seen %lld at %.1f Hz; receive path SCHED_FIFO %s, stepped down: loop "
      "%ld, receive %ld\n",
      junk_name(kind), flood_s, kValid, junk_n, junk_n / flood_s, accepted, lost, 100.0 * lost / kValid, s.missed,
      s.filtered, s.malformed, s.dropped, s.socket_drops, 100.0 * s.socket_drops / std::max(1L, junk_n), s.rejected,
      by(io::Reject::kDecode), by(io::Reject::kUnauthenticated), by(io::Reject::kBadMac), by(io::Reject::kReplayed), late,
      s.out_of_order, static_cast<long long>(tick_after - tick_before), (tick_after - tick_before) / flood_s,
      static_cast<long long>(outs), out_rate_hz, rx_fifo ? "granted" : "refused", loop_down, rx_down);
  fig->valid = kValid;
  fig->applied = accepted;
  fig->missed = s.missed;
  fig->junk = junk_n;
  EXPECT_GE(junk_n, kJunkPerValid * kValid);
  EXPECT_LE(accepted, kValid);
  EXPECT_EQ(applied, last_seq) << "the valid commands sent after the flood are applied";
  EXPECT_EQ(foreign, 0) << "an output ran under a torque no valid command carried";
  EXPECT_EQ(s.out_of_order, 0);
  EXPECT_EQ(s.missed + late, lost) << "every valid command not applied is counted once: lost on the way (a gap in the "
                                     "seqs that reached the checks) or held past max_input_age (rejected for its utime)";
  EXPECT_EQ(s.received - (1 + kAfter) - accepted - s.out_of_order, s.rejected)
      << "every junk datagram that reached a check is counted as rejected";
  // the last loop_stats_t agrees with the summary line
  EXPECT_EQ(st.received, s.received);
  EXPECT_EQ(st.rejected, s.rejected);
  long reasons = 0;
  for (int k = 1; k < io::kRejectKinds; ++k) reasons += static_cast<long>(st.rejected_by_reason[k]);
  EXPECT_EQ(reasons, st.rejected) << "every rejection has its reason";
  // every datagram sent, junk or valid, counted exactly once where it went: it reached a check, or
  // the receive process refused it or could not queue it (ring full), or the kernel dropped it at the
  // socket (its filter, a full buffer)
  EXPECT_EQ(s.received + s.filtered + s.malformed + s.dropped + s.socket_drops, junk_n + last_seq)
      << "every datagram counted once, where it went";
  EXPECT_EQ(s.socket_drops, drops_logged) << "the summary's socket drops are the ones the log said";
  if (kind == Junk::kFragments) {
    EXPECT_EQ(s.rejected, late) << "no fragment reaches a decoder: the only rejections are valid commands held too long";
    EXPECT_EQ(st.receiver_restarts, 0);
  }
  if (auth) {
    // The share applied: with the receive path at SCHED_FIFO through the flood it applied 300 of 300
    // in each of 30 runs (bench/flood.sh: 12 at load 5-7, 10 beside a parallel build at load 6-10;
    // this test alone, 8 at load 10; 68,000-297,000 junk datagrams/s), so it is asserted there; without the priority (not root, or
    // a guard that stepped it down) it is a race between one sending thread and the receive process
    // (180-299 of 300 when auto's guard stepped it down), printed and not judged. What is asserted
    // in every case: no junk is accepted and every valid command lost is counted.
    if (rt_default) {
      EXPECT_EQ(rx_down, 0) << "realtime.sched_fifo true never steps the receive path down";
    }
    if (rx_fifo && rx_down == 0)
      EXPECT_GE(accepted, kValid * 99 / 100) << "with the receive path at SCHED_FIFO, >= 99 % of valid commands applied";
    else
      std::printf("[flood] the share applied is not judged: the receive path %s\n",
                  rx_fifo ? "was stepped down to SCHED_OTHER during the flood" : "did not get SCHED_FIFO (needs root)");
    EXPECT_EQ(s.accepted, 1 + accepted + kAfter) << "no junk accepted";
    EXPECT_EQ(by(io::Reject::kDecode) + by(io::Reject::kUnauthenticated) + by(io::Reject::kBadMac) +
                  by(io::Reject::kReplayed) + late,
              s.rejected)
        << "junk is rejected as malformed, unauthenticated, bad MAC or replayed, and nothing else is but valid commands "
           "held too long";
    EXPECT_GT(by(io::Reject::kUnauthenticated), 0);
    EXPECT_GT(by(io::Reject::kBadMac), 0);
    EXPECT_GT(by(io::Reject::kReplayed), 0);
  }
}
}  // namespace

// One test, two floods in turn (two flood tests run side by side by ctest -j2 would share two
// cores). First random junk, which the socket filter keeps out of the receive process; then junk
// that carries the command fingerprint, which passes the filter: the receive path reads all of it.
// In both, every valid command lost is counted exactly (asserted in run_flood); how many were lost,
// and the loop's rate, are printed (bench/flood.sh gathers them).
TEST(DaemonFlood, ValidCommandLossCounted) {
  FloodFigures f;
  run_flood(Junk::kRandom, &f);
  if (!f.ran || HasFatalFailure()) return;
  FloodFigures g;
  run_flood(Junk::kFingerprinted, &g);
}

// liblcm 1.3.1's crash fragment (LC03, offset 0xFFFFFF00) as fast as one thread sends it, while 300
// valid commands arrive at 100 Hz: the receive process refuses every one (counted as malformed or not
// a coopdyn message), nothing restarts, every valid command lost is counted; how many were lost is
// printed (bench/flood.sh: the fragment rate the daemon survives).
TEST(DaemonFlood, CraftedFragmentsAtFullRateRefusedAndCounted) {
  FloodFigures f;
  run_flood(Junk::kFragments, &f);
}

// Authentication on: the flood's junk is garbage after the command fingerprint, well-formed unsigned
// commands, commands signed with another key and a valid command's bytes sent again, in turn, as fast
// as one thread publishes them, while 300 signed commands arrive at 100 Hz. With the receive path at
// SCHED_FIFO (as root) at least 99 % of the signed commands are applied (else the share is printed,
// bench/flood.sh measures it); none of the junk is (every output's torque is a signed command's), and
// every junk datagram that reaches a check is rejected with its reason (asserted in run_flood).
TEST(DaemonFlood, WithAuthenticationJunkIsRejectedAndValidCommandsApplied) {
  FloodFigures f;
  run_flood(Junk::kForged, &f);
}

// The socket filter itself: datagrams that are not a coopdyn message of an input channel (the
// command fingerprint on another channel, another type's fingerprint on the command channel, a
// truncated one, a non-LCM datagram) are dropped by the kernel and never reach the receive process;
// a valid command after them is applied.
TEST(DaemonFlood, SocketFilterLetsOnlyCoopdynMessagesOfItsChannelsThrough) {
  const std::string url = private_udpm_url(2), url_in = private_udpm_url(3, "239.255.76.68");
  auto rx = try_bus(url), tx = try_bus(url_in);
  if (!rx || !tx) GTEST_SKIP() << "LCM udpm unavailable (no multicast route? 'ip route add 224.0.0.0/4 dev lo')";
  const System sys = load_scene(scene_path("two_puma_load"));
  const std::string config = tmp_path("filter.yaml");
  {
    std::ofstream(config) << "lcm_url_in: \"" << url_in << "\"\n";
  }
  std::mutex mu;
  int64_t outputs = 0, max_seq_applied = -1;
  rx->subscribe("COOPDYN_OUTPUT", [&](const void* d, int n, long long) {
    io::DecodedOutput o;
    if (!io::decode_output(d, n, &o)) return;
    std::lock_guard<std::mutex> lk(mu);
    ++outputs;
    if (o.input == static_cast<int>(io::Input::kCommand)) max_seq_applied = std::max<int64_t>(max_seq_applied, o.input_seq);
  });
  rx->start();
  Child d({COOPDYND_PATH, "--scene", scene_path("two_puma_load"), "--config", config, "--lcm-url", url, "--duration",
           kDaemonDuration},
          "filter");
  for (int i = 0; i < 2000; ++i) {
    {
      std::lock_guard<std::mutex> lk(mu);
      if (outputs > 0) break;
    }
    std::this_thread::sleep_for(5ms);
  }
  const auto cmd = io::encode_torque_command(io::wall_us(), 7, {}, stdvec(some_torque(sys, 3)));
  const auto ctl = io::encode_control(io::wall_us(), 1, io::ControlAction::kPause);
  std::vector<uint8_t> output_hash(64, 0);
  for (int k = 0; k < 8; ++k)
    output_hash[k] = static_cast<uint8_t>(static_cast<uint64_t>(io::fingerprint(io::MessageType::kOutput)) >> (56 - 8 * k));
  const int kEach = 50;
  int sent = 0;
  for (int i = 0; i < kEach; ++i) {
    ASSERT_EQ(tx->publish("COOPDYN_COMMANDX", cmd.data(), static_cast<int>(cmd.size())), 0);  // another channel
    ASSERT_EQ(tx->publish("COOPDYN_COMMAN", cmd.data(), static_cast<int>(cmd.size())), 0);   // a prefix of it
    ASSERT_EQ(tx->publish("COOPDYN_COMMAND", ctl.data(), static_cast<int>(ctl.size())), 0);  // control_t on the command channel
    ASSERT_EQ(tx->publish("COOPDYN_CONTROL", cmd.data(), static_cast<int>(cmd.size())), 0);  // a command on the control channel
    ASSERT_EQ(tx->publish("COOPDYN_COMMAND", output_hash.data(), 64), 0);                     // another coopdyn type
    ASSERT_EQ(tx->publish("COOPDYN_COMMAND", cmd.data(), 7), 0);                              // the fingerprint cut short
    sent += 6;
  }
  ASSERT_EQ(tx->publish("COOPDYN_COMMAND", cmd.data(), static_cast<int>(cmd.size())), 0);
  wait_until([&] {
    std::lock_guard<std::mutex> lk(mu);
    return max_seq_applied == 7;
  });
  // the kernel's drops reach the daemon (the receive process reads the socket's count every 50 to 100
  // ms, idle or not; the daemon logs what it has not logged yet at most once a second)
  EXPECT_TRUE(wait_until([&] { return logged_socket_drops(slurp(d.err)) >= sent; }, kEventLimit, 20ms)) << slurp(d.err);
  kill(d.pid, SIGTERM);
  ASSERT_EQ(d.wait(), 0) << slurp(d.err);
  rx->stop();
  std::remove(config.c_str());
  {
    std::lock_guard<std::mutex> lk(mu);
    EXPECT_EQ(max_seq_applied, 7) << "the valid command after the others is applied";
  }
  Summary s;
  ASSERT_TRUE(parse_summary(slurp(d.out), &s)) << slurp(d.out);
  EXPECT_EQ(s.received, 1) << "only the valid command reached the decoders";
  EXPECT_EQ(s.filtered, 0) << "nothing reached the receive process's own check";
  EXPECT_EQ(s.malformed, 0) << "well-formed LCM datagrams, each refused by the filter, none by the wire parser";
  EXPECT_EQ(s.socket_drops, sent) << "the kernel dropped every other datagram at the socket";
}
