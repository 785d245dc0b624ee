// The solve of Q lambda = b, Q = G M^-1 G^T symmetric positive semi-definite (METHOD s.5).
//
// factor() takes the Cholesky fast path when every pivot of Q is >= fast_tol * the largest;
// otherwise it reveals the rank, flags the rows of lambda the physics leaves free and prepares the
// scene's redundancy rule (minimum norm or compliance-weighted). solve() may then be called for any
// number of right-hand sides. Sized once from the number of rows; allocation-free afterwards.
#pragma once

#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "service/dynamics/system.h"

namespace coopdyn {

struct QFactorInfo {
  int rank = 0;
  double condition = 1.0;  // estimate of the condition of Q on its range
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
  Eigen::MatrixXd Lq;            // (rows x rows) Cholesky factor on the fast path (lower)
  Eigen::MatrixXd eig_A, eig_V;  // (rows x rows) Jacobi eigen-decomposition (rank path)
  Eigen::VectorXd eig_w;         // (rows) eigenvalues, ascending
  Eigen::VectorXd ev_inv;        // (rows) 1/eigenvalue on the range, 0 on the null space
  Eigen::MatrixXd NtCN;          // (rows x rows) compliance split
  Eigen::LDLT<Eigen::MatrixXd> ntcn_ldlt;
  Eigen::VectorXd tmp_m, tmp_m2, compliance;  // (rows)
};

}  // namespace coopdyn
