#include "service/io/transport/rx_isolated.h"

#include <fcntl.h>
#include <linux/futex.h>
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

#include "service/io/codec/codec.h"
#include "service/io/transport/lcm_bus.h"
#include "service/io/transport/lcm_wire.h"

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
  counters_ = &hdr_->counters;
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

long long IsolatedReceiver::child_received() const { return static_cast<long long>(hdr_->counters.received.load()); }
void IsolatedReceiver::set_auth_key(const AuthKey& key) {
  std::memcpy(hdr_->auth_key, key.data(), kKeyBytes);
  hdr_->auth_on.store(1);
}
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
  if (rc == 0 && fifo_priority_.load() > 0) {
    sched_param p{};
    p.sched_priority = fifo_priority_.load();
    sched_setscheduler(pid, SCHED_FIFO, &p);  // refused without the privilege: SCHED_OTHER
  }
}

long long IsolatedReceiver::child_cpu_ns() const {
  const pid_t p = pid_.load();
  clockid_t id;
  if (p <= 0 || clock_getcpuclockid(p, &id) != 0) return -1;
  return clock_ns(id);
}

long long IsolatedReceiver::thread_cpu_ns() const {
  clockid_t id;
  if (tid_.load() == 0 || pthread_getcpuclockid(const_cast<std::thread&>(thread_).native_handle(), &id) != 0) return -1;
  return clock_ns(id);
}

bool IsolatedReceiver::other_cpus(cpu_set_t* set) const {
  if (avoid_cpu_ < 0 || avoid_cpu_ >= CPU_SETSIZE) return false;
  if (sched_getaffinity(0, sizeof *set, set) != 0) return false;
  CPU_CLR(avoid_cpu_, set);
  return CPU_COUNT(set) > 0;
}

void IsolatedReceiver::start(Handler handler, RestartHandler on_restart, ReadyHandler on_ready) {
  if (thread_.joinable()) return;
  handler_ = std::move(handler);
  on_restart_ = std::move(on_restart);
  on_ready_ = std::move(on_ready);
  stop_ = false;
  spawn();
  thread_ = std::thread([this] {
    cpu_set_t set;
    if (other_cpus(&set)) pthread_setaffinity_np(pthread_self(), sizeof set, &set);
    if (fifo_priority_.load() > 0) {
      sched_param p{};
      p.sched_priority = fifo_priority_.load();
      pthread_setschedparam(pthread_self(), SCHED_FIFO, &p);  // refused without the privilege
    }
    prctl(PR_SET_NAME, "coopdynd-rx", 0, 0, 0);
    tid_.store(static_cast<pid_t>(syscall(SYS_gettid)));
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
  long long started = monotonic_ns(), backoff_ns = 0, respawn_at = 0;
  pid_t reported = -1;  // the last child reported ready
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
    if (p > 0 && p != reported && child_ready()) {  // a new child has subscribed
      reported = p;
      if (on_ready_) on_ready_(p, restarts_.load());
      children_ready_.fetch_add(1);
    }
    if (p > 0) {
      int status = 0;
      if (waitpid(p, &status, WNOHANG) == p) {
        pid_.store(-1);
        const long long n = restarts_.fetch_add(1) + 1;
        const long long now = monotonic_ns();
        backoff_ns = now - started < 1000000000LL ? std::min(std::max(2 * backoff_ns, 1000000LL), 1000000000LL) : 0;
        respawn_at = now + backoff_ns;
        if (on_restart_) on_restart_(status, n);
      }
    } else if (monotonic_ns() >= respawn_at) {
      started = monotonic_ns();
      spawn();
    }
  }
}

namespace {

constexpr int kMaxAccept = kRxChannels;

// What the receive process hands a message to: the ring and its doorbell.
struct ChildRing {
  RxRingHeader* hdr;
  unsigned char* base;
  int event_fd;
};

// CHANNEL HASH pairs of the command line (from argv[6] on)
std::vector<InputChannel> accepted_from_args(int argc, char** argv) {
  std::vector<std::string> channels;
  std::vector<int64_t> hashes;
  for (int a = 6; a + 1 < argc; a += 2) {
    channels.push_back(argv[a]);
    hashes.push_back(static_cast<int64_t>(std::strtoull(argv[a + 1], nullptr, 16)));
  }
  return input_channels(channels, hashes);
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

// A message into the next free slot with its receive time (the doorbell is rung per batch).
// false if it was dropped (larger than a slot, or the ring full).
bool push(ChildRing& c, const uint8_t* data, int len, int64_t t) {
  const int slots = static_cast<int>(c.hdr->slots), bytes = static_cast<int>(c.hdr->slot_bytes);
  const uint64_t head = c.hdr->head.load(std::memory_order_relaxed);
  if (len > bytes || head - c.hdr->tail.load(std::memory_order_acquire) >= static_cast<uint64_t>(slots)) {
    c.hdr->counters.dropped.fetch_add(1, std::memory_order_relaxed);
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

// Receives until the parent is gone: recvmmsg in batches, each datagram through the gate, the
// doorbell rung once per batch that queued something, the kernel's drop count read now and then.
void serve(ChildRing& c, InputGate& gate, int sock, pid_t parent) {
  long long drops_read = 0;
  c.hdr->alive.store(static_cast<uint64_t>(getpid()));
  const uint64_t one = 1;
  (void)!write(c.event_fd, &one, sizeof one);  // the receive thread reports the subscription at once
  auto read_drops = [&](long long t) {
    if (t - drops_read <= 50000000LL) return;  // at most 20 reads per second
    c.hdr->counters.socket_drops.store(kernel_drops(sock), std::memory_order_relaxed);
    drops_read = t;
  };
  while (getppid() == parent) {
    pollfd pfd{sock, POLLIN, 0};
    if (sock < 0 || poll(&pfd, 1, 100) <= 0) {
      if (sock < 0) poll(nullptr, 0, 100);
      else read_drops(monotonic_ns());  // idle: what the kernel's filter dropped is counted too
      continue;
    }
    bool queued = false;
    gate.receive(sock, [&](int, const uint8_t* data, int len, long long t) { queued |= push(c, data, len, t); });
    const long long t = gate.batch_ns();
    if (queued && c.hdr->caller_drains.load(std::memory_order_relaxed)) {  // the daemon's loop waits on the bell
      c.hdr->bell.fetch_add(1, std::memory_order_seq_cst);  // before the load of bell_waiting (wait_bell: the other way round)
      if (c.hdr->bell_waiting.load(std::memory_order_seq_cst))
        syscall(SYS_futex, reinterpret_cast<uint32_t*>(&c.hdr->bell), FUTEX_WAKE, 1, nullptr, nullptr, 0);
    } else if (queued) {
      (void)!write(c.event_fd, &one, sizeof one);
    }
    read_drops(t);
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
  for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGQUIT}) signal(sig, SIG_IGN);
  const pid_t parent = getppid();
  const int shm_fd = std::atoi(argv[3]), event_fd = std::atoi(argv[4]);
  const long rcvbuf = std::strtol(argv[5], nullptr, 10);
  std::vector<InputChannel> acc;
  try {
    acc = accepted_from_args(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "coopdynd --rx-child: %s\n", e.what());
    return 2;
  }
  RxRingHeader* hdr = map_ring(shm_fd);
  if (!hdr) return 3;
  InputGate gate(acc, static_cast<int>(hdr->slot_bytes), &hdr->counters);
  if (hdr->auth_on.load() == 1) {
    AuthKey key;
    std::memcpy(key.data(), hdr->auth_key, kKeyBytes);
    gate.set_auth_key(key);
    sodium_memzero(key.data(), key.size());
  }
  ChildRing ring{hdr, reinterpret_cast<unsigned char*>(hdr) + 64 * ((sizeof(RxRingHeader) + 63) / 64), event_fd};
  // udpm: our own socket; anything else (memq:// is in-process only) receives nothing here
  wire::UdpmUrl u;
  std::string why;
  int sock = -1;
  if (wire::parse_udpm_url(argv[2], &u, &why)) {
    sock = open_input_socket(u, rcvbuf, acc, &hdr->counters, &why);
    if (sock < 0) {
      std::fprintf(stderr, "coopdynd receive process: %s\n", why.c_str());
      return 4;
    }
  } else {
    hdr->counters.filter.store(-1);
  }
  serve(ring, gate, sock, parent);
  return 0;
}

}  // namespace coopdyn::io
