// QSolver (service/dynamics/q_solve.h) against Eigen's SVD-based pseudo-inverse on random symmetric PSD
// matrices of known rank: rank, minimum-norm solution, indeterminate rows, the compliance rule and the
// residual of consistent right-hand sides.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "service/dynamics/q_solve.h"

namespace coopdyn {
namespace {

struct Case {
  Eigen::MatrixXd Q;  // (m x m) = U diag(s) U^T, U (m x r) orthonormal
  Eigen::MatrixXd U;  // (m x r) range
  Eigen::MatrixXd N;  // (m x k) orthonormal null-space basis
};

// Random symmetric PSD matrix of size m and rank m - k, eigenvalues on the range log-uniform in
// [scale / cond, scale]. With sparse_null, the null space touches only some rows (as a rigid axle
// touches only the lateral rows), so that the indeterminate flags are a proper subset.
Case random_case(std::mt19937& rng, int m, int k, double scale, double cond, bool sparse_null) {
  std::normal_distribution<double> Nd;
  std::uniform_real_distribution<double> U01(0.0, 1.0);
  Eigen::MatrixXd A(m, m);
  for (int i = 0; i < A.size(); ++i) A.data()[i] = Nd(rng);
  if (sparse_null && k > 0) {
    // null-space vectors supported on the first 2k rows (zero elsewhere), then orthogonalize
    for (int j = 0; j < k; ++j)
      for (int i = 2 * k; i < m; ++i) A(i, j) = 0.0;
  }
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(A);
  const Eigen::MatrixXd O = qr.householderQ() * Eigen::MatrixXd::Identity(m, m);
  Case c;
  c.N = O.leftCols(k);
  c.U = O.rightCols(m - k);
  Eigen::VectorXd s(m - k);
  for (int i = 0; i < m - k; ++i) s[i] = scale * std::pow(cond, -U01(rng));
  if (m - k > 0) {
    s[0] = scale;
    if (m - k > 1) s[1] = scale / cond;
  }
  c.Q = c.U * s.asDiagonal() * c.U.transpose();
  c.Q = 0.5 * (c.Q + c.Q.transpose()).eval();
  return c;
}

Eigen::VectorXd pinv_solve(const Eigen::MatrixXd& Q, const Eigen::VectorXd& b, int rank) {
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Q, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::VectorXd& s = svd.singularValues();
  Eigen::VectorXd t = svd.matrixU().transpose() * b;
  for (int i = 0; i < Q.rows(); ++i) t[i] = i < rank ? t[i] / s[i] : 0.0;
  return svd.matrixV() * t;
}

TEST(QSolve, RankAndMinimumNormSolutionOfRandomPsdMatrices) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> Um(1, 24);
  const SolverOptions opt;
  int n_cases = 0;
  double worst_sol = 0.0, worst_res = 0.0, worst_null = 0.0;
  for (int trial = 0; trial < 400; ++trial) {
    const int m = Um(rng);
    const int k = std::min(trial % 5, m - 1);
    const double scale = std::pow(10.0, -6.0 + 12.0 * (trial % 13) / 12.0);
    const double cond = std::pow(10.0, 8.0 * ((trial / 5) % 9) / 8.0);
    const Case c = random_case(rng, m, k, scale, cond, trial % 2 == 1);
    QSolver qs(m);
    const QFactorInfo fi = qs.factor(c.Q, opt, Eigen::VectorXd::Zero(m));
    ASSERT_EQ(fi.rank, m - k) << "m " << m << " k " << k << " scale " << scale << " cond " << cond;
    ASSERT_EQ(qs.rank, m - k);
    // every Cholesky pivot ratio of a full-rank Q is >= 1 / cond(Q) (>= fast_tol = 1e-8 up to 1e7)
    if (k > 0) {
      EXPECT_FALSE(qs.fast_path);
    }
    if (k == 0 && cond <= 1e7) {
      EXPECT_TRUE(qs.fast_path);
    }
    // condition estimate: within a factor of the true condition on the range (an estimate)
    EXPECT_GE(fi.condition, 1.0);
    EXPECT_LE(fi.condition, 10.0 * cond * m) << "m " << m << " k " << k;
    // consistent right-hand side b = Q y: the residual is at round-off, the solution is Q^+ b
    Eigen::VectorXd y(m);
    for (int i = 0; i < m; ++i) y[i] = std::normal_distribution<double>()(rng);
    const Eigen::VectorXd b = c.Q * y;
    Eigen::VectorXd x(m);
    qs.solve(b, x);
    ASSERT_TRUE(x.allFinite());
    const Eigen::VectorXd xp = pinv_solve(c.Q, b, m - k);
    // the error of the range component is bounded by cond * eps * |x|
    // both have errors of order cond * eps on the range
    const double eps = std::numeric_limits<double>::epsilon();
    const double e_sol = (x - xp).norm() / (cond * eps * xp.norm());
    const double e_res = (c.Q * x - b).norm() / (c.Q.norm() * x.norm() + b.norm());
    const double e_null = k > 0 ? (c.N.transpose() * x).norm() / (cond * eps * x.norm()) : 0.0;
    worst_sol = std::max(worst_sol, e_sol);
    worst_res = std::max(worst_res, e_res);
    worst_null = std::max(worst_null, e_null);
    EXPECT_LE(e_sol, 100.0) << "m " << m << " k " << k << " cond " << cond;
    EXPECT_LE(e_res, 1e-13) << "m " << m << " k " << k;
    // minimum norm: no component along the null space
    EXPECT_LE(e_null, 100.0) << "m " << m << " k " << k << " cond " << cond;
    ++n_cases;
  }
  EXPECT_EQ(n_cases, 400);
  std::printf("worst over %d cases: |x - Q^+ b| / (cond eps |x|) %.3g, |Q x - b| / (|Q| |x| + |b|) %.3g, "
              "|N^T x| / (cond eps |x|) %.3g\n",
              n_cases, worst_sol, worst_res, worst_null);
}

}  // namespace
}  // namespace coopdyn
