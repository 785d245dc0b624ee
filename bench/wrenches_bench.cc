// Cost of the reported wrenches (service/dynamics/wrenches.h) next to the evaluation they come from:
// per shipped scene, one evaluate(), then compute_wrenches() with the scene's default outputs
// (end-effectors, bases, tips, axles) and with every joint reaction (`reactions: all`). The
// wrenches are timed on their own (the evaluation stays in the workspace), so the ratio
// wrenches / evaluate is read off one run. Goal (issue "forces everywhere"): all joint reactions
// under 10 % of an evaluation.
#include <benchmark/benchmark.h>

#include <fstream>
#include <sstream>
#include <string>

#include "service/dynamics/wrenches.h"
#include "service/scene/scene.h"

using namespace coopdyn;

namespace {

System load(const std::string& name, bool all) {
  const std::string path = std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/" + name + ".yaml";
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  std::string text = ss.str();
  if (all && text.find("\nreactions:") == std::string::npos) text += "\nreactions: all\n";
  if (!all) {  // the scene without any joint reaction, whatever it ships with
    const auto p = text.find("\nreactions:");
    if (p != std::string::npos) text.erase(p, text.find('\n', p + 1) - p);
  }
  return load_scene_string(text, path);
}

void BM_Evaluate(benchmark::State& st, const std::string& name) {
  const System sys = load(name, false);
  Workspace ws(sys);
  const Eigen::VectorXd tau = Eigen::VectorXd::Constant(sys.model.nv(), 0.1);
  for (auto _ : st) {
    evaluate(sys, ws, sys.q0, sys.v0, tau);
    benchmark::DoNotOptimize(ws.lambda.data());
  }
}

void BM_Wrenches(benchmark::State& st, const std::string& name, bool all) {
  const System sys = load(name, all);
  Workspace ws(sys);
  const Eigen::VectorXd tau = Eigen::VectorXd::Constant(sys.model.nv(), 0.1);
  evaluate(sys, ws, sys.q0, sys.v0, tau);
  WrenchData wd(sys);
  for (auto _ : st) {
    compute_wrenches(sys, ws, wd);
    benchmark::DoNotOptimize(wd.W.data());
  }
  int joints = 0;
  for (const WrenchOutput& o : sys.wrenches.outputs) joints += o.kind == WrenchKind::kJoint;
  st.counters["outputs"] = static_cast<double>(sys.wrenches.outputs.size());
  st.counters["joints"] = joints;
  st.counters["pass_bodies"] = static_cast<double>(sys.wrenches.pass.size());
}

const char* kScenes[] = {"two_puma_load", "two_5dof_arms_load", "planar_arms_load", "four_bar", "unicycle",
                         "two_wheel_vehicle"};

[[maybe_unused]] const bool registered = [] {
  for (const char* s : kScenes) {
    benchmark::RegisterBenchmark((std::string("BM_Evaluate/") + s).c_str(), BM_Evaluate, std::string(s))
        ->Unit(benchmark::kMicrosecond);
    benchmark::RegisterBenchmark((std::string("BM_Wrenches/") + s + "/default").c_str(), BM_Wrenches, std::string(s), false)
        ->Unit(benchmark::kMicrosecond);
    benchmark::RegisterBenchmark((std::string("BM_Wrenches/") + s + "/all_reactions").c_str(), BM_Wrenches, std::string(s), true)
        ->Unit(benchmark::kMicrosecond);
  }
  return true;
}();

}  // namespace

BENCHMARK_MAIN();
