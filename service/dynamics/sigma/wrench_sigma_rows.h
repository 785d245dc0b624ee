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

// The change to a report frame, [Rt (n - p x f); Rt f] of a wrench [n; f] (world, at p_ref), as
// scalars a column loop keeps in registers
struct FrameChange {
  double px, py, pz, r00, r01, r02, r10, r11, r12, r20, r21, r22;
  FrameChange(const Mat3& Rt, const Vec3& p)
      : px(p.x()), py(p.y()), pz(p.z()), r00(Rt(0, 0)), r01(Rt(0, 1)), r02(Rt(0, 2)), r10(Rt(1, 0)), r11(Rt(1, 1)),
        r12(Rt(1, 2)), r20(Rt(2, 0)), r21(Rt(2, 1)), r22(Rt(2, 2)) {}
  // column j of 6 rows of stride lo at o <- the change of [d0 d1 d2; f0 f1 f2]
  inline void put(double d0, double d1, double d2, double f0, double f1, double f2, double* __restrict o, Eigen::Index lo,
                  int j) const {
    const double n0 = d0 - (py * f2 - pz * f1), n1 = d1 - (pz * f0 - px * f2), n2 = d2 - (px * f1 - py * f0);
    o[j] = r00 * n0 + r01 * n1 + r02 * n2;
    o[lo + j] = r10 * n0 + r11 * n1 + r12 * n2;
    o[2 * lo + j] = r20 * n0 + r21 * n1 + r22 * n2;
    o[3 * lo + j] = r00 * f0 + r01 * f1 + r02 * f2;
    o[4 * lo + j] = r10 * f0 + r11 * f1 + r12 * f2;
    o[5 * lo + j] = r20 * f0 + r21 * f1 + r22 * f2;
  }
};

// C = [Rt (n - p x f); Rt f] for D = [n; f] on 6 rows of nc columns (row r of D at d + r ld, of C
// at o + r lo)
inline void to_frame(const Mat3& Rt, const Vec3& p, const double* __restrict d, Eigen::Index ld, double* __restrict o,
              Eigen::Index lo, int nc) {
  const FrameChange F(Rt, p);
#pragma GCC ivdep
  for (int j = 0; j < nc; ++j) F.put(d[j], d[ld + j], d[2 * ld + j], d[3 * ld + j], d[4 * ld + j], d[5 * ld + j], o, lo, j);
}

// The reaction pass's blocks (6 x nc per body) are compact: row r of a block at r nc, so that with
// a compile-time column count (std::integral_constant) every address in the kernels below is a
// fixed offset from the block's start (a runtime stride holds a register per row, and the kernels
// ran out of them).

// A = P - s x on a 6 x nc block: a body's acceleration change from its parent's over its joint's
// one DOF, s = -S (the DOF's motion axis negated, as the pass's row operations take it: the same
// products), column by column
template <class Nc>
inline void accel_one(const double* __restrict pa, const double* __restrict s, const double* __restrict x, double* __restrict a,
                      Nc nc) {
  const int la = nc;
  const double s0 = s[0], s1 = s[1], s2 = s[2], s3 = s[3], s4 = s[4], s5 = s[5];
#pragma GCC ivdep
  for (int c = 0; c < la; ++c) {
    const double xc = x[c];
    a[c] = pa[c] - s0 * xc, a[la + c] = pa[la + c] - s1 * xc, a[2 * la + c] = pa[2 * la + c] - s2 * xc;
    a[3 * la + c] = pa[3 * la + c] - s3 * xc, a[4 * la + c] = pa[4 * la + c] - s4 * xc, a[5 * la + c] = pa[5 * la + c] - s5 * xc;
  }
}

// One body of the reaction pass on 6 x nc blocks, column by column: acc (in: its children's sum)
// += I a; rb = acc [+ I_fix a]; parent's acc += acc, in the order of the row operations this
// replaced. A rigid inertia by its parts: n = Io w + h x v, f = m v - h x w (the 6 x 6 matrix
// without its zeros and repeats: 24 multiply-adds a column instead of 36). ivdep here and in the
// other column loops: the rows never overlap, and without it GCC leaves these loops scalar.
template <bool kInertia, bool kFix, bool kParent, class Nc>
inline void reaction_body(const RigidInertia& I, const RigidInertia& If, const double* __restrict a, double* __restrict acc,
                          double* __restrict rb, double* __restrict accp, Nc nc) {
  const int la = nc;
  const double m = I.m, hx = I.h.x(), hy = I.h.y(), hz = I.h.z();
  const double j00 = I.Io(0, 0), j01 = I.Io(0, 1), j02 = I.Io(0, 2), j10 = I.Io(1, 0), j11 = I.Io(1, 1), j12 = I.Io(1, 2),
               j20 = I.Io(2, 0), j21 = I.Io(2, 1), j22 = I.Io(2, 2);
  const double fm = If.m, fx = If.h.x(), fy = If.h.y(), fz = If.h.z();
  const double k00 = If.Io(0, 0), k01 = If.Io(0, 1), k02 = If.Io(0, 2), k10 = If.Io(1, 0), k11 = If.Io(1, 1), k12 = If.Io(1, 2),
               k20 = If.Io(2, 0), k21 = If.Io(2, 1), k22 = If.Io(2, 2);
#pragma GCC ivdep
  for (int c = 0; c < la; ++c) {
    const double wx = a[c], wy = a[la + c], wz = a[2 * la + c], vx = a[3 * la + c], vy = a[4 * la + c], vz = a[5 * la + c];
    double r0 = acc[c], r1 = acc[la + c], r2 = acc[2 * la + c], r3 = acc[3 * la + c], r4 = acc[4 * la + c], r5 = acc[5 * la + c];
    if constexpr (kInertia) {
      const double x0 = j00 * wx + j01 * wy + j02 * wz + hy * vz - hz * vy;
      const double x1 = j10 * wx + j11 * wy + j12 * wz + hz * vx - hx * vz;
      const double x2 = j20 * wx + j21 * wy + j22 * wz + hx * vy - hy * vx;
      const double x3 = m * vx - (hy * wz - hz * wy), x4 = m * vy - (hz * wx - hx * wz), x5 = m * vz - (hx * wy - hy * wx);
      r0 += x0, r1 += x1, r2 += x2, r3 += x3, r4 += x4, r5 += x5;
    }
    if constexpr (kParent) {
      accp[c] += r0, accp[la + c] += r1, accp[2 * la + c] += r2, accp[3 * la + c] += r3, accp[4 * la + c] += r4,
          accp[5 * la + c] += r5;
    }
    if constexpr (kFix) {
      const double x0 = k00 * wx + k01 * wy + k02 * wz + fy * vz - fz * vy;
      const double x1 = k10 * wx + k11 * wy + k12 * wz + fz * vx - fx * vz;
      const double x2 = k20 * wx + k21 * wy + k22 * wz + fx * vy - fy * vx;
      const double x3 = fm * vx - (fy * wz - fz * wy), x4 = fm * vy - (fz * wx - fx * wz), x5 = fm * vz - (fx * wy - fy * wx);
      r0 += x0, r1 += x1, r2 += x2, r3 += x3, r4 += x4, r5 += x5;
    }
    rb[c] = r0, rb[la + c] = r1, rb[2 * la + c] = r2, rb[3 * la + c] = r3, rb[4 * la + c] = r4, rb[5 * la + c] = r5;
  }
}

// to_frame of D = R + sum_t g_t F_t (kNs of them: a reaction's specs' forces, g_t = +-1) without
// forming D: R a compact 6 x nc block, F_t 6 rows of stride lf, the output 6 rows of stride lo.
// FrameChange's arithmetic written out: through FrameChange::put this loop is slower, where
// to_frame is not (bench/README.md, "Each wrench's sigma: the cost").
template <int kNs, class Nc>
inline void to_frame_sum(const Mat3& Rt, const Vec3& p, const double* __restrict r, const double* const* f, const double* g,
                         Eigen::Index lf, double* __restrict o, Eigen::Index lo, Nc nc) {
  const int lr = nc;
  const double px = p.x(), py = p.y(), pz = p.z();
  const double r00 = Rt(0, 0), r01 = Rt(0, 1), r02 = Rt(0, 2), r10 = Rt(1, 0), r11 = Rt(1, 1), r12 = Rt(1, 2), r20 = Rt(2, 0),
               r21 = Rt(2, 1), r22 = Rt(2, 2);
  const double* __restrict fa = kNs > 0 ? f[0] : nullptr;
  const double* __restrict fb = kNs > 1 ? f[1] : nullptr;
  const double ga = kNs > 0 ? g[0] : 0.0, gb = kNs > 1 ? g[1] : 0.0;
#pragma GCC ivdep
  for (int j = 0; j < lr; ++j) {
    double d[6];
    for (int k = 0; k < 6; ++k) {
      d[k] = r[k * lr + j];
      if constexpr (kNs > 0) d[k] += ga * fa[k * lf + j];
      if constexpr (kNs > 1) d[k] += gb * fb[k * lf + j];
    }
    const double f0 = d[3], f1 = d[4], f2 = d[5];
    const double n0 = d[0] - (py * f2 - pz * f1), n1 = d[1] - (pz * f0 - px * f2), n2 = d[2] - (px * f1 - py * f0);
    o[j] = r00 * n0 + r01 * n1 + r02 * n2;
    o[lo + j] = r10 * n0 + r11 * n1 + r12 * n2;
    o[2 * lo + j] = r20 * n0 + r21 * n1 + r22 * n2;
    o[3 * lo + j] = r00 * f0 + r01 * f1 + r02 * f2;
    o[4 * lo + j] = r10 * f0 + r11 * f1 + r12 * f2;
    o[5 * lo + j] = r20 * f0 + r21 * f1 + r22 * f2;
  }
}

}  // namespace coopdyn::sigma_rows
