// Headless Chromium driven over its DevTools protocol, started as a child process.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/child_process.h"
#include "tests/support/files.h"
#include "tests/support/png_reader.h"

namespace coopdyn::testing {

// Chromium: $COOPDYN_CHROMIUM, else chromium or chromium-browser on the PATH; "" when there is none.
inline std::string find_chromium() {
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

inline std::vector<unsigned char> base64_decode(const std::string& s) {
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

inline std::string between(const std::string& s, const std::string& a, const std::string& b) {
  const size_t i = s.find(a);
  if (i == std::string::npos) return "";
  const size_t j = s.find(b, i + a.size());
  return j == std::string::npos ? "" : s.substr(i + a.size(), j - i - a.size());
}

// A JSON string literal of s.
inline std::string json_quote(const std::string& s) {
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
inline std::string json_unquote(const std::string& s, size_t at) {
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

// Headless Chromium driven over the DevTools protocol, in real time: a test waits until the page
// reports what it needs (set up, a played time, frames received), however long the machine takes,
// instead of giving Chromium a virtual-time budget and judging what fitted in it; one browser serves
// a test's pages, one tab at a time. The protocol runs on a pipe (--remote-debugging-pipe: Chromium reads commands on its fd 3 and
// writes replies and events on its fd 4, each a JSON text ended by a NUL).
class DevTools {
 public:
  // files: where its log (files.chromium.log) and its profile (files.profile) go
  DevTools(const std::string& chromium, const std::string& files) : log_(files + ".chromium.log") {
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
    const std::vector<std::string> argv{chromium, "--headless", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
                                        "--enable-unsafe-swiftshader", "--hide-scrollbars", "--mute-audio", "--no-first-run",
                                        "--user-data-dir=" + files + ".profile", "--window-size=900,600",
                                        "--remote-debugging-pipe", "about:blank"};
    pid_ = daemon_test::spawn(argv, [&](posix_spawn_file_actions_t* fa) {
      posix_spawn_file_actions_adddup2(fa, in, 3);
      posix_spawn_file_actions_adddup2(fa, out, 4);
      posix_spawn_file_actions_addopen(fa, 1, log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      posix_spawn_file_actions_adddup2(fa, 1, 2);
    });
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
    const auto set_up_or_failed = [](const std::string& d) {
      return d.find("data-ready=\"1\"") != std::string::npos || d.find("JSERROR") != std::string::npos;
    };
    if (!wait_until(set_up_or_failed, 60, &dom))
      *why = "not ready in 60 s: " + dom.substr(0, 2000) + "\n" + log();
    return dom;
  }
  // The value of a JavaScript expression that gives a string, in the page ("" on failure).
  std::string eval(const std::string& expr) {
    const std::string r = call("Runtime.evaluate", "{\"expression\":" + json_quote(expr) + ",\"returnByValue\":true}", 60);
    const size_t at = r.find("\"type\":\"string\",\"value\":\"");
    return at == std::string::npos ? "" : json_unquote(r, at + 24);
  }
  // What a coopdyn view page's DOM says about itself: the title, whether it is ready and the
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

}  // namespace coopdyn::testing
