// coopdyn view --live: coopdynd over udpm on a private loopback port, `coopdyn view --live` as its
// own process serving the page and its WebSocket on 127.0.0.1 (port 0: the one it prints).
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "service/io/codec/codec.h"
#include "service/io/transport/lcm_bus.h"
#include "tests/support/child_process.h"
#include "tests/support/http_client.h"
#include "tests/clients/view/view_test_util.h"

namespace coopdyn {
namespace {
using namespace view_test;

using testing::http_get;
using testing::ws_connect;

long rss_kib(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::atol(line.c_str() + 6);
  return -1;
}

// A running daemon and a live viewer of it, and what the test receives from the daemon.
struct LiveRig {
  std::string url;
  std::unique_ptr<io::LcmBus> bus;
  std::unique_ptr<daemon_test::Child> daemon, viewer;
  int port = -1;
  std::mutex mu;
  std::vector<double> sim_t;               // output_t sim_time, as received
  struct Sent {                            // what a received output_t says of wrench `track`
    double sim_time;
    int sigma_source;
    std::array<double, 6> wrench, sigma;   // [moment; force] in its report frame
  };
  std::string track = "arm1.ee";
  std::vector<Sent> sent;
  std::vector<std::pair<int64_t, int64_t>> stats;  // loop_stats_t (utime, tick)
  std::string skip;

  LiveRig(int offset, const std::vector<std::string>& viewer_extra, const std::string& scene = scene_file("two_puma_load")) {
    if (!COOPDYN_VIEW_LIVE) {
      skip = "coopdyn view --live is not built (Debian: libwebsocketpp-dev libasio-dev)";
      return;
    }
    url = private_udpm_url(offset);
    bus = daemon_test::try_bus(url);
    if (!bus) {
      skip = "LCM over udpm unavailable (multicast route? ip route add 224.0.0.0/4 dev lo)";
      return;
    }
    bus->subscribe("COOPDYN_OUTPUT", [this](const void* d, int n, long long) {
      io::DecodedOutput o;
      if (!io::decode_output(d, n, &o)) return;
      std::lock_guard<std::mutex> lk(mu);
      sim_t.push_back(o.sim_time);
      for (size_t k = 0; k < o.wrench_names.size(); ++k)
        if (o.wrench_names[k] == track && k < o.wrench.size() && k < o.wrench_sigma.size())
          sent.push_back({o.sim_time, o.sigma_source, o.wrench[k], o.wrench_sigma[k]});
    });
    bus->subscribe("COOPDYN_STATS", [this](const void* d, int n, long long) {
      io::StatsFrame st;
      if (!io::decode_stats(d, n, &st)) return;
      std::lock_guard<std::mutex> lk(mu);
      stats.emplace_back(st.utime, st.tick);
    });
    bus->start();
    const std::string cfg = daemon_test::tmp_path("live_cfg.yaml");
    std::ofstream(cfg) << "stats_period_s: 0.25\n";
    daemon = std::make_unique<daemon_test::Child>(
        std::vector<std::string>{COOPDYND_PATH, "--scene", scene, "--config", cfg, "--lcm-url", url,
                                 "--rate", "1000", "--duration", "300"},
        "live_daemon");
    std::vector<std::string> args{kBin, "view", "--scene", scene, "--live", "--listen",
                                  "127.0.0.1:0", "--lcm-url", url};
    args.insert(args.end(), viewer_extra.begin(), viewer_extra.end());
    viewer = std::make_unique<daemon_test::Child>(args, "live_viewer");
    for (int i = 0; i < 200 && port < 0; ++i) {  // its address, once it listens
      std::this_thread::sleep_for(std::chrono::milliseconds(25));
      const std::string err = daemon_test::slurp(viewer->err);
      const size_t at = err.find("serving http://127.0.0.1:");
      if (at != std::string::npos) port = std::atoi(err.c_str() + at + 25);
    }
  }
  ~LiveRig() {
    if (bus) bus->stop();
  }
  // ticks per second of the daemon from its loop_stats_t between wall times [t0, t1] (us)
  double tick_rate(int64_t t0, int64_t t1) {
    std::lock_guard<std::mutex> lk(mu);
    const std::pair<int64_t, int64_t>* a = nullptr;
    const std::pair<int64_t, int64_t>* b = nullptr;
    for (const auto& s : stats) {
      if (s.first >= t0 && !a) a = &s;
      if (s.first <= t1) b = &s;
    }
    if (!a || !b || b->first <= a->first) return NAN;
    return static_cast<double>(b->second - a->second) / (static_cast<double>(b->first - a->first) * 1e-6);
  }
};

// The live page in Chromium connects, receives the daemon's frames and shows the simulation time
// advancing: the time it shows is later than the first it received, and both are times the daemon
// published.
TEST(ViewLive, BrowserReceivesFramesAndTimeAdvances) {
  REQUIRE_BROWSER();
  TempDir dir("live");
  LiveRig rig(2, {});
  if (!rig.skip.empty()) GTEST_SKIP() << rig.skip;
  ASSERT_GT(rig.port, 0) << daemon_test::slurp(rig.viewer->err);
  const std::string index = http_get(rig.port, "/");
  ASSERT_EQ(index.rfind("HTTP/1.1 200", 0), 0u) << index.substr(0, 200);
  EXPECT_NE(index.find("\"live\":true"), std::string::npos);
  EXPECT_EQ(http_get(rig.port, "/nothing").rfind("HTTP/1.1 404", 0), 0u);

  // Chromium in real time: wait until the page has received 5 frames and shows a time 10 ms past
  // the first, however long that takes the machine (at most 60 s)
  DevTools browser(chromium, dir / "live");
  ASSERT_EQ(browser.open("http://127.0.0.1:" + std::to_string(rig.port) + "/#wrench=arm1.ee"), "");
  auto shown_t = [](const PageState& s) { return std::strtod(s.time_text.c_str() + 4, nullptr); };  // "t = 0.123 s"
  std::string dom;
  const bool advanced = browser.wait_until(
      [&](const std::string& d) {
        const PageState s = page_state(d);
        return num_after(s.probe, "\"received\":") >= 5 && shown_t(s) > num_after(s.probe, "\"first_t\":") + 0.01;
      },
      60, &dom);
  const PageState p = page_state(dom);
  EXPECT_TRUE(advanced) << "in 60 s: " << p.probe << "\n" << browser.log();
  EXPECT_EQ(p.title, "coopdyn view: two_puma_load") << "a JavaScript error, or the page did not finish";
  const std::string live = between(dom, "<span id=\"live\">", "</span>");
  EXPECT_EQ(live.rfind("live: connected, ", 0), 0u) << live;
  const long received = std::atol(live.c_str() + std::string("live: connected, ").size());
  EXPECT_GE(received, 5) << live;
  const double first_t = num_after(p.probe, "\"first_t\":");
  ASSERT_TRUE(std::isfinite(first_t)) << p.probe;
  // the time text shows the newest frame received (playing follows it)
  const double shown = shown_t(p);
  EXPECT_GT(shown, first_t + 0.01) << p.time_text << " " << p.probe;
  // the plot of the selected wrench grew with the frames, its cursor on the newest
  const std::string plot = between(p.probe, "\"plot\":{", "\"axes\"");
  EXPECT_EQ(between(plot, "\"wrench\":\"", "\""), "arm1.ee") << p.probe;
  EXPECT_EQ(num_after(plot, "\"n\":"), num_after(p.probe, "\"received\":")) << p.probe;  // (one render)
  EXPECT_EQ(num_after(plot, "\"cursor_t\":"), p.t) << p.probe;
  EXPECT_EQ(num_after(plot, "\"t0\":"), first_t) << p.probe;
  {
    std::lock_guard<std::mutex> lk(rig.mu);
    ASSERT_FALSE(rig.sim_t.empty());
    auto near = [&](double t) {
      return std::any_of(rig.sim_t.begin(), rig.sim_t.end(), [&](double x) { return std::abs(x - t) < 5e-4; });
    };
    EXPECT_TRUE(near(first_t)) << first_t << " is not a time the daemon published";
    EXPECT_TRUE(near(shown)) << shown << " is not a time the daemon published";
  }
  rig.viewer->signal(SIGTERM);
  EXPECT_EQ(rig.viewer->wait(std::chrono::seconds(5)), 0) << daemon_test::slurp(rig.viewer->err);
  rig.daemon->signal(SIGTERM);
  EXPECT_EQ(rig.daemon->wait(std::chrono::seconds(5)), 0);
}

// Live with declared torque noise (two_puma_load with `noise: {tau: 20}`, the daemon simulating it):
// the bands the page draws are the sigma the daemon published in the output_t of the frame shown
// (matched by sim_time): the 3D ellipsoid's half-axes are that sigma over the page's arrow scales
// (force, moment), and the plot's band at the cursor is that message's value -+ sigma, to
// round-off, at the y its axes map them to. Waits for a frame with both drawn, never for a time.
TEST(ViewLive, BandsAreTheSigmaTheDaemonPublished) {
  REQUIRE_BROWSER();
  TempDir dir("live_bands");
  LiveRig rig(6, {}, noisy_scene(dir, "\nnoise: {tau: 20}\n"));
  if (!rig.skip.empty()) GTEST_SKIP() << rig.skip;
  ASSERT_GT(rig.port, 0) << daemon_test::slurp(rig.viewer->err);
  DevTools browser(chromium, dir / "live");
  ASSERT_EQ(browser.open("http://127.0.0.1:" + std::to_string(rig.port) + "/#wrench=arm1.ee"), "");
  // a frame with both drawn, and the output_t of that frame as this process received it (the page's
  // time is its sim_time to 9 digits; the daemon's ticks are 1 ms apart). UDP may drop a message on
  // its way to this process (a loaded machine): then another frame of the page, within 60 s in all.
  const auto drawn_both = [](const std::string& d) {
    const PageState s = page_state(d);
    return drawn(s.probe, "arm1.ee", "sigma_f").found && plot_band(s.probe, "fx").sigma.found;
  };
  const auto received = [&](double t, LiveRig::Sent* out) {
    std::lock_guard<std::mutex> lk(rig.mu);
    for (const LiveRig::Sent& x : rig.sent)
      if (std::abs(x.sim_time - t) < 1e-6) {
        *out = x;
        return true;
      }
    return false;
  };
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  std::string dom;
  PageState p;
  LiveRig::Sent msg{};
  bool have = false;
  while (!have && std::chrono::steady_clock::now() < end) {
    if (!browser.wait_until(drawn_both, 60, &dom)) break;
    p = page_state(dom);
    for (int i = 0; i < 40 && !(have = received(p.t, &msg)); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(drawn_both(dom)) << "no band drawn in 60 s: " << page_state(dom).probe << "\n" << browser.log();
  EXPECT_EQ(p.title, "coopdyn view: two_puma_load") << "a JavaScript error, or the page did not finish";
  ASSERT_TRUE(have) << "the test received no output_t at any frame the page showed (the last at t = " << p.t << ")";
  EXPECT_NE(msg.sigma_source, 0) << "the daemon published no sigma";
  std::printf("the page's frame at t = %.3f s: arm1.ee fz = %.6g N, sigma_fz = %.6g N in the daemon's output_t\n", p.t,
              msg.wrench[5], msg.sigma[5]);
  const double force_scale = p.force_scale, moment_scale = num_after(p.probe, "\"moment_scale\":");
  ASSERT_GT(force_scale, 0);
  ASSERT_GT(moment_scale, 0);
  const Drawn f = drawn(p.probe, "arm1.ee", "sigma_f"), m = drawn(p.probe, "arm1.ee", "sigma_m");
  ASSERT_TRUE(m.found) << p.probe;
  for (int j = 0; j < 3; ++j) {
    const double sm = msg.sigma[static_cast<size_t>(j)], sf = msg.sigma[static_cast<size_t>(3 + j)];
    ASSERT_GT(sf, 0) << j;
    EXPECT_NEAR(f.half[j], sf / force_scale, 1e-7 * sf / force_scale) << "force sigma along axis " << j;
    EXPECT_NEAR(m.half[j], sm / moment_scale, 1e-7 * sm / moment_scale + 1e-12) << "moment sigma along axis " << j;
  }
  const std::vector<PlotAxes> axes = plot_axes(p.probe);
  ASSERT_EQ(axes.size(), 2u) << p.probe;
  for (int c = 0; c < 6; ++c) {
    const PlotBand b = plot_band(p.probe, kComponents[c]);
    ASSERT_TRUE(b.sigma.found) << kComponents[c] << ": " << p.probe;
    const double v = msg.wrench[static_cast<size_t>(c)], s = msg.sigma[static_cast<size_t>(c)];
    const double eps = 1e-12 * (std::abs(v) + s);
    EXPECT_EQ(b.value, v) << kComponents[c];
    EXPECT_NEAR(b.sigma.lo, v - s, eps) << kComponents[c];
    EXPECT_NEAR(b.sigma.hi, v + s, eps) << kComponents[c];
    EXPECT_NEAR(b.sigma.y_lo, axes[c < 3 ? 0 : 1].y(v - s), 1e-6) << kComponents[c];
    EXPECT_NEAR(b.sigma.y_hi, axes[c < 3 ? 0 : 1].y(v + s), 1e-6) << kComponents[c];
    EXPECT_FALSE(b.bound.found) << kComponents[c] << ": a friction bound in simulate mode";
  }
  rig.viewer->signal(SIGTERM);
  EXPECT_EQ(rig.viewer->wait(std::chrono::seconds(5)), 0) << daemon_test::slurp(rig.viewer->err);
  rig.daemon->signal(SIGTERM);
  EXPECT_EQ(rig.daemon->wait(std::chrono::seconds(5)), 0);
}

// A WebSocket client that connects and never reads: once its socket and its bounded queue are full,
// the viewer drops its frames (counted: at least one for every frame the reading client was sent
// meanwhile) instead of queueing them, its memory stays bounded, and a client that reads goes on
// receiving. (Whether such a client slows the daemon down is a rate: bench/view_live_rate.sh.)
TEST(ViewLive, ClientThatNeverReadsIsDroppedFrom) {
  TempDir dir("slow");
  // every output framed and sent (--rate 1000, the daemon at 1 kHz): ~2.5 kB a frame for each client
  LiveRig rig(3, {"--rate", "1000"});
  if (!rig.skip.empty()) GTEST_SKIP() << rig.skip;
  ASSERT_GT(rig.port, 0) << daemon_test::slurp(rig.viewer->err);
  const int cap = 32;  // --queue's default: frames queued per client at most
  struct Stats {
    double framed, sent, dropped, clients, queued, buffered;
  };
  auto stats = [&] {
    const std::string s = http_get(rig.port, "/stats");
    return Stats{num_after(s, "\"framed\":"), num_after(s, "\"sent\":"),    num_after(s, "\"dropped\":"),
                 num_after(s, "\"clients\":"), num_after(s, "\"queued\":"), num_after(s, "\"buffered\":")};
  };
  // waits (at most 60 s) until done(): false if it never was
  auto wait_for = [](const std::function<bool()>& done) {
    for (int i = 0; i < 1200; ++i) {
      if (done()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return done();
  };

  // the client that never reads (a small receive buffer), alone at first: wait until its socket and
  // its queue are full (what it holds queued is all that is queued), from then on every frame put
  // into its queue drops one
  const int sleeper = ws_connect(rig.port, 4096);
  ASSERT_GE(sleeper, 0);
  Stats s1{};
  ASSERT_TRUE(wait_for([&] { return (s1 = stats()).queued >= cap; }))
      << "the queue of the client that never reads did not fill: " << http_get(rig.port, "/stats");
  EXPECT_EQ(s1.queued, cap) << "more queued than the per-client bound";
  EXPECT_EQ(s1.clients, 1);

  // a reader that keeps reading
  const int reader = ws_connect(rig.port, 0);
  ASSERT_GE(reader, 0);
  std::atomic<long> read_bytes{0};
  std::atomic<bool> stop{false};
  std::thread rd([&] {
    char buf[65536];
    while (!stop) {
      const ssize_t n = recv(reader, buf, sizeof buf, 0);
      if (n > 0) read_bytes += n;
      else if (n == 0) break;
    }
  });
  // the viewer's memory once the reader is under way, then after the reader got 4 MiB more: what a
  // queue without bound would have grown by for the client that never reads (the frames framed
  // meanwhile, at least those the reader got)
  const long warm = 256 * 1024, window = 4 * 1024 * 1024;
  const bool warmed = wait_for([&] { return read_bytes >= warm; });
  const long rss1 = rss_kib(rig.viewer->pid), read1 = read_bytes;
  const int64_t t1 = io::wall_us();
  const bool got = warmed && wait_for([&] { return read_bytes >= read1 + window; });
  const int64_t t2 = io::wall_us();
  const long rss2 = rss_kib(rig.viewer->pid), read2 = read_bytes;
  const Stats s2 = stats();
  stop = true;
  shutdown(reader, SHUT_RDWR);
  rd.join();
  close(reader);

  std::printf("viewer RSS %ld -> %ld KiB while the reader got %ld KiB; frames framed %.0f, sent %.0f, dropped %.0f since "
              "the queue of the client that never reads filled; daemon tick rate then %.1f Hz (not judged)\n",
              rss1, rss2, (read2 - read1) / 1024, s2.framed - s1.framed, s2.sent - s1.sent, s2.dropped - s1.dropped,
              rig.tick_rate(t1, t2));
  ASSERT_TRUE(got) << "the reading client was starved: it got " << read_bytes << " bytes in 60 s";
  EXPECT_EQ(s2.clients, 2);
  EXPECT_LE(s2.queued, 2 * cap) << "more queued than the per-client bound";
  // every frame the reader was sent since went into the full queue of the other, which dropped one
  EXPECT_GE(s2.dropped - s1.dropped, s2.sent - s1.sent) << "the client that never reads was not dropped from";
  EXPECT_GT(s2.sent - s1.sent, 0);
#if defined(__SANITIZE_ADDRESS__)
  std::printf("(AddressSanitizer: freed memory is quarantined, the viewer's RSS is not judged)\n");
#else
  EXPECT_LT(rss2 - rss1, 0.3 * (read2 - read1) / 1024) << "the viewer's memory grew (KiB) while a client did not read";
#endif
  close(sleeper);
  rig.viewer->signal(SIGTERM);
  EXPECT_EQ(rig.viewer->wait(std::chrono::seconds(5)), 0) << daemon_test::slurp(rig.viewer->err);
  rig.daemon->signal(SIGTERM);
  EXPECT_EQ(rig.daemon->wait(std::chrono::seconds(5)), 0);
}

}  // namespace
}  // namespace coopdyn
