// Cost of the Q solve (over-constrained systems: README): factor + one solve of Q lambda = b,
// Q = G M^-1 G^T symmetric PSD.
//   QSolve/jacobi/m/k     the former rank path: cyclic Jacobi eigen-decomposition + 1/eigenvalue
//                         on the range (reproduced here so that it stays measurable)
//   QSolve/qsolver/m/k    QSolver::factor + solve: k = 0 is the Cholesky fast path, k > 0 the
//                         pivoted-Cholesky rank path
//   Evaluate/<scene>      the whole evaluate() of the scenes that go down the rank path
// m rows, k = rank deficiency; Q = B B^T with B (m x (m-k)) uniform in [-1, 1].
#include <benchmark/benchmark.h>

#include <algorithm>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/jacobi.h"
#include "service/dynamics/q_solve.h"
#include "service/scene/scene.h"

using namespace coopdyn;

namespace {

Eigen::MatrixXd random_psd(int m, int k, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Eigen::MatrixXd B(m, m - k);
  for (int i = 0; i < B.size(); ++i) B.data()[i] = U(rng);
  Eigen::MatrixXd Q = B * B.transpose();
  return Q;
}

Eigen::VectorXd random_vec(int m, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Eigen::VectorXd b(m);
  for (int i = 0; i < m; ++i) b[i] = U(rng);
  return b;
}

// The former rank path (minimum norm), with its buffers sized outside the loop.
void BM_Jacobi(benchmark::State& state) {
  const int m = static_cast<int>(state.range(0)), k = static_cast<int>(state.range(1));
  const Eigen::MatrixXd Q = random_psd(m, k, 1);
  const Eigen::VectorXd b = Q * random_vec(m, 2);
  const double rank_tol = SolverOptions{}.rank_tol;
  Eigen::MatrixXd A(m, m), V(m, m);
  Eigen::VectorXd w(m), ev_inv(m), t(m), x(m);
  int rank = 0;
  for (auto _ : state) {
    A = Q;
    jacobi_eigen(A, w, V);
    const double emax = std::max(w[m - 1], 0.0);
    rank = 0;
    for (int i = 0; i < m; ++i) {
      const bool keep = w[i] > rank_tol * emax && emax > 0.0;
      ev_inv[i] = keep ? 1.0 / w[i] : 0.0;
      rank += keep;
    }
    t.noalias() = V.transpose() * b;
    t.array() *= ev_inv.array();
    x.noalias() = V * t;
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["rank"] = rank;
}

void BM_QSolver(benchmark::State& state) {
  const int m = static_cast<int>(state.range(0)), k = static_cast<int>(state.range(1));
  const Eigen::MatrixXd Q = random_psd(m, k, 1);
  const Eigen::VectorXd b = Q * random_vec(m, 2);
  const Eigen::VectorXd compliance = Eigen::VectorXd::Zero(m);
  const SolverOptions opt;
  QSolver qs(m);
  Eigen::VectorXd x(m);
  for (auto _ : state) {
    qs.factor(Q, opt, compliance);
    qs.solve(b, x);
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["rank"] = qs.rank;
  state.counters["fast_path"] = qs.fast_path;
}

// QSolver::factor_nominal_last + solve: one nominal direction per 6 rows (an arm without armature
// on each weld), G's column of joint 1 of each weld random.
void BM_QSolverNominal(benchmark::State& state) {
  const int m = static_cast<int>(state.range(0)), nd = m / 6;
  const Eigen::MatrixXd Q = random_psd(m, 0, 1);
  const Eigen::VectorXd b = Q * random_vec(m, 2);
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(m, nd);
  std::vector<std::pair<int, int>> rows;
  for (int a = 0; a < nd; ++a) {
    G.block(6 * a, a, 6, 1) = random_vec(6, 3 + a);
    rows.emplace_back(a, 6 * a);
  }
  const SolverOptions opt;
  QSolver qs(m);
  qs.plan_nominal(rows);
  Eigen::VectorXd x(m);
  double condition = 0.0;
  bool ok = true;
  for (auto _ : state) {
    ok = qs.factor_nominal_last(Q, G, opt, &condition);
    qs.solve(b, x);
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["fast_path"] = ok;
}

void BM_Evaluate(benchmark::State& state, const std::string& name) {
  const System sys = load_scene(std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/" + name + ".yaml");
  Workspace ws(sys);
  const Eigen::VectorXd tau = Eigen::VectorXd::Constant(sys.model.nv(), 0.1);
  for (auto _ : state) {
    evaluate(sys, ws, sys.q0, sys.v0, tau);
    benchmark::DoNotOptimize(ws.lambda.data());
  }
  state.counters["rows"] = sys.constraints.rows;
  state.counters["rank"] = ws.diag.rank;
}

int register_all() {
  for (int m : {6, 12})
    for (int k : {1, 3}) {
      benchmark::RegisterBenchmark("QSolve/jacobi", BM_Jacobi)->Args({m, k});
      benchmark::RegisterBenchmark("QSolve/qsolver", BM_QSolver)->Args({m, k});
    }
  for (int m : {6, 12}) benchmark::RegisterBenchmark("QSolve/qsolver", BM_QSolver)->Args({m, 0});
  for (int m : {6, 12, 24}) benchmark::RegisterBenchmark("QSolve/nominal_last", BM_QSolverNominal)->Args({m});
  for (const char* s : {"two_wheel_vehicle", "unicycle", "planar_arms_load"})
    benchmark::RegisterBenchmark((std::string("Evaluate/") + s).c_str(), BM_Evaluate, std::string(s));
  return 0;
}
const int registered = register_all();

}  // namespace

BENCHMARK_MAIN();
