#include "service/io/rx_isolated.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <linux/filter.h>
#include <linux/sock_diag.h>
#include <netinet/in.h>
#include <lcm/lcm.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <spawn.h>
#include <sys/eventfd.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <vector>

extern char** environ;

namespace coopdyn::io {

namespace {

constexpr uint64_t kMagic = 0x636f6f7064796e72ULL;  // "coopdynr"
constexpr int kChildShmFd = 3, kChildEventFd = 4;

size_t slot_stride(int slot_bytes) { return (sizeof(uint32_t) + sizeof(int64_t) + slot_bytes + 63) & ~size_t(63); }
size_t ring_size(int slots, int slot_bytes) { return 64 * ((sizeof(RxRingHeader) + 63) / 64) + slots * slot_stride(slot_bytes); }
unsigned char* slot_at(unsigned char* base, int slot_bytes, uint64_t i, int slots) {
  return base + (i % static_cast<uint64_t>(slots)) * slot_stride(slot_bytes);
}
long long now_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<long long>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

}  // namespace

IsolatedReceiver::IsolatedReceiver(std::string exe, std::string url, std::vector<std::string> channels,
                                   std::vector<int64_t> fingerprints, int slots, int slot_bytes, int socket_buffer_bytes)
    : exe_(std::move(exe)),
      url_(std::move(url)),
      channels_(std::move(channels)),
      fingerprints_(std::move(fingerprints)),
      slots_(slots),
      slot_bytes_(slot_bytes),
      socket_buffer_bytes_(socket_buffer_bytes) {
  if (fingerprints_.size() != channels_.size()) throw std::runtime_error("receive isolation: one fingerprint per channel");
  shm_size_ = ring_size(slots_, slot_bytes_);
  shm_fd_ = memfd_create("coopdyn-rx", MFD_CLOEXEC);
  if (shm_fd_ < 0 || ftruncate(shm_fd_, static_cast<off_t>(shm_size_)) != 0)
    throw std::runtime_error(std::string("receive isolation: cannot create the shared ring: ") + std::strerror(errno));
  void* p = mmap(nullptr, shm_size_, PROT_READ | PROT_WRITE, MAP_SHARED, shm_fd_, 0);
  if (p == MAP_FAILED) throw std::runtime_error(std::string("receive isolation: mmap: ") + std::strerror(errno));
  hdr_ = new (p) RxRingHeader{kMagic, static_cast<uint32_t>(slots_), static_cast<uint32_t>(slot_bytes_), {0}, {0}, {0}, {0}, {0}, {0}, {0}, {0}, {0}};
  base_ = static_cast<unsigned char*>(p) + 64 * ((sizeof(RxRingHeader) + 63) / 64);
  event_fd_ = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (event_fd_ < 0) throw std::runtime_error(std::string("receive isolation: eventfd: ") + std::strerror(errno));
}

IsolatedReceiver::~IsolatedReceiver() {
  stop();
  if (hdr_) munmap(hdr_, shm_size_);
  if (shm_fd_ >= 0) close(shm_fd_);
  if (event_fd_ >= 0) close(event_fd_);
}

long long IsolatedReceiver::dropped() const { return static_cast<long long>(hdr_->dropped.load()); }
long long IsolatedReceiver::child_received() const { return static_cast<long long>(hdr_->received.load()); }
long long IsolatedReceiver::filtered() const { return static_cast<long long>(hdr_->filtered.load()); }
long long IsolatedReceiver::socket_drops() const { return static_cast<long long>(hdr_->socket_drops.load()); }
long long IsolatedReceiver::socket_buffer() const { return static_cast<long long>(hdr_->rcvbuf.load()); }
int IsolatedReceiver::filter_state() const { return static_cast<int>(hdr_->filter.load()); }
bool IsolatedReceiver::child_ready() const { return hdr_->alive.load() == static_cast<uint64_t>(pid_.load()); }

void IsolatedReceiver::spawn() {
  // posix_spawn (vfork + exec) is safe from a multithreaded parent; the ring and the eventfd are
  // handed over as fds 3 and 4, nothing else is inherited (the parent's fds are CLOEXEC)
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, shm_fd_, kChildShmFd);
  posix_spawn_file_actions_adddup2(&fa, event_fd_, kChildEventFd);
  std::vector<std::string> args = {exe_, "--rx-child", url_, std::to_string(kChildShmFd), std::to_string(kChildEventFd),
                                   std::to_string(socket_buffer_bytes_)};
  for (size_t i = 0; i < channels_.size(); ++i) {
    char h[24];
    std::snprintf(h, sizeof h, "%016llx", static_cast<unsigned long long>(fingerprints_[i]));
    args.push_back(channels_[i]);
    args.push_back(h);
  }
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, exe_.c_str(), &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  pid_.store(rc == 0 ? pid : -1);
  cpu_set_t set;
  if (rc == 0 && other_cpus(&set)) sched_setaffinity(pid, sizeof set, &set);  // inherited by its threads
}

bool IsolatedReceiver::other_cpus(cpu_set_t* set) const {
  if (avoid_cpu_ < 0 || avoid_cpu_ >= CPU_SETSIZE) return false;
  if (sched_getaffinity(0, sizeof *set, set) != 0) return false;
  CPU_CLR(avoid_cpu_, set);
  return CPU_COUNT(set) > 0;
}

void IsolatedReceiver::start(Handler handler, RestartHandler on_restart) {
  if (thread_.joinable()) return;
  handler_ = std::move(handler);
  on_restart_ = std::move(on_restart);
  stop_ = false;
  spawn();
  thread_ = std::thread([this] {
    cpu_set_t set;
    if (other_cpus(&set)) pthread_setaffinity_np(pthread_self(), sizeof set, &set);
    run();
  });
}

void IsolatedReceiver::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  const pid_t p = pid_.exchange(-1);
  if (p > 0) {
    kill(p, SIGKILL);
    waitpid(p, nullptr, 0);
  }
}

void IsolatedReceiver::run() {
  long long started = now_ns(), backoff_ns = 0, respawn_at = 0;
  pollfd pfd{event_fd_, POLLIN, 0};
  while (!stop_.load(std::memory_order_relaxed)) {
    poll(&pfd, 1, 20);
    uint64_t ev;
    while (read(event_fd_, &ev, sizeof ev) == sizeof ev) {
    }
    // drain the ring: the child published slots [tail, head)
    uint64_t tail = hdr_->tail.load(std::memory_order_relaxed);
    const uint64_t head = hdr_->head.load(std::memory_order_acquire);
    if (head < tail || head - tail > static_cast<uint64_t>(slots_)) {  // a child that wrote garbage: resync
      tail = head;
      hdr_->tail.store(tail, std::memory_order_release);
    }
    for (; tail < head; ++tail) {
      unsigned char* s = slot_at(base_, slot_bytes_, tail, slots_);
      uint32_t len;
      int64_t recv_ns;
      std::memcpy(&len, s, sizeof len);
      std::memcpy(&recv_ns, s + sizeof len, sizeof recv_ns);
      if (len <= static_cast<uint32_t>(slot_bytes_)) handler_(s + sizeof len + sizeof recv_ns, static_cast<int>(len), recv_ns);
      hdr_->tail.store(tail + 1, std::memory_order_release);
    }
    // supervision
    const pid_t p = pid_.load();
    if (p > 0) {
      int status = 0;
      if (waitpid(p, &status, WNOHANG) == p) {
        pid_.store(-1);
        const long long n = restarts_.fetch_add(1) + 1;
        const long long now = now_ns();
        backoff_ns = now - started < 1000000000LL ? std::min(std::max(2 * backoff_ns, 1000000LL), 1000000000LL) : 0;
        respawn_at = now + backoff_ns;
        if (on_restart_) on_restart_(status, n);
      }
    } else if (now_ns() >= respawn_at) {
      started = now_ns();
      spawn();
    }
  }
}

namespace {

constexpr uint32_t kLc02 = 0x4c433032, kLc03 = 0x4c433033;  // LCM's short message and fragment magic
constexpr int kMaxAccept = 8;

struct Accept {
  std::string channel;
  unsigned char hash[8];  // big-endian, as on the wire
};

// The classic BPF program of the receive socket. For a UDP socket the filter sees the datagram from
// the UDP header (8 bytes) on: LCM's header at 8 (magic, seqno), the channel and its NUL at 16, the
// payload (its 8-byte type hash first) after it. A load past the end of the datagram drops it.
std::vector<sock_filter> build_filter(const std::vector<Accept>& acc) {
  std::vector<sock_filter> f;
  auto stmt = [&](uint16_t code, uint32_t k) { f.push_back(sock_filter{code, 0, 0, k}); };
  auto jeq = [&](uint32_t k, uint8_t jt, uint8_t jf) { f.push_back(sock_filter{BPF_JMP | BPF_JEQ | BPF_K, jt, jf, k}); };
  stmt(BPF_LD | BPF_W | BPF_ABS, 8);
  jeq(kLc03, 0, 1);
  stmt(BPF_RET | BPF_K, 0xffffffffu);  // a fragment: accepted (the handler checks complete messages)
  jeq(kLc02, 1, 0);
  stmt(BPF_RET | BPF_K, 0);
  for (const Accept& a : acc) {
    // the bytes to match at offset 16: channel, NUL, hash
    std::vector<unsigned char> m(a.channel.begin(), a.channel.end());
    m.push_back(0);
    m.insert(m.end(), a.hash, a.hash + 8);
    // count the instructions of this entry (2 per compare, then the accept) to jump past it on a mismatch
    int compares = 0;
    for (size_t k = 0; k < m.size();) {
      const size_t n = m.size() - k >= 4 ? 4 : m.size() - k >= 2 ? 2 : 1;
      k += n;
      ++compares;
    }
    int left = 2 * compares + 1;  // instructions of this entry from the current one on
    for (size_t k = 0; k < m.size();) {
      const size_t n = m.size() - k >= 4 ? 4 : m.size() - k >= 2 ? 2 : 1;
      uint32_t v = 0;
      for (size_t b = 0; b < n; ++b) v = (v << 8) | m[k + b];
      stmt(BPF_LD | (n == 4 ? BPF_W : n == 2 ? BPF_H : BPF_B) | BPF_ABS, static_cast<uint32_t>(16 + k));
      left -= 1;
      // mismatch: to the first instruction after this entry's accept
      jeq(v, 0, static_cast<uint8_t>(left - 1));
      left -= 1;
      k += n;
    }
    stmt(BPF_RET | BPF_K, 0xffffffffu);
  }
  stmt(BPF_RET | BPF_K, 0);
  return f;
}

// The UDP socket LCM bound to the URL's port (its receive socket), or -1.
int find_receive_socket(uint16_t port) {
  if (port == 0) return -1;  // not udpm (an unbound socket would report port 0)
  rlimit rl{};
  const int max_fd = getrlimit(RLIMIT_NOFILE, &rl) == 0 && rl.rlim_cur < 65536 ? static_cast<int>(rl.rlim_cur) : 65536;
  int found = -1;
  for (int fd = 0; fd < max_fd; ++fd) {
    int type = 0;
    socklen_t tl = sizeof type;
    if (getsockopt(fd, SOL_SOCKET, SO_TYPE, &type, &tl) != 0 || type != SOCK_DGRAM) continue;
    sockaddr_in a{};
    socklen_t al = sizeof a;
    if (getsockname(fd, reinterpret_cast<sockaddr*>(&a), &al) != 0 || a.sin_family != AF_INET || ntohs(a.sin_port) != port)
      continue;
    if (found >= 0) return -1;  // two candidates: not the layout this code knows
    found = fd;
  }
  return found;
}

// udpm://ADDR:PORT?...: the port (LCM's default 7667 when absent), 0 if not udpm
uint16_t url_port(const std::string& url) {
  if (url.rfind("udpm://", 0) != 0) return 0;
  std::string rest = url.substr(7);
  rest = rest.substr(0, rest.find('?'));
  const size_t c = rest.find(':');
  if (c == std::string::npos) return 7667;
  const long p = std::strtol(rest.c_str() + c + 1, nullptr, 10);
  return p > 0 && p < 65536 ? static_cast<uint16_t>(p) : 0;
}

uint64_t kernel_drops(int fd) {
#ifdef SO_MEMINFO
  uint32_t mi[SK_MEMINFO_VARS] = {};
  socklen_t l = sizeof mi;
  if (fd >= 0 && getsockopt(fd, SOL_SOCKET, SO_MEMINFO, mi, &l) == 0 && l > SK_MEMINFO_DROPS * sizeof(uint32_t))
    return mi[SK_MEMINFO_DROPS];
#else
  (void)fd;
#endif
  return 0;
}

// What the receive process hands a message to: the ring and its doorbell, and the channels with
// their type hashes it accepts.
struct ChildRing {
  RxRingHeader* hdr;
  unsigned char* base;
  int event_fd;
  const std::vector<Accept>* acc;
};

// CHANNEL HASH pairs of the command line (from argv[6] on)
std::vector<Accept> accepted_from_args(int argc, char** argv) {
  std::vector<Accept> acc;
  for (int a = 6; a + 1 < argc; a += 2) {
    Accept x;
    x.channel = argv[a];
    const unsigned long long h = std::strtoull(argv[a + 1], nullptr, 16);
    for (int b = 0; b < 8; ++b) x.hash[b] = static_cast<unsigned char>(h >> (56 - 8 * b));
    acc.push_back(x);
  }
  return acc;
}

// The ring the daemon made (its header checked), mapped; nullptr if it is not one.
RxRingHeader* map_ring(int shm_fd) {
  struct stat st;
  if (fstat(shm_fd, &st) != 0 || st.st_size < static_cast<off_t>(sizeof(RxRingHeader))) return nullptr;
  void* p = mmap(nullptr, static_cast<size_t>(st.st_size), PROT_READ | PROT_WRITE, MAP_SHARED, shm_fd, 0);
  if (p == MAP_FAILED) return nullptr;
  auto* hdr = static_cast<RxRingHeader*>(p);
  if (hdr->magic != kMagic || ring_size(static_cast<int>(hdr->slots), static_cast<int>(hdr->slot_bytes)) > static_cast<size_t>(st.st_size))
    return nullptr;
  return hdr;
}

// the channels are matched literally: LCM takes a regular expression, so escape them
std::string channel_regex(const std::vector<Accept>& acc) {
  std::string re;
  for (const Accept& a : acc) {
    if (!re.empty()) re += '|';
    for (const char* c = a.channel.c_str(); *c; ++c) {
      if (std::strchr(".^$|()[]{}*+?\\", *c)) re += '\\';
      re += *c;
    }
  }
  return "(" + re + ")";  // LCM anchors the expression as ^...$: group the alternatives
}

// LCM's handler: a message into the next free slot with its receive time, then the doorbell.
void on_message(const lcm_recv_buf_t* rb, const char* channel, void* user) {
  ChildRing& c = *static_cast<ChildRing*>(user);
  c.hdr->received.fetch_add(1, std::memory_order_relaxed);
  // a coopdyn message of this channel's type, or nothing: no ring slot, no decode time
  bool ours = false;
  for (const Accept& a : *c.acc)
    if (rb->data_size >= 8 && std::memcmp(rb->data, a.hash, 8) == 0 && a.channel == channel) ours = true;
  if (!ours) {
    c.hdr->filtered.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const int slots = static_cast<int>(c.hdr->slots), bytes = static_cast<int>(c.hdr->slot_bytes);
  const uint64_t head = c.hdr->head.load(std::memory_order_relaxed);
  if (rb->data_size > static_cast<uint32_t>(bytes) || head - c.hdr->tail.load(std::memory_order_acquire) >= static_cast<uint64_t>(slots)) {
    c.hdr->dropped.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  unsigned char* s = slot_at(c.base, bytes, head, slots);
  const uint32_t len = rb->data_size;
  const int64_t t = now_ns();
  std::memcpy(s, &len, sizeof len);
  std::memcpy(s + sizeof len, &t, sizeof t);
  std::memcpy(s + sizeof len + sizeof t, rb->data, len);
  c.hdr->head.store(head + 1, std::memory_order_release);
  const uint64_t one = 1;
  (void)!write(c.event_fd, &one, sizeof one);
}

// The receive socket (LCM opens it on the first subscribe): its buffer size and the kernel filter,
// what they came to in the header. Returns the socket, or -1 if it was not found.
int tune_receive_socket(RxRingHeader* hdr, const char* url, long rcvbuf, const std::vector<Accept>& acc) {
  const int sock = find_receive_socket(url_port(url));
  if (sock < 0) {
    hdr->filter.store(-1);
    return sock;
  }
  if (rcvbuf > 0) {
    const int want = static_cast<int>(std::min<long>(rcvbuf, 1L << 30));
    setsockopt(sock, SOL_SOCKET, SO_RCVBUF, &want, sizeof want);
  }
  std::vector<sock_filter> prog = build_filter(acc);
  sock_fprog fp{static_cast<unsigned short>(prog.size()), prog.data()};
  hdr->filter.store(setsockopt(sock, SOL_SOCKET, SO_ATTACH_FILTER, &fp, sizeof fp) == 0 ? 1 : -2);
  int got = 0;
  socklen_t gl = sizeof got;
  if (getsockopt(sock, SOL_SOCKET, SO_RCVBUF, &got, &gl) == 0) hdr->rcvbuf.store(got);
  return sock;
}

// Handles messages until the parent is gone, reading the kernel's drop count now and then.
void serve(lcm_t* lcm, RxRingHeader* hdr, int sock, pid_t parent) {
  long long drops_read = 0;
  while (getppid() == parent) {
    lcm_handle_timeout(lcm, 100);
    if (const long long now = now_ns(); now - drops_read > 50000000LL) {  // at most 20 reads per second
      hdr->socket_drops.store(kernel_drops(sock), std::memory_order_relaxed);
      drops_read = now;
    }
  }
}

}  // namespace

int rx_child_main(int argc, char** argv) {
  if (argc < 8 || (argc - 6) % 2 != 0 || (argc - 6) / 2 > kMaxAccept) {
    std::fprintf(stderr, "coopdynd --rx-child: internal mode (URL SHM_FD EVENT_FD RCVBUF CHANNEL HASH...)\n");
    return 2;
  }
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  const pid_t parent = getppid();
  const char* url = argv[2];
  const int shm_fd = std::atoi(argv[3]), event_fd = std::atoi(argv[4]);
  const long rcvbuf = std::strtol(argv[5], nullptr, 10);
  const std::vector<Accept> acc = accepted_from_args(argc, argv);
  RxRingHeader* hdr = map_ring(shm_fd);
  if (!hdr) return 3;
  ChildRing ring{hdr, reinterpret_cast<unsigned char*>(hdr) + 64 * ((sizeof(RxRingHeader) + 63) / 64), event_fd, &acc};
  lcm_t* lcm = lcm_create(url);
  if (!lcm) return 4;
  lcm_subscription_t* sub = lcm_subscribe(lcm, channel_regex(acc).c_str(), on_message, &ring);
  if (!sub) return 4;
  // LCM drops a message silently when its subscription already queues this many (default 30)
  lcm_subscription_set_queue_capacity(sub, static_cast<int>(hdr->slots));
  const int sock = tune_receive_socket(hdr, url, rcvbuf, acc);
  hdr->alive.store(static_cast<uint64_t>(getpid()));
  serve(lcm, hdr, sock, parent);
  lcm_destroy(lcm);
  return 0;
}

}  // namespace coopdyn::io
