#include "service/algorithms/tree_cholesky.h"

#include <algorithm>
#include <cmath>

#ifdef __AVX512F__
#include <immintrin.h>
#endif

namespace coopdyn {

namespace {

// The row updates below in whole chunks of Model::kFactorRowPad = 8 doubles: every row starts on a
// 64-byte boundary and owns its chunks (its padding zeros included), so a chunk is loaded and
// stored whole, without masked stores (which do not forward to the next step's loads) and without
// overlapping a neighbour row. Lanes past the row's end are kept by masking the multiply-adds, not
// the stores. Each entry gets the same fused multiply-adds in the same order as the scalar loops.
constexpr int kPad = Model::kFactorRowPad;
static_assert(kPad == 8, "the chunks are one 8-wide AVX-512 vector");

#ifdef __AVX512F__
static_assert(EIGEN_MAX_ALIGN_BYTES >= 64, "Data::Lc and Mc start on a 64-byte boundary (aligned loads)");
inline __mmask8 lanes_below(int n) { return n >= kPad ? __mmask8(0xff) : __mmask8((1u << n) - 1u); }

// r[q] -= c * a[q] for q < n
inline void row_axpy(double* __restrict r, const double* __restrict a, double c, int n) {
  const __m512d cv = _mm512_set1_pd(c);
  for (int q = 0; q < n; q += kPad) {
    const __m512d x = _mm512_load_pd(r + q);
    _mm512_store_pd(r + q, _mm512_mask3_fnmadd_pd(cv, _mm512_load_pd(a + q), x, lanes_below(n - q)));
  }
}

// r[q] = r[q] - c * a[q] - e * b[q] for q < n (the two updates in that order)
inline void row_axpy2(double* __restrict r, const double* __restrict a, double c, const double* __restrict b,
                      double e, int n) {
  const __m512d cv = _mm512_set1_pd(c), ev = _mm512_set1_pd(e);
  for (int q = 0; q < n; q += kPad) {
    const __mmask8 m = lanes_below(n - q);
    const __m512d x = _mm512_mask3_fnmadd_pd(cv, _mm512_load_pd(a + q), _mm512_load_pd(r + q), m);
    _mm512_store_pd(r + q, _mm512_mask3_fnmadd_pd(ev, _mm512_load_pd(b + q), x, m));
  }
}

// r[q] *= s for q < n
inline void row_scale(double* __restrict r, double s, int n) {
  const __m512d sv = _mm512_set1_pd(s);
  for (int q = 0; q < n; q += kPad) {
    const __m512d x = _mm512_load_pd(r + q);
    _mm512_store_pd(r + q, _mm512_mask_mul_pd(x, lanes_below(n - q), x, sv));
  }
}
#else
inline void row_axpy(double* __restrict r, const double* __restrict a, double c, int n) {
  for (int q = 0; q < n; ++q) r[q] -= c * a[q];
}
inline void row_axpy2(double* __restrict r, const double* __restrict a, double c, const double* __restrict b,
                      double e, int n) {
  for (int q = 0; q < n; ++q) r[q] = r[q] - c * a[q] - e * b[q];
}
inline void row_scale(double* __restrict r, double s, int n) {
  for (int q = 0; q < n; ++q) r[q] *= s;
}
#endif

struct Factor {
  const Model& model;
  Data& data;
  double* lc;
  double min_pivot;  // rel_tol * the largest diagonal of M

  double* row(int k) const { return lc + model.dof_row_offset[k]; }
  bool pivot_ok(double h) const { return h > min_pivot && std::isfinite(h); }
  // the diagonal L(k, k) = sqrt(h) and row k scaled by 1/sqrt(h) = sqrt(h) * (1/h), over its d entries;
  // the diagonal stored after the scaling, whose chunk load would not take it from a pending
  // 8-byte store
  void finish_row(int k, double* r, int d, double h, double rh) const {
    const double l = std::sqrt(h);
    const double inv = l * rh;
    data.Ld_inv[k] = inv;
    row_scale(r, inv, d);
    r[d] = l;
  }
};

// H(i, j) -= L(k, i) L(k, j) = H(k, i) H(k, j) / H(k, k) for the ancestors j <= i of k; with
// i = path[p], those are the first p + 1 entries of k's path, and row i is stored over exactly
// that prefix. The update uses row k before it is scaled, so that the critical path from one
// pivot to the next is one division; the square root and the scaling of row k run beside it.
void eliminate(const Factor& f, int k, double* __restrict rk, int d, double rh) {
  const int* pk = f.model.dof_path.data() + f.model.dof_path_offset[k];
  for (int p = 0; p < d; ++p) row_axpy(f.row(pk[p]), rk, rk[p] * rh, p + 1);
}

// k and its parent j (k its only child DOF, Model::dof_elim_steps): row j updated by k, then every
// other ancestor row by k and j in one pass, each entry's two updates in that order (the arithmetic
// of eliminating k, then j). False if j's pivot fails.
bool eliminate_pair(const Factor& f, int k, double* __restrict rk, int d, double rh, int j) {
  double* __restrict rj = f.row(j);  // d entries: j's path is k's first d - 1, then its diagonal
  row_axpy(rj, rk, rk[d - 1] * rh, d);
  const double hjj = rj[d - 1];
  if (!f.pivot_ok(hjj)) return false;
  const double rhj = 1.0 / hjj;
  const int* pk = f.model.dof_path.data() + f.model.dof_path_offset[k];
  for (int p = 0; p < d - 1; ++p) row_axpy2(f.row(pk[p]), rk, rk[p] * rh, rj, rj[p] * rhj, p + 1);
  f.finish_row(j, rj, d - 1, hjj, rhj);
  return true;
}

}  // namespace

bool tree_cholesky_factor(const Model& model, Data& data, double rel_tol, int* bad_dof) {
  const int n = model.nv();
  data.Lc = data.Mc;  // same size: no allocation
  double scale = 0.0;
  // from Mc, not from the copy just made: no wait for its stores
  for (int k = 0; k < n; ++k) scale = std::max(scale, std::abs(data.Mc[model.dof_row_offset[k] + model.dof_depth[k]]));
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
