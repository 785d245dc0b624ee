// The solve of Q lambda = b, Q = G M^-1 G^T symmetric positive semi-definite (over-constrained
// systems, beyond the paper: README).
//
// factor() takes the Cholesky fast path when every pivot of Q is >= fast_tol * the largest;
// otherwise it reveals the rank (Cholesky with diagonal pivoting, stopping at a pivot <= rank_tol
// max_i Q(i, i)), flags the rows of lambda the physics leaves free (|N(i, :)|^2 > 1e-12, N the null
// space) and prepares the scene's redundancy rule (minimum norm, = Q^+ b, or compliance-weighted).
// solve() may then be called for any number of right-hand sides. The condition reported is the
// ratio of the largest to the smallest kept pivot: an estimate of Q's on its range, never above m
// times the true value. factor_nominal_last() factors Q with its nominal directions (an arm's joint
// 1 without armature) eliminated last, so its leading pivots give the condition without them.
// Sized once from the number of rows; allocation-free afterwards.
// The rank test, what it guarantees and the nominal-direction factor: docs/method.md, "Solving Q".
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
