#include "service/dynamics/wrenches.h"

#include "service/dynamics/canonical_basis.h"
#include "service/dynamics/jacobi.h"

#include <algorithm>
#include <cmath>

#include "service/algorithms/joint_reactions.h"
#include "service/algorithms/kinematics.h"

namespace coopdyn {

const char* wrench_kind_name(WrenchKind k) {
  switch (k) {
    case WrenchKind::kEndEffector: return "end_effector";
    case WrenchKind::kBase: return "base";
    case WrenchKind::kTip: return "tip";
    case WrenchKind::kAxle: return "axle";
    case WrenchKind::kJoint: return "joint";
  }
  return "?";
}

void WrenchSet::compile(const Model& model, const ConstraintSet& cs) {
  std::stable_sort(outputs.begin(), outputs.end(),
                   [](const WrenchOutput& a, const WrenchOutput& b) { return a.kind < b.kind; });
  for (WrenchOutput& o : outputs) {
    o.frame_rotated = !(o.X_BF.R.array() == Mat3::Identity().array()).all();
    o.frame_offset = !(o.X_BF.p.array() == 0.0).all();
  }
  const int nb = model.nbodies();
  in_pass.assign(nb, 0);
  for (const WrenchOutput& o : outputs)
    if (o.spec < 0 && o.body >= 0) in_pass[o.body] = 1;
  for (int i = 0; i < nb; ++i)
    if (model.bodies[i].parent >= 0 && in_pass[model.bodies[i].parent]) in_pass[i] = 1;
  pass.clear();
  for (int i = nb - 1; i >= 0; --i)
    if (in_pass[i]) pass.push_back(i);
  pass_specs.clear();
  auto touches = [&](int frame) { return frame >= 0 && model.frames[frame].body >= 0 && in_pass[model.frames[frame].body]; };
  for (size_t s = 0; s < cs.specs.size(); ++s) {
    const ConstraintSpec& c = cs.specs[s];
    const bool t = c.kind == ConstraintKind::kRolling ? in_pass[c.body] != 0
                   : c.kind == ConstraintKind::kWeld  ? touches(c.frame_a) || touches(c.frame_b)
                                                      : false;  // a lock is a generalized force inside its joint
    if (t) pass_specs.push_back(static_cast<int>(s));
  }
  out_spec_begin.assign(1, 0);
  out_spec.clear();
  for (const WrenchOutput& o : outputs) {
    if (o.spec < 0 && o.body >= 0)
      for (size_t j = 0; j < pass_specs.size(); ++j) {
        const ConstraintSpec& c = cs.specs[pass_specs[j]];
        auto inside = [&](int b) { return b >= 0 && model.is_ancestor(o.body, b); };
        int coef = 0;  // constraint_body_forces: +F on the body of frame A (rolling: the wheel), -F on frame B's
        if (c.kind == ConstraintKind::kRolling) {
          coef -= inside(c.body);
        } else {
          coef -= inside(model.frames[c.frame_a].body);
          if (c.frame_b >= 0) coef += inside(model.frames[c.frame_b].body);
        }
        if (coef != 0) out_spec.emplace_back(static_cast<int>(j), coef);
      }
    out_spec_begin.push_back(static_cast<int>(out_spec.size()));
  }
}

WrenchData::WrenchData(const System& sys) {
  const size_t nb = static_cast<size_t>(sys.model.nbodies()), no = sys.wrenches.outputs.size();
  W.assign(no, Vec6::Zero());
  indeterminate.assign(no, 0);
  f_ext.assign(nb, Vec6::Zero());
  a.assign(nb, Vec6::Zero());
  acc.assign(nb, Vec6::Zero());
  R.assign(nb, Vec6::Zero());
  dF_spec.assign(sys.wrenches.pass_specs.size(), Vec6::Zero());
  dlam.setZero(sys.constraints.rows);
  const ConstraintSet& cs = sys.constraints;
  const int m = cs.rows;
  free_lambda.setZero(m, m);
  free_class.assign(static_cast<size_t>(m), FreeClass::kMixed);
  free_W.setZero(6 * static_cast<Eigen::Index>(no), m);
  fb_N.setZero(m, m);
  fb_T.setZero(m, m);
  fb_A.setZero(m, m);
  fb_V.setZero(m, m);
  fb_w.setZero(m);
  fb_g.setZero(m);
  row_class.assign(static_cast<size_t>(m), static_cast<uint8_t>(FreeClass::kMixed));
  class_present.assign(kFreeClasses, 0);
  for (size_t s = 0; s < cs.specs.size(); ++s)
    for (int r = 0; r < cs.row_count[s]; ++r) {
      const int ax = cs.row_axis[s][r];
      FreeClass c;
      switch (cs.specs[s].kind) {
        case ConstraintKind::kRolling:
          c = ax == 5 ? FreeClass::kWheelNormal : ax == 4 ? FreeClass::kWheelLateral : FreeClass::kWheelLongitudinal;
          break;
        case ConstraintKind::kLock:
        case ConstraintKind::kCouple: c = FreeClass::kLock; break;
        default: c = ax < 3 ? FreeClass::kMoment : FreeClass::kForce; break;
      }
      row_class[static_cast<size_t>(cs.row_offset[s] + r)] = static_cast<uint8_t>(c);
      class_present[static_cast<size_t>(c)] = 1;
    }
}

const char* free_class_name(FreeClass c) {
  switch (c) {
    case FreeClass::kWheelNormal: return "wheel_normal";
    case FreeClass::kWheelLateral: return "wheel_lateral";
    case FreeClass::kWheelLongitudinal: return "wheel_longitudinal";
    case FreeClass::kForce: return "force";
    case FreeClass::kMoment: return "moment";
    case FreeClass::kLock: return "lock";
    case FreeClass::kMixed: break;
  }
  return "mixed";
}

namespace {

Transform report_frame(const Model& model, const Data& data, const ConstraintSet& cs, const WrenchOutput& o) {
  if (o.centre_of >= 0) {
    const ConstraintSpec& c = cs.specs[o.centre_of];
    return Transform(rolling_contact_frame(model, data, c).R, data.X_WB[c.body].p);
  }
  if (o.spec >= 0) {
    const ConstraintSpec& c = cs.specs[o.spec];
    return c.kind == ConstraintKind::kRolling ? rolling_contact_frame(model, data, c) : frame_pose(model, data, c.frame_a);
  }
  return o.frame_body >= 0 ? data.X_WB[o.frame_body] * o.X_BF : o.X_BF;
}

// A spatial force F (world coordinates at p_ref) expressed in output o's frame F at its origin,
// negated for a reversed output. The frame F = X_WB * X_BF of a reaction is not formed:
// the rotations are applied one after the other (cheaper, and no 3x3 product through memory), the
// second only when X_BF turns, its offset only when it has one. Written in scalars: Eigen's cross
// product of a freshly computed 3-vector reloads it from the stack in overlapping pairs, which
// stalls store-to-load forwarding (the loop spent a quarter of its time there).
inline void rotate_t(const Mat3& R, double x, double y, double z, double& a, double& b, double& c) {  // R^T v
  a = R(0, 0) * x + R(1, 0) * y + R(2, 0) * z;
  b = R(0, 1) * x + R(1, 1) * y + R(2, 1) * z;
  c = R(0, 2) * x + R(1, 2) * y + R(2, 2) * z;
}
struct Six {  // a spatial force as six scalars, returned in registers
  double v0, v1, v2, v3, v4, v5;
};
// Inlined at both calls (the output loop, the null-space pass): a call would return the result
// through memory, which the null-space test reloads in packets (store-to-load forwarding again).
EIGEN_ALWAYS_INLINE Six reaction_in_frame(const Data& data, const ConstraintSet& cs, const ConstraintData& cd,
                                          const WrenchOutput& o, const double* F) {
  const double nx = F[0], ny = F[1], nz = F[2], fx = F[3], fy = F[4], fz = F[5];
  const Mat3* R1;
  const Mat3* R2 = nullptr;
  double px, py, pz;  // the frame's origin relative to p_ref
  if (o.centre_of >= 0) {  // the wheel centre, in the contact frame's axes (the evaluation's)
    R1 = &cd.X_RS[o.centre_of].R;
    const Vec3& c = data.X_WB[cs.specs[o.centre_of].body].p;
    px = c[0] - data.p_ref[0];
    py = c[1] - data.p_ref[1];
    pz = c[2] - data.p_ref[2];
  } else if (o.frame_body >= 0) {
    const Transform& X = data.X_WB[o.frame_body];
    R1 = &X.R;
    if (o.frame_rotated) R2 = &o.X_BF.R;
    px = X.p[0] - data.p_ref[0];
    py = X.p[1] - data.p_ref[1];
    pz = X.p[2] - data.p_ref[2];
    if (o.frame_offset) {
      const Vec3& q = o.X_BF.p;
      px += X.R(0, 0) * q[0] + X.R(0, 1) * q[1] + X.R(0, 2) * q[2];
      py += X.R(1, 0) * q[0] + X.R(1, 1) * q[1] + X.R(1, 2) * q[2];
      pz += X.R(2, 0) * q[0] + X.R(2, 1) * q[1] + X.R(2, 2) * q[2];
    }
  } else {
    R1 = &o.X_BF.R;
    px = o.X_BF.p[0] - data.p_ref[0];
    py = o.X_BF.p[1] - data.p_ref[1];
    pz = o.X_BF.p[2] - data.p_ref[2];
  }
  // the moment about the frame's origin: n - p x f
  const double mx = nx - (py * fz - pz * fy), my = ny - (pz * fx - px * fz), mz = nz - (px * fy - py * fx);
  double a0, a1, a2, b0, b1, b2;
  rotate_t(*R1, mx, my, mz, a0, a1, a2);
  rotate_t(*R1, fx, fy, fz, b0, b1, b2);
  if (R2) {
    rotate_t(*R2, a0, a1, a2, a0, a1, a2);
    rotate_t(*R2, b0, b1, b2, b0, b1, b2);
  }
  const double sg = o.reversed ? -1.0 : 1.0;
  return Six{sg * a0, sg * a1, sg * a2, sg * b0, sg * b1, sg * b2};
}

}  // namespace

Transform wrench_frame_pose(const System& sys, const Data& data, int k) {
  return report_frame(sys.model, data, sys.constraints, sys.wrenches.outputs[k]);
}

// In scalars (see reaction_in_frame).
void spec_force(const ConstraintSet& cs, const ConstraintData& cd, const double* lambda, int s, double* F) {
  // the spec's wrench [moment; force] in its own frame (tip_wrench's layout)
  double w[6] = {0, 0, 0, 0, 0, 0};
  const int r0 = cs.row_offset[s];
  for (int k = 0; k < cs.row_count[s]; ++k) w[cs.row_axis[s][k]] = lambda[r0 + k];
  set_rolling_resistance_moment(cs, cd, s, w);
  const Mat3& R = cd.X_RS[s].R;
  const Vec3& p = cd.X_RS[s].p;
  const double f0 = R(0, 0) * w[3] + R(0, 1) * w[4] + R(0, 2) * w[5];
  const double f1 = R(1, 0) * w[3] + R(1, 1) * w[4] + R(1, 2) * w[5];
  const double f2 = R(2, 0) * w[3] + R(2, 1) * w[4] + R(2, 2) * w[5];
  F[0] = R(0, 0) * w[0] + R(0, 1) * w[1] + R(0, 2) * w[2] + (p[1] * f2 - p[2] * f1);
  F[1] = R(1, 0) * w[0] + R(1, 1) * w[1] + R(1, 2) * w[2] + (p[2] * f0 - p[0] * f2);
  F[2] = R(2, 0) * w[0] + R(2, 1) * w[1] + R(2, 2) * w[2] + (p[0] * f1 - p[1] * f0);
  F[3] = f0, F[4] = f1, F[5] = f2;
}

namespace {

// The constraint forces of multipliers lambda on the bodies of the reaction pass (world coordinates
// at data.p_ref) into f_ext. Only the bodies the pass specs push on are ever written (zeroed first
// here); the others keep the zero WrenchData's constructor gave them.
void constraint_body_forces(const System& sys, const ConstraintData& cd, const double* lambda, std::vector<Vec6>& f_ext) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  const WrenchSet& ws = sys.wrenches;
  auto zero = [&](int body) {
    double* e = f_ext[body].data();
    for (int k = 0; k < 6; ++k) e[k] = 0.0;
  };
  for (int s : ws.pass_specs) {
    const ConstraintSpec& c = cs.specs[s];
    if (c.kind == ConstraintKind::kRolling) {
      zero(c.body);
      continue;
    }
    const int ba = model.frames[c.frame_a].body, bb = c.frame_b >= 0 ? model.frames[c.frame_b].body : -1;
    if (ba >= 0 && ws.in_pass[ba]) zero(ba);
    if (bb >= 0 && ws.in_pass[bb]) zero(bb);
  }
  for (int s : ws.pass_specs) {
    const ConstraintSpec& c = cs.specs[s];
    double F[6];
    spec_force(cs, cd, lambda, s, F);
    auto add = [&](int body, double sign) {
      double* e = f_ext[body].data();
      for (int k = 0; k < 6; ++k) e[k] += sign * F[k];
    };
    if (c.kind == ConstraintKind::kRolling) {
      add(c.body, 1.0);
      continue;
    }
    // the other side's wrench on tip frame A; its opposite acts on frame B's body
    const int ba = model.frames[c.frame_a].body, bb = c.frame_b >= 0 ? model.frames[c.frame_b].body : -1;
    if (ba >= 0 && ws.in_pass[ba]) add(ba, 1.0);
    if (bb >= 0 && ws.in_pass[bb]) add(bb, -1.0);
  }
}

}  // namespace

namespace {
// wd.free_lambda <- the null space of Q grouped by FreeClass: for each class in turn, the directions
// of the remaining basis N that move no row outside the class are the null space of N_out (its rows
// outside the class), i.e. the eigenvectors of N_out^T N_out with eigenvalue ~0 (Jacobi, k x k);
// they are taken out and the rest (orthonormal, the other eigenvectors) goes on to the next class.
void free_basis(const System& sys, const Workspace& ws, WrenchData& wd) {
  const ConstraintSet& cs = sys.constraints;
  const int m = cs.rows;
  const bool basis = sys.options.formulation != Formulation::kSvdBaseline && !ws.qs.fast_path;
  int k = 0;
  Eigen::MatrixXd& N = wd.fb_N;
  if (basis) {
    k = m - ws.qs.rank;
    for (int j = 0; j < k; ++j)
      for (int i = 0; i < m; ++i) N(i, j) = ws.qs.Nq(i, j);
  } else {
    for (int d = 0; d < m; ++d) {
      if (!ws.qs.row_indeterminate[d]) continue;
      for (int i = 0; i < m; ++i) N(i, k) = i == d ? 1.0 : 0.0;
      ++k;
    }
  }
  int nf = 0;
  auto take = [&](int col_N, FreeClass c) {  // N's column (after the rotation) -> free_lambda, sign fixed
    int imax = 0;
    for (int i = 1; i < m; ++i)
      if (std::abs(N(i, col_N)) > std::abs(N(imax, col_N)) + 1e-12) imax = i;
    const double sg = N(imax, col_N) < 0 ? -1.0 : 1.0;
    for (int i = 0; i < m; ++i) wd.free_lambda(i, nf) = sg * N(i, col_N);
    wd.free_class[static_cast<size_t>(nf)] = c;
    ++nf;
  };
  const uint8_t* rc = wd.row_class.data();
  double* Nd = N.data();
  const Eigen::Index ld = N.outerStride();
  for (int cls = 0; cls < kFreeClasses - 1 && k > 0; ++cls) {
    if (!wd.class_present[static_cast<size_t>(cls)]) continue;
    auto A = wd.fb_A.topLeftCorner(k, k);
    for (int a = 0; a < k; ++a)  // A = N_out^T N_out over the rows outside the class
      for (int b = a; b < k; ++b) {
        const double* na = Nd + a * ld;
        const double* nb = Nd + b * ld;
        double x = 0;
        for (int i = 0; i < m; ++i) x += rc[i] == cls ? 0.0 : na[i] * nb[i];
        A(a, b) = A(b, a) = x;
      }
    auto w = wd.fb_w.head(k);
    auto V = wd.fb_V.topLeftCorner(k, k);
    jacobi_eigen(A, w, V);  // ascending
    int j = 0;
    while (j < k && w[j] < 1e-12) ++j;
    if (j == 0) continue;
    // T = N V: the first j columns lie in the class, the others are the rest
    double* Td = wd.fb_T.data();
    const Eigen::Index lt = wd.fb_T.outerStride();
    for (int c = 0; c < k; ++c) {
      double* t = Td + c * lt;
      for (int i = 0; i < m; ++i) t[i] = 0.0;
      for (int a = 0; a < k; ++a) {
        const double v = V(a, c);
        const double* na = Nd + a * ld;
        for (int i = 0; i < m; ++i) t[i] += v * na[i];
      }
    }
    for (int c = 0; c < j; ++c) {
      double* t = Td + c * lt;
      for (int i = 0; i < m; ++i)  // exactly in the class: round-off outside it dropped
        if (rc[i] != cls) t[i] = 0.0;
    }
    canonical_basis(Td, lt, m, j, wd.fb_g.data());
    for (int c = 0; c < j; ++c) {
      for (int i = 0; i < m; ++i) Nd[c * ld + i] = Td[c * lt + i];
      take(c, static_cast<FreeClass>(cls));
    }
    for (int c = j; c < k; ++c)
      for (int i = 0; i < m; ++i) Nd[(c - j) * ld + i] = Td[c * lt + i];
    k -= j;
  }
  canonical_basis(Nd, ld, m, k, wd.fb_g.data());
  for (int c = 0; c < k; ++c) take(c, FreeClass::kMixed);
  wd.num_free = nf;
}
}  // namespace

void compute_wrenches(const System& sys, const Workspace& ws, WrenchData& wd) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  const WrenchSet& set = sys.wrenches;
  const Data& data = ws.data;
  const size_t no = set.outputs.size();
  if (ws.diag.status == Status::kError) {
    for (size_t k = 0; k < no; ++k) {
      wd.W[k].setZero();
      wd.indeterminate[k] = 0;
    }
    wd.num_free = 0;
    return;
  }
  if (!set.pass.empty()) {
    constraint_body_forces(sys, ws.cd, ws.lambda.data(), wd.f_ext);
    joint_reactions(model, data, ws.vdot, wd.f_ext, set.pass, wd.a, wd.acc, wd.R);
  }
  for (size_t k = 0; k < no; ++k) {
    const WrenchOutput& o = set.outputs[k];
    double* W = wd.W[k].data();
    if (o.spec >= 0) {  // tip_wrench(), in scalars
      unsigned mask = 0;
      for (int c = 0; c < 6; ++c) W[c] = 0.0;
      const int r0 = cs.row_offset[o.spec];
      for (int r = 0; r < cs.row_count[o.spec]; ++r) {
        const int ax = cs.row_axis[o.spec][r];
        W[ax] = ws.lambda[r0 + r];
        if (ws.qs.row_indeterminate[r0 + r]) mask |= 1u << ax;
      }
      set_rolling_resistance_moment(cs, ws.cd, o.spec, W);
      if (ws.cd.rr_arm[o.spec] != 0.0 && (mask & (1u << 5))) mask |= 1u << 1;  // it moves with an indeterminate N
      wd.indeterminate[k] = static_cast<uint8_t>(mask);
      continue;
    }
    const Six r = reaction_in_frame(data, cs, ws.cd, o, wd.R[o.body].data());
    W[0] = r.v0, W[1] = r.v1, W[2] = r.v2, W[3] = r.v3, W[4] = r.v4, W[5] = r.v5;
    wd.indeterminate[k] = 0;
  }
  // Free directions of lambda (an over-constrained system): a reaction component that moves along
  // one is not determined by the physics. The directions are the null space of Q where the solve
  // computed it, else (the SVD baseline) every indeterminate row on its own.
  wd.num_free = 0;
  if (ws.diag.indeterminate <= 0) return;
  free_basis(sys, ws, wd);
  for (int d = 0; d < wd.num_free; ++d) {
    const double* dlam = wd.free_lambda.col(d).data();
    double* FW = wd.free_W.col(d).data();
    for (size_t k = 0; k < no; ++k) {  // a tip's wrench is its rows of lambda
      const WrenchOutput& o = set.outputs[k];
      if (o.spec < 0) continue;
      for (int c = 0; c < 6; ++c) FW[6 * k + c] = 0.0;
      const int r0 = cs.row_offset[o.spec];
      for (int r = 0; r < cs.row_count[o.spec]; ++r) FW[6 * k + cs.row_axis[o.spec][r]] = dlam[r0 + r];
      set_rolling_resistance_moment(cs, ws.cd, o.spec, FW + 6 * k);
    }
    if (set.pass.empty()) continue;
    for (size_t j = 0; j < set.pass_specs.size(); ++j) spec_force(cs, ws.cd, dlam, set.pass_specs[j], wd.dF_spec[j].data());
    for (size_t k = 0; k < no; ++k) {
      const WrenchOutput& o = set.outputs[k];
      if (o.spec >= 0) continue;
      // the reaction's change: minus the subtree sum of the force change (WrenchSet::out_spec)
      double dR[6] = {0, 0, 0, 0, 0, 0};
      for (int t = set.out_spec_begin[k]; t < set.out_spec_begin[k + 1]; ++t) {
        const double* F = wd.dF_spec[set.out_spec[t].first].data();
        const double c = set.out_spec[t].second;
        for (int i = 0; i < 6; ++i) dR[i] += c * F[i];
      }
      const Six r = reaction_in_frame(data, cs, ws.cd, o, dR);
      FW[6 * k + 0] = r.v0, FW[6 * k + 1] = r.v1, FW[6 * k + 2] = r.v2;
      FW[6 * k + 3] = r.v3, FW[6 * k + 4] = r.v4, FW[6 * k + 5] = r.v5;
      auto bit = [](double x, int c) { return static_cast<unsigned>(std::abs(x) > 1e-6) << c; };
      unsigned mask = wd.indeterminate[k];
      mask |= bit(r.v0, 0) | bit(r.v1, 1) | bit(r.v2, 2) | bit(r.v3, 3) | bit(r.v4, 4) | bit(r.v5, 5);
      wd.indeterminate[k] = static_cast<uint8_t>(mask);
    }
  }
}

}  // namespace coopdyn
