#include "service/runtime/realtime.h"

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <sys/mman.h>
#include <fcntl.h>
#include <unistd.h>

#include <cstdint>

#include <cerrno>
#include <cstring>

namespace coopdyn::runtime {

std::vector<RealtimeResult> apply_realtime(const RealtimeOptions& o) {
  std::vector<RealtimeResult> out;
  // The default 50 us timer slack of SCHED_OTHER threads delays every absolute-deadline wake-up;
  // 1 ns asks for the precise expiry (no privilege needed).
  if (prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL) != 0)
    out.push_back({false, std::string("timer slack not reduced: ") + std::strerror(errno)});
  if (o.mlockall) {
    if (::mlockall(MCL_CURRENT | MCL_FUTURE) == 0)
      out.push_back({true, "mlockall: current and future pages locked"});
    else
      out.push_back({false, std::string("mlockall refused: ") + std::strerror(errno) +
                                " (needs CAP_IPC_LOCK or a large enough 'ulimit -l'); pages may fault"});
  }
  if (o.cpu_dma_latency_zero) {
    // the PM QoS request lasts while the file stays open: held until the process exits
    static int fd = -1;
    if (fd < 0) fd = ::open("/dev/cpu_dma_latency", O_WRONLY | O_CLOEXEC);
    const int32_t zero = 0;
    if (fd >= 0 && ::write(fd, &zero, sizeof zero) == static_cast<ssize_t>(sizeof zero))
      out.push_back({true, "/dev/cpu_dma_latency held at 0 us (no deep idle states while running)"});
    else
      out.push_back({false, std::string("/dev/cpu_dma_latency not held at 0: ") + std::strerror(errno) + " (needs root; the loop then wakes from deep idle states: realtime.cpu_dma_latency_zero)"});
  }
  if (o.spin_us > 0)
    out.push_back({true, "spinning the last " + std::to_string(o.spin_us) + " us before each deadline (busy wait)"});
  if (o.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(o.cpu, &set);
    const int rc = pthread_setaffinity_np(pthread_self(), sizeof set, &set);
    if (rc == 0)
      out.push_back({true, "loop thread pinned to CPU " + std::to_string(o.cpu)});
    else
      out.push_back({false, "CPU affinity " + std::to_string(o.cpu) + " refused: " + std::strerror(rc) + " (" +
                                std::to_string(sysconf(_SC_NPROCESSORS_ONLN)) + " CPUs online)"});
  }
  if (o.sched_fifo == SchedFifo::kAuto && !loop_asks_fifo(o))
    out.push_back({true, "loop thread runs SCHED_OTHER: realtime.sched_fifo auto takes no real-time priority for a "
                         "busy-polling loop without a cpu of its own (it would hold a shared CPU); set cpu, or "
                         "sched_fifo: true"});
  if (loop_asks_fifo(o)) {
    sched_param p{};
    p.sched_priority = o.priority;
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p);
    const std::string how = o.sched_fifo == SchedFifo::kAuto
                                ? " (realtime.sched_fifo auto: stepped down to SCHED_OTHER if it hogs its CPU)"
                                : " (realtime.sched_fifo true)";
    if (rc == 0)
      out.push_back({true, "loop thread runs SCHED_FIFO priority " + std::to_string(o.priority) + how});
    else
      out.push_back({false, std::string("SCHED_FIFO priority ") + std::to_string(o.priority) + " refused: " + std::strerror(rc) +
                                " (needs root, CAP_SYS_NICE or an rtprio limit); running SCHED_OTHER"});
  }
  if (out.empty()) out.push_back({true, "real-time options off (SCHED_OTHER, no affinity, no mlockall)"});
  return out;
}

bool runs_fifo() {
  int policy = 0;
  sched_param p{};
  return pthread_getschedparam(pthread_self(), &policy, &p) == 0 && policy == SCHED_FIFO;
}

bool demote_to_other(int pid) {
  sched_param p{};
  p.sched_priority = 0;
  return sched_setscheduler(pid, SCHED_OTHER, &p) == 0;  // Linux: pid 0 is the calling thread
}

}  // namespace coopdyn::runtime
