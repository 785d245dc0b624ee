#include "service/dynamics/wrench_sigma_arms.h"

#include <cmath>

#include <Eigen/Cholesky>

#include "service/algorithms/tree_cholesky.h"
#include "service/dynamics/wrench_sigma_rows.h"

namespace coopdyn {

namespace {
using namespace sigma_rows;
using RowMat = SigmaArms::RowMat;

// the arm of each DOF from the block plan: a group's specs reach its own DOFs and the common ones;
// false where a DOF is reached by two groups or by none
bool assign_dofs(const Workspace& ws, SigmaArms& sa, int n) {
  sa.common = ws.qb.common;
  sa.dof_arm.assign(static_cast<size_t>(n), -2);
  for (int d : sa.common) sa.dof_arm[static_cast<size_t>(d)] = -1;
  for (size_t g = 0; g < ws.qb.groups.size(); ++g) {
    const QBlocks::Group& G = ws.qb.groups[g];
    SigmaArms::Arm arm;
    arm.spec0 = G.spec0;
    arm.spec1 = G.spec1;
    arm.row0 = G.row0;
    arm.rows = G.rows;
    sa.arms.push_back(std::move(arm));
    for (int s = G.spec0; s < G.spec1; ++s)
      for (int d : ws.y_support[static_cast<size_t>(s)]) {
        int& a = sa.dof_arm[static_cast<size_t>(d)];
        if (a == -1) continue;
        if (a >= 0 && a != static_cast<int>(g)) return false;
        a = static_cast<int>(g);
      }
  }
  for (int a : sa.dof_arm)
    if (a == -2) return false;
  return true;
}

// each arm's torque columns contiguous, every noisy DOF an arm's own
bool assign_columns(const WrenchSigmaData& sd, SigmaArms& sa) {
  for (size_t j = 0; j < sd.dofs.size(); ++j) {
    const int a = sa.dof_arm[static_cast<size_t>(sd.dofs[j])];
    if (a < 0) return false;
    SigmaArms::Arm& arm = sa.arms[static_cast<size_t>(a)];
    if (arm.nj == 0) arm.j0 = static_cast<int>(j);
    else if (arm.j0 + arm.nj != static_cast<int>(j)) return false;
    ++arm.nj;
  }
  return true;
}

// the arm a body's motion belongs to (-1: the common DOFs' alone, or none); -2: two arms
int body_arm(const Model& model, const SigmaArms& sa, int i) {
  int arm = -1;
  for (int d : model.body_support[static_cast<size_t>(i)]) {
    const int a = sa.dof_arm[static_cast<size_t>(d)];
    if (a >= 0 && arm >= 0 && a != arm) return -2;
    if (a >= 0) arm = a;
  }
  return arm;
}

bool in_subtree(const Model& model, int i, int b) {
  for (; i >= 0; i = model.bodies[static_cast<size_t>(i)].parent)
    if (i == b) return true;
  return false;
}

int spec_arm(const SigmaArms& sa, int s) {
  for (size_t g = 0; g < sa.arms.size(); ++g)
    if (s >= sa.arms[g].spec0 && s < sa.arms[g].spec1) return static_cast<int>(g);
  return -1;
}

// the arm each reported wrench lies within (its reaction's subtree and constraint forces, or its
// spec): false where one spans two arms or none; each arm's bodies
bool assign_outputs(const System& sys, SigmaArms& sa) {
  const Model& model = sys.model;
  const WrenchSet& set = sys.wrenches;
  const int nb = model.nbodies();
  for (SigmaArms::Arm& arm : sa.arms) arm.in.assign(static_cast<size_t>(nb), 0);
  for (int i = 0; i < nb; ++i) {
    const int a = body_arm(model, sa, i);
    if (a == -2) return false;
    if (a >= 0) sa.arms[static_cast<size_t>(a)].in[static_cast<size_t>(i)] = 1;
  }
  for (size_t k = 0; k < set.outputs.size(); ++k) {
    const WrenchOutput& o = set.outputs[k];
    int arm = o.spec >= 0 ? spec_arm(sa, o.spec) : -1;
    if (o.spec < 0) {
      for (int i = 0; i < nb; ++i) {
        if (!in_subtree(model, i, o.body)) continue;
        const int a = body_arm(model, sa, i);
        if (a >= 0 && arm >= 0 && a != arm) return false;
        if (a >= 0) arm = a;
      }
      for (int t = set.out_spec_begin[k]; t < set.out_spec_begin[k + 1]; ++t) {
        const int a = spec_arm(sa, set.pass_specs[static_cast<size_t>(set.out_spec[static_cast<size_t>(t)].first)]);
        if (a < 0 || (arm >= 0 && a != arm)) return false;
        arm = a;
      }
    }
    if (arm < 0) return false;
    SigmaArms::Arm& A = sa.arms[static_cast<size_t>(arm)];
    A.outputs.push_back(static_cast<int>(k));
    if (o.spec < 0)
      for (int i = 0; i < nb; ++i)
        if (in_subtree(model, i, o.body)) A.in[static_cast<size_t>(i)] = 1;
  }
  return true;
}

void fill_arm_lists(const System& sys, SigmaArms& sa) {
  const Model& model = sys.model;
  const WrenchSet& set = sys.wrenches;
  for (int d : model.dof_elim_order)
    if (sa.dof_arm[static_cast<size_t>(d)] >= 0) sa.arms[static_cast<size_t>(sa.dof_arm[static_cast<size_t>(d)])].elim.push_back(d);
  for (SigmaArms::Arm& arm : sa.arms) {
    for (int i = 0; i < model.nbodies(); ++i)
      if (arm.in[static_cast<size_t>(i)]) arm.bodies.push_back(i);
    for (int i : set.pass)
      if (arm.in[static_cast<size_t>(i)]) arm.pass.push_back(i);
    for (size_t t = 0; t < set.pass_specs.size(); ++t)
      if (set.pass_specs[t] >= arm.spec0 && set.pass_specs[t] < arm.spec1) arm.specs_t.push_back(static_cast<int>(t));
    arm.A.setZero(arm.rows, arm.rows);
    arm.dinv.setZero(arm.rows);
  }
}

}  // namespace

std::unique_ptr<SigmaArms> plan_sigma_arms(const System& sys, const WrenchSigmaData& sd) {
  const Formulation f = sys.options.formulation;
  const ConstraintSet& cs = sys.constraints;
  if (!sd.declared || (f != Formulation::kMobilePlatform && f != Formulation::kClassic) || cs.rolling_resistance ||
      static_cast<int>(sd.dofs.size()) < 6 || sys.wrenches.outputs.empty())
    return nullptr;
  for (const auto& s : cs.specs)
    if (s.kind == ConstraintKind::kRolling) return nullptr;
  const Workspace ws(sys);
  if (!ws.use_q_blocks || !ws.qb.usable || ws.qb.common.size() != 6) return nullptr;
  auto sa = std::make_unique<SigmaArms>();
  if (!assign_dofs(ws, *sa, sys.model.nv()) || !assign_columns(sd, *sa) || !assign_outputs(sys, *sa)) return nullptr;
  fill_arm_lists(sys, *sa);
  const Eigen::Index no = static_cast<Eigen::Index>(sys.wrenches.outputs.size());
  sa->V.setZero(6 * no, 6);
  sa->Xv.setZero(sys.model.nv(), 6);
  sa->Cc.setZero(6, static_cast<Eigen::Index>(sd.dofs.size()));
  return sa;
}

namespace {

// A_h = Y Y^T over the arm's own DOFs (QBlocks::assemble's A_g) and its Cholesky factor; false on
// a pivot that is not positive or, squared, below fast_tol of the largest (QBlocks' test)
bool factor_arm(const ConstraintSet& cs, const Workspace& ws, const QBlocks::Group& g, SigmaArms::Arm& arm, double fast_tol) {
  for (const QBlocks::Group::Pair& p : g.pairs) {
    Mat6 acc = Mat6::Zero();
    for (const auto& rg : p.ranges)
      for (int d = rg.first, e = rg.first + rg.second; d < e; ++d)
        acc.noalias() += ws.Yb[static_cast<size_t>(p.s)].row(d).transpose() * ws.Yb[static_cast<size_t>(p.t)].row(d);
    const int rs = cs.row_offset[p.s] - arm.row0, rt = cs.row_offset[p.t] - arm.row0;
    for (int i = 0; i < cs.row_count[p.s]; ++i)
      for (int j = 0; j < cs.row_count[p.t]; ++j) {
        arm.A(rs + i, rt + j) = acc(i, j);
        arm.A(rt + j, rs + i) = acc(i, j);
      }
  }
  double dmax = 0.0, dmin = HUGE_VAL;
  for (int j = 0; j < arm.rows; ++j) {
    double d = arm.A(j, j);
    for (int k = 0; k < j; ++k) d -= arm.A(j, k) * arm.A(j, k);
    if (!(d > 0.0)) return false;
    const double l = std::sqrt(d);
    arm.A(j, j) = l;
    arm.dinv[j] = 1.0 / l;
    dmax = std::max(dmax, l);
    dmin = std::min(dmin, l);
    for (int i = j + 1; i < arm.rows; ++i) {
      double sum = arm.A(i, j);
      for (int k = 0; k < j; ++k) sum -= arm.A(i, k) * arm.A(j, k);
      arm.A(i, j) = sum * arm.dinv[j];
    }
  }
  return dmin * dmin >= fast_tol * dmax * dmax;
}

// H_j on the arm's own DOFs and rows with the load held (a = 0), columns [j0, j0 + nj): X <-
// L_g^-T X0, Lam = A_h^-1 (-Y X), X <- L_g^-1 (X + Y^T Lam) (batch_response on the arm alone)
void held_solve(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const SigmaArms& sa, const SigmaArms::Arm& arm, int g) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  const int nc = arm.nj;
  const Eigen::Index lx = sd.X.outerStride(), ll = sd.Lam.outerStride();
  double* x = sd.X.data() + arm.j0;
  double* lam = sd.Lam.data() + arm.j0;
  const double* x0 = sd.X0.data() + arm.j0;
  const int* path = model.dof_path.data();
  for (int d : arm.elim)
    for (int c = 0; c < nc; ++c) x[d * lx + c] = x0[d * sd.X0.outerStride() + c];
  for (int d : arm.elim) {  // leaves to root, ancestors in the arm only (the common ones are held)
    const double* r = tree_factor_row(model, ws.data, d);
    const int* pd = path + model.dof_path_offset[d];
    scale_row(x + d * lx, ws.data.Ld_inv[d], nc);
    for (int p = 0; p < model.dof_depth[d]; ++p)
      if (sa.dof_arm[static_cast<size_t>(pd[p])] == g) axpy_row(x + pd[p] * lx, x + d * lx, r[p], nc);
  }
  for (int i = 0; i < arm.rows; ++i)
    for (int c = 0; c < nc; ++c) lam[(arm.row0 + i) * ll + c] = 0.0;
  for (int s = arm.spec0; s < arm.spec1; ++s) {
    const double* y = ws.Yb[static_cast<size_t>(s)].data();
    for (int d : ws.y_support[static_cast<size_t>(s)])
      if (sa.dof_arm[static_cast<size_t>(d)] == g)
        for (int k = 0; k < cs.row_count[s]; ++k) axpy_row(lam + (cs.row_offset[s] + k) * ll, x + d * lx, y[6 * d + k], nc);
  }
  double* l0 = lam + arm.row0 * ll;
  for (int i = 0; i < arm.rows; ++i) {  // A_h^-1 = L^-T L^-1
    for (int k = 0; k < i; ++k) axpy_row(l0 + i * ll, l0 + k * ll, arm.A(i, k), nc);
    scale_row(l0 + i * ll, arm.dinv[i], nc);
  }
  for (int i = arm.rows - 1; i >= 0; --i) {
    for (int k = i + 1; k < arm.rows; ++k) axpy_row(l0 + i * ll, l0 + k * ll, arm.A(k, i), nc);
    scale_row(l0 + i * ll, arm.dinv[i], nc);
  }
  for (int s = arm.spec0; s < arm.spec1; ++s) {
    const double* y = ws.Yb[static_cast<size_t>(s)].data();
    for (int d : ws.y_support[static_cast<size_t>(s)])
      if (sa.dof_arm[static_cast<size_t>(d)] == g)
        for (int k = 0; k < cs.row_count[s]; ++k) axpy_row(x + d * lx, lam + (cs.row_offset[s] + k) * ll, -y[6 * d + k], nc);
  }
  for (auto it = arm.elim.rbegin(); it != arm.elim.rend(); ++it) {  // root to leaves
    const int d = *it;
    const double* r = tree_factor_row(model, ws.data, d);
    const int* pd = path + model.dof_path_offset[d];
    for (int p = 0; p < model.dof_depth[d]; ++p)
      if (sa.dof_arm[static_cast<size_t>(pd[p])] == g) axpy_row(x + d * lx, x + pd[p] * lx, r[p], nc);
    scale_row(x + d * lx, ws.data.Ld_inv[d], nc);
  }
}

// the arm's outputs' change under H (batch_outputs on its columns [j0, j0 + nj)), added to C
void held_outputs(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const SigmaArms::Arm& arm) {
  const ConstraintSet& cs = sys.constraints;
  const WrenchSet& set = sys.wrenches;
  const int nc = arm.nj, j0 = arm.j0;
  const Eigen::Index lcm = sd.C.outerStride(), ll = sd.Lam.outerStride(), la = sd.Rb.outerStride(), lf = sd.dF.outerStride();
  const Eigen::Index lt = sd.Tmp.outerStride(), lt2 = sd.Tmp2.outerStride();
  for (int k : arm.outputs) {
    const WrenchOutput& o = set.outputs[static_cast<size_t>(k)];
    double* ck = sd.C.data() + 6 * k * lcm + j0;
    if (o.spec >= 0) {
      const int r0 = cs.row_offset[o.spec];
      for (int r = 0; r < cs.row_count[o.spec]; ++r)
        axpy_row(ck + cs.row_axis[o.spec][r] * lcm, sd.Lam.data() + (r0 + r) * ll + j0, -1.0, nc);
      continue;
    }
    double* d = sd.Tmp.data();
    for (int c = 0; c < 6; ++c) {
      const double* rb = sd.Rb.data() + (6 * o.body + c) * la + j0;
      for (int q = 0; q < nc; ++q) d[c * lt + q] = rb[q];
      for (int t = set.out_spec_begin[k]; t < set.out_spec_begin[k + 1]; ++t)
        axpy_row(d + c * lt, sd.dF.data() + (6 * set.out_spec[t].first + c) * lf + j0,
                 -static_cast<double>(set.out_spec[t].second), nc);
    }
    const Transform& X = sd.X_WF[static_cast<size_t>(k)];
    to_frame((o.reversed ? -1.0 : 1.0) * X.R.transpose(), X.p - ws.data.p_ref, d, lt, sd.Tmp2.data(), lt2, nc);
    for (int c = 0; c < 6; ++c) axpy_row(ck + c * lcm, sd.Tmp2.data() + c * lt2, -1.0, nc);
  }
}

// the reaction pass (batch_reactions, batch_outputs) of H over the arm's bodies: its outputs'
// change, added to their rows of C, columns [j0, j0 + nj)
void held_pass(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const SigmaArms& sa, const SigmaArms::Arm& arm, int g) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  const WrenchSet& set = sys.wrenches;
  const int nc = arm.nj, j0 = arm.j0;
  const Eigen::Index la = sd.A.outerStride(), lx = sd.X.outerStride();
  for (int i : arm.bodies) {  // accelerations: the bodies above the arm are held
    const Body& b = model.bodies[static_cast<size_t>(i)];
    double* a = sd.A.data() + 6 * i * la + j0;
    if (b.parent >= 0 && arm.in[static_cast<size_t>(b.parent)]) copy_rows(sd.A.data() + 6 * b.parent * la + j0, a, la, nc);
    else zero_rows(a, la, nc);
    for (int k = 0; k < b.joint.nv; ++k) {
      const int d = b.joint.idx_v + k;
      if (sa.dof_arm[static_cast<size_t>(d)] != g) continue;
      for (int c = 0; c < 6; ++c) axpy_row(a + c * la, sd.X.data() + d * lx + j0, -ws.data.S_W(c, d), nc);
    }
    zero_rows(sd.Acc.data() + 6 * i * la + j0, la, nc);
  }
  for (int i : arm.pass) {
    const Body& b = model.bodies[static_cast<size_t>(i)];
    double* acc = sd.Acc.data() + 6 * i * la + j0;
    const double* a = sd.A.data() + 6 * i * la + j0;
    if (ws.data.has_inertia[i]) inertia_times<true>(sd.I_lin[static_cast<size_t>(i)], a, la, acc, la, nc);
    copy_rows(acc, sd.Rb.data() + 6 * i * la + j0, la, nc);
    if (b.joint.type == JointType::kFixed && b.parent >= 0)
      inertia_times<true>(sd.I_fix[static_cast<size_t>(i)], a, la, sd.Rb.data() + 6 * i * la + j0, la, nc);
    if (b.parent >= 0 && arm.in[static_cast<size_t>(b.parent)])
      for (int c = 0; c < 6; ++c) axpy_row(sd.Acc.data() + (6 * b.parent + c) * la + j0, acc + c * la, -1.0, nc);
  }
  const Eigen::Index lf = sd.dF.outerStride(), ll = sd.Lam.outerStride();
  for (int t : arm.specs_t) {  // dF = T_spec Lam
    const int s = set.pass_specs[static_cast<size_t>(t)], r0 = cs.row_offset[s];
    const Mat6& T = sd.T_spec[static_cast<size_t>(s)];
    for (int c = 0; c < 6; ++c) {
      double* f = sd.dF.data() + (6 * t + c) * lf + j0;
      for (int q = 0; q < nc; ++q) f[q] = 0.0;
      for (int r = 0; r < cs.row_count[s]; ++r) axpy_row(f, sd.Lam.data() + (r0 + r) * ll + j0, -T(c, r), nc);
    }
  }
  held_outputs(sys, ws, sd, arm);
}

// O = V I for a row-major 6 x 6 V on 6 rows of nc columns (row r of I at in + r li, of O at o + r lo)
void mat6_times(const double* __restrict v, const double* __restrict in, Eigen::Index li, double* __restrict o, Eigen::Index lo,
                int nc) {
#pragma GCC ivdep
  for (int j = 0; j < nc; ++j) {
    const double x0 = in[j], x1 = in[li + j], x2 = in[2 * li + j], x3 = in[3 * li + j], x4 = in[4 * li + j], x5 = in[5 * li + j];
    for (int r = 0; r < 6; ++r) {
      const double* w = v + 6 * r;
      o[r * lo + j] = w[0] * x0 + w[1] * x1 + w[2] * x2 + w[3] * x3 + w[4] * x4 + w[5] * x5;
    }
  }
}

// V, Xv and A_v from the 6 columns, then c_j = A_v^-1 a_j, a_j = S_j Xv(d_j, :); false where A_v
// is not safely positive definite
bool load_columns(const System& sys, WrenchSigmaData& sd, SigmaArms& sa) {
  const int na = static_cast<int>(sd.dofs.size());
  sa.V = sd.C.leftCols(6);
  sa.Xv = sd.X.leftCols(6);
  for (int r = 0; r < 6; ++r) sa.Av.row(r) = sa.Xv.row(sa.common[static_cast<size_t>(r)]);
  const Eigen::LLT<Mat6> llt(sa.Av);
  if (llt.info() != Eigen::Success) return false;
  const Vec6 diag = llt.matrixLLT().diagonal();
  if (!(diag.minCoeff() > 0.0) || !(diag.minCoeff() * diag.minCoeff() >= sys.options.fast_tol * diag.maxCoeff() * diag.maxCoeff()))
    return false;
  for (int j = 0; j < na; ++j) sa.Cc.col(j) = sd.S[j] * sa.Xv.row(sd.dofs[static_cast<size_t>(j)]).transpose();
  const Mat6& L = llt.matrixLLT();  // Cc <- L^-T L^-1 Cc, as row operations
  double* c = sa.Cc.data();
  const Eigen::Index lc = sa.Cc.outerStride();
  for (int i = 0; i < 6; ++i) {
    for (int k = 0; k < i; ++k) axpy_row(c + i * lc, c + k * lc, L(i, k), na);
    scale_row(c + i * lc, 1.0 / L(i, i), na);
  }
  for (int i = 5; i >= 0; --i) {
    for (int k = i + 1; k < 6; ++k) axpy_row(c + i * lc, c + k * lc, L(k, i), na);
    scale_row(c + i * lc, 1.0 / L(i, i), na);
  }
  return true;
}

}  // namespace

bool sigma_arms_torque(const System& sys, const Workspace& ws, WrenchSigmaData& sd, SigmaArms& sa) {
  const int na = static_cast<int>(sd.dofs.size());
  for (size_t g = 0; g < sa.arms.size(); ++g)
    if (!factor_arm(sys.constraints, ws, ws.qb.groups[g], sa.arms[g], sys.options.fast_tol)) return false;
  if (!load_columns(sys, sd, sa)) return false;
  const Eigen::Index lc = sd.C.outerStride(), lcc = sa.Cc.outerStride();
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k)  // C = V c, each output's 6 rows in one sweep
    mat6_times(sa.V.data() + 36 * k, sa.Cc.data(), lcc, sd.C.data() + 6 * static_cast<Eigen::Index>(k) * lc, lc, na);
  for (size_t g = 0; g < sa.arms.size(); ++g) {  // + H
    if (sa.arms[g].nj == 0) continue;
    held_solve(sys, ws, sd, sa, sa.arms[g], static_cast<int>(g));
    held_pass(sys, ws, sd, sa, sa.arms[g], static_cast<int>(g));
  }
  return true;
}

}  // namespace coopdyn
