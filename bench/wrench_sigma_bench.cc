// Cost of each reported wrench's sigma (service/dynamics/sigma/wrench_sigma.h) next to the evaluation it
// comes from. Per scene (the shipped scenes whose formulation propagates noise, then 1, 2, 3, 4, 6 and 8
// PUMAs holding a load: bench/scenes/pumas_N.yaml, and 3, 4, 6 and 8 without joint armature, whose Q
// is factored with the nominal rows last: pumas_N_no_armature.yaml; every joint reaction reported,
// `noise: {tau: 0.1, q: 1e-4, v: 1e-3}` on every actuated / measured joint), interleaved in one process (a shared machine's load drifts
// between separate runs): per repetition a block of evaluate() calls, then compute_wrenches(), then
// compute_wrench_sigma() with the torque noise (simulate mode), then with the torque, position and
// velocity noise (estimate mode), then the same with the load's pose and twist refitted (their response
// carried in every column, state_fit_sigma.h: estimate mode when a state omits them; scenes with a
// load, at the initial state), each block ~0.3 ms; printed per scene: the medians over REPS
// (default 31) repetitions of each per-call time and of the ratios sigma / evaluate within one
// repetition. q_us and v_us: estimate mode with the torque noise and only the position (only the
// velocity) noise declared, what each kind of measurement-noise column adds to sigma_us. arms: the
// simulate-mode sigma took the arm form (wrench_sigma_arms.h); cols_us: the same sigma by the
// column form (every noisy torque a column through the solve and the pass), arms_us: by the arm
// form from two arms on ('-': its structure does not hold), both timed interleaved with sigma_us. Goal: the sigma of every reported wrench under 25 % of an evaluation.
//
//   wrench_sigma_bench [REPS] [SCENE] [REACTIONS] [FORMULATION]   (SCENE: only the scenes whose file
//   name contains it; REACTIONS: the joint reactions reported, `all` (the default) or `none`: the
//   scene's end-effector, base, tip and axle wrenches only; FORMULATION: replaces each scene's, e.g.
//   `classic`)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "bench/bench_util.h"
#include "service/dynamics/sigma/state_fit_sigma.h"
#include "service/dynamics/sigma/wrench_sigma.h"
#include "service/scene/scene.h"

using namespace coopdyn;

using coopdyn::bench::median;
using coopdyn::bench::per_call_us;

namespace {

std::string reactions = "all";
SceneOverrides overrides;

System load(const std::string& path, const char* noise = "{tau: 0.1, q: 1e-4, v: 1e-3}") {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  std::string text = ss.str();
  const auto p = text.find("\nreactions:");
  if (p != std::string::npos) text.erase(p, text.find('\n', p + 1) - p);
  return load_scene_string(text + "\nreactions: " + reactions + "\nnoise: " + noise + "\n", path, overrides);
}

}  // namespace

int main(int argc, char** argv) {
  const int reps = argc > 1 ? std::atoi(argv[1]) : 31;
  const std::string only = argc > 2 ? argv[2] : "";
  if (argc > 3) reactions = argv[3];
  if (Formulation f; argc > 4) {
    if (!parse_formulation(argv[4], &f)) {
      std::fprintf(stderr, "wrench_sigma_bench: unknown formulation '%s'\n", argv[4]);
      return 2;
    }
    overrides.formulation = f;
  }
  const std::string dir = std::string(COOPDYN_SOURCE_DIR);
  std::vector<std::string> scenes;
  for (const char* n : {"four_bar", "four_wheel_car", "planar_arms_load", "pr2_box", "tiago_pro_box", "trike", "two_5dof_arms_load",
                        "two_iiwa_load", "two_puma_load", "two_wheel_vehicle", "unicycle"})
    scenes.push_back(dir + "/config/scenes/" + n + ".yaml");
  for (const char* n : {"pumas_1", "pumas_2", "pumas_3", "pumas_4", "pumas_6", "pumas_8", "pumas_3_no_armature",
                        "pumas_4_no_armature", "pumas_6_no_armature", "pumas_8_no_armature"})
    scenes.push_back(dir + "/bench/scenes/" + n + ".yaml");
  std::printf("%-22s %4s %4s %4s %5s %5s %8s %9s %8s %10s %4s %8s %9s %8s %8s %10s %8s %8s %8s %10s\n", "scene", "nv", "rows", "out",
              "tau", "q+v", "eval_us", "wrench_us", "sigma_us", "sigma/eval", "arms", "cols_us", "cols/eval", "arms_us", "est_us",
              "est/eval", "q_us", "v_us", "fit_us", "fit/eval");
  for (const std::string& path : scenes) {
    if (path.substr(path.rfind('/') + 1).find(only) == std::string::npos) continue;
    const System sys = load(path);
    Workspace ws(sys);
    WrenchData wd(sys);
    WrenchSigmaData sd(sys), sc(sys), sa(sys);
    sc.arms_min = std::numeric_limits<int>::max();  // the column form and the arm form from 2 arms,
    sa.arms_min = 2;                                // interleaved with sd's (as shipped)
    if (!wrench_sigma_supported(sys)) continue;
    const System sys_q = load(path, "{tau: 0.1, q: 1e-4}"), sys_v = load(path, "{tau: 0.1, v: 1e-3}");
    Workspace ws_q(sys_q), ws_v(sys_v);
    WrenchSigmaData sd_q(sys_q), sd_v(sys_v);  // a formulation that does not propagate noise
    const Eigen::VectorXd tau = Eigen::VectorXd::Constant(sys.model.nv(), 0.1);
    const StateFitPlan plan = plan_state_fit(sys);
    std::optional<FitRefit> refit;
    WrenchSigmaData sf(sys);
    if (plan.q_fittable && plan.v_fittable && !plan.fit_q.empty()) {
      refit.emplace(sys, plan);
      refit->set(sys.q0, true, true);
      sf.refit = &*refit;
    }
    evaluate(sys, ws, sys.q0, sys.v0, tau);
    evaluate(sys_q, ws_q, sys.q0, sys.v0, tau);
    evaluate(sys_v, ws_v, sys.q0, sys.v0, tau);
    const double e0 = per_call_us(50, [&] { evaluate(sys, ws, sys.q0, sys.v0, tau); });
    const int n = std::max(5, static_cast<int>(300.0 / std::max(e0, 1e-3)));
    std::vector<double> te, tw, ts, tc, ta, tq, tqq, tqv, tf, ratio, ratio_c, ratio_q, ratio_f;
    for (int r = 0; r < reps; ++r) {
      te.push_back(per_call_us(n, [&] { evaluate(sys, ws, sys.q0, sys.v0, tau); }));
      tw.push_back(per_call_us(n, [&] { compute_wrenches(sys, ws, wd); }));
      ts.push_back(per_call_us(n, [&] { compute_wrench_sigma(sys, ws, sd); }));
      tc.push_back(per_call_us(n, [&] { compute_wrench_sigma(sys, ws, sc); }));
      ratio_c.push_back(tc.back() / te.back());
      ta.push_back(per_call_us(n, [&] { compute_wrench_sigma(sys, ws, sa); }));
      tq.push_back(per_call_us(n, [&] { compute_wrench_sigma(sys, ws, sd, sys.q0, sys.v0, tau); }));
      tqq.push_back(per_call_us(n, [&] { compute_wrench_sigma(sys_q, ws_q, sd_q, sys.q0, sys.v0, tau); }));
      tqv.push_back(per_call_us(n, [&] { compute_wrench_sigma(sys_v, ws_v, sd_v, sys.q0, sys.v0, tau); }));
      ratio.push_back(ts.back() / te.back());
      ratio_q.push_back(tq.back() / te.back());
      if (!refit) continue;
      tf.push_back(per_call_us(n, [&] { compute_wrench_sigma(sys, ws, sf, sys.q0, sys.v0, tau); }));
      ratio_f.push_back(tf.back() / te.back());
    }
    const std::string name = path.substr(path.rfind('/') + 1);
    compute_wrench_sigma(sys, ws, sd);
    compute_wrench_sigma(sys, ws, sa);
    char arms_us[16] = "-";
    if (sa.arms_used) std::snprintf(arms_us, sizeof arms_us, "%.2f", median(ta));
    std::printf("%-22s %4d %4d %4zu %5zu %5zu %8.2f %9.2f %8.2f %10.3f %4s %8.2f %9.3f %8s %8.2f %10.3f %8.2f %8.2f", name.c_str(),
                sys.model.nv(), sys.constraints.rows, sys.wrenches.outputs.size(), sd.dofs.size(), sd.q_dofs.size() + sd.v_dofs.size(),
                median(te), median(tw), median(ts), median(ratio), sd.arms_used ? "yes" : "no", median(tc), median(ratio_c), arms_us,
                median(tq), median(ratio_q), median(tqq), median(tqv));
    if (refit) std::printf(" %8.2f %10.3f\n", median(tf), median(ratio_f));
    else std::printf(" %8s %10s\n", "-", "-");
  }
  return 0;
}
