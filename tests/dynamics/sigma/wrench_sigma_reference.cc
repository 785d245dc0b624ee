// The definition of each wrench's sigma before its fast path (service/dynamics/sigma/wrench_sigma.cc as it
// was): every noise source a column propagated through the evaluation's factor of M, a dense solve
// of Q independent of the evaluation's factors of it (q_solve_rows below), and a reaction pass on
// 6 x columns blocks with dense 6 x 6 inertias and frame transforms. Kept as the reference the
// fast path is tested against (wrench_sigma_fast_test.cc); not linked into the service.
#include "tests/dynamics/sigma/wrench_sigma_reference.h"

#include <cmath>
#include <random>

#include <Eigen/Cholesky>

#include "service/algorithms/kinematics.h"
#include "service/algorithms/rnea.h"
#include "service/algorithms/tree_cholesky.h"

namespace coopdyn::reference {

double velocity_step = 1e-2;
double position_step = 1e-3;

namespace {
using RowMat = WrenchSigmaData::RowMat;


Mat3 skew(const Vec3& h) {
  Mat3 S;
  S << 0, -h[2], h[1], h[2], 0, -h[0], -h[1], h[0], 0;
  return S;
}

// [n; f] = I [w; v] for a rigid inertia (m, h, Io) about the reference point: n = Io w + h x v,
// f = m v - h x w
Mat6 inertia_matrix(const RigidInertia& I) {
  Mat6 M;
  const Mat3 H = skew(I.h);
  M.topLeftCorner<3, 3>() = I.Io;
  M.topRightCorner<3, 3>() = H;
  M.bottomLeftCorner<3, 3>() = -H;
  M.bottomRightCorner<3, 3>() = I.m * Mat3::Identity();
  return M;
}
// per body: the reaction's inertia on its acceleration, dense (the service now keeps RigidInertia)
std::vector<Mat6> I_lin, I_fix;
}  // namespace

namespace {

// row a -= f * row b over nc entries (row-major rows: contiguous, vectorized)
inline void axpy_row(double* __restrict a, const double* __restrict b, double f, int nc) {
  for (int c = 0; c < nc; ++c) a[c] -= f * b[c];
}
inline void scale_row(double* a, double f, int nc) {
  for (int c = 0; c < nc; ++c) a[c] *= f;
}

// X(:, 0:nc) <- L^-T X, every column at once (tree_solve_Lt on rows)
void rows_solve_Lt(const Model& model, const Data& data, RowMat& X, int nc) {
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
void rows_solve_L(const Model& model, const Data& data, RowMat& X, int nc) {
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

// Lam = Q^-1 Rhs. Where the evaluation factored Q positive definite (its fast path: the dense
// Cholesky, the block Cholesky of q_blocks.h, either with the nominal rows last), independently of
// those factors: Q = G M^-1 G^T assembled densely from the constraint rows and the tree solve of M,
// then Eigen's LDLT of it. An over-constrained evaluation (the rank-revealing solve, whose
// redundancy rule picks the indeterminate part) column by column through QSolver::solve, the
// definition of that rule. Allocates (test code).
void q_solve_rows(const System& sys, Workspace& ws, WrenchSigmaData& sd, int nc) {
  if (!ws.qs.fast_path) {
    for (int j = 0; j < nc; ++j) {
      sd.col_b = sd.Rhs.col(j);
      ws.qs.solve(sd.col_b, sd.col_x);
      sd.Lam.col(j) = sd.col_x;
    }
    return;
  }
  const Eigen::MatrixXd& G = ws.cd.G;  // (rows x nv)
  Eigen::MatrixXd MinvGt = G.transpose();
  for (int r = 0; r < MinvGt.cols(); ++r) tree_solve_M(sys.model, ws.data, MinvGt.col(r));
  const Eigen::MatrixXd Q = G * MinvGt;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(Q);
  sd.Lam.leftCols(nc) = ldlt.solve(Eigen::MatrixXd(sd.Rhs.leftCols(nc)));
}

// Lam and X (the accelerations' change) for the generalized-force changes X0 and the constraint
// right-hand side changes Gm of every column, through the evaluation's factors of M and Q
// (schur_solve of constrained_dynamics.cc). With rolling resistance the wheels' moments (linear in
// their normal forces) are iterated to the same fixed point as the evaluation's.
void batch_response(const System& sys, Workspace& ws, WrenchSigmaData& sd, int nc) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  const int ns = static_cast<int>(cs.specs.size());
  const bool rr = cs.rolling_resistance;
  for (int it = 0; it < (rr ? 50 : 1); ++it) {
    sd.X.leftCols(nc) = sd.X0.leftCols(nc);
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
    sd.Rhs.leftCols(nc) = sd.Gm.leftCols(nc);
    double* rhs = sd.Rhs.data();
    const double* x = sd.X.data();
    const Eigen::Index lr = sd.Rhs.outerStride(), lx = sd.X.outerStride();
    for (int s = 0; s < ns; ++s) {
      const double* y = ws.Yb[static_cast<size_t>(s)].data();
      const int r0 = cs.row_offset[s], nk = cs.row_count[s];
      for (int d : ws.y_support[static_cast<size_t>(s)])
        for (int k = 0; k < nk; ++k) axpy_row(rhs + (r0 + k) * lr, x + d * lx, y[Workspace::kYStride * d + k], nc);
    }
    q_solve_rows(sys, ws, sd, nc);
    if (it > 0) {
      const double step = (sd.Lam.leftCols(nc) - sd.Lam_prev.leftCols(nc)).cwiseAbs().maxCoeff();
      if (!(step > 1e-14 * sd.Lam.leftCols(nc).cwiseAbs().maxCoeff())) break;
    }
  }
  double* x = sd.X.data();
  const double* lam = sd.Lam.data();
  const Eigen::Index lx = sd.X.outerStride(), ll = sd.Lam.outerStride();
  for (int s = 0; s < ns; ++s) {  // X <- L^-1 (X + Y^T Lam)
    const double* y = ws.Yb[static_cast<size_t>(s)].data();
    const int r0 = cs.row_offset[s], nk = cs.row_count[s];
    for (int d : ws.y_support[static_cast<size_t>(s)])
      for (int k = 0; k < nk; ++k) axpy_row(x + d * lx, lam + (r0 + k) * ll, -y[Workspace::kYStride * d + k], nc);
  }
  rows_solve_L(model, ws.data, sd.X, nc);
}

// The state-dependent matrices of the pass: each reaction's inertia on its body's acceleration
// (joint_reactions.h: the body's I_W, and for a fixed joint the welded group's I_Bw), each pass
// spec's force per unit of its rows (spec_force), each output's report frame.
void batch_setup(const System& sys, const Workspace& ws, WrenchSigmaData& sd) {
  const Model& model = sys.model;
  const Data& data = ws.data;
  const ConstraintSet& cs = sys.constraints;
  const WrenchSet& set = sys.wrenches;
  I_lin.assign(static_cast<size_t>(model.nbodies()), Mat6::Zero());
  I_fix.assign(static_cast<size_t>(model.nbodies()), Mat6::Zero());
  for (int i : set.pass) {
    if (data.has_inertia[i]) I_lin[i] = inertia_matrix(data.I_W[i]);
    if (model.bodies[i].joint.type == JointType::kFixed && model.bodies[i].parent >= 0)
      I_fix[i] = inertia_matrix(data.I_Bw[i].transformed(data.X_WB[i].R, data.X_WB[i].p - data.p_ref));
  }
  for (int s : set.pass_specs) {
    const int r0 = cs.row_offset[s];
    for (int r = 0; r < cs.row_count[s]; ++r) {
      sd.unit[r0 + r] = 1.0;
      spec_force(cs, ws.cd, sd.unit.data(), s, sd.T_spec[static_cast<size_t>(s)].col(r).data());
      sd.unit[r0 + r] = 0.0;
    }
  }
  for (size_t k = 0; k < set.outputs.size(); ++k)
    if (set.outputs[k].spec < 0) sd.X_WF[k] = wrench_frame_pose(sys, data, static_cast<int>(k));
}

// Rb: the joint reactions' change (world, at p_ref) for the accelerations' change X, without the
// constraint forces (added per output): joint_reactions' vdot-linear part on 6 x nc blocks
void batch_reactions(const System& sys, const Workspace& ws, WrenchSigmaData& sd, int nc) {
  const Model& model = sys.model;
  const std::vector<int>& pass = sys.wrenches.pass;
  const int last = pass.front();
  auto blk = [nc](RowMat& M, int i) { return M.block(6 * i, 0, 6, nc); };
  for (int i = 0; i <= last; ++i) {
    const Body& b = model.bodies[i];
    auto Ai = blk(sd.A, i);
    if (b.parent >= 0) Ai = blk(sd.A, b.parent);
    else Ai.setZero();
    for (int k = 0; k < b.joint.nv; ++k)
      Ai.noalias() += ws.data.S_W.col(b.joint.idx_v + k) * sd.X.row(b.joint.idx_v + k).head(nc);
    blk(sd.Acc, i).setZero();
  }
  for (int i : pass) {
    const Body& b = model.bodies[i];
    auto N = blk(sd.Acc, i);
    if (ws.data.has_inertia[i]) N.noalias() += I_lin[i] * blk(sd.A, i);
    auto R = blk(sd.Rb, i);
    R = N;
    if (b.joint.type == JointType::kFixed && b.parent >= 0) R.noalias() += I_fix[i] * blk(sd.A, i);
    if (b.parent >= 0) blk(sd.Acc, b.parent) += N;
  }
}

// C(:, 0:nc): each output's change per column (tips: their rows of Lam; joint reactions: Rb minus
// the subtree sum of the constraint-force change, in the output's report frame)
void batch_outputs(const System& sys, const Workspace& ws, WrenchSigmaData& sd, int nc) {
  const ConstraintSet& cs = sys.constraints;
  const WrenchSet& set = sys.wrenches;
  for (size_t t = 0; t < set.pass_specs.size(); ++t) {
    const int s = set.pass_specs[t];
    sd.dF.block(6 * static_cast<Eigen::Index>(t), 0, 6, nc).noalias() =
        sd.T_spec[static_cast<size_t>(s)].leftCols(cs.row_count[s]) * sd.Lam.block(cs.row_offset[s], 0, cs.row_count[s], nc);
  }
  for (size_t k = 0; k < set.outputs.size(); ++k) {
    const WrenchOutput& o = set.outputs[k];
    auto Ck = sd.C.block(6 * static_cast<Eigen::Index>(k), 0, 6, nc);
    if (o.spec >= 0) {
      Ck.setZero();
      const int r0 = cs.row_offset[o.spec];
      for (int r = 0; r < cs.row_count[o.spec]; ++r) Ck.row(cs.row_axis[o.spec][r]) = sd.Lam.row(r0 + r).head(nc);
      if (cs.specs[static_cast<size_t>(o.spec)].kind == ConstraintKind::kRolling)
        Ck.row(1) = ws.cd.rr_arm[static_cast<size_t>(o.spec)] * Ck.row(5);  // set_rolling_resistance_moment
      continue;
    }
    auto dR = sd.Tmp.leftCols(nc);
    dR = sd.Rb.block(6 * o.body, 0, 6, nc);
    for (int t = set.out_spec_begin[k]; t < set.out_spec_begin[k + 1]; ++t)
      dR += static_cast<double>(set.out_spec[t].second) * sd.dF.block(6 * set.out_spec[t].first, 0, 6, nc);
    // world coordinates at p_ref -> the report frame at its origin: [R^T (n - p x f); R^T f]
    const Transform& X = sd.X_WF[k];
    const Mat3 Rt = (o.reversed ? -1.0 : 1.0) * X.R.transpose();
    Mat6 T = Mat6::Zero();
    T.topLeftCorner<3, 3>() = Rt;
    T.topRightCorner<3, 3>() = -Rt * skew(X.p - ws.data.p_ref);
    T.bottomRightCorner<3, 3>() = Rt;
    Ck.noalias() = T * dR;
  }
}

// the residuals (E1, E2 of the header) and the wrenches at (sd.qp, sd.vp) with the evaluation's
// vdot, lambda and friction held (damping follows v)
void residual(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& v,
              const Eigen::VectorXd& tau, Eigen::VectorXd& r_tau, Eigen::VectorXd& r_g, WrenchData& wd) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  Workspace& wp = *sd.wp;
  forward_kinematics(model, wp.data, sd.qp, sd.vp);
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

// Column col of X0 and Gm and cd_col of Cd for position iq: the five-point central difference of
// step position_step, (8 (r(h) - r(-h)) - (r(2h) - r(-2h))) / 12 h (truncation O(h^4), round-off
// ~eps |r| / h). Allocates (test code).
void five_point(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& q,
                const Eigen::VectorXd& v, const Eigen::VectorXd& tau, int iq, int col, int cd_col, double scale) {
  const double hs = position_step;
  const size_t no = sys.wrenches.outputs.size();
  Eigen::VectorXd t = Eigen::VectorXd::Zero(sd.r_tau.size()), g = Eigen::VectorXd::Zero(sd.r_g.size());
  Eigen::VectorXd w = Eigen::VectorXd::Zero(6 * static_cast<Eigen::Index>(no));
  for (const auto& [k, wt] : {std::pair{1.0, 8.0}, {-1.0, -8.0}, {2.0, -1.0}, {-2.0, 1.0}}) {
    sd.qp[iq] = q[iq] + k * hs;
    residual(sys, ws, sd, v, tau, sd.r_tau, sd.r_g, *sd.wd1);
    t += wt * sd.r_tau;
    g += wt * sd.r_g;
    for (size_t o = 0; o < no; ++o) w.segment<6>(6 * static_cast<Eigen::Index>(o)) += wt * sd.wd1->W[o];
  }
  sd.qp[iq] = q[iq];
  const double f = scale / (12.0 * hs);
  sd.X0.col(col) = f * t;
  sd.Gm.col(col) = f * g;
  for (Eigen::Index r = 0; r < w.size(); ++r) sd.Cd(r, cd_col) = f * w[r];
}

// Columns na.. of X0 and Gm (the residuals' change per one standard deviation of each measured
// coordinate) and of Cd (the wrenches' own change at fixed vdot, lambda): forward differences
void state_columns(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& q,
                   const Eigen::VectorXd& v, const Eigen::VectorXd& tau, int nq) {
  constexpr double h = 1e-7;  // rad, m, rad/s, m/s
  const int na = static_cast<int>(sd.dofs.size());
  const size_t no = sys.wrenches.outputs.size();
  sd.qp = q;
  sd.vp = v;
  residual(sys, ws, sd, v, tau, sd.r0_tau, sd.r0_g, *sd.wd0);
  auto column = [&](int j, double scale) {
    sd.X0.col(na + j) = (sd.r_tau - sd.r0_tau) * scale;
    sd.Gm.col(na + j) = (sd.r_g - sd.r0_g) * scale;
    for (size_t k = 0; k < no; ++k)
      for (int c = 0; c < 6; ++c)
        sd.Cd(6 * static_cast<Eigen::Index>(k) + c, j) = (sd.wd1->W[k][c] - sd.wd0->W[k][c]) * scale;
  };
  for (int a = 0; a < nq; ++a) {
    const int iq = sd.q_index[static_cast<size_t>(a)];
    if (position_step > 0 && !sd.refit && sd.qt_tangent[static_cast<size_t>(a)]) {
      five_point(sys, ws, sd, q, v, tau, iq, na + a, a, sd.Sq[a]);
      continue;
    }
    sd.qp[iq] = q[iq] + h;
    residual(sys, ws, sd, v, tau, sd.r_tau, sd.r_g, *sd.wd1);
    sd.qp[iq] = q[iq];
    column(a, sd.Sq[a] / h);
  }
  // velocities: central differences of step velocity_step (the residuals and wrenches are
  // quadratic in v but for the rolling-resistance arm: no truncation error there, round-off
  // ~1e-16 |r| / step), or forward differences of 1e-7 (velocity_step <= 0: the former definition)
  const double hv = velocity_step > 0 ? velocity_step : h;
  for (int a = 0; a < static_cast<int>(sd.v_dofs.size()); ++a) {
    const int d = sd.v_dofs[static_cast<size_t>(a)];
    if (velocity_step > 0) {
      sd.vp[d] = v[d] - hv;
      residual(sys, ws, sd, v, tau, sd.r0_tau, sd.r0_g, *sd.wd0);
    }
    sd.vp[d] = v[d] + hv;
    residual(sys, ws, sd, v, tau, sd.r_tau, sd.r_g, *sd.wd1);
    sd.vp[d] = v[d];
    column(nq + a, sd.Sv[a] / (velocity_step > 0 ? 2 * hv : hv));
  }
}

// valid: noise declared and an evaluation that succeeded
bool start(Workspace& ws, WrenchSigmaData& sd, int nc) {
  // joints at rest: their friction is free within its bound (friction_bound.h reports that
  // interval); the noise's spread is the response with it left free, the one computed here
  sd.valid = sd.declared && nc > 0 && ws.diag.status != Status::kError;
  sd.ncols = sd.valid ? nc : 0;
  if (!sd.valid) {
    sd.source = 0;
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

void propagate(const System& sys, Workspace& ws, WrenchSigmaData& sd, int nc) {
  batch_setup(sys, ws, sd);
  batch_response(sys, ws, sd, nc);
  if (!sys.wrenches.pass.empty()) batch_reactions(sys, ws, sd, nc);
  batch_outputs(sys, ws, sd, nc);
}

void finish(WrenchSigmaData& sd) {
  for (size_t k = 0; k < sd.sigma.size(); ++k)
    for (int c = 0; c < 6; ++c) sd.sigma[k][c] = sd.C.row(6 * static_cast<Eigen::Index>(k) + c).head(sd.ncols).norm();
}

}  // namespace

void compute_wrench_sigma(const System& sys, Workspace& ws, WrenchSigmaData& sd) {
  const int na = static_cast<int>(sd.dofs.size());
  if (!start(ws, sd, na)) return;
  sd.source = WrenchSigmaData::kTau;
  tau_columns(sd);
  propagate(sys, ws, sd, na);
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
  tau_columns(sd);
  if (nq + nv > 0) state_columns(sys, ws, sd, q, v, tau, nq);
  propagate(sys, ws, sd, nc);
  if (nq + nv > 0) sd.C.block(0, na, sd.C.rows(), nq + nv) += sd.Cd.leftCols(nq + nv);
  finish(sd);
}

void random_v_tau(const System& sys, unsigned seed, Eigen::VectorXd& v, Eigen::VectorXd& tau) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  v = sys.v0;
  tau = Eigen::VectorXd::Zero(sys.model.nv());
  for (int i = 0; i < sys.model.nv(); ++i) {
    v[i] += 0.3 * U(rng);
    tau[i] = 2.0 * U(rng);
  }
}

}  // namespace coopdyn::reference
