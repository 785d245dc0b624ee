#include "service/runtime/realtime.h"

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <sys/mman.h>
#include <unistd.h>

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
  if (o.sched_fifo) {
    sched_param p{};
    p.sched_priority = o.priority;
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p);
    if (rc == 0)
      out.push_back({true, "loop thread runs SCHED_FIFO priority " + std::to_string(o.priority)});
    else
      out.push_back({false, std::string("SCHED_FIFO priority ") + std::to_string(o.priority) + " refused: " + std::strerror(rc) +
                                " (needs root, CAP_SYS_NICE or an rtprio limit); running SCHED_OTHER"});
  }
  if (out.empty()) out.push_back({true, "real-time options off (SCHED_OTHER, no affinity, no mlockall)"});
  return out;
}

}  // namespace coopdyn::runtime
