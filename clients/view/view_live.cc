// coopdyn view --live: a process of its own that subscribes to coopdynd's output_t channel and
// serves the live page (HTTP) and a WebSocket of frames on one port (websocketpp on standalone
// asio, one thread). The daemon never knows it is there: LCM multicast has no back-pressure.
//
// Threads and queues. The LCM receive thread (io::LcmBus) decodes each output, skips it when it
// comes sooner than 1/rate after the last one taken, computes the frame's geometry (forward
// kinematics) and its JSON, and puts it into the inbox: a deque of at most `queue` frames (the
// oldest dropped), under a mutex held only for the push; it then wakes the server thread (one post
// at a time). It never waits for a client. The server thread moves the inbox into each client's own
// queue (at most `queue` frames, the oldest dropped: latest wins) and sends from it only while that
// connection holds less than kMaxBuffered bytes not yet written to its socket. A client that stops
// reading thus costs at most kMaxBuffered + queue frames of memory (and its socket's send buffer,
// kSocketSendBuffer, in the kernel), and drops frames, counted.
#include <signal.h>

#define ASIO_STANDALONE
#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "clients/view/view.h"
#include "service/io/codec/codec.h"
#include "service/io/transport/lcm_bus.h"
#include "clients/cli/lcm_route.h"

namespace coopdyn::cli {

namespace {

using Server = websocketpp::server<websocketpp::config::asio>;
using Hdl = websocketpp::connection_hdl;
constexpr size_t kMaxBuffered = 256 * 1024;  // bytes a connection may hold unwritten before we stop sending to it
constexpr int kSocketSendBuffer = 64 * 1024;  // SO_SNDBUF of each client's socket (the kernel doubles it)

struct Client {
  std::deque<std::shared_ptr<const std::string>> queue;
  long sent = 0, dropped = 0;
};

struct Counters {
  std::atomic<long> received{0}, skipped_rate{0}, mismatched{0}, undecodable{0}, framed{0};
  long sent = 0, dropped = 0;  // server thread only
};

std::string json_stats(const Counters& c, size_t clients, size_t queued, size_t buffered) {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "{\"received\":%ld,\"skipped_rate\":%ld,\"mismatched\":%ld,\"undecodable\":%ld,\"framed\":%ld,"
                "\"sent\":%ld,\"dropped\":%ld,\"clients\":%zu,\"queued\":%zu,\"buffered\":%zu}",
                c.received.load(), c.skipped_rate.load(), c.mismatched.load(), c.undecodable.load(), c.framed.load(),
                c.sent, c.dropped, clients, queued, buffered);
  return buf;
}

// HOST:PORT (a bracketed IPv6 host unbracketed); false, the reason printed, when it is not that.
bool parse_listen(const std::string& listen, std::string* host, std::string* port) {
  const auto colon = listen.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == listen.size()) {
    std::fprintf(stderr, "coopdyn view: --listen '%s': expected HOST:PORT (e.g. 127.0.0.1:8765)\n", listen.c_str());
    return false;
  }
  *host = listen.substr(0, colon);
  *port = listen.substr(colon + 1);
  if (host->size() > 2 && host->front() == '[' && host->back() == ']') *host = host->substr(1, host->size() - 2);
  return true;
}

// The page: the scene at its initial state stands in until the first frame arrives.
std::string live_page(const System& sys, const ViewVisuals& vis, const std::string& three_js, const std::string& loaders,
                      const std::string& source) {
  ViewFrames vf = view_geometry(sys, &vis);
  Data data(sys.model);
  ViewSample s0;
  s0.t = 0;
  s0.status = "waiting";
  s0.q = sys.q0;
  s0.w.assign(vf.wrenches.size(), Vec6::Zero());
  add_view_frame(sys, data, s0, &vf);
  return view_page(sys, vf, three_js, source, true, loaders);
}

// The server thread's state, and the inbox the LCM thread fills.
struct LiveServer {
  LiveServer(size_t cap_, std::string page_) : cap(cap_), page(std::move(page_)) {}

  Server server;
  const size_t cap;  // frames queued at most, in the inbox and per client
  const std::string page;
  Counters count;
  std::map<Hdl, Client, std::owner_less<Hdl>> clients;  // server thread only
  std::mutex inbox_mu;
  std::deque<std::shared_ptr<const std::string>> inbox;  // LCM thread -> server thread, at most cap
  std::atomic<bool> wake_posted{false};

  bool start() {
    server.clear_access_channels(websocketpp::log::alevel::all);
    server.clear_error_channels(websocketpp::log::elevel::all);  // a client gone mid-write is no error of ours
    try {
      server.init_asio();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "coopdyn view: cannot start the server: %s\n", e.what());
      return false;
    }
    server.set_reuse_addr(true);
    return true;
  }

  // Sends from c's queue while the connection holds less than kMaxBuffered bytes unwritten.
  void flush(const Hdl& h, Client& c) {
    websocketpp::lib::error_code ec;
    Server::connection_ptr con = server.get_con_from_hdl(h, ec);
    if (ec || !con || con->get_state() != websocketpp::session::state::open) return;
    while (!c.queue.empty() && con->get_buffered_amount() < kMaxBuffered) {
      ec = con->send(*c.queue.front(), websocketpp::frame::opcode::text);
      if (ec) return;
      c.queue.pop_front();
      ++c.sent;
      ++count.sent;
    }
  }

  // Server thread: the inbox into every client's queue, then send what may be sent.
  void drain() {
    wake_posted = false;
    std::deque<std::shared_ptr<const std::string>> got;
    {
      std::lock_guard<std::mutex> lk(inbox_mu);
      got.swap(inbox);
    }
    for (auto& [h, c] : clients) {
      for (const auto& f : got) {
        c.queue.push_back(f);
        if (c.queue.size() > cap) {
          c.queue.pop_front();
          ++c.dropped;
          ++count.dropped;
        }
      }
      flush(h, c);
    }
  }

  // LCM thread: the frame into the inbox (the oldest dropped), the server thread woken once.
  void post_frame(std::shared_ptr<const std::string> json) {
    {
      std::lock_guard<std::mutex> lk(inbox_mu);
      inbox.push_back(std::move(json));
      if (inbox.size() > cap) inbox.pop_front();
    }
    if (!wake_posted.exchange(true)) server.get_io_service().post([this] { drain(); });
  }

  // GET / (the page), /stats (the counters as JSON), anything else 404.
  void serve_http(Hdl h) {
    Server::connection_ptr con = server.get_con_from_hdl(h);
    std::string res = con->get_resource();
    const auto q = res.find('?');
    if (q != std::string::npos) res = res.substr(0, q);
    if (res == "/" || res == "/index.html") {
      con->set_status(websocketpp::http::status_code::ok);
      con->append_header("Content-Type", "text/html; charset=utf-8");
      con->append_header("Cache-Control", "no-store");
      con->set_body(page);
    } else if (res == "/stats") {
      size_t queued = 0, buffered = 0;
      for (const auto& [hh, c] : clients) {
        queued += c.queue.size();
        websocketpp::lib::error_code e2;
        if (Server::connection_ptr cc = server.get_con_from_hdl(hh, e2)) buffered += cc->get_buffered_amount();
      }
      con->set_status(websocketpp::http::status_code::ok);
      con->append_header("Content-Type", "application/json");
      con->set_body(json_stats(count, clients.size(), queued, buffered) + "\n");
    } else {
      con->set_status(websocketpp::http::status_code::not_found);
      con->set_body("not found: the page is at /, its WebSocket at /ws\n");
    }
  }

  void open_client(Hdl h) {
    // a small kernel send buffer per client (the kernel would otherwise take megabytes of a client
    // that does not read before our bound applies) and no Nagle delay for the small frames
    asio::error_code ignore;
    asio::ip::tcp::socket& sock = server.get_con_from_hdl(h)->get_socket();
    sock.set_option(asio::socket_base::send_buffer_size(kSocketSendBuffer), ignore);
    sock.set_option(asio::ip::tcp::no_delay(true), ignore);
    clients.emplace(h, Client{});
  }

  void set_handlers() {
    server.set_http_handler([this](Hdl h) { serve_http(h); });
    server.set_validate_handler([this](Hdl h) { return server.get_con_from_hdl(h)->get_resource() == "/ws"; });
    server.set_open_handler([this](Hdl h) { open_client(h); });
    server.set_close_handler([this](Hdl h) { clients.erase(h); });
    server.set_fail_handler([this](Hdl h) { clients.erase(h); });
  }

  bool listen(const std::string& host, const std::string& port, const std::string& listen_arg) {
    websocketpp::lib::error_code ec;
    server.listen(host, port, ec);
    if (ec) {
      std::fprintf(stderr, "coopdyn view: cannot listen on %s: %s\n", listen_arg.c_str(), ec.message().c_str());
      return false;
    }
    server.start_accept(ec);
    if (ec) {
      std::fprintf(stderr, "coopdyn view: cannot accept on %s: %s\n", listen_arg.c_str(), ec.message().c_str());
      return false;
    }
    return true;
  }
};

// The LCM receive thread's own state: each output taken (at most max_rate_hz) becomes a frame's
// JSON in the server's inbox.
struct FrameMaker {
  FrameMaker(const System& sys_, const ViewVisuals& vis, const std::string& channel_, double max_rate_hz, LiveServer& live_)
      : sys(sys_), channel(channel_), live(live_), vf(view_geometry(sys_, &vis)), data(sys_.model),
        min_gap_ns(static_cast<long long>(1e9 / max_rate_hz)) {}

  const System& sys;
  const std::string& channel;
  LiveServer& live;
  ViewFrames vf;
  Data data;
  io::DecodedOutput o;
  std::string why;
  const long long min_gap_ns;
  long long last_ns = 0;
  bool warned = false;
  ViewSample s, last_pose;  // last_pose: the last sample with its own pose (held by error outputs)

  void on_output(const void* d, int n, long long recv_ns) {
    Counters& count = live.count;
    ++count.received;
    if (last_ns != 0 && recv_ns - last_ns < min_gap_ns) {
      ++count.skipped_rate;
      return;
    }
    if (!io::decode_output(d, n, &o)) {
      ++count.undecodable;
      return;
    }
    if (!sample_of_output(sys, vf, o, &s, &why, &last_pose)) {
      if (!warned) std::fprintf(stderr, "coopdyn view: an output on '%s' %s: ignored\n", channel.c_str(), why.c_str());
      warned = true;
      ++count.mismatched;
      return;
    }
    last_ns = recv_ns;
    if (!s.pose_held) last_pose = s;
    vf.clear_frames();
    add_view_frame(sys, data, s, &vf);
    auto json = std::make_shared<const std::string>(view_frame_json(vf, 0));
    ++count.framed;
    live.post_frame(std::move(json));
  }
};

}  // namespace

int run_view_live(const System& sys, const ViewVisuals& vis, const std::string& three_js, const std::string& loaders,
                  const std::string& listen, const std::string& lcm_url, const std::string& channel, double max_rate_hz,
                  int queue_frames) {
  std::string host, port;
  if (!parse_listen(listen, &host, &port)) return 2;
  LiveServer live(static_cast<size_t>(queue_frames), live_page(sys, vis, three_js, loaders, "live: " + channel + " on " + lcm_url));
  Server& server = live.server;
  if (!live.start()) return 1;
  live.set_handlers();
  if (!live.listen(host, port, listen)) return 1;
  websocketpp::lib::error_code ec;
  const auto ep = server.get_local_endpoint(ec);

  warn_loopback_multicast("view", lcm_url);
  std::unique_ptr<io::LcmBus> bus;
  try {
    bus = std::make_unique<io::LcmBus>(lcm_url);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "coopdyn view: %s\n", e.what());
    return 1;
  }
  FrameMaker frames(sys, vis, channel, max_rate_hz, live);
  bus->subscribe(channel, [&](const void* d, int n, long long recv_ns) { frames.on_output(d, n, recv_ns); });

  asio::signal_set stop_signals(server.get_io_service(), SIGINT, SIGTERM);
  stop_signals.async_wait([&](const asio::error_code& e, int) {
    if (e) return;
    websocketpp::lib::error_code ignore;
    server.stop_listening(ignore);
    for (auto& [h, c] : live.clients) server.close(h, websocketpp::close::status::going_away, "coopdyn view stops", ignore);
    bus->stop();
    server.get_io_service().post([&] { server.stop(); });
  });

  bus->start();
  std::fprintf(stderr, "coopdyn view: scene '%s', output_t on '%s' from %s; serving http://%s:%u/ (stop: Ctrl-C)\n",
               sys.name.c_str(), channel.c_str(), lcm_url.c_str(), ep.address().to_string().c_str(),
               static_cast<unsigned>(ep.port()));
  std::fflush(stderr);
  try {
    server.run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "coopdyn view: server: %s\n", e.what());
    bus->stop();
    return 1;
  }
  bus->stop();
  std::fprintf(stderr, "coopdyn view: stopped: %s\n", json_stats(live.count, live.clients.size(), 0, 0).c_str());
  return 0;
}

}  // namespace coopdyn::cli
