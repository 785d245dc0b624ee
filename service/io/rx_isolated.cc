#include "service/io/rx_isolated.h"
#include "service/io/udpm_socket.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <linux/filter.h>
#include <linux/futex.h>
#include <linux/sock_diag.h>
#include <netinet/in.h>
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
#include <sys/syscall.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>
#include <vector>

#include "service/io/codec.h"
#include "service/io/lcm_wire.h"

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
  hdr_ = new (p) RxRingHeader;  // the memfd is zero-filled: every counter starts at 0
  hdr_->magic = kMagic;
  hdr_->slots = static_cast<uint32_t>(slots_);
  hdr_->slot_bytes = static_cast<uint32_t>(slot_bytes_);
  base_ = static_cast<unsigned char*>(p) + 64 * ((sizeof(RxRingHeader) + 63) / 64);
  event_fd_ = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (event_fd_ < 0) throw std::runtime_error(std::string("receive isolation: eventfd: ") + std::strerror(errno));
}

IsolatedReceiver::~IsolatedReceiver() {
  stop();
  if (hdr_) sodium_memzero(hdr_->auth_key, sizeof hdr_->auth_key);
  if (hdr_) munmap(hdr_, shm_size_);
  if (shm_fd_ >= 0) close(shm_fd_);
  if (event_fd_ >= 0) close(event_fd_);
}

long long IsolatedReceiver::dropped() const { return static_cast<long long>(hdr_->dropped.load()); }
long long IsolatedReceiver::child_received() const { return static_cast<long long>(hdr_->received.load()); }
long long IsolatedReceiver::malformed() const {
  long long n = 0;
  for (int k = 0; k < wire::kWireStatuses; ++k)
    if (wire::refused(static_cast<wire::WireStatus>(k))) n += static_cast<long long>(hdr_->malformed_by[k].load());
  return n;
}
long long IsolatedReceiver::malformed(wire::WireStatus why) const {
  return static_cast<long long>(hdr_->malformed_by[static_cast<int>(why)].load());
}
void IsolatedReceiver::set_auth_key(const AuthKey& key) {
  std::memcpy(hdr_->auth_key, key.data(), kKeyBytes);
  hdr_->auth_on.store(1);
}
long long IsolatedReceiver::rejected(int channel, Reject why) const {
  if (channel < 0 || channel >= kRxChannels || static_cast<int>(why) < 0 || static_cast<int>(why) >= kRejectKinds) return 0;
  return static_cast<long long>(hdr_->rejected_by[channel][static_cast<int>(why)].load(std::memory_order_relaxed));
}
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

const unsigned char* IsolatedReceiver::slot(uint64_t i) const { return slot_at(base_, slot_bytes_, i, slots_); }

void IsolatedReceiver::wait_bell(uint32_t seen, long long deadline_ns) {
  // as runtime::Doorbell::wait, on the word shared with the child (no FUTEX_PRIVATE_FLAG)
  hdr_->bell_waiting.store(1, std::memory_order_seq_cst);
  if (hdr_->bell.load(std::memory_order_seq_cst) == seen) {
    timespec ts;
    ts.tv_sec = static_cast<time_t>(deadline_ns / 1000000000LL);
    ts.tv_nsec = static_cast<long>(deadline_ns % 1000000000LL);
    syscall(SYS_futex, reinterpret_cast<uint32_t*>(&hdr_->bell), FUTEX_WAIT_BITSET, seen, &ts, nullptr,
            FUTEX_BITSET_MATCH_ANY);
  }
  hdr_->bell_waiting.store(0, std::memory_order_relaxed);
}

void IsolatedReceiver::run() {
  long long started = now_ns(), backoff_ns = 0, respawn_at = 0;
  pollfd pfd{event_fd_, POLLIN, 0};
  const bool supervise_only = caller_drains();
  while (!stop_.load(std::memory_order_relaxed)) {
    poll(&pfd, 1, 20);
    uint64_t ev;
    while (read(event_fd_, &ev, sizeof ev) == sizeof ev) {
    }
    if (!supervise_only) drain(handler_);  // the child published slots [tail, head)
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
constexpr int kMaxAccept = kRxChannels;

struct Accept {
  std::string channel;
  unsigned char hash[8];  // big-endian, as on the wire
  MessageType type;       // the type of that hash
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

// Authentication on: each accepted channel's verifier (its type from the channel's fingerprint) and
// the utime of the last message that verified on it (the replay rule, as the inboxes apply it).
struct ChildAuth {
  std::vector<Verifier> verifiers;
  std::vector<int64_t> last_utime;
  ChildAuth(const AuthKey& key, const std::vector<Accept>& acc) {
    for (const Accept& a : acc) {
      verifiers.emplace_back(key, a.channel, a.type);
      last_utime.push_back(std::numeric_limits<int64_t>::min());
    }
  }
  // kNone: a signed message of channel k, newer than the last one that verified there. The MAC is
  // computed last: a message without one, or whose utime is not above the last verified one's (which
  // no MAC can make acceptable), costs no HMAC; such a message with a forged MAC counts as replayed.
  Reject check(int k, MessageType t, const uint8_t* data, int len) {
    Reject r = form(t, data, len);
    if (r != Reject::kNone) return r;
    const int64_t u = raw_utime(data, len);
    if (u <= last_utime[static_cast<size_t>(k)]) return Reject::kReplayed;
    r = verifiers[static_cast<size_t>(k)].check(data, len);
    if (r == Reject::kNone) last_utime[static_cast<size_t>(k)] = u;
    return r;
  }
  // Verifier::check's reasons that need no HMAC: kDecode (no mac_len field where it must be, or bytes
  // after the MAC), kUnauthenticated (mac_len 0), kBadMac (a MAC of another length); else kNone
  static Reject form(MessageType t, const uint8_t* data, int len) {
    const int at = mac_field_offset(t, data, len);
    if (at < 0 || len - at < 4) return Reject::kDecode;
    const int32_t mac_len = static_cast<int32_t>((uint32_t{data[at]} << 24) | (uint32_t{data[at + 1]} << 16) |
                                                 (uint32_t{data[at + 2]} << 8) | uint32_t{data[at + 3]});
    const int rest = len - at - 4;
    if (mac_len == 0) return rest == 0 ? Reject::kUnauthenticated : Reject::kDecode;
    return mac_len == kMacBytes && rest == kMacBytes ? Reject::kNone : Reject::kBadMac;
  }
};

// What the receive process hands a message to: the ring and its doorbell, the channels with their
// type hashes it accepts, and with authentication on their verifiers.
struct ChildRing {
  RxRingHeader* hdr;
  unsigned char* base;
  int event_fd;
  const std::vector<Accept>* acc;
  ChildAuth* auth;  // nullptr: authentication off
};

// CHANNEL HASH pairs of the command line (from argv[6] on)
std::vector<Accept> accepted_from_args(int argc, char** argv) {
  std::vector<Accept> acc;
  for (int a = 6; a + 1 < argc; a += 2) {
    Accept x;
    x.channel = argv[a];
    const unsigned long long h = std::strtoull(argv[a + 1], nullptr, 16);
    for (int b = 0; b < 8; ++b) x.hash[b] = static_cast<unsigned char>(h >> (56 - 8 * b));
    x.type = identify(x.hash, 8);
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

// The receive socket (udpm_socket.h) with the kernel filter of the accepted channels attached
// before it is bound and the buffer size asked for; what the filter and the buffer came to goes to
// the header. -1 if the socket cannot be set up.
int open_receive_socket(RxRingHeader* hdr, const wire::UdpmUrl& u, long rcvbuf, const std::vector<Accept>& acc) {
  std::vector<sock_filter> prog = build_filter(acc);
  sock_fprog fp{static_cast<unsigned short>(prog.size()), prog.data()};
  const UdpmSocket s = open_udpm_socket(u, rcvbuf, &fp);
  hdr->filter.store(s.filter ? 1 : -2);
  if (s.fd < 0) {
    std::fprintf(stderr, "coopdynd receive process: %s\n", s.why.c_str());
    return -1;
  }
  hdr->rcvbuf.store(s.rcvbuf);
  return s.fd;
}

// A coopdyn message of one of the accepted channels: the channel literally, then the payload's
// first 8 bytes the type's fingerprint. Returns the channel's index, -1 if none.
int accepted(const std::vector<Accept>& acc, const char* channel, int channel_len, const uint8_t* data, int len) {
  for (size_t k = 0; k < acc.size(); ++k) {
    const Accept& a = acc[k];
    if (len >= 8 && std::memcmp(data, a.hash, 8) == 0 && a.channel.size() == static_cast<size_t>(channel_len) &&
        std::memcmp(a.channel.data(), channel, a.channel.size()) == 0)
      return static_cast<int>(k);
  }
  return -1;
}

// A message into the next free slot with its receive time (the doorbell is rung per batch).
// false if it was dropped (larger than a slot, or the ring full).
bool push(ChildRing& c, const uint8_t* data, int len, int64_t t) {
  const int slots = static_cast<int>(c.hdr->slots), bytes = static_cast<int>(c.hdr->slot_bytes);
  const uint64_t head = c.hdr->head.load(std::memory_order_relaxed);
  if (len > bytes || head - c.hdr->tail.load(std::memory_order_acquire) >= static_cast<uint64_t>(slots)) {
    c.hdr->dropped.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  unsigned char* s = slot_at(c.base, bytes, head, slots);
  const uint32_t n = static_cast<uint32_t>(len);
  std::memcpy(s, &n, sizeof n);
  std::memcpy(s + sizeof n, &t, sizeof t);
  std::memcpy(s + sizeof n + sizeof t, data, n);
  c.hdr->head.store(head + 1, std::memory_order_release);
  return true;
}

// One datagram: parsed and reassembled (lcm_wire.h); a refused one counted by its reason, a
// fragment 0 or a complete message of another channel or type counted as filtered. Returns true
// when a message went into the ring.
bool on_datagram(ChildRing& c, wire::Reassembler& reasm, const uint8_t* buf, size_t len, const sockaddr_in& from,
                 int64_t t) {
  wire::Datagram d;
  wire::WireStatus st = wire::parse_datagram(buf, len, &d);
  if (st == wire::WireStatus::kPending && d.fragment_no == 0 &&
      accepted(*c.acc, d.channel, d.channel_len, d.data, d.data_len) < 0) {  // refused before it takes a slot
    c.hdr->filtered.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  wire::Message m;
  if (!wire::refused(st)) {
    const uint64_t sender = (uint64_t{ntohl(from.sin_addr.s_addr)} << 16) | ntohs(from.sin_port);
    st = reasm.add(buf, len, sender, t, &m);
  }
  if (wire::refused(st)) {
    c.hdr->malformed_by[static_cast<int>(st)].fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  if (st != wire::WireStatus::kComplete) return false;
  c.hdr->received.fetch_add(1, std::memory_order_relaxed);
  const int k = accepted(*c.acc, m.channel, m.channel_len, m.data, m.len);
  if (k < 0) {
    c.hdr->filtered.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  // authentication on: the MAC and the replay rule before the ring; off: a message whose fields do not
  // walk up to the MAC field is malformed (the decoders would refuse it: Reject::kDecode), refused
  // here so that junk after a fingerprint never takes a ring slot
  const Reject r = c.auth ? c.auth->check(k, (*c.acc)[static_cast<size_t>(k)].type, m.data, m.len)
                          : mac_field_offset((*c.acc)[static_cast<size_t>(k)].type, m.data, m.len) < 0 ? Reject::kDecode
                                                                                                       : Reject::kNone;
  if (r != Reject::kNone) {
    c.hdr->rejected_by[k][static_cast<int>(r)].fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  return push(c, m.data, m.len, t);
}

constexpr int kBatch = 16;                      // datagrams per recvmmsg
constexpr int kDatagramBytes = 65536;           // the largest UDP datagram
constexpr int kReassemblySlots = 8;             // partial messages kept at once (one per sender)
constexpr long long kReassemblyNs = 100000000;  // a partial message's life: 100 ms

// Receives until the parent is gone: recvmmsg in batches, each datagram through on_datagram, the
// doorbell rung once per batch that queued something, the kernel's drop count read now and then.
void serve(ChildRing& c, int sock, pid_t parent) {
  wire::Reassembler reasm(kReassemblySlots, static_cast<int>(c.hdr->slot_bytes), kReassemblyNs);
  std::vector<uint8_t> bufs(static_cast<size_t>(kBatch) * kDatagramBytes);
  mmsghdr msgs[kBatch];
  iovec iov[kBatch];
  sockaddr_in from[kBatch];
  long long drops_read = 0;
  c.hdr->alive.store(static_cast<uint64_t>(getpid()));
  while (getppid() == parent) {
    pollfd pfd{sock, POLLIN, 0};
    if (sock < 0 || poll(&pfd, 1, 100) <= 0) {
      if (sock < 0) poll(nullptr, 0, 100);
      continue;
    }
    for (int k = 0; k < kBatch; ++k) {
      iov[k] = iovec{bufs.data() + static_cast<size_t>(k) * kDatagramBytes, kDatagramBytes};
      msgs[k].msg_hdr = msghdr{&from[k], sizeof from[k], &iov[k], 1, nullptr, 0, 0};
      msgs[k].msg_len = 0;
    }
    const int n = recvmmsg(sock, msgs, kBatch, MSG_DONTWAIT, nullptr);
    const int64_t t = now_ns();
    bool queued = false;
    for (int k = 0; k < n; ++k)
      if (!(msgs[k].msg_hdr.msg_flags & MSG_TRUNC))  // a datagram over 64 KiB cannot be LCM's
        queued |= on_datagram(c, reasm, static_cast<const uint8_t*>(iov[k].iov_base), msgs[k].msg_len, from[k], t);
      else
        c.hdr->malformed_by[static_cast<int>(wire::WireStatus::kTooLarge)].fetch_add(1, std::memory_order_relaxed);
    if (queued && c.hdr->caller_drains.load(std::memory_order_relaxed)) {  // the daemon's loop waits on the bell
      c.hdr->bell.fetch_add(1, std::memory_order_seq_cst);  // before the load of bell_waiting (wait_bell: the other way round)
      if (c.hdr->bell_waiting.load(std::memory_order_seq_cst))
        syscall(SYS_futex, reinterpret_cast<uint32_t*>(&c.hdr->bell), FUTEX_WAKE, 1, nullptr, nullptr, 0);
    } else if (queued) {
      const uint64_t one = 1;
      (void)!write(c.event_fd, &one, sizeof one);
    }
    if (t - drops_read > 50000000LL) {  // at most 20 reads per second
      c.hdr->socket_drops.store(kernel_drops(sock), std::memory_order_relaxed);
      drops_read = t;
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
  // a stop (Ctrl-C, a service manager's SIGTERM to the process group) is the daemon's to handle:
  // it stops this process itself; the receive process dies with it (PR_SET_PDEATHSIG)
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) signal(sig, SIG_IGN);
  const pid_t parent = getppid();
  const int shm_fd = std::atoi(argv[3]), event_fd = std::atoi(argv[4]);
  const long rcvbuf = std::strtol(argv[5], nullptr, 10);
  const std::vector<Accept> acc = accepted_from_args(argc, argv);
  RxRingHeader* hdr = map_ring(shm_fd);
  if (!hdr) return 3;
  std::unique_ptr<ChildAuth> auth;
  if (hdr->auth_on.load() == 1) {
    AuthKey key;
    std::memcpy(key.data(), hdr->auth_key, kKeyBytes);
    auth = std::make_unique<ChildAuth>(key, acc);
    sodium_memzero(key.data(), key.size());
  }
  ChildRing ring{hdr, reinterpret_cast<unsigned char*>(hdr) + 64 * ((sizeof(RxRingHeader) + 63) / 64), event_fd, &acc,
                 auth.get()};
  // udpm: our own socket; anything else (memq:// is in-process only) receives nothing here
  wire::UdpmUrl u;
  std::string why;
  int sock = -1;
  if (wire::parse_udpm_url(argv[2], &u, &why)) {
    sock = open_receive_socket(hdr, u, rcvbuf, acc);
    if (sock < 0) return 4;
  } else {
    hdr->filter.store(-1);
  }
  serve(ring, sock, parent);
  return 0;
}

}  // namespace coopdyn::io
