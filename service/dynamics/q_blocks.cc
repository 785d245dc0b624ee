#include "service/dynamics/q_blocks.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace coopdyn {

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
  for (Group& g : groups) {
    if (!has_nominal) break;
    g.Ar.setZero(g.rows, g.rows);
    g.Br.setZero(g.rows, kMaxCommon);
    g.Wr.setZero(g.rows, kMaxCommon);
    g.dinvr.setZero(g.rows);
    g.keep.setOnes(g.rows);
  }
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
  // Cholesky of C in place (lower)
  for (int j = 0; j < r; ++j) {
    double d = A(j, j);
    for (int k = 0; k < j; ++k) d -= A(j, k) * A(j, k);
    if (!(d > 0.0)) return false;
    const double rd = 1.0 / d, ljj = std::sqrt(d);  // side by side on the critical path (q_solve.cc)
    A(j, j) = ljj;
    const double inv = ljj * rd;
    dinv[j] = inv;
    dmax = std::max(dmax, ljj);
    dmin = std::min(dmin, ljj);
    for (int i = j + 1; i < r; ++i) {
      double sum = A(i, j);
      for (int k = 0; k < j; ++k) sum -= A(i, k) * A(j, k);
      A(i, j) = sum * inv;
    }
  }
  // W = L_g^-1 BP (forward substitution, the 6 columns at once)
  for (int i = 0; i < r; ++i) {
    for (int k = 0; k < i; ++k) W.row(i) -= A(i, k) * W.row(k);
    W.row(i) *= dinv[i];
  }
  P.noalias() -= W.transpose().lazyProduct(W);
  return true;
}

// The group's part of the reduced Q (q_blocks.h), as condition_without_nominal forms the dense one:
// per nominal direction u = G's column of joint 1 in the weld's rows, either the one row u lies
// along is dropped or H = I - w w^T (H u = -sign(u_0) |u| e_0) acts on the six rows, A <- H A H,
// B <- H B, and the first is dropped; the kept rows are then written to Ar and Br, sized to them.
template <int R>
void reduce_group(QBlocks::Group& g, const Eigen::MatrixXd& G) {
  const int r = g.rows;
  MatR<R> A = Eigen::Map<const MatR<R>>(g.A.data(), r, r);  // both triangles (assemble)
  MatR6<R> B = Eigen::Map<const MatR6<R>>(g.B.data(), r, 6);
  g.keep.setOnes(r);
  for (const auto& [dof, o] : g.nominal) {
    Vec6 w = G.block<6, 1>(g.row0 + o, dof);
    const double un = w.norm();
    if (!(un > 0.0) || !std::isfinite(un)) continue;
    int single = -1;
    for (int k = 0; k < 6; ++k)
      if (w[k] != 0.0) single = single == -1 ? k : -2;
    if (single >= 0) {
      g.keep[o + single] = 0;
      continue;
    }
    w /= un;
    w[0] += w[0] >= 0 ? 1.0 : -1.0;
    w *= std::sqrt(2.0 / w.squaredNorm());
    // A <- H A (rows o..o+5), then A <- A H (columns o..o+5), B <- H B
    const Eigen::Matrix<double, 1, R, Eigen::RowMajor, 1, R == Eigen::Dynamic ? QBlocks::kMaxGroupRows : R> tr =
        w.transpose().lazyProduct(A.template middleRows<6>(o));
    A.template middleRows<6>(o) -= w.lazyProduct(tr);
    const VecR<R> tc = A.template middleCols<6>(o).lazyProduct(w);
    A.template middleCols<6>(o) -= tc.lazyProduct(w.transpose());
    const Eigen::Matrix<double, 1, 6> tb = w.transpose().lazyProduct(B.template middleRows<6>(o));
    B.template middleRows<6>(o) -= w.lazyProduct(tb);
    g.keep[o] = 0;
  }
  int k = 0;
  for (int j = 0; j < r; ++j) k += g.keep[j] != 0.0 ? 1 : 0;
  g.red_rows = k;
  g.Ar.resize(k, k);  // within the fixed maximum: no allocation
  g.Br.resize(k, 6);
  g.Wr.resize(k, 6);
  g.dinvr.resize(k);
  for (int j = 0, c = 0; j < r; ++j) {
    if (g.keep[j] == 0.0) continue;
    for (int i = 0, l = 0; i < r; ++i)
      if (g.keep[i] != 0.0) g.Ar(l++, c) = A(i, j);
    g.Br.row(c++) = B.row(j);
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
  // the diagnostic first (the full factor overwrites A_g): the reduced Q's pivots, every group
  // (one without a nominal direction as it is: P carries the others' reductions)
  double ratio_red = 1.0;
  if (has_nominal) {
    P.setIdentity();
    double dmax = 0.0, dmin = HUGE_VAL;
    for (Group& g : groups) {
      if (g.rows == 6) reduce_group<6>(g, G);
      else reduce_group<Eigen::Dynamic>(g, G);
      if (!factor_any(g.red_rows, g.Ar.data(), g.Br.data(), g.Wr.data(), g.dinvr.data(), P, dmax, dmin)) return false;
    }
    ratio_red = dmin * dmin / (dmax * dmax);
    if (!(ratio_red >= opt.fast_tol)) return false;
  }
  P.setIdentity();
  double dmax = 0.0, dmin = HUGE_VAL;
  for (Group& g : groups)
    if (!factor_any(g.rows, g.A.data(), g.B.data(), g.W.data(), g.dinv.data(), P, dmax, dmin)) return false;
  const double ratio = dmin * dmin / (dmax * dmax);
  if (!(ratio >= opt.fast_tol)) return false;
  *condition = 1.0 / (has_nominal ? ratio_red : ratio);
  return true;
}

void QBlocks::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  x.resize(b.size());  // no-op at the right size
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

}  // namespace coopdyn
