// Where the time of one evaluation goes, on the arms-on-one-load scenes (bench/scenes/pumas_N.yaml
// and pumas_N_no_armature.yaml, 1, 2, 4 and 8 arms): the stages of begin_evaluation() timed as
// cumulative prefixes in one process (kinematics; + bias forces; + mass matrix; + its tree factor;
// begin_evaluation, which adds the constraint rows; evaluate, which adds the solve of Q and the
// diagnostics), each the median over repetitions of blocks of about 2 ms of thread CPU time
// (CLOCK_THREAD_CPUTIME_ID) cycling 16 random states near the scene's initial one, as arms_scaling.
// The last column is evaluate() with the condition without the nominal base-link directions left
// out (Workspace::nominal_rows and QBlocks::has_nominal cleared; the condition then reported is Q's own):
// what that diagnostic costs where the arms carry no armature.
//
//   build/bin/evaluation_stages [REPETITIONS=15]
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "service/algorithms/crba.h"
#include "service/algorithms/kinematics.h"
#include "service/algorithms/rnea.h"
#include "service/algorithms/tree_cholesky.h"
#include "service/dynamics/constrained_dynamics.h"
#include "service/scene/scene.h"

using namespace coopdyn;

namespace {

double cpu_ns() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e9 + static_cast<double>(ts.tv_nsec);
}

// median over reps of the time per call of f(k), k cycling over the 16 states
double time_per_call(int reps, const std::function<void(int)>& f) {
  std::vector<double> t;
  for (int r = 0; r < reps + 1; ++r) {  // repetition 0 warms up
    long calls = 0;
    const double t0 = cpu_ns();
    double t1 = t0;
    while (t1 - t0 < 2e6) {
      for (int k = 0; k < 16; ++k) f(k);
      calls += 16;
      t1 = cpu_ns();
    }
    if (r > 0) t.push_back((t1 - t0) / static_cast<double>(calls));
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const int reps = argc > 1 ? std::max(3, std::atoi(argv[1])) : 15;
  std::printf("| scene | DOF | kinematics | bias | mass matrix | tree factor | constraint rows | solve + diagnostics |"
              " evaluate | without the nominal condition |\n|---|---|---|---|---|---|---|---|---|---|\n");
  for (const char* suffix : {"", "_no_armature"})
    for (int n : {1, 2, 4, 8}) {
      const std::string name = "pumas_" + std::to_string(n) + suffix;
      const System sys = load_scene(std::string(COOPDYN_SOURCE_DIR) + "/bench/scenes/" + name + ".yaml");
      const Model& m = sys.model;
      std::mt19937 rng(5);
      std::uniform_real_distribution<double> U(-1.0, 1.0);
      std::vector<Eigen::VectorXd> q, v;
      for (int k = 0; k < 16; ++k) {
        Eigen::VectorXd dq(m.nv()), qk(m.nq()), vk(m.nv());
        for (int i = 0; i < m.nv(); ++i) dq[i] = 0.05 * U(rng);
        integrate(m, sys.q0, dq, 1.0, qk);
        for (int i = 0; i < m.nv(); ++i) vk[i] = 0.3 * U(rng);
        q.push_back(qk);
        v.push_back(vk);
      }
      const Eigen::VectorXd tau = Eigen::VectorXd::Zero(m.nv());
      Workspace ws(sys), ws_nn(sys);
      ws_nn.nominal_rows.clear();  // the dense path's reduced Q
      ws_nn.qb.has_nominal = false;  // the block path's
      double t[7];
      for (int stage = 0; stage < 4; ++stage)
        t[stage] = time_per_call(reps, [&](int k) {
          forward_kinematics(m, ws.data, q[k], v[k]);
          if (stage >= 1) rnea_bias(m, ws.data);
          if (stage >= 2) crba_compact(m, ws.data);
          if (stage >= 3) tree_cholesky_factor(m, ws.data);
        });
      t[4] = time_per_call(reps, [&](int k) { begin_evaluation(sys, ws, q[k], v[k]); });
      t[5] = time_per_call(reps, [&](int k) { evaluate(sys, ws, q[k], v[k], tau); });
      t[6] = time_per_call(reps, [&](int k) { evaluate(sys, ws_nn, q[k], v[k], tau); });
      std::printf("| %s | %d | %.0f ns | %.0f ns | %.0f ns | %.0f ns | %.0f ns | %.0f ns | %.0f ns | %s |\n", name.c_str(),
                  m.nv(), t[0], t[1] - t[0], t[2] - t[1], t[3] - t[2], t[4] - t[3], t[5] - t[4], t[5],
                  ws.nominal_rows.empty() ? "-" : (std::to_string(static_cast<int>(t[6] + 0.5)) + " ns").c_str());
    }
  std::printf("\n%d repetitions; medians of the time per call; stages as differences of cumulative prefixes.\n", reps);
  return 0;
}
