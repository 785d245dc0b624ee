// Leaving out pays: the same system with and without what a scene can declare, so that the cost of
// each declaration is measured, not assumed. Variants are built from the shipped scene texts by one
// textual replacement (as tests/support/test_util.h does), so everything else stays identical:
//   pseudo-joints  four_bar with its two pseudo-joints locked (6 DOF, 5 rows) vs the same tree with
//                  those joints declared fixed (4 DOF, 3 rows) vs the bare tree without the cut
//   stabilization  the vehicle scenes with their shipped Baumgarte gains and projection vs each alone
//                  vs none (RK4 step; the projection runs only in the step)
//   formulation    the SVD baseline vs the mobile platform / classic form of the same scene
//   wheels         unicycle and two_wheel_vehicle: evaluate and RK4 step
// Run: build/bin/leave_out_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cstdio>
#include <fstream>
#include <cstdlib>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "service/dynamics/integrators.h"
#include "service/scene/scene.h"

using namespace coopdyn;

namespace {

std::string scene_path(const std::string& name) {
  return std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/" + name + ".yaml";
}

std::string scene_text(const std::string& name) {
  std::ifstream f(scene_path(name));
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// Replaces one occurrence; a missing pattern aborts the benchmark (the shipped scene changed).
std::string replace_once(std::string text, const std::string& from, const std::string& to) {
  const auto p = text.find(from);
  if (p == std::string::npos) {
    std::fprintf(stderr, "leave_out_bench: not in the scene: %s\n", from.c_str());
    std::exit(1);
  }
  text.replace(p, from.size(), to);
  return text;
}

struct Variant {
  std::string label;  // benchmark name
  std::string scene;  // shipped scene the text came from (for relative paths)
  std::string text;   // YAML
  std::optional<Formulation> formulation;
};

void BM_Evaluate(benchmark::State& state, std::shared_ptr<const System> sys) {
  Workspace ws(*sys);
  const Eigen::VectorXd tau = Eigen::VectorXd::Constant(sys->model.nv(), 0.1);
  for (auto _ : state) {
    evaluate(*sys, ws, sys->q0, sys->v0, tau);
    benchmark::DoNotOptimize(ws.lambda.data());
  }
  state.counters["nv"] = sys->model.nv();
  state.counters["rows"] = sys->constraints.rows;
  state.counters["rank"] = ws.diag.rank;
}

void BM_Rk4Step(benchmark::State& state, std::shared_ptr<const System> sys) {
  Stepper st(*sys);
  Eigen::VectorXd q = sys->q0, v = sys->v0;
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys->model.nv());
  long n = 0;
  for (auto _ : state) {
    step(*sys, st, Integrator::kRk4, 1e-3, tau, q, v);
    if (++n == 500) {  // stay near the initial state
      state.PauseTiming();
      q = sys->q0;
      v = sys->v0;
      n = 0;
      state.ResumeTiming();
    }
  }
  state.counters["nv"] = sys->model.nv();
  state.counters["rows"] = sys->constraints.rows;
}

std::shared_ptr<const System> build(const Variant& v) {
  SceneOverrides ov;
  ov.formulation = v.formulation;
  return std::make_shared<const System>(load_scene_string(v.text, scene_path(v.scene), ov));
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<Variant> eval, steps;

  // pseudo-joints: locked (shipped) vs declared fixed vs no cut at all
  const std::string fb = scene_text("four_bar");
  std::string fb_fixed = replace_once(fb, "joint: {type: revolute, axis: [0, 0, 1], name: crank_bend, pseudo: true, q: 0}",
                                      "joint: {type: fixed, name: crank_bend}");
  fb_fixed = replace_once(fb_fixed, "joint: {type: prismatic, axis: [1, 0, 0], name: coupler_axial, pseudo: true, q: 0}",
                          "joint: {type: fixed, name: coupler_axial}");
  const std::string fb_tree = replace_once(
      fb_fixed, "constraints:\n  - {name: coupler_cut, type: weld, frame: cut_a, to: cut_b, axes: [wz, vx, vy]}", "");
  for (auto* list : {&eval, &steps}) {
    list->push_back({"four_bar/classic/pseudo_joints_locked", "four_bar", fb, Formulation::kClassic});
    list->push_back({"four_bar/classic/pseudo_joints_fixed", "four_bar", fb_fixed, Formulation::kClassic});
    list->push_back({"four_bar/tree_only_no_cut", "four_bar", fb_tree, Formulation::kClassic});
  }
  eval.push_back({"four_bar/pseudo_joint_schur", "four_bar", fb, Formulation::kPseudoJointSchur});

  // formulation: SVD baseline vs the analytic forms
  for (const std::string s : {"two_puma_load", "planar_arms_load"}) {
    eval.push_back({s + "/mobile_platform", s, scene_text(s), Formulation::kMobilePlatform});
    eval.push_back({s + "/svd", s, scene_text(s), Formulation::kSvdBaseline});
  }
  eval.push_back({"four_bar/svd/pseudo_joints_locked", "four_bar", fb, Formulation::kSvdBaseline});
  eval.push_back({"four_bar/svd/pseudo_joints_fixed", "four_bar", fb_fixed, Formulation::kSvdBaseline});

  // stabilization on the wheel scenes
  const std::string uni = scene_text("unicycle");
  const std::string uni_bg = "stabilization: {baumgarte: {alpha: 20, beta: 100}}";
  const std::string veh = scene_text("two_wheel_vehicle");
  const std::string veh_st = "stabilization: {baumgarte: {alpha: 20, beta: 100}, projection: {iterations: 3}}";
  const std::vector<std::pair<std::string, std::string>> uni_v = {
      {"baumgarte", uni}, {"none", replace_once(uni, uni_bg, "stabilization: none")}};
  const std::vector<std::pair<std::string, std::string>> veh_v = {
      {"baumgarte+projection", veh},
      {"projection", replace_once(veh, veh_st, "stabilization: {projection: {iterations: 3}}")},
      {"baumgarte", replace_once(veh, veh_st, "stabilization: {baumgarte: {alpha: 20, beta: 100}}")},
      {"none", replace_once(veh, veh_st, "stabilization: none")}};
  for (const auto& [lab, text] : uni_v) {
    eval.push_back({"unicycle/" + lab, "unicycle", text, std::nullopt});
    steps.push_back({"unicycle/" + lab, "unicycle", text, std::nullopt});
  }
  for (const auto& [lab, text] : veh_v) {
    eval.push_back({"two_wheel_vehicle/" + lab, "two_wheel_vehicle", text, std::nullopt});
    steps.push_back({"two_wheel_vehicle/" + lab, "two_wheel_vehicle", text, std::nullopt});
  }

  for (const Variant& v : eval) benchmark::RegisterBenchmark(("evaluate/" + v.label).c_str(), BM_Evaluate, build(v));
  for (const Variant& v : steps) benchmark::RegisterBenchmark(("rk4_step/" + v.label).c_str(), BM_Rk4Step, build(v));

  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
