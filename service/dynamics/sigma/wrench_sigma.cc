#include "service/dynamics/sigma/wrench_sigma.h"

#include <cmath>
#include <type_traits>

#include "service/algorithms/kinematics.h"
#include "service/algorithms/rnea.h"
#include "service/algorithms/tree_cholesky.h"
#include "service/dynamics/sigma/wrench_sigma_arms.h"
#include "service/dynamics/sigma/wrench_sigma_position.h"
#include "service/dynamics/sigma/wrench_sigma_rows.h"
#include "service/dynamics/sigma/wrench_sigma_velocity.h"

namespace coopdyn {

namespace {
using RowMat = WrenchSigmaData::RowMat;
using namespace sigma_rows;

bool positive(const Eigen::VectorXd& x) { return x.size() > 0 && x.maxCoeff() > 0.0; }

// Each reaction's DOFs for the composite form (WrenchSigmaData::composite) and whether it takes
// far fewer multiply-adds a column than the pass (what both share, the specs' forces and the frame,
// left out)
void composite_plan(const System& sys, WrenchSigmaData& sd) {
  const Model& model = sys.model;
  const WrenchSet& set = sys.wrenches;
  const size_t no = set.outputs.size();
  sd.out_up.assign(no, {});
  sd.out_down.assign(no, {});
  sd.U.assign(no, Eigen::Matrix<double, 6, Eigen::Dynamic>());
  long pass_cost = 0, composite_cost = 0;
  for (int i : set.pass) {  // accelerations, inertia, subtree sum, copies
    const Body& b = model.bodies[i];
    pass_cost += 6 * b.joint.nv + 24 + 6 + 6 + 6 + 6 + (b.joint.type == JointType::kFixed && b.parent >= 0 ? 24 : 0);
  }
  for (size_t k = 0; k < no; ++k) {
    const int b = set.outputs[k].body;
    if (set.outputs[k].spec >= 0) continue;
    for (int i = b; i >= 0; i = model.bodies[i].parent)
      for (int c = 0; c < model.bodies[i].joint.nv; ++c) sd.out_up[k].push_back(model.bodies[i].joint.idx_v + c);
    for (int j = b + 1; j < model.nbodies(); ++j)
      if (model.is_ancestor(b, j))
        for (int c = 0; c < model.bodies[j].joint.nv; ++c) sd.out_down[k].push_back(model.bodies[j].joint.idx_v + c);
    sd.U[k].setZero(6, static_cast<Eigen::Index>(sd.out_up[k].size()));
    composite_cost += 6 * static_cast<long>(sd.out_up[k].size() + sd.out_down[k].size()) - 6;
  }
  // measured (compute_wrench_sigma, simulate mode): the composite form's per-term overhead and its
  // per-evaluation coefficients make it pay only well below the pass's count (PUMAs without joint
  // reactions: 1/6 of it, 20-30 % faster; planar arms with every reaction: 0.8 of it, 25 % slower)
  sd.composite = !set.pass.empty() && 4 * composite_cost <= pass_cost;
  sd.Ic.assign(static_cast<size_t>(model.nbodies()), RigidInertia());
  sd.F_dof.setZero(6, model.nv());
}

}  // namespace

bool wrench_sigma_supported(const System& sys) {
  const Formulation f = sys.options.formulation;
  return (f == Formulation::kMobilePlatform || f == Formulation::kClassic) &&
         (positive(sys.tau_noise) || positive(sys.q_noise) || positive(sys.v_noise));
}

WrenchSigmaData::WrenchSigmaData(const System& sys) {
  const Model& model = sys.model;
  const int n = model.nv(), m = sys.constraints.rows;
  const size_t nb = static_cast<size_t>(model.nbodies()), no = sys.wrenches.outputs.size();
  declared = wrench_sigma_supported(sys);
  for (int i = 0; declared && i < n; ++i) {
    if (sys.tau_noise.size() == n && sys.tau_noise[i] > 0.0) dofs.push_back(i);
    if (sys.q_noise.size() == n && sys.q_noise[i] > 0.0) {
      q_dofs.push_back(i);
      q_index.push_back(model.bodies[model.dof_body[i]].joint.idx_q);
    }
    if (sys.v_noise.size() == n && sys.v_noise[i] > 0.0) v_dofs.push_back(i);
  }
  const int na = static_cast<int>(dofs.size()), nq = static_cast<int>(q_dofs.size()), nv = static_cast<int>(v_dofs.size());
  S.setZero(na);
  Sq.setZero(nq);
  Sv.setZero(nv);
  for (int j = 0; j < na; ++j) S[j] = sys.tau_noise[dofs[static_cast<size_t>(j)]];
  for (int j = 0; j < nq; ++j) Sq[j] = sys.q_noise[q_dofs[static_cast<size_t>(j)]];
  for (int j = 0; j < nv; ++j) Sv[j] = sys.v_noise[v_dofs[static_cast<size_t>(j)]];
  sigma_arms_plan(sys, *this);  // torque noise by arms: its columns share the scratch below
  const int nc = std::max({1, na + nq + nv, arm.usable ? arm.pack + static_cast<int>(arm.common.size()) : 0});
  if (nq + nv > 0)  // a refit fits the floating joints (state_fit.h): their tangents are columns too
    for (const Body& b : model.bodies)
      if (b.joint.type == JointType::kFloating)
        for (int k = 0; k < b.joint.nv; ++k) float_dofs.push_back(b.joint.idx_v + k);
  const int nf = static_cast<int>(float_dofs.size());
  sigma.assign(no, Vec6::Zero());
  C.setZero(6 * static_cast<Eigen::Index>(no), nc);
  Cd.setZero(6 * static_cast<Eigen::Index>(no), std::max(1, nq + nv) + 2 * nf);
  X.setZero(n, nc);
  X0.setZero(n, nc + 2 * nf);
  Lam.setZero(m, nc);
  Lam_prev.setZero(m, nc);
  Rhs.setZero(m, nc);
  Gm.setZero(m, nc + 2 * nf);
  Gv.setZero(m, nq + nf);
  t_column.assign(static_cast<size_t>(nq), 0);
  K.setZero(2 * nf, nq + nv);
  A.setZero(6 * static_cast<Eigen::Index>(nb), nc);
  Rb.setZero(6 * static_cast<Eigen::Index>(nb), nc);
  Acc.setZero(6 * static_cast<Eigen::Index>(nb), nc);
  dF.setZero(6 * static_cast<Eigen::Index>(sys.wrenches.pass_specs.size()), nc);
  Tmp.setZero(6, nc);
  Tmp2.setZero(6, nc);
  I_lin.assign(nb, RigidInertia());
  I_fix.assign(nb, RigidInertia());
  T_spec.assign(sys.constraints.specs.size(), Mat6::Zero());
  unit.setZero(m);
  qrow.assign(static_cast<size_t>(m), 0);
  col_b.setZero(m);
  col_x.setZero(m);
  X_WF.assign(no, Transform());
  if (nq + nv > 0) {
    wp = std::make_unique<Workspace>(sys);
    wd0 = std::make_unique<WrenchData>(sys);
    wd1 = std::make_unique<WrenchData>(sys);
    qp.setZero(model.nq());
    vp.setZero(n);
    tau_id.setZero(n);
    r0_tau.setZero(n);
    r_tau.setZero(n);
    r0_g.setZero(m);
    r_g.setZero(m);
    tv.setZero(n);
    tv_nz.reserve(static_cast<size_t>(n));
    tV.assign(nb, Vec6::Zero());
    tA.assign(nb, Vec6::Zero());
    tF.assign(nb, Vec6::Zero());
    P_W.assign(nb, Vec6::Zero());
    t_moved.assign(nb, 0);
    t_touched.assign(nb, 0);
    tGdot.setZero(m);
    trr.assign(sys.constraints.specs.size(), 0.0);
    I_own.assign(nb, RigidInertia());
    pa.assign(nb, Vec6::Zero());
    pAt.assign(nb, Vec6::Zero());
    pP.assign(nb, Vec6::Zero());
    pF.assign(nb, Vec6::Zero());
    pFs.assign(sys.constraints.specs.size(), Vec6::Zero());
    position_tangent_plan(sys, *this);
  }
  composite_plan(sys, *this);
}

namespace {

// X(:, 0:nc) <- L^-T X, every column at once (tree_solve_Lt on rows)
template <class Nc>
void rows_solve_Lt(const Model& model, const Data& data, RowMat& X, Nc nc) {
  const int* path = model.dof_path.data();
  double* x = X.data();
  const Eigen::Index ld = X.outerStride();
  for (int e = 0; e < model.nv(); ++e) {
    const int i = model.dof_elim_order[e];
    const double* r = tree_factor_row(model, data, i);
    const int* pi = path + model.dof_path_offset[i];
    double* xi = x + i * ld;
    scale_row(xi, data.Ld_inv[i], nc);
    for (int p = 0; p < model.dof_depth[i]; ++p) axpy_row(x + pi[p] * ld, xi, r[p], nc);
  }
}

// X(:, 0:nc) <- L^-1 X (tree_solve_L on rows)
template <class Nc>
void rows_solve_L(const Model& model, const Data& data, RowMat& X, Nc nc) {
  const int* path = model.dof_path.data();
  double* x = X.data();
  const Eigen::Index ld = X.outerStride();
  for (int e = model.nv() - 1; e >= 0; --e) {
    const int i = model.dof_elim_order[e];
    const double* r = tree_factor_row(model, data, i);
    const int* pi = path + model.dof_path_offset[i];
    double* xi = x + i * ld;
    for (int p = 0; p < model.dof_depth[i]; ++p) axpy_row(xi, x + pi[p] * ld, r[p], nc);
    scale_row(xi, data.Ld_inv[i], nc);
  }
}

// Lam = Q^-1 Rhs through the block factor (QBlocks::solve, every column at once, as row operations)
// rows x_0..x_{n-1} (stride ll, nc columns) <- L^-T x, L lower with 1 / diag(L) in dinv: a group's
// backward step, on its full or its reduced factor
template <class Mat, class Vec, class Nc>
void back_substitute_rows(double* x0, int ll, const Mat& L, const Vec& dinv, int n, Nc nc) {
  for (int i = n - 1; i >= 0; --i) {
    double* x = x0 + i * ll;
    for (int k = i + 1; k < n; ++k) axpy_row(x, x0 + k * ll, L(k, i), nc);
    scale_row(x, dinv[i], nc);
  }
}

template <class Nc>
void blocks_solve_rows(QBlocks& qb, WrenchSigmaData& sd, Nc nc) {
  double* z = sd.Tmp.data();  // (6 x nc) the common-DOF sums z, then t
  const Eigen::Index lz = sd.Tmp.outerStride(), ll = sd.Lam.outerStride(), lr = sd.Rhs.outerStride();
  double* lam = sd.Lam.data();
  const double* rhs = sd.Rhs.data();
  zero_rows(z, lz, nc);
  for (QBlocks::Group& g : qb.groups) {  // forward: y_g = L_g^-1 (b_g - B_g z)
    for (int i = 0; i < g.rows; ++i) {
      double* y = lam + (g.row0 + i) * ll;
      const double* b = rhs + (g.row0 + i) * lr;
      for (int c = 0; c < nc; ++c) y[c] = b[c];
      for (int k = 0; k < QBlocks::kMaxCommon; ++k) axpy_row(y, z + k * lz, g.B(i, k), nc);
      for (int k = 0; k < i; ++k) axpy_row(y, lam + (g.row0 + k) * ll, g.A(i, k), nc);
      scale_row(y, g.dinv[i], nc);
    }
    for (int i = 0; i < g.rows; ++i)
      for (int k = 0; k < QBlocks::kMaxCommon; ++k) axpy_row(z + k * lz, lam + (g.row0 + i) * ll, -g.W(i, k), nc);
  }
  zero_rows(z, lz, nc);
  for (auto it = qb.groups.rbegin(); it != qb.groups.rend(); ++it) {  // backward: x_g = L_g^-T (y_g - W_g t)
    QBlocks::Group& g = *it;
    for (int i = 0; i < g.rows; ++i)
      for (int k = 0; k < QBlocks::kMaxCommon; ++k) axpy_row(lam + (g.row0 + i) * ll, z + k * lz, g.W(i, k), nc);
    back_substitute_rows(lam + g.row0 * ll, ll, g.A, g.dinv, g.rows, nc);
    for (int i = 0; i < g.rows; ++i)
      for (int k = 0; k < QBlocks::kMaxCommon; ++k) axpy_row(z + k * lz, lam + (g.row0 + i) * ll, -g.B(i, k), nc);
  }
}

// H = I - w w^T on the 6 rows at x (stride ld), nc columns; w = 0: none
template <class Nc>
void reflect6(const Vec6& w, double* x, Eigen::Index ld, Nc nc) {
  if (w.isZero(0.0)) return;
  for (int c = 0; c < nc; ++c) {
    double t = 0.0;
    for (int k = 0; k < 6; ++k) t += w[k] * x[k * ld + c];
    for (int k = 0; k < 6; ++k) x[k * ld + c] -= t * w[k];
  }
}

// Lam = R Rhs (q_blocks.h, the single factor with the nominal rows last): per group its weld rows
// reflected (in Rhs, scratch), the kept rows to Lam's rows row0.., the dropped after them; sd.qrow
// = the row of Lam of each of the N dropped rows
template <class Nc>
void nominal_rows_in(const QBlocks& qb, WrenchSigmaData& sd, Nc nc) {
  const Eigen::Index lr = sd.Rhs.outerStride();
  for (const QBlocks::Group& g : qb.groups) {
    for (size_t n = 0; n < g.nominal.size(); ++n) reflect6(g.hw[n], sd.Rhs.data() + (g.row0 + g.nominal[n].second) * lr, lr, nc);
    for (int c = 0; c < g.red_rows; ++c) row(sd.Lam, g.row0 + c, nc) = row(sd.Rhs, g.row0 + g.kept_idx[c], nc);
    for (int c = 0; c < g.nd; ++c) {
      sd.qrow[static_cast<size_t>(g.d0 + c)] = g.row0 + g.red_rows + c;
      row(sd.Lam, g.row0 + g.red_rows + c, nc) = row(sd.Rhs, g.row0 + g.drop_idx[c], nc);
    }
  }
}

// Rhs = R^T Lam, then Lam = Rhs (the inverse of nominal_rows_in)
template <class Nc>
void nominal_rows_out(const QBlocks& qb, WrenchSigmaData& sd, Nc nc) {
  const Eigen::Index lr = sd.Rhs.outerStride();
  for (const QBlocks::Group& g : qb.groups) {
    for (int c = 0; c < g.red_rows; ++c) row(sd.Rhs, g.row0 + g.kept_idx[c], nc) = row(sd.Lam, g.row0 + c, nc);
    for (int c = 0; c < g.nd; ++c) row(sd.Rhs, g.row0 + g.drop_idx[c], nc) = row(sd.Lam, g.row0 + g.red_rows + c, nc);
    for (size_t n = 0; n < g.nominal.size(); ++n) reflect6(g.hw[n], sd.Rhs.data() + (g.row0 + g.nominal[n].second) * lr, lr, nc);
  }
  sd.Lam.leftCols(nc) = sd.Rhs.leftCols(nc);
}

// Lam = Q^-1 Rhs through the single block factor with the nominal rows last (QBlocks::solve_nominal_last,
// every column at once, as row operations): y_g = L_g^-1 (b_g - Br_g z), z += Wr_g^T y_g,
// b_d -= Y_g^T y_g; x_d = L_S^-T L_S^-1 b_d; x_g = L_g^-T (y_g - Wr_g t - Y_g x_d), t += Br_g^T x_g
template <class Nc>
void nominal_solve_rows(const QBlocks& qb, WrenchSigmaData& sd, Nc nc) {
  nominal_rows_in(qb, sd, nc);
  double* z = sd.Tmp.data();  // (6 x nc) z, then t
  double* lam = sd.Lam.data();
  const Eigen::Index lz = sd.Tmp.outerStride(), ll = sd.Lam.outerStride();
  auto xd = [&](int d) { return lam + sd.qrow[static_cast<size_t>(d)] * ll; };
  zero_rows(z, lz, nc);
  for (const QBlocks::Group& g : qb.groups) {
    for (int i = 0; i < g.red_rows; ++i) {
      double* y = lam + (g.row0 + i) * ll;
      for (int k = 0; k < QBlocks::kMaxCommon; ++k) axpy_row(y, z + k * lz, g.Br(i, k), nc);
      for (int k = 0; k < i; ++k) axpy_row(y, lam + (g.row0 + k) * ll, g.Ar(i, k), nc);
      scale_row(y, g.dinvr[i], nc);
    }
    for (int i = 0; i < g.red_rows; ++i) {
      const double* y = lam + (g.row0 + i) * ll;
      for (int k = 0; k < QBlocks::kMaxCommon; ++k) axpy_row(z + k * lz, y, -g.Wr(i, k), nc);
      for (int d = 0; d < qb.nd; ++d) axpy_row(xd(d), y, g.Yt(d, i), nc);
    }
  }
  for (int i = 0; i < qb.nd; ++i) {  // L_S^-1, then L_S^-T
    for (int k = 0; k < i; ++k) axpy_row(xd(i), xd(k), qb.S(i, k), nc);
    scale_row(xd(i), qb.sdinv[i], nc);
  }
  for (int i = qb.nd - 1; i >= 0; --i) {
    for (int k = i + 1; k < qb.nd; ++k) axpy_row(xd(i), xd(k), qb.S(k, i), nc);
    scale_row(xd(i), qb.sdinv[i], nc);
  }
  zero_rows(z, lz, nc);
  for (auto it = qb.groups.rbegin(); it != qb.groups.rend(); ++it) {
    const QBlocks::Group& g = *it;
    for (int i = 0; i < g.red_rows; ++i) {
      double* x = lam + (g.row0 + i) * ll;
      for (int k = 0; k < QBlocks::kMaxCommon; ++k) axpy_row(x, z + k * lz, g.Wr(i, k), nc);
      for (int d = 0; d < qb.nd; ++d) axpy_row(x, xd(d), g.Yt(d, i), nc);
    }
    back_substitute_rows(lam + g.row0 * ll, ll, g.Ar, g.dinvr, g.red_rows, nc);
    for (int i = 0; i < g.red_rows; ++i)
      for (int k = 0; k < QBlocks::kMaxCommon; ++k) axpy_row(z + k * lz, lam + (g.row0 + i) * ll, -g.Br(i, k), nc);
  }
  nominal_rows_out(qb, sd, nc);
}

// Lam = Q^-1 Rhs with the evaluation's factorization of Q: the block (either form) or dense Cholesky on all
// columns at once, the rank-revealing solve (over-constrained systems) column by column
template <class Nc>
void q_solve_rows(Workspace& ws, WrenchSigmaData& sd, Nc nc) {
  const int m = ws.qs.m;
  if (ws.q_blocks_active && !ws.qb.has_nominal) return blocks_solve_rows(ws.qb, sd, nc);
  if (ws.q_blocks_active) return nominal_solve_rows(ws.qb, sd, nc);
  if (ws.qs.fast_path) {  // U = L^T, column i of U is row i of L
    const double* u = ws.qs.Lq.data();
    const Eigen::Index ld = ws.qs.Lq.outerStride();
    const QSolver& qs = ws.qs;
    if (qs.nominal_active) {  // the factor of R Q R^T (q_solve.h): Lam = R Rhs, Rhs is scratch
      qs.reflect_rows(sd.Rhs.data(), sd.Rhs.outerStride(), nc);
      for (int i = 0; i < m; ++i) sd.Lam.row(i).head(nc) = sd.Rhs.row(qs.nominal_perm[i]).head(nc);
    } else {
      sd.Lam.leftCols(nc) = sd.Rhs.leftCols(nc);
    }
    double* x = sd.Lam.data();
    const Eigen::Index lx = sd.Lam.outerStride();
    for (int i = 0; i < m; ++i) {
      const double* ui = u + i * ld;
      for (int k = 0; k < i; ++k) axpy_row(x + i * lx, x + k * lx, ui[k], nc);
      scale_row(x + i * lx, ws.qs.dinv_q[i], nc);
    }
    for (int i = m - 1; i >= 0; --i) {
      const double* ui = u + i * ld;
      scale_row(x + i * lx, ws.qs.dinv_q[i], nc);
      for (int k = 0; k < i; ++k) axpy_row(x + k * lx, x + i * lx, ui[k], nc);
    }
    if (qs.nominal_active) {  // Lam = R^T Lam
      for (int i = 0; i < m; ++i) sd.Rhs.row(qs.nominal_perm[i]).head(nc) = sd.Lam.row(i).head(nc);
      qs.reflect_rows(sd.Rhs.data(), sd.Rhs.outerStride(), nc);
      sd.Lam.leftCols(nc) = sd.Rhs.leftCols(nc);
    }
    return;
  }
  for (int j = 0; j < nc; ++j) {
    sd.col_b = sd.Rhs.col(j);
    ws.qs.solve(sd.col_b, sd.col_x);
    sd.Lam.col(j) = sd.col_x;
  }
}

// f(offset, count) over the parts of a row of K columns held in registers: the whole row where K is
// a multiple of 4 (12: three 4-wide registers), else in_parts (18: 8 + 8 + 2 instead of nine
// 2-wide); the choice measured in bench/README.md, "Each wrench's sigma: the cost"
template <int K, class F>
inline void held_parts(F&& f) {
  if constexpr (K % 4 == 0) f(std::integral_constant<int, 0>{}, std::integral_constant<int, K>{});
  else in_parts<K>(f);
}

// Rhs -= Y X over every spec's rows. A spec of 6 rows at a compile-time column count holds its 6
// rows of Rhs in registers over its DOFs (each DOF's row of X loaded once); the same products and
// sums in the same order per row as the row operations.
template <class Nc>
void rows_minus_yx(const ConstraintSet& cs, const Workspace& ws, WrenchSigmaData& sd, Nc nc) {
  double* rhs = sd.Rhs.data();
  const double* x = sd.X.data();
  const Eigen::Index lr = sd.Rhs.outerStride(), lx = sd.X.outerStride();
  for (size_t s = 0; s < cs.specs.size(); ++s) {
    const double* y = ws.Yb[s].data();
    const int r0 = cs.row_offset[s], nk = cs.row_count[s];
    if constexpr (!std::is_same_v<Nc, int>) {
      if (nk == 6) {
        held_parts<Nc::value>([&](auto o, auto n) {
          using Row = Eigen::Matrix<double, 1, decltype(n)::value>;
          using CM = Eigen::Map<const Row>;
          double* b = rhs + r0 * lr + o;
          Row a0 = CM(b), a1 = CM(b + lr), a2 = CM(b + 2 * lr), a3 = CM(b + 3 * lr), a4 = CM(b + 4 * lr), a5 = CM(b + 5 * lr);
          for (int d : ws.y_support[s]) {
            const double* f = y + Workspace::kYStride * d;
            const CM xr(x + d * lx + o);
            a0 -= f[0] * xr, a1 -= f[1] * xr, a2 -= f[2] * xr, a3 -= f[3] * xr, a4 -= f[4] * xr, a5 -= f[5] * xr;
          }
          Eigen::Map<Row> o0(b), o1(b + lr), o2(b + 2 * lr), o3(b + 3 * lr), o4(b + 4 * lr), o5(b + 5 * lr);
          o0 = a0, o1 = a1, o2 = a2, o3 = a3, o4 = a4, o5 = a5;
        });
        continue;
      }
    }
    for (int d : ws.y_support[s])
      for (int k = 0; k < nk; ++k) axpy_row(rhs + (r0 + k) * lr, x + d * lx, y[Workspace::kYStride * d + k], nc);
  }
}

// X += Y^T Lam over every spec's rows (as row operations X -= (-Y^T) Lam). A spec of 6 rows at a
// compile-time column count holds its 6 rows of Lam in registers over its DOFs (each DOF's row of
// X loaded and stored once per spec); the same products and sums in the same order per row.
template <class Nc>
void rows_plus_ytlam(const ConstraintSet& cs, const Workspace& ws, WrenchSigmaData& sd, Nc nc) {
  double* x = sd.X.data();
  const double* lam = sd.Lam.data();
  const Eigen::Index lx = sd.X.outerStride(), ll = sd.Lam.outerStride();
  for (size_t s = 0; s < cs.specs.size(); ++s) {
    const double* y = ws.Yb[s].data();
    const int r0 = cs.row_offset[s], nk = cs.row_count[s];
    if constexpr (!std::is_same_v<Nc, int>) {
      if (nk == 6) {
        held_parts<Nc::value>([&](auto o, auto n) {
          using Row = Eigen::Matrix<double, 1, decltype(n)::value>;
          using CM = Eigen::Map<const Row>;
          const double* l = lam + r0 * ll + o;
          const Row l0 = CM(l), l1 = CM(l + ll), l2 = CM(l + 2 * ll), l3 = CM(l + 3 * ll), l4 = CM(l + 4 * ll), l5 = CM(l + 5 * ll);
          for (int d : ws.y_support[s]) {
            const double* f = y + Workspace::kYStride * d;
            Row xr = CM(x + d * lx + o);
            xr -= -f[0] * l0, xr -= -f[1] * l1, xr -= -f[2] * l2, xr -= -f[3] * l3, xr -= -f[4] * l4, xr -= -f[5] * l5;
            Eigen::Map<Row> out(x + d * lx + o);
            out = xr;
          }
        });
        continue;
      }
    }
    for (int d : ws.y_support[s])
      for (int k = 0; k < nk; ++k) axpy_row(x + d * lx, lam + (r0 + k) * ll, -y[Workspace::kYStride * d + k], nc);
  }
}

// Lam and X (the accelerations' change) for the generalized-force changes X0 and the constraint
// right-hand side changes Gm of every column, through the evaluation's factors of M and Q
// (schur_solve of constrained_dynamics.cc). With rolling resistance the wheels' moments (linear in
// their normal forces) are iterated to the same fixed point as the evaluation's.
template <class Nc>
void batch_response(const System& sys, Workspace& ws, WrenchSigmaData& sd, Nc nc) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  const int ns = static_cast<int>(cs.specs.size());
  const bool rr = cs.rolling_resistance;
  const bool tau_only = sd.source == WrenchSigmaData::kTau;  // X0: the torques' unit columns, Gm: zero
  const int na = static_cast<int>(sd.dofs.size());
  for (int it = 0; it < (rr ? 50 : 1); ++it) {
    if (tau_only) {
      zero_block(sd.X.data(), sd.X.outerStride(), model.nv(), nc);
      if (sd.arms_used) sigma_arms_columns(sd, sd.X);
      else
        for (int j = 0; j < na; ++j) sd.X(sd.dofs[static_cast<size_t>(j)], j) = sd.S[j];
    } else {
      copy_block(sd.X0.data(), sd.X0.outerStride(), sd.X.data(), sd.X.outerStride(), model.nv(), nc);
    }
    if (it > 0) {
      for (int s = 0; s < ns; ++s) {
        const double arm = ws.cd.rr_arm[static_cast<size_t>(s)];
        if (arm == 0.0) continue;
        const Vec3 y_C = ws.cd.X_RS[static_cast<size_t>(s)].R.col(1);
        for (int d : cs.support[static_cast<size_t>(s)])
          sd.X.row(d).head(nc) += (arm * ws.data.S_W.col(d).head<3>().dot(y_C)) * sd.Lam.row(cs.row_offset[s] + 2).head(nc);
      }
      sd.Lam_prev.leftCols(nc) = sd.Lam.leftCols(nc);
    }
    rows_solve_Lt(model, ws.data, sd.X, nc);
    if (tau_only) zero_block(sd.Rhs.data(), sd.Rhs.outerStride(), cs.rows, nc);
    else copy_block(sd.Gm.data(), sd.Gm.outerStride(), sd.Rhs.data(), sd.Rhs.outerStride(), cs.rows, nc);
    rows_minus_yx(cs, ws, sd, nc);
    q_solve_rows(ws, sd, nc);
    if (it > 0) {
      const double step = (sd.Lam.leftCols(nc) - sd.Lam_prev.leftCols(nc)).cwiseAbs().maxCoeff();
      if (!(step > 1e-14 * sd.Lam.leftCols(nc).cwiseAbs().maxCoeff())) break;
    }
  }
  rows_plus_ytlam(cs, ws, sd, nc);  // X <- L^-1 (X + Y^T Lam)
  rows_solve_L(model, ws.data, sd.X, nc);
}

// f = I s (RigidInertia's product, the same expression) written in place: returned, its
// temporary's narrow stores were reloaded wide for the copy, a failed store-to-load forwarding
// each (perf annotate: most of the composite form's setup)
void apply_into(const RigidInertia& I, const double* s, double* f) {
  const Eigen::Map<const Vec6> V(s);
  const Vec3 w = V.head<3>(), v = V.tail<3>();
  Eigen::Map<Vec6> F(f);
  F.head<3>() = I.Io * w + I.h.cross(v);
  F.tail<3>() = I.m * v - I.h.cross(w);
}

// The composite form's coefficients (WrenchSigmaData::composite): each subtree's inertia, each
// DOF's Ic S, each reaction's (Ic_b [+ I_fix_b]) S on its path. After the pass's inertias (batch_setup).
void composite_setup(const System& sys, const Workspace& ws, WrenchSigmaData& sd) {
  const Model& model = sys.model;
  const Data& data = ws.data;
  const WrenchSet& set = sys.wrenches;
  for (int i : set.pass) sd.Ic[i] = data.has_inertia[i] ? sd.I_lin[i] : RigidInertia();
  for (int i : set.pass) {  // children first
    const int p = model.bodies[i].parent;
    if (p >= 0 && set.in_pass[p]) sd.Ic[p] += sd.Ic[i];
  }
  for (int i : set.pass)
    for (int c = 0; c < model.bodies[i].joint.nv; ++c) {
      const int d = model.bodies[i].joint.idx_v + c;
      apply_into(sd.Ic[i], data.S_W.col(d).data(), sd.F_dof.col(d).data());
    }
  for (size_t k = 0; k < set.outputs.size(); ++k) {
    if (set.outputs[k].spec >= 0) continue;
    const int b = set.outputs[k].body;
    RigidInertia I = sd.Ic[b];
    if (model.bodies[b].joint.type == JointType::kFixed && model.bodies[b].parent >= 0) I += sd.I_fix[b];
    for (size_t t = 0; t < sd.out_up[k].size(); ++t)
      apply_into(I, data.S_W.col(sd.out_up[k][t]).data(), sd.U[k].col(static_cast<Eigen::Index>(t)).data());
  }
}

// spec_force of a unit multiplier on axis a (0-2 moment, 3-5 force) of a spec that is not a rolling
// contact (no rolling-resistance moment): its products by the unit's 1 and 0s left out (exact: the
// same values)
void unit_spec_force(const Transform& X_RS, int a, double* F) {
  const Mat3& R = X_RS.R;
  const Vec3& p = X_RS.p;
  if (a < 3) {
    F[0] = R(0, a), F[1] = R(1, a), F[2] = R(2, a), F[3] = 0.0, F[4] = 0.0, F[5] = 0.0;
    return;
  }
  const double f0 = R(0, a - 3), f1 = R(1, a - 3), f2 = R(2, a - 3);
  F[0] = p[1] * f2 - p[2] * f1;
  F[1] = p[2] * f0 - p[0] * f2;
  F[2] = p[0] * f1 - p[1] * f0;
  F[3] = f0, F[4] = f1, F[5] = f2;
}

// X = wrench_frame_pose(sys, data, k), a reaction's frame X_WB X_BF formed in place (the same
// products): returned, the copy reloaded its temporary wide (store-to-load forwarding, perf: 4-6 %
// of the sigma at 2 PUMAs)
void report_frame_into(const System& sys, const Data& data, int k, Transform& X) {
  const WrenchOutput& o = sys.wrenches.outputs[static_cast<size_t>(k)];
  if (o.centre_of >= 0) {
    X = wrench_frame_pose(sys, data, k);
  } else if (o.frame_body >= 0) {
    const Transform& B = data.X_WB[o.frame_body];
    X.R.noalias() = B.R * o.X_BF.R;
    X.p.noalias() = B.p + B.R * o.X_BF.p;
  } else {
    X = o.X_BF;
  }
}

// The state-dependent matrices of the pass: each reaction's inertia on its body's acceleration
// (joint_reactions.h: the body's I_W, and for a fixed joint the welded group's I_Bw), each pass
// spec's force per unit of its rows (spec_force), each output's report frame.
void batch_setup(const System& sys, const Workspace& ws, WrenchSigmaData& sd) {
  const Model& model = sys.model;
  const Data& data = ws.data;
  const ConstraintSet& cs = sys.constraints;
  const WrenchSet& set = sys.wrenches;
  for (int i : set.pass) {
    if (data.has_inertia[i]) sd.I_lin[i] = data.I_W[i];
    if (model.bodies[i].joint.type == JointType::kFixed && model.bodies[i].parent >= 0)
      sd.I_fix[i] = data.I_Bw[i].transformed(data.X_WB[i].R, data.X_WB[i].p - data.p_ref);
  }
  for (int s : set.pass_specs) {
    const int r0 = cs.row_offset[s];
    for (int r = 0; r < cs.row_count[s]; ++r) {
      double* t = sd.T_spec[static_cast<size_t>(s)].col(r).data();
      if (cs.specs[static_cast<size_t>(s)].kind != ConstraintKind::kRolling) {
        unit_spec_force(ws.cd.X_RS[static_cast<size_t>(s)], cs.row_axis[s][r], t);
        continue;
      }
      sd.unit[r0 + r] = 1.0;
      spec_force(cs, ws.cd, sd.unit.data(), s, t);
      sd.unit[r0 + r] = 0.0;
    }
  }
  for (size_t k = 0; k < set.outputs.size(); ++k)
    if (set.outputs[k].spec < 0) report_frame_into(sys, data, static_cast<int>(k), sd.X_WF[k]);
  if (sd.composite) composite_setup(sys, ws, sd);
}

// Rb: the joint reactions' change (world, at p_ref) for the accelerations' change X, without the
// constraint forces (added per output): joint_reactions' vdot-linear part on 6 x nc blocks
template <class Nc>
void batch_reactions(const System& sys, const Workspace& ws, WrenchSigmaData& sd, Nc nc) {
  const Model& model = sys.model;
  const std::vector<int>& pass = sys.wrenches.pass;
  const int last = pass.front();
  const int la = nc;  // A, Acc, Rb: compact 6 x nc blocks per body (wrench_sigma_rows.h)
  for (int i = 0; i <= last; ++i) {
    const Body& b = model.bodies[i];
    double* a = sd.A.data() + 6 * i * la;
    if (b.parent >= 0 && b.joint.nv == 1) {  // the common case in one pass over the columns
      const int d = b.joint.idx_v;
      const double s[6] = {-ws.data.S_W(0, d), -ws.data.S_W(1, d), -ws.data.S_W(2, d),
                           -ws.data.S_W(3, d), -ws.data.S_W(4, d), -ws.data.S_W(5, d)};
      accel_one(sd.A.data() + 6 * b.parent * la, s, sd.X.data() + d * sd.X.outerStride(), a, nc);
    } else {
      if (b.parent >= 0) copy_rows(sd.A.data() + 6 * b.parent * la, a, la, nc);
      else zero_rows(a, la, nc);
      for (int c = 0; c < 6; ++c)
        for (int k = 0; k < b.joint.nv; ++k) {
          const int d = b.joint.idx_v + k;
          axpy_row(a + c * la, sd.X.data() + d * sd.X.outerStride(), -ws.data.S_W(c, d), nc);
        }
    }
    zero_rows(sd.Acc.data() + 6 * i * la, la, nc);
  }
  for (int i : pass) {  // children first: each body's acc holds its children's sum when it comes
    const Body& b = model.bodies[i];
    const bool inertia = ws.data.has_inertia[i], fixed = b.joint.type == JointType::kFixed && b.parent >= 0;
    const double* a = sd.A.data() + 6 * i * la;
    double* acc = sd.Acc.data() + 6 * i * la;
    double* rb = sd.Rb.data() + 6 * i * la;
    double* accp = b.parent >= 0 ? sd.Acc.data() + 6 * b.parent * la : nullptr;
    const RigidInertia &I = sd.I_lin[i], &If = sd.I_fix[i];
    if (!accp) {
      if (inertia) reaction_body<true, false, false>(I, If, a, acc, rb, accp, nc);
      else reaction_body<false, false, false>(I, If, a, acc, rb, accp, nc);
    } else if (fixed) {
      if (inertia) reaction_body<true, true, true>(I, If, a, acc, rb, accp, nc);
      else reaction_body<false, true, true>(I, If, a, acc, rb, accp, nc);
    } else {
      if (inertia) reaction_body<true, false, true>(I, If, a, acc, rb, accp, nc);
      else reaction_body<false, false, true>(I, If, a, acc, rb, accp, nc);
    }
  }
}

// Tmp(0:6, 0:nc) = output k's reaction without its specs' forces (world, at p_ref) in the composite form
template <class Nc>
void composite_reaction(WrenchSigmaData& sd, size_t k, Nc nc) {
  const std::vector<int>& up = sd.out_up[k];
  const std::vector<int>& down = sd.out_down[k];
  const auto& U = sd.U[k];
  const double* x = sd.X.data();
  const Eigen::Index lx = sd.X.outerStride(), lt = sd.Tmp.outerStride();
  double* tmp = sd.Tmp.data();
  if constexpr (std::is_same_v<Nc, int>) {
    zero_rows(tmp, lt, nc);
    for (size_t t = 0; t < up.size(); ++t)
      for (int c = 0; c < 6; ++c) axpy_row(tmp + c * lt, x + up[t] * lx, -U(c, static_cast<Eigen::Index>(t)), nc);
    for (int d : down)
      for (int c = 0; c < 6; ++c) axpy_row(tmp + c * lt, x + d * lx, -sd.F_dof(c, d), nc);
  } else {  // the 6 rows held in registers
    using Row = Eigen::Matrix<double, 1, Nc::value>;
    Row a0 = Row::Zero(), a1 = Row::Zero(), a2 = Row::Zero(), a3 = Row::Zero(), a4 = Row::Zero(), a5 = Row::Zero();
    auto add = [&](const double* w, const double* r) {
      const ConstFixedRow<Nc> xr(r);
      a0 += w[0] * xr, a1 += w[1] * xr, a2 += w[2] * xr, a3 += w[3] * xr, a4 += w[4] * xr, a5 += w[5] * xr;
    };
    for (size_t t = 0; t < up.size(); ++t) add(U.data() + 6 * t, x + up[t] * lx);
    for (int d : down) add(sd.F_dof.data() + 6 * d, x + d * lx);
    FixedRow<Nc> o0(tmp), o1(tmp + lt), o2(tmp + 2 * lt), o3(tmp + 3 * lt), o4(tmp + 4 * lt), o5(tmp + 5 * lt);
    o0 = a0, o1 = a1, o2 = a2, o3 = a3, o4 = a4, o5 = a5;
  }
}

// C(:, 0:nc): each output's change per column (tips: their rows of Lam; joint reactions: Rb minus
// the subtree sum of the constraint-force change, in the output's report frame)
template <class Nc>
void batch_outputs(const System& sys, const Workspace& ws, WrenchSigmaData& sd, Nc nc) {
  const ConstraintSet& cs = sys.constraints;
  const WrenchSet& set = sys.wrenches;
  RowMat& C = sd.arms_used ? sd.arm.Cf : sd.C;  // the arm form's columns: scratch of their own
  for (size_t t = 0; t < set.pass_specs.size(); ++t) {  // dF = T_spec Lam, row by row
    const int s = set.pass_specs[t], r0 = cs.row_offset[s];
    const Mat6& T = sd.T_spec[static_cast<size_t>(s)];
    for (int c = 0; c < 6; ++c) {
      auto f = row(sd.dF, 6 * static_cast<Eigen::Index>(t) + c, nc);
      f = T(c, 0) * row(sd.Lam, r0, nc);
      for (int r = 1; r < cs.row_count[s]; ++r) f += T(c, r) * row(sd.Lam, r0 + r, nc);
    }
  }
  for (size_t k = 0; k < set.outputs.size(); ++k) {
    const WrenchOutput& o = set.outputs[k];
    const Eigen::Index c0 = 6 * static_cast<Eigen::Index>(k);
    if (o.spec >= 0) {
      C.block(c0, 0, 6, nc).setZero();
      const int r0 = cs.row_offset[o.spec];
      for (int r = 0; r < cs.row_count[o.spec]; ++r) row(C, c0 + cs.row_axis[o.spec][r], nc) = row(sd.Lam, r0 + r, nc);
      if (cs.specs[static_cast<size_t>(o.spec)].kind == ConstraintKind::kRolling)  // set_rolling_resistance_moment
        row(C, c0 + 1, nc) = ws.cd.rr_arm[static_cast<size_t>(o.spec)] * row(C, c0 + 5, nc);
      continue;
    }
    const Transform& X = sd.X_WF[k];
    const int ns = set.out_spec_begin[k + 1] - set.out_spec_begin[k];
    if (!sd.composite && ns <= 2) {  // the reaction's specs' forces summed inside the frame change
      const double* f[2] = {nullptr, nullptr};
      double g[2] = {0.0, 0.0};
      for (int t = 0; t < ns; ++t) {
        const auto& st = set.out_spec[static_cast<size_t>(set.out_spec_begin[k] + t)];
        f[t] = sd.dF.data() + 6 * st.first * sd.dF.outerStride();
        g[t] = static_cast<double>(st.second);
      }
      const Mat3 Rt = (o.reversed ? -1.0 : 1.0) * X.R.transpose();
      const Vec3 p = X.p - ws.data.p_ref;
      const double* rb = sd.Rb.data() + 6 * o.body * static_cast<int>(nc);
      double* out = &C(c0, 0);
      const Eigen::Index lf = sd.dF.outerStride(), lo = C.outerStride();
      if (ns == 0) to_frame_sum<0>(Rt, p, rb, f, g, lf, out, lo, nc);
      else if (ns == 1) to_frame_sum<1>(Rt, p, rb, f, g, lf, out, lo, nc);
      else to_frame_sum<2>(Rt, p, rb, f, g, lf, out, lo, nc);
      continue;
    }
    if (sd.composite) composite_reaction(sd, k, nc);
    for (int c = 0; c < 6; ++c) {
      auto d = row(sd.Tmp, c, nc);
      if (!sd.composite) d = Eigen::Map<const Eigen::RowVectorXd>(sd.Rb.data() + (6 * o.body + c) * static_cast<int>(nc), nc);
      for (int t = set.out_spec_begin[k]; t < set.out_spec_begin[k + 1]; ++t)
        d += static_cast<double>(set.out_spec[t].second) * row(sd.dF, 6 * set.out_spec[t].first + c, nc);
    }
    // world coordinates at p_ref -> the report frame at its origin: [R^T (n - p x f); R^T f]
    to_frame((o.reversed ? -1.0 : 1.0) * X.R.transpose(), X.p - ws.data.p_ref, sd.Tmp.data(), sd.Tmp.outerStride(), &C(c0, 0),
             C.outerStride(), nc);
  }
}

// the residuals (E1, E2 of the header) and the wrenches at (sd.qp, sd.vp) with the evaluation's
// vdot, lambda and friction held (damping follows v). fk_root >= 0: sd.wp's kinematics are at a
// state that differs from (sd.qp, sd.vp) only below body fk_root (forward_kinematics_subtree).
void residual(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& v,
              const Eigen::VectorXd& tau, Eigen::VectorXd& r_tau, Eigen::VectorXd& r_g, WrenchData& wd, int fk_root = -1) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  Workspace& wp = *sd.wp;
  if (fk_root >= 0) forward_kinematics_subtree(model, wp.data, sd.qp, sd.vp, fk_root);
  else forward_kinematics(model, wp.data, sd.qp, sd.vp);
  rnea(model, wp.data, ws.vdot, nullptr, sd.tau_id);
  rnea_bias(model, wp.data);  // the bias forces the wrench pass reads
  constraint_rows(model, wp.data, cs, sd.qp, sd.vp, wp.cd);
  r_tau = tau + ws.tau_loss - sd.tau_id;
  for (int d : ws.damped_dofs) r_tau[d] -= ws.damping[d] * (sd.vp[d] - v[d]);
  r_g = wp.cd.gamma;
  for (size_t s = 0; s < cs.specs.size(); ++s) {
    const int r0 = cs.row_offset[s], nk = cs.row_count[s];
    const double arm = wp.cd.rr_arm[s];
    const Vec3 mm = (arm * (arm != 0.0 ? ws.lambda[r0 + 2] : 0.0)) * wp.cd.X_RS[s].R.col(1);
    for (int d : cs.support[s]) {
      const double* g = wp.cd.G.col(d).data() + r0;
      double f = 0.0;
      for (int k = 0; k < nk; ++k) {
        f += g[k] * ws.lambda[r0 + k];
        r_g[r0 + k] -= g[k] * ws.vdot[d];
      }
      r_tau[d] += f + (arm != 0.0 ? wp.data.S_W.col(d).head<3>().dot(mm) : 0.0);
    }
  }
  wp.vdot = ws.vdot;
  wp.lambda = ws.lambda;
  wp.diag.status = Status::kOk;
  wp.diag.indeterminate = 0;
  compute_wrenches(sys, wp, wd);
}

// A refit (state_fit_sigma.h) whose fitted coordinates the tangents carry: positions not fitted,
// or each floating-joint DOF a tangent (wrench_sigma_position.h). No refit: nothing to carry.
bool fit_carried(const WrenchSigmaData& sd, const FitResponse* fit) {
  if (!fit) return true;
  const size_t nq = sd.q_dofs.size();
  for (size_t k = 0; fit->positions && k < sd.float_dofs.size(); ++k)
    if (!sd.qt_tangent[nq + k]) return false;
  return true;
}

// The floating joints' tangents per unit, in the last 2 nf columns of X0, Gm and Cd: their
// position tangents when positions were fitted (and in Gv's last nf columns their G v change when
// velocities were), then their velocity tangents when velocities were. Position tangents first:
// the velocity tangents' pass leaves its bodies' marks (wrench_sigma_velocity.h).
void fitted_position_tangents(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& v,
                              const FitResponse& fit) {
  const int nf = static_cast<int>(sd.float_dofs.size()), nq = static_cast<int>(sd.q_dofs.size());
  const int c0 = static_cast<int>(sd.X0.cols()) - 2 * nf, d0 = static_cast<int>(sd.Cd.cols()) - 2 * nf;
  if (!fit.positions) return;
  for (int k = 0; k < nf; ++k) position_column(sys, ws, sd, v, nq + k, c0 + k, d0 + k, fit.velocities ? nq + k : -1, 1.0);
}
void fitted_velocity_tangents(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& v,
                              const FitResponse& fit) {
  const int nf = static_cast<int>(sd.float_dofs.size());
  const int c0 = static_cast<int>(sd.X0.cols()) - 2 * nf, d0 = static_cast<int>(sd.Cd.cols()) - 2 * nf;
  if (!fit.velocities) return;
  for (int k = 0; k < nf; ++k) {
    const int d = sd.float_dofs[static_cast<size_t>(k)];
    sd.tv.setZero();
    sd.tv[d] = 1.0;
    sd.tv_nz.assign(1, d);
    velocity_column(sys, ws, sd, v, c0 + nf + k, d0 + nf + k, 1.0);
  }
}

// K's first nq + nv columns: the fitted coordinates' first-order change per column (a position
// column that is a difference refits them itself: zero; positions: the fitted positions' tangents
// were computed). A measured position moves the fitted pose
// by Kq, and with it the rows' velocity G v (its own tangent's and the pose's, Gv); the velocity fit
// answers that change with -Pv; a measured velocity moves the fitted twist by Kv.
void fitted_weights(WrenchSigmaData& sd, const FitResponse& fit, int nq, const std::vector<char>& tangent,
                    bool positions) {
  const int nf = static_cast<int>(sd.float_dofs.size()), nv = static_cast<int>(sd.v_dofs.size());
  const int nq_all = static_cast<int>(sd.q_dofs.size());
  sd.K.leftCols(nq + nv).setZero();
  for (int a = 0; a < nq; ++a) {
    if (!tangent[static_cast<size_t>(a)]) {
      sd.Gv.col(a).setZero();
      continue;
    }
    if (positions) sd.K.col(a).head(nf) = fit.Kq.col(sd.q_dofs[static_cast<size_t>(a)]) * sd.Sq[a];
  }
  if (!fit.velocities) return;
  if (positions) sd.Gv.leftCols(nq).noalias() += sd.Gv.middleCols(nq_all, nf) * sd.K.topLeftCorner(nf, nq);
  sd.K.bottomLeftCorner(nf, nq).noalias() = -fit.Pv * sd.Gv.leftCols(nq);
  for (int a = 0; a < nq; ++a)
    if (!tangent[static_cast<size_t>(a)]) sd.K.col(a).tail(nf).setZero();
  for (int a = 0; a < nv; ++a) sd.K.col(nq + a).tail(nf) = fit.Kv.col(sd.v_dofs[static_cast<size_t>(a)]) * sd.Sv[a];
}

// The columns na.. of X0 and Gm and 0.. of Cd plus the floating joints' tangents weighted by K
void add_fitted(WrenchSigmaData& sd, int na, int n) {
  const Eigen::Index nf2 = sd.K.rows();
  const auto K = sd.K.leftCols(n);
  sd.X0.middleCols(na, n).noalias() += sd.X0.rightCols(nf2) * K;
  sd.Gm.middleCols(na, n).noalias() += sd.Gm.rightCols(nf2) * K;
  sd.Cd.leftCols(n).noalias() += sd.Cd.rightCols(nf2) * K;
}

// Columns na.. of X0 and Gm (the residuals' change per one standard deviation of each measured
// coordinate) and of Cd (the wrenches' own change at fixed vdot, lambda). Positions: the tangent
// along the joint's motion (wrench_sigma_position.h), else forward differences. Velocities: the
// tangent of the velocity recursion (wrench_sigma_velocity.h) along the joint's velocity. With a
// refit, each column adds the fitted coordinates' response (fitted_weights) through the floating
// joints' tangents, or (a position column whose tangents do not apply) is a difference of the
// refitted state.
void state_columns(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& q,
                   const Eigen::VectorXd& v, const Eigen::VectorXd& tau, int nq) {
  constexpr double h = 1e-7;  // rad, m
  const int na = static_cast<int>(sd.dofs.size()), nv = static_cast<int>(sd.v_dofs.size());
  const size_t no = sys.wrenches.outputs.size();
  const FitResponse* fit = sd.refit ? sd.refit->linearize(ws.cd.G) : nullptr;
  const bool carried = fit_carried(sd, fit);
  std::vector<char>& tangent = sd.t_column;
  bool any_tangent = false, any_difference = false;
  for (int a = 0; a < nq; ++a) {
    tangent[static_cast<size_t>(a)] = carried && sd.qt_tangent[static_cast<size_t>(a)];
    (tangent[static_cast<size_t>(a)] ? any_tangent : any_difference) = true;
  }
  // the floating joints' position tangents: only for position columns (none when over-constrained)
  const bool fitted_positions = fit && carried && fit->positions && any_tangent;
  if (any_tangent) position_tangent_setup(sys, ws, sd);
  if (fitted_positions) fitted_position_tangents(sys, ws, sd, v, *fit);
  if (any_difference) {
    sd.qp = q;
    sd.vp = v;
    residual(sys, ws, sd, v, tau, sd.r0_tau, sd.r0_g, *sd.wd0);
  }
  auto column = [&](int j, double scale) {
    sd.X0.col(na + j) = (sd.r_tau - sd.r0_tau) * scale;
    sd.Gm.col(na + j) = (sd.r_g - sd.r0_g) * scale;
    for (size_t k = 0; k < no; ++k)
      for (int c = 0; c < 6; ++c)
        sd.Cd(6 * static_cast<Eigen::Index>(k) + c, j) = (sd.wd1->W[k][c] - sd.wd0->W[k][c]) * scale;
  };
  for (int a = 0; a < nq; ++a) {
    if (tangent[static_cast<size_t>(a)]) {
      position_column(sys, ws, sd, v, a, na + a, a, fit && fit->velocities ? a : -1, sd.Sq[a]);
      continue;
    }
    // without a refit only the joint's subtree moves: its kinematics alone are redone, and
    // undone after the column
    const int iq = sd.q_index[static_cast<size_t>(a)];
    const int root = fit ? -1 : sys.model.dof_body[sd.q_dofs[static_cast<size_t>(a)]];
    sd.qp[iq] = q[iq] + h;
    if (fit) sd.refit->refit(sd.qp, sd.vp);
    residual(sys, ws, sd, v, tau, sd.r_tau, sd.r_g, *sd.wd1, root);
    sd.qp = q;
    sd.vp = v;
    if (root >= 0) forward_kinematics_subtree(sys.model, sd.wp->data, q, v, root);
    column(a, sd.Sq[a] / h);
  }
  if (nv > 0 || (fit && fit->velocities)) velocity_tangent_setup(sys, ws, sd);
  if (fit) fitted_velocity_tangents(sys, ws, sd, v, *fit);
  for (int a = 0; a < nv; ++a) {
    const int d = sd.v_dofs[static_cast<size_t>(a)];
    sd.tv.setZero();
    sd.tv[d] = 1.0;
    sd.tv_nz.assign(1, d);
    velocity_column(sys, ws, sd, v, na + nq + a, nq + a, sd.Sv[a]);
  }
  if (!fit) return;
  fitted_weights(sd, *fit, nq, tangent, fitted_positions);
  add_fitted(sd, na, nq + nv);
}

// valid: noise declared and an evaluation that succeeded
bool start(Workspace& ws, WrenchSigmaData& sd, int nc) {
  // joints at rest: their friction is free within its bound (friction_bound.h reports that
  // interval); the noise's spread is the response with it left free, the one computed here
  sd.valid = sd.declared && nc > 0 && ws.diag.status != Status::kError;
  sd.ncols = sd.valid ? nc : 0;
  if (!sd.valid) {
    sd.source = 0;
    sd.arms_used = false;
    sd.c_filled = true;
    if (sd.declared) {
      for (Vec6& s : sd.sigma) s.setZero();
      sd.C.setZero();
    }
  }
  return sd.valid;
}

void tau_columns(WrenchSigmaData& sd) {
  const int na = static_cast<int>(sd.dofs.size());
  sd.X0.leftCols(na).setZero();
  sd.Gm.leftCols(na).setZero();
  for (int j = 0; j < na; ++j) sd.X0(sd.dofs[static_cast<size_t>(j)], j) = sd.S[j];
}

// after batch_setup; nc a compile-time column count (std::integral_constant) or int
template <class Nc>
void propagate_cols(const System& sys, Workspace& ws, WrenchSigmaData& sd, Nc nc) {
  batch_response(sys, ws, sd, nc);
  if (!sys.wrenches.pass.empty() && !sd.composite) batch_reactions(sys, ws, sd, nc);
  batch_outputs(sys, ws, sd, nc);
}

// f(nc) with the common column counts (6 per arm's joints, and the estimate mode's 3 kinds of
// columns) at compile time (std::integral_constant): the row operations then run as fixed-size
// rows, whole vector registers without loop set-up; any other count as an int.
template <class F>
void with_cols(int nc, F&& f) {
  switch (nc) {
    case 6: return f(std::integral_constant<int, 6>{});
    case 12: return f(std::integral_constant<int, 12>{});
    case 18: return f(std::integral_constant<int, 18>{});
    case 24: return f(std::integral_constant<int, 24>{});
    case 36: return f(std::integral_constant<int, 36>{});
    case 48: return f(std::integral_constant<int, 48>{});
    default: return f(nc);
  }
}
void propagate(const System& sys, Workspace& ws, WrenchSigmaData& sd, int nc) {
  with_cols(nc, [&](auto n) { propagate_cols(sys, ws, sd, n); });
}

template <class Nc>
void finish_cols(WrenchSigmaData& sd, Nc nc) {
  for (size_t k = 0; k < sd.sigma.size(); ++k)
    for (int c = 0; c < 6; ++c) sd.sigma[k][c] = row(sd.C, 6 * static_cast<Eigen::Index>(k) + c, nc).norm();
}
void finish(WrenchSigmaData& sd) {
  with_cols(sd.ncols, [&](auto nc) { finish_cols(sd, nc); });
}

}  // namespace

void compute_wrench_sigma(const System& sys, Workspace& ws, WrenchSigmaData& sd) {
  const int na = static_cast<int>(sd.dofs.size());
  if (!start(ws, sd, na)) return;
  sd.source = WrenchSigmaData::kTau;  // batch_response writes the torques' columns itself
  batch_setup(sys, ws, sd);
  sd.arms_used = sigma_arms_apply(sys, ws, sd);
  if (sd.arms_used) {  // wrench_sigma_arms.h: the packed torques and the common DOFs' unit forces
    propagate(sys, ws, sd, sd.arm.pack + static_cast<int>(sd.arm.common.size()));
    if (sigma_arms_finish(sd)) {
      sd.c_filled = sd.keep_C;
      if (sd.keep_C) finish(sd);
      return;
    }
    sd.arms_used = false;  // a near-singular arm: every column
  }
  propagate(sys, ws, sd, na);
  sd.c_filled = true;
  finish(sd);
}

void compute_wrench_sigma(const System& sys, Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& q,
                          const Eigen::VectorXd& v, const Eigen::VectorXd& tau) {
  // an over-constrained evaluation: the rule that picks lambda's indeterminate part is linear in
  // the right-hand side (torques, velocities) but its null space turns with q, which the fixed
  // factorization does not see: no position columns there (sigma_source says so)
  const int na = static_cast<int>(sd.dofs.size());
  const int nq = ws.diag.indeterminate > 0 ? 0 : static_cast<int>(sd.q_dofs.size());
  const int nv = static_cast<int>(sd.v_dofs.size()), nc = na + nq + nv;
  if (!start(ws, sd, nc)) return;
  sd.source = (na > 0 ? WrenchSigmaData::kTau : 0) | (nq > 0 ? WrenchSigmaData::kQ : 0) | (nv > 0 ? WrenchSigmaData::kV : 0);
  sd.arms_used = false;
  sd.c_filled = true;
  tau_columns(sd);
  batch_setup(sys, ws, sd);
  if (nq + nv > 0) state_columns(sys, ws, sd, q, v, tau, nq);
  propagate(sys, ws, sd, nc);
  if (nq + nv > 0) sd.C.block(0, na, sd.C.rows(), nq + nv) += sd.Cd.leftCols(nq + nv);
  finish(sd);
}

}  // namespace coopdyn
