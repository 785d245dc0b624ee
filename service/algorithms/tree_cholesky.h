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
  return data.Lc.data() + model.dof_row_offset[k];
}

// x <- L^{-T} x  (solves L^T y = x). Also turns a row g of G into the row of Y = G L^{-1}.
// Leaves to root in Model::dof_elim_steps: a paired parent j with its child k in one pass over
// their ancestors, each entry's two updates in the order of the two steps.
template <typename Vec>
inline void tree_solve_Lt(const Model& model, const Data& data, Vec&& x) {
  const int* path = model.dof_path.data();
  for (const auto& [k, j] : model.dof_elim_steps) {  // leaves to root, branches interleaved
    const double* rk = tree_factor_row(model, data, k);
    const int d = model.dof_depth[k];
    const int* pk = path + model.dof_path_offset[k];
    const double xk = x[k] * data.Ld_inv[k];
    x[k] = xk;
    if (j < 0) {
      if (xk == 0.0) continue;
      for (int p = 0; p < d; ++p) x[pk[p]] -= rk[p] * xk;
      continue;
    }
    const double* rj = tree_factor_row(model, data, j);  // j's path: the first d - 1 entries of k's
    const double xj = (xk == 0.0 ? x[j] : x[j] - rk[d - 1] * xk) * data.Ld_inv[j];
    x[j] = xj;
    if (xk == 0.0 && xj == 0.0) continue;
    for (int p = 0; p < d - 1; ++p) x[pk[p]] = x[pk[p]] - rk[p] * xk - rj[p] * xj;
  }
}

// x <- L^{-1} x  (solves L y = x): root to leaves, a paired parent j before its child k, their two
// dot products over the common ancestors in one pass.
template <typename Vec>
inline void tree_solve_L(const Model& model, const Data& data, Vec&& x) {
  const int* path = model.dof_path.data();
  for (auto it = model.dof_elim_steps.rbegin(); it != model.dof_elim_steps.rend(); ++it) {
    const int k = it->first, j = it->second;
    const double* rk = tree_factor_row(model, data, k);
    const int d = model.dof_depth[k];
    const int* pk = path + model.dof_path_offset[k];
    double s = x[k];
    if (j < 0) {
      for (int p = 0; p < d; ++p) s -= rk[p] * x[pk[p]];
      x[k] = s * data.Ld_inv[k];
      continue;
    }
    const double* rj = tree_factor_row(model, data, j);
    double sj = x[j];
    for (int p = 0; p < d - 1; ++p) {
      const double a = x[pk[p]];
      sj -= rj[p] * a;
      s -= rk[p] * a;
    }
    const double xj = sj * data.Ld_inv[j];
    x[j] = xj;
    s -= rk[d - 1] * xj;
    x[k] = s * data.Ld_inv[k];
  }
}

// x <- M^{-1} x
template <typename Vec>
inline void tree_solve_M(const Model& model, const Data& data, Vec&& x) {
  tree_solve_Lt(model, data, x);
  tree_solve_L(model, data, x);
}

}  // namespace coopdyn
