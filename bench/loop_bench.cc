// Cost of the daemon's per-tick work without the scheduler: ServiceLoop::tick() (input handoff,
// watchdog, integrator step or evaluation, output encoding, publish to a null bus) per scene and
// mode, and the codec on its own (output encode, command decode + validation).
#include <benchmark/benchmark.h>

#include "service/io/codec.h"
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
  const std::vector<double> tau(sys.model.nv(), 0.0);
  const auto b = cfg.mode == runtime::ServiceMode::kSimulate
                     ? io::encode_torque_command(0, 1, {}, tau)
                     : io::encode_measured_state(0, 1, {}, std::vector<double>(sys.q0.data(), sys.q0.data() + sys.q0.size()),
                                                 {}, std::vector<double>(sys.v0.data(), sys.v0.data() + sys.v0.size()), tau);
  long long now = 0;
  for (auto _ : st) {
    // a fresh input every tick keeps the watchdog satisfied (the handoff is part of the cost)
    if (cfg.mode == runtime::ServiceMode::kSimulate) loop.commands().offer(b.data(), static_cast<int>(b.size()), now);
    else loop.states().offer(b.data(), static_cast<int>(b.size()), now);
    loop.tick(now);
    now += 1000000;
  }
  st.SetLabel(name + (cfg.mode == runtime::ServiceMode::kSimulate ? " simulate (rk4)" : " estimate"));
  st.counters["bytes/tick"] = static_cast<double>(bus.bytes) / static_cast<double>(st.iterations());
}
BENCHMARK(BM_Tick)->ArgsProduct({{0, 1, 2, 3}, {0, 1}})->Unit(benchmark::kMicrosecond);

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
