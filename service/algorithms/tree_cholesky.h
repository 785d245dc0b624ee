// Tree-sparse factorization M = L^T L and its solves (RBDA s.6.5, tables 6.3-6.4).
//
// L is lower triangular with the sparsity of M: L(i,j) != 0 only if DOF j is DOF i or one of its
// ancestors (model.dof_parent). Factoring from the leaves up causes no fill-in, so the cost is
// O(sum of depth^2) instead of O(nv^3): the arms of the mobile platform never couple except through
// the platform DOFs. Each row of L is stored over its DOF's ancestor path (Data::Lc); the path of
// an ancestor is a prefix of the path of its descendant, so every update of the factorization is
// one contiguous loop.
#pragma once

#include <Eigen/Core>

#include "service/model/model.h"

namespace coopdyn {

// Factors M, as crba left it in data.Mc, into data.Lc. Returns false (and leaves data.L_ok false) if M is not positive
// definite: a pivot <= rel_tol * max diagonal, which names a DOF that moves no mass (*bad_dof).
bool tree_cholesky_factor(const Model& model, Data& data, double rel_tol = 1e-13, int* bad_dof = nullptr);

// The factor as a dense lower-triangular matrix (allocates: for tests and tools).
Eigen::MatrixXd tree_factor_dense(const Model& model, const Data& data);

// Row k of L: its entries over the ancestor path, then the diagonal at [dof_depth[k]].
inline const double* tree_factor_row(const Model& model, const Data& data, int k) {
  return data.Lc.data() + model.dof_path_offset[k] + k;
}

// x <- L^{-T} x  (solves L^T y = x). Also turns a row g of G into the row of Y = G L^{-1}.
template <typename Vec>
inline void tree_solve_Lt(const Model& model, const Data& data, Vec&& x) {
  const int n = model.nv();
  const int* path = model.dof_path.data();
  for (int e = 0; e < n; ++e) {  // leaves to root, branches interleaved
    const int i = model.dof_elim_order[e];
    const double* r = tree_factor_row(model, data, i);
    const int d = model.dof_depth[i];
    const double xi = x[i] * data.Ld_inv[i];
    x[i] = xi;
    if (xi == 0.0) continue;
    const int* pi = path + model.dof_path_offset[i];
    for (int p = 0; p < d; ++p) x[pi[p]] -= r[p] * xi;
  }
}

// x <- L^{-1} x  (solves L y = x)
template <typename Vec>
inline void tree_solve_L(const Model& model, const Data& data, Vec&& x) {
  const int n = model.nv();
  const int* path = model.dof_path.data();
  for (int e = n - 1; e >= 0; --e) {  // root to leaves, branches interleaved
    const int i = model.dof_elim_order[e];
    const double* r = tree_factor_row(model, data, i);
    const int d = model.dof_depth[i];
    const int* pi = path + model.dof_path_offset[i];
    double s = x[i];
    for (int p = 0; p < d; ++p) s -= r[p] * x[pi[p]];
    x[i] = s * data.Ld_inv[i];
  }
}

// x <- M^{-1} x
template <typename Vec>
inline void tree_solve_M(const Model& model, const Data& data, Vec&& x) {
  tree_solve_Lt(model, data, x);
  tree_solve_L(model, data, x);
}

}  // namespace coopdyn
