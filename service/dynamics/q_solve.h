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
//
// Nominal directions (System::nominal_bases: an arm's joint 1 without armature). In the weld's six
// rows the direction u = G's column of joint 1 carries Q's ~1 / (nominal inertia) eigenvalue; the
// condition reported is that of Q with it eliminated (constrained_dynamics.h). factor_nominal_last()
// factors Q once in the basis where that direction is one row and in the order where those rows
// come last: per nominal direction a Householder reflection H of the weld's rows (H u = |u| e_0 up
// to sign; the one row u lies along when it is a base axis, without H), R = Pi H (Pi the order: the
// kept rows as they were, then the dropped ones), and the unpivoted Cholesky of R Q R^T. Its
// leading (rows - N) pivots are those of the reduced Q (Q without the nominal directions), whose
// ratio is the condition; the whole factor solves Q x = b as x = R^T (R Q R^T)^-1 R b (R orthogonal).
// Against factoring Q and then the reduced Q apart (as before), the condition is the same up to
// round-off (the same matrix, factored in the same order) and the solution equal to round-off. The
// fast-path test reads R Q R^T's pivots instead of Q's: the unpivoted Cholesky of one matrix in two
// orthogonally related bases, each pivot ratio an estimate of its condition (within a factor of
// about the rows, above), so they can disagree only where that condition is within such a factor
// of 1 / fast_tol; where R Q R^T fails, factor() on Q decides exactly as before.
#pragma once

#include <utility>
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

  // The nominal directions: (velocity index of joint 1, first row of its 6-row weld) each. Start-up.
  void plan_nominal(const std::vector<std::pair<int, int>>& nominal_rows);
  // The reflections and the order of the nominal directions for the constraint rows G (rows x nv);
  // returns the number of rows kept (rows less the directions dropped). Used by factor_nominal_last
  // and by the caller's condition of the reduced Q where the fast path fails.
  int prepare_nominal(const Eigen::MatrixXd& G);
  // Start-up: the reference directions from the constraint rows of one configuration; prepare_nominal()
  // keeps their reflections where G's directions equal them to round-off (QBlocks::set_nominal_reference).
  void set_nominal_reference(const Eigen::MatrixXd& G);
  // A <- H A H (A rows x rows, column-major, leading dimension rows), H the reflections of prepare_nominal.
  void reflect_symmetric(double* a) const;
  // X <- H X on nc columns of a row-major (rows x nc) X with leading dimension ld (one column: ld 1).
  void reflect_rows(double* x, Eigen::Index ld, int nc) const;
  // The fast path on R Q R^T (see above): true when its unpivoted Cholesky exists with every pivot
  // >= fast_tol * the largest (as factor()'s fast path), with *condition = the leading pivots'
  // ratio (the reduced Q's); solve() then works through it (nominal_active). False: nothing
  // usable is left, factor() decides. Q: both triangles.
  bool factor_nominal_last(const Eigen::MatrixXd& Q, const Eigen::MatrixXd& G, const SolverOptions& opt, double* condition);
  // The same on R Q R^T already in Nq's upper triangle (the caller formed it after prepare_nominal,
  // row i of R Q R^T being row nominal_perm[i] of H Q H; nominal_iperm the inverse order).
  bool factor_nominal_formed(const SolverOptions& opt, double* condition);
  // The reflections and orders for the directions u (nominal_rows.size()).
  void reflections(const Eigen::Matrix<double, 6, 1>* u);

  int m = 0;
  bool fast_path = true;
  int rank = 0;
  std::vector<unsigned char> row_indeterminate;  // (rows) 1 if that component is not determined
  bool use_compliance = false;

  // the nominal directions (plan_nominal, prepare_nominal)
  std::vector<std::pair<int, int>> nominal_rows;  // (velocity index of joint 1, first weld row)
  std::vector<Eigen::Matrix<double, 6, 1>> nominal_w;  // H = I - w w^T on rows r0..r0+5 (w = 0: none)
  std::vector<Eigen::Matrix<double, 6, 1>> nominal_u;      // the directions of the last prepare_nominal
  std::vector<Eigen::Matrix<double, 6, 1>> nominal_u_ref;  // the reference directions (set_nominal_reference), else empty
  bool nominal_at_ref = false;  // nominal_w, nominal_kept, the orders and nominal_lead are the reference's
  std::vector<int> nominal_perm;  // (rows) row i of R Q R^T is row nominal_perm[i] of H Q H
  std::vector<int> nominal_iperm;  // (rows) row i of H Q H is row nominal_iperm[i] of R Q R^T
  std::vector<unsigned char> nominal_kept;  // (rows) 1 for a row of the reduced Q
  int nominal_lead = 0;           // rows of the reduced Q
  bool nominal_active = false;    // the fast-path factor Lq is of R Q R^T (factor_nominal_last)

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
