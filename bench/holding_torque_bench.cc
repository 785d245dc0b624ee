// Cost of the safe torque `hold` (service/dynamics/holding_torque.h) per tick, next to one
// evaluation of the same scene: it runs only while no command is fresh. BM_HoldingTorque: from
// (q, v) (begin_evaluation, then the factored solve); BM_HoldFromEvaluation: the solve alone, from
// an evaluation already begun (what the loop adds to its step); BM_HoldSvd: the reference solve
// (two Jacobi SVDs) from the same evaluation.
#include <benchmark/benchmark.h>

#include <string>

#include "service/dynamics/holding_torque.h"
#include "service/scene/scene.h"

using namespace coopdyn;

namespace {
System load(const std::string& name) { return load_scene(std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/" + name + ".yaml"); }

void BM_HoldingTorque(benchmark::State& st, const std::string& name) {
  const System sys = load(name);
  HoldWorkspace hw(sys, default_actuated(sys));
  Eigen::VectorXd tau(sys.model.nv());
  for (auto _ : st) {
    holding_torque(sys, hw, sys.q0, sys.v0, tau);
    benchmark::DoNotOptimize(tau.data());
  }
  st.counters["actuated"] = static_cast<double>(hw.act.size());
}
void BM_HoldFromEvaluation(benchmark::State& st, const std::string& name, bool svd) {
  const System sys = load(name);
  HoldWorkspace hw(sys, default_actuated(sys));
  Workspace ws(sys);
  begin_evaluation(sys, ws, sys.q0, sys.v0);
  Eigen::VectorXd tau(sys.model.nv());
  for (auto _ : st) {
    if (svd) holding_torque_svd(sys, hw, ws, tau);
    else holding_torque(sys, hw, ws, tau);
    benchmark::DoNotOptimize(tau.data());
  }
  st.counters["factored"] = hw.factored;
}
void BM_Evaluate(benchmark::State& st, const std::string& name) {
  const System sys = load(name);
  Workspace ws(sys);
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
  for (auto _ : st) {
    evaluate(sys, ws, sys.q0, sys.v0, tau);
    benchmark::DoNotOptimize(ws.vdot.data());
  }
}
BENCHMARK_CAPTURE(BM_HoldingTorque, two_puma_load, std::string("two_puma_load"))->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Evaluate, two_puma_load, std::string("two_puma_load"))->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_HoldFromEvaluation, two_puma_load, std::string("two_puma_load"), false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_HoldFromEvaluation, two_puma_load_svd, std::string("two_puma_load"), true)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_HoldFromEvaluation, tiago_pro_box, std::string("tiago_pro_box"), false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_HoldFromEvaluation, tiago_pro_box_svd, std::string("tiago_pro_box"), true)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_HoldingTorque, planar_arms_load, std::string("planar_arms_load"))->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_HoldingTorque, two_wheel_vehicle, std::string("two_wheel_vehicle"))->Unit(benchmark::kMicrosecond);
}  // namespace

BENCHMARK_MAIN();
