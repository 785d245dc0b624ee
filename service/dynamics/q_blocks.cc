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

// One group of the block Cholesky (q_blocks.h) on its first r rows: A's lower triangle <- L_g of
// A_g + B_g P B_g^T, W = L_g^-1 B_g P, P -= W^T W, dinv = 1 / diag(L_g); dmax, dmin the extreme
// diagonals so far. False on a pivot that is not positive.
bool factor_group(int r, QBlocks::GMat& A, const QBlocks::GBMat& B, QBlocks::GBMat& W, QBlocks::GVec& dinv, Mat6& P,
                  double& dmax, double& dmin) {
  // BP = B_g P (kept in W until W = L_g^-1 BP below); C = A_g + BP B_g^T into A's lower triangle
  for (int i = 0; i < r; ++i) W.row(i).noalias() = B.row(i) * P;  // 1 x 6 times 6 x 6: fixed-size products
  for (int j = 0; j < r; ++j)
    for (int i = j; i < r; ++i) A(i, j) += W.row(i).dot(B.row(j));
  // Cholesky of C in place (lower)
  for (int j = 0; j < r; ++j) {
    double d = A(j, j);
    for (int k = 0; k < j; ++k) d -= A(j, k) * A(j, k);
    if (!(d > 0.0)) return false;
    const double ljj = std::sqrt(d);
    A(j, j) = ljj;
    const double inv = 1.0 / ljj;
    dinv[j] = inv;
    dmax = std::max(dmax, ljj);
    dmin = std::min(dmin, ljj);
    for (int i = j + 1; i < r; ++i) {
      double sum = A(i, j);
      for (int k = 0; k < j; ++k) sum -= A(i, k) * A(j, k);
      A(i, j) = sum * inv;
    }
  }
  // W = L_g^-1 BP (forward substitution, column by column of the 6)
  for (int i = 0; i < r; ++i) {
    for (int k = 0; k < i; ++k) W.row(i) -= A(i, k) * W.row(k);
    W.row(i) *= dinv[i];
  }
  for (int i = 0; i < r; ++i) P.noalias() -= W.row(i).transpose() * W.row(i);
  return true;
}

// The group's part of the reduced Q (q_blocks.h), as condition_without_nominal forms the dense one:
// per nominal direction u = G's column of joint 1 in the weld's rows, either the one row u lies
// along is dropped or H = I - w w^T (H u = -sign(u_0) |u| e_0) acts on the six rows, A <- H A H,
// B <- H B, and the first is dropped; then the kept rows are compacted to the top.
void reduce_group(QBlocks::Group& g, const Eigen::MatrixXd& G) {
  const int r = g.rows;
  g.Ar.topLeftCorner(r, r) = g.A.topLeftCorner(r, r);  // both triangles (assemble)
  g.Br.topRows(r) = g.B.topRows(r);
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
    for (int j = 0; j < r; ++j) {  // A <- H A (rows o..o+5)
      const double t = w.dot(g.Ar.block<6, 1>(o, j));
      g.Ar.block<6, 1>(o, j) -= t * w;
    }
    for (int i = 0; i < r; ++i) {  // A <- A H (columns o..o+5)
      const double t = g.Ar.block<1, 6>(i, o).dot(w.transpose());
      g.Ar.block<1, 6>(i, o) -= t * w.transpose();
    }
    for (int c = 0; c < QBlocks::kMaxCommon; ++c) {  // B <- H B
      const double t = w.dot(g.Br.block<6, 1>(o, c));
      g.Br.block<6, 1>(o, c) -= t * w;
    }
    g.keep[o] = 0;
  }
  int k = 0;
  for (int j = 0; j < r; ++j) {
    if (g.keep[j] == 0.0) continue;
    int l = 0;
    for (int i = 0; i < r; ++i)
      if (g.keep[i] != 0.0) g.Ar(l++, k) = g.Ar(i, j);
    g.Br.row(k) = g.Br.row(j);
    ++k;
  }
  g.red_rows = k;
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
      reduce_group(g, G);
      if (!factor_group(g.red_rows, g.Ar, g.Br, g.Wr, g.dinvr, P, dmax, dmin)) return false;
    }
    ratio_red = dmin * dmin / (dmax * dmax);
    if (!(ratio_red >= opt.fast_tol)) return false;
  }
  P.setIdentity();
  double dmax = 0.0, dmin = HUGE_VAL;
  for (Group& g : groups)
    if (!factor_group(g.rows, g.A, g.B, g.W, g.dinv, P, dmax, dmin)) return false;
  const double ratio = dmin * dmin / (dmax * dmax);
  if (!(ratio >= opt.fast_tol)) return false;
  *condition = 1.0 / (has_nominal ? ratio_red : ratio);
  return true;
}

void QBlocks::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  x.resize(b.size());  // no-op at the right size
  Vec6 z = Vec6::Zero();
  for (Group& g : groups) {  // forward: y_g = L_g^-1 (b_g - B_g z), into x
    const int r = g.rows;
    double* y = x.data() + g.row0;
    for (int i = 0; i < r; ++i) {
      double s = b[g.row0 + i] - g.B.row(i).dot(z);
      for (int k = 0; k < i; ++k) s -= g.A(i, k) * y[k];
      y[i] = s * g.dinv[i];
    }
    for (int i = 0; i < r; ++i) z.noalias() += y[i] * g.W.row(i).transpose();
  }
  Vec6 t = Vec6::Zero();
  for (auto it = groups.rbegin(); it != groups.rend(); ++it) {  // backward: x_g = L_g^-T (y_g - W_g t)
    Group& g = *it;
    const int r = g.rows;
    double* xg = x.data() + g.row0;
    for (int i = 0; i < r; ++i) xg[i] -= g.W.row(i).dot(t);
    for (int i = r - 1; i >= 0; --i) {
      double s = xg[i];
      for (int k = i + 1; k < r; ++k) s -= g.A(k, i) * xg[k];
      xg[i] = s * g.dinv[i];
    }
    for (int i = 0; i < r; ++i) t.noalias() += xg[i] * g.B.row(i).transpose();
  }
}

}  // namespace coopdyn
