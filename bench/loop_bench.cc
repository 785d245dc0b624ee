// Cost of the daemon's per-tick work without the scheduler: ServiceLoop::tick() (input handoff,
// watchdog, integrator step or evaluation, output encoding, publish to a null bus) per scene and
// mode, and the codec on its own (output encode, command decode + validation).
// BM_TickFreshState: an estimate tick with a new measured state each time (trigger: arrival's case).
// BM_TickRatio gives the hold tick / commanded tick and in place / warm ratios, each in one run.
// BM_TickPaced takes the in-place cost apart: the same tick back to back or after sleeping to an
// absolute 1 ms deadline (as the daemon does), publishing to a null bus or over udpm on loopback
// to a subscriber in this process (as the daemon does to a controller or logger).
#include <benchmark/benchmark.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "service/dynamics/holding_torque.h"
#include "service/io/transport/lcm_bus.h"

#include "service/io/codec/codec.h"
#include "service/runtime/service_loop.h"
#include "service/scene/scene.h"

using namespace coopdyn;

namespace {
struct NullBus : io::Bus {
  long bytes = 0;
  int publish(const char*, const void*, int len) override {
    bytes += len;
    return 0;
  }
};
std::string scene(const std::string& n) { return std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/" + n + ".yaml"; }
const char* kScenes[] = {"two_puma_load", "two_5dof_arms_load", "planar_arms_load", "four_bar"};

// The input a tick takes: a zero torque command (simulate) or the scene's initial state (estimate).
std::vector<uint8_t> input_message(const System& sys, runtime::ServiceMode mode) {
  const std::vector<double> tau(sys.model.nv(), 0.0);
  if (mode == runtime::ServiceMode::kSimulate) return io::encode_torque_command(0, 1, {}, tau);
  return io::encode_measured_state(0, 1, {}, std::vector<double>(sys.q0.data(), sys.q0.data() + sys.q0.size()), {},
                                   std::vector<double>(sys.v0.data(), sys.v0.data() + sys.v0.size()), tau);
}
// A fresh input every tick keeps the watchdog satisfied (the handoff is part of the cost).
void offer(runtime::ServiceLoop& loop, runtime::ServiceMode mode, const std::vector<uint8_t>& b, long long now) {
  if (mode == runtime::ServiceMode::kSimulate) loop.commands().offer(b.data(), static_cast<int>(b.size()), now);
  else loop.states().offer(b.data(), static_cast<int>(b.size()), now);
}

void BM_Tick(benchmark::State& st) {
  const std::string name = kScenes[st.range(0)];
  System sys;
  try {
    sys = load_scene(scene(name));
  } catch (const std::exception& e) {
    st.SkipWithError(e.what());
    return;
  }
  runtime::ServiceConfig cfg;
  cfg.mode = st.range(1) ? runtime::ServiceMode::kEstimate : runtime::ServiceMode::kSimulate;
  cfg.max_input_age_ms = 0;  // one message offered for the whole run: its utime would go stale
  NullBus bus;
  runtime::ServiceLoop loop(sys, cfg, bus);
  const std::vector<uint8_t> b = input_message(sys, cfg.mode);
  long long now = 0;
  for (auto _ : st) {
    offer(loop, cfg.mode, b, now);
    loop.tick(now);
    now += 1000000;
  }
  st.SetLabel(name + (cfg.mode == runtime::ServiceMode::kSimulate ? " simulate (rk4)" : " estimate"));
  st.counters["bytes/tick"] = static_cast<double>(bus.bytes) / static_cast<double>(st.iterations());
}
BENCHMARK(BM_Tick)->ArgsProduct({{0, 1, 2, 3}, {0, 1}})->Unit(benchmark::kMicrosecond);

// An estimate tick that takes a fresh measured state every time (what trigger: arrival does; BM_Tick
// offers one state, so after its first tick the loop re-evaluates the state it holds). Arg: 0 the
// states give every coordinate, 1 only the joints (the loop fits the load's pose and twist).
void BM_TickFreshState(benchmark::State& st) {
  const System sys = load_scene(scene("two_puma_load"));
  runtime::ServiceConfig cfg;
  cfg.mode = runtime::ServiceMode::kEstimate;
  cfg.max_input_age_ms = 0;
  NullBus bus;
  runtime::ServiceLoop loop(sys, cfg, bus);
  const std::vector<double> tau(sys.model.nv(), 0.0);
  std::vector<std::string> qn, vn;
  std::vector<double> q, v;
  for (int i = 0; i < sys.model.nq(); ++i)
    if (!st.range(0) || sys.model.q_names[static_cast<size_t>(i)].rfind("load", 0) != 0) {
      qn.push_back(sys.model.q_names[static_cast<size_t>(i)]);
      q.push_back(sys.q0[i]);
    }
  for (int i = 0; i < sys.model.nv(); ++i)
    if (!st.range(0) || sys.model.v_names[static_cast<size_t>(i)].rfind("load", 0) != 0) {
      vn.push_back(sys.model.v_names[static_cast<size_t>(i)]);
      v.push_back(sys.v0[i]);
    }
  std::vector<std::vector<uint8_t>> msgs;
  for (int k = 0; k < 4096; ++k) msgs.push_back(io::encode_measured_state(0, k + 1, qn, q, vn, v, std::vector<double>(v.size(), 0.0)));
  long long now = 0;
  long k = 0, accepted = 0;
  for (auto _ : st) {
    if (k == 4096) {  // the sequence restarts: a new loop would be needed; re-offer the last (held)
      st.SkipWithError("more than 4096 iterations");
      break;
    }
    const auto& b = msgs[static_cast<size_t>(k++)];
    accepted += loop.states().offer(b.data(), static_cast<int>(b.size()), now) == runtime::Offer::kAccepted;
    loop.tick(now);
    now += 1000000;
  }
  st.counters["accepted"] = static_cast<double>(accepted) / static_cast<double>(st.iterations());
  st.SetLabel(st.range(0) ? "two_puma_load, joints only (load fitted)" : "two_puma_load, every coordinate");
}
BENCHMARK(BM_TickFreshState)->Arg(0)->Arg(1)->Iterations(4000)->Unit(benchmark::kMicrosecond);

// Args: mode (0 simulate, 1 estimate), paced (0 back to back, 1 sleep to the next 1 ms deadline
// between ticks, clock_nanosleep TIMER_ABSTIME), bus (0 null, 1 udpm on loopback with a subscriber
// in a receive thread, 2 udpm on loopback with no subscriber on the host's port: the datagram is
// sent but nobody is woken). Time per tick taken around tick() alone (manual time); p50 and p99 as
// counters. The loop's thread is whatever CPU the benchmark runs on (taskset it). The scene:
// two_puma_load, or the file in the environment variable LOOP_BENCH_SCENE.
void BM_TickPaced(benchmark::State& st) {
  const char* env = std::getenv("LOOP_BENCH_SCENE");  // bench/loop_timing.sh times its SCENE
  const std::string path = env && *env ? env : scene("two_puma_load");
  System sys;
  try {
    sys = load_scene(path);
  } catch (const std::exception& e) {
    st.SkipWithError(e.what());
    return;
  }
  runtime::ServiceConfig cfg;
  cfg.mode = st.range(0) ? runtime::ServiceMode::kEstimate : runtime::ServiceMode::kSimulate;
  cfg.max_input_age_ms = 0;
  const bool paced = st.range(1) != 0, udpm = st.range(2) != 0, subscriber = st.range(2) == 1;
  NullBus null_bus;
  std::unique_ptr<io::LcmBus> out, sub;
  std::atomic<long> received{0};
  if (udpm) {
    const std::string url = "udpm://239.255.76.67:" + std::to_string(7900 + getpid() % 90) + "?ttl=0";
    try {
      out = std::make_unique<io::LcmBus>(url);
      if (subscriber) sub = std::make_unique<io::LcmBus>(url);
    } catch (const std::exception& e) {
      st.SkipWithError(e.what());
      return;
    }
    if (sub) {
      sub->subscribe(cfg.output_channel, [&](const void*, int, long long) { received.fetch_add(1, std::memory_order_relaxed); });
      sub->start();
    }
  }
  io::Bus& bus = udpm ? static_cast<io::Bus&>(*out) : null_bus;
  runtime::ServiceLoop loop(sys, cfg, bus);
  const std::vector<uint8_t> b = input_message(sys, cfg.mode);
  std::vector<double> us;
  us.reserve(1 << 16);
  long long now = 0;
  timespec deadline;
  clock_gettime(CLOCK_MONOTONIC, &deadline);
  for (auto _ : st) {
    offer(loop, cfg.mode, b, now);
    if (paced) {
      deadline.tv_nsec += 1000000;
      if (deadline.tv_nsec >= 1000000000) deadline.tv_nsec -= 1000000000, ++deadline.tv_sec;
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr);
    }
    const long long t0 = io::monotonic_ns();
    loop.tick(now);
    const double dt = static_cast<double>(io::monotonic_ns() - t0) * 1e-9;
    st.SetIterationTime(dt);
    if (us.size() < us.capacity()) us.push_back(dt * 1e6);
    now += 1000000;
  }
  if (sub) sub->stop();
  std::sort(us.begin(), us.end());
  if (!us.empty()) {
    st.counters["p50_us"] = us[us.size() / 2];
    st.counters["p99_us"] = us[us.size() * 99 / 100];
  }
  // the same counters in every run (the CSV reporter needs them): NaN where they do not apply
  st.counters["bytes/tick"] = udpm ? std::nan("") : static_cast<double>(null_bus.bytes) / static_cast<double>(st.iterations());
  st.counters["delivered"] = sub ? static_cast<double>(received.load()) / static_cast<double>(st.iterations()) : std::nan("");
  st.SetLabel(sys.name + (cfg.mode == runtime::ServiceMode::kSimulate ? " simulate" : " estimate") +
              (paced ? ", slept to 1 ms deadlines" : ", back to back") + (!udpm ? ", null bus" : subscriber ? ", udpm + subscriber" : ", udpm, no subscriber"));
}
BENCHMARK(BM_TickPaced)
    ->ArgsProduct({{0, 1}, {0, 1}, {0, 1, 2}})
    ->UseManualTime()
    ->Iterations(3000)
    ->Unit(benchmark::kMicrosecond);

// Ratios in one run, interleaved tick by tick so that both sides see the same machine. Scene:
// two_puma_load or LOOP_BENCH_SCENE, simulate, null bus, manual time = the first side's.
//   Arg 0, hold / commanded: a loop without commands (the safe torque `hold` every tick) next to
//     one commanded with the holding torques of q0 (so both stay where they start), back to back.
//   Arg 1, in place / warm: one commanded loop slept to an absolute 1 ms deadline, ticked once
//     (in place: caches cold after the sleep) and at once again (warm).
// Counters: p50 and p99 of each side (a_ first, b_ second) and a_p50 / b_p50.
double pct(std::vector<double>& x, double p) {
  if (x.empty()) return std::nan("");
  std::sort(x.begin(), x.end());
  return x[static_cast<size_t>(p * static_cast<double>(x.size() - 1))];
}
void BM_TickRatio(benchmark::State& st) {
  const char* env = std::getenv("LOOP_BENCH_SCENE");
  const std::string path = env && *env ? env : scene("two_puma_load");
  System sys;
  try {
    sys = load_scene(path);
  } catch (const std::exception& e) {
    st.SkipWithError(e.what());
    return;
  }
  const bool in_place = st.range(0) == 1;
  runtime::ServiceConfig cfg;
  cfg.mode = runtime::ServiceMode::kSimulate;
  cfg.max_input_age_ms = 0;
  NullBus bus_a, bus_b;
  runtime::ServiceLoop a(sys, cfg, bus_a), b(sys, cfg, bus_b);
  HoldWorkspace hw(sys, default_actuated(sys));
  Eigen::VectorXd held(sys.model.nv());
  holding_torque(sys, hw, sys.q0, sys.v0, held);
  const std::vector<uint8_t> cmd = io::encode_torque_command(0, 1, {}, std::vector<double>(held.data(), held.data() + held.size()));
  std::vector<double> ta, tb;
  ta.reserve(1 << 16);
  tb.reserve(1 << 16);
  long long now = 0;
  timespec deadline;
  clock_gettime(CLOCK_MONOTONIC, &deadline);
  auto timed = [](runtime::ServiceLoop& l, long long t) {
    const long long t0 = io::monotonic_ns();
    l.tick(t);
    return static_cast<double>(io::monotonic_ns() - t0) * 1e-3;
  };
  for (auto _ : st) {
    if (in_place) {
      b.commands().offer(cmd.data(), static_cast<int>(cmd.size()), now);
      deadline.tv_nsec += 1000000;
      if (deadline.tv_nsec >= 1000000000) deadline.tv_nsec -= 1000000000, ++deadline.tv_sec;
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr);
      ta.push_back(timed(b, now));
      now += 1000000;
      b.commands().offer(cmd.data(), static_cast<int>(cmd.size()), now);
      tb.push_back(timed(b, now));
    } else {
      b.commands().offer(cmd.data(), static_cast<int>(cmd.size()), now);
      ta.push_back(timed(a, now));
      tb.push_back(timed(b, now));
    }
    st.SetIterationTime(ta.back() * 1e-6);
    now += 1000000;
  }
  const double pa = pct(ta, 0.5), pb = pct(tb, 0.5);
  st.counters["a_p50_us"] = pa;
  st.counters["a_p99_us"] = pct(ta, 0.99);
  st.counters["b_p50_us"] = pb;
  st.counters["b_p99_us"] = pct(tb, 0.99);
  st.counters["a_over_b"] = pa / pb;
  st.SetLabel(sys.name + (in_place ? ": a = in place (slept to 1 ms deadlines), b = warm (at once after)"
                                   : ": a = hold (no command), b = commanded, back to back"));
}
BENCHMARK(BM_TickRatio)->Arg(0)->Arg(1)->UseManualTime()->Iterations(3000)->Unit(benchmark::kMicrosecond);

void BM_EncodeOutput(benchmark::State& st) {
  const System sys = load_scene(scene("two_puma_load"));
  Workspace ws(sys);
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
  evaluate(sys, ws, sys.q0, sys.v0, tau);
  io::OutputEncoder enc(sys);
  std::vector<uint8_t> buf(static_cast<size_t>(enc.max_size()));
  io::OutputFrame f;
  f.valid = true;
  f.q = &sys.q0;
  f.v = &sys.v0;
  f.tau = &tau;
  f.ws = &ws;
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  f.wrenches = &wd;
  for (auto _ : st) benchmark::DoNotOptimize(enc.encode(f, buf.data(), static_cast<int>(buf.size())));
}
BENCHMARK(BM_EncodeOutput)->Unit(benchmark::kMicrosecond);

void BM_DecodeCommand(benchmark::State& st) {
  const System sys = load_scene(scene("two_puma_load"));
  io::CommandDecoder dec(sys);
  io::CommandSlot slot;
  slot.tau = Eigen::VectorXd::Zero(sys.model.nv());
  const auto b = io::encode_torque_command(0, 1, st.range(0) ? sys.model.v_names : std::vector<std::string>{},
                                           std::vector<double>(sys.model.nv(), 0.5));
  for (auto _ : st) benchmark::DoNotOptimize(dec.decode(b.data(), static_cast<int>(b.size()), slot));
  st.SetLabel(st.range(0) ? "by name" : "scene order");
}
BENCHMARK(BM_DecodeCommand)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);
}  // namespace

BENCHMARK_MAIN();
