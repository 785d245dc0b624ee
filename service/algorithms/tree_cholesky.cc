#include "service/algorithms/tree_cholesky.h"

#include <algorithm>
#include <cmath>

namespace coopdyn {

namespace {

struct Factor {
  const Model& model;
  Data& data;
  double* lc;
  double min_pivot;  // rel_tol * the largest diagonal of M

  double* row(int k) const { return lc + model.dof_path_offset[k] + k; }
  bool pivot_ok(double h) const { return h > min_pivot && std::isfinite(h); }
  // the diagonal L(k, k) = sqrt(h) and row k scaled by 1/sqrt(h) = sqrt(h) * (1/h), over its d entries
  void finish_row(int k, double* r, int d, double h, double rh) const {
    const double l = std::sqrt(h);
    r[d] = l;
    const double inv = l * rh;
    data.Ld_inv[k] = inv;
    for (int p = 0; p < d; ++p) r[p] *= inv;
  }
};

// H(i, j) -= L(k, i) L(k, j) = H(k, i) H(k, j) / H(k, k) for the ancestors j <= i of k; with
// i = path[p], those are the first p + 1 entries of k's path, and row i is stored over exactly
// that prefix. The update uses row k before it is scaled, so that the critical path from one
// pivot to the next is one division; the square root and the scaling of row k run beside it.
void eliminate(const Factor& f, int k, double* __restrict rk, int d, double rh) {
  const int* pk = f.model.dof_path.data() + f.model.dof_path_offset[k];
  for (int p = 0; p < d; ++p) {
    double* __restrict ri = f.row(pk[p]);
    const double c = rk[p] * rh;
    for (int q = 0; q <= p; ++q) ri[q] -= c * rk[q];
  }
}

// k and its parent j (k its only child DOF, Model::dof_elim_steps): row j updated by k, then every
// other ancestor row by k and j in one pass, each entry's two updates in that order (the arithmetic
// of eliminating k, then j). False if j's pivot fails.
bool eliminate_pair(const Factor& f, int k, double* __restrict rk, int d, double rh, int j) {
  double* __restrict rj = f.row(j);  // d entries: j's path is k's first d - 1, then its diagonal
  const double cj0 = rk[d - 1] * rh;
  for (int q = 0; q < d; ++q) rj[q] -= cj0 * rk[q];
  const double hjj = rj[d - 1];
  if (!f.pivot_ok(hjj)) return false;
  const double rhj = 1.0 / hjj;
  const int* pk = f.model.dof_path.data() + f.model.dof_path_offset[k];
  for (int p = 0; p < d - 1; ++p) {
    double* __restrict ri = f.row(pk[p]);
    const double c = rk[p] * rh, cj = rj[p] * rhj;
    for (int q = 0; q <= p; ++q) ri[q] = ri[q] - c * rk[q] - cj * rj[q];
  }
  f.finish_row(j, rj, d - 1, hjj, rhj);
  return true;
}

}  // namespace

bool tree_cholesky_factor(const Model& model, Data& data, double rel_tol, int* bad_dof) {
  const int n = model.nv();
  data.Lc = data.Mc;  // same size: no allocation
  double scale = 0.0;
  for (int k = 0; k < n; ++k) scale = std::max(scale, std::abs(data.Lc[model.dof_path_offset[k] + k + model.dof_depth[k]]));
  data.L_ok = false;
  const Factor f{model, data, data.Lc.data(), rel_tol * scale};
  for (const auto& [k, j] : model.dof_elim_steps) {
    double* rk = f.row(k);
    const int d = model.dof_depth[k];
    const double hkk = rk[d];
    if (!f.pivot_ok(hkk)) {
      if (bad_dof) *bad_dof = k;
      return false;
    }
    const double rh = 1.0 / hkk;
    if (j < 0) {
      eliminate(f, k, rk, d, rh);
    } else if (!eliminate_pair(f, k, rk, d, rh, j)) {
      if (bad_dof) *bad_dof = j;
      return false;
    }
    f.finish_row(k, rk, d, hkk, rh);
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
