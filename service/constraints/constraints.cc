#include "service/constraints/constraints.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "service/algorithms/jacobians.h"
#include "service/algorithms/kinematics.h"

namespace coopdyn {

namespace {

// One spec's rows: the axis of each row, their compliances (appended to comp) and the DOFs it
// touches (ascending). Invalid specs throw std::invalid_argument.
struct SpecLayout {
  std::array<int, 6> ax{{-1, -1, -1, -1, -1, -1}};
  int n = 0;
  std::vector<int> sup;
};

void weld_layout(const Model& model, const ConstraintSpec& c, SpecLayout& l, std::vector<double>& comp) {
  if (c.frame_a < 0 || c.frame_a >= static_cast<int>(model.frames.size()))
    throw std::invalid_argument("constraint '" + c.name + "': unknown tip frame");
  if (c.frame_b >= static_cast<int>(model.frames.size()))
    throw std::invalid_argument("constraint '" + c.name + "': unknown second frame");
  for (int k = 0; k < 6; ++k)
    if (c.axes[k]) {
      l.ax[l.n++] = k;
      comp.push_back(c.compliance[k]);
    }
  if (l.n == 0) throw std::invalid_argument("constraint '" + c.name + "': no axes selected");
  const int ba = model.frames[c.frame_a].body;
  if (ba >= 0) l.sup = model.support_dofs(ba);
  if (c.frame_b >= 0) {
    const int bb = model.frames[c.frame_b].body;
    if (bb >= 0) {
      std::vector<int> sb = model.support_dofs(bb), u;
      std::set_union(l.sup.begin(), l.sup.end(), sb.begin(), sb.end(), std::back_inserter(u));
      l.sup = u;
    }
  }
}

void rolling_layout(const Model& model, const ConstraintSpec& c, SpecLayout& l, std::vector<double>& comp,
                    bool& rolling_resistance) {
  if (c.body < 0 || c.body >= model.nbodies())
    throw std::invalid_argument("constraint '" + c.name + "': unknown wheel body");
  if (!(c.radius > 0.0) || !std::isfinite(c.radius))
    throw std::invalid_argument("constraint '" + c.name + "': wheel radius must be > 0");
  if (!(std::abs(c.axle.norm() - 1.0) < 1e-9))
    throw std::invalid_argument("constraint '" + c.name + "': wheel axle must be a unit vector");
  if (!(c.rolling_resistance >= 0.0 && c.rolling_resistance <= 0.1))
    throw std::invalid_argument("constraint '" + c.name + "': rolling resistance must be in [0, 0.1]");
  if (c.rolling_resistance > 0) rolling_resistance = true;
  if (!(std::abs(c.ground_n.norm() - 1.0) < 1e-9) || !std::isfinite(c.ground_d))
    throw std::invalid_argument("constraint '" + c.name + "': ground normal must be a unit vector, offset finite");
  for (int k = 0; k < 3; ++k) {
    l.ax[l.n++] = 3 + k;
    comp.push_back(c.compliance[3 + k]);
  }
  l.sup = model.support_dofs(c.body);
}

void lock_layout(const Model& model, const ConstraintSpec& c, SpecLayout& l, std::vector<double>& comp) {
  if (c.dof < 0 || c.dof >= model.nv()) throw std::invalid_argument("constraint '" + c.name + "': bad DOF");
  l.ax[0] = 0;
  l.n = 1;
  comp.push_back(c.compliance[0]);
  l.sup = {c.dof};
}

void couple_layout(const Model& model, const ConstraintSpec& c, SpecLayout& l, std::vector<double>& comp) {
  auto one_dof = [&](int d) { return d >= 0 && d < model.nv() && model.bodies[model.dof_body[d]].joint.nv == 1; };
  if (!one_dof(c.dof) || !one_dof(c.couple_dof) || c.dof == c.couple_dof)
    throw std::invalid_argument("constraint '" + c.name + "': a coupling needs two different one-DOF joints");
  if (!std::isfinite(c.multiplier) || !std::isfinite(c.offset))
    throw std::invalid_argument("constraint '" + c.name + "': coupling multiplier and offset must be finite");
  l.ax[0] = 0;
  l.n = 1;
  comp.push_back(c.compliance[0]);
  l.sup = {std::min(c.dof, c.couple_dof), std::max(c.dof, c.couple_dof)};
}

}  // namespace

void ConstraintSet::compile(const Model& model) {
  rows = 0;
  rolling_resistance = false;
  row_offset.clear();
  row_count.clear();
  row_axis.clear();
  support.clear();
  row_spec.clear();
  couple_specs.clear();
  std::vector<double> comp;
  for (size_t s = 0; s < specs.size(); ++s) {
    const ConstraintSpec& c = specs[s];
    SpecLayout l;
    if (c.kind == ConstraintKind::kWeld) {
      weld_layout(model, c, l, comp);
    } else if (c.kind == ConstraintKind::kRolling) {
      rolling_layout(model, c, l, comp, rolling_resistance);
    } else if (c.kind == ConstraintKind::kCouple) {
      couple_layout(model, c, l, comp);
      couple_specs.push_back(static_cast<int>(s));
    } else {
      lock_layout(model, c, l, comp);
    }
    row_offset.push_back(rows);
    row_count.push_back(l.n);
    row_axis.push_back(l.ax);
    support.push_back(l.sup);
    for (int k = 0; k < l.n; ++k) row_spec.push_back(static_cast<int>(s));
    rows += l.n;
  }
  row_compliance = Eigen::Map<Eigen::VectorXd>(comp.data(), static_cast<Eigen::Index>(comp.size()));
}

ConstraintData::ConstraintData(const Model& model, const ConstraintSet& set) {
  G.setZero(set.rows, model.nv());
  Gdot_v.setZero(set.rows);
  err.setZero(set.rows);
  Gv.setZero(set.rows);
  gamma.setZero(set.rows);
  J_a.setZero(6, model.nv());
  J_b.setZero(6, model.nv());
  X_RS.assign(set.specs.size(), Transform());
  rr_arm.assign(set.specs.size(), 0.0);
  lock_target.assign(set.specs.size(), 0.0);
  for (size_t s = 0; s < set.specs.size(); ++s)
    if (set.specs[s].kind == ConstraintKind::kLock) lock_target[s] = set.specs[s].q_target;
}

namespace {

// Contact geometry of a rolling disk and its time derivative along the motion (ConstraintKind::
// kRolling). All vectors in world coordinates; n is the ground plane's unit normal.
struct RollingGeometry {
  Vec3 a, d, x, y, p;              // axle, centre->top of the wheel plane, heading, lateral, contact point
  Vec3 d_dot, x_dot, y_dot, p_dot; // their rates; p_dot is the geometric contact point's velocity
                                   // (it runs around the rim), not the wheel material's
};

// R = R_WB, c = p_WB (wheel centre), w = angular velocity and c_dot = centre velocity (world).
void rolling_geometry(const Mat3& R, const Vec3& c, const Vec3& axle, double r, const Vec3& n, const Vec3& w,
                      const Vec3& c_dot, RollingGeometry& g) {
  g.a = R * axle;
  const Vec3 a_dot = w.cross(g.a);
  const double s = n.dot(g.a), s_dot = n.dot(a_dot);
  const Vec3 m = n - s * g.a;                    // |m| = |a x n| = sqrt(1 - s^2) = k
  const Vec3 m_dot = -s_dot * g.a - s * a_dot;
  const double k = m.norm();
  if (k < 1e-9) {  // wheel lying flat: no heading; any frame, no rates (finite, not physical)
    g.x = g.a.unitOrthogonal();
    g.y = n.cross(g.x);
    g.d = g.a.cross(g.x).normalized();
    g.d_dot.setZero();
    g.x_dot.setZero();
    g.y_dot.setZero();
    g.p = c - r * g.d;
    g.p_dot = c_dot;
    return;
  }
  const Vec3 b = g.a.cross(n), b_dot = a_dot.cross(n);
  g.d = m / k;
  g.d_dot = (m_dot - g.d * g.d.dot(m_dot)) / k;  // d/dt (m/|m|)
  g.x = b / k;
  g.x_dot = (b_dot - g.x * g.x.dot(b_dot)) / k;
  g.y = n.cross(g.x);
  g.y_dot = n.cross(g.x_dot);
  g.p = c - r * g.d;
  g.p_dot = c_dot - r * g.d_dot;
}

}  // namespace

Transform rolling_contact_frame(const Model& model, const Data& data, const ConstraintSpec& c) {
  (void)model;
  const Transform& X_WB = data.X_WB[c.body];
  RollingGeometry g;
  rolling_geometry(X_WB.R, X_WB.p, c.axle, c.radius, c.ground_n, Vec3::Zero(), Vec3::Zero(), g);
  Transform X_WC;
  X_WC.R.col(0) = g.x;
  X_WC.R.col(1) = g.y;
  X_WC.R.col(2) = c.ground_n;
  X_WC.p = g.p;
  return X_WC;
}

namespace {

// A pseudo-joint lock: one row on its DOF, the error from the held target.
void lock_rows(const ConstraintSpec& c, int s, int r0, const Eigen::VectorXd& q, const Eigen::VectorXd& v, bool errors,
               ConstraintData& cd) {
  cd.G(r0, c.dof) = 1.0;
  cd.Gdot_v[r0] = 0.0;
  if (errors) cd.err[r0] = q[c.q_index] - cd.lock_target[s];
  cd.Gv[r0] = v[c.dof];
}

// A coupling q_j = m q_i + o: one row e_j - m e_i, no Gdot v.
void couple_rows(const ConstraintSpec& c, int r0, const Eigen::VectorXd& q, const Eigen::VectorXd& v, bool errors,
                 ConstraintData& cd) {
  cd.G(r0, c.dof) = 1.0;
  cd.G(r0, c.couple_dof) = -c.multiplier;
  cd.Gdot_v[r0] = 0.0;
  if (errors) cd.err[r0] = q[c.q_index] - c.multiplier * q[c.couple_q] - c.offset;
  cd.Gv[r0] = v[c.dof] - c.multiplier * v[c.couple_dof];
}

// A rolling wheel, rows: C^T u, u = v_R + w x p_RP the wheel's material velocity at the contact
// point P, from the body twist at the reference point R [w; v_R] = S_W v. Along the motion (vdot = 0)
//   d/dt (C^T u) = Cdot^T u + C^T (a_R + alpha x p_RP + w x pdot_RP)
// with [alpha; a_R] the body's spatial acceleration at vdot = 0 (A0) at R. The geometry is
// computed relative to R (positions p_R*), the contact height in the world.
void rolling_rows(const Data& data, const ConstraintSpec& c, int s, int r0, const std::vector<int>& sup, bool errors,
                  ConstraintData& cd) {
  const Transform& X_WB = data.X_WB[c.body];
  const Vec6& V_W = data.V_W[c.body];
  const Vec6& A_W = data.A0_W[c.body];
  const Vec3 w = V_W.head<3>();
  RollingGeometry g;
  const Vec3 c_R = X_WB.p - data.p_ref;  // wheel centre relative to R
  rolling_geometry(X_WB.R, c_R, c.axle, c.radius, c.ground_n, w, V_W.tail<3>() + w.cross(c_R), g);
  const Vec3 u = V_W.tail<3>() + w.cross(g.p);
  const Vec3 u_dot = A_W.tail<3>() + A_W.head<3>().cross(g.p) + w.cross(g.p_dot);
  const Vec3& nz = c.ground_n;
  for (int d : sup) {
    const Vec3 Jp = data.S_W.col(d).tail<3>() + data.S_W.col(d).head<3>().cross(g.p);
    cd.G(r0, d) = g.x.dot(Jp);
    cd.G(r0 + 1, d) = g.y.dot(Jp);
    cd.G(r0 + 2, d) = nz.dot(Jp);
  }
  cd.Gv[r0] = g.x.dot(u);
  cd.Gv[r0 + 1] = g.y.dot(u);
  cd.Gv[r0 + 2] = nz.dot(u);
  cd.Gdot_v[r0] = g.x_dot.dot(u) + g.x.dot(u_dot);
  cd.Gdot_v[r0 + 1] = g.y_dot.dot(u) + g.y.dot(u_dot);
  cd.Gdot_v[r0 + 2] = nz.dot(u_dot);
  if (errors) {
    cd.err[r0] = 0.0;  // nonholonomic: no position error, so no Baumgarte beta term
    cd.err[r0 + 1] = 0.0;
    cd.err[r0 + 2] = nz.dot(g.p + data.p_ref) - c.ground_d;  // height of the contact point above the plane
  }
  if (c.rolling_resistance > 0) {
    const double uc = g.x.dot(V_W.tail<3>() + w.cross(c_R));  // the centre's speed along the heading
    cd.rr_arm[s] = -c.rolling_resistance * c.radius * uc / std::sqrt(uc * uc + kRollingResistanceSpeed * kRollingResistanceSpeed);
  }
  Transform& X_RC = cd.X_RS[s];
  X_RC.R.col(0) = g.x;
  X_RC.R.col(1) = g.y;
  X_RC.R.col(2) = nz;
  X_RC.p = g.p;
}

// A weld of a frame on a body to the world (every arm base of a mobile platform, every classic
// tip): one pose, and each row of G is a component of X_WA^-1 applied to a motion-subspace column,
// written straight into G (column d of G holds the spec's rows contiguously).
void world_weld_rows(const Data& data, const ConstraintSet& set, const ConstraintSpec& c, int s, int body_a,
                     const Transform& X_WA, bool errors, ConstraintData& cd) {
  const int r0 = set.row_offset[s], n = set.row_count[s];
  const Mat3 Rt = X_WA.R.transpose();
  const Vec3 p_RA = X_WA.p - data.p_ref;
  const std::array<int, 6>& axes = set.row_axis[s];
  if (n == 6) {  // every axis (a full weld: axes 0..5): each column's six rows written whole
    for (int d : set.support[s]) {
      const Vec3 w = data.S_W.col(d).head<3>();
      const Vec3 vo = data.S_W.col(d).tail<3>();
      double* g = cd.G.col(d).data() + r0;
      Eigen::Map<Vec3>(g).noalias() = Rt * w;
      Eigen::Map<Vec3>(g + 3).noalias() = Rt * (vo - p_RA.cross(w));
    }
  } else {
    for (int d : set.support[s]) {
      const Vec3 w = data.S_W.col(d).head<3>();
      const Vec3 vo = data.S_W.col(d).tail<3>();
      Vec6 J;
      J.head<3>().noalias() = Rt * w;
      J.tail<3>().noalias() = Rt * (vo - p_RA.cross(w));
      double* g = cd.G.col(d).data() + r0;
      for (int k = 0; k < n; ++k) g[k] = J[axes[k]];
    }
  }
  // V and A0 of the body seen in A (inv_act of the pose relative to R, by halves)
  Vec6 V_A, a_A;
  {
    const Vec3 w = data.V_W[body_a].head<3>(), vo = data.V_W[body_a].tail<3>();
    const Vec3 aw = data.A0_W[body_a].head<3>(), ao = data.A0_W[body_a].tail<3>();
    V_A.head<3>().noalias() = Rt * w;
    V_A.tail<3>().noalias() = Rt * (vo - p_RA.cross(w));
    a_A.head<3>().noalias() = Rt * aw;
    a_A.tail<3>().noalias() = Rt * (ao - p_RA.cross(aw));
  }
  for (int k = 0; k < n; ++k) {
    const int ax = axes[k], r = r0 + k;
    cd.Gdot_v[r] = a_A[ax];
    cd.Gv[r] = V_A[ax];
  }
  if (!errors) return;
  const Vec6 e = pose_error(c.X_WA_target.inverse() * X_WA);
  for (int k = 0; k < n; ++k) cd.err[r0 + k] = e[axes[k]];
}

// Any other weld: frame A to frame B, or a frame on no body (the world) to the world, through the
// frame Jacobians (J_a - X_AB J_b), relative velocity and bias acceleration in A.
void frame_weld_rows(const Model& model, const Data& data, const ConstraintSet& set, const ConstraintSpec& c, int s,
                     const Transform& X_WA, bool errors, ConstraintData& cd) {
  const int r0 = set.row_offset[s], n = set.row_count[s];
  const std::vector<int>& sup = set.support[s];
  Vec6 a_rel, V_rel, e;
  const Vec6 V_A = frame_velocity(model, data, c.frame_a);
  for (int d : sup) cd.J_a.col(d).setZero();
  frame_jacobian(model, data, c.frame_a, model.frame_support(c.frame_a), cd.J_a);
  if (c.frame_b < 0) {
    a_rel = frame_bias_acceleration(model, data, c.frame_a);
    V_rel = V_A;
    if (errors) e = pose_error(c.X_WA_target.inverse() * X_WA);
  } else {
    const Transform X_WB = frame_pose(model, data, c.frame_b);
    const Transform X_AB = X_WA.inverse() * X_WB;
    const Vec6 V_B_inA = X_AB.act(frame_velocity(model, data, c.frame_b));
    for (int d : sup) cd.J_b.col(d).setZero();
    frame_jacobian(model, data, c.frame_b, model.frame_support(c.frame_b), cd.J_b);
    for (int d : sup) cd.J_a.col(d) -= X_AB.act(cd.J_b.col(d));
    a_rel = frame_bias_acceleration(model, data, c.frame_a) - X_AB.act(frame_bias_acceleration(model, data, c.frame_b)) +
            cross_motion(V_A, V_B_inA);
    V_rel = V_A - V_B_inA;
    if (errors) e = pose_error(X_AB.inverse());
  }
  for (int k = 0; k < n; ++k) {
    const int ax = set.row_axis[s][k], r = r0 + k;
    for (int d : sup) cd.G(r, d) = cd.J_a(ax, d);
    cd.Gdot_v[r] = a_rel[ax];
    if (errors) cd.err[r] = e[ax];
    cd.Gv[r] = V_rel[ax];
  }
}

// A weld's rows; also records its tip frame A (relative to R) in X_RS.
void weld_rows(const Model& model, const Data& data, const ConstraintSet& set, const ConstraintSpec& c, int s,
               bool errors, ConstraintData& cd) {
  const Transform X_WA = frame_pose(model, data, c.frame_a);
  cd.X_RS[s].R = X_WA.R;
  cd.X_RS[s].p = X_WA.p - data.p_ref;
  const int body_a = model.frames[c.frame_a].body;
  if (c.frame_b < 0 && body_a >= 0)
    world_weld_rows(data, set, c, s, body_a, X_WA, errors, cd);
  else
    frame_weld_rows(model, data, set, c, s, X_WA, errors, cd);
}

}  // namespace

void constraint_rows(const Model& model, const Data& data, const ConstraintSet& set, const Eigen::VectorXd& q,
                     const Eigen::VectorXd& v, ConstraintData& cd, PositionErrors errors) {
  const bool fill = errors == PositionErrors::kFill || set.stabilize;
  for (size_t i = 0; i < set.specs.size(); ++i) {
    const ConstraintSpec& c = set.specs[i];
    const int s = static_cast<int>(i), r0 = set.row_offset[i];
    switch (c.kind) {
      case ConstraintKind::kLock: lock_rows(c, s, r0, q, v, fill, cd); break;
      case ConstraintKind::kCouple: couple_rows(c, r0, q, v, fill, cd); break;
      case ConstraintKind::kRolling: rolling_rows(data, c, s, r0, set.support[i], fill, cd); break;
      case ConstraintKind::kWeld: weld_rows(model, data, set, c, s, fill, cd); break;
    }
  }
  if (!fill) cd.err.setConstant(std::numeric_limits<double>::quiet_NaN());
  if (set.stabilize)
    cd.gamma = -cd.Gdot_v - set.baumgarte_alpha * cd.Gv - set.baumgarte_beta * cd.err;
  else
    cd.gamma = -cd.Gdot_v;
}

namespace {

// rolling_rows' Gdot_v and rr_arm along (dV, dA0) of the wheel: rolling_geometry's rates are linear
// in (w, c_dot), so its call with (dw, dc_dot) gives the rates' changes
void rolling_tangent(const Data& data, const ConstraintSpec& c, int s, int r0, const Vec6& dV, const Vec6& dA,
                     Eigen::VectorXd& dGdot_v, std::vector<double>& drr_arm) {
  const Transform& X_WB = data.X_WB[c.body];
  const Vec6& V_W = data.V_W[c.body];
  const Vec3 w = V_W.head<3>(), dw = dV.head<3>();
  const Vec3 c_R = X_WB.p - data.p_ref;
  RollingGeometry g, t;
  rolling_geometry(X_WB.R, c_R, c.axle, c.radius, c.ground_n, w, V_W.tail<3>() + w.cross(c_R), g);
  rolling_geometry(X_WB.R, c_R, c.axle, c.radius, c.ground_n, dw, dV.tail<3>() + dw.cross(c_R), t);
  const Vec3 u = V_W.tail<3>() + w.cross(g.p), du = dV.tail<3>() + dw.cross(g.p);
  const Vec3 du_dot = dA.tail<3>() + dA.head<3>().cross(g.p) + dw.cross(g.p_dot) + w.cross(t.p_dot);
  dGdot_v[r0] = t.x_dot.dot(u) + g.x_dot.dot(du) + g.x.dot(du_dot);
  dGdot_v[r0 + 1] = t.y_dot.dot(u) + g.y_dot.dot(du) + g.y.dot(du_dot);
  dGdot_v[r0 + 2] = c.ground_n.dot(du_dot);
  if (c.rolling_resistance > 0) {  // d/du [u / sqrt(u^2 + u0^2)] = u0^2 / (u^2 + u0^2)^(3/2)
    const double uc = g.x.dot(V_W.tail<3>() + w.cross(c_R)), duc = g.x.dot(dV.tail<3>() + dw.cross(c_R));
    const double u0 = kRollingResistanceSpeed, s2 = uc * uc + u0 * u0;
    drr_arm[s] = -c.rolling_resistance * c.radius * u0 * u0 / (s2 * std::sqrt(s2)) * duc;
  }
}

// a weld's rows of Gdot_v: the relative bias acceleration of A and B in A (frame_weld_rows:
// a_rel = A0_a - A0_b + V_A x V_B, all seen in A), along (dV, dA0)
void weld_tangent(const Model& model, const Data& data, const ConstraintSet& set, const ConstraintData& cd, int s,
                  const std::vector<Vec6>& dV_W, const std::vector<Vec6>& dA0_W, const std::vector<char>& moved,
                  Eigen::VectorXd& dGdot_v) {
  const ConstraintSpec& c = set.specs[static_cast<size_t>(s)];
  const int ba = model.frames[c.frame_a].body, bb = c.frame_b >= 0 ? model.frames[c.frame_b].body : -1;
  const bool ma = ba >= 0 && moved[ba], mb = bb >= 0 && moved[bb];
  const int r0 = set.row_offset[s], n = set.row_count[s];
  if (!ma && !mb) {
    for (int k = 0; k < n; ++k) dGdot_v[r0 + k] = 0.0;
    return;
  }
  const Transform& X_RA = cd.X_RS[s];  // A's pose, origin relative to p_ref
  Vec6 dA = Vec6::Zero(), dVa = Vec6::Zero(), dVb = Vec6::Zero();
  if (ma) dA += dA0_W[ba], dVa = dV_W[ba];
  if (mb) dA -= dA0_W[bb], dVb = dV_W[bb];
  Vec6 da = X_RA.inv_act(dA);
  if (bb >= 0) {  // + d(V_A x V_B), both seen in A
    const Vec6 V_A = ba >= 0 ? X_RA.inv_act(data.V_W[ba]) : Vec6::Zero(), V_B = X_RA.inv_act(data.V_W[bb]);
    da += cross_motion(X_RA.inv_act(dVa), V_B) + cross_motion(V_A, X_RA.inv_act(dVb));
  }
  for (int k = 0; k < n; ++k) dGdot_v[r0 + k] = da[set.row_axis[s][k]];
}

}  // namespace

void constraint_bias_tangent(const Model& model, const Data& data, const ConstraintSet& set, const ConstraintData& cd,
                             const std::vector<Vec6>& dV_W, const std::vector<Vec6>& dA0_W, const std::vector<char>& moved,
                             Eigen::VectorXd& dGdot_v, std::vector<double>& drr_arm) {
  for (size_t i = 0; i < set.specs.size(); ++i) {
    const ConstraintSpec& c = set.specs[i];
    const int s = static_cast<int>(i), r0 = set.row_offset[i];
    drr_arm[i] = 0.0;
    switch (c.kind) {
      case ConstraintKind::kLock:
      case ConstraintKind::kCouple: dGdot_v[r0] = 0.0; break;
      case ConstraintKind::kRolling:
        if (moved[c.body]) rolling_tangent(data, c, s, r0, dV_W[c.body], dA0_W[c.body], dGdot_v, drr_arm);
        else dGdot_v.segment<3>(r0).setZero();
        break;
      case ConstraintKind::kWeld: weld_tangent(model, data, set, cd, s, dV_W, dA0_W, moved, dGdot_v); break;
    }
  }
}

double constraint_position_error(const ConstraintData& cd) {
  return cd.err.size() ? cd.err.cwiseAbs().maxCoeff() : 0.0;
}

}  // namespace coopdyn
