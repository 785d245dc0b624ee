// coopdyn view: the page it writes, checked in a real headless Chromium (skipped, saying so, when
// Chromium or three.js is not installed), and its errors on bad input.
//
// The browser tests run `coopdyn sim` and `coopdyn view`, then headless Chromium, driven over its
// DevTools protocol, on the page with a hash that picks the frame (#t=, #slider=) and pauses. Each
// waits for the event it needs (the page set up, a played time, frames received), never for a
// fixed time. They read the page's DOM (the title, which carries any JavaScript error, the time
// text and the #probe element with the camera) and its screenshot (PNG, read with libpng). The
// expected arrow is computed here, not by the page: the wrench columns of the CSV row, the report
// frame's pose from this process's own forward kinematics of the row's q, the force scale the page
// shows, and a pinhole projection with the page's camera.
#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>
#include <fcntl.h>
#include <poll.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "service/algorithms/kinematics.h"
#include "service/dynamics/wrenches.h"
#include "service/io/codec.h"
#include "tests/support/child_process.h"
#include "service/constraints/constraints.h"
#include "service/scene/scene.h"

namespace coopdyn {
namespace {
using coopdyn::daemon_test::private_udpm_url;

namespace fs = std::filesystem;
const std::string kSrc = COOPDYN_SOURCE_DIR;
const std::string kBin = COOPDYN_BIN;
const char kThree[] = "/usr/share/javascript/three/three.min.js";

std::string scene_file(const std::string& name) { return kSrc + "/config/scenes/" + name + ".yaml"; }

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// A fresh directory per test, removed at the end.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name) {
    path = fs::temp_directory_path() / ("coopdyn_view_test_" + std::to_string(getpid()) + "_" + name);
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    if (!std::getenv("COOPDYN_KEEP_TEST_FILES")) fs::remove_all(path, ec);
  }
  std::string operator/(const std::string& f) const { return (path / f).string(); }
};

// Runs a shell command; returns its exit status and its stderr in *err.
int run(const std::string& cmd, const std::string& err_file, std::string* err = nullptr) {
  const int rc = std::system((cmd + " 2> '" + err_file + "'").c_str());
  if (err) *err = slurp(err_file);
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

int sim(const std::string& scene, double duration, double dt, const std::string& csv, const std::string& err_file) {
  char buf[64];
  std::snprintf(buf, sizeof buf, " --duration %g --dt %g", duration, dt);
  return run("'" + kBin + "' sim --scene '" + scene_file(scene) + "'" + buf + " --out '" + csv + "'", err_file);
}

int view(const std::string& scene_path, const std::string& csv, const std::string& html, const std::string& err_file,
         std::string* err, const std::string& extra = "") {
  return run("'" + kBin + "' view --scene '" + scene_path + "' --csv '" + csv + "' --out '" + html + "' " + extra, err_file, err);
}

std::string find_chromium() {
  if (const char* c = std::getenv("COOPDYN_CHROMIUM")) return c;
  for (const char* n : {"chromium", "chromium-browser"}) {
    const char* path = std::getenv("PATH");
    std::stringstream ss(path ? path : "/usr/bin:/bin");
    std::string dir;
    while (std::getline(ss, dir, ':'))
      if (!dir.empty() && access((dir + "/" + n).c_str(), X_OK) == 0) return dir + "/" + n;
  }
  return "";
}

#define REQUIRE_BROWSER()                                                                                  \
  const std::string chromium = find_chromium();                                                            \
  if (chromium.empty())                                                                                    \
    GTEST_SKIP() << "Chromium not installed (Debian: apt-get install chromium, or set COOPDYN_CHROMIUM): " \
                    "browser test skipped";                                                                \
  if (!fs::exists(kThree)) GTEST_SKIP() << kThree << " missing (Debian: apt-get install libjs-three): browser test skipped"

struct Image {
  int w = 0, h = 0;
  std::vector<unsigned char> rgb;
  const unsigned char* at(int x, int y) const { return &rgb[3 * (static_cast<size_t>(y) * w + x)]; }
};

bool read_png(const std::vector<unsigned char>& bytes, Image* im) {
  png_image p{};
  p.version = PNG_IMAGE_VERSION;
  if (bytes.empty() || !png_image_begin_read_from_memory(&p, bytes.data(), bytes.size())) return false;
  p.format = PNG_FORMAT_RGB;
  im->w = static_cast<int>(p.width);
  im->h = static_cast<int>(p.height);
  im->rgb.resize(PNG_IMAGE_SIZE(p));
  if (!png_image_finish_read(&p, nullptr, im->rgb.data(), 0, nullptr)) {
    png_image_free(&p);
    return false;
  }
  return true;
}

std::vector<unsigned char> base64_decode(const std::string& s) {
  std::vector<unsigned char> out;
  unsigned acc = 0;
  int bits = 0;
  for (const char c : s) {
    int v;
    if (c >= 'A' && c <= 'Z') v = c - 'A';
    else if (c >= 'a' && c <= 'z') v = c - 'a' + 26;
    else if (c >= '0' && c <= '9') v = c - '0' + 52;
    else if (c == '+') v = 62;
    else if (c == '/') v = 63;
    else continue;  // '=' and what is not base64
    acc = (acc << 6) | static_cast<unsigned>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<unsigned char>(acc >> bits));
      acc &= (1u << bits) - 1;
    }
  }
  return out;
}

std::string between(const std::string& s, const std::string& a, const std::string& b) {
  const size_t i = s.find(a);
  if (i == std::string::npos) return "";
  const size_t j = s.find(b, i + a.size());
  return j == std::string::npos ? "" : s.substr(i + a.size(), j - i - a.size());
}
double num_after(const std::string& s, const std::string& key) {
  const size_t i = s.find(key);
  return i == std::string::npos ? NAN : std::strtod(s.c_str() + i + key.size(), nullptr);
}
Vec3 vec_after(const std::string& s, const std::string& key) {  // key ends with '['
  size_t i = s.find(key);
  if (i == std::string::npos) return Vec3::Constant(NAN);
  const char* p = s.c_str() + i + key.size();
  Vec3 v;
  for (int k = 0; k < 3; ++k) {
    char* end;
    v[k] = std::strtod(p, &end);
    p = end + 1;  // the comma
  }
  return v;
}

// A JSON string literal of s.
std::string json_quote(const std::string& s) {
  std::string q = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') q += '\\', q += c;
    else if (c == '\n') q += "\\n";
    else if (static_cast<unsigned char>(c) < 0x20) {
      char u[8];
      std::snprintf(u, sizeof u, "\\u%04x", c);
      q += u;
    } else q += c;
  }
  return q + "\"";
}
// The JSON string literal that starts at s[at] (its opening quote), unescaped (\uXXXX as UTF-8).
std::string json_unquote(const std::string& s, size_t at) {
  std::string out;
  auto utf8 = [&](unsigned cp) {
    if (cp < 0x80) out += static_cast<char>(cp);
    else if (cp < 0x800) out += static_cast<char>(0xC0 | cp >> 6), out += static_cast<char>(0x80 | (cp & 0x3F));
    else if (cp < 0x10000)
      out += static_cast<char>(0xE0 | cp >> 12), out += static_cast<char>(0x80 | (cp >> 6 & 0x3F)),
          out += static_cast<char>(0x80 | (cp & 0x3F));
    else
      out += static_cast<char>(0xF0 | cp >> 18), out += static_cast<char>(0x80 | (cp >> 12 & 0x3F)),
          out += static_cast<char>(0x80 | (cp >> 6 & 0x3F)), out += static_cast<char>(0x80 | (cp & 0x3F));
  };
  for (size_t i = at + 1; i < s.size() && s[i] != '"'; ++i) {
    if (s[i] != '\\' || i + 1 >= s.size()) {
      out += s[i];
      continue;
    }
    const char e = s[++i];
    if (e == 'n') out += '\n';
    else if (e == 't') out += '\t';
    else if (e == 'r') out += '\r';
    else if (e == 'b') out += '\b';
    else if (e == 'f') out += '\f';
    else if (e == 'u' && i + 4 < s.size()) {
      unsigned cp = static_cast<unsigned>(std::stoul(s.substr(i + 1, 4), nullptr, 16));
      i += 4;
      if (cp >= 0xD800 && cp < 0xDC00 && i + 6 < s.size() && s[i + 1] == '\\' && s[i + 2] == 'u') {
        const unsigned lo = static_cast<unsigned>(std::stoul(s.substr(i + 3, 4), nullptr, 16));
        cp = 0x10000 + ((cp - 0xD800) << 10) + (lo - 0xDC00);
        i += 6;
      }
      utf8(cp);
    } else out += e;  // \" \\ \/
  }
  return out;
}

// What a page's DOM says about itself.
struct PageState {
  std::string title, time_text, probe, error;
  bool ready = false;
  int frame = -1;
  double t = NAN, force_scale = NAN, fov = NAN;
  double canvas_x = NAN, canvas_y = NAN, canvas_w = NAN, canvas_h = NAN;  // the 3D canvas in the page, CSS px
  double window_w = NAN, window_h = NAN;                                  // the page's viewport
  Vec3 eye, target, up;
};
PageState page_state(const std::string& dom) {
  PageState s;
  s.title = between(dom, "<title>", "</title>");
  s.time_text = between(dom, "<span id=\"time\">", "</span>");
  s.error = between(dom, "<div id=\"error\"", "</div>");
  s.probe = between(dom, "<pre id=\"probe\">", "</pre>");
  s.ready = dom.find("data-ready=\"1\"") != std::string::npos;
  s.frame = static_cast<int>(num_after(s.probe, "\"frame\":"));
  s.t = num_after(s.probe, "\"t\":");
  s.force_scale = num_after(s.probe, "\"force_scale\":");
  s.fov = num_after(s.probe, "\"fov\":");
  const std::string canvas = between(s.probe, "\"canvas\":{", "}");
  s.canvas_x = num_after(canvas, "\"left\":");
  s.canvas_y = num_after(canvas, "\"top\":");
  s.canvas_w = num_after(canvas, "\"width\":");
  s.canvas_h = num_after(canvas, "\"height\":");
  const std::string window = between(s.probe, "\"window\":{", "}");
  s.window_w = num_after(window, "\"width\":");
  s.window_h = num_after(window, "\"height\":");
  s.eye = vec_after(s.probe, "\"eye\":[");
  s.target = vec_after(s.probe, "\"target\":[");
  s.up = vec_after(s.probe, "\"up\":[");
  return s;
}

// Headless Chromium driven over the DevTools protocol, in real time: a test waits until the page
// reports what it needs (set up, a played time, frames received), however long the machine takes,
// instead of giving Chromium a virtual-time budget and judging what fitted in it; one browser serves
// a test's pages, one tab at a time. The protocol runs on a pipe (--remote-debugging-pipe: Chromium reads commands on its fd 3 and
// writes replies and events on its fd 4, each a JSON text ended by a NUL).
class DevTools {
 public:
  DevTools(const std::string& chromium, const TempDir& dir, const std::string& tag) : log_(dir / (tag + ".chromium.log")) {
    int cmd[2], rep[2];
    if (pipe2(cmd, O_CLOEXEC) != 0) return;
    if (pipe2(rep, O_CLOEXEC) != 0) {
      close(cmd[0]), close(cmd[1]);
      return;
    }
    // Chromium's ends above 3 and 4 first, so that the dup2s below never leave one in place
    const int in = fcntl(cmd[0], F_DUPFD_CLOEXEC, 10), out = fcntl(rep[1], F_DUPFD_CLOEXEC, 10);
    close(cmd[0]), close(rep[1]);
    to_ = cmd[1], from_ = rep[0];
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, in, 3);
    posix_spawn_file_actions_adddup2(&fa, out, 4);
    posix_spawn_file_actions_addopen(&fa, 1, log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    const std::vector<std::string> argv{chromium, "--headless", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
                                        "--enable-unsafe-swiftshader", "--hide-scrollbars", "--mute-audio", "--no-first-run",
                                        "--user-data-dir=" + dir / (tag + ".profile"), "--window-size=900,600",
                                        "--remote-debugging-pipe", "about:blank"};
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    if (posix_spawn(&pid_, args[0], &fa, nullptr, args.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&fa);
    close(in), close(out);
  }
  ~DevTools() {
    if (pid_ > 0 && to_ >= 0) session_.clear(), call("Browser.close", "{}", 5);
    if (to_ >= 0) close(to_);
    if (from_ >= 0) close(from_);
    if (pid_ <= 0) return;
    for (int i = 0; i < 500; ++i) {  // 10 s
      if (waitpid(pid_, nullptr, WNOHANG) == pid_) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
  }
  // Opens url in a new tab, which later calls talk to. Empty on success, else what went wrong.
  std::string open(const std::string& url) {
    if (pid_ <= 0) return "cannot start Chromium";
    close_tab();
    std::string r = call("Target.createTarget", "{\"url\":\"about:blank\"}", 60);
    target_ = between(r, "\"targetId\":\"", "\"");
    if (target_.empty()) return "Target.createTarget: '" + r + "'; " + log();
    r = call("Target.attachToTarget", "{\"targetId\":\"" + target_ + "\",\"flatten\":true}", 60);
    session_ = between(r, "\"sessionId\":\"", "\"");
    if (session_.empty()) return "Target.attachToTarget: '" + r + "'; " + log();
    // the page laid out in the 900 x 600 CSS px its screenshots have
    r = call("Emulation.setDeviceMetricsOverride", "{\"width\":900,\"height\":600,\"deviceScaleFactor\":1,\"mobile\":false}", 60);
    if (r.find("\"result\":{}") == std::string::npos) return "Emulation.setDeviceMetricsOverride: '" + r + "'";
    r = call("Page.navigate", "{\"url\":" + json_quote(url) + "}", 60);
    return r.find("\"frameId\"") == std::string::npos || r.find("\"errorText\"") != std::string::npos
               ? "Page.navigate: '" + r + "'"
               : "";
  }
  // Closes the tab open() opened, if any.
  void close_tab() {
    session_.clear();
    if (!target_.empty()) call("Target.closeTarget", "{\"targetId\":\"" + target_ + "\"}", 60);
    target_.clear();
  }
  // Opens url and waits (at most 60 s) until the page has finished setting itself up (data-ready)
  // or failed (a JavaScript error in its title); its snapshot() then, or "" and *why.
  std::string load(const std::string& url, std::string* why) {
    *why = open(url);
    if (!why->empty()) return "";
    std::string dom;
    if (!wait_until([](const std::string& d) { return page_state(d).ready || d.find("JSERROR") != std::string::npos; },
                    60, &dom))
      *why = "not ready in 60 s: " + dom.substr(0, 2000) + "\n" + log();
    return dom;
  }
  // The value of a JavaScript expression that gives a string, in the page ("" on failure).
  std::string eval(const std::string& expr) {
    const std::string r = call("Runtime.evaluate", "{\"expression\":" + json_quote(expr) + ",\"returnByValue\":true}", 60);
    const size_t at = r.find("\"type\":\"string\",\"value\":\"");
    return at == std::string::npos ? "" : json_unquote(r, at + 24);
  }
  // What the page's DOM says about itself, for page_state: the title, whether it is ready and the
  // elements #time, #probe, #live, #error as they are now.
  std::string snapshot() {
    return eval(R"((function () {
      var h = function (id) { var e = document.getElementById(id); return e ? e.outerHTML : ''; };
      return '<title>' + document.title + '</title>' + h('time') + h('probe') + h('live') + h('error') +
             (document.body && document.body.getAttribute('data-ready') === '1' ? ' data-ready="1"' : '');
    })())");
  }
  // Polls snapshot() until done(it) or timeout_s; returns the last snapshot in *last.
  bool wait_until(const std::function<bool(const std::string&)>& done, double timeout_s, std::string* last) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (true) {
      *last = snapshot();
      if (done(*last)) return true;
      if (std::chrono::steady_clock::now() > end) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
  // The whole DOM now, as --dump-dom writes it.
  std::string dom() { return eval("document.documentElement.outerHTML"); }
  // A screenshot of the page now.
  bool screenshot(Image* im) {
    const std::string r = call("Page.captureScreenshot", "{\"format\":\"png\"}", 60);
    return read_png(base64_decode(between(r, "\"data\":\"", "\"")), im);
  }
  std::string log() const { return slurp(log_).substr(0, 3000); }

 private:
  // Sends a command; returns its reply (the message with its id), or "" after timeout_s.
  std::string call(const std::string& method, const std::string& params, double timeout_s) {
    const int id = next_id_++;
    std::string msg = "{\"id\":" + std::to_string(id) + (session_.empty() ? "" : ",\"sessionId\":\"" + session_ + "\"") +
                      ",\"method\":\"" + method + "\",\"params\":" + params + "}";
    msg.push_back('\0');
    for (size_t off = 0; off < msg.size();) {
      const ssize_t n = write(to_, msg.data() + off, msg.size() - off);
      if (n <= 0) return "";
      off += static_cast<size_t>(n);
    }
    const std::string mine = "{\"id\":" + std::to_string(id) + ",";
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (true) {
      for (size_t z; (z = buf_.find('\0')) != std::string::npos;) {
        std::string m = buf_.substr(0, z);
        buf_.erase(0, z + 1);
        if (m.rfind(mine, 0) == 0) return m;  // (events and other replies are not waited for)
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
      pollfd p{from_, POLLIN, 0};
      if (left.count() <= 0 || poll(&p, 1, static_cast<int>(left.count())) <= 0) return "";
      char b[65536];
      const ssize_t n = read(from_, b, sizeof b);
      if (n <= 0) return "";
      buf_.append(b, static_cast<size_t>(n));
    }
  }

  std::string log_, buf_, session_, target_;
  pid_t pid_ = -1;
  int to_ = -1, from_ = -1, next_id_ = 1;
};

// A page with `hash` in the browser, once it has set itself up: its DOM and, if asked, a screenshot
// (the same 900 x 600 CSS px the DOM was laid out in).
struct Browse {
  std::string dom;
  Image shot;
  bool ok = false;
  std::string log;
};
Browse browse(DevTools& browser, const std::string& html, const std::string& hash, bool screenshot) {
  Browse b;
  b.dom = browser.load("file://" + html + "#" + hash, &b.log);
  if (!b.log.empty()) return b;
  b.dom = browser.dom();
  if (screenshot && !browser.screenshot(&b.shot)) {
    b.log = "no screenshot; " + browser.log();
    return b;
  }
  const PageState p = page_state(b.dom);
  if (screenshot && (b.shot.w != p.window_w || b.shot.h != p.window_h)) {
    b.log = "a screenshot of " + std::to_string(b.shot.w) + " x " + std::to_string(b.shot.h) + " px of a page laid out in " +
            std::to_string(p.window_w) + " x " + std::to_string(p.window_h);
    return b;
  }
  b.ok = !b.dom.empty();
  return b;
}

// Pinhole projection as three.js's PerspectiveCamera.lookAt(target) with camera.up: the pixel of
// the page (x right, y down) where p falls in the page's 3D canvas (its rectangle from the probe).
Eigen::Vector2d project(const PageState& c, const Vec3& p) {
  const double w = c.canvas_w, h = c.canvas_h;
  const Vec3 z = (c.eye - c.target).normalized(), x = c.up.cross(z).normalized(), y = z.cross(x);
  const Vec3 d = p - c.eye;
  const double depth = -d.dot(z), f = 1.0 / std::tan(c.fov * M_PI / 360.0);
  const double nx = f * d.dot(x) / (depth * (w / h)), ny = f * d.dot(y) / depth;
  return {c.canvas_x + (nx + 1) / 2 * w, c.canvas_y + (1 - ny) / 2 * h};
}

// The pixels of the screenshot inside the page's 3D canvas that are of a colour.
int count_in_canvas(const Image& im, const PageState& p, bool (*is_colour)(const unsigned char*)) {
  int n = 0;
  for (int y = static_cast<int>(p.canvas_y); y < std::min<int>(im.h, static_cast<int>(p.canvas_y + p.canvas_h)); ++y)
    for (int x = static_cast<int>(p.canvas_x); x < std::min<int>(im.w, static_cast<int>(p.canvas_x + p.canvas_w)); ++x)
      n += is_colour(im.at(x, y));
  return n;
}

// The CSV row at time t: every column by name.
std::map<std::string, std::string> csv_row(const std::string& csv, double t) {
  std::ifstream f(csv);
  std::string line;
  while (std::getline(f, line) && !line.empty() && line[0] == '#') {}  // the comment and units lines
  std::vector<std::string> head;
  {
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) head.push_back(c);
  }
  while (std::getline(f, line)) {
    std::stringstream ss(line);
    std::string c;
    std::vector<std::string> cells;
    while (std::getline(ss, c, ',')) cells.push_back(c);
    if (cells.size() == head.size() && std::abs(std::stod(cells[0]) - t) < 1e-9) {
      std::map<std::string, std::string> r;
      for (size_t i = 0; i < head.size(); ++i) r[head[i]] = cells[i];
      return r;
    }
  }
  return {};
}

// The force of wrench `name` at the CSV row at time t, in the world: its application point and the
// force vector, from the row's q (own forward kinematics) and the row's wrench columns.
struct WorldForce {
  Vec3 origin, force, moment;
};
WorldForce world_force(const System& sys, const std::string& csv, double t, const std::string& name) {
  const auto row = csv_row(csv, t);
  EXPECT_FALSE(row.empty()) << "no row at t=" << t << " in " << csv;
  const Model& m = sys.model;
  Eigen::VectorXd q(m.nq());
  for (int i = 0; i < m.nq(); ++i) q[i] = std::stod(row.at("q:" + m.q_names[i]));
  Data data(m);
  forward_kinematics(m, data, q, Eigen::VectorXd::Zero(m.nv()));
  const Vec3 f_F(std::stod(row.at(name + ".fx")), std::stod(row.at(name + ".fy")), std::stod(row.at(name + ".fz")));
  const Vec3 m_F(std::stod(row.at(name + ".mx")), std::stod(row.at(name + ".my")), std::stod(row.at(name + ".mz")));
  for (const ConstraintSpec& c : sys.constraints.specs)
    if (c.kind == ConstraintKind::kRolling && c.name == name) {  // a wheel's ground force: the contact frame
      const Transform X = rolling_contact_frame(m, data, c);
      return {X.p, X.R * f_F, X.R * m_F};
    }
  for (const WrenchOutput& o : sys.wrenches.outputs)
    if (o.name == name) {
      const int fi = m.frame_index(o.frame);
      EXPECT_GE(fi, 0) << "frame " << o.frame << " of " << name << " is not a model frame";
      if (fi < 0) break;
      const Transform X = frame_pose(m, data, fi);
      return {X.p, X.R * f_F, X.R * m_F};
    }
  ADD_FAILURE() << "no wrench " << name;
  return {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
}

bool is_force_colour(const unsigned char* p) { return p[0] > 200 && p[1] < 90 && p[2] > 200; }   // #ff00ff
bool is_moment_colour(const unsigned char* p) { return p[0] < 90 && p[1] > 200 && p[2] > 200; }  // #00ffff

// The force-coloured pixels of the canvas form an arrow from the projection of its origin to the
// projection of its tip: none before the origin or past the tip (a few pixels of antialiasing
// aside), some at both ends, none far from the line between them.
bool is_indet_force_colour(const unsigned char* p) { return p[0] > 200 && p[1] > 90 && p[1] < 170 && p[2] < 60; }  // #ff8000
void expect_arrow_at(const Image& im, const PageState& p, const Eigen::Vector2d& o, const Eigen::Vector2d& tip,
                     const std::string& what, bool (*is_colour)(const unsigned char*) = is_force_colour) {
  const Eigen::Vector2d axis = tip - o;
  const double L = axis.norm();
  ASSERT_GT(L, 30) << what << ": the projected arrow is too short to judge (" << L << " px)";
  const Eigen::Vector2d u = axis / L;
  double smin = INFINITY, smax = -INFINITY, dmax = 0;
  int n = 0;
  for (int y = static_cast<int>(p.canvas_y); y < std::min<int>(im.h, static_cast<int>(p.canvas_y + p.canvas_h)); ++y)
    for (int x = static_cast<int>(p.canvas_x); x < std::min<int>(im.w, static_cast<int>(p.canvas_x + p.canvas_w)); ++x) {
      if (!is_colour(im.at(x, y))) continue;
      const Eigen::Vector2d d = Eigen::Vector2d(x + 0.5, y + 0.5) - o;
      const double s = d.dot(u);
      smin = std::min(smin, s);
      smax = std::max(smax, s);
      dmax = std::max(dmax, std::abs(d.x() * u.y() - d.y() * u.x()));
      ++n;
    }
  ASSERT_GT(n, 30) << what << ": no force arrow in the screenshot (expected from (" << o.transpose() << ") to ("
                   << tip.transpose() << "))";
  EXPECT_NEAR(smax, L, 5) << what << ": the arrow's tip is off its projection " << tip.transpose();
  EXPECT_NEAR(smin, 0, 5) << what << ": the arrow's base is off its projection " << o.transpose();
  EXPECT_LT(dmax, 0.2 * L + 4) << what << ": force-coloured pixels away from the arrow's line";
}

// ---------------------------------------------------------------------------------------------
// Bad input: a clear error naming the file, exit status 1, no page.

TEST(ViewErrors, NameTheFile) {
  TempDir dir("errors");
  ASSERT_EQ(sim("unicycle", 0.05, 0.01, dir / "u.csv", dir / "sim.err"), 0) << slurp(dir / "sim.err");
  const std::string fake_three = dir / "three.min.js";
  std::ofstream(fake_three) << "/* stand-in */ var THREE = {WebGLRenderer: null};\n";
  const std::string three = "--three-js '" + fake_three + "'";
  std::string err;

  // three.js missing or not three.js
  EXPECT_EQ(view(scene_file("unicycle"), dir / "u.csv", dir / "a.html", dir / "e", &err, "--three-js /nonexistent/three.min.js"), 1);
  EXPECT_NE(err.find("/nonexistent/three.min.js"), std::string::npos) << err;
  EXPECT_NE(err.find("libjs-three"), std::string::npos) << err;
  EXPECT_EQ(view(scene_file("unicycle"), dir / "u.csv", dir / "a.html", dir / "e", &err, "--three-js '" + dir / "u.csv" + "'"), 1);
  EXPECT_NE(err.find("is not three.js"), std::string::npos) << err;

  // the CSV of another scene
  EXPECT_EQ(view(scene_file("four_bar"), dir / "u.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "u.csv"), std::string::npos) << err;
  EXPECT_NE(err.find("four_bar"), std::string::npos) << err;

  // a missing wrench column, a short row, a bad number, no rows, no file
  const std::string csv = slurp(dir / "u.csv");
  // the comment and units lines, then the header at line hl (clients/csv/step_csv.h)
  size_t pos = 0;
  int hl = 1;
  while (csv[pos] == '#') pos = csv.find('\n', pos) + 1, ++hl;
  const std::string pre = csv.substr(0, pos), header = csv.substr(pos, csv.find('\n', pos) - pos);
  const std::string rest = csv.substr(csv.find('\n', pos));  // from the header's newline
  const std::string at_header = ":" + std::to_string(hl), at_row1 = ":" + std::to_string(hl + 1);
  {
    std::string h = header;
    const size_t at = h.find(",wheel.fz");
    ASSERT_NE(at, std::string::npos) << header;
    h.replace(at, 9, ",wheel.FZ");
    std::ofstream(dir / "nocol.csv") << pre << h << rest;
  }
  EXPECT_EQ(view(scene_file("unicycle"), dir / "nocol.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "nocol.csv" + at_header + ": no column 'wheel.fz'"), std::string::npos) << err;

  std::ofstream(dir / "short.csv") << pre << header << "\n" << rest.substr(1, 20) << "\n";
  EXPECT_EQ(view(scene_file("unicycle"), dir / "short.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "short.csv" + at_row1 + ":"), std::string::npos) << err;

  {
    std::string body = rest.substr(1);
    body.replace(body.find(','), 1, ",x");  // the first q of the first row
    std::ofstream(dir / "bad.csv") << pre << header << "\n" << body;
  }
  EXPECT_EQ(view(scene_file("unicycle"), dir / "bad.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "bad.csv" + at_row1 + ": bad number"), std::string::npos) << err;

  {  // a contact state that is none of ok, slip, lift_off; the contact report's columns missing
    std::string body = rest.substr(1);
    const size_t at = body.find(",-1,ok,ok,");
    ASSERT_NE(at, std::string::npos) << body.substr(0, body.find('\n'));
    body.replace(at, 10, ",-1,skid,ok,");
    std::ofstream(dir / "state.csv") << pre << header << "\n" << body;
    std::string h = header;
    h.replace(h.find(",wheel.utilisation"), 18, ",wheel.utilization");
    std::ofstream(dir / "nocontact.csv") << pre << h << rest;
  }
  EXPECT_EQ(view(scene_file("unicycle"), dir / "state.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "state.csv" + at_row1 + ": unknown contact state 'skid' in column 'wheel.contact'"), std::string::npos) << err;
  EXPECT_EQ(view(scene_file("unicycle"), dir / "nocontact.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "nocontact.csv" + at_header + ": no column 'wheel.utilisation'"), std::string::npos) << err;

  // a units line that does not match the header
  std::ofstream(dir / "units.csv") << "# units: s\n" << header << rest;
  EXPECT_EQ(view(scene_file("unicycle"), dir / "units.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "units.csv" + ":1: 1 units for "), std::string::npos) << err;

  std::ofstream(dir / "empty.csv") << pre << header << "\n";
  EXPECT_EQ(view(scene_file("unicycle"), dir / "empty.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "empty.csv" + ": no rows"), std::string::npos) << err;

  EXPECT_EQ(view(scene_file("unicycle"), dir / "none.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find("cannot open '" + dir / "none.csv" + "'"), std::string::npos) << err;

  EXPECT_FALSE(fs::exists(dir / "a.html"));
}

// The page holds everything (no address to fetch), three.js inline, at most --max-frames frames,
// the first and the last row always among them.
TEST(ViewPage, SelfContainedAndSubsampled) {
  TempDir dir("page");
  ASSERT_EQ(sim("unicycle", 3, 0.001, dir / "u.csv", dir / "sim.err"), 0) << slurp(dir / "sim.err");
  const std::string fake_three = dir / "three.min.js";
  std::ofstream(fake_three) << "/* stand-in */ var THREE_STAND_IN = 'WebGLRenderer';\n";
  std::string err;
  ASSERT_EQ(view(scene_file("unicycle"), dir / "u.csv", dir / "u.html", dir / "e", &err, "--three-js '" + fake_three + "'"), 0) << err;
  const std::string page = slurp(dir / "u.html");
  EXPECT_NE(page.find("var THREE_STAND_IN = 'WebGLRenderer';"), std::string::npos);
  for (const char* ref : {"src=", "href=", "http:", "https:", "<link", "import("}) EXPECT_EQ(page.find(ref), std::string::npos) << ref;
  const std::string t = between(page, "\"t\":[", "]");
  ASSERT_FALSE(t.empty());
  const long commas = std::count(t.begin(), t.end(), ',');
  EXPECT_EQ(commas + 1, 2000);  // 3001 rows -> the default cap
  EXPECT_EQ(t.substr(0, 2), "0,");
  EXPECT_EQ(t.substr(t.rfind(',') + 1), "3");

  ASSERT_EQ(view(scene_file("unicycle"), dir / "u.csv", dir / "v.html", dir / "e", &err,
                 "--max-frames 7 --three-js '" + fake_three + "'"), 0) << err;
  EXPECT_EQ(between(slurp(dir / "v.html"), "\"t\":[", "]"), "0,0.5,1,1.5,2,2.5,3");
}

// ---------------------------------------------------------------------------------------------
// In the browser.

// Every shipped scene's page loads and renders with no JavaScript error, at the frame the hash asks.
TEST(ViewBrowser, EveryShippedSceneLoads) {
  REQUIRE_BROWSER();
  TempDir dir("scenes");
  std::vector<std::string> scenes;
  for (const auto& e : fs::directory_iterator(kSrc + "/config/scenes"))
    if (e.path().extension() == ".yaml") scenes.push_back(e.path().stem().string());
  std::sort(scenes.begin(), scenes.end());
  ASSERT_GE(scenes.size(), 6u);
  for (const auto& s : scenes) {
    ASSERT_EQ(sim(s, 0.5, 0.005, dir / (s + ".csv"), dir / "sim.err"), 0) << s << ": " << slurp(dir / "sim.err");
    std::string err;
    ASSERT_EQ(view(scene_file(s), dir / (s + ".csv"), dir / (s + ".html"), dir / "e", &err), 0) << s << ": " << err;
  }
  // one browser, one page after the other, each judged once it has set itself up
  DevTools browser(chromium, dir, "scenes");
  for (const auto& s : scenes) {
    std::string why;
    const std::string dom = browser.load("file://" + dir / (s + ".html") + "#t=0.25&paused=1", &why);
    ASSERT_EQ(why, "") << s;
    const PageState p = page_state(dom);
    const System sys = load_scene(scene_file(s));
    EXPECT_EQ(p.title, "coopdyn view: " + sys.name) << s << ": a JavaScript error, or the page did not finish";
    EXPECT_EQ(p.title.find("JSERROR"), std::string::npos) << s << ": " << p.title;
    EXPECT_TRUE(p.ready) << s;
    EXPECT_EQ(p.error, ">") << s << ": the page shows an error";  // <div id="error"></div>, empty
    EXPECT_EQ(p.frame, 50) << s << ": " << p.probe;
    EXPECT_DOUBLE_EQ(p.t, 0.25) << s;
    EXPECT_EQ(p.time_text, "t = 0.250 s") << s;
  }
}

// A wrench in a rotated frame: arm1's end-effector wrench of two_puma_load (in frame arm1.ee),
// drawn where its world direction projects, at a time picked by #t.
TEST(ViewBrowser, ForceArrowWhereProjected) {
  REQUIRE_BROWSER();
  TempDir dir("arrow");
  // with zero torque the arms fall and pull the box apart: 855 N on arm1's end-effector at 0.7 s
  ASSERT_EQ(sim("two_puma_load", 0.8, 0.005, dir / "p.csv", dir / "sim.err"), 0) << slurp(dir / "sim.err");
  std::string err;
  ASSERT_EQ(view(scene_file("two_puma_load"), dir / "p.csv", dir / "p.html", dir / "e", &err), 0) << err;
  DevTools browser(chromium, dir, "p");
  const Browse b = browse(browser, dir / "p.html", "t=0.7&paused=1&wrench=arm1.ee", true);
  ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
  const PageState p = page_state(b.dom);
  ASSERT_EQ(p.title, "coopdyn view: two_puma_load");
  ASSERT_DOUBLE_EQ(p.t, 0.7);
  ASSERT_LT(p.canvas_w, b.shot.w) << "the plot's panel beside the 3D view while a wrench is selected";
  ASSERT_GT(p.force_scale, 0);
  EXPECT_NE(b.dom.find("force <span id=\"fscale\">1 m = " + between(p.probe, "\"force_scale\":", ",") + " N</span>"), std::string::npos)
      << "the scale shown is not the one drawn";

  const System sys = load_scene(scene_file("two_puma_load"));
  const WorldForce wf = world_force(sys, dir / "p.csv", 0.7, "arm1.ee");
  EXPECT_GT(wf.force.norm(), 800);
  const Eigen::Vector2d o = project(p, wf.origin), tip = project(p, wf.origin + wf.force / p.force_scale);
  expect_arrow_at(b.shot, p, o, tip, "arm1.ee at t=0.7");
  // the moment arrow, in its own colour, when it is long enough to see
  const double moment_scale = num_after(p.probe, "\"moment_scale\":");
  const double lm = (project(p, wf.origin + wf.moment / moment_scale) - o).norm();
  const int cyan = count_in_canvas(b.shot, p, is_moment_colour);
  if (lm > 15) {
    EXPECT_GT(cyan, 10) << "no moment arrow (" << lm << " px long)";
  }
}

// Moving the time slider (the hash sets it and fires its input event, the handler dragging runs)
// shows another frame: the time text and the probe follow, and the rolling wheel's contact force,
// which has no moment, is drawn where each frame's projection says.
TEST(ViewBrowser, TimeSliderChangesFrame) {
  REQUIRE_BROWSER();
  TempDir dir("slider");
  ASSERT_EQ(sim("unicycle", 1, 0.005, dir / "u.csv", dir / "sim.err"), 0) << slurp(dir / "sim.err");
  std::string err;
  ASSERT_EQ(view(scene_file("unicycle"), dir / "u.csv", dir / "u.html", dir / "e", &err), 0) << err;
  const System sys = load_scene(scene_file("unicycle"));
  DevTools browser(chromium, dir, "u");
  const Browse b0 = browse(browser, dir / "u.html", "slider=40&paused=1", true);
  const Browse b = browse(browser, dir / "u.html", "slider=160&paused=1", true);
  std::vector<Eigen::Vector2d> tips;
  for (int k = 0; k < 2; ++k) {
    const Browse& br = k == 0 ? b0 : b;
    const int frame = k == 0 ? 40 : 160;
    ASSERT_TRUE(br.ok) << br.log.substr(0, 3000);
    const PageState p = page_state(br.dom);
    ASSERT_EQ(p.title, "coopdyn view: unicycle");
    EXPECT_EQ(p.frame, frame);
    const double t = frame * 0.005;
    EXPECT_NEAR(p.t, t, 1e-12);
    char text[32];
    std::snprintf(text, sizeof text, "t = %.3f s", t);
    EXPECT_EQ(p.time_text, text);
    const WorldForce wf = world_force(sys, dir / "u.csv", t, "wheel");
    EXPECT_NEAR(wf.force.z(), 3 * 9.81, 0.5);  // the wheel's weight, up, at the contact point
    const Eigen::Vector2d o = project(p, wf.origin), tip = project(p, wf.origin + wf.force / p.force_scale);
    expect_arrow_at(br.shot, p, o, tip, "wheel at frame " + std::to_string(frame));
    tips.push_back(tip);
    const int cyan = count_in_canvas(br.shot, p, is_moment_colour);
    EXPECT_EQ(cyan, 0) << "a moment arrow for a point contact";
  }
  ASSERT_EQ(tips.size(), 2u);
  EXPECT_GT((tips[1] - tips[0]).norm(), 50) << "the wheel rolled 1.2 m between the frames";
}

// Play: without `paused` the page advances on its own, on its animation clock, at the speed asked.
// Chromium runs in real time, driven over DevTools: the test waits until the page has played
// 400 ms (a run time of 0.1 s, 20 frames at a quarter of the speed), however long the machine
// takes to give it that, and judges the render that reported it.
TEST(ViewBrowser, Plays) {
  REQUIRE_BROWSER();
  TempDir dir("play");
  ASSERT_EQ(sim("four_bar", 2, 0.005, dir / "f.csv", dir / "sim.err"), 0) << slurp(dir / "sim.err");
  std::string err;
  ASSERT_EQ(view(scene_file("four_bar"), dir / "f.csv", dir / "f.html", dir / "e", &err), 0) << err;
  DevTools browser(chromium, dir, "f");
  const std::string opened = browser.open("file://" + dir / "f.html" + "#t=0&speed=0.25");
  ASSERT_EQ(opened, "");
  std::string dom;
  const bool played = browser.wait_until(
      [](const std::string& d) { return num_after(page_state(d).probe, "\"played_ms\":") >= 400; }, 60, &dom);
  const PageState p = page_state(dom);
  ASSERT_TRUE(played) << "the page did not play 400 ms in 60 s: " << p.title << " " << p.probe << "\n" << browser.log();
  ASSERT_EQ(p.title, "coopdyn view: four_bar");
  EXPECT_NE(p.probe.find("\"playing\":true"), std::string::npos) << p.probe;
  // the run advanced at a quarter of the animation clock (the 2 s run loops after 8 s of it), and
  // the frame shown is the last one at or before the run time
  const double played_ms = num_after(p.probe, "\"played_ms\":"), played_sim = num_after(p.probe, "\"played_sim\":");
  EXPECT_NEAR(played_sim, 0.25 * played_ms / 1000, 1e-9) << p.probe;
  EXPECT_LE(p.t, played_sim + 1e-12) << p.probe;
  EXPECT_GT(p.t, played_sim - 0.005 - 1e-12) << p.probe;
  EXPECT_GT(p.frame, 0) << p.probe;
}

// ---------------------------------------------------------------------------------------------
// From a daemon log: coopdynd runs over udpm on a private loopback port, this process receives its
// messages (a real LCM round trip) and writes them with LCM's event-log API as lcm-logger would.

struct Received {
  std::string channel;
  std::vector<uint8_t> data;
  int64_t utime;
};

// Runs coopdynd on `scene` at `rate` Hz until this process has received `outputs` of its output
// messages and one of its stats messages (waiting up to 60 s for them, however slowly the machine
// runs it), stops it with SIGTERM, and returns every message it published on the output and stats
// channels, in arrival order; empty when LCM cannot start (no multicast route).
std::vector<Received> record_daemon(const std::string& url, const std::string& scene, int rate, size_t outputs,
                                    std::string* daemon_err, const std::string& config = "") {
  auto bus = daemon_test::try_bus(url);
  if (!bus) return {};
  std::mutex mu;
  std::condition_variable cv;
  std::vector<Received> got;
  size_t n_out = 0, n_stats = 0;
  for (const char* ch : {"COOPDYN_OUTPUT", "COOPDYN_STATS"})
    bus->subscribe(ch, [&, ch](const void* d, int n, long long) {
      std::lock_guard<std::mutex> lk(mu);
      got.push_back({ch, std::vector<uint8_t>(static_cast<const uint8_t*>(d), static_cast<const uint8_t*>(d) + n),
                     io::wall_us()});
      ++(got.back().channel == "COOPDYN_OUTPUT" ? n_out : n_stats);
      cv.notify_all();
    });
  bus->start();
  const std::string cfg = daemon_test::tmp_path("view_cfg.yaml");
  std::ofstream(cfg) << "stats_period_s: 0.1\n" << config;
  daemon_test::Child d({COOPDYND_PATH, "--scene", scene_file(scene), "--config", cfg, "--lcm-url", url, "--rate",
                        std::to_string(rate)},
                       "view_daemon");
  {
    std::unique_lock<std::mutex> lk(mu);
    EXPECT_TRUE(cv.wait_for(lk, std::chrono::seconds(60), [&] { return n_out >= outputs && n_stats >= 1; }))
        << "in 60 s: " << n_out << " of " << outputs << " outputs, " << n_stats << " stats messages received";
  }
  d.signal(SIGTERM);
  EXPECT_EQ(d.wait(), 0) << daemon_test::slurp(d.err);
  *daemon_err = daemon_test::slurp(d.err);
  std::remove(cfg.c_str());
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // (what is still on its way, for the log)
  bus->stop();
  std::lock_guard<std::mutex> lk(mu);
  return got;
}

void write_log(const std::string& path, const std::vector<Received>& msgs) {
  lcm::LogFile log(path, "w");
  ASSERT_TRUE(log.good()) << path;
  int64_t n = 0;
  for (const Received& r : msgs) {
    lcm::LogEvent ev{};
    ev.eventnum = n++;
    ev.timestamp = r.utime;
    ev.channel = r.channel;
    ev.datalen = static_cast<int32_t>(r.data.size());
    ev.data = const_cast<uint8_t*>(r.data.data());
    ASSERT_EQ(log.writeEvent(&ev), 0);
  }
}

std::vector<double> numbers(const std::string& list) {  // "1,2.5,3" -> {1, 2.5, 3}
  std::vector<double> out;
  const char* p = list.c_str();
  while (*p) {
    char* end;
    out.push_back(std::strtod(p, &end));
    if (end == p) break;
    p = *end == ',' ? end + 1 : end;
  }
  return out;
}

// The page of a recorded daemon log has one frame per output_t message: the message's simulation
// time and status, and its wrenches turned into world axes with the message's own configuration
// (this process's forward kinematics). It loads in Chromium without a JavaScript error.
TEST(ViewLog, FramesAreTheDaemonsMessages) {
  TempDir dir("log");
  std::string derr;
  const std::vector<Received> msgs = record_daemon(private_udpm_url(1), "two_puma_load", 200, 100, &derr);
  if (msgs.empty()) GTEST_SKIP() << "LCM over udpm unavailable (multicast route? ip route add 224.0.0.0/4 dev lo)";
  std::vector<io::DecodedOutput> outs;
  for (const Received& r : msgs) {
    if (r.channel != "COOPDYN_OUTPUT") continue;
    io::DecodedOutput o;
    ASSERT_TRUE(io::decode_output(r.data.data(), static_cast<int>(r.data.size()), &o));
    outs.push_back(std::move(o));
  }
  ASSERT_GE(outs.size(), 100u) << derr;  // (record_daemon waited for them)
  const std::string log = dir / "run.lcmlog";
  write_log(log, msgs);

  std::string err;
  ASSERT_EQ(run("'" + kBin + "' view --scene '" + scene_file("two_puma_load") + "' --log '" + log + "' --out '" +
                    dir / "v.html" + "'",
                dir / "e", &err),
            0)
      << err;
  const std::string page = slurp(dir / "v.html");
  const std::vector<double> t = numbers(between(page, "\"t\":[", "]"));
  ASSERT_EQ(t.size(), outs.size());
  const std::string all_w = between(page, "\"wrench\":[[", "]],\"pj\"");
  std::vector<std::vector<double>> w;
  for (size_t at = 0, next; at < all_w.size(); at = next + 3) {
    next = all_w.find("],[", at);
    if (next == std::string::npos) next = all_w.size();
    w.push_back(numbers(all_w.substr(at, next - at)));
  }
  ASSERT_EQ(w.size(), outs.size());
  const System sys = load_scene(scene_file("two_puma_load"));
  std::vector<int> drawn;
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k)
    if (sys.wrenches.outputs[k].kind != WrenchKind::kJoint) drawn.push_back(static_cast<int>(k));
  Data data(sys.model);
  int checked = 0;
  double fmax = 0;
  for (size_t i = 0; i < outs.size(); ++i) {
    const io::DecodedOutput& o = outs[i];
    EXPECT_NEAR(t[i], o.sim_time, 1e-8 * (1 + o.sim_time)) << "frame " << i;
    ASSERT_EQ(w[i].size(), 9 * drawn.size());
    Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(o.q.data(), static_cast<Eigen::Index>(o.q.size()));
    normalize_configuration(sys.model, q);
    forward_kinematics(sys.model, data, q, Eigen::VectorXd::Zero(sys.model.nv()));
    for (size_t j = 0; j < drawn.size(); ++j) {
      const Transform X = wrench_frame_pose(sys, data, drawn[j]);
      const Vec3 f = X.R * Vec3(o.wrench[drawn[j]][3], o.wrench[drawn[j]][4], o.wrench[drawn[j]][5]);
      const Vec3 m = X.R * Vec3(o.wrench[drawn[j]][0], o.wrench[drawn[j]][1], o.wrench[drawn[j]][2]);
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(w[i][9 * j + k], X.p[k], 1e-5 * (1 + X.p.norm())) << o.wrench_names[drawn[j]];
        EXPECT_NEAR(w[i][9 * j + 3 + k], f[k], 1e-5 * (1 + f.norm())) << o.wrench_names[drawn[j]] << " frame " << i;
        EXPECT_NEAR(w[i][9 * j + 6 + k], m[k], 1e-5 * (1 + m.norm())) << o.wrench_names[drawn[j]] << " frame " << i;
      }
      fmax = std::max(fmax, f.norm());
      ++checked;
    }
  }
  EXPECT_GT(fmax, 10) << "the wrenches compared are not all zero";
  EXPECT_EQ(checked, static_cast<int>(outs.size() * drawn.size()));
  EXPECT_NE(page.find("\"source\":\"" + log + "\""), std::string::npos);

  // bad input: another scene, another channel, a missing log, a file that is not a log
  EXPECT_EQ(run("'" + kBin + "' view --scene '" + scene_file("four_bar") + "' --log '" + log + "' --out '" + dir / "x.html" + "'",
                dir / "e", &err),
            1);
  EXPECT_NE(err.find(log + ": output_t 1 on channel 'COOPDYN_OUTPUT'"), std::string::npos) << err;
  EXPECT_NE(err.find("scene 'four_bar'"), std::string::npos) << err;
  EXPECT_NE(err.find("another scene"), std::string::npos) << err;
  EXPECT_EQ(run("'" + kBin + "' view --scene '" + scene_file("two_puma_load") + "' --log '" + log +
                    "' --channel COOPDYN_STATS --out '" + dir / "x.html" + "'",
                dir / "e", &err),
            1);
  EXPECT_NE(err.find(log + ": no coopdyn.output_t messages on channel 'COOPDYN_STATS'"), std::string::npos) << err;
  EXPECT_NE(err.find("COOPDYN_OUTPUT (coopdyn.output_t, " + std::to_string(outs.size()) + ")"), std::string::npos) << err;
  EXPECT_NE(err.find("COOPDYN_STATS (coopdyn.loop_stats_t"), std::string::npos) << err;
  EXPECT_EQ(run("'" + kBin + "' view --scene '" + scene_file("two_puma_load") + "' --log '" + dir / "none.lcmlog" +
                    "' --out '" + dir / "x.html" + "'",
                dir / "e", &err),
            1);
  EXPECT_NE(err.find("cannot read '" + dir / "none.lcmlog" + "' as an LCM log"), std::string::npos) << err;
  EXPECT_EQ(run("'" + kBin + "' view --scene '" + scene_file("two_puma_load") + "' --log '" + scene_file("two_puma_load") +
                    "' --out '" + dir / "x.html" + "'",
                dir / "e", &err),
            1);
  EXPECT_NE(err.find(scene_file("two_puma_load") + ": no coopdyn.output_t messages"), std::string::npos) << err;
  std::ofstream(dir / "broken.yaml") << "name: broken\nrobots: [\n";
  EXPECT_EQ(run("'" + kBin + "' view --scene '" + dir / "broken.yaml" + "' --log '" + log + "' --out '" + dir / "x.html" + "'",
                dir / "e", &err),
            1);
  EXPECT_NE(err.find(dir / "broken.yaml"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "x.html"));

  const std::string chromium = find_chromium();
  if (chromium.empty() || !fs::exists(kThree)) {
    std::printf("[  SKIPPED ] the browser part: Chromium or three.js not installed\n");
    return;
  }
  DevTools browser(chromium, dir, "v");
  std::string why;
  const PageState p = page_state(browser.load("file://" + dir / "v.html" + "#frame=20&paused=1", &why));
  ASSERT_EQ(why, "");
  EXPECT_EQ(p.title, "coopdyn view: two_puma_load") << "a JavaScript error, or the page did not finish";
  EXPECT_TRUE(p.ready);
  EXPECT_EQ(p.frame, 20);
  EXPECT_NEAR(p.t, outs[20].sim_time, 1e-8);
}

// Decoded outputs of a recorded run, and its log.
std::vector<io::DecodedOutput> outputs_of(const std::vector<Received>& msgs) {
  std::vector<io::DecodedOutput> outs;
  for (const Received& r : msgs) {
    io::DecodedOutput o;
    if (r.channel == "COOPDYN_OUTPUT" && io::decode_output(r.data.data(), static_cast<int>(r.data.size()), &o))
      outs.push_back(std::move(o));
  }
  return outs;
}

// Stresses as colours: each pseudo-joint of the four-bar is a ball at the joint whose colour is the
// page's map of the message's stress (grey at 0, pure red / blue at the largest positive / negative
// stress of that joint over the run), computed here from the messages; the ball is where this
// process's forward kinematics of the message's q projects.
TEST(ViewLog, StressColoursOnThePseudoJoints) {
  REQUIRE_BROWSER();
  TempDir dir("stress");
  std::string derr;
  // no torque (not the default hold): the four-bar falls and its stresses change
  const std::vector<Received> msgs =
      record_daemon(private_udpm_url(4), "four_bar", 200, 100, &derr, "safe_torque:\n  policy: zero\n");
  if (msgs.empty()) GTEST_SKIP() << "LCM over udpm unavailable (multicast route? ip route add 224.0.0.0/4 dev lo)";
  const std::vector<io::DecodedOutput> outs = outputs_of(msgs);
  ASSERT_GE(outs.size(), 100u) << derr;
  write_log(dir / "run.lcmlog", msgs);
  std::string err;
  ASSERT_EQ(run("'" + kBin + "' view --scene '" + scene_file("four_bar") + "' --log '" + dir / "run.lcmlog" + "' --out '" +
                    dir / "v.html" + "'",
                dir / "e", &err),
            0)
      << err;
  const System sys = load_scene(scene_file("four_bar"));
  const Model& m = sys.model;
  ASSERT_EQ(m.pseudo_dofs.size(), 2u);
  std::vector<double> smax(m.pseudo_dofs.size(), 0.0);
  std::vector<std::vector<double>> st(outs.size());
  for (size_t i = 0; i < outs.size(); ++i)
    for (size_t k = 0; k < m.pseudo_dofs.size(); ++k) {
      const auto& names = outs[i].stress_names;
      const auto it = std::find(names.begin(), names.end(), m.v_names[m.pseudo_dofs[k]]);
      ASSERT_NE(it, names.end()) << m.v_names[m.pseudo_dofs[k]];
      st[i].push_back(outs[i].stress[static_cast<size_t>(it - names.begin())]);
      smax[k] = std::max(smax[k], std::abs(st[i][k]));
    }
  auto expected = [&](double s, double mx) {  // the page's map
    const double r = mx > 0 ? std::min(1.0, std::abs(s) / mx) : 0;
    return s >= 0 ? Vec3(128 + 127 * r, 128 - 128 * r, 128 - 128 * r) : Vec3(128 - 128 * r, 128 - 128 * r, 128 + 127 * r);
  };
  // the frames of the smallest and the largest |stress| of the first pseudo-joint
  size_t frames[2] = {0, 0};
  for (size_t i = 0; i < outs.size(); ++i) {
    if (std::abs(st[i][0]) < std::abs(st[frames[0]][0])) frames[0] = i;
    if (std::abs(st[i][0]) > std::abs(st[frames[1]][0])) frames[1] = i;
  }
  std::vector<Vec3> seen;
  DevTools browser(chromium, dir, "v");
  for (size_t i : frames) {
    const Browse b = browse(browser, dir / "v.html", "frame=" + std::to_string(i) + "&paused=1", true);
    ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
    const PageState p = page_state(b.dom);
    ASSERT_EQ(p.title, "coopdyn view: four_bar");
    ASSERT_EQ(p.frame, static_cast<int>(i));
    Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(outs[i].q.data(), static_cast<Eigen::Index>(outs[i].q.size()));
    Data data(m);
    forward_kinematics(m, data, q, Eigen::VectorXd::Zero(m.nv()));
    for (size_t k = 0; k < m.pseudo_dofs.size(); ++k) {
      const Vec3 x = data.X_WB[m.dof_body[m.pseudo_dofs[k]]].p;
      const Eigen::Vector2d px = project(p, x);
      const Vec3 want = expected(st[i][k], smax[k]);
      Vec3 got = Vec3::Zero();  // the mean of 3 x 3 pixels at the projection
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const unsigned char* c = b.shot.at(static_cast<int>(px.x()) + dx, static_cast<int>(px.y()) + dy);
          got += Vec3(c[0], c[1], c[2]) / 9;
        }
      EXPECT_LT((got - want).cwiseAbs().maxCoeff(), 12)
          << m.v_names[m.pseudo_dofs[k]] << " at frame " << i << ": stress " << st[i][k] << " of max " << smax[k]
          << ", expected colour " << want.transpose() << ", got " << got.transpose() << " at " << px.transpose();
      seen.push_back(want);
    }
  }
  // the map told the frames apart (else the check above could not tell a stress from a constant)
  EXPECT_GT((seen[0] - seen[2]).cwiseAbs().maxCoeff() + (seen[1] - seen[3]).cwiseAbs().maxCoeff(), 40)
      << "the stresses barely changed over the run";
}

// Indeterminate components highlighted: on the two-wheel vehicle (a rigid axle, over-constrained)
// a wheel's contact force with components the physics does not determine is drawn orange, not
// magenta, where its projection says; the status shows the free directions.
TEST(ViewLog, IndeterminateForceIsHighlighted) {
  REQUIRE_BROWSER();
  TempDir dir("indet");
  std::string derr;
  const std::vector<Received> msgs = record_daemon(private_udpm_url(5), "two_wheel_vehicle", 200, 60, &derr);
  if (msgs.empty()) GTEST_SKIP() << "LCM over udpm unavailable (multicast route? ip route add 224.0.0.0/4 dev lo)";
  const std::vector<io::DecodedOutput> outs = outputs_of(msgs);
  ASSERT_GE(outs.size(), 60u) << derr;
  write_log(dir / "run.lcmlog", msgs);
  std::string err;
  ASSERT_EQ(run("'" + kBin + "' view --scene '" + scene_file("two_wheel_vehicle") + "' --log '" + dir / "run.lcmlog" +
                    "' --out '" + dir / "v.html" + "'",
                dir / "e", &err),
            0)
      << err;
  const System sys = load_scene(scene_file("two_wheel_vehicle"));
  // a frame and a drawn wrench with an indeterminate force component and a force long enough to see
  const size_t i = outs.size() / 2;
  const io::DecodedOutput& o = outs[i];
  int pick = -1;
  double fbest = 0;
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k) {
    if (sys.wrenches.outputs[k].kind == WrenchKind::kJoint || !(o.indeterminate_mask[k] & 0x38)) continue;
    const double f = Vec3(o.wrench[k][3], o.wrench[k][4], o.wrench[k][5]).norm();
    if (f > fbest) fbest = f, pick = static_cast<int>(k);
  }
  ASSERT_GE(pick, 0) << "no indeterminate force in the vehicle's output (status " << o.status << ")";
  ASSERT_FALSE(o.free_class.empty());
  const std::string name = sys.wrenches.outputs[static_cast<size_t>(pick)].name;
  DevTools browser(chromium, dir, "v");
  const Browse b = browse(browser, dir / "v.html", "frame=" + std::to_string(i) + "&paused=1&wrench=" + name, true);
  ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
  const PageState p = page_state(b.dom);
  ASSERT_EQ(p.title, "coopdyn view: two_wheel_vehicle");
  ASSERT_EQ(p.frame, static_cast<int>(i));
  const std::string status = between(b.dom, "<span id=\"status\" class=\"indeterminate\">", "</span>");
  EXPECT_EQ(status.rfind("indeterminate (free: ", 0), 0u) << b.dom.substr(b.dom.find("id=\"status\""), 120);
  Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(o.q.data(), static_cast<Eigen::Index>(o.q.size()));
  Data data(sys.model);
  forward_kinematics(sys.model, data, q, Eigen::VectorXd::Zero(sys.model.nv()));
  const Transform X = wrench_frame_pose(sys, data, pick);
  const Vec3 f = X.R * Vec3(o.wrench[pick][3], o.wrench[pick][4], o.wrench[pick][5]);
  const Eigen::Vector2d po = project(p, X.p), tip = project(p, X.p + f / p.force_scale);
  expect_arrow_at(b.shot, p, po, tip, name + " (indeterminate) at frame " + std::to_string(i), is_indet_force_colour);
  const int magenta = count_in_canvas(b.shot, p, is_force_colour);
  EXPECT_EQ(magenta, 0) << "an indeterminate force drawn in the determinate colour";
}

// ---------------------------------------------------------------------------------------------
// The contact report, the plot of a wrench and the ground as declared.

// Numbers of the probe's JSON after `"key":` inside the object that starts at `from`.
double probe_num(const std::string& probe, const std::string& from, const std::string& key) {
  const size_t at = probe.find(from);
  return at == std::string::npos ? NAN : num_after(probe.substr(at), "\"" + key + "\":");
}
std::string probe_str(const std::string& probe, const std::string& from, const std::string& key) {
  const size_t at = probe.find(from);
  return at == std::string::npos ? "" : between(probe.substr(at), "\"" + key + "\":\"", "\"");
}

// The page's colour of a contact within its friction (utilisation u in [0, 1)): HSL hue 120 deg
// (green) at 0 to 55 deg (yellow) at 1, saturation 0.8, lightness 0.45 (three.js Color.setHSL).
Vec3 utilisation_colour(double u) {
  const double h = (120 - 65 * std::min(u, 1.0)) / 360, s = 0.8, l = 0.45;
  const double p = l <= 0.5 ? l * (1 + s) : l + s - l * s, q = 2 * l - p;
  auto hue = [&](double t) {
    t = t - std::floor(t);
    if (t < 1.0 / 6) return q + (p - q) * 6 * t;
    if (t < 0.5) return p;
    if (t < 2.0 / 3) return q + (p - q) * 6 * (2.0 / 3 - t);
    return q;
  };
  return 255 * Vec3(hue(h + 1.0 / 3), hue(h), hue(h - 1.0 / 3));
}
bool is_slip_colour(const unsigned char* p) { return p[0] > 200 && p[1] < 50 && p[2] < 50; }  // #ff0000

// The car driven hard on its left rear wheel alone: that wheel needs more friction than mu = 0.85
// and slips, the others do not. The page reports each wheel's utilisation, friction needed and
// state as the CSV's row has them (the same doubles), colours each contact's disc by that
// utilisation where this process's projection of the contact point says (red for the slipping
// wheel, the green-to-yellow map of the CSV's utilisation for the others), has red nowhere else,
// and names the slipping wheel in its status row.
TEST(ViewContacts, SlippingWheelHighlightedWhereProjected) {
  REQUIRE_BROWSER();
  TempDir dir("slip");
  ASSERT_EQ(run("'" + kBin + "' sim --scene '" + scene_file("four_wheel_car") +
                    "' --duration 0.3 --dt 0.01 --torque rl_spin:constant:2000 --out '" + dir / "c.csv" + "'",
                dir / "sim.err"),
            0)
      << slurp(dir / "sim.err");
  std::string err;
  ASSERT_EQ(view(scene_file("four_wheel_car"), dir / "c.csv", dir / "c.html", dir / "e", &err), 0) << err;
  const double t = 0.2;
  const auto row = csv_row(dir / "c.csv", t);
  ASSERT_FALSE(row.empty());
  const std::vector<std::string> wheels = {"fl", "fr", "rl", "rr"};
  for (const auto& w : wheels) EXPECT_EQ(row.at(w + ".contact"), w == "rl" ? "slip" : "ok") << w << " at t=" << t;

  DevTools browser(chromium, dir, "c");
  const Browse b = browse(browser, dir / "c.html", "t=0.2&paused=1", true);
  ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
  const PageState p = page_state(b.dom);
  ASSERT_EQ(p.title, "coopdyn view: four_wheel_car");
  ASSERT_DOUBLE_EQ(p.t, t);
  for (const auto& w : wheels) {
    const std::string at = "{\"name\":\"" + w + "\",\"utilisation\"";
    EXPECT_EQ(probe_num(p.probe, at, "utilisation"), std::stod(row.at(w + ".utilisation"))) << w << ": " << p.probe;
    EXPECT_EQ(probe_num(p.probe, at, "friction_needed"), std::stod(row.at(w + ".friction_needed"))) << w;
    EXPECT_EQ(probe_str(p.probe, at, "state"), row.at(w + ".contact")) << w;
  }
  EXPECT_EQ(between(b.dom, "<span id=\"cwarn\" class=\"bad\">", "</span>"), "slipping: rl");

  // where each contact projects: its disc's colour about there (the disc's pixels within its
  // projected radius of the point, of which the contact's and the axle's arrows, drawn over it,
  // cover a part)
  const System sys = load_scene(scene_file("four_wheel_car"));
  const Model& m = sys.model;
  Eigen::VectorXd q(m.nq());
  for (int i = 0; i < m.nq(); ++i) q[i] = std::stod(row.at("q:" + m.q_names[i]));
  Data data(m);
  forward_kinematics(m, data, q, Eigen::VectorXd::Zero(m.nv()));
  Eigen::Vector2d rl_centre;
  double rl_reach = 0;
  for (const ConstraintSpec& c : sys.constraints.specs) {
    if (c.kind != ConstraintKind::kRolling) continue;
    const Transform X = rolling_contact_frame(m, data, c);
    const Vec3 right = (p.up.cross(p.eye - p.target)).normalized();  // the camera's, in the flat ground
    const Eigen::Vector2d at = project(p, X.p);
    const double reach = (project(p, X.p + 0.6 * c.radius * right) - at).norm();  // the disc's radius
    const double u = std::stod(row.at(c.name + ".utilisation"));
    const Vec3 want = c.name == "rl" ? Vec3(255, 0, 0) : utilisation_colour(u);
    int match = 0;
    for (int y = static_cast<int>(at.y() - reach); y <= static_cast<int>(at.y() + reach); ++y)
      for (int x = static_cast<int>(at.x() - reach); x <= static_cast<int>(at.x() + reach); ++x) {
        if ((Eigen::Vector2d(x + 0.5, y + 0.5) - at).norm() > reach) continue;
        const unsigned char* q = b.shot.at(x, y);
        match += (Vec3(q[0], q[1], q[2]) - want).cwiseAbs().maxCoeff() < 12;
      }
    EXPECT_GT(match, 20) << c.name << " (utilisation " << u << "): no disc of colour " << want.transpose()
                         << " within " << reach << " px of " << at.transpose();
    if (c.name == "rl") {
      const Vec3 centre = X.p + c.radius * X.R.col(2);
      rl_centre = project(p, centre);
      for (int k = 0; k < 3; ++k)
        rl_reach = std::max(rl_reach, 1.6 * (project(p, centre + c.radius * Vec3::Unit(k)) - rl_centre).norm());
    }
  }
  // red (the disc and the wheel) about the slipping wheel only
  int near = 0, far = 0;
  for (int y = static_cast<int>(p.canvas_y); y < static_cast<int>(p.canvas_y + p.canvas_h); ++y)
    for (int x = static_cast<int>(p.canvas_x); x < static_cast<int>(p.canvas_x + p.canvas_w); ++x)
      if (is_slip_colour(b.shot.at(x, y))) ((Eigen::Vector2d(x + 0.5, y + 0.5) - rl_centre).norm() < rl_reach ? near : far)++;
  EXPECT_GT(near, 50) << "the slipping wheel is not red";
  EXPECT_EQ(far, 0) << "red away from the slipping wheel (within " << rl_reach << " px of " << rl_centre.transpose() << ")";
}

// From a daemon log: each frame's contact report is the message's (output_t contact_*, the same
// doubles), by name.
TEST(ViewLog, ContactReportIsTheMessages) {
  TempDir dir("logcontacts");
  std::string derr;
  const std::vector<Received> msgs = record_daemon(private_udpm_url(5), "four_wheel_car", 200, 60, &derr);
  if (msgs.empty()) GTEST_SKIP() << "LCM over udpm unavailable (multicast route? ip route add 224.0.0.0/4 dev lo)";
  const std::vector<io::DecodedOutput> outs = outputs_of(msgs);
  ASSERT_GE(outs.size(), 60u) << derr;
  write_log(dir / "run.lcmlog", msgs);
  std::string err;
  ASSERT_EQ(run("'" + kBin + "' view --scene '" + scene_file("four_wheel_car") + "' --log '" + dir / "run.lcmlog" +
                    "' --out '" + dir / "v.html" + "'",
                dir / "e", &err),
            0)
      << err;
  const std::string page = slurp(dir / "v.html");
  const std::vector<std::string> names = {"fl", "fr", "rl", "rr"};
  for (size_t k = 0; k < names.size(); ++k)
    EXPECT_NE(page.find("{\"name\":\"" + names[k] + "\",\"mu\":0.84999999999999998"), std::string::npos) << names[k];
  auto frames_of = [&](const std::string& key) {
    std::vector<std::vector<double>> out;
    const std::string all = between(page, "\"" + key + "\":[[", "]]");
    for (size_t at = 0, next; at < all.size(); at = next + 3) {
      next = all.find("],[", at);
      if (next == std::string::npos) next = all.size();
      out.push_back(numbers(all.substr(at, next - at)));
    }
    return out;
  };
  const auto cu = frames_of("contact_u"), cs = frames_of("contact_state");
  ASSERT_EQ(cu.size(), outs.size());
  ASSERT_EQ(cs.size(), outs.size());
  double umax = 0;
  for (size_t i = 0; i < outs.size(); ++i) {
    const io::DecodedOutput& o = outs[i];
    ASSERT_EQ(cu[i].size(), 2 * names.size()) << "frame " << i;
    for (size_t k = 0; k < names.size(); ++k) {
      const size_t j = static_cast<size_t>(std::find(o.contact_names.begin(), o.contact_names.end(), names[k]) - o.contact_names.begin());
      ASSERT_LT(j, o.contact_names.size()) << names[k];
      EXPECT_EQ(cu[i][2 * k], o.contact_utilisation[j]) << names[k] << " frame " << i;
      EXPECT_EQ(cu[i][2 * k + 1], o.contact_friction_needed[j]) << names[k] << " frame " << i;
      EXPECT_EQ(cs[i][k], o.contact_state[j]) << names[k] << " frame " << i;
      umax = std::max(umax, o.contact_utilisation[j]);
    }
  }
  std::printf("largest utilisation of the car held at rest: %.3g\n", umax);
}

// The ground as declared: a unicycle on an inclined plane {normal, point, mu} off the origin; the
// page's grid (three.js's own vertices, in the world) lies in that plane with its normal, not at
// z = 0, and the page reports the friction a disk rolling down it needs.
TEST(ViewGround, InclinedGridLiesOnThePlane) {
  REQUIRE_BROWSER();
  TempDir dir("incline");
  const Vec3 n = Vec3(-0.3, 0, 1).normalized(), point(0.5, 0, 0.1);
  const double r = 0.25;
  const Vec3 c = point + r * n;  // the wheel's centre, its axle along y: its lowest rim point on the plane
  std::ofstream(dir / "incline.yaml") << "name: incline\ngravity: [0, 0, -9.81]\nformulation: mobile_platform\n"
                                         "stabilization: {baumgarte: {alpha: 20, beta: 100}}\n"
                                         "ground: {normal: [-0.3, 0, 1], point: [0.5, 0, 0.1], mu: 0.5}\n"
                                         "bodies:\n  - name: wheel\n    parent: world\n"
                                         "    joint: {type: floating, name: wheel, q: {xyz: ["
                                      << c.x() << ", 0, " << c.z() << "]}}\n"
                                         "    mass: 3.0\n    inertia: [0.046875, 0.09375, 0.046875, 0, 0, 0]\n"
                                         "constraints:\n  - {name: wheel, type: rolling, body: wheel, axle: [0, 1, 0], radius: 0.25}\n";
  ASSERT_EQ(run("'" + kBin + "' sim --scene '" + dir / "incline.yaml" + "' --duration 0.5 --dt 0.01 --out '" + dir / "i.csv" + "'",
                dir / "sim.err"),
            0)
      << slurp(dir / "sim.err");
  std::string err;
  ASSERT_EQ(view(dir / "incline.yaml", dir / "i.csv", dir / "i.html", dir / "e", &err), 0) << err;
  DevTools browser(chromium, dir, "i");
  std::string why;
  const PageState p = page_state(browser.load("file://" + dir / "i.html" + "#t=0.5&paused=1", &why));
  ASSERT_EQ(why, "");
  ASSERT_EQ(p.title, "coopdyn view: incline");
  const std::string g = between(p.probe, "\"grounds\":[", ",\"plot\"");
  ASSERT_NE(g.find("\"vertices\":"), std::string::npos) << p.probe;
  EXPECT_EQ(g.find("\"normal\":"), g.rfind("\"normal\":")) << "one plane, one grid: " << g;
  const Vec3 gn = vec_after(g, "\"normal\":[");
  EXPECT_LT((gn - n).norm(), 1e-9) << "the grid's normal " << gn.transpose();
  std::string verts = g.substr(g.find("\"vertices\":") + 11);
  verts.erase(std::remove_if(verts.begin(), verts.end(), [](char ch) { return ch == '[' || ch == ']' || ch == '{' || ch == '}'; }),
              verts.end());
  const std::vector<double> v = numbers(verts);
  ASSERT_EQ(v.size(), 12u) << verts;
  double span = 0;
  for (int k = 0; k < 4; ++k) {
    const Vec3 x(v[3 * k], v[3 * k + 1], v[3 * k + 2]);
    EXPECT_NEAR(n.dot(x - point), 0, 1e-6) << "grid vertex " << x.transpose() << " off the plane";
    span = std::max(span, (x - point).norm());
  }
  EXPECT_GT(span, 1) << "the grid is a plane, not a point";
  // the wheel rolled down the slope on it, below where it started, and the contact report the page
  // shows is the rolling disk's on a slope of angle th: friction needed f_t / f_n = tan(th) / 3
  // (I = m r^2 / 2), here 0.3 / 3 = 0.1, utilisation 0.1 / mu = 0.2
  const auto row = csv_row(dir / "i.csv", 0.5);
  ASSERT_FALSE(row.empty());
  EXPECT_LT(std::stod(row.at("q:wheel.z")), c.z() - 1e-3);
  EXPECT_EQ(probe_num(p.probe, "{\"name\":\"wheel\",\"utilisation\"", "utilisation"), std::stod(row.at("wheel.utilisation")));
  EXPECT_NEAR(probe_num(p.probe, "{\"name\":\"wheel\",\"utilisation\"", "friction_needed"), 0.1, 1e-5) << p.probe;
  EXPECT_NEAR(probe_num(p.probe, "{\"name\":\"wheel\",\"utilisation\"", "utilisation"), 0.2, 2e-5) << p.probe;
}

// The plot of one wrench: a click on its arrow selects it (the click's place is this process's
// projection of the arrow), the plot's series are the CSV's six columns of that wrench (the same
// doubles), and its white cursor stands where the frame's time maps on the plot's axes, following
// the time slider.
TEST(ViewPlot, ClickedWrenchPlottedWithACursorOnTheSlider) {
  REQUIRE_BROWSER();
  TempDir dir("plot");
  // with zero torque the arms fall and pull the box apart: 855 N on arm1's end-effector at 0.7 s
  ASSERT_EQ(sim("two_puma_load", 0.8, 0.005, dir / "p.csv", dir / "sim.err"), 0) << slurp(dir / "sim.err");
  std::string err;
  ASSERT_EQ(view(scene_file("two_puma_load"), dir / "p.csv", dir / "p.html", dir / "e", &err), 0) << err;
  const System sys = load_scene(scene_file("two_puma_load"));
  const int f1 = 140, f2 = 40;  // frames (0.005 s apart)
  DevTools browser(chromium, dir, "p");
  const Browse a = browse(browser, dir / "p.html", "slider=" + std::to_string(f1) + "&paused=1", false);
  ASSERT_TRUE(a.ok) << a.log.substr(0, 3000);
  const PageState pa = page_state(a.dom);
  ASSERT_EQ(pa.title, "coopdyn view: two_puma_load");
  EXPECT_EQ(pa.probe.find("\"plot\":null") != std::string::npos, true) << "no plot before a wrench is picked";
  // a point on arm1.ee's force arrow 8 px or more from every other arrow drawn
  const double moment_scale = num_after(pa.probe, "\"moment_scale\":");
  auto seg_dist = [](const Eigen::Vector2d& x, const Eigen::Vector2d& a0, const Eigen::Vector2d& a1) {
    const Eigen::Vector2d d = a1 - a0;
    const double s = d.squaredNorm() > 0 ? std::clamp((x - a0).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0.0;
    return (x - a0 - s * d).norm();
  };
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> others;
  Eigen::Vector2d o1, t1;
  for (const WrenchOutput& w : sys.wrenches.outputs) {
    if (w.kind == WrenchKind::kJoint) continue;
    const WorldForce wf = world_force(sys, dir / "p.csv", f1 * 0.005, w.name);
    const Eigen::Vector2d o = project(pa, wf.origin), tf = project(pa, wf.origin + wf.force / pa.force_scale);
    if (w.name == "arm1.ee") o1 = o, t1 = tf;
    else others.emplace_back(o, tf);
    others.emplace_back(o, project(pa, wf.origin + wf.moment / moment_scale));
  }
  ASSERT_GT((t1 - o1).norm(), 30);
  Eigen::Vector2d click(-1, -1);
  for (double s = 0.3; s <= 0.95 && click.x() < 0; s += 0.05) {
    const Eigen::Vector2d x = o1 + s * (t1 - o1);
    if (std::all_of(others.begin(), others.end(), [&](const auto& sg) { return seg_dist(x, sg.first, sg.second) > 12; })) click = x;
  }
  ASSERT_GE(click.x(), 0) << "no point of arm1.ee's force arrow clear of the others";
  char hash[128];
  std::snprintf(hash, sizeof hash, "slider=%d&paused=1&plotdata=1&click=%.1f,%.1f", f1, click.x() - pa.canvas_x,
                click.y() - pa.canvas_y);
  const Browse b = browse(browser, dir / "p.html", hash, true);
  const Browse c = browse(browser, dir / "p.html", "slider=" + std::to_string(f2) + "&paused=1&wrench=arm1.ee", true);
  ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
  ASSERT_TRUE(c.ok) << c.log.substr(0, 3000);
  const PageState pb = page_state(b.dom);
  ASSERT_EQ(pb.title, "coopdyn view: two_puma_load");
  ASSERT_EQ(between(pb.probe, "\"wrench\":\"", "\""), "arm1.ee") << "the click did not pick arm1.ee's arrow";

  // the series: every row's six columns
  std::vector<std::vector<double>> series;
  {
    const std::string values = between(b.dom, "\"values\":[[", "]]}");
    for (size_t at = 0, next; at < values.size(); at = next + 3) {
      next = values.find("],[", at);
      if (next == std::string::npos) next = values.size();
      series.push_back(numbers(values.substr(at, next - at)));
    }
  }
  ASSERT_EQ(series.size(), 6u);
  std::ifstream f(dir / "p.csv");
  std::string line;
  while (std::getline(f, line) && !line.empty() && line[0] == '#') {}  // the comment and units lines
  std::vector<std::string> head;
  {
    std::stringstream ss(line);
    std::string h;
    while (std::getline(ss, h, ',')) head.push_back(h);
  }
  const char* comp[6] = {"mx", "my", "mz", "fx", "fy", "fz"};
  std::vector<size_t> col;
  for (const char* cn : comp)
    col.push_back(static_cast<size_t>(std::find(head.begin(), head.end(), std::string("arm1.ee.") + cn) - head.begin()));
  std::vector<double> times;
  size_t rows = 0;
  while (std::getline(f, line)) {
    std::stringstream ss(line);
    std::vector<std::string> cells;
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    times.push_back(std::stod(cells[0]));
    for (int j = 0; j < 6; ++j) {
      ASSERT_LT(rows, series[j].size());
      EXPECT_EQ(series[j][rows], std::stod(cells[col[j]])) << "arm1.ee." << comp[j] << " at row " << rows + 1;
    }
    ++rows;
  }
  for (int j = 0; j < 6; ++j) EXPECT_EQ(series[j].size(), rows) << comp[j];

  // the cursor: at the frame's time on the axes the probe gives, white in the screenshot there and
  // nowhere else on the plot
  for (const Browse* br : {&b, &c}) {
    const PageState ps = page_state(br->dom);
    const int frame = br == &b ? f1 : f2;
    ASSERT_EQ(ps.frame, frame);
    const std::string plot = ps.probe.substr(ps.probe.find("\"plot\":{"));
    // (the page's times are the CSV's to 9 digits)
    EXPECT_NEAR(probe_num(plot, "\"plot\"", "cursor_t"), times[frame], 1e-9);
    EXPECT_NEAR(probe_num(plot, "\"plot\"", "t0"), times.front(), 1e-9);
    EXPECT_NEAR(probe_num(plot, "\"plot\"", "t1"), times.back(), 1e-9);
    // two axes, moments (N*m) above forces (N), on one time axis
    const std::string axes = between(plot, "\"axes\":[", "]");
    const size_t split = axes.find("},{");
    ASSERT_NE(split, std::string::npos) << axes;
    const std::string ax1 = axes.substr(0, split), ax2 = axes.substr(split);
    const double left = num_after(ax1, "\"left\":"), width = num_after(ax1, "\"width\":");
    const double top1 = num_after(ax1, "\"top\":"), h1 = num_after(ax1, "\"height\":");
    const double top2 = num_after(ax2, "\"top\":"), h2 = num_after(ax2, "\"height\":");
    EXPECT_EQ(num_after(ax2, "\"left\":"), left);
    EXPECT_EQ(num_after(ax2, "\"width\":"), width);
    EXPECT_EQ(between(ax2, "\"unit\":\"", "\""), "N");
    EXPECT_GT(top2, top1 + h1);
    EXPECT_EQ(h2, h1);
    ASSERT_GT(width, 100);
    ASSERT_GT(h1, 40);
    EXPECT_GE(left, ps.canvas_x + ps.canvas_w) << "the plot beside the 3D view";
    const double x = left + (times[frame] - times.front()) / (times.back() - times.front()) * width;
    EXPECT_NEAR(probe_num(plot, "\"plot\"", "cursor_x"), x, 1e-6);
    auto white_in_column = [&](int px) {
      int n = 0;
      for (int y = static_cast<int>(top1) + 2; y < static_cast<int>(top1 + h1) - 2; ++y) {
        const unsigned char* q = br->shot.at(px, y);
        n += q[0] > 240 && q[1] > 240 && q[2] > 240;
      }
      return n;
    };
    const int cx = static_cast<int>(std::floor(x + 0.5));  // the page draws it at Math.round(x) + 0.5
    EXPECT_GT(white_in_column(cx), 0.9 * (h1 - 4)) << "no cursor at x = " << x << " (frame " << frame << ")";
    for (int px = static_cast<int>(left) + 2; px < static_cast<int>(left + width) - 2; ++px)
      if (std::abs(px - cx) > 1) {
        EXPECT_LT(white_in_column(px), 0.2 * h1) << "white at x = " << px << ", the cursor is at " << x;
      }
  }
}

// ---------------------------------------------------------------------------------------------
// Live: coopdynd over udpm on a private loopback port, `coopdyn view --live` as its own process
// serving the page and its WebSocket on 127.0.0.1 (port 0: the one it prints).

// A TCP connection to 127.0.0.1:port (rcvbuf > 0: that receive buffer, set before connecting).
int tcp_connect(int port, int rcvbuf = 0) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  if (rcvbuf > 0) setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
  timeval tv{5, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}
bool send_all(int fd, const std::string& s) { return ::send(fd, s.data(), s.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(s.size()); }
// Reads up to the end of the HTTP head (and whatever came with it).
std::string read_head(int fd) {
  std::string got;
  char buf[4096];
  while (got.find("\r\n\r\n") == std::string::npos) {
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    got.append(buf, static_cast<size_t>(n));
  }
  return got;
}
std::string http_get(int port, const std::string& path) {
  const int fd = tcp_connect(port);
  if (fd < 0) return "";
  send_all(fd, "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n");
  std::string got;
  char buf[65536];
  for (ssize_t n; (n = recv(fd, buf, sizeof buf, 0)) > 0;) got.append(buf, static_cast<size_t>(n));
  close(fd);
  return got;
}
// A WebSocket client at the handshake: returns the socket after the server's 101, or -1.
int ws_connect(int port, int rcvbuf) {
  const int fd = tcp_connect(port, rcvbuf);
  if (fd < 0) return -1;
  send_all(fd, "GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
               "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n");
  if (read_head(fd).rfind("HTTP/1.1 101", 0) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}
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
  std::vector<std::pair<int64_t, int64_t>> stats;  // loop_stats_t (utime, tick)
  std::string skip;

  LiveRig(int offset, const std::vector<std::string>& viewer_extra) {
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
        std::vector<std::string>{COOPDYND_PATH, "--scene", scene_file("two_puma_load"), "--config", cfg, "--lcm-url", url,
                                 "--rate", "1000", "--duration", "300"},
        "live_daemon");
    std::vector<std::string> args{kBin, "view", "--scene", scene_file("two_puma_load"), "--live", "--listen",
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
  DevTools browser(chromium, dir, "live");
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

// Bad command lines of the new sources: one source at a time, --out for a file, a usable --listen
// (a malformed one, a port already taken: the error names it), exit status 2 for usage, 1 for the rest.
TEST(ViewErrors, SourcesAndListenAddress) {
  TempDir dir("usage");
  const std::string v = "'" + kBin + "' view --scene '" + scene_file("unicycle") + "' ";
  std::string err;
  EXPECT_EQ(run(v + "--csv a.csv --log b.lcmlog --out x.html", dir / "e", &err), 2);
  EXPECT_NE(err.find("--csv excludes --log"), std::string::npos) << err;
  EXPECT_EQ(run(v + "--log b.lcmlog", dir / "e", &err), 2);
  EXPECT_NE(err.find("--out VIEW.html"), std::string::npos) << err;
  EXPECT_EQ(run(v + "--live --log b.lcmlog", dir / "e", &err), 2);
  if (!COOPDYN_VIEW_LIVE) return;
  EXPECT_EQ(run(v + "--live --listen nonsense --lcm-url memq://", dir / "e", &err), 2);
  EXPECT_NE(err.find("--listen 'nonsense': expected HOST:PORT"), std::string::npos) << err;
  // a port this process holds
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ASSERT_EQ(listen(fd, 1), 0);
  socklen_t len = sizeof a;
  getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  const std::string taken = "127.0.0.1:" + std::to_string(ntohs(a.sin_port));
  EXPECT_EQ(run(v + "--live --listen " + taken + " --lcm-url memq://", dir / "e", &err), 1);
  EXPECT_NE(err.find("cannot listen on " + taken), std::string::npos) << err;
  close(fd);
}

}  // namespace
}  // namespace coopdyn
