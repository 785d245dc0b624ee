#include "service/dynamics/q_solve.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "service/dynamics/jacobi.h"

namespace coopdyn {

namespace {

// Unblocked Cholesky Q = L L^T into the lower triangle of L (the small sizes here make Eigen's
// blocked LLT slower). Returns false on a non-positive pivot.
bool small_cholesky(const Eigen::MatrixXd& Q, Eigen::MatrixXd& L, int m) {
  for (int j = 0; j < m; ++j) {
    double d = Q(j, j);
    for (int k = 0; k < j; ++k) d -= L(j, k) * L(j, k);
    if (!(d > 0.0)) return false;
    const double ljj = std::sqrt(d);
    L(j, j) = ljj;
    const double inv = 1.0 / ljj;
    for (int i = j + 1; i < m; ++i) {
      double sum = Q(i, j);
      for (int k = 0; k < j; ++k) sum -= L(i, k) * L(j, k);
      L(i, j) = sum * inv;
    }
  }
  return true;
}

}  // namespace

QSolver::QSolver(int rows) : m(rows), ntcn_ldlt(rows) {
  row_indeterminate.assign(m, 0);
  Lq.setZero(m, m);
  eig_A.setZero(m, m);
  eig_V.setZero(m, m);
  eig_w.setZero(m);
  ev_inv.setZero(m);
  NtCN.setZero(m, m);
  tmp_m.setZero(m);
  tmp_m2.setZero(m);
  compliance.setZero(m);
}

QFactorInfo QSolver::factor(const Eigen::MatrixXd& Q, const SolverOptions& opt, const Eigen::VectorXd& row_compliance) {
  QFactorInfo info;
  fast_path = false;
  use_compliance = false;
  if (small_cholesky(Q, Lq, m)) {
    const auto d = Lq.diagonal();
    const double dmax = d.maxCoeff(), dmin = d.minCoeff();
    const double ratio = dmin * dmin / (dmax * dmax);
    if (ratio >= opt.fast_tol) {
      fast_path = true;
      rank = m;
      info.rank = m;
      info.condition = 1.0 / ratio;
      for (int i = 0; i < m; ++i) row_indeterminate[i] = 0;
      return info;
    }
  }
  eig_A = Q;
  jacobi_eigen(eig_A, eig_w, eig_V);
  const auto& ev = eig_w;  // ascending
  const double emax = std::max(ev[m - 1], 0.0);
  const double tol = opt.rank_tol * emax;
  int r = 0;
  double emin_kept = emax;
  for (int i = 0; i < m; ++i) {
    if (ev[i] > tol && emax > 0.0) {
      ev_inv[i] = 1.0 / ev[i];
      ++r;
      emin_kept = std::min(emin_kept, ev[i]);
    } else {
      ev_inv[i] = 0.0;
    }
  }
  rank = r;
  info.rank = r;
  info.condition = r > 0 ? emax / emin_kept : std::numeric_limits<double>::infinity();
  const int k = m - r;  // null-space eigenvectors are the first k columns
  const auto& V = eig_V;
  for (int i = 0; i < m; ++i) {
    double s = 0.0;
    for (int j = 0; j < k; ++j) s += V(i, j) * V(i, j);
    row_indeterminate[i] = s > 1e-12 ? 1 : 0;
  }
  if (k > 0 && opt.redundancy == Redundancy::kCompliance && row_compliance.size() == m &&
      row_compliance.maxCoeff() > 0.0) {
    // NtCN (k x k) padded with the identity to m x m, so that the LDLT keeps its size
    use_compliance = true;
    compliance = row_compliance;
    const double cmax = compliance.maxCoeff();
    NtCN.setIdentity();
    for (int a = 0; a < k; ++a)
      for (int bb = 0; bb < k; ++bb) {
        double s = 0.0;
        for (int i = 0; i < m; ++i) s += V(i, a) * compliance[i] * V(i, bb);
        NtCN(a, bb) = s + (a == bb ? 1e-12 * cmax : 0.0);
      }
    ntcn_ldlt.compute(NtCN);
  }
  return info;
}

void QSolver::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  if (fast_path) {
    x = b;
    Lq.triangularView<Eigen::Lower>().solveInPlace(x);
    Lq.triangularView<Eigen::Lower>().transpose().solveInPlace(x);
    return;
  }
  const auto& V = eig_V;
  tmp_m.noalias() = V.transpose() * b;
  tmp_m.array() *= ev_inv.array();
  x.noalias() = V * tmp_m;
  const int k = m - rank;
  if (k > 0 && use_compliance) {
    // z = -(N^T C N)^-1 N^T C x ; x += N z
    tmp_m2.setZero();
    for (int a = 0; a < k; ++a) {
      double s = 0.0;
      for (int i = 0; i < m; ++i) s += V(i, a) * compliance[i] * x[i];
      tmp_m2[a] = -s;
    }
    ntcn_ldlt.solveInPlace(tmp_m2);
    for (int a = 0; a < k; ++a) x += tmp_m2[a] * V.col(a);
  }
}

}  // namespace coopdyn
