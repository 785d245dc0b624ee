#include "service/algorithms/tree_cholesky.h"

#include <algorithm>
#include <cmath>

namespace coopdyn {

bool tree_cholesky_factor(const Model& model, Data& data, double rel_tol, int* bad_dof) {
  const int n = model.nv();
  data.Lc = data.Mc;  // same size: no allocation
  double* lc = data.Lc.data();
  const int* path = model.dof_path.data();
  double scale = 0.0;
  for (int k = 0; k < n; ++k) scale = std::max(scale, std::abs(lc[model.dof_path_offset[k] + k + model.dof_depth[k]]));
  data.L_ok = false;
  for (int e = 0; e < n; ++e) {
    const int k = model.dof_elim_order[e];
    double* __restrict rk = lc + model.dof_path_offset[k] + k;
    const int* pk = path + model.dof_path_offset[k];
    const int d = model.dof_depth[k];
    const double hkk = rk[d];
    if (!(hkk > rel_tol * scale) || !std::isfinite(hkk)) {
      if (bad_dof) *bad_dof = k;
      return false;
    }
    // H(i, j) -= L(k, i) L(k, j) = H(k, i) H(k, j) / H(k, k) for the ancestors j <= i of k; with
    // i = path[p], those are the first p + 1 entries of k's path, and row i is stored over exactly
    // that prefix. The update uses row k before it is scaled, so that the critical path from one
    // pivot to the next is one division; the square root and the scaling of row k run beside it.
    const double rh = 1.0 / hkk;
    for (int p = 0; p < d; ++p) {
      const int i = pk[p];
      double* __restrict ri = lc + model.dof_path_offset[i] + i;
      const double c = rk[p] * rh;
      for (int q = 0; q <= p; ++q) ri[q] -= c * rk[q];
    }
    const double lkk = std::sqrt(hkk);
    rk[d] = lkk;
    const double inv = lkk * rh;  // 1/sqrt(h) = sqrt(h) * (1/h)
    data.Ld_inv[k] = inv;
    for (int p = 0; p < d; ++p) rk[p] *= inv;
  }
  data.L_ok = true;
  return true;
}

Eigen::MatrixXd tree_factor_dense(const Model& model, const Data& data) {
  const int n = model.nv();
  Eigen::MatrixXd L = Eigen::MatrixXd::Zero(n, n);
  for (int k = 0; k < n; ++k) {
    const double* r = tree_factor_row(model, data, k);
    const int d = model.dof_depth[k];
    for (int p = 0; p < d; ++p) L(k, model.dof_path[model.dof_path_offset[k] + p]) = r[p];
    L(k, k) = r[d];
  }
  return L;
}

}  // namespace coopdyn
