#include "service/dynamics/friction_lcp.h"

#include <algorithm>
#include <cmath>

namespace coopdyn {

FrictionLcp::FrictionLcp(int kmax) {
  A.setZero(kmax, kmax);
  b.setZero(kmax);
  bound.setZero(kmax);
  f.setZero(kmax);
  a.setZero(kmax);
  state.assign(static_cast<size_t>(kmax), 0);
  W_.setZero(kmax, kmax);
  r_.setZero(kmax);
  t_.setZero(kmax);
  C_.setZero(kmax, kmax);
  idx_.assign(static_cast<size_t>(kmax), 0);
  perm_.assign(static_cast<size_t>(kmax), 0);
}

// f of the stuck joints from A_SS f_S = -(b_S + A_SB f_B), the bound joints at +-F; then a = b + A f.
// Pivoted Cholesky of A_SS, stopped at a pivot <= 1e-12 of A's largest diagonal: the stuck block
// is then singular (indeterminate) and f_S its minimum-norm solution.
void FrictionLcp::solve_stuck(int k) {
  int n = 0;
  for (int i = 0; i < k; ++i) {
    if (state[i] != 0) f[i] = state[i] * bound[i];
    else idx_[n++] = i;
  }
  double dmax = 0.0;
  for (int i = 0; i < k; ++i) dmax = std::max(dmax, A(i, i));
  const double tol = 1e-12 * dmax;
  for (int p = 0; p < n; ++p) {
    const int i = idx_[p];
    double s = b[i];
    for (int j = 0; j < k; ++j)
      if (state[j] != 0) s += A(i, j) * f[j];
    r_[p] = -s;
    perm_[p] = i;
    for (int q = 0; q < n; ++q) W_(p, q) = A(i, idx_[q]);
  }
  int rank = 0;
  for (int j = 0; j < n; ++j) {
    int p = j;
    for (int i = j + 1; i < n; ++i)
      if (W_(i, i) > W_(p, p)) p = i;
    if (!(W_(p, p) > tol)) break;
    if (p != j) {
      W_.row(j).swap(W_.row(p));
      W_.col(j).swap(W_.col(p));
      std::swap(perm_[j], perm_[p]);
      std::swap(r_[j], r_[p]);
    }
    const double d = std::sqrt(W_(j, j));
    W_(j, j) = d;
    for (int i = j + 1; i < n; ++i) W_(i, j) /= d;
    for (int c = j + 1; c < n; ++c)
      for (int i = j + 1; i < n; ++i) W_(i, c) -= W_(i, j) * W_(c, j);
    ++rank;
  }
  indeterminate = n - rank;
  if (rank == n) {
    for (int j = 0; j < n; ++j) {  // L y = r
      double s = r_[j];
      for (int i = 0; i < j; ++i) s -= W_(j, i) * r_[i];
      r_[j] = s / W_(j, j);
    }
    for (int j = n - 1; j >= 0; --j) {  // L^T x = y
      double s = r_[j];
      for (int i = j + 1; i < n; ++i) s -= W_(i, j) * r_[i];
      r_[j] = s / W_(j, j);
    }
  } else {
    // A_SS = L L^T with L (n x rank): the minimum-norm solution x = L (L^T L)^-2 L^T r
    for (int j = 0; j < rank; ++j) {  // t = L^T r
      double s = 0.0;
      for (int i = j; i < n; ++i) s += W_(i, j) * r_[i];
      t_[j] = s;
    }
    for (int i = 0; i < rank; ++i)  // C = L^T L (lower part), then its Cholesky
      for (int j = 0; j <= i; ++j) {
        double s = 0.0;
        for (int l = i; l < n; ++l) s += W_(l, i) * W_(l, j);
        C_(i, j) = s;
      }
    for (int j = 0; j < rank; ++j) {
      double d = C_(j, j);
      for (int l = 0; l < j; ++l) d -= C_(j, l) * C_(j, l);
      C_(j, j) = std::sqrt(std::max(d, 0.0));
      for (int i = j + 1; i < rank; ++i) {
        double s = C_(i, j);
        for (int l = 0; l < j; ++l) s -= C_(i, l) * C_(j, l);
        C_(i, j) = C_(j, j) > 0.0 ? s / C_(j, j) : 0.0;
      }
    }
    for (int pass = 0; pass < 2; ++pass) {  // t <- C^-1 t, twice
      for (int j = 0; j < rank; ++j) {
        double s = t_[j];
        for (int l = 0; l < j; ++l) s -= C_(j, l) * t_[l];
        t_[j] = C_(j, j) > 0.0 ? s / C_(j, j) : 0.0;
      }
      for (int j = rank - 1; j >= 0; --j) {
        double s = t_[j];
        for (int l = j + 1; l < rank; ++l) s -= C_(l, j) * t_[l];
        t_[j] = C_(j, j) > 0.0 ? s / C_(j, j) : 0.0;
      }
    }
    for (int i = 0; i < n; ++i) {  // x = L t
      double s = 0.0;
      for (int j = 0; j <= std::min(i, rank - 1); ++j) s += W_(i, j) * t_[j];
      r_[i] = s;
    }
  }
  for (int j = 0; j < n; ++j) f[perm_[j]] = r_[j];
  for (int i = 0; i < k; ++i) {
    double s = b[i];
    for (int j = 0; j < k; ++j) s += A(i, j) * f[j];
    a[i] = s;
  }
}

bool FrictionLcp::check(int k, double tol_a) const {
  for (int i = 0; i < k; ++i) {
    if (state[i] == 0 && (std::abs(f[i]) > bound[i] * (1.0 + 1e-9) || std::abs(a[i]) > tol_a)) return false;
    if (state[i] != 0 && state[i] * a[i] > tol_a) return false;
  }
  return true;
}

void FrictionLcp::solve(int k) {
  double scale = 0.0;  // the accelerations' scale: what the friction or the load alone can give
  for (int i = 0; i < k; ++i) {
    state[i] = 0;
    scale = std::max({scale, std::abs(b[i]), A(i, i) * bound[i]});
  }
  const double tol_a = 1e-10 * scale;
  converged = false;
  iterations = 0;
  for (int it = 0; it < 4 * k + 8; ++it) {
    iterations = it + 1;
    solve_stuck(k);
    int worst = -1;
    double worst_v = 1.0 + 1e-12;
    for (int i = 0; i < k; ++i)  // a stuck joint that needs more than its bound: to the bound
      if (state[i] == 0 && std::abs(f[i]) > worst_v * bound[i]) {
        worst = i;
        worst_v = std::abs(f[i]) / bound[i];
      }
    if (worst >= 0) {
      state[worst] = f[worst] > 0 ? 1 : -1;
      continue;
    }
    worst_v = tol_a;
    for (int i = 0; i < k; ++i)  // a sliding joint whose acceleration turned against its friction: stuck again
      if (state[i] != 0 && state[i] * a[i] > worst_v) {
        worst = i;
        worst_v = state[i] * a[i];
      }
    if (worst >= 0) {
      state[worst] = 0;
      continue;
    }
    break;
  }
  converged = check(k, 10.0 * tol_a);
}

}  // namespace coopdyn
