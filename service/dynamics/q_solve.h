// The solve of Q lambda = b, Q = G M^-1 G^T symmetric positive semi-definite (over-constrained
// systems, beyond the paper: README).
//
// factor() takes the Cholesky fast path when every pivot of Q is >= fast_tol * the largest;
// otherwise it reveals the rank, flags the rows of lambda the physics leaves free and prepares the
// scene's redundancy rule (minimum norm or compliance-weighted). solve() may then be called for any
// number of right-hand sides. Sized once from the number of rows; allocation-free afterwards.
//
// Rank path: Cholesky with symmetric (diagonal) pivoting (Higham, "Accuracy and Stability of
// Numerical Algorithms", 2nd ed., s.10.3; LAPACK dpstrf), unblocked:
//   P Q P^T = [L11; L21] [L11^T L21^T] + S,   L11 (r x r) lower, L21 ((m-r) x r),
// where step j takes the largest remaining diagonal of the Schur complement as its pivot and the
// factorization stops at the first step whose largest remaining pivot is
//   <= rank_tol * max_i Q(i, i)                                          (rank_tol = 1e-10 default)
// so that rank = r and the neglected Schur complement S has every diagonal entry <= that
// tolerance. What this guarantees (Weyl's inequality on P Q P^T = L L^T + S):
//   - a dropped direction is small: eigenvalue r+1 of Q <= trace(S) <= (m - r) rank_tol max Q(i, i);
//   - a direction is kept when its eigenvalue > (m - r + 1) rank_tol max Q(i, i) (the r-th pivot is
//     >= eigenvalue r / (m - r + 1)).
// In between the pivot test and the former eigenvalue test (eigenvalue <= rank_tol * lambda_max,
// a singular value of G M^-1/2 below sqrt(rank_tol) = 1e-5 relative) may disagree: the last pivot
// is about lambda / v_p^2 (v_p the component of that eigenvector on the last pivot row), so an
// eigenvalue a few decades below the threshold can be kept. Exact dependencies (the rigid axle,
// the planar arms) leave round-off eigenvalues ~1e-16 relative, far below it. max_i Q(i, i) lies
// in [lambda_max / m, lambda_max].
//   Null space of Q: N = P^T [-L11^-T L21^T; I] (m x k, k = m - r), orthonormalized by modified
//   Gram-Schmidt applied twice.
//   Minimum-norm solution (= Q^+ b, also for a b with a component outside the range of Q, which
//   is removed first): b_r = b - N N^T b, x_b = P^T [L11^-T L11^-1 (P b_r)_1; 0], x = x_b - N N^T x_b.
//   Indeterminate rows: the rows i with |N(i, :)|^2 > 1e-12 (components that the null space moves).
//   Redundancy::kCompliance: x += N z, z minimizing (x + N z)^T C (x + N z), C = diag(compliance),
//   i.e. (N^T C N) z = -N^T C x (regularized by 1e-12 max C on its diagonal).
//   Condition: (L11(0,0) / L11(r-1,r-1))^2, the ratio of the largest to the smallest kept pivot of
//   Q. It is an ESTIMATE of lambda_max / lambda_r of Q on its range: it never exceeds m times the
//   true value, but it can underestimate it (by the 1 / v_p^2 above, a factor ~m for a random
//   orientation, more when the small direction barely touches the last pivot row). The fast path
//   reports the same ratio for its unpivoted factor.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "service/dynamics/system.h"

namespace coopdyn {

struct QFactorInfo {
  int rank = 0;
  double condition = 1.0;  // estimate of the condition of Q on its range (see above)
};

struct QSolver {
  explicit QSolver(int rows);

  // Factors Q (rows x rows, both triangles). row_compliance: per-row compliances of the scene
  // (used by Redundancy::kCompliance). Fills row_indeterminate.
  QFactorInfo factor(const Eigen::MatrixXd& Q, const SolverOptions& opt, const Eigen::VectorXd& row_compliance);
  // x = the solution of Q x = b selected by the rule of the last factor(); x may not alias b.
  void solve(const Eigen::VectorXd& b, Eigen::VectorXd& x);

  int m = 0;
  bool fast_path = true;
  int rank = 0;
  std::vector<unsigned char> row_indeterminate;  // (rows) 1 if that component is not determined
  bool use_compliance = false;

  // buffers
  Eigen::MatrixXd Lq;     // (rows x rows) Cholesky factor on the fast path, stored as U = L^T (upper)
  Eigen::MatrixXd Lp;     // (rows x rows) pivoted factor: L11, L21 in the first rank columns
  std::vector<int> perm;  // (rows) (P Q P^T)(i, j) = Q(perm[i], perm[j])
  Eigen::VectorXd dpiv;   // (rows) remaining diagonal of the Schur complement
  Eigen::MatrixXd Nq;     // (rows x rows) orthonormal null-space basis in the first rows - rank columns
  Eigen::MatrixXd Lc;     // (rows x rows) Cholesky factor of N^T C N (top-left k x k)
  Eigen::VectorXd dinv_q, dinv_p, dinv_c;  // (rows) inverse diagonals of Lq, Lp, Lc
  Eigen::VectorXd tmp_m, tmp_m2, compliance;  // (rows)
};

}  // namespace coopdyn
