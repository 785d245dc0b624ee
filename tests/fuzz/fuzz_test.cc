// Seeded mutation fuzzing of the untrusted-input boundaries:
//   - CommandDecoder / StateDecoder (service/io/codec/codec.h) on mutated valid encodings: bit flips,
//     truncations, inserted / deleted / duplicated bytes, count and string-length fields set to
//     hostile values, doubles set to NaN / Inf / huge / just over the limit, splices of two seeds;
//   - DirectStateDecoder (service/io/codec/direct_decoder.h) on the same mutated states, against
//     StateDecoder: the same reason for every input, the same slot for every one accepted;
//   - load_scene_string on mutated shipped scenes (config/scenes/*.yaml) and the scene corpus;
//   - load_config_string on mutated config/coopdynd.yaml and the config corpus;
//   - the LCM wire parser and reassembler (service/io/transport/lcm_wire.h) on mutated datagram sequences of
//     the wire corpus (LC02, LC03 sets, the fragment that crashes liblcm 1.3.1).
// Every input must end in a clean result or the documented error (a Reject, SceneError,
// ConfigError): never a crash, a hang or another exception. A clean result is checked too: a
// decoded command is finite, within tau_limit and exactly 0 on unactuated DOFs; a loaded scene has
// consistent sizes and limits and evaluates its initial state without NaN; a loaded config is
// inside the documented bounds of service/runtime/config.h.
//
// Deterministic: input i of a target is mutate(seed[i % n], rng(seed, i)), so one input reproduces
// alone. On a failure the driver prints the seed, the iteration, the input (hex, or the text) and
// writes it to fuzz-failure-<target>-<seed>-<iteration>.bin in the working directory; a crash or
// sanitizer report does the same from a signal handler (sanitizer death callback), a hang from a
// watchdog thread. Environment:
//   COOPDYN_FUZZ_SEED=S    base seed (default 20240610)
//   COOPDYN_FUZZ_ITERS=N   iterations per target (default: the build's budget, below)
//   COOPDYN_FUZZ_ONLY=I    run iteration I only (reproduce a failure)
// `coopdyn_fuzz_tests --write-corpus DIR` regenerates the binary seeds (DIR/command, DIR/state, DIR/wire).
#include <gtest/gtest.h>
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstring>
#include <dirent.h>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/common_interface_defs.h>
#endif

#include "service/dynamics/constrained_dynamics.h"
#include "service/io/transport/auth.h"
#include "service/io/codec/codec.h"
#include "service/io/codec/direct_decoder.h"
#include "service/io/transport/lcm_wire.h"
#include "service/runtime/config.h"
#include "service/scene/scene.h"
#include "tests/support/files.h"

using namespace coopdyn;

namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
// Iterations per target: about 11 s for all targets together in Release on the 2-core machine;
// the ASan+UBSan build runs 2-4x slower per input, so it gets a quarter of the inputs (about 11 s).
constexpr long kDecoderIters = kSanitized ? 50000 : 200000;
constexpr long kSceneIters = kSanitized ? 2000 : 8000;
constexpr long kConfigIters = kSanitized ? 5000 : 20000;
constexpr long kWireIters = kSanitized ? 25000 : 100000;  // ~1.6 s in Release
// An input that runs longer than this is a hang.
constexpr long long kHangNs = (kSanitized ? 60LL : 10LL) * 1000000000LL;

const std::string kSrc = COOPDYN_SOURCE_DIR;
const std::string kCorpus = kSrc + "/tests/fuzz/corpus";

uint64_t env_u64(const char* name, uint64_t def) {
  const char* s = std::getenv(name);
  return s && *s ? std::strtoull(s, nullptr, 10) : def;
}
const uint64_t kSeed = env_u64("COOPDYN_FUZZ_SEED", 20240610);

using coopdyn::testing::slurp;
std::vector<std::string> list_dir(const std::string& dir, const std::string& suffix) {
  std::vector<std::string> out;
  if (DIR* d = opendir(dir.c_str())) {
    while (dirent* e = readdir(d)) {
      const std::string n = e->d_name;
      if (n.size() > suffix.size() && n.compare(n.size() - suffix.size(), suffix.size(), suffix) == 0)
        out.push_back(dir + "/" + n);
    }
    closedir(d);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// ---- the input being run, for the crash / hang reporters (async-signal-safe writes only) --------
char g_target[32] = "";
std::atomic<long> g_iter{-1};
std::atomic<long long> g_start_ns{0};
std::string g_input;  // assigned before each run, read by the reporters

long long mono_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

void put(int fd, const char* s) {
  if (write(fd, s, strlen(s)) < 0) {}
}
void u64_text(uint64_t x, char* o) {  // o: at least 21 bytes
  char b[24];
  int n = 0;
  do b[n++] = static_cast<char>('0' + x % 10); while ((x /= 10) != 0);
  for (int i = 0; i < n; ++i) o[i] = b[n - 1 - i];
  o[n] = 0;
}
void put_u64(int fd, uint64_t x) {
  char o[24];
  u64_text(x, o);
  put(fd, o);
}
void append_u64(char* dst, uint64_t x, const char* sep) {
  char o[24];
  u64_text(x, o);
  strcat(dst, sep);
  strcat(dst, o);
}
// The current input: written to a file, and printed (the text if printable, else hex; cut at 8 KiB).
void report_input(const char* what) {
  const int e = 2;
  put(e, "\n=== FUZZ FAILURE (");
  put(e, what);
  put(e, ") target ");
  put(e, g_target);
  put(e, " seed ");
  put_u64(e, kSeed);
  put(e, " iteration ");
  put_u64(e, static_cast<uint64_t>(g_iter.load()));
  put(e, " input bytes ");
  put_u64(e, g_input.size());
  put(e, "\nreproduce: COOPDYN_FUZZ_SEED=");
  put_u64(e, kSeed);
  put(e, " COOPDYN_FUZZ_ONLY=");
  put_u64(e, static_cast<uint64_t>(g_iter.load()));
  put(e, " build/bin/coopdyn_fuzz_tests --gtest_filter='*");
  put(e, g_target);
  put(e, "*'\n");
  char name[128] = "fuzz-failure-";
  strncat(name, g_target, 40);
  append_u64(name, kSeed, "-");
  append_u64(name, static_cast<uint64_t>(g_iter.load()), "-");
  strcat(name, ".bin");
  const int fd = open(name, O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd >= 0) {
    if (write(fd, g_input.data(), g_input.size()) < 0) {}
    close(fd);
    put(e, "input written to ");
    put(e, name);
    put(e, " (in the test's working directory)\n");
  }
  bool text = true;
  for (unsigned char ch : g_input) text = text && (ch == '\n' || ch == '\t' || (ch >= 32 && ch < 127));
  const size_t n = std::min<size_t>(g_input.size(), 8192);
  if (text) {
    put(e, "--- input (text) ---\n");
    if (write(e, g_input.data(), n) < 0) {}
  } else {
    put(e, "--- input (hex) ---\n");
    static const char* hx = "0123456789abcdef";
    char line[100];
    for (size_t i = 0; i < n; i += 32) {
      int k = 0;
      for (size_t j = i; j < std::min(n, i + 32); ++j) {
        line[k++] = hx[static_cast<unsigned char>(g_input[j]) >> 4];
        line[k++] = hx[static_cast<unsigned char>(g_input[j]) & 15];
      }
      line[k++] = '\n';
      if (write(e, line, k) < 0) {}
    }
  }
  put(e, "\n=== end of input\n");
}

#if defined(__SANITIZE_ADDRESS__)
void on_sanitizer_death() { report_input("sanitizer report above"); }
#else
void on_crash(int sig) {
  report_input(sig == SIGSEGV ? "SIGSEGV" : sig == SIGABRT ? "SIGABRT" : sig == SIGFPE ? "SIGFPE" : "signal");
  signal(sig, SIG_DFL);
  raise(sig);
}
#endif

void install_reporters() {
  static bool done = false;
  if (done) return;
  done = true;
#if defined(__SANITIZE_ADDRESS__)
  __sanitizer_set_death_callback(on_sanitizer_death);  // ASan / UBSan keep their own handlers
#else
  for (int s : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) signal(s, on_crash);
#endif
  std::thread([] {  // hang watchdog
    for (;;) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      const long long t0 = g_start_ns.load();
      if (t0 != 0 && mono_ns() - t0 > kHangNs) {
        report_input("hang: one input ran longer than the limit");
        _exit(3);
      }
    }
  }).detach();
}

// Runs body(i) for the target's iterations (or the one of COOPDYN_FUZZ_ONLY); body returns "" or
// what went wrong, and sets g_input first.
template <class Body>
void run_target(const char* target, long iters, Body body) {
  install_reporters();
  strncpy(g_target, target, sizeof g_target - 1);
  iters = static_cast<long>(env_u64("COOPDYN_FUZZ_ITERS", static_cast<uint64_t>(iters)));
  const char* only = std::getenv("COOPDYN_FUZZ_ONLY");
  const long first = only && *only ? std::atol(only) : 0, last = only && *only ? first + 1 : iters;
  const auto t0 = std::chrono::steady_clock::now();
  long failures = 0;
  for (long i = first; i < last && failures < 5; ++i) {
    g_iter = i;
    g_start_ns = mono_ns();
    const std::string why = body(i);
    g_start_ns = 0;
    if (!why.empty()) {
      ++failures;
      report_input(why.c_str());
      ADD_FAILURE() << target << " seed " << kSeed << " iteration " << i << ": " << why;
    }
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[fuzz] %s: %ld inputs in %.2f s (seed %llu)\n", target, last - first, s,
              static_cast<unsigned long long>(kSeed));
}

std::mt19937_64 rng_for(const char* target, long i) {
  uint64_t h = kSeed * 0x9E3779B97F4A7C15ULL;
  for (const char* p = target; *p; ++p) h = (h ^ static_cast<unsigned char>(*p)) * 0x100000001B3ULL;
  std::seed_seq sq{static_cast<uint32_t>(h), static_cast<uint32_t>(h >> 32), static_cast<uint32_t>(i),
                   static_cast<uint32_t>(static_cast<uint64_t>(i) >> 32)};
  return std::mt19937_64(sq);
}
size_t pick(std::mt19937_64& r, size_t n) { return n == 0 ? 0 : std::uniform_int_distribution<size_t>(0, n - 1)(r); }

// ---- byte mutations ---------------------------------------------------------------------------
void put_be32(std::string& s, size_t at, int32_t v) {
  const uint32_t u = static_cast<uint32_t>(v);
  for (int k = 0; k < 4; ++k) s[at + k] = static_cast<char>(u >> (24 - 8 * k));
}
void put_be64(std::string& s, size_t at, uint64_t u) {
  for (int k = 0; k < 8; ++k) s[at + k] = static_cast<char>(u >> (56 - 8 * k));
}
int32_t be32(const std::string& s, size_t at) {
  uint32_t u = 0;
  for (int k = 0; k < 4; ++k) u = (u << 8) | static_cast<unsigned char>(s[at + k]);
  return static_cast<int32_t>(u);
}

// Where the fields of a valid LCM encoding are: int32 counts and string lengths, doubles.
struct Layout {
  std::vector<size_t> i32, f64;
};
// torque_command_t: hash, utime, seq, num_names, names[], num_torques, tau[];
// measured_state_t: hash, utime, seq, (num names, names[], num, values[]) for q then v, tau[num_v],
// then num_wrenches, wrench_names[], wrench[][6]; both end with mac_len, mac[] (auth.h).
Layout layout_of(const std::string& s, bool state) {
  Layout L;
  size_t p = 24;
  L.f64.push_back(8);  // utime and seq as raw 8-byte fields too
  L.f64.push_back(16);
  // names[] then values[]; the values have their own count unless shared_count (one count for both)
  auto block = [&](int values_per, bool shared_count) {
    L.i32.push_back(p);
    const int32_t nn = be32(s, p);
    p += 4;
    for (int k = 0; k < nn; ++k) {
      L.i32.push_back(p);
      p += 4 + be32(s, p);
    }
    int32_t nv = nn;
    if (!shared_count) {
      L.i32.push_back(p);
      nv = be32(s, p);
      p += 4;
    }
    for (int k = 0; k < nv * values_per; ++k, p += 8) L.f64.push_back(p);
  };
  if (state) {
    block(1, false);  // q
    block(2, false);  // v and tau
    block(6, true);   // measured wrenches: num_wrenches, wrench_names[], wrench[][6]
  } else {
    block(1, false);  // torques: num_names, names[], num_torques, tau[]
    block(1, true);   // lock targets: num_targets, target_names[], target[]
  }
  L.i32.push_back(p);  // mac_len, then the MAC's bytes
  p += 4 + static_cast<size_t>(std::max(0, be32(s, p)));
  if (p != s.size()) throw std::logic_error("layout_of: the seed's fields end at byte " + std::to_string(p) +
                                            " of " + std::to_string(s.size()));
  return L;
}

const int32_t kHostileCounts[] = {0, 1, -1, 2, 6, 7, 12, 17, 18, 19, 88, 89, 255, 256, 65535, 65536, 1 << 20,
                                  1 << 30, std::numeric_limits<int32_t>::max(), std::numeric_limits<int32_t>::min(),
                                  std::numeric_limits<int32_t>::max() - 3, -4};
const double kHostileDoubles[] = {std::numeric_limits<double>::quiet_NaN(), -std::numeric_limits<double>::quiet_NaN(),
                                  std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                                  1e308, -1e308, std::numeric_limits<double>::max(), std::numeric_limits<double>::denorm_min(),
                                  -0.0, 0.0, 1e6, -1e6, 97.6, 186.40000000000001, 1e-300, 4.9e-324};

std::string mutate_bytes(std::string s, const std::vector<std::string>& seeds, const Layout* L, std::mt19937_64& r) {
  const int n_mut = 1 + static_cast<int>(pick(r, 4));
  for (int m = 0; m < n_mut; ++m) {
    const size_t op = pick(r, L ? 10 : 6);
    switch (op) {
      case 0: {  // flip 1..8 bits
        if (s.empty()) break;
        for (size_t k = 0, nb = 1 + pick(r, 8); k < nb; ++k) s[pick(r, s.size())] ^= static_cast<char>(1u << pick(r, 8));
        break;
      }
      case 1:  // truncate
        s.resize(pick(r, s.size() + 1));
        break;
      case 2: {  // insert 1..16 random bytes
        const size_t at = pick(r, s.size() + 1), nb = 1 + pick(r, 16);
        std::string ins;
        for (size_t k = 0; k < nb; ++k) ins.push_back(static_cast<char>(pick(r, 256)));
        s.insert(at, ins);
        break;
      }
      case 3: {  // delete a range
        if (s.empty()) break;
        const size_t at = pick(r, s.size());
        s.erase(at, 1 + pick(r, std::min<size_t>(64, s.size() - at)));
        break;
      }
      case 4: {  // duplicate a range
        if (s.empty()) break;
        const size_t at = pick(r, s.size()), len = 1 + pick(r, std::min<size_t>(64, s.size() - at));
        s.insert(pick(r, s.size() + 1), s.substr(at, len));
        break;
      }
      case 5: {  // splice: head of this, tail of another seed
        const std::string& o = seeds[pick(r, seeds.size())];
        s = s.substr(0, pick(r, s.size() + 1)) + o.substr(pick(r, o.size() + 1));
        break;
      }
      case 6:
      case 7: {  // a count or string length set to a hostile value (field offsets of the seed)
        if (L->i32.empty()) break;
        const size_t at = L->i32[pick(r, L->i32.size())];
        if (at + 4 > s.size()) break;
        int32_t v = kHostileCounts[pick(r, std::size(kHostileCounts))];
        if (pick(r, 3) == 0)  // off by a little (wrapping, as 32 bits on the wire do)
          v = static_cast<int32_t>(static_cast<uint32_t>(be32(s, at)) + static_cast<uint32_t>(pick(r, 5)) - 2u);
        put_be32(s, at, v);
        break;
      }
      case 8: {  // a double set to a hostile value
        if (L->f64.empty()) break;
        const size_t at = L->f64[pick(r, L->f64.size())];
        if (at + 8 > s.size()) break;
        const double d = kHostileDoubles[pick(r, std::size(kHostileDoubles))];
        uint64_t u;
        std::memcpy(&u, &d, 8);
        put_be64(s, at, u);
        break;
      }
      case 9: {  // the fingerprint of the other message type, or a random one
        if (s.size() < 8) break;
        const std::string& o = seeds[pick(r, seeds.size())];
        if (o.size() >= 8 && pick(r, 2)) s.replace(0, 8, o.substr(0, 8));
        else s[pick(r, 8)] ^= static_cast<char>(1 + pick(r, 255));
        break;
      }
    }
  }
  return s;
}

// ---- text (YAML) mutations --------------------------------------------------------------------
const char* const kHostileNumbers[] = {"1e308", "-1e308", "1e400", "-1e400", "1e-320", ".nan", ".NaN", "nan", ".inf",
                                       "-.inf", "0", "-0", "-1", "99999999999999999999", "0x7fffffff", "2147483648",
                                       "-2147483649", "1e9", "1e13", "3.0e-300", "0.001", "1e-9", "~", "''", "[]",
                                       "{}", "[1, 2]", "true", "18446744073709551616", "0.0000001"};
const char* const kSnippets[] = {"? [a, b]\n: 1\n", "&a ", "*a ", "<<: *a\n", "!!binary ", "!!map ", "{", "[", "}", "]",
                                 ": ", "- ", "  ", "\t", "#", "'", "\"", "|\n", ">\n", "---\n", "...\n", "%YAML 1.2\n",
                                 "x: [[[[[[[[[[[[1]]]]]]]]]]]]\n", "? \n", "!<tag:x> ", "\\u0000", "\xff\xfe",
                                 "actuated: true\n", "tau_limit: 0\n", "pseudo: true\n", "type: floating\n",
                                 "name: dup\n", "reactions: all\n", "formulation: classic\n", "formulation: svd\n",
                                 "formulation: pseudo_joint\n", "projection: {iterations: 50}\n"};
const char* const kKeys[] = {"name",      "mass",      "com",    "inertia",  "pose",     "velocity", "q",       "v",
                             "tau_limit", "armature",  "joint",  "type",     "axis",     "parent",   "placement",
                             "frame",     "to",        "axes",   "radius",   "axle",     "body",     "actuated",
                             "load",      "arms",      "bodies", "robots",   "file",     "urdf",     "rate_hz",
                             "watchdog_ms", "channels", "policy", "damping", "realtime", "cpu",     "priority"};

std::vector<std::pair<size_t, size_t>> number_tokens(const std::string& s) {
  std::vector<std::pair<size_t, size_t>> out;
  for (size_t i = 0; i < s.size();) {
    const bool start = (std::isdigit(static_cast<unsigned char>(s[i])) || s[i] == '-' || s[i] == '.') &&
                       (i == 0 || !std::isalnum(static_cast<unsigned char>(s[i - 1])));
    if (!start) {
      ++i;
      continue;
    }
    size_t j = i + 1;
    while (j < s.size() && (std::isdigit(static_cast<unsigned char>(s[j])) || s[j] == '.' || s[j] == 'e' || s[j] == 'E' ||
                            s[j] == '-' || s[j] == '+'))
      ++j;
    if (j - i > 1 || std::isdigit(static_cast<unsigned char>(s[i]))) out.push_back({i, j - i});
    i = j;
  }
  return out;
}
std::vector<size_t> line_starts(const std::string& s) {
  std::vector<size_t> out{0};
  for (size_t i = 0; i + 1 < s.size(); ++i)
    if (s[i] == '\n') out.push_back(i + 1);
  return out;
}

std::string mutate_text(std::string s, const std::vector<std::string>& seeds, std::mt19937_64& r) {
  const int n_mut = 1 + static_cast<int>(pick(r, 3));
  for (int m = 0; m < n_mut; ++m) {
    const size_t op = pick(r, 10);
    if (op < 3) {  // byte-level
      static const char kAlphabet[] = ":{}[],-&*!|>'\"#?%@` \t\n0123456789.eE+-abcxyz_";
      std::string t = mutate_bytes(s, seeds, nullptr, r);
      if (pick(r, 2) && !t.empty())  // and a YAML-ish character somewhere
        t.insert(pick(r, t.size() + 1), 1, kAlphabet[pick(r, sizeof kAlphabet - 1)]);
      s = t;
    } else if (op < 6) {  // a number replaced by a hostile value
      const auto toks = number_tokens(s);
      if (toks.empty()) continue;
      const auto [at, len] = toks[pick(r, toks.size())];
      s.replace(at, len, kHostileNumbers[pick(r, std::size(kHostileNumbers))]);
    } else if (op < 8) {  // a line deleted, duplicated, swapped or re-indented
      const auto ls = line_starts(s);
      const size_t a = ls[pick(r, ls.size())];
      const size_t ae = s.find('\n', a) == std::string::npos ? s.size() : s.find('\n', a) + 1;
      const std::string line = s.substr(a, ae - a);
      switch (pick(r, 4)) {
        case 0: s.erase(a, ae - a); break;
        case 1: s.insert(ae, line); break;
        case 2: {
          const size_t b = ls[pick(r, ls.size())];
          s.erase(a, ae - a);
          s.insert(std::min(b, s.size()), line);
          break;
        }
        case 3:
          if (pick(r, 2) && s.compare(a, 2, "  ") == 0) s.erase(a, 2);
          else s.insert(a, "  ");
          break;
      }
    } else if (op < 9) {  // a snippet inserted at a line start or anywhere
      const auto ls = line_starts(s);
      const size_t at = pick(r, 2) ? ls[pick(r, ls.size())] : pick(r, s.size() + 1);
      s.insert(at, kSnippets[pick(r, std::size(kSnippets))]);
    } else {  // a key replaced by another key of the formats
      const auto ls = line_starts(s);
      const size_t a = ls[pick(r, ls.size())];
      size_t k = a;
      while (k < s.size() && (s[k] == ' ' || s[k] == '-')) ++k;
      const size_t colon = s.find(':', k);
      if (colon == std::string::npos || s.find('\n', k) < colon) continue;
      s.replace(k, colon - k, kKeys[pick(r, std::size(kKeys))]);
    }
  }
  if (s.size() > (1u << 16)) s.resize(1u << 16);  // the inputs stay small (the loaders bound files separately)
  return s;
}

// ---- seeds ------------------------------------------------------------------------------------
struct BinarySeed {
  std::string scene, bytes;
};
// <scene>.<label>.bin: a valid encoding for config/scenes/<scene>.yaml.
std::vector<BinarySeed> binary_seeds(const std::string& kind) {
  std::vector<BinarySeed> out;
  for (const std::string& p : list_dir(kCorpus + "/" + kind, ".bin")) {
    const std::string base = p.substr(p.rfind('/') + 1);
    out.push_back({base.substr(0, base.find('.')), slurp(p)});
  }
  return out;
}

// The key of the signed seeds (<scene>.signed.bin), and the channels they are signed for.
io::AuthKey fuzz_key() { return io::parse_key("a0a1a2a3a4a5a6a7a8a9aaabacadaeafb0b1b2b3b4b5b6b7b8b9babbbcbdbebf", "fuzz key"); }
const char* const kFuzzChannel[] = {"COOPDYN_COMMAND", "COOPDYN_STATE"};

// The binary corpus, regenerated from the shipped scenes (torques within the limits, 0 on
// unactuated DOFs; states at the initial state), unsigned and signed with fuzz_key().
int write_corpus(const std::string& dir) {
  for (const char* sub : {"/command", "/state"}) {
    const std::string d = dir + sub;
    if (system(("mkdir -p '" + d + "'").c_str()) != 0) return 1;
  }
  auto save = [&](const std::string& path, const std::vector<uint8_t>& b) {
    std::ofstream f(path, std::ios::binary);
    f.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
    std::printf("wrote %s (%zu bytes)\n", path.c_str(), b.size());
  };
  {  // the car's drive torques with steer targets (lock targets by name)
    save(dir + "/command/four_wheel_car.steer.bin",
         io::encode_torque_command(1718000000000000LL, 3, {"rl_spin", "rr_spin"}, {120.0, 120.0}, {"fl_steer", "fr_steer"},
                                   {0.0689, 0.0652}));
  }
  for (const char* name : {"two_puma_load", "four_bar", "unicycle", "two_wheel_vehicle"}) {
    const System sys = load_scene(kSrc + "/config/scenes/" + name + ".yaml");
    const int nv = sys.model.nv();
    std::vector<double> tau(nv, 0.0);
    std::vector<std::string> names;
    std::vector<double> named;
    for (int i = 0; i < nv; ++i) {
      const double lim = sys.tau_limit[i];
      tau[i] = lim > 0 ? std::min(lim, 0.5 + 0.25 * i) * (i % 2 ? -1 : 1) : 0.0;
      if (lim > 0 && names.size() < 3) {
        names.push_back(sys.model.v_names[i]);
        named.push_back(tau[i]);
      }
    }
    const int64_t t = 1718000000000000LL;
    save(dir + "/command/" + name + ".ordered.bin", io::encode_torque_command(t, 1, {}, tau));
    std::vector<uint8_t> signed_cmd = io::encode_torque_command(t, 4, {}, tau), signed_state =
        io::encode_measured_state(t, 4, {}, std::vector<double>(sys.q0.data(), sys.q0.data() + sys.q0.size()), {},
                                  std::vector<double>(sys.v0.data(), sys.v0.data() + nv), tau);
    io::sign(signed_cmd, kFuzzChannel[0], fuzz_key(), io::MessageType::kTorqueCommand);
    io::sign(signed_state, kFuzzChannel[1], fuzz_key(), io::MessageType::kMeasuredState);
    save(dir + "/command/" + name + ".signed.bin", signed_cmd);
    save(dir + "/state/" + name + ".signed.bin", signed_state);
    if (!names.empty()) save(dir + "/command/" + name + ".named.bin", io::encode_torque_command(t, 2, names, named));
    const std::vector<double> q(sys.q0.data(), sys.q0.data() + sys.q0.size()), v(sys.v0.data(), sys.v0.data() + nv);
    save(dir + "/state/" + name + ".ordered.bin", io::encode_measured_state(t, 1, {}, q, {}, v, tau));
    save(dir + "/state/" + name + ".named.bin",
         io::encode_measured_state(t, 2, sys.model.q_names, q, sys.model.v_names, v, tau));
    {  // named in reverse order, with every sensor's reading in reverse order (the lookups of names)
      std::vector<std::string> rq(sys.model.q_names.rbegin(), sys.model.q_names.rend()),
          rv(sys.model.v_names.rbegin(), sys.model.v_names.rend()), wn;
      std::vector<std::array<double, 6>> w;
      for (size_t k = sys.wrenches.outputs.size(); k-- > 0;) {
        wn.push_back(sys.wrenches.outputs[k].name);
        w.push_back({0.5 * static_cast<double>(k), -1.0, 2.0, -3.0, 4.0, -5.0});
      }
      save(dir + "/state/" + name + ".reversed.bin",
           io::encode_measured_state(t, 5, rq, std::vector<double>(q.rbegin(), q.rend()), rv, std::vector<double>(v.rbegin(), v.rend()),
                                     std::vector<double>(tau.rbegin(), tau.rend()), wn, w));
    }
    // the arms' joints only (the load fitted) with a wrist sensor's reading, where the scene allows it
    const StateFitPlan plan = plan_state_fit(sys);
    if (plan.q_fittable && plan.v_fittable && !sys.wrenches.outputs.empty()) {
      std::vector<std::string> jq, jv;
      std::vector<double> qj, vj, tj;
      for (int i = 0; i < sys.model.nq(); ++i)
        if (std::find(plan.fit_q.begin(), plan.fit_q.end(), i) == plan.fit_q.end()) jq.push_back(sys.model.q_names[i]), qj.push_back(q[i]);
      for (int i = 0; i < nv; ++i)
        if (std::find(plan.fit_v.begin(), plan.fit_v.end(), i) == plan.fit_v.end())
          jv.push_back(sys.model.v_names[i]), vj.push_back(v[i]), tj.push_back(tau[i]);
      save(dir + "/state/" + name + ".joints_sensor.bin",
           io::encode_measured_state(t, 3, jq, qj, jv, vj, tj, {sys.wrenches.outputs[0].name}, {{0.1, -0.2, 0.3, 1.0, -2.0, 30.0}}));
    }
  }
  return 0;
}

// ---- the LCM wire parser and reassembler (service/io/transport/lcm_wire.h) -------------------------------
// A wire input is a sequence of datagrams, each framed as [u8 sender][u16 length, big-endian][bytes]
// (tests/fuzz/corpus/wire/*.bin). Mutations: a datagram's bytes (mutate_bytes), an LC03 header field
// set to a hostile value, a datagram repeated, dropped or moved, another sender.
struct Framed {
  uint8_t sender;
  std::string bytes;
};
std::vector<Framed> unframe(const std::string& s) {
  std::vector<Framed> out;
  for (size_t p = 0; p + 3 <= s.size();) {
    const size_t n = std::min<size_t>((static_cast<unsigned char>(s[p + 1]) << 8) | static_cast<unsigned char>(s[p + 2]),
                                      s.size() - p - 3);
    out.push_back({static_cast<uint8_t>(s[p]), s.substr(p + 3, n)});
    p += 3 + n;
  }
  return out;
}
std::string frame(const std::vector<Framed>& ds) {
  std::string s;
  for (const Framed& d : ds) {
    const size_t n = std::min<size_t>(d.bytes.size(), 65535);
    s.push_back(static_cast<char>(d.sender));
    s.push_back(static_cast<char>(n >> 8));
    s.push_back(static_cast<char>(n));
    s.append(d.bytes, 0, n);
  }
  return s;
}
const uint32_t kHostileWire[] = {0, 1, 2, 3, 7, 8, 100, 255, 256, 1000, 1199, 1200, 2999, 3000, 3001, 4095, 4096, 4097,
                                 65535, 65536, 0x7fffffffu, 0x80000000u, 0xFFFFFF00u, 0xFFFFFFFFu};
std::string mutate_wire(const std::string& input, const std::vector<std::string>& seeds, std::mt19937_64& r) {
  std::vector<Framed> ds = unframe(input);
  if (ds.empty()) ds.push_back({0, std::string()});
  const int n_mut = 1 + static_cast<int>(pick(r, 3));
  for (int m = 0; m < n_mut; ++m) {
    Framed& d = ds[pick(r, ds.size())];
    switch (pick(r, 6)) {
      case 0: d.bytes = mutate_bytes(d.bytes, seeds, nullptr, r); break;
      case 1:
      case 2: {  // an LC03 field: msg_size (8), fragment_offset (12), fragment_no (16) or n_fragments (18)
        static const size_t kAt[] = {8, 12, 16, 18};
        const size_t at = kAt[pick(r, 4)];
        if (d.bytes.size() < at + 4) break;
        const uint32_t v = kHostileWire[pick(r, std::size(kHostileWire))];
        if (at >= 16) {
          d.bytes[at] = static_cast<char>(v >> 8);
          d.bytes[at + 1] = static_cast<char>(v);
        } else {
          put_be32(d.bytes, at, static_cast<int32_t>(v));
        }
        break;
      }
      case 3: ds.push_back(ds[pick(r, ds.size())]); break;                          // repeated (at the end)
      case 4: if (ds.size() > 1) ds.erase(ds.begin() + static_cast<long>(pick(r, ds.size()))); break;  // dropped
      case 5:
        if (pick(r, 2)) std::swap(ds[pick(r, ds.size())], ds[pick(r, ds.size())]);  // moved
        else d.sender = static_cast<uint8_t>(pick(r, 4));                             // another sender
        break;
    }
  }
  return frame(ds);
}

// The wire corpus: liblcm's datagrams of a command (LC02), of a 3000-byte message in three
// fragments (in order, and reversed with a repeat), and the fragment that crashes liblcm 1.3.1.
int write_wire_corpus(const std::string& dir) {
  if (system(("mkdir -p '" + dir + "/wire'").c_str()) != 0) return 1;
  auto be = [](std::string& s, uint32_t v, int bytes) {
    for (int k = bytes - 1; k >= 0; --k) s.push_back(static_cast<char>(v >> (8 * k)));
  };
  auto save = [&](const std::string& name, const std::vector<Framed>& ds) {
    const std::string s = frame(ds);
    std::ofstream(dir + "/wire/" + name, std::ios::binary).write(s.data(), static_cast<std::streamsize>(s.size()));
    std::printf("wrote %s/wire/%s (%zu bytes)\n", dir.c_str(), name.c_str(), s.size());
  };
  const std::vector<uint8_t> cmd = io::encode_torque_command(1718000000000000LL, 1, {}, {0.5, -0.25, 0.0, 1.0});
  std::string lc02;
  be(lc02, io::wire::kShortMagic, 4);
  be(lc02, 7, 4);
  lc02 += std::string("COOPDYN_COMMAND") + '\0' + std::string(cmd.begin(), cmd.end());
  save("lc02_command.bin", {{0, lc02}});
  std::string msg(3000, '\0');
  for (size_t i = 0; i < msg.size(); ++i) msg[i] = static_cast<char>(i * 31 + 7);
  std::memcpy(&msg[0], cmd.data(), 8);  // the command's fingerprint first
  std::vector<Framed> frags;
  const std::string channel = "COOPDYN_COMMAND";
  const size_t first = 1200 - channel.size() - 1;
  for (uint32_t k = 0, off = 0; k < 3; ++k) {
    const size_t n = k == 0 ? first : std::min<size_t>(1200, msg.size() - off);
    std::string f;
    be(f, io::wire::kFragmentMagic, 4);
    be(f, 9, 4);
    be(f, 3000, 4);
    be(f, off, 4);
    be(f, k, 2);
    be(f, 3, 2);
    if (k == 0) f += channel + '\0';
    f += msg.substr(off, n);
    frags.push_back({1, f});
    off += static_cast<uint32_t>(n);
  }
  save("lc03_three_fragments.bin", frags);
  save("lc03_reversed_repeated.bin", {frags[2], frags[1], frags[1], frags[0]});
  std::string crafted;
  be(crafted, io::wire::kFragmentMagic, 4);
  be(crafted, 1, 4);
  be(crafted, 100, 4);
  be(crafted, 0xFFFFFF00u, 4);
  be(crafted, 0, 2);
  be(crafted, 2, 2);
  crafted += channel + '\0';
  crafted.resize(324, '\xab');
  save("crafted_liblcm_crash.bin", {{2, crafted}});
  return 0;
}

// Feeds one input's datagrams to a fresh-state reassembler; "" or what went wrong. complete:
// messages put together.
std::string run_wire(io::wire::Reassembler& reasm, const std::string& input, long long* now, int* complete) {
  for (const Framed& d : unframe(input)) {
    io::wire::Message m;
    *now += 1000;
    const io::wire::WireStatus st = reasm.add(d.bytes.data(), d.bytes.size(), d.sender, *now, &m);
    const int si = static_cast<int>(st);
    if (si < 0 || si >= io::wire::kWireStatuses) return "status out of range";
    if (reasm.busy_slots() > 4) return "more busy slots than the reassembler has";
    if (st != io::wire::WireStatus::kComplete) continue;
    ++*complete;
    if (m.len < 0 || m.len > 4096) return "a complete message of " + std::to_string(m.len) + " bytes (max 4096)";
    if (m.channel_len < 1 || m.channel_len > io::wire::kMaxChannel || std::strlen(m.channel) != static_cast<size_t>(m.channel_len))
      return "a complete message with a malformed channel";
    volatile uint8_t sum = 0;  // every byte readable (ASan checks)
    for (int k = 0; k < m.len; ++k) sum = static_cast<uint8_t>(sum + m.data[k]);
  }
  return "";
}

// ---- checks of a clean result -----------------------------------------------------------------
std::string check_command(const System& sys, const io::CommandSlot& c) {
  for (int i = 0; i < sys.model.nv(); ++i) {
    const double t = c.tau[i], lim = sys.tau_limit[i];
    if (!std::isfinite(t)) return "accepted command with a non-finite torque on " + sys.model.v_names[i];
    if (std::abs(t) > lim) return "accepted command over tau_limit on " + sys.model.v_names[i];
    if (lim == 0 && t != 0) return "accepted command with force on unactuated " + sys.model.v_names[i];
  }
  for (size_t k = 0; k < sys.constraints.specs.size(); ++k) {
    const ConstraintSpec& sp = sys.constraints.specs[k];
    if (sp.kind != ConstraintKind::kLock) continue;
    const double x = c.lock_target[static_cast<Eigen::Index>(k)];
    if (!std::isfinite(x)) return "accepted command with a non-finite target for " + sp.name;
    if (x != sp.q_target && !(std::abs(x) <= sp.target_limit)) return "accepted command with a target over target_limit for " + sp.name;
  }
  return "";
}
std::string check_state(const io::StateSlot& s) {
  if (!s.q.allFinite() || !s.v.allFinite() || !s.tau.allFinite()) return "accepted state with a non-finite value";
  return "";
}

template <class Decoder, class Slot>
struct DecoderRig {
  const System* sys;
  std::unique_ptr<Decoder> dec;
  Slot slot, again;
};

template <class Decoder, class Slot>
void fuzz_decoder(const char* target, const std::string& kind, bool state, long iters) {
  const std::vector<BinarySeed> seeds = binary_seeds(kind);
  ASSERT_GE(seeds.size(), 4u) << "corpus " << kCorpus << "/" << kind << " (regenerate: coopdyn_fuzz_tests --write-corpus)";
  std::map<std::string, System> systems;
  for (const BinarySeed& s : seeds)
    if (!systems.count(s.scene)) systems.emplace(s.scene, load_scene(kSrc + "/config/scenes/" + s.scene + ".yaml"));
  std::vector<DecoderRig<Decoder, Slot>> rigs;
  std::vector<Layout> layouts;
  std::vector<std::string> all;
  for (const BinarySeed& s : seeds) {
    const System& sys = systems.at(s.scene);
    DecoderRig<Decoder, Slot> r{&sys, std::make_unique<Decoder>(sys), {}, {}};
    r.slot.tau = r.again.tau = Eigen::VectorXd::Zero(sys.model.nv());
    if constexpr (std::is_same_v<Slot, io::CommandSlot>)
      r.slot.lock_target = r.again.lock_target = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(sys.constraints.specs.size()));
    if constexpr (std::is_same_v<Slot, io::StateSlot>) {
      r.slot.q = r.again.q = Eigen::VectorXd::Zero(sys.model.nq());
      r.slot.v = r.again.v = Eigen::VectorXd::Zero(sys.model.nv());
    }
    // every seed is a valid message for its scene: the mutations start from something the decoder accepts
    const io::Reject rj = r.dec->decode(s.bytes.data(), static_cast<int>(s.bytes.size()), r.slot);
    ASSERT_EQ(rj, io::Reject::kNone) << "seed for " << s.scene << " rejected: " << io::reject_name(rj)
                                     << " (regenerate the corpus: coopdyn_fuzz_tests --write-corpus " << kCorpus << ")";
    layouts.push_back(layout_of(s.bytes, state));
    all.push_back(s.bytes);
    rigs.push_back(std::move(r));
  }
  std::vector<long> by_reason(io::kRejectKinds, 0);
  // every input also goes through the MAC check (authentication on): only a signed seed's exact
  // bytes may verify, anything else is a forgery the check let through
  const io::Verifier verifier(fuzz_key(), kFuzzChannel[state ? 1 : 0], state ? io::MessageType::kMeasuredState : io::MessageType::kTorqueCommand);
  run_target(target, iters, [&](long i) -> std::string {
    std::mt19937_64 rng = rng_for(target, i);
    const size_t k = static_cast<size_t>(i) % seeds.size();
    g_input = mutate_bytes(all[k], all, &layouts[k], rng);
    auto& r = rigs[k];
    io::Reject rj;
    try {
      rj = r.dec->decode(g_input.data(), static_cast<int>(g_input.size()), r.slot);
    } catch (const std::exception& e) {
      return std::string("decoder threw ") + e.what();
    } catch (...) {
      return "decoder threw a non-standard exception";
    }
    const int ri = static_cast<int>(rj);
    if (ri < 0 || ri >= io::kRejectKinds) return "reject code out of range";
    if (verifier.check(g_input.data(), static_cast<int>(g_input.size())) == io::Reject::kNone &&
        std::find(all.begin(), all.end(), g_input) == all.end())
      return "a mutated message passed the MAC check";
    ++by_reason[ri];
    if (rj == io::Reject::kNone) {
      std::string why;
      if constexpr (std::is_same_v<Slot, io::CommandSlot>) why = check_command(*r.sys, r.slot);
      else why = check_state(r.slot);
      if (!why.empty()) return why;
    }
    // the reused message object carries nothing over: a fresh decoder, after another message,
    // answers the same (every 8th input; a fresh decoder builds its name maps)
    if (i % 8 == 0) {
      Decoder fresh(*r.sys);
      const io::Reject rj2 = fresh.decode(g_input.data(), static_cast<int>(g_input.size()), r.again);
      if (rj2 != rj) return std::string("a fresh decoder answers ") + io::reject_name(rj2) + ", the reused one " + io::reject_name(rj);
      if (rj == io::Reject::kNone && r.again.tau != r.slot.tau) return "a fresh decoder decodes other torques";
      if constexpr (std::is_same_v<Slot, io::CommandSlot>)
        if (rj == io::Reject::kNone && r.again.lock_target != r.slot.lock_target) return "a fresh decoder decodes other targets";
    }
    return "";
  });
  std::printf("[fuzz] %s outcomes:", target);
  for (int k = 0; k < io::kRejectKinds; ++k)
    if (by_reason[k]) std::printf(" %s %ld,", io::reject_name(static_cast<io::Reject>(k)), by_reason[k]);
  std::printf("\n");
  // the mutations reach past the framing: values are decoded and judged, not only headers
  EXPECT_GT(by_reason[static_cast<int>(io::Reject::kNone)], 0);
  EXPECT_GT(by_reason[static_cast<int>(io::Reject::kDecode)], 0);
  EXPECT_GT(by_reason[static_cast<int>(io::Reject::kCount)], 0);
  EXPECT_GT(by_reason[static_cast<int>(io::Reject::kNonFinite)], 0);
  if (!state) {  // torques judged against the limits: the PUMA's, and 0 on unactuated DOFs
    EXPECT_GT(by_reason[static_cast<int>(io::Reject::kOverLimit)], 0);
    EXPECT_GT(by_reason[static_cast<int>(io::Reject::kUnactuated)], 0);
  }
}

}  // namespace

TEST(Fuzz, CommandDecoder) {
  fuzz_decoder<io::CommandDecoder, io::CommandSlot>("CommandDecoder", "command", false, kDecoderIters);
}

TEST(Fuzz, StateDecoder) {
  fuzz_decoder<io::StateDecoder, io::StateSlot>("StateDecoder", "state", true, kDecoderIters);
}

// The allocation-free state decoder the loop's thread runs, differentially: every mutated state goes
// through it and through the generated decoder (StateDecoder), which must agree.
TEST(Fuzz, DirectStateDecoder) {
  const std::vector<BinarySeed> seeds = binary_seeds("state");
  ASSERT_GE(seeds.size(), 4u) << "corpus " << kCorpus << "/state (regenerate: coopdyn_fuzz_tests --write-corpus)";
  std::map<std::string, System> systems;
  for (const BinarySeed& s : seeds)
    if (!systems.count(s.scene)) systems.emplace(s.scene, load_scene(kSrc + "/config/scenes/" + s.scene + ".yaml"));
  struct Rig {
    const System* sys;
    std::unique_ptr<io::StateDecoder> generated;
    std::unique_ptr<io::DirectStateDecoder> direct;
    io::StateSlot a, b;
  };
  std::vector<Rig> rigs;
  std::vector<Layout> layouts;
  std::vector<std::string> all;
  for (const BinarySeed& s : seeds) {
    const System& sys = systems.at(s.scene);
    Rig r{&sys, std::make_unique<io::StateDecoder>(sys), std::make_unique<io::DirectStateDecoder>(sys), {}, {}};
    for (io::StateSlot* x : {&r.a, &r.b}) {
      x->q = Eigen::VectorXd::Zero(sys.model.nq());
      x->v = x->tau = Eigen::VectorXd::Zero(sys.model.nv());
    }
    const io::Reject rj = r.direct->decode(s.bytes.data(), static_cast<int>(s.bytes.size()), r.b);
    ASSERT_EQ(rj, io::Reject::kNone) << "seed for " << s.scene << " rejected: " << io::reject_name(rj);
    layouts.push_back(layout_of(s.bytes, true));
    all.push_back(s.bytes);
    rigs.push_back(std::move(r));
  }
  std::vector<long> by_reason(io::kRejectKinds, 0);
  run_target("DirectStateDecoder", kDecoderIters, [&](long i) -> std::string {
    std::mt19937_64 rng = rng_for("DirectStateDecoder", i);
    const size_t k = static_cast<size_t>(i) % seeds.size();
    g_input = mutate_bytes(all[k], all, &layouts[k], rng);
    Rig& r = rigs[k];
    const int n = static_cast<int>(g_input.size());
    const io::Reject rg = r.generated->decode(g_input.data(), n, r.a);
    const io::Reject rd = r.direct->decode(g_input.data(), n, r.b);
    if (rg != rd) return std::string("the direct decoder answers ") + io::reject_name(rd) + ", the generated one " + io::reject_name(rg);
    ++by_reason[static_cast<int>(rd)];
    if (rd != io::Reject::kNone) return "";
    if (r.a.q != r.b.q || r.a.v != r.b.v || r.a.tau != r.b.tau) return "the direct decoder decodes another state";
    if (r.a.fit_q != r.b.fit_q || r.a.fit_v != r.b.fit_v || r.a.utime != r.b.utime || r.a.seq != r.b.seq)
      return "the direct decoder decodes other flags, utime or seq";
    if (r.a.has_wrench != r.b.has_wrench || r.a.n_wrenches != r.b.n_wrenches) return "the direct decoder finds other sensors";
    for (size_t t = 0; t < r.a.has_wrench.size(); ++t)
      if (r.a.has_wrench[t] && r.a.wrench[t] != r.b.wrench[t]) return "the direct decoder reads another sensor value";
    return check_state(r.b);
  });
  std::printf("[fuzz] DirectStateDecoder outcomes:");
  for (int k = 0; k < io::kRejectKinds; ++k)
    if (by_reason[k]) std::printf(" %s %ld,", io::reject_name(static_cast<io::Reject>(k)), by_reason[k]);
  std::printf("\n");
  EXPECT_GT(by_reason[static_cast<int>(io::Reject::kNone)], 0);
  EXPECT_GT(by_reason[static_cast<int>(io::Reject::kDecode)], 0);
  EXPECT_GT(by_reason[static_cast<int>(io::Reject::kUnknownName)], 0);
  EXPECT_GT(by_reason[static_cast<int>(io::Reject::kNonFinite)], 0);
}

TEST(Fuzz, SceneLoader) {
  // seeds: the shipped scenes, loaded under their own path (robot files resolve), and the corpus
  std::vector<std::pair<std::string, std::string>> seeds;  // path, text
  for (const std::string& p : list_dir(kSrc + "/config/scenes", ".yaml")) seeds.push_back({p, slurp(p)});
  for (const std::string& p : list_dir(kCorpus + "/scene", ".yaml")) seeds.push_back({p, slurp(p)});
  ASSERT_GE(seeds.size(), 8u);
  std::vector<std::string> texts;
  for (const auto& s : seeds) {
    texts.push_back(s.second);
    ASSERT_NO_THROW(load_scene_string(s.second, s.first)) << s.first << " is not a valid seed";
  }
  long loaded = 0, errors = 0;
  run_target("SceneLoader", kSceneIters, [&](long i) -> std::string {
    std::mt19937_64 rng = rng_for("SceneLoader", i);
    const size_t k = static_cast<size_t>(i) % seeds.size();
    g_input = mutate_text(texts[k], texts, rng);
    try {
      const System sys = load_scene_string(g_input, seeds[k].first);
      ++loaded;
      const int nq = sys.model.nq(), nv = sys.model.nv();
      if (sys.q0.size() != nq || sys.v0.size() != nv || sys.tau_limit.size() != nv) return "loaded scene with inconsistent sizes";
      if (!sys.q0.allFinite() || !sys.v0.allFinite()) return "loaded scene with a non-finite initial state";
      for (int d = 0; d < nv; ++d)
        if (!(sys.tau_limit[d] >= 0)) return "loaded scene with tau_limit < 0 or NaN on " + sys.model.v_names[d];
      Workspace ws(sys);
      const Diagnostics& d = evaluate(sys, ws, sys.q0, sys.v0, Eigen::VectorXd::Zero(nv));
      if (!ws.vdot.allFinite()) return "a loaded scene evaluates to a non-finite vdot";
      if (d.status == Status::kError && ws.vdot.cwiseAbs().maxCoeff() != 0) return "error status with nonzero outputs";
    } catch (const SceneError& e) {
      ++errors;
      const std::string w = e.what();
      if (w.empty()) return "SceneError without a message";
      if (w.size() > 4096) return "SceneError message of " + std::to_string(w.size()) + " characters";
      if (w.compare(0, seeds[k].first.size(), seeds[k].first) != 0 && w.find(".yaml") == std::string::npos &&
          w.find(".urdf") == std::string::npos)
        return "SceneError that names no file: " + w.substr(0, 200);
    } catch (const std::exception& e) {
      return std::string("load_scene_string threw a non-SceneError: ") + e.what();
    } catch (...) {
      return "load_scene_string threw a non-standard exception";
    }
    return "";
  });
  std::printf("[fuzz] SceneLoader outcomes: loaded %ld, SceneError %ld\n", loaded, errors);
  EXPECT_GT(loaded, 0);  // some mutations keep a valid scene (a hostile number where it is legal)
  EXPECT_GT(errors, 0);
}

TEST(Fuzz, ConfigLoader) {
  std::vector<std::pair<std::string, std::string>> seeds;
  seeds.push_back({kSrc + "/config/coopdynd.yaml", slurp(kSrc + "/config/coopdynd.yaml")});
  for (const std::string& p : list_dir(kCorpus + "/config", ".yaml")) seeds.push_back({p, slurp(p)});
  ASSERT_GE(seeds.size(), 3u);
  std::vector<std::string> texts;
  for (const auto& s : seeds) {
    texts.push_back(s.second);
    ASSERT_NO_THROW(runtime::load_config_string(s.second, s.first)) << s.first << " is not a valid seed";
  }
  long loaded = 0, errors = 0;
  run_target("ConfigLoader", kConfigIters, [&](long i) -> std::string {
    std::mt19937_64 rng = rng_for("ConfigLoader", i);
    const size_t k = static_cast<size_t>(i) % seeds.size();
    g_input = mutate_text(texts[k], texts, rng);
    try {
      const runtime::ServiceConfig c = runtime::load_config_string(g_input, seeds[k].first);
      ++loaded;
      try {
        runtime::validate(c);
      } catch (const runtime::ConfigError& e) {
        return std::string("a loaded config fails validate(): ") + e.what();
      }
      // the documented bounds (service/runtime/config.h)
      if (!(c.rate_hz >= runtime::kMinRateHz && c.rate_hz <= runtime::kMaxRateHz)) return "rate_hz out of bounds";
      if (!(c.watchdog_ms >= runtime::kMinWatchdogMs && c.watchdog_ms <= runtime::kMaxWatchdogMs)) return "watchdog_ms out of bounds";
      if (!(c.stats_period_s >= 1.0 / c.rate_hz - 1e-12 && c.stats_period_s <= runtime::kMaxStatsPeriodS))
        return "stats_period_s out of bounds";
      if (!(c.max_input_age_ms == 0 || (c.max_input_age_ms >= 1 && c.max_input_age_ms <= runtime::kMaxWatchdogMs)))
        return "max_input_age_ms out of bounds";
      if (c.max_catch_up < 0 || c.max_catch_up > runtime::kMaxCatchUp) return "max_catch_up out of bounds";
      if (c.realtime.cpu < -1 || c.realtime.cpu > runtime::kMaxCpu) return "realtime.cpu out of bounds";
      if (c.realtime.priority < 1 || c.realtime.priority > 99) return "realtime.priority out of bounds";
      if (!std::isfinite(c.damping)) return "damping not finite";
      for (const std::string* ch : {&c.command_channel, &c.state_channel, &c.output_channel, &c.stats_channel})
        if (ch->empty() || static_cast<int>(ch->size()) > runtime::kMaxChannelChars) return "channel name length out of bounds";
      if (c.lcm_url.empty() || static_cast<int>(c.lcm_url.size()) > runtime::kMaxUrlChars) return "lcm_url length out of bounds";
      if (c.period_ns() <= 0 || c.watchdog_ns() <= 0) return "period or watchdog not positive in ns";
    } catch (const runtime::ConfigError& e) {
      ++errors;
      const std::string w = e.what();
      if (w.compare(0, seeds[k].first.size(), seeds[k].first) != 0) return "ConfigError that does not start with the file: " + w.substr(0, 200);
      if (w.size() > 4096) return "ConfigError message of " + std::to_string(w.size()) + " characters";
    } catch (const std::exception& e) {
      return std::string("load_config_string threw a non-ConfigError: ") + e.what();
    } catch (...) {
      return "load_config_string threw a non-standard exception";
    }
    return "";
  });
  std::printf("[fuzz] ConfigLoader outcomes: loaded %ld, ConfigError %ld\n", loaded, errors);
  EXPECT_GT(loaded, 0);
  EXPECT_GT(errors, 0);
}

TEST(Fuzz, WireReassembler) {
  std::vector<std::string> seeds;
  for (const std::string& p : list_dir(kCorpus + "/wire", ".bin")) seeds.push_back(slurp(p));
  ASSERT_GE(seeds.size(), 4u) << "corpus " << kCorpus << "/wire (regenerate: coopdyn_fuzz_tests --write-corpus)";
  // the valid seeds each give one message, the crafted fragment none
  for (const std::string& p : list_dir(kCorpus + "/wire", ".bin")) {
    io::wire::Reassembler reasm(4, 4096, 100000);
    long long now = 0;
    int complete = 0;
    ASSERT_EQ(run_wire(reasm, slurp(p), &now, &complete), "") << p;
    EXPECT_EQ(complete, p.find("crafted") == std::string::npos ? 1 : 0) << p;
  }
  io::wire::Reassembler reasm(4, 4096, 100000);  // reused: partial messages carry over between inputs
  long long now = 0;
  long complete = 0;
  run_target("WireReassembler", kWireIters, [&](long i) -> std::string {
    std::mt19937_64 rng = rng_for("WireReassembler", i);
    g_input = mutate_wire(seeds[static_cast<size_t>(i) % seeds.size()], seeds, rng);
    int c = 0;
    const std::string why = run_wire(reasm, g_input, &now, &c);
    complete += c;
    return why;
  });
  std::printf("[fuzz] WireReassembler: %ld complete messages, %lld partial expired, %lld abandoned\n", complete,
              reasm.expired(), reasm.abandoned());
  EXPECT_GT(complete, 0);  // mutations keep some messages whole: the reassembly itself is exercised
}

int main(int argc, char** argv) {
  if (argc == 3 && std::string(argv[1]) == "--write-corpus") return write_corpus(argv[2]) || write_wire_corpus(argv[2]);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
