#include "service/algorithms/tree_cholesky.h"

#include <cmath>

namespace coopdyn {

bool tree_cholesky_factor(const Model& model, Data& data, double rel_tol, int* bad_dof) {
  const int n = model.nv();
  Eigen::MatrixXd& H = data.L;
  H = data.M;  // same size: no allocation
  const double scale = n > 0 ? H.diagonal().cwiseAbs().maxCoeff() : 1.0;
  data.L_ok = false;
  for (int k = n - 1; k >= 0; --k) {
    const double hkk = H(k, k);
    if (!(hkk > rel_tol * scale) || !std::isfinite(hkk)) {
      if (bad_dof) *bad_dof = k;
      return false;
    }
    H(k, k) = std::sqrt(hkk);
    for (int i = model.dof_parent[k]; i >= 0; i = model.dof_parent[i]) H(k, i) /= H(k, k);
    for (int i = model.dof_parent[k]; i >= 0; i = model.dof_parent[i])
      for (int j = i; j >= 0; j = model.dof_parent[j]) H(i, j) -= H(k, i) * H(k, j);
  }
  // clear the strict upper triangle so that L is a plain lower-triangular matrix
  for (int j = 1; j < n; ++j) H.col(j).head(j).setZero();
  data.L_ok = true;
  return true;
}

}  // namespace coopdyn
