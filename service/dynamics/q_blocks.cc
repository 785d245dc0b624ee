#include "service/dynamics/q_blocks.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace coopdyn {

void QBlocks::plan(const System& sys, const std::vector<std::vector<int>>& y_support) {
  usable = false;
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
  usable = groups.size() >= 2;
  if (!usable) groups.clear();
}

bool QBlocks::factor(const SolverOptions& opt, double* condition) {
  P.setIdentity();
  double dmax = 0.0, dmin = HUGE_VAL;
  for (Group& g : groups) {
    const int r = g.rows;
    // BP = B_g P (kept in W until W = L_g^-1 BP below); C = A_g + BP B_g^T into A's lower triangle
    g.W.noalias() = g.B * P;
    for (int j = 0; j < r; ++j)
      for (int i = j; i < r; ++i) g.A(i, j) += g.W.row(i).dot(g.B.row(j));
    // Cholesky of C in place (lower)
    for (int j = 0; j < r; ++j) {
      double d = g.A(j, j);
      for (int k = 0; k < j; ++k) d -= g.A(j, k) * g.A(j, k);
      if (!(d > 0.0)) return false;
      const double ljj = std::sqrt(d);
      g.A(j, j) = ljj;
      const double inv = 1.0 / ljj;
      g.dinv[j] = inv;
      dmax = std::max(dmax, ljj);
      dmin = std::min(dmin, ljj);
      for (int i = j + 1; i < r; ++i) {
        double sum = g.A(i, j);
        for (int k = 0; k < j; ++k) sum -= g.A(i, k) * g.A(j, k);
        g.A(i, j) = sum * inv;
      }
    }
    // W = L_g^-1 BP (forward substitution, column by column of the 6)
    for (int i = 0; i < r; ++i) {
      for (int k = 0; k < i; ++k) g.W.row(i) -= g.A(i, k) * g.W.row(k);
      g.W.row(i) *= g.dinv[i];
    }
    P.noalias() -= g.W.transpose() * g.W;
  }
  const double ratio = dmin * dmin / (dmax * dmax);
  if (!(ratio >= opt.fast_tol)) return false;
  *condition = 1.0 / ratio;
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
