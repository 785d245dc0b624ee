#include "service/dynamics/q_blocks.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace coopdyn {

namespace {

// the padded width of the nominal columns (q_blocks.h): 4 or 8 where the kernels are fixed, else N
int nominal_width(int n) { return n <= 4 ? 4 : n <= 8 ? 8 : n; }

// the single factor's storage (q_blocks.h): nmax nominal directions, rows of Q
void size_nominal(QBlocks& qb, int nmax, int rows) {
  const int pmax = nominal_width(nmax);
  for (QBlocks::Group& g : qb.groups) {
    g.Ar.setZero(g.rows, g.rows);
    g.Br.setZero(g.rows, QBlocks::kMaxCommon);
    g.Wr.setZero(g.rows, QBlocks::kMaxCommon);
    g.dinvr.setZero(g.rows);
    g.keep.setOnes(g.rows);
    g.hw.assign(g.nominal.size(), Vec6::Zero());
    g.Ad.setZero(g.rows, g.rows);
    g.Yt.setZero(pmax, QBlocks::kMaxGroupRows);
  }
  qb.S.setZero(pmax, pmax);
  qb.sdinv.setZero(nmax);
  qb.Zt.setZero(pmax, QBlocks::kMaxCommon);
  qb.xd.setZero(pmax);
  qb.xr.setZero(rows);
}

}  // namespace

void QBlocks::plan(const System& sys, const std::vector<std::vector<int>>& y_support,
                   const std::vector<std::pair<int, int>>& nominal_rows) {
  usable = false;
  has_nominal = false;
  groups.clear();
  common.clear();
  const ConstraintSet& cs = sys.constraints;
  const int ns = static_cast<int>(cs.specs.size()), n = sys.model.nv();
  if (ns < 2) return;
  // the common DOFs: reached by every spec
  std::vector<int> reach(n, 0);
  for (int s = 0; s < ns; ++s)
    for (int d : y_support[s]) ++reach[d];
  std::vector<char> is_common(n, 0);
  for (int d = 0; d < n; ++d)
    if (reach[d] == ns) {
      common.push_back(d);
      is_common[d] = 1;
    }
  if (static_cast<int>(common.size()) > kMaxCommon) return;
  // groups: specs joined when they share an own DOF (union-find), then checked to be contiguous
  std::vector<int> parent(ns);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int s) {
    while (parent[s] != s) s = parent[s] = parent[parent[s]];
    return s;
  };
  std::vector<int> owner(n, -1);
  for (int s = 0; s < ns; ++s)
    for (int d : y_support[s]) {
      if (is_common[d]) continue;
      if (owner[d] < 0) owner[d] = s;
      else parent[find(s)] = find(owner[d]);
    }
  for (int s = 0; s < ns;) {
    int e = s + 1;
    while (e < ns && find(e) == find(s)) ++e;
    for (int t = e; t < ns; ++t)
      if (find(t) == find(s)) return;  // a group whose specs are not contiguous: its rows are not a block
    Group g;
    g.spec0 = s;
    g.spec1 = e;
    g.row0 = cs.row_offset[s];
    g.rows = 0;
    for (int t = s; t < e; ++t) g.rows += cs.row_count[t];
    if (g.rows > kMaxGroupRows) return;
    g.A.setZero(g.rows, g.rows);
    g.B.setZero(g.rows, kMaxCommon);
    g.W.setZero(g.rows, kMaxCommon);
    g.dinv.setZero(g.rows);
    std::vector<char> ts(n), tt(n);
    for (int a = s; a < e; ++a)
      for (int b = a; b < e; ++b) {
        Group::Pair p{a, b, {}};
        std::fill(ts.begin(), ts.end(), 0);
        std::fill(tt.begin(), tt.end(), 0);
        for (int d : y_support[a]) ts[d] = !is_common[d];
        for (int d : y_support[b]) tt[d] = !is_common[d];
        for (int d = 0; d < n;) {
          if (!(ts[d] && tt[d])) {
            ++d;
            continue;
          }
          int f = d;
          while (f < n && ts[f] && tt[f]) ++f;
          p.ranges.push_back({d, f - d});
          d = f;
        }
        g.pairs.push_back(std::move(p));
      }
    groups.push_back(std::move(g));
    s = e;
  }
  // the nominal directions: each base weld's six rows inside one group
  for (const auto& [dof, r0] : nominal_rows) {
    Group* in = nullptr;
    for (Group& g : groups)
      if (r0 >= g.row0 && r0 + 6 <= g.row0 + g.rows) in = &g;
    if (!in) {
      groups.clear();
      return;
    }
    in->nominal.emplace_back(dof, r0 - in->row0);
    has_nominal = true;
  }
  if (has_nominal) size_nominal(*this, static_cast<int>(nominal_rows.size()), cs.rows);
  usable = groups.size() >= 2;
  if (!usable) groups.clear();
}

namespace {

// The group kernels below take the group's row count R at compile time where it is one of the
// common sizes (a 6-row weld, 5 rows once a nominal direction is dropped), else Eigen::Dynamic: the
// fixed sizes unroll the 6-wide products and the small Cholesky. A (R x R), B and W (R x 6) are
// column-major with leading dimension R (the group's storage, sized to its rows).
template <int R>
using MatR = Eigen::Matrix<double, R, R, 0, R == Eigen::Dynamic ? QBlocks::kMaxGroupRows : R,
                           R == Eigen::Dynamic ? QBlocks::kMaxGroupRows : R>;
template <int R>
using MatR6 = Eigen::Matrix<double, R, 6, 0, R == Eigen::Dynamic ? QBlocks::kMaxGroupRows : R, 6>;
template <int R>
using VecR = Eigen::Matrix<double, R, 1, 0, R == Eigen::Dynamic ? QBlocks::kMaxGroupRows : R, 1>;

// Cholesky of the leading n x n of A in place (lower), dinv = 1 / its diagonal; dmax, dmin the extreme
// diagonals so far. False on a pivot that is not positive. One kernel for a group's fixed-size block
// and the dynamic Schur complement (each instantiation unrolls as its matrix type allows).
template <class Mat>
bool cholesky_lower(Mat& A, double* dinv, int n, double& dmax, double& dmin) {
  for (int j = 0; j < n; ++j) {
    double d = A(j, j);
    for (int k = 0; k < j; ++k) d -= A(j, k) * A(j, k);
    if (!(d > 0.0)) return false;
    const double rd = 1.0 / d, ljj = std::sqrt(d);  // side by side on the critical path (q_solve.cc)
    A(j, j) = ljj;
    const double inv = ljj * rd;
    dinv[j] = inv;
    dmax = std::max(dmax, ljj);
    dmin = std::min(dmin, ljj);
    for (int i = j + 1; i < n; ++i) {
      double sum = A(i, j);
      for (int k = 0; k < j; ++k) sum -= A(i, k) * A(j, k);
      A(i, j) = sum * inv;
    }
  }
  return true;
}

// One group of the block Cholesky (q_blocks.h) on r rows: A's lower triangle <- L_g of
// A_g + B_g P B_g^T, W = L_g^-1 B_g P, P -= W^T W, dinv = 1 / diag(L_g); dmax, dmin the extreme
// diagonals so far. False on a pivot that is not positive.
template <int R>
bool factor_group(int r, double* a, const double* b, double* w, double* dinv, Mat6& P, double& dmax, double& dmin) {
  Eigen::Map<MatR<R>> A(a, r, r);
  Eigen::Map<const MatR6<R>> B(b, r, 6);
  Eigen::Map<MatR6<R>> W(w, r, 6);
  // BP = B_g P (kept in W until W = L_g^-1 BP below); C = A_g + BP B_g^T (both triangles; the lower read)
  W.noalias() = B.lazyProduct(P);
  A.noalias() += W.lazyProduct(B.transpose());
  if (!cholesky_lower(A, dinv, r, dmax, dmin)) return false;  // of C, in place
  // W = L_g^-1 BP (forward substitution, the 6 columns at once)
  for (int i = 0; i < r; ++i) {
    for (int k = 0; k < i; ++k) W.row(i) -= A(i, k) * W.row(k);
    W.row(i) *= dinv[i];
  }
  P.noalias() -= W.transpose().lazyProduct(W);
  return true;
}

// The group's reflections for the nominal directions u (q_blocks.h; u[n] = G's column of joint 1 in the
// weld's rows): per direction either the one row u lies along is dropped (w = 0) or H = I - w w^T
// (H u = -sign(u_0) |u| e_0) and the weld's first row is dropped; keep, kept_idx, drop_idx, red_rows
// and nd follow.
void reflections_group(QBlocks::Group& g, const Vec6* u) {
  const int r = g.rows;
  g.keep.setOnes(r);
  for (size_t n = 0; n < g.nominal.size(); ++n) {
    const int o = g.nominal[n].second;
    Vec6& w = g.hw[n];
    w = u[n];
    const double un = w.norm();
    int single = -1;
    for (int k = 0; k < 6; ++k)
      if (w[k] != 0.0) single = single == -1 ? k : -2;
    if (!(un > 0.0) || !std::isfinite(un) || single >= 0) {
      if (un > 0.0 && std::isfinite(un)) g.keep[o + single] = 0;
      w.setZero();
      continue;
    }
    w /= un;
    w[0] += w[0] >= 0 ? 1.0 : -1.0;
    w *= std::sqrt(2.0 / w.squaredNorm());
    g.keep[o] = 0;
  }
  int k = 0, nd = 0;
  for (int j = 0; j < r; ++j) {
    if (g.keep[j] != 0.0) g.kept_idx[k++] = j;
    else g.drop_idx[nd++] = j;
  }
  g.red_rows = k;
  g.nd = nd;
}

// A group of one weld whose first row is the nominal direction's, reflected (the common case): the
// same quantities, H A H formed as the rank-2 update A - w v^T - v w^T (t = A w, v = t - (w.t / 2) w)
// and written straight to its places, H B = B - w (w^T B) likewise. Against the two one-sided
// reflections of reduce_group, the same matrix to round-off with a shorter chain of dependent
// products and no copy of A and B.
void reduce_weld_reflected(QBlocks::Group& g, int d0, Eigen::MatrixXd& Zt, Eigen::MatrixXd& S) {
  using Vec5 = Eigen::Matrix<double, 5, 1>;
  const Eigen::Map<const Mat6> A(g.A.data()), B(g.B.data());  // 6 rows: leading dimension 6
  const Vec6& w = g.hw[0];
  const Vec6 t = A.lazyProduct(w);
  const Vec6 v = t - (0.5 * w.dot(t)) * w;
  const Vec5 w5 = w.tail<5>(), v5 = v.tail<5>();
  const Eigen::Matrix<double, 1, 6> tb = w.transpose().lazyProduct(B);
  g.d0 = d0;
  g.Ar.resize(5, 5);  // within the fixed maximum: no allocation
  g.Br.resize(5, 6);
  g.Wr.resize(5, 6);
  g.dinvr.resize(5);
  g.Ad.resize(5, 1);
  Eigen::Map<Eigen::Matrix<double, 5, 5>>{g.Ar.data()} =
      A.bottomRightCorner<5, 5>() - w5.lazyProduct(v5.transpose()) - v5.lazyProduct(w5.transpose());
  Eigen::Map<Vec5>{g.Ad.data()} = A.col(0).tail<5>() - w5 * v[0] - v5 * w[0];
  S(d0, d0) = A(0, 0) - 2.0 * w[0] * v[0];
  Eigen::Map<Eigen::Matrix<double, 5, 6>>{g.Br.data()} = B.bottomRows<5>() - w5.lazyProduct(tb);
  Zt.row(d0) = B.row(0) - w[0] * tb;
}

// The group's part of the reduced Q (q_blocks.h), as condition_without_nominal forms the dense one,
// with the reflections of reflections_group: A <- H A H, B <- H B on each reflected weld's six rows,
// the kept rows written to Ar and Br, sized to them.
// Also the dropped rows, for the single factor (q_blocks.h): Ad = H A_g H (kept, dropped), their
// rows of H B_g into Zt's rows d0.. and their block of H A_g H into S at (d0, d0).
template <int R>
void reduce_group(QBlocks::Group& g, int d0, Eigen::MatrixXd& Zt, Eigen::MatrixXd& S) {
  const int r = g.rows;
  if (R == 6 && g.nominal.size() == 1 && g.nominal[0].second == 0 && g.nd == 1 && g.drop_idx[0] == 0 &&
      !g.hw[0].isZero(0.0))
    return reduce_weld_reflected(g, d0, Zt, S);
  MatR<R> A = Eigen::Map<const MatR<R>>(g.A.data(), r, r);  // both triangles (assemble)
  MatR6<R> B = Eigen::Map<const MatR6<R>>(g.B.data(), r, 6);
  for (size_t n = 0; n < g.nominal.size(); ++n) {
    const int o = g.nominal[n].second;
    const Vec6& w = g.hw[n];
    if (w.isZero(0.0)) continue;  // no reflection: the one row u lies along is dropped, or none
    // A <- H A (rows o..o+5), then A <- A H (columns o..o+5), B <- H B
    const Eigen::Matrix<double, 1, R, Eigen::RowMajor, 1, R == Eigen::Dynamic ? QBlocks::kMaxGroupRows : R> tr =
        w.transpose().lazyProduct(A.template middleRows<6>(o));
    A.template middleRows<6>(o) -= w.lazyProduct(tr);
    const VecR<R> tc = A.template middleCols<6>(o).lazyProduct(w);
    A.template middleCols<6>(o) -= tc.lazyProduct(w.transpose());
    const Eigen::Matrix<double, 1, 6> tb = w.transpose().lazyProduct(B.template middleRows<6>(o));
    B.template middleRows<6>(o) -= w.lazyProduct(tb);
  }
  const int k = g.red_rows, nd = g.nd;
  g.d0 = d0;
  g.Ar.resize(k, k);  // within the fixed maximum: no allocation
  g.Br.resize(k, 6);
  g.Wr.resize(k, 6);
  g.dinvr.resize(k);
  g.Ad.resize(k, nd);
  if (R == 6 && nd == 1 && g.drop_idx[0] == 0) {  // a weld with its first row dropped: blocks, not indices
    Eigen::Map<Eigen::Matrix<double, 5, 5>>{g.Ar.data()} = A.template bottomRightCorner<5, 5>();
    Eigen::Map<Eigen::Matrix<double, 5, 6>>{g.Br.data()} = B.template bottomRows<5>();
    Eigen::Map<Eigen::Matrix<double, 5, 1>>{g.Ad.data()} = A.col(0).template tail<5>();
    S(d0, d0) = A(0, 0);
    Zt.row(d0) = B.row(0);
    return;
  }
  for (int c = 0; c < k; ++c) {
    const int j = g.kept_idx[c];
    for (int l = 0; l < k; ++l) g.Ar(l, c) = A(g.kept_idx[l], j);
    g.Br.row(c) = B.row(j);
  }
  for (int c = 0; c < nd; ++c) {
    const int j = g.drop_idx[c];
    for (int l = 0; l < k; ++l) g.Ad(l, c) = A(g.kept_idx[l], j);
    for (int l = 0; l < nd; ++l) S(d0 + l, d0 + c) = A(g.drop_idx[l], j);
    Zt.row(d0 + c) = B.row(j);
  }
}

bool factor_any(int r, double* a, const double* b, double* w, double* dinv, Mat6& P, double& dmax, double& dmin) {
  switch (r) {
    case 6: return factor_group<6>(r, a, b, w, dinv, P, dmax, dmin);
    case 5: return factor_group<5>(r, a, b, w, dinv, P, dmax, dmin);
    case 3: return factor_group<3>(r, a, b, w, dinv, P, dmax, dmin);
    default: return factor_group<Eigen::Dynamic>(r, a, b, w, dinv, P, dmax, dmin);
  }
}

// y_g = L_g^-1 (b_g - B_g z) into y, then z += W_g^T y_g
template <int R>
void forward_group(const QBlocks::Group& g, const double* b, double* y, Vec6& z) {
  const int r = g.rows;
  Eigen::Map<const MatR<R>> L(g.A.data(), r, r);
  Eigen::Map<const MatR6<R>> B(g.B.data(), r, 6), W(g.W.data(), r, 6);
  Eigen::Map<VecR<R>> yv(y, r);
  yv = Eigen::Map<const VecR<R>>(b, r) - B.lazyProduct(z);
  for (int i = 0; i < r; ++i) {
    double s = yv[i];
    for (int k = 0; k < i; ++k) s -= L(i, k) * yv[k];
    yv[i] = s * g.dinv[i];
  }
  z.noalias() += W.transpose().lazyProduct(yv);
}

// x_g = L_g^-T (x_g - W_g t), then t += B_g^T x_g
template <int R>
void backward_group(const QBlocks::Group& g, double* x, Vec6& t) {
  const int r = g.rows;
  Eigen::Map<const MatR<R>> L(g.A.data(), r, r);
  Eigen::Map<const MatR6<R>> B(g.B.data(), r, 6), W(g.W.data(), r, 6);
  Eigen::Map<VecR<R>> xv(x, r);
  xv -= W.lazyProduct(t);
  for (int i = r - 1; i >= 0; --i) {
    double s = xv[i];
    for (int k = i + 1; k < r; ++k) s -= L(k, i) * xv[k];
    xv[i] = s * g.dinv[i];
  }
  t.noalias() += B.transpose().lazyProduct(xv);
}

}  // namespace

bool QBlocks::factor(const SolverOptions& opt, const Eigen::MatrixXd& G, double* condition) {
  if (has_nominal) return factor_nominal_last(opt, G, condition);
  P.setIdentity();
  double dmax = 0.0, dmin = HUGE_VAL;
  for (Group& g : groups)
    if (!factor_any(g.rows, g.A.data(), g.B.data(), g.W.data(), g.dinv.data(), P, dmax, dmin)) return false;
  const double ratio = dmin * dmin / (dmax * dmax);
  if (!(ratio >= opt.fast_tol)) return false;
  *condition = 1.0 / ratio;
  return true;
}

namespace {

// The group's columns of L_dr (q_blocks.h), after its reduced factor: Y_g = L_g^-1 (Br_g Z + Ad E_g) (the
// forward solve of the group's rows of Q_rd: K_g Z + (L_g^-1 Ad) E_g without forming K_g = L_g^-1 Br_g),
// stored as Yt = Y_g^T (N x red_rows, a reduced row's N entries contiguous: the L_g^-1 steps are
// N-wide), then Z <- Z - W_g^T Y_g and S <- S - Y_g^T Y_g, over the first np rows of Zt, Yt and S (np >=
// N: the rows beyond N are zero in Zt, so in Yt, and S's are not read). R: the reduced rows, NP: np,
// each fixed or Eigen::Dynamic.
template <int R, int NP>
void nominal_columns(QBlocks::Group& g, int np, Eigen::MatrixXd& Zt, Eigen::MatrixXd& S) {
  const int r = g.red_rows;
  using Stride = Eigen::OuterStride<>;
  Eigen::Map<Eigen::Matrix<double, NP, R>, 0, Stride> Y(g.Yt.data(), np, r, Stride(g.Yt.outerStride()));
  Eigen::Map<Eigen::Matrix<double, NP, 6>, 0, Stride> Z(Zt.data(), np, 6, Stride(Zt.outerStride()));
  Eigen::Map<Eigen::Matrix<double, NP, NP>, 0, Stride> Sm(S.data(), np, np, Stride(S.outerStride()));
  Eigen::Map<const MatR<R>> L(g.Ar.data(), r, r);
  Eigen::Map<const MatR6<R>> B(g.Br.data(), r, 6), W(g.Wr.data(), r, 6);
  Y.noalias() = Z.lazyProduct(B.transpose());
  for (int c = 0; c < g.nd; ++c)
    for (int i = 0; i < r; ++i) Y(g.d0 + c, i) += g.Ad(i, c);
  for (int i = 0; i < r; ++i) {
    for (int k = 0; k < i; ++k) Y.col(i) -= L(i, k) * Y.col(k);
    Y.col(i) *= g.dinvr[i];
  }
  Z.noalias() -= Y.lazyProduct(W);
  Sm.noalias() -= Y.lazyProduct(Y.transpose());
}

// S += Zt Zt^T over the first np rows (np: 4, 8 fixed, else dynamic)
template <int NP>
void add_outer_n(int np, const Eigen::MatrixXd& Zt, Eigen::MatrixXd& S) {
  using Stride = Eigen::OuterStride<>;
  Eigen::Map<const Eigen::Matrix<double, NP, 6>, 0, Stride> Z(Zt.data(), np, 6, Stride(Zt.outerStride()));
  Eigen::Map<Eigen::Matrix<double, NP, NP>, 0, Stride> Sm(S.data(), np, np, Stride(S.outerStride()));
  Sm.noalias() += Z.lazyProduct(Z.transpose());
}
void add_outer(int np, const Eigen::MatrixXd& Zt, Eigen::MatrixXd& S) {
  if (np == 4) return add_outer_n<4>(np, Zt, S);
  if (np == 8) return add_outer_n<8>(np, Zt, S);
  add_outer_n<Eigen::Dynamic>(np, Zt, S);
}

void nominal_columns_any(QBlocks::Group& g, int np, Eigen::MatrixXd& Zt, Eigen::MatrixXd& S) {
  if (g.red_rows == 5 && np == 4) return nominal_columns<5, 4>(g, np, Zt, S);
  if (g.red_rows == 5 && np == 8) return nominal_columns<5, 8>(g, np, Zt, S);
  nominal_columns<Eigen::Dynamic, Eigen::Dynamic>(g, np, Zt, S);
}

// The solve's group steps on the reduced rows y (q_blocks.h), R and NP as in nominal_columns:
// forward y <- L_g^-1 (y - Br_g z), z += Wr_g^T y, xd -= Y_g^T y
template <int R, int NP>
void nominal_forward(const QBlocks::Group& g, int np, double* y, Vec6& z, double* xd) {
  const int r = g.red_rows;
  using Stride = Eigen::OuterStride<>;
  Eigen::Map<const MatR<R>> L(g.Ar.data(), r, r);
  Eigen::Map<const MatR6<R>> B(g.Br.data(), r, 6), W(g.Wr.data(), r, 6);
  Eigen::Map<const Eigen::Matrix<double, NP, R>, 0, Stride> Y(g.Yt.data(), np, r, Stride(g.Yt.outerStride()));
  Eigen::Map<VecR<R>> yv(y, r);
  Eigen::Map<Eigen::Matrix<double, NP, 1>> d(xd, np);
  yv -= B.lazyProduct(z);
  for (int i = 0; i < r; ++i) {
    double s = yv[i];
    for (int k = 0; k < i; ++k) s -= L(i, k) * yv[k];
    yv[i] = s * g.dinvr[i];
  }
  z.noalias() += W.transpose().lazyProduct(yv);
  d.noalias() -= Y.lazyProduct(yv);
}

// backward y <- L_g^-T (y - Wr_g t - Y_g xd), t += Br_g^T y
template <int R, int NP>
void nominal_backward(const QBlocks::Group& g, int np, double* y, Vec6& t, const double* xd) {
  const int r = g.red_rows;
  using Stride = Eigen::OuterStride<>;
  Eigen::Map<const MatR<R>> L(g.Ar.data(), r, r);
  Eigen::Map<const MatR6<R>> B(g.Br.data(), r, 6), W(g.Wr.data(), r, 6);
  Eigen::Map<const Eigen::Matrix<double, NP, R>, 0, Stride> Y(g.Yt.data(), np, r, Stride(g.Yt.outerStride()));
  Eigen::Map<VecR<R>> yv(y, r);
  Eigen::Map<const Eigen::Matrix<double, NP, 1>> d(xd, np);
  yv -= W.lazyProduct(t) + Y.transpose().lazyProduct(d);
  for (int i = r - 1; i >= 0; --i) {
    double s = yv[i];
    for (int k = i + 1; k < r; ++k) s -= L(k, i) * yv[k];
    yv[i] = s * g.dinvr[i];
  }
  t.noalias() += B.transpose().lazyProduct(yv);
}


}  // namespace

namespace {
// a group of one weld whose first row is the one dropped (reflected or not): its rows as blocks
bool weld_first_dropped(const QBlocks::Group& g) { return g.rows == 6 && g.nd == 1 && g.drop_idx[0] == 0; }
}  // namespace

bool QBlocks::near_reference(const Vec6& u, const Vec6& ur) {
  const double tol = kNominalRefTol * ur.cwiseAbs().maxCoeff();
  bool same = tol > 0.0 && std::isfinite(tol);
  for (int k = 0; k < 6; ++k) same = same && (u[k] == 0.0) == (ur[k] == 0.0) && std::abs(u[k] - ur[k]) <= tol;
  return same;
}

void QBlocks::set_nominal_reference(const Eigen::MatrixXd& G) {
  for (Group& g : groups) {
    g.u_ref.resize(g.nominal.size());
    for (size_t n = 0; n < g.nominal.size(); ++n) g.u_ref[n] = G.block<6, 1>(g.row0 + g.nominal[n].second, g.nominal[n].first);
    reflections_group(g, g.u_ref.data());
    g.at_ref = true;
  }
}

void QBlocks::prepare_nominal(const Eigen::MatrixXd& G) {
  for (Group& g : groups) {
    const size_t nn = g.nominal.size();
    Vec6 u[kMaxGroupRows / 6];
    bool ref = g.u_ref.size() == nn;
    for (size_t n = 0; n < nn; ++n) {
      u[n] = G.block<6, 1>(g.row0 + g.nominal[n].second, g.nominal[n].first);
      ref = ref && QBlocks::near_reference(u[n], g.u_ref[n]);
    }
    if (ref && g.at_ref) continue;  // the reference's reflections stand
    reflections_group(g, ref ? g.u_ref.data() : u);
    g.at_ref = ref;
  }
  prepared = true;
}

bool QBlocks::factor_nominal_last(const SolverOptions& opt, const Eigen::MatrixXd& G, double* condition) {
  if (!prepared) prepare_nominal(G);
  prepared = false;
  // R Q R^T's parts: the reduced groups, the dropped rows' block of H A H (into S) and of H B (into Zt)
  nd = 0;
  Zt.setZero();  // the padding rows stay 0
  S.setZero();   // the entries beyond the dropped rows' blocks start at 0
  for (Group& g : groups) {
    if (g.rows == 6) reduce_group<6>(g, nd, Zt, S);
    else reduce_group<Eigen::Dynamic>(g, nd, Zt, S);
    nd += g.nd;
  }
  np = nominal_width(nd);
  // S = Q_dd = blkdiag(H A_g H (dropped)) + Bd Bd^T (the lower triangle read; the padding stays 0)
  add_outer(np, Zt, S);
  // the reduced rows' block Cholesky, and the columns of L_dr with the Schur complement group by group
  P.setIdentity();
  double dmax = 0.0, dmin = HUGE_VAL;
  for (Group& g : groups) {
    if (!factor_any(g.red_rows, g.Ar.data(), g.Br.data(), g.Wr.data(), g.dinvr.data(), P, dmax, dmin))
      return false;
    nominal_columns_any(g, np, Zt, S);
  }
  const double ratio_red = dmin * dmin / (dmax * dmax);
  if (!cholesky_lower(S, sdinv.data(), nd, dmax, dmin)) return false;
  if (!(dmin * dmin / (dmax * dmax) >= opt.fast_tol)) return false;
  *condition = 1.0 / ratio_red;
  return true;
}

void QBlocks::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  x.resize(b.size());  // no-op at the right size
  if (has_nominal) return solve_nominal_last(b, x);
  Vec6 z = Vec6::Zero();
  for (const Group& g : groups) {
    if (g.rows == 6) forward_group<6>(g, b.data() + g.row0, x.data() + g.row0, z);
    else forward_group<Eigen::Dynamic>(g, b.data() + g.row0, x.data() + g.row0, z);
  }
  Vec6 t = Vec6::Zero();
  for (auto it = groups.rbegin(); it != groups.rend(); ++it) {
    if (it->rows == 6) backward_group<6>(*it, x.data() + it->row0, t);
    else backward_group<Eigen::Dynamic>(*it, x.data() + it->row0, t);
  }
}

// x = R^T (R Q R^T)^-1 R b through the single factor (q_blocks.h)
void QBlocks::solve_nominal_last(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  // R b: per group its rows reflected, the kept ones into xr (at the group's rows), the dropped into xd
  xd.setZero();  // the padding entries stay 0
  for (const Group& g : groups) {
    if (weld_first_dropped(g)) {  // one weld, its first row dropped: the reflected rows in place
      Vec6 v = b.segment<6>(g.row0);
      v -= g.hw[0].dot(v) * g.hw[0];
      xr.segment<5>(g.row0) = v.tail<5>();
      xd[g.d0] = v[0];
      continue;
    }
    GVec v = b.segment(g.row0, g.rows);
    for (size_t n = 0; n < g.nominal.size(); ++n) {
      const Vec6& w = g.hw[n];
      const int o = g.nominal[n].second;
      v.segment<6>(o) -= w.dot(v.segment<6>(o)) * w;  // w = 0 where there is no reflection
    }
    for (int c = 0; c < g.red_rows; ++c) xr[g.row0 + c] = v[g.kept_idx[c]];
    for (int c = 0; c < g.nd; ++c) xd[g.d0 + c] = v[g.drop_idx[c]];
  }
  // forward: y_g = L_g^-1 (b_g - Br_g z), z += Wr_g^T y_g, b_d -= Y_g^T y_g; then y_d = L_S^-1 b_d
  Vec6 z = Vec6::Zero();
  for (const Group& g : groups) {
    if (g.red_rows == 5 && np == 4) nominal_forward<5, 4>(g, np, xr.data() + g.row0, z, xd.data());
    else if (g.red_rows == 5 && np == 8) nominal_forward<5, 8>(g, np, xr.data() + g.row0, z, xd.data());
    else nominal_forward<Eigen::Dynamic, Eigen::Dynamic>(g, np, xr.data() + g.row0, z, xd.data());
  }
  for (int i = 0; i < nd; ++i) {
    double s = xd[i];
    for (int k = 0; k < i; ++k) s -= S(i, k) * xd[k];
    xd[i] = s * sdinv[i];
  }
  for (int i = nd - 1; i >= 0; --i) {  // x_d = L_S^-T y_d
    double s = xd[i];
    for (int k = i + 1; k < nd; ++k) s -= S(k, i) * xd[k];
    xd[i] = s * sdinv[i];
  }
  // backward: x_g = L_g^-T (y_g - Wr_g t - Y_g x_d), t += Br_g^T x_g
  Vec6 t = Vec6::Zero();
  for (auto it = groups.rbegin(); it != groups.rend(); ++it) {
    const Group& g = *it;
    if (g.red_rows == 5 && np == 4) nominal_backward<5, 4>(g, np, xr.data() + g.row0, t, xd.data());
    else if (g.red_rows == 5 && np == 8) nominal_backward<5, 8>(g, np, xr.data() + g.row0, t, xd.data());
    else nominal_backward<Eigen::Dynamic, Eigen::Dynamic>(g, np, xr.data() + g.row0, t, xd.data());
  }
  // x = R^T [x_r; x_d]
  for (const Group& g : groups) {
    if (weld_first_dropped(g)) {
      Vec6 v;
      v[0] = xd[g.d0];
      v.tail<5>() = xr.segment<5>(g.row0);
      v -= g.hw[0].dot(v) * g.hw[0];
      x.segment<6>(g.row0) = v;
      continue;
    }
    GVec v(g.rows);
    for (int c = 0; c < g.red_rows; ++c) v[g.kept_idx[c]] = xr[g.row0 + c];
    for (int c = 0; c < g.nd; ++c) v[g.drop_idx[c]] = xd[g.d0 + c];
    for (size_t n = 0; n < g.nominal.size(); ++n) {
      const Vec6& w = g.hw[n];
      const int o = g.nominal[n].second;
      v.segment<6>(o) -= w.dot(v.segment<6>(o)) * w;
    }
    x.segment(g.row0, g.rows) = v;
  }
}

}  // namespace coopdyn
