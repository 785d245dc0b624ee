// Cost of each reported wrench's friction bound (service/dynamics/friction_bound.h) next to the
// evaluation it comes from, on bench/scenes/two_puma_friction.yaml (every joint reaction reported):
// all 12 joints at rest (12 resting responses), and moving with 2 at rest. Interleaved in one
// process (a shared machine's load drifts between separate runs): per repetition a block of
// evaluate() calls, then compute_wrenches(), then compute_friction_bound(), each block ~0.3 ms;
// printed: the medians over REPS (default 31) repetitions of each per-call time and of the ratio
// bound / evaluate within one repetition. The evaluation includes the stiction solve (one extra
// solve per resting joint), which the bound reuses.
//
//   friction_bound_bench [REPS]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/QR>

#include "bench/bench_util.h"
#include "service/algorithms/kinematics.h"
#include "service/dynamics/friction_bound.h"
#include "service/scene/scene.h"

using namespace coopdyn;

using coopdyn::bench::median;
using coopdyn::bench::per_call_us;

namespace {

// a velocity closing the constraints at q0 with every arm joint moving but joint 2 of each arm
Eigen::VectorXd moving(const System& sys) {
  Eigen::VectorXd v = Eigen::VectorXd::Zero(sys.model.nv());
  for (int i = 0; i < v.size(); ++i) v[i] = 0.05 * ((i % 3) + 1) * (i % 2 ? -1 : 1);
  Workspace ws(sys);
  forward_kinematics(sys.model, ws.data, sys.q0, v);
  constraint_rows(sys.model, ws.data, sys.constraints, sys.q0, v, ws.cd);
  Eigen::MatrixXd G = ws.cd.G;
  std::vector<int> rest;
  for (const char* n : {"arm1.q2", "arm2.q2"})
    rest.push_back(static_cast<int>(std::find(sys.model.v_names.begin(), sys.model.v_names.end(), n) - sys.model.v_names.begin()));
  for (int d : rest) G.col(d).setZero(), v[d] = 0.0;
  Eigen::VectorXd out = v - Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd>(G).solve(G * v);
  for (int d : rest) out[d] = 0.0;
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  const int reps = argc > 1 ? std::atoi(argv[1]) : 31;
  const std::string path = std::string(COOPDYN_SOURCE_DIR) + "/bench/scenes/two_puma_friction.yaml";
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  const System sys = load_scene_string(ss.str() + "\nreactions: all\n", path);
  std::printf("%-26s %4s %4s %4s %7s %10s %10s %10s %8s\n", "two_puma_friction", "nv", "rows", "out", "resting", "eval_us",
              "wrench_us", "bound_us", "bound/eval");
  const Eigen::VectorXd tau = Eigen::VectorXd::Constant(sys.model.nv(), 0.1);
  for (const Eigen::VectorXd& v : {Eigen::VectorXd(sys.v0), moving(sys)}) {
    Workspace ws(sys);
    WrenchData wd(sys);
    FrictionBoundData fb(sys);
    evaluate(sys, ws, sys.q0, v, tau);
    const double e0 = per_call_us(50, [&] { evaluate(sys, ws, sys.q0, v, tau); });
    const int n = std::max(5, static_cast<int>(300.0 / std::max(e0, 1e-3)));
    std::vector<double> te, tw, tb, ratio;
    for (int r = 0; r < reps; ++r) {
      te.push_back(per_call_us(n, [&] { evaluate(sys, ws, sys.q0, v, tau); }));
      tw.push_back(per_call_us(n, [&] { compute_wrenches(sys, ws, wd); }));
      tb.push_back(per_call_us(n, [&] { compute_friction_bound(sys, ws, fb); }));
      ratio.push_back(tb.back() / te.back());
    }
    std::printf("%-26s %4d %4d %4zu %7d %10.2f %10.2f %10.2f %8.3f\n", ws.rest_count == 12 ? "  all joints at rest" : "  2 joints at rest",
                sys.model.nv(), sys.constraints.rows, sys.wrenches.outputs.size(), fb.resting, median(te), median(tw), median(tb),
                median(ratio));
  }
  return 0;
}
