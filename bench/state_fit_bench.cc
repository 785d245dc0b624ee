// Cost of completing a measured state from the joints alone (service/dynamics/state_fit.h), per
// tick of estimate mode, next to one evaluation of the same scene: warm (the load moved a little
// since the last fit, as on a measured trajectory), cold (from the initial pose, 0.2 rad away), and
// the closure residual of a full state (what every estimate tick with a full state pays).
#include <benchmark/benchmark.h>

#include <string>

#include "service/dynamics/integrators.h"
#include "service/dynamics/state_fit.h"
#include "service/scene/scene.h"

using namespace coopdyn;

namespace {
System load(const std::string& name) { return load_scene(std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/" + name + ".yaml"); }

// a closed state 'spread' (rad) from q0 along every joint, the load fitted once to close it
void closed_state(const System& sys, double spread, Eigen::VectorXd& q, Eigen::VectorXd& v) {
  Eigen::VectorXd dv = Eigen::VectorXd::Constant(sys.model.nv(), spread);
  q = sys.q0;
  integrate(sys.model, sys.q0, dv, 1.0, q);
  v = sys.v0;
  System s2 = sys;
  s2.options.projection_iterations = 50;
  Stepper st(s2);
  project_state(s2, st, q, v);
}

void BM_FitWarm(benchmark::State& st, const std::string& name) {
  const System sys = load(name);
  const StateFitPlan plan = plan_state_fit(sys);
  StateFitWorkspace ws(sys, plan);
  Eigen::VectorXd qa, va, qb, vb;
  closed_state(sys, 0.01, qa, va);
  closed_state(sys, 0.0101, qb, vb);  // the next tick: 1e-4 rad further
  Eigen::VectorXd q = qa, v = va;
  fit_state(sys, plan, ws, true, true, q, v);
  int it = 0;
  for (auto _ : st) {
    q = (++it & 1) ? qb : qa;
    v = (it & 1) ? vb : va;
    const Closure& c = fit_state(sys, plan, ws, true, true, q, v);
    benchmark::DoNotOptimize(c.value);
  }
  st.counters["iterations"] = ws.closure.iterations;
}
void BM_FitCold(benchmark::State& st, const std::string& name) {
  const System sys = load(name);
  const StateFitPlan plan = plan_state_fit(sys);
  StateFitWorkspace ws(sys, plan);
  Eigen::VectorXd qa, va;
  closed_state(sys, 0.2, qa, va);
  Eigen::VectorXd q = qa, v = va;
  for (auto _ : st) {
    ws.q_start = sys.q0;
    q = qa;
    v = va;
    const Closure& c = fit_state(sys, plan, ws, true, true, q, v);
    benchmark::DoNotOptimize(c.value);
  }
  st.counters["iterations"] = ws.closure.iterations;
}
void BM_ClosureOfFullState(benchmark::State& st, const std::string& name) {
  const System sys = load(name);
  const StateFitPlan plan = plan_state_fit(sys);
  StateFitWorkspace ws(sys, plan);
  Eigen::VectorXd q = sys.q0, v = sys.v0;
  for (auto _ : st) {
    const Closure& c = fit_state(sys, plan, ws, false, false, q, v);
    benchmark::DoNotOptimize(c.value);
  }
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
#define SCENE(s)                                                                                  \
  BENCHMARK_CAPTURE(BM_FitWarm, s, std::string(#s))->Unit(benchmark::kMicrosecond);               \
  BENCHMARK_CAPTURE(BM_FitCold, s, std::string(#s))->Unit(benchmark::kMicrosecond);               \
  BENCHMARK_CAPTURE(BM_ClosureOfFullState, s, std::string(#s))->Unit(benchmark::kMicrosecond);    \
  BENCHMARK_CAPTURE(BM_Evaluate, s, std::string(#s))->Unit(benchmark::kMicrosecond);
SCENE(two_puma_load)
SCENE(planar_arms_load)
SCENE(two_5dof_arms_load)
}  // namespace

BENCHMARK_MAIN();
