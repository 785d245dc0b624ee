// Row kernels of each wrench's sigma (wrench_sigma.cc): operations on rows of
// row-major blocks of columns (one column per noise source), contiguous so that they vectorize.
// Internal to the sigma; allocation-free.
#pragma once

#include <type_traits>

#include <Eigen/Core>

#include "service/spatial/spatial.h"

namespace coopdyn::sigma_rows {

// row a -= f * row b over nc entries (row-major rows: contiguous, vectorized)
// A compile-time column count (std::integral_constant): the row as a fixed-size vector, whose
// operations Eigen writes as whole vector registers (a plain loop of a known short count GCC
// unrolls into scalar operations before it vectorizes).
template <class Nc>
using FixedRow = Eigen::Map<Eigen::Matrix<double, 1, Nc::value>>;
template <class Nc>
using ConstFixedRow = Eigen::Map<const Eigen::Matrix<double, 1, Nc::value>>;
// f(offset, count) over a row of K columns in parts whose count Eigen runs at its widest vectors:
// the multiples of 8, then the rest (Eigen runs a fixed row of 12 or 18 at the widest width that
// divides it: 4 or 2)
template <int K, class F>
inline void in_parts(F&& f) {
  constexpr int head = K - K % 8;
  if constexpr (head > 0) f(std::integral_constant<int, 0>{}, std::integral_constant<int, head>{});
  if constexpr (K % 8 > 0) f(std::integral_constant<int, head>{}, std::integral_constant<int, K % 8>{});
}

template <class Nc>
inline void axpy_row(double* __restrict a, const double* __restrict b, double f, Nc nc) {
  if constexpr (std::is_same_v<Nc, int>) {
    for (int c = 0; c < nc; ++c) a[c] -= f * b[c];
  } else {
    in_parts<Nc::value>([&](auto o, auto n) { FixedRow<decltype(n)>(a + o) -= f * ConstFixedRow<decltype(n)>(b + o); });
  }
}
template <class Nc>
inline void scale_row(double* a, double f, Nc nc) {
  if constexpr (std::is_same_v<Nc, int>) {
    for (int c = 0; c < nc; ++c) a[c] *= f;
  } else {
    in_parts<Nc::value>([&](auto o, auto n) { FixedRow<decltype(n)>(a + o) *= f; });
  }
}

// rows 0:n, columns 0:nc: to = from, or a = 0 (strides lf, lt, ld)
template <class Nc>
inline void copy_block(const double* __restrict from, Eigen::Index lf, double* __restrict to, Eigen::Index lt, int n, Nc nc) {
  for (int r = 0; r < n; ++r)
    if constexpr (std::is_same_v<Nc, int>) {
      for (int c = 0; c < nc; ++c) to[r * lt + c] = from[r * lf + c];
    } else {
      FixedRow<Nc>(to + r * lt) = ConstFixedRow<Nc>(from + r * lf);
    }
}
template <class Nc>
inline void zero_block(double* a, Eigen::Index ld, int n, Nc nc) {
  for (int r = 0; r < n; ++r)
    if constexpr (std::is_same_v<Nc, int>) {
      for (int c = 0; c < nc; ++c) a[r * ld + c] = 0.0;
    } else {
      FixedRow<Nc>(a + r * ld).setZero();
    }
}

// the first nc entries of 6 rows of stride ld (a body's or spec's 6 x nc block)
template <class Nc>
inline void copy_rows(const double* __restrict from, double* __restrict to, Eigen::Index ld, Nc nc) {
  copy_block(from, ld, to, ld, 6, nc);
}
template <class Nc>
inline void zero_rows(double* a, Eigen::Index ld, Nc nc) {
  zero_block(a, ld, 6, nc);
}

// Row r, columns 0:nc, of a row-major matrix: contiguous, so that the sums of rows below vectorize.
template <class Mat, class Nc>
inline auto row(Mat& M, Eigen::Index r, Nc nc) {
  if constexpr (std::is_same_v<Nc, int>) return M.row(r).head(nc);
  else return M.row(r).template head<Nc::value>();
}

// N (+)= I A for a rigid inertia on 6 rows of nc columns (row r of A at a + r la, of N at
// n + r ln): n = Io w + h x v, f = m v - h x w (the 6 x 6 inertia matrix without its zeros and
// repeats: 24 multiply-adds a column instead of 36). ivdep here and in to_frame: the rows never
// overlap, and without it GCC leaves these loops scalar (a quarter slower at 48 columns).
template <bool kAdd>
inline void inertia_times(const RigidInertia& I, const double* __restrict a, Eigen::Index la, double* __restrict n,
                   Eigen::Index ln, int nc) {
  const double m = I.m, hx = I.h.x(), hy = I.h.y(), hz = I.h.z();
  const double j00 = I.Io(0, 0), j01 = I.Io(0, 1), j02 = I.Io(0, 2), j10 = I.Io(1, 0), j11 = I.Io(1, 1), j12 = I.Io(1, 2),
               j20 = I.Io(2, 0), j21 = I.Io(2, 1), j22 = I.Io(2, 2);
#pragma GCC ivdep
  for (int c = 0; c < nc; ++c) {
    const double wx = a[c], wy = a[la + c], wz = a[2 * la + c], vx = a[3 * la + c], vy = a[4 * la + c], vz = a[5 * la + c];
    const double x0 = j00 * wx + j01 * wy + j02 * wz + hy * vz - hz * vy;
    const double x1 = j10 * wx + j11 * wy + j12 * wz + hz * vx - hx * vz;
    const double x2 = j20 * wx + j21 * wy + j22 * wz + hx * vy - hy * vx;
    const double x3 = m * vx - (hy * wz - hz * wy), x4 = m * vy - (hz * wx - hx * wz), x5 = m * vz - (hx * wy - hy * wx);
    if constexpr (kAdd) {
      n[c] += x0, n[ln + c] += x1, n[2 * ln + c] += x2, n[3 * ln + c] += x3, n[4 * ln + c] += x4, n[5 * ln + c] += x5;
    } else {
      n[c] = x0, n[ln + c] = x1, n[2 * ln + c] = x2, n[3 * ln + c] = x3, n[4 * ln + c] = x4, n[5 * ln + c] = x5;
    }
  }
}

// C = [Rt (n - p x f); Rt f] for D = [n; f] on 6 rows of nc columns (row r of D at d + r ld, of C
// at o + r lo)
inline void to_frame(const Mat3& Rt, const Vec3& p, const double* __restrict d, Eigen::Index ld, double* __restrict o,
              Eigen::Index lo, int nc) {
  const double px = p.x(), py = p.y(), pz = p.z();
  const double r00 = Rt(0, 0), r01 = Rt(0, 1), r02 = Rt(0, 2), r10 = Rt(1, 0), r11 = Rt(1, 1), r12 = Rt(1, 2), r20 = Rt(2, 0),
               r21 = Rt(2, 1), r22 = Rt(2, 2);
#pragma GCC ivdep
  for (int j = 0; j < nc; ++j) {
    const double f0 = d[3 * ld + j], f1 = d[4 * ld + j], f2 = d[5 * ld + j];
    const double n0 = d[j] - (py * f2 - pz * f1), n1 = d[ld + j] - (pz * f0 - px * f2), n2 = d[2 * ld + j] - (px * f1 - py * f0);
    o[j] = r00 * n0 + r01 * n1 + r02 * n2;
    o[lo + j] = r10 * n0 + r11 * n1 + r12 * n2;
    o[2 * lo + j] = r20 * n0 + r21 * n1 + r22 * n2;
    o[3 * lo + j] = r00 * f0 + r01 * f1 + r02 * f2;
    o[4 * lo + j] = r10 * f0 + r11 * f1 + r12 * f2;
    o[5 * lo + j] = r20 * f0 + r21 * f1 + r22 * f2;
  }
}

}  // namespace coopdyn::sigma_rows
