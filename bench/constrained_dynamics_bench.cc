// Cost of one full constrained evaluation (dynamics + wrenches + stresses + diagnostics) and of one
// integrator step, for every shipped scene and formulation. Also the stages of the evaluation, so
// that the cost of what a scene declares can be read off.
#include <benchmark/benchmark.h>

#include <random>
#include <string>

#include "service/algorithms/crba.h"
#include "service/algorithms/kinematics.h"
#include "service/algorithms/rnea.h"
#include "service/algorithms/tree_cholesky.h"
#include "service/dynamics/integrators.h"
#include "service/scene/scene.h"

using namespace coopdyn;

namespace {

System load(const std::string& name, Formulation f) {
  SceneOverrides ov;
  ov.formulation = f;
  return load_scene(std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/" + name + ".yaml", ov);
}

void BM_Evaluate(benchmark::State& state, const std::string& name, Formulation f) {
  const System sys = load(name, f);
  Workspace ws(sys);
  const Eigen::VectorXd v = sys.v0, tau = Eigen::VectorXd::Constant(sys.model.nv(), 0.1);
  for (auto _ : state) {
    evaluate(sys, ws, sys.q0, v, tau);
    benchmark::DoNotOptimize(ws.lambda.data());
  }
  state.counters["nv"] = sys.model.nv();
  state.counters["rows"] = sys.constraints.rows;
  state.counters["rank"] = ws.diag.rank;
}

void BM_Step(benchmark::State& state, const std::string& name, Formulation f, Integrator integ) {
  const System sys = load(name, f);
  Stepper st(sys);
  Eigen::VectorXd q = sys.q0, v = sys.v0;
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
  long n = 0;
  for (auto _ : state) {
    step(sys, st, integ, 1e-3, tau, q, v);
    if (++n == 500) {  // stay near the initial state
      state.PauseTiming();
      q = sys.q0;
      v = sys.v0;
      n = 0;
      state.ResumeTiming();
    }
  }
}

void BM_Stage(benchmark::State& state, int stage) {
  const System sys = load("two_puma_load", Formulation::kMobilePlatform);
  const Model& m = sys.model;
  Data d(m);
  const Eigen::VectorXd v = Eigen::VectorXd::Constant(m.nv(), 0.1);
  forward_kinematics(m, d, sys.q0, v);
  crba(m, d);
  tree_cholesky_factor(m, d);
  for (auto _ : state) {
    switch (stage) {
      case 0: forward_kinematics(m, d, sys.q0, v); break;
      case 1: rnea_bias(m, d); break;
      case 2: crba(m, d); break;
      case 3: tree_cholesky_factor(m, d); break;
    }
    benchmark::ClobberMemory();
  }
}

const char* kScenes[] = {"two_puma_load", "two_5dof_arms_load", "planar_arms_load", "four_bar"};

int register_all() {
  for (const char* s : kScenes) {
    const std::string name = s;
    for (Formulation f : {Formulation::kMobilePlatform, Formulation::kClassic, Formulation::kPseudoJointSchur,
                          Formulation::kSvdBaseline}) {
      const bool fb = name == "four_bar";
      if (fb && f == Formulation::kMobilePlatform) continue;
      if (!fb && f == Formulation::kPseudoJointSchur) continue;
      benchmark::RegisterBenchmark(("Evaluate/" + name + "/" + formulation_name(f)).c_str(), BM_Evaluate, name, f);
    }
    const Formulation def = name == "four_bar" ? Formulation::kClassic : Formulation::kMobilePlatform;
    for (Integrator i : {Integrator::kSemiImplicitEuler, Integrator::kRk4})
      benchmark::RegisterBenchmark(("Step/" + name + "/" + integrator_name(i)).c_str(), BM_Step, name, def, i);
  }
  const char* stages[] = {"forward_kinematics", "rnea_bias", "crba", "tree_cholesky"};
  for (int k = 0; k < 4; ++k)
    benchmark::RegisterBenchmark((std::string("Stage/two_puma_load/") + stages[k]).c_str(), BM_Stage, k);
  return 0;
}
const int registered = register_all();

}  // namespace

BENCHMARK_MAIN();
