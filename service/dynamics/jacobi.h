// Allocation-free Jacobi decompositions for the small dense matrices of the constraint solve.
//
// Eigen's SelfAdjointEigenSolver and JacobiSVD allocate temporaries inside compute(); the loop may
// not. Cyclic Jacobi is also the most accurate method for small symmetric matrices (relative
// accuracy of small eigenvalues), converging quadratically; sizes here are <= a few dozen.
#pragma once

#include <cmath>

#include <Eigen/Core>

namespace coopdyn {

// Symmetric eigen-decomposition A = V diag(w) V^T, eigenvalues ascending. A (n x n) is used as
// workspace and destroyed; w (n) and V (n x n) must be sized. Returns the sweeps used.
template <typename MatA, typename VecW, typename MatV>
int jacobi_eigen(MatA& A, VecW& w, MatV& V, int max_sweeps = 30) {
  const int n = static_cast<int>(A.rows());
  V.setIdentity();
  int sweep = 0;
  for (; sweep < max_sweeps; ++sweep) {
    double off = 0.0, diag = 0.0;
    for (int p = 0; p < n; ++p) {
      diag += A(p, p) * A(p, p);
      for (int q = p + 1; q < n; ++q) off += A(p, q) * A(p, q);
    }
    if (off <= 1e-32 * diag || off == 0.0) break;
    for (int p = 0; p < n - 1; ++p)
      for (int q = p + 1; q < n; ++q) {
        const double apq = A(p, q);
        if (apq == 0.0) continue;
        const double theta = (A(q, q) - A(p, p)) / (2.0 * apq);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
        for (int k = 0; k < n; ++k) {  // A <- A J (columns p, q)
          const double akp = A(k, p), akq = A(k, q);
          A(k, p) = c * akp - s * akq;
          A(k, q) = s * akp + c * akq;
        }
        for (int k = 0; k < n; ++k) {  // A <- J^T A (rows p, q)
          const double apk = A(p, k), aqk = A(q, k);
          A(p, k) = c * apk - s * aqk;
          A(q, k) = s * apk + c * aqk;
        }
        for (int k = 0; k < n; ++k) {
          const double vkp = V(k, p), vkq = V(k, q);
          V(k, p) = c * vkp - s * vkq;
          V(k, q) = s * vkp + c * vkq;
        }
      }
  }
  for (int i = 0; i < n; ++i) w[i] = A(i, i);
  for (int i = 0; i < n - 1; ++i) {  // selection sort, ascending
    int k = i;
    for (int j = i + 1; j < n; ++j)
      if (w[j] < w[k]) k = j;
    if (k != i) {
      std::swap(w[i], w[k]);
      V.col(i).swap(V.col(k));
    }
  }
  return sweep;
}

// One-sided (Hestenes) Jacobi SVD of the rows of B (k x n): rotations from the left orthogonalize
// the rows, so that U^T B has orthogonal rows whose norms are the singular values. On return B holds
// U^T B, U (k x k) the left singular vectors as columns and s (k) the singular values, descending.
template <typename MatB, typename MatU, typename VecS>
void jacobi_svd_rows(MatB& B, MatU& U, VecS& s, int max_sweeps = 30) {
  const int k = static_cast<int>(B.rows());
  U.setIdentity();
  for (int sweep = 0; sweep < max_sweeps; ++sweep) {
    bool rotated = false;
    for (int p = 0; p < k - 1; ++p)
      for (int q = p + 1; q < k; ++q) {
        const double a = B.row(p).squaredNorm(), b = B.row(q).squaredNorm(), g = B.row(p).dot(B.row(q));
        if (std::abs(g) <= 1e-15 * std::sqrt(a * b) || g == 0.0) continue;
        rotated = true;
        const double zeta = (b - a) / (2.0 * g);
        const double t = (zeta >= 0 ? 1.0 : -1.0) / (std::abs(zeta) + std::sqrt(1.0 + zeta * zeta));
        const double c = 1.0 / std::sqrt(1.0 + t * t), sn = c * t;
        for (int j = 0; j < B.cols(); ++j) {
          const double bp = B(p, j), bq = B(q, j);
          B(p, j) = c * bp - sn * bq;
          B(q, j) = sn * bp + c * bq;
        }
        for (int j = 0; j < k; ++j) {
          const double up = U(j, p), uq = U(j, q);
          U(j, p) = c * up - sn * uq;
          U(j, q) = sn * up + c * uq;
        }
      }
    if (!rotated) break;
  }
  for (int i = 0; i < k; ++i) s[i] = B.row(i).norm();
  for (int i = 0; i < k - 1; ++i) {  // descending
    int m = i;
    for (int j = i + 1; j < k; ++j)
      if (s[j] > s[m]) m = j;
    if (m != i) {
      std::swap(s[i], s[m]);
      B.row(i).swap(B.row(m));
      U.col(i).swap(U.col(m));
    }
  }
}

}  // namespace coopdyn
