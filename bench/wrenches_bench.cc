// Cost of the reported wrenches (service/dynamics/wrenches.h) next to the evaluation they come from:
// per shipped scene, one evaluate(), then compute_wrenches() with the scene's default outputs
// (end-effectors, bases, tips, axles) and with every joint reaction (`reactions: all`). The
// wrenches are timed on their own (the evaluation stays in the workspace), so the ratio
// wrenches / evaluate is read off one run. Goal: all joint reactions
// under 10 % of an evaluation.
//
// `wrenches_bench --ratio [REPS]` times the same three things instead with interleaved loops in one
// process (on a noisy shared machine the ratio of two separate Google Benchmark runs drifts with the
// load): per repetition and scene, a block of evaluate() calls, then compute_wrenches() with the
// default outputs, then with every joint reaction, each block ~0.3 ms; it prints per scene the
// medians over REPS (default 31) repetitions of each per-call time and of the ratio
// all reactions / evaluate taken within one repetition.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "bench/bench_util.h"
#include "service/dynamics/wrenches.h"
#include "service/scene/scene.h"

using namespace coopdyn;

using coopdyn::bench::median;
using coopdyn::bench::per_call_us;

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

// ---- --ratio: interleaved timing -----------------------------------------------------------------

struct RatioCase {
  std::string name;
  System sys_def, sys_all;
  Workspace ws_def, ws_all;
  WrenchData wd_def, wd_all;
  Eigen::VectorXd tau;
  int n_eval = 1, n_def = 1, n_all = 1;  // calls per block
  std::vector<double> t_eval, t_def, t_all, ratio, ratio_extra;
  RatioCase(const std::string& n, System d, System a)
      : name(n), sys_def(std::move(d)), sys_all(std::move(a)), ws_def(sys_def), ws_all(sys_all), wd_def(sys_def),
        wd_all(sys_all), tau(Eigen::VectorXd::Constant(sys_all.model.nv(), 0.1)) {}
};

int run_ratio(int reps) {
  std::vector<RatioCase*> cases;
  for (const char* s : kScenes) cases.push_back(new RatioCase(s, load(s, false), load(s, true)));
  auto eval = [](RatioCase& c) {
    evaluate(c.sys_all, c.ws_all, c.sys_all.q0, c.sys_all.v0, c.tau);
    benchmark::DoNotOptimize(c.ws_all.lambda.data());
  };
  auto def = [](RatioCase& c) {
    compute_wrenches(c.sys_def, c.ws_def, c.wd_def);
    benchmark::DoNotOptimize(c.wd_def.W.data());
    benchmark::ClobberMemory();
  };
  auto all = [](RatioCase& c) {
    compute_wrenches(c.sys_all, c.ws_all, c.wd_all);
    benchmark::DoNotOptimize(c.wd_all.W.data());
    benchmark::ClobberMemory();
  };
  // warm up and size the blocks (~0.3 ms each)
  const double block_us = 300.0;
  for (RatioCase* c : cases) {
    evaluate(c->sys_def, c->ws_def, c->sys_def.q0, c->sys_def.v0, c->tau);
    eval(*c);
    const double te = per_call_us(2000, [&] { eval(*c); });
    const double td = per_call_us(20000, [&] { def(*c); });
    const double ta = per_call_us(20000, [&] { all(*c); });
    c->n_eval = std::max(1, static_cast<int>(block_us / te));
    c->n_def = std::max(1, static_cast<int>(block_us / std::max(td, 1e-3)));
    c->n_all = std::max(1, static_cast<int>(block_us / std::max(ta, 1e-3)));
  }
  for (int r = 0; r < reps; ++r)
    for (RatioCase* c : cases) {
      // the evaluation stays in ws_all for the wrenches; evaluate() leaves the same state each call
      const double te = per_call_us(c->n_eval, [&] { eval(*c); });
      const double td = per_call_us(c->n_def, [&] { def(*c); });
      const double ta = per_call_us(c->n_all, [&] { all(*c); });
      c->t_eval.push_back(te);
      c->t_def.push_back(td);
      c->t_all.push_back(ta);
      c->ratio.push_back(ta / te);
      c->ratio_extra.push_back((ta - td) / te);
    }
  std::printf("interleaved, %d repetitions, medians (per call)\n", reps);
  std::printf("| scene | pass bodies | joint outputs | evaluate | default wrenches | all joint reactions | all / evaluate | (all - default) / evaluate |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (RatioCase* c : cases) {
    int joints = 0;
    for (const WrenchOutput& o : c->sys_all.wrenches.outputs) joints += o.kind == WrenchKind::kJoint;
    std::printf("| %s | %zu | %d | %.3f us | %.3f us | %.3f us | %.1f %% | %.1f %% |\n", c->name.c_str(),
                c->sys_all.wrenches.pass.size(), joints, median(c->t_eval), median(c->t_def), median(c->t_all),
                100.0 * median(c->ratio), 100.0 * median(c->ratio_extra));
  }
  for (RatioCase* c : cases) delete c;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i)
    if (std::strcmp(argv[i], "--ratio") == 0) return run_ratio(i + 1 < argc ? std::max(1, std::atoi(argv[i + 1])) : 31);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
