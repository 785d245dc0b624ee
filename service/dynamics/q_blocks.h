// The Cholesky of Q = G M^-1 G^T per arm, coupled through the platform only: linear in the number
// of arms instead of cubic in the rows.
//
// With the constraint specs in groups that share no DOF but a common set C (at most 6 DOFs: the
// platform's or the load's), Q = blkdiag(A_g) + B B^T, and its block Cholesky is exactly the dense
// one: the same pivots, so the fast-path test and the condition estimate are QSolver's (q_solve.h).
// With nominal base links the factor is that of R Q R^T with the nominal rows last, as
// QSolver::factor_nominal_last.
//
// Where the structure does not hold (fewer than two groups, a group's rows not contiguous in the
// spec order, more than 6 common DOFs or 12 rows in a group) plan() leaves it unusable; where Q is
// not positive definite to the fast-path tolerance, factor() returns false and the caller takes the
// dense path (the rank-revealing solve of q_solve.h). Sized once; allocation-free afterwards.
// The recurrences and the nominal rows: docs/method.md, "The block factor of Q".
#pragma once

#include <utility>
#include <vector>

#include <Eigen/Core>

#include "service/dynamics/system.h"

namespace coopdyn {

struct QBlocks {
  static constexpr int kMaxCommon = 6, kMaxGroupRows = 12;
  using GMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxGroupRows, kMaxGroupRows>;
  using GBMat = Eigen::Matrix<double, Eigen::Dynamic, kMaxCommon, 0, kMaxGroupRows, kMaxCommon>;
  using GVec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxGroupRows, 1>;
  struct Group {
    int spec0 = 0, spec1 = 0;  // specs [spec0, spec1)
    int row0 = 0, rows = 0;    // rows [row0, row0 + rows) of Q
    GMat A;    // (rows x rows) Y_g Y_g^T over the group's own DOFs; then L_g (lower) in place
    GBMat B;   // (rows x 6) Y_g on the common DOFs (columns beyond |C| zero)
    GBMat W;   // (rows x 6) L_g^-1 B_g P_g
    GVec dinv; // (rows) 1 / diag(L_g)
    // the nominal directions in this group: (velocity index of joint 1, first row of its weld in the group)
    std::vector<std::pair<int, int>> nominal;
    int red_rows = 0;      // rows of the reduced Q in this group (rows less the directions dropped)
    GMat Ar;               // (red_rows x red_rows) the reduced A_g (H A_g H without the dropped rows); then its factor
    GBMat Br, Wr;          // (red_rows x 6) H B_g without the dropped rows; L_g^-1 B_g P_g of the reduced factor
    GVec dinvr;            // (red_rows) 1 / diag of the reduced factor
    GVec keep;             // (rows) 1 for a row kept in the reduced Q, else 0
    // the single factor with the nominal rows last (has_nominal)
    int nd = 0;            // the group's dropped rows this evaluation (at most nominal.size())
    int d0 = 0;            // the first of them among the N dropped rows of Q
    std::vector<Vec6> hw;  // (nominal.size()) H = I - w w^T on the weld's rows (w = 0: none)
    std::vector<Vec6> u_ref;  // (nominal.size()) the reference directions (set_nominal_reference), else empty
    bool at_ref = false;      // hw, keep, kept_idx, drop_idx, red_rows are u_ref's
    int kept_idx[kMaxGroupRows] = {}, drop_idx[kMaxGroupRows] = {};  // local rows kept, dropped
    GMat Ad;               // (red_rows x nd) H A_g H (kept, dropped)
    Eigen::MatrixXd Yt;    // (P_max x kMaxGroupRows) Y_g^T: column i is reduced row i's N entries of L_dr
    // pairs of specs s <= t of the group with the ranges [first, first + second) of own DOFs both reach
    struct Pair {
      int s, t;
      std::vector<std::pair<int, int>> ranges;
    };
    std::vector<Pair> pairs;
  };

  // y_support: per spec, the DOFs its rows of Y reach (ascending). nominal_rows: (velocity index of
  // joint 1, first row of the base weld) per nominal base link (System::nominal_bases).
  void plan(const System& sys, const std::vector<std::vector<int>>& y_support,
            const std::vector<std::pair<int, int>>& nominal_rows = {});

  // A_g and B_g from Yb (per spec, nv x 6 row-major: its rows of Y as columns, one DOF per row).
  template <class YBlock>
  void assemble(const System& sys, const std::vector<YBlock>& Yb);
  // The block Cholesky; false if a pivot is not positive or the smallest pivot is below fast_tol
  // times the largest (QSolver's fast-path test), else *condition = (largest / smallest diagonal)^2.
  // With nominal directions (G: the constraint rows, for joint 1's column in the base weld), the
  // same test on the reduced Q decides and *condition is the reduced Q's ratio.
  bool factor(const SolverOptions& opt, const Eigen::MatrixXd& G, double* condition);
  // The reflections and the kept and dropped rows of the nominal directions for G (has_nominal).
  // factor() takes them from here when called since its last run (the same G), else computes them:
  // the caller runs this before work that does not need them (build_q: before the L^-T sweep of Y),
  // so that their chain of square roots and divisions overlaps it.
  void prepare_nominal(const Eigen::MatrixXd& G);
  // Start-up: the reflections of the nominal directions for the constraint rows G of one configuration
  // (the scene's initial one). Each nominal direction is the joint's motion in the weld frame, the same
  // vector in every configuration up to its round-off; prepare_nominal() keeps these reflections for
  // a G whose directions equal the reference's to kNominalRefTol (relative, per entry, and the same exact
  // zeros), so that the chain of square roots and divisions is not taken at every evaluation, and
  // computes them from G otherwise. The reflection then differs from G's own by at most about that
  // tolerance: the factor is of the same Q in a basis orthogonal to round-off, the condition the
  // reduced Q's to about kNominalRefTol times it.
  void set_nominal_reference(const Eigen::MatrixXd& G);
  static constexpr double kNominalRefTol = 2e-15;
  // Whether u is the reference direction ur to round-off: the same exact zeros (so the same rule: a
  // reflection or the one row u lies along) and every entry within kNominalRefTol |ur|_inf of ur's
  // (also QSolver's dense path).
  static bool near_reference(const Vec6& u, const Vec6& ur);
  // x = Q^-1 b (x may not alias b).
  void solve(const Eigen::VectorXd& b, Eigen::VectorXd& x);

  bool usable = false;
  bool has_nominal = false;  // some group has a nominal direction: the single factor with them last
  bool prepared = false;     // prepare_nominal() ran since the last factor()
  std::vector<int> common;  // the DOFs every spec reaches, ascending
  std::vector<Group> groups;
  Mat6 P;
  // the single factor with the nominal rows last (has_nominal), N_max = the nominal directions
  int nd = 0;              // N: the dropped rows this evaluation
  int np = 0;              // N padded to the width of the fixed kernels (4, 8, else N)
  Eigen::MatrixXd S;       // (P_max x P_max, P_max = N_max padded as np) Schur complement of the dropped rows; then L_S (lower)
  Eigen::VectorXd sdinv;   // (N_max) 1 / diag(L_S)
  Eigen::MatrixXd Zt;      // (P_max x 6) Z^T of the factorization; Bd first
  Eigen::VectorXd xd;      // (P_max) the dropped rows' part of a solve
  Eigen::VectorXd xr;      // (rows of Q) the reduced rows' part of a solve, group by group

 private:
  bool factor_nominal_last(const SolverOptions& opt, const Eigen::MatrixXd& G, double* condition);
  void solve_nominal_last(const Eigen::VectorXd& b, Eigen::VectorXd& x);
};

// The 6 x 6 block Y_s^T Y_t of two specs' rows of Y (ys, yt: YBlock, row-major, a DOF's row at
// stride S >= 6): the sum over the DOFs both reach (ranges) of the outer products ys.row(d)^T
// yt.row(d), each entry's multiply-adds in the order of d. Kept by rows 0-3 and 4-5 (a 4-wide and a
// 2-wide vector per column, where a 6-vector is three 2-wide ones); for a spec with itself (same)
// only rows 4-5's last two columns besides rows 0-3, the rest of rows 4-5 mirrored from rows 0-3's
// last two columns (the same products: fma(x, y, z) = fma(y, x, z)). Bit for bit the plain 6 x 6 sums.
template <class YBlock>
Mat6 pair_block(const YBlock& ys, const YBlock& yt, const std::vector<std::pair<int, int>>& ranges, bool same) {
  using Row6 = Eigen::Matrix<double, 1, 6>;
  constexpr int S = YBlock::ColsAtCompileTime;
  Eigen::Matrix<double, 4, 6> top = Eigen::Matrix<double, 4, 6>::Zero();
  Eigen::Matrix<double, 2, 6> bot = Eigen::Matrix<double, 2, 6>::Zero();
  Eigen::Matrix2d corner = Eigen::Matrix2d::Zero();
  for (const auto& rg : ranges)
    for (int d = rg.first, e = rg.first + rg.second; d < e; ++d) {
      const double* a = ys.data() + S * d;
      const double* b = yt.data() + S * d;
      top.noalias() += Eigen::Map<const Eigen::Vector4d>(a) * Eigen::Map<const Row6>(b);
      if (same) corner.noalias() += Eigen::Map<const Eigen::Vector2d>(a + 4) * Eigen::Map<const Eigen::RowVector2d>(b + 4);
      else bot.noalias() += Eigen::Map<const Eigen::Vector2d>(a + 4) * Eigen::Map<const Row6>(b);
    }
  Mat6 acc;
  acc.template topRows<4>() = top;
  if (same) {
    acc.template bottomLeftCorner<2, 4>() = top.template rightCols<2>().transpose();
    acc.template bottomRightCorner<2, 2>() = corner;
  } else {
    acc.template bottomRows<2>() = bot;
  }
  return acc;
}

template <class YBlock>
void QBlocks::assemble(const System& sys, const std::vector<YBlock>& Yb) {
  const ConstraintSet& cs = sys.constraints;
  const int nc = static_cast<int>(common.size());
  constexpr int S = YBlock::ColsAtCompileTime;
  for (Group& g : groups) {
    for (int s = g.spec0; s < g.spec1; ++s) {
      const int o = cs.row_offset[s] - g.row0, nk = cs.row_count[s];
      const double* y = Yb[s].data();
      for (int c = 0; c < nc; ++c) {
        double* bc = &g.B(o, c);
        const double* yc = y + S * common[c];
        if (nk == 6) Eigen::Map<Vec6>{bc} = Eigen::Map<const Vec6>(yc);
        else
          for (int k = 0; k < nk; ++k) bc[k] = yc[k];
      }
    }
    for (const Group::Pair& p : g.pairs) {
      const Mat6 acc = pair_block(Yb[p.s], Yb[p.t], p.ranges, p.s == p.t);
      const int rs = cs.row_offset[p.s] - g.row0, rt = cs.row_offset[p.t] - g.row0;
      const int ks = cs.row_count[p.s], kt = cs.row_count[p.t];
      if (ks == 6 && kt == 6 && g.rows == 6) {  // a group of one weld: its A is the block
        Eigen::Map<Mat6>{g.A.data()} = acc;
        continue;
      }
      for (int i = 0; i < ks; ++i)
        for (int j = 0; j < kt; ++j) {
          g.A(rs + i, rt + j) = acc(i, j);
          g.A(rt + j, rs + i) = acc(i, j);
        }
    }
  }
}

}  // namespace coopdyn
