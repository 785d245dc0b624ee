#include "service/dynamics/q_solve.h"

#include "service/dynamics/q_blocks.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace coopdyn {

namespace {

// Unblocked Cholesky Q = L L^T of the leading n x n block into the lower triangle of L (the small
// sizes here make Eigen's blocked LLT slower), with dinv(j) = 1 / L(j, j). Returns false on a
// non-positive pivot. 1/sqrt(d) is taken as sqrt(d) * (1/d) so that the square root and the division,
// both on the critical path from one column to the next, run side by side.
bool small_cholesky(const Eigen::MatrixXd& Q, Eigen::MatrixXd& L, Eigen::VectorXd& dinv, int n) {
  for (int j = 0; j < n; ++j) {
    double d = Q(j, j);
    for (int k = 0; k < j; ++k) d -= L(j, k) * L(j, k);
    if (!(d > 0.0)) return false;
    const double rd = 1.0 / d;
    const double ljj = std::sqrt(d);
    L(j, j) = ljj;
    const double inv = ljj * rd;
    dinv[j] = inv;
    for (int i = j + 1; i < n; ++i) {
      double sum = Q(i, j);
      for (int k = 0; k < j; ++k) sum -= L(i, k) * L(j, k);
      L(i, j) = sum * inv;
    }
  }
  return true;
}

// x(0:n) <- L^-1 x then L^-T x, L the lower triangle of the leading n x n block, dinv its inverse diagonal.
void cholesky_solve_in_place(const Eigen::MatrixXd& L, const Eigen::VectorXd& dinv, int n, Eigen::VectorXd& x) {
  for (int i = 0; i < n; ++i) {
    double s = x[i];
    for (int k = 0; k < i; ++k) s -= L(i, k) * x[k];
    x[i] = s * dinv[i];
  }
  for (int i = n - 1; i >= 0; --i) {
    double s = x[i];
    for (int k = i + 1; k < n; ++k) s -= L(k, i) * x[k];
    x[i] = s * dinv[i];
  }
}

// The same factor stored as its transpose U = L^T in the upper triangle of U, so that every inner
// loop of the factorization and the solves runs down a contiguous column.
bool small_cholesky_upper(const Eigen::MatrixXd& Q, Eigen::MatrixXd& U, Eigen::VectorXd& dinv, int n) {
  const Eigen::Index ld = U.outerStride();
  double* __restrict u = U.data();
  for (int j = 0; j < n; ++j) {
    const double* __restrict uj = u + j * ld;
    double d = Q(j, j);
    for (int k = 0; k < j; ++k) d -= uj[k] * uj[k];
    if (!(d > 0.0)) return false;
    const double rd = 1.0 / d;
    const double ujj = std::sqrt(d);
    u[j * ld + j] = ujj;
    const double inv = ujj * rd;
    dinv[j] = inv;
    for (int i = j + 1; i < n; ++i) {
      const double* __restrict ui = u + i * ld;
      double sum = Q(j, i);
      for (int k = 0; k < j; ++k) sum -= ui[k] * uj[k];
      u[i * ld + j] = sum * inv;
    }
  }
  return true;
}

// x(0:n) <- U^-T x then U^-1 x (U from small_cholesky_upper).
void cholesky_upper_solve_in_place(const Eigen::MatrixXd& U, const Eigen::VectorXd& dinv, int n, Eigen::VectorXd& x) {
  const Eigen::Index ld = U.outerStride();
  const double* __restrict u = U.data();
  double* __restrict xp = x.data();
  for (int i = 0; i < n; ++i) {
    const double* __restrict ui = u + i * ld;
    double s = xp[i];
    for (int k = 0; k < i; ++k) s -= ui[k] * xp[k];
    xp[i] = s * dinv[i];
  }
  for (int i = n - 1; i >= 0; --i) {
    const double* __restrict ui = u + i * ld;
    const double xi = xp[i] * dinv[i];
    xp[i] = xi;
    for (int k = 0; k < i; ++k) xp[k] -= ui[k] * xi;
  }
}

// x <- x - N N^T x over the first k columns of N (orthonormal).
void remove_null_component(const Eigen::MatrixXd& N, int m, int k, Eigen::VectorXd& x) {
  for (int a = 0; a < k; ++a) {
    double s = 0.0;
    for (int i = 0; i < m; ++i) s += N(i, a) * x[i];
    for (int i = 0; i < m; ++i) x[i] -= s * N(i, a);
  }
}

}  // namespace

QSolver::QSolver(int rows) : m(rows) {
  row_indeterminate.assign(m, 0);
  perm.assign(m, 0);
  Lq.setZero(m, m);
  Lp.setZero(m, m);
  dpiv.setZero(m);
  Nq.setZero(m, m);
  Lc.setZero(m, m);
  dinv_q.setZero(m);
  dinv_p.setZero(m);
  dinv_c.setZero(m);
  tmp_m.setZero(m);
  tmp_m2.setZero(m);
  compliance.setZero(m);
}

namespace {

// The fast path: an unpivoted Cholesky factor into Lq, taken when it exists and its smallest pivot
// is >= fast_tol * the largest (squared diagonal ratio of U = L^T).
bool factor_fast_path(QSolver& qs, const Eigen::MatrixXd& Q, const SolverOptions& opt, QFactorInfo& info) {
  const int m = qs.m;
  if (!small_cholesky_upper(Q, qs.Lq, qs.dinv_q, m)) return false;
  double dmax = qs.Lq(0, 0), dmin = qs.Lq(0, 0);  // the diagonal of U = L^T
  for (int i = 1; i < m; ++i) {
    dmax = std::max(dmax, qs.Lq(i, i));
    dmin = std::min(dmin, qs.Lq(i, i));
  }
  const double ratio = dmin * dmin / (dmax * dmax);
  if (ratio < opt.fast_tol) return false;
  qs.fast_path = true;
  qs.rank = m;
  info.rank = m;
  info.condition = 1.0 / ratio;
  for (int i = 0; i < m; ++i) qs.row_indeterminate[i] = 0;
  return true;
}

// Pivoted Cholesky of Q into Lp, perm (lower triangle and diagonal of a copy are read, both are
// swapped), stopping at the first pivot <= rank_tol * max Q(i, i); sets rank, dinv_p and info.
void factor_pivoted(QSolver& qs, const Eigen::MatrixXd& Q, const SolverOptions& opt, QFactorInfo& info) {
  const int m = qs.m;
  Eigen::MatrixXd& Lp = qs.Lp;
  Eigen::VectorXd& dpiv = qs.dpiv;
  Lp = Q;
  double qmax = 0.0;
  for (int i = 0; i < m; ++i) {
    qs.perm[i] = i;
    dpiv[i] = Q(i, i);
    if (Q(i, i) > qmax) qmax = Q(i, i);  // a NaN diagonal is skipped here and stops the loop below
  }
  const double tol = opt.rank_tol * qmax;
  int r = 0;
  for (int j = 0; j < m; ++j) {
    int p = j;
    for (int i = j + 1; i < m; ++i)
      if (dpiv[i] > dpiv[p]) p = i;
    const double d = dpiv[p];
    if (!(d > tol) || !(qmax > 0.0) || !std::isfinite(d)) break;
    if (p != j) {  // symmetric swap of rows/columns j and p (the computed columns of L follow the rows)
      Lp.row(j).swap(Lp.row(p));
      Lp.col(j).swap(Lp.col(p));
      std::swap(qs.perm[j], qs.perm[p]);
      std::swap(dpiv[j], dpiv[p]);
    }
    const double ljj = std::sqrt(d);
    Lp(j, j) = ljj;
    const double inv = 1.0 / ljj;
    for (int i = j + 1; i < m; ++i) {
      double s = Lp(i, j);
      for (int k = 0; k < j; ++k) s -= Lp(i, k) * Lp(j, k);
      const double lij = s * inv;
      Lp(i, j) = lij;
      dpiv[i] -= lij * lij;
    }
    r = j + 1;
  }
  for (int i = 0; i < r; ++i) qs.dinv_p[i] = 1.0 / Lp(i, i);
  qs.rank = r;
  info.rank = r;
  info.condition = r > 0 ? (Lp(0, 0) / Lp(r - 1, r - 1)) * (Lp(0, 0) / Lp(r - 1, r - 1))
                         : std::numeric_limits<double>::infinity();
}

// The k = m - rank null-space columns of Nq: column a is P^T [-L11^-T L21(a, :)^T; e_a],
// orthonormalized by modified Gram-Schmidt, twice ("twice is enough": orthonormal to round-off).
void null_space_basis(QSolver& qs) {
  const int m = qs.m, r = qs.rank, k = m - r;
  const Eigen::MatrixXd& Lp = qs.Lp;
  Eigen::MatrixXd& Nq = qs.Nq;
  Eigen::VectorXd& t = qs.tmp_m;
  for (int a = 0; a < k; ++a) {
    for (int i = 0; i < r; ++i) t[i] = -Lp(r + a, i);
    for (int i = r - 1; i >= 0; --i) {  // L11^T t = -L21(a, :)^T
      double s = t[i];
      for (int l = i + 1; l < r; ++l) s -= Lp(l, i) * t[l];
      t[i] = s / Lp(i, i);
    }
    for (int i = 0; i < r; ++i) Nq(qs.perm[i], a) = t[i];
    for (int i = r; i < m; ++i) Nq(qs.perm[i], a) = i == r + a ? 1.0 : 0.0;
  }
  for (int pass = 0; pass < 2; ++pass)
    for (int a = 0; a < k; ++a) {
      for (int c = 0; c < a; ++c) {
        double s = 0.0;
        for (int i = 0; i < m; ++i) s += Nq(i, c) * Nq(i, a);
        for (int i = 0; i < m; ++i) Nq(i, a) -= s * Nq(i, c);
      }
      double nn = 0.0;
      for (int i = 0; i < m; ++i) nn += Nq(i, a) * Nq(i, a);
      const double inv = nn > 0.0 && std::isfinite(nn) ? 1.0 / std::sqrt(nn) : 0.0;
      for (int i = 0; i < m; ++i) Nq(i, a) *= inv;
    }
}

// row_indeterminate: the rows the null space moves (|N(i, :)|^2 > 1e-12)
void flag_indeterminate_rows(QSolver& qs) {
  const int k = qs.m - qs.rank;
  for (int i = 0; i < qs.m; ++i) {
    double s = 0.0;
    for (int a = 0; a < k; ++a) s += qs.Nq(i, a) * qs.Nq(i, a);
    qs.row_indeterminate[i] = s > 1e-12 ? 1 : 0;
  }
}

// Redundancy::kCompliance: the Cholesky factor of N^T C N (k x k) into Lc, regularized so that a
// null direction without compliance stays solvable; sets use_compliance.
void factor_compliance_metric(QSolver& qs, const Eigen::VectorXd& row_compliance) {
  const int m = qs.m, k = m - qs.rank;
  const Eigen::MatrixXd& Nq = qs.Nq;
  Eigen::MatrixXd& Lc = qs.Lc;
  qs.compliance = row_compliance;
  const double cmax = qs.compliance.maxCoeff();
  for (int a = 0; a < k; ++a)
    for (int c = 0; c <= a; ++c) {
      double s = 0.0;
      for (int i = 0; i < m; ++i) s += Nq(i, a) * qs.compliance[i] * Nq(i, c);
      Lc(a, c) = s + (a == c ? 1e-12 * cmax : 0.0);
      Lc(c, a) = Lc(a, c);
    }
  qs.use_compliance = small_cholesky(Lc, Lc, qs.dinv_c, k);  // in place: reads (i, j) before writing it
}

}  // namespace

QFactorInfo QSolver::factor(const Eigen::MatrixXd& Q, const SolverOptions& opt, const Eigen::VectorXd& row_compliance) {
  QFactorInfo info;
  fast_path = false;
  nominal_active = false;
  use_compliance = false;
  if (m == 0) {
    fast_path = true;
    rank = 0;
    info.rank = 0;
    return info;
  }
  if (factor_fast_path(*this, Q, opt, info)) return info;
  factor_pivoted(*this, Q, opt, info);
  null_space_basis(*this);
  flag_indeterminate_rows(*this);
  const int k = m - rank;
  if (k > 0 && opt.redundancy == Redundancy::kCompliance && row_compliance.size() == m &&
      row_compliance.maxCoeff() > 0.0)
    factor_compliance_metric(*this, row_compliance);
  return info;
}

void QSolver::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  if (fast_path && nominal_active) {  // x = R^T (R Q R^T)^-1 R b
    tmp_m2 = b;
    reflect_rows(tmp_m2.data(), 1, 1);
    for (int i = 0; i < m; ++i) tmp_m[i] = tmp_m2[nominal_perm[i]];
    cholesky_upper_solve_in_place(Lq, dinv_q, m, tmp_m);
    for (int i = 0; i < m; ++i) tmp_m2[nominal_perm[i]] = tmp_m[i];
    reflect_rows(tmp_m2.data(), 1, 1);
    x = tmp_m2;
    return;
  }
  if (fast_path) {
    x = b;
    cholesky_upper_solve_in_place(Lq, dinv_q, m, x);
    return;
  }
  x.resize(m);  // no-op (no allocation) at the right size
  const int r = rank, k = m - rank;
  // b_r = b - N N^T b: the part of b in the range of Q (least squares when b is inconsistent)
  tmp_m2 = b;
  remove_null_component(Nq, m, k, tmp_m2);
  // basic solution x_b = P^T [L11^-T L11^-1 (P b_r)_1; 0]
  for (int i = 0; i < r; ++i) tmp_m[i] = tmp_m2[perm[i]];
  cholesky_solve_in_place(Lp, dinv_p, r, tmp_m);
  for (int i = 0; i < r; ++i) x[perm[i]] = tmp_m[i];
  for (int i = r; i < m; ++i) x[perm[i]] = 0.0;
  // minimum norm
  remove_null_component(Nq, m, k, x);
  if (k > 0 && use_compliance) {
    // z = -(N^T C N)^-1 N^T C x ; x += N z
    for (int a = 0; a < k; ++a) {
      double s = 0.0;
      for (int i = 0; i < m; ++i) s += Nq(i, a) * compliance[i] * x[i];
      tmp_m[a] = -s;
    }
    cholesky_solve_in_place(Lc, dinv_c, k, tmp_m);
    for (int a = 0; a < k; ++a)
      for (int i = 0; i < m; ++i) x[i] += tmp_m[a] * Nq(i, a);
  }
}

void QSolver::plan_nominal(const std::vector<std::pair<int, int>>& rows) {
  nominal_rows = rows;
  nominal_w.assign(rows.size(), Eigen::Matrix<double, 6, 1>::Zero());
  nominal_u.assign(rows.size(), Eigen::Matrix<double, 6, 1>::Zero());
  nominal_u_ref.clear();
  nominal_at_ref = false;
  nominal_perm.assign(m, 0);
  nominal_iperm.assign(m, 0);
  nominal_kept.assign(m, 1);
  nominal_lead = m;
  nominal_active = false;
}

// As the dense condition_without_nominal always did (constrained_dynamics.cc): u along one axis of
// the weld frame (joint 1 on a base axis) drops that row; otherwise H = I - w w^T with
// H u = -sign(u_0) |u| e_0 and row r0 is dropped; u = 0 (or not finite) drops nothing.
// u: the nominal_rows.size() directions.
void QSolver::reflections(const Eigen::Matrix<double, 6, 1>* u) {
  for (int i = 0; i < m; ++i) nominal_kept[i] = 1;
  for (size_t a = 0; a < nominal_rows.size(); ++a) {
    const int r0 = nominal_rows[a].second;
    Eigen::Matrix<double, 6, 1>& w = nominal_w[a];
    w = u[a];
    const double un = w.norm();
    int single = -1;
    for (int k = 0; k < 6; ++k)
      if (w[k] != 0.0) single = single == -1 ? k : -2;
    if (!(un > 0.0) || !std::isfinite(un) || single >= 0) {
      if (un > 0.0 && std::isfinite(un)) nominal_kept[r0 + single] = 0;
      w.setZero();
      continue;
    }
    w /= un;
    w[0] += w[0] >= 0 ? 1.0 : -1.0;
    w *= std::sqrt(2.0 / w.squaredNorm());
    nominal_kept[r0] = 0;
  }
  int k = 0;
  for (int i = 0; i < m; ++i)
    if (nominal_kept[i]) nominal_perm[k++] = i;
  nominal_lead = k;
  for (int i = 0; i < m; ++i)
    if (!nominal_kept[i]) nominal_perm[k++] = i;
  for (int i = 0; i < m; ++i) nominal_iperm[nominal_perm[i]] = i;
}

void QSolver::set_nominal_reference(const Eigen::MatrixXd& G) {
  nominal_u_ref.resize(nominal_rows.size());
  for (size_t a = 0; a < nominal_rows.size(); ++a)
    nominal_u_ref[a] = G.block<6, 1>(nominal_rows[a].second, nominal_rows[a].first);
  reflections(nominal_u_ref.data());
  nominal_at_ref = true;
}

int QSolver::prepare_nominal(const Eigen::MatrixXd& G) {
  const size_t nn = nominal_rows.size();
  bool ref = nominal_u_ref.size() == nn;
  for (size_t a = 0; a < nn; ++a) {
    Eigen::Matrix<double, 6, 1>& u = nominal_u[a];
    u = G.block<6, 1>(nominal_rows[a].second, nominal_rows[a].first);
    ref = ref && QBlocks::near_reference(u, nominal_u_ref[a]);
  }
  if (!(ref && nominal_at_ref)) reflections(ref ? nominal_u_ref.data() : nominal_u.data());
  nominal_at_ref = ref;
  return nominal_lead;
}

void QSolver::reflect_symmetric(double* a) const {
  for (size_t n = 0; n < nominal_rows.size(); ++n) {
    const Eigen::Matrix<double, 6, 1>& w = nominal_w[n];
    if (w.isZero(0.0)) continue;
    const int r0 = nominal_rows[n].second;
    for (int j = 0; j < m; ++j) {  // A <- H A (rows r0..r0+5)
      double* c = a + static_cast<size_t>(j) * m + r0;
      double t = 0.0;
      for (int k = 0; k < 6; ++k) t += w[k] * c[k];
      for (int k = 0; k < 6; ++k) c[k] -= t * w[k];
    }
    for (int i = 0; i < m; ++i) {  // A <- A H (columns r0..r0+5)
      double t = 0.0;
      for (int k = 0; k < 6; ++k) t += a[static_cast<size_t>(r0 + k) * m + i] * w[k];
      for (int k = 0; k < 6; ++k) a[static_cast<size_t>(r0 + k) * m + i] -= t * w[k];
    }
  }
}

void QSolver::reflect_rows(double* x, Eigen::Index ld, int nc) const {
  for (size_t n = 0; n < nominal_rows.size(); ++n) {
    const Eigen::Matrix<double, 6, 1>& w = nominal_w[n];
    if (w.isZero(0.0)) continue;
    double* r = x + nominal_rows[n].second * ld;
    for (int c = 0; c < nc; ++c) {
      double t = 0.0;
      for (int k = 0; k < 6; ++k) t += w[k] * r[k * ld + c];
      for (int k = 0; k < 6; ++k) r[k * ld + c] -= t * w[k];
    }
  }
}

bool QSolver::factor_nominal_last(const Eigen::MatrixXd& Q, const Eigen::MatrixXd& G, const SolverOptions& opt,
                                  double* condition) {
  fast_path = false;
  nominal_active = false;
  use_compliance = false;
  if (m == 0) return false;
  prepare_nominal(G);
  Lp = Q;  // H Q H in Lp, then R Q R^T's upper triangle in Nq (both the rank path's, free here)
  reflect_symmetric(Lp.data());
  for (int j = 0; j < m; ++j)
    for (int i = 0; i <= j; ++i) Nq(i, j) = Lp(nominal_perm[i], nominal_perm[j]);
  return factor_nominal_formed(opt, condition);
}

bool QSolver::factor_nominal_formed(const SolverOptions& opt, double* condition) {
  fast_path = false;
  nominal_active = false;
  use_compliance = false;
  if (m == 0) return false;
  const int lead = nominal_lead;
  if (!small_cholesky_upper(Nq, Lq, dinv_q, m)) return false;
  double dmax = Lq(0, 0), dmin = Lq(0, 0), lmax = 0.0, lmin = HUGE_VAL;
  for (int i = 0; i < m; ++i) {
    dmax = std::max(dmax, Lq(i, i));
    dmin = std::min(dmin, Lq(i, i));
    if (i < lead) {
      lmax = std::max(lmax, Lq(i, i));
      lmin = std::min(lmin, Lq(i, i));
    }
  }
  if (dmin * dmin / (dmax * dmax) < opt.fast_tol) return false;
  fast_path = true;
  nominal_active = true;
  rank = m;
  for (int i = 0; i < m; ++i) row_indeterminate[i] = 0;
  *condition = lead > 0 ? 1.0 / (lmin * lmin / (lmax * lmax)) : 1.0;
  return true;
}

}  // namespace coopdyn
