#include "service/io/rx_isolated.h"

#include <fcntl.h>
#include <lcm/lcm.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/eventfd.h>
#include <sys/mman.h>
#include <sys/prctl.h>
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

IsolatedReceiver::IsolatedReceiver(std::string exe, std::string url, std::vector<std::string> channels, int slots,
                                   int slot_bytes)
    : exe_(std::move(exe)), url_(std::move(url)), channels_(std::move(channels)), slots_(slots), slot_bytes_(slot_bytes) {
  shm_size_ = ring_size(slots_, slot_bytes_);
  shm_fd_ = memfd_create("coopdyn-rx", MFD_CLOEXEC);
  if (shm_fd_ < 0 || ftruncate(shm_fd_, static_cast<off_t>(shm_size_)) != 0)
    throw std::runtime_error(std::string("receive isolation: cannot create the shared ring: ") + std::strerror(errno));
  void* p = mmap(nullptr, shm_size_, PROT_READ | PROT_WRITE, MAP_SHARED, shm_fd_, 0);
  if (p == MAP_FAILED) throw std::runtime_error(std::string("receive isolation: mmap: ") + std::strerror(errno));
  hdr_ = new (p) RxRingHeader{kMagic, static_cast<uint32_t>(slots_), static_cast<uint32_t>(slot_bytes_), {0}, {0}, {0}, {0}, {0}};
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
bool IsolatedReceiver::child_ready() const { return hdr_->alive.load() == static_cast<uint64_t>(pid_.load()); }

void IsolatedReceiver::spawn() {
  // posix_spawn (vfork + exec) is safe from a multithreaded parent; the ring and the eventfd are
  // handed over as fds 3 and 4, nothing else is inherited (the parent's fds are CLOEXEC)
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, shm_fd_, kChildShmFd);
  posix_spawn_file_actions_adddup2(&fa, event_fd_, kChildEventFd);
  std::vector<std::string> args = {exe_, "--rx-child", url_, std::to_string(kChildShmFd), std::to_string(kChildEventFd)};
  args.insert(args.end(), channels_.begin(), channels_.end());
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, exe_.c_str(), &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  pid_.store(rc == 0 ? pid : -1);
}

void IsolatedReceiver::start(Handler handler, RestartHandler on_restart) {
  if (thread_.joinable()) return;
  handler_ = std::move(handler);
  on_restart_ = std::move(on_restart);
  stop_ = false;
  spawn();
  thread_ = std::thread([this] { run(); });
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

int rx_child_main(int argc, char** argv) {
  if (argc < 6) {
    std::fprintf(stderr, "coopdynd --rx-child: internal mode (URL SHM_FD EVENT_FD CHANNEL...)\n");
    return 2;
  }
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  const pid_t parent = getppid();
  const char* url = argv[2];
  const int shm_fd = std::atoi(argv[3]), event_fd = std::atoi(argv[4]);
  struct stat st;
  if (fstat(shm_fd, &st) != 0 || st.st_size < static_cast<off_t>(sizeof(RxRingHeader))) return 3;
  void* p = mmap(nullptr, static_cast<size_t>(st.st_size), PROT_READ | PROT_WRITE, MAP_SHARED, shm_fd, 0);
  if (p == MAP_FAILED) return 3;
  auto* hdr = static_cast<RxRingHeader*>(p);
  if (hdr->magic != kMagic || ring_size(static_cast<int>(hdr->slots), static_cast<int>(hdr->slot_bytes)) > static_cast<size_t>(st.st_size))
    return 3;
  struct Ctx {
    RxRingHeader* hdr;
    unsigned char* base;
    int event_fd;
  } ctx{hdr, static_cast<unsigned char*>(p) + 64 * ((sizeof(RxRingHeader) + 63) / 64), event_fd};
  lcm_t* lcm = lcm_create(url);
  if (!lcm) return 4;
  // the channels are matched literally: LCM takes a regular expression, so escape them
  std::string re;
  for (int a = 5; a < argc; ++a) {
    if (!re.empty()) re += '|';
    for (const char* p = argv[a]; *p; ++p) {
      if (std::strchr(".^$|()[]{}*+?\\", *p)) re += '\\';
      re += *p;
    }
  }
  re = "(" + re + ")";  // LCM anchors the expression as ^...$: group the alternatives
  lcm_subscribe(
      lcm, re.c_str(),
      [](const lcm_recv_buf_t* rb, const char*, void* user) {
        Ctx& c = *static_cast<Ctx*>(user);
        c.hdr->received.fetch_add(1, std::memory_order_relaxed);
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
      },
      &ctx);
  hdr->alive.store(static_cast<uint64_t>(getpid()));
  while (getppid() == parent) lcm_handle_timeout(lcm, 100);
  lcm_destroy(lcm);
  return 0;
}

}  // namespace coopdyn::io
