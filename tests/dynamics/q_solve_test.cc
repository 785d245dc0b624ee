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
  Eigen::MatrixXd O = qr.householderQ() * Eigen::MatrixXd::Identity(m, m);
  // rows in random order, so that the null space does not sit in the last rows
  Eigen::PermutationMatrix<Eigen::Dynamic> P(m);
  P.setIdentity();
  std::shuffle(P.indices().data(), P.indices().data() + m, rng);
  O = (P * O).eval();
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

TEST(QSolve, IndeterminateRowsAreExactlyThoseTheNullSpaceMoves) {
  // The null space touches only some rows (the sparse cases: as a rigid axle touches only the
  // lateral rows); those and only those are flagged.
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> Um(2, 24);
  const SolverOptions opt;
  int n_partial = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const int m = Um(rng);
    const int k = 1 + trial % std::min(4, m - 1);
    const double scale = std::pow(10.0, -6.0 + 12.0 * (trial % 7) / 6.0);
    const double cond = std::pow(10.0, (trial / 7) % 9);
    const Case c = random_case(rng, m, k, scale, cond, true);
    QSolver qs(m);
    ASSERT_EQ(qs.factor(c.Q, opt, Eigen::VectorXd::Zero(m)).rank, m - k);
    int flagged = 0;
    for (int i = 0; i < m; ++i) {
      const bool moved = c.N.row(i).squaredNorm() > 1e-12;
      EXPECT_EQ(qs.row_indeterminate[i] != 0, moved) << "m " << m << " k " << k << " row " << i;
      flagged += moved;
    }
    n_partial += flagged < m;
  }
  EXPECT_GT(n_partial, 100);  // most cases flag a proper subset of the rows
}

TEST(QSolve, InconsistentRightHandSideGivesTheLeastSquaresMinimumNormSolution) {
  // b = Q y + N w has a part outside the range of Q (a stabilization term on dependent rows can):
  // the solution is still Q^+ b, i.e. the part along N is ignored.
  std::mt19937 rng(13);
  std::normal_distribution<double> Nd;
  const SolverOptions opt;
  double worst = 0.0;
  for (int trial = 0; trial < 100; ++trial) {
    const int m = 2 + trial % 23, k = 1 + trial % std::min(4, m - 1);
    const double cond = std::pow(10.0, trial % 7);
    const Case c = random_case(rng, m, k, 1.0, cond, trial % 2 == 0);
    QSolver qs(m);
    qs.factor(c.Q, opt, Eigen::VectorXd::Zero(m));
    Eigen::VectorXd y(m), w(k);
    for (int i = 0; i < m; ++i) y[i] = Nd(rng);
    for (int i = 0; i < k; ++i) w[i] = Nd(rng);
    const Eigen::VectorXd b = c.Q * y + c.N * w;
    Eigen::VectorXd x(m);
    qs.solve(b, x);
    const Eigen::VectorXd xp = pinv_solve(c.Q, b, m - k);
    // least-squares perturbation bound (Wedin): cond eps |x| + cond^2 eps |r| / |Q|, |Q| = 1 here,
    // r = N w the residual of the least-squares solution
    const double eps = std::numeric_limits<double>::epsilon();
    const double e = (x - xp).norm() / (cond * eps * xp.norm() + cond * cond * eps * w.norm());
    worst = std::max(worst, e);
    EXPECT_LE(e, 100.0) << "m " << m << " k " << k << " cond " << cond;
  }
}

TEST(QSolve, ComplianceRuleMinimizesTheElasticEnergyAmongAllSolutions) {
  // Redundancy::kCompliance: x solves Q x = b and minimizes x^T C x over x + N z: no perturbation
  // along the null space lowers it, its gradient C x is orthogonal to N, and it equals the closed
  // form x+ - N (N^T C N)^-1 N^T C x+ built from the test's own null space and pseudo-inverse.
  std::mt19937 rng(17);
  std::normal_distribution<double> Nd;
  std::uniform_real_distribution<double> U01(0.0, 1.0);
  SolverOptions opt;
  opt.redundancy = Redundancy::kCompliance;
  double worst = 0.0;
  for (int trial = 0; trial < 150; ++trial) {
    const int m = 2 + trial % 23, k = 1 + trial % std::min(4, m - 1);
    const double cond = std::pow(10.0, trial % 7);
    const double scale = std::pow(10.0, -6.0 + 12.0 * (trial % 5) / 4.0);
    const Case c = random_case(rng, m, k, scale, cond, trial % 2 == 0);
    Eigen::VectorXd C(m);  // per-row compliances over three decades
    for (int i = 0; i < m; ++i) C[i] = 1e-9 * std::pow(1e3, U01(rng));
    QSolver qs(m);
    ASSERT_EQ(qs.factor(c.Q, opt, C).rank, m - k);
    Eigen::VectorXd y(m);
    for (int i = 0; i < m; ++i) y[i] = Nd(rng);
    const Eigen::VectorXd b = c.Q * y;
    Eigen::VectorXd x(m);
    qs.solve(b, x);
    const double eps = std::numeric_limits<double>::epsilon();
    EXPECT_LE((c.Q * x - b).norm(), 1e-13 * (c.Q.norm() * x.norm() + b.norm()));
    const Eigen::VectorXd xp = pinv_solve(c.Q, b, m - k);
    const Eigen::MatrixXd NtCN = c.N.transpose() * C.asDiagonal() * c.N;
    const Eigen::VectorXd xc = xp - c.N * NtCN.ldlt().solve(c.N.transpose() * (C.asDiagonal() * xp));
    // errors: cond eps from Q, and the 1e-12 max C regularization of N^T C N, both amplified by
    // the spread of the compliances
    const double spread = C.maxCoeff() / C.minCoeff();
    const double e = (x - xc).norm() / ((cond * eps + 1e-12) * spread * xc.norm());
    worst = std::max(worst, e);
    EXPECT_LE(e, 100.0) << "m " << m << " k " << k << " cond " << cond;
    const Eigen::VectorXd grad = c.N.transpose() * (C.asDiagonal() * x);
    EXPECT_LE(grad.norm(), 100.0 * (cond * eps + 1e-12) * spread * C.maxCoeff() * x.norm());
    const double e0 = x.dot(C.asDiagonal() * x);
    for (int p = 0; p < 5; ++p) {
      Eigen::VectorXd z(k);
      for (int a = 0; a < k; ++a) z[a] = Nd(rng);
      const Eigen::VectorXd xz = x + 1e-3 * x.norm() / z.norm() * (c.N * z);
      EXPECT_LE((c.Q * xz - b).norm(), 1e-12 * (c.Q.norm() * xz.norm() + b.norm()));  // still a solution
      EXPECT_GT(xz.dot(C.asDiagonal() * xz), e0);
    }
  }
  std::printf("compliance rule: worst |x - x_C| / ((cond eps + 1e-12) max C / min C |x_C|) %.3g\n", worst);
}

TEST(QSolve, RankToleranceIsRelativeToTheLargestDiagonal) {
  // One direction with eigenvalue delta * scale next to eigenvalues in [scale / 10, scale], any
  // scale, rank path forced (fast_tol > 1). What the pivot test guarantees (q_solve.h):
  // - a direction is dropped only if small: with rank r, eigenvalue r+1 <= (m - r) rank_tol max Q(i, i);
  // - pivot r >= eigenvalue r / (m - r + 1), so delta = 1e-7 (> m rank_tol) is always kept;
  // - a direction far below the threshold (delta = 1e-14, as the round-off null space of an exact
  //   dependency) is dropped.
  std::mt19937 rng(19);
  SolverOptions opt;
  opt.fast_tol = 2.0;
  for (int m : {3, 6, 12, 24})
    for (double scale : {1e-6, 1.0, 1e6})
      for (double delta : {1e-14, 1e-7})
        for (int rep = 0; rep < 5; ++rep) {
          Case c = random_case(rng, m, 1, scale, 10.0, rep % 2 == 1);
          c.Q += delta * scale * c.N * c.N.transpose();
          QSolver qs(m);
          const QFactorInfo fi = qs.factor(c.Q, opt, Eigen::VectorXd::Zero(m));
          EXPECT_FALSE(qs.fast_path);
          EXPECT_EQ(fi.rank, delta < opt.rank_tol ? m - 1 : m) << "m " << m << " scale " << scale << " delta " << delta;
          Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(c.Q);  // ascending
          const Eigen::VectorXd& ev = es.eigenvalues();
          if (fi.rank < m) {
            EXPECT_LE(ev[m - 1 - fi.rank], (m - fi.rank) * opt.rank_tol * c.Q.diagonal().maxCoeff());
          }
          // the condition estimate never exceeds m times the condition on the range
          EXPECT_LE(fi.condition, m * ev[m - 1] / ev[m - fi.rank]);
          EXPECT_GE(fi.condition, 1.0);
        }
}

TEST(QSolve, ZeroMatrixLeavesEveryRowIndeterminateAndTheSolutionZero) {
  const int m = 6;
  QSolver qs(m);
  const QFactorInfo fi = qs.factor(Eigen::MatrixXd::Zero(m, m), SolverOptions{}, Eigen::VectorXd::Zero(m));
  EXPECT_EQ(fi.rank, 0);
  EXPECT_TRUE(std::isinf(fi.condition));
  for (int i = 0; i < m; ++i) EXPECT_EQ(qs.row_indeterminate[i], 1);
  Eigen::VectorXd x(m);
  qs.solve(Eigen::VectorXd::Ones(m), x);
  EXPECT_EQ(x, Eigen::VectorXd::Zero(m));
}

// The fast path with the nominal directions last (factor_nominal_last, q_solve.h) on
// Q = G M^-1 G^T built as the mobile-platform form builds it: two 6-row welds, each holding a leaf
// DOF of nominal inertia 1e-3 (G's column of that DOF nonzero in its weld's rows only, along a
// general direction in the first weld and along one axis in the second), the other DOFs of order 1.
// Checked against independent constructions: the solution equals the plain fast path's (the same
// linear system); the condition is the pivot ratio of Eigen's LLT of the reduced Q, formed with
// Eigen from the reflection's definition (I - 2 v v^T / v^T v, v = u / |u| + sign(u_0) e_0) and the
// dropped rows removed; and that reduced Q has the eigenvalues of Q restricted, by a QR, to the
// complement of the nominal columns of G (it eliminates exactly those directions).
TEST(QSolve, NominalDirectionsLastGiveTheReducedConditionAndTheSameSolution) {
  std::mt19937 rng(3);
  std::normal_distribution<double> Nd;
  const int m = 12, n = 14;
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::MatrixXd G(m, n);
    for (int i = 0; i < G.size(); ++i) G.data()[i] = Nd(rng);
    G.col(0).setZero();
    G.col(1).setZero();
    for (int k = 0; k < 6; ++k) G(k, 0) = Nd(rng);  // weld 0: a general direction
    G(6 + trial % 6, 1) = 0.5 + std::abs(Nd(rng));   // weld 1: along one axis
    Eigen::MatrixXd A(n, n);
    for (int i = 0; i < A.size(); ++i) A.data()[i] = Nd(rng);
    Eigen::MatrixXd M = A * A.transpose() + n * Eigen::MatrixXd::Identity(n, n);
    M.row(0).setZero();
    M.col(0).setZero();
    M.row(1).setZero();
    M.col(1).setZero();
    M(0, 0) = M(1, 1) = 1e-3;
    Eigen::MatrixXd Q = G * M.llt().solve(G.transpose());
    Q = 0.5 * (Q + Q.transpose()).eval();
    const SolverOptions opt;
    QSolver qs(m), plain(m);
    qs.plan_nominal({{0, 0}, {1, 6}});
    double condition = 0.0;
    ASSERT_TRUE(qs.factor_nominal_last(Q, G, opt, &condition)) << trial;
    EXPECT_TRUE(qs.fast_path);
    EXPECT_EQ(qs.rank, m);
    EXPECT_EQ(qs.nominal_lead, m - 2);
    plain.factor(Q, opt, Eigen::VectorXd::Zero(m));
    ASSERT_TRUE(plain.fast_path);
    Eigen::VectorXd b(m), x(m), xp(m);
    for (int i = 0; i < m; ++i) b[i] = Nd(rng);
    qs.solve(b, x);
    plain.solve(b, xp);
    const Eigen::VectorXd eq = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Q).eigenvalues();
    const double eps = std::numeric_limits<double>::epsilon(), cond_q = eq.maxCoeff() / eq.minCoeff();
    EXPECT_LE((x - xp).norm(), 100 * eps * cond_q * xp.norm()) << trial;  // both have errors ~ cond eps
    EXPECT_LE((Q * x - b).norm(), 1e-12 * (Q.norm() * x.norm() + b.norm())) << trial;
    // the reduced Q from the reflection's definition
    Eigen::MatrixXd H = Eigen::MatrixXd::Identity(m, m);
    const Eigen::VectorXd u = G.block(0, 0, 6, 1);
    Eigen::VectorXd v = u / u.norm();
    v[0] += v[0] >= 0 ? 1.0 : -1.0;
    H.topLeftCorner(6, 6) -= 2.0 * v * v.transpose() / v.squaredNorm();
    const Eigen::MatrixXd Qh = H * Q * H;
    std::vector<int> kept;
    for (int i = 0; i < m; ++i)
      if (i != 0 && i != 6 + trial % 6) kept.push_back(i);
    Eigen::MatrixXd Qr(m - 2, m - 2);
    for (int i = 0; i < m - 2; ++i)
      for (int j = 0; j < m - 2; ++j) Qr(i, j) = Qh(kept[i], kept[j]);
    const Eigen::VectorXd d = Qr.llt().matrixL().toDenseMatrix().diagonal();
    const double expected = (d.maxCoeff() / d.minCoeff()) * (d.maxCoeff() / d.minCoeff());
    EXPECT_NEAR(condition, expected, 1e-9 * expected) << trial;
    Eigen::MatrixXd U = Eigen::MatrixXd::Zero(m, 2);
    U.col(0) = G.col(0);
    U.col(1) = G.col(1);
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(U);
    const Eigen::MatrixXd Nc = (qr.householderQ() * Eigen::MatrixXd::Identity(m, m)).rightCols(m - 2);
    const Eigen::VectorXd e1 = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Qr).eigenvalues();
    const Eigen::VectorXd e2 = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Nc.transpose() * Q * Nc).eigenvalues();
    EXPECT_LE((e1 - e2).cwiseAbs().maxCoeff(), 1e-10 * e2.maxCoeff()) << trial;
    // and Q itself carries the nominal eigenvalue, 1e2 and more above the reduced Q's
    EXPECT_GT(eq.maxCoeff(), 100 * e2.maxCoeff());
  }
}

}  // namespace
}  // namespace coopdyn
