// Tree-sparse factorization M = L^T L and its solves (RBDA s.6.5, tables 6.3-6.4).
//
// L is lower triangular with the sparsity of M: L(i,j) != 0 only if DOF j is DOF i or one of its
// ancestors (model.dof_parent). Factoring from the leaves up causes no fill-in, so the cost is
// O(sum of depth^2) instead of O(nv^3): the arms of the mobile platform never couple except through
// the platform DOFs.
#pragma once

#include <Eigen/Core>

#include "service/model/model.h"

namespace coopdyn {

// Factors data.M into data.L. Returns false (and leaves data.L_ok false) if M is not positive
// definite: a pivot <= rel_tol * max diagonal, which names a DOF that moves no mass (*bad_dof).
bool tree_cholesky_factor(const Model& model, Data& data, double rel_tol = 1e-13, int* bad_dof = nullptr);

// x <- L^{-T} x  (solves L^T y = x). Also turns a row g of G into the row of Y = G L^{-1}.
template <typename Vec>
inline void tree_solve_Lt(const Model& model, const Eigen::MatrixXd& L, Vec&& x) {
  const int n = model.nv();
  for (int i = n - 1; i >= 0; --i) {
    const double xi = x[i] / L(i, i);
    x[i] = xi;
    if (xi == 0.0) continue;
    for (int j = model.dof_parent[i]; j >= 0; j = model.dof_parent[j]) x[j] -= L(i, j) * xi;
  }
}

// x <- L^{-1} x  (solves L y = x)
template <typename Vec>
inline void tree_solve_L(const Model& model, const Eigen::MatrixXd& L, Vec&& x) {
  const int n = model.nv();
  for (int i = 0; i < n; ++i) {
    double s = x[i];
    for (int j = model.dof_parent[i]; j >= 0; j = model.dof_parent[j]) s -= L(i, j) * x[j];
    x[i] = s / L(i, i);
  }
}

// x <- M^{-1} x
template <typename Vec>
inline void tree_solve_M(const Model& model, const Eigen::MatrixXd& L, Vec&& x) {
  tree_solve_Lt(model, L, x);
  tree_solve_L(model, L, x);
}

}  // namespace coopdyn
