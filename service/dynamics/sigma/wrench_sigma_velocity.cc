#include "service/dynamics/sigma/wrench_sigma_velocity.h"

#include <algorithm>

namespace coopdyn {

namespace {

// I dA + dV x* (I V) + V x* (I dV): the change of a body's bias force I A0 + V x* I V (gravity
// and the vdot part do not move), P = I V
inline Vec6 bias_force_tangent(const RigidInertia& I, const Vec6& V, const Vec6& P, const Vec6& dV, const Vec6& dA) {
  return I * dA + cross_force(dV, P) + cross_force(V, I * dV);
}

// the down pass: tV, tA of every body below a DOF with tv != 0; their own tF (bias force change)
void tangent_down(const Model& model, const Data& data, WrenchSigmaData& sd, const Eigen::VectorXd& v) {
  const int nb = model.nbodies();
  int i0 = nb;
  for (int d : sd.tv_nz) i0 = std::min(i0, model.dof_body[d]);
  for (int i = 0; i < nb; ++i) sd.t_moved[i] = sd.t_touched[i] = 0;
  for (int i = i0; i < nb; ++i) {
    const Body& b = model.bodies[i];
    const Joint& j = b.joint;
    const bool pm = b.parent >= 0 && sd.t_moved[b.parent];
    bool own = false;
    for (int k = 0; k < j.nv; ++k) own |= sd.tv[j.idx_v + k] != 0.0;
    if (!own && !pm) continue;
    Vec6 dV = pm ? sd.tV[b.parent] : Vec6::Zero(), dA = pm ? sd.tA[b.parent] : Vec6::Zero();
    if (j.nv > 0) {  // a joint carried by a moved parent adds dV x J too
      Vec6 J = Vec6::Zero(), dJ = Vec6::Zero();
      for (int k = 0; k < j.nv; ++k) {
        J += data.S_W.col(j.idx_v + k) * v[j.idx_v + k];
        dJ += data.S_W.col(j.idx_v + k) * sd.tv[j.idx_v + k];
      }
      dV += dJ;
      dA += cross_motion(dV, J) + cross_motion(data.V_W[i], dJ);
      if (j.type == JointType::kRevolute2) {  // S' qdot = qd0 qd1 a1 x a2 (kinematics.cc)
        const int d = j.idx_v;
        const Vec3 a1 = data.S_W.col(d).head<3>(), a2 = data.S_W.col(d + 1).head<3>();
        const Vec3 c = (sd.tv[d] * v[d + 1] + v[d] * sd.tv[d + 1]) * a1.cross(a2);
        dA.head<3>() += c;
        dA.tail<3>() += (data.X_WB[i].p - data.p_ref).cross(c);
      }
    }
    sd.tV[i] = dV;
    sd.tA[i] = dA;
    sd.t_moved[i] = sd.t_touched[i] = 1;
    sd.tF[i] = data.has_inertia[i] ? bias_force_tangent(data.I_W[i], data.V_W[i], sd.P_W[i], dV, dA) : Vec6::Zero();
  }
}

// the up pass: tF the subtree sums; X0's column -dtau (every DOF, zero where nothing moved)
void tangent_up(const Model& model, const Data& data, WrenchSigmaData& sd, int col, double scale) {
  sd.X0.col(col).setZero();
  for (int i = model.nbodies() - 1; i >= 0; --i) {
    if (!sd.t_touched[i]) continue;
    const Body& b = model.bodies[i];
    for (int k = 0; k < b.joint.nv; ++k) sd.X0(b.joint.idx_v + k, col) = -scale * data.S_W.col(b.joint.idx_v + k).dot(sd.tF[i]);
    if (b.parent < 0) continue;
    if (sd.t_touched[b.parent]) {
      sd.tF[b.parent] += sd.tF[i];
    } else {
      sd.tF[b.parent] = sd.tF[i];
      sd.t_touched[b.parent] = 1;
    }
  }
}

// damping (-b dv) and the rolling-resistance moment's change (residual() of wrench_sigma.cc) in
// X0's column; Gm's column: -dGdot v - alpha G dv
void residual_terms(const System& sys, const Workspace& ws, WrenchSigmaData& sd, int col, double scale) {
  const ConstraintSet& cs = sys.constraints;
  for (int d : ws.damped_dofs) sd.X0(d, col) -= scale * ws.damping[d] * sd.tv[d];
  for (size_t s = 0; s < cs.specs.size(); ++s) {
    if (sd.trr[s] == 0.0) continue;
    const Vec3 mm = (sd.trr[s] * ws.lambda[cs.row_offset[s] + 2]) * ws.cd.X_RS[s].R.col(1);
    for (int d : cs.support[s]) sd.X0(d, col) += scale * ws.data.S_W.col(d).head<3>().dot(mm);
  }
  const double alpha = cs.stabilize ? cs.baumgarte_alpha : 0.0;
  for (int r = 0; r < cs.rows; ++r) {
    double gv = 0.0;
    if (alpha != 0.0)
      for (int d : sd.tv_nz) gv += ws.cd.G(r, d) * sd.tv[d];
    sd.Gm(r, col) = -scale * (sd.tGdot[r] + alpha * gv);
  }
}

// Cd's column: each output's own change (tips: the rolling-resistance moment; joint reactions: the
// bias sums, the welded group's share, minus the constraint forces' change), in its report frame
void wrench_terms(const System& sys, const Workspace& ws, WrenchSigmaData& sd, int cd_col, double scale) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  const WrenchSet& set = sys.wrenches;
  const Data& data = ws.data;
  for (size_t k = 0; k < set.outputs.size(); ++k) {
    const WrenchOutput& o = set.outputs[k];
    const Eigen::Index c0 = 6 * static_cast<Eigen::Index>(k);
    if (o.spec >= 0) {  // W[1] = rr_arm W[5] (set_rolling_resistance_moment)
      for (int c = 0; c < 6; ++c) sd.Cd(c0 + c, cd_col) = 0.0;
      const double drr = sd.trr[static_cast<size_t>(o.spec)];  // nonzero only on a rolling spec (rows x y z)
      if (drr != 0.0) sd.Cd(c0 + 1, cd_col) = scale * drr * ws.lambda[cs.row_offset[o.spec] + 2];
      continue;
    }
    const int i = o.body;
    Vec6 dR = sd.t_touched[i] ? sd.tF[i] : Vec6::Zero();
    const Body& b = model.bodies[i];
    if (b.joint.type == JointType::kFixed && b.parent >= 0 && sd.t_moved[i])
      dR += bias_force_tangent(sd.I_fix[i], data.V_W[i], sd.I_fix[i] * data.V_W[i], sd.tV[i], sd.tA[i]);
    for (int t = set.out_spec_begin[k]; t < set.out_spec_begin[k + 1]; ++t) {
      const int s = set.pass_specs[static_cast<size_t>(set.out_spec[t].first)];
      if (sd.trr[static_cast<size_t>(s)] == 0.0) continue;  // spec_force: only its moment about y_C moves
      const double m = set.out_spec[t].second * sd.trr[static_cast<size_t>(s)] * ws.lambda[cs.row_offset[s] + 2];
      dR.head<3>() += m * ws.cd.X_RS[static_cast<size_t>(s)].R.col(1);
    }
    const Transform& X = sd.X_WF[k];
    const Vec3 p = X.p - data.p_ref;
    const Vec3 n = dR.head<3>() - p.cross(dR.tail<3>());
    const double sg = (o.reversed ? -1.0 : 1.0) * scale;
    const Vec3 rn = sg * (X.R.transpose() * n), rf = sg * (X.R.transpose() * dR.tail<3>());
    for (int c = 0; c < 3; ++c) {
      sd.Cd(c0 + c, cd_col) = rn[c];
      sd.Cd(c0 + 3 + c, cd_col) = rf[c];
    }
  }
}

}  // namespace

void velocity_tangent_setup(const System& sys, const Workspace& ws, WrenchSigmaData& sd) {
  const Data& data = ws.data;
  for (int i = 0; i < sys.model.nbodies(); ++i)
    if (data.has_inertia[i]) sd.P_W[i] = data.I_W[i] * data.V_W[i];
}

void velocity_column(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& v, int col,
                     int cd_col, double scale) {
  tangent_down(sys.model, ws.data, sd, v);
  constraint_bias_tangent(sys.model, ws.data, sys.constraints, ws.cd, sd.tV, sd.tA, sd.t_moved, sd.tGdot, sd.trr);
  tangent_up(sys.model, ws.data, sd, col, scale);
  residual_terms(sys, ws, sd, col, scale);
  wrench_terms(sys, ws, sd, cd_col, scale);
}

}  // namespace coopdyn
