// The canonical orthonormal basis of a subspace: the same columns (up to round-off and sign) from
// any orthonormal basis of it. Used on the free directions of the multipliers (wrenches.cc), whose
// basis an SVD or an eigen-solver returns rotated by round-off: printed as readings, they must
// depend on the subspace only. Allocation-free (the loop calls it), O(m j^2).
#pragma once

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

namespace coopdyn {

// Columns [0, j) of B (m rows, column stride ld; orthonormal) replaced by the canonical orthonormal
// basis of the subspace they span: column s is P e_r / |P e_r| for the projector P on what columns
// [s, j) still span and r the first row where P's diagonal is within 1e-9 of its largest, then P
// loses that direction. A Householder reflection on columns [s, j) does each step (it turns row r
// of those columns into |row r| e_s), so the rest stays orthonormal. Two bases of one subspace give
// the same columns up to round-off and sign; take() fixes the sign. g: scratch of size >= j.
inline void canonical_basis(double* B, Eigen::Index ld, int m, int j, double* g) {
  for (int s = 0; s < j; ++s) {
    double dmax = 0;
    for (int i = 0; i < m; ++i) {
      double d = 0;
      for (int c = s; c < j; ++c) d += B[c * ld + i] * B[c * ld + i];
      dmax = std::max(dmax, d);
    }
    int r = 0;
    for (int i = 0; i < m; ++i) {
      double d = 0;
      for (int c = s; c < j; ++c) d += B[c * ld + i] * B[c * ld + i];
      if (d >= dmax * (1 - 1e-9)) {
        r = i;
        break;
      }
    }
    double norm2 = 0;
    for (int c = s; c < j; ++c) norm2 += (g[c] = B[c * ld + r]) * B[c * ld + r];
    const double alpha = (g[s] < 0 ? 1.0 : -1.0) * std::sqrt(norm2);  // g -> alpha e_s
    g[s] -= alpha;
    double beta = 0;
    for (int c = s; c < j; ++c) beta += g[c] * g[c];
    if (!(beta > 0)) continue;  // row r is already alpha e_s
    for (int i = 0; i < m; ++i) {
      double w = 0;
      for (int c = s; c < j; ++c) w += B[c * ld + i] * g[c];
      w *= 2 / beta;
      for (int c = s; c < j; ++c) B[c * ld + i] -= w * g[c];
    }
  }
}

}  // namespace coopdyn
