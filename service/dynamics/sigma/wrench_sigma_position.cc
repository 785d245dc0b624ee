#include "service/dynamics/sigma/wrench_sigma_position.h"

namespace coopdyn {

namespace {

// the bodies of a weld's frames (-1: the world)
inline int frame_body(const Model& model, int frame) { return frame >= 0 ? model.frames[frame].body : -1; }

// b's subtree holds body x
inline bool below(const Model& model, int b, int x) { return x >= 0 && model.is_ancestor(b, x); }

// what a position column of the joint of body b touches: its welds (kWeld with a frame below b),
// couplings and locks of its DOF; false when it cannot be a tangent (see the header)
bool plan_specs(const System& sys, int b, int dof, std::vector<int>& specs) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  const bool feedback = cs.stabilize && cs.baumgarte_beta != 0.0;
  for (size_t s = 0; s < cs.specs.size(); ++s) {
    const ConstraintSpec& c = cs.specs[s];
    bool touched = false;
    switch (c.kind) {
      case ConstraintKind::kRolling:
        if (below(model, b, c.body)) return false;
        break;
      case ConstraintKind::kWeld:
        touched = below(model, b, frame_body(model, c.frame_a)) || below(model, b, frame_body(model, c.frame_b));
        if (touched && feedback) return false;
        break;
      case ConstraintKind::kLock: touched = c.dof == dof; break;
      case ConstraintKind::kCouple: touched = c.dof == dof || c.couple_dof == dof; break;
    }
    if (touched) specs.push_back(static_cast<int>(s));
  }
  return true;
}

// the reactions a column of body b's joint moves: above or inside its subtree, reported in a
// frame on it, or loaded by a weld that touches it
void plan_outputs(const System& sys, int b, const std::vector<int>& specs, std::vector<int>& outs) {
  const Model& model = sys.model;
  const WrenchSet& set = sys.wrenches;
  for (size_t k = 0; k < set.outputs.size(); ++k) {
    const WrenchOutput& o = set.outputs[k];
    if (o.spec >= 0) continue;  // a weld's tip wrench is its multipliers, held
    bool moves = below(model, b, o.body) || model.is_ancestor(o.body, b) || below(model, b, o.frame_body);
    for (int t = set.out_spec_begin[k]; t < set.out_spec_begin[k + 1] && !moves; ++t) {
      const int s = set.pass_specs[static_cast<size_t>(set.out_spec[t].first)];
      for (int u : specs) moves |= u == s;
    }
    if (moves) outs.push_back(static_cast<int>(k));
  }
}

// the down pass over the subtree (ascending): tV = dV, tA = dA0, tF = df (header)
void carry_down(const Model& model, const Data& data, WrenchSigmaData& sd, const std::vector<int>& bodies,
                const Vec6& delta, int p) {
  const Vec6 Vp = p >= 0 ? data.V_W[p] : Vec6::Zero(), A0p = p >= 0 ? data.A0_W[p] : Vec6::Zero();
  const Vec6 ap = p >= 0 ? sd.pa[p] : Vec6::Zero();
  const Vec6 dVp = cross_motion(delta, Vp);
  for (int i : bodies) {
    sd.t_moved[i] = 1;
    const Vec6 Vr = data.V_W[i] - Vp;
    sd.tV[i] = cross_motion(delta, Vr);
    sd.tA[i] = cross_motion(delta, data.A0_W[i] - A0p) - cross_motion(dVp, Vr);
    const RigidInertia& I = sd.I_own[i];
    const Vec6& V = data.V_W[i];
    const Vec6 dAt = sd.tA[i] + cross_motion(delta, sd.pa[i] - ap);
    const Vec6 dP = cross_force(delta, sd.pP[i]) - I * cross_motion(delta, V) + I * sd.tV[i];  // d(I V)
    sd.tF[i] = cross_force(delta, I * sd.pAt[i]) - I * cross_motion(delta, sd.pAt[i]) + I * dAt +
               cross_force(sd.tV[i], sd.pP[i]) + cross_force(V, dP);
  }
}

// the up pass: tF the subtree sums of df; X0's column -dtau
void carry_up(const Model& model, const Data& data, WrenchSigmaData& sd, const std::vector<int>& bodies,
              const std::vector<int>& path, const Vec6& delta, int col, double scale) {
  const int b = bodies.front();
  for (size_t n = bodies.size(); n-- > 0;) {
    const int i = bodies[n];
    const Joint& j = model.bodies[i].joint;
    if (j.nv > 0) {
      const Vec6 g = sd.tF[i] - cross_force(delta, sd.pF[i]);
      for (int k = 0; k < j.nv; ++k) sd.X0(j.idx_v + k, col) = -scale * data.S_W.col(j.idx_v + k).dot(g);
    }
    if (i != b) sd.tF[model.bodies[i].parent] += sd.tF[i];
  }
  for (int d : path) sd.X0(d, col) = -scale * data.S_W.col(d).dot(sd.tF[b]);
}

// a weld's change: its generalized force in X0's column, its rows in Gm's (header)
void weld_change(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& v, int s,
                 const Vec6& delta, int col, int gv_col, double scale) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  const Data& data = ws.data;
  const ConstraintSpec& c = cs.specs[static_cast<size_t>(s)];
  const int A = frame_body(model, c.frame_a), B = frame_body(model, c.frame_b);
  const bool Am = A >= 0 && sd.t_moved[A], Bm = B >= 0 && sd.t_moved[B];
  const Transform& X_RA = ws.cd.X_RS[static_cast<size_t>(s)];
  const Vec6 dFs = cross_force(delta, sd.pFs[static_cast<size_t>(s)]);
  const double alpha = cs.stabilize ? cs.baumgarte_alpha : 0.0;
  Vec6 w = Vec6::Zero();  // sum over k of dG(:, k) (vdot_k + alpha v_k), all six axes of A
  const std::vector<int>& sup = cs.support[static_cast<size_t>(s)];
  const signed char* side = sd.qt_side[static_cast<size_t>(s)].data();
  for (size_t n = 0; n < sup.size(); ++n) {
    const int d = sup[n], bd = model.dof_body[d], sg = side[n];
    const bool dm = sd.t_moved[bd] != 0;
    if (sg == 0 || dm == Am) continue;  // S_k and A carried together, or neither
    const double e = Am ? 1.0 : -1.0;   // dG(:, k) = sg X_A^-1 (dS_k - [A moved] delta x S_k)
    sd.X0(d, col) += scale * sg * e * data.S_W.col(d).dot(dFs);
    w -= (sg * e * (ws.vdot[d] + alpha * v[d])) * X_RA.inv_act(cross_motion(delta, data.S_W.col(d)));
  }
  const Vec6 Va = A >= 0 ? data.V_W[A] : Vec6::Zero(), Vb = B >= 0 ? data.V_W[B] : Vec6::Zero();
  Vec6 dg = Vec6::Zero();  // the change of A0_a - A0_b + V_a x V_b (world)
  if (Am) dg += sd.tA[A] + cross_motion(sd.tV[A], Vb);
  if (Bm) dg += -sd.tA[B] + cross_motion(Va, sd.tV[B]);
  if (Am) {
    const Vec6 g = (A >= 0 ? data.A0_W[A] : Vec6::Zero()) - (B >= 0 ? data.A0_W[B] : Vec6::Zero()) + cross_motion(Va, Vb);
    dg -= cross_motion(delta, g);
  }
  const Vec6 dGdot = X_RA.inv_act(dg);
  const int r0 = cs.row_offset[static_cast<size_t>(s)];
  for (int k = 0; k < cs.row_count[static_cast<size_t>(s)]; ++k) {
    const int ax = cs.row_axis[static_cast<size_t>(s)][k];
    sd.Gm(r0 + k, col) = -scale * (dGdot[ax] + w[ax]);
  }
  if (gv_col < 0) return;
  // G v = X_A^-1 (V_a - V_b): its change at fixed v (frame A turns with delta when it moves)
  Vec6 dv = Vec6::Zero();
  if (Am) dv += sd.tV[A] - cross_motion(delta, Va - Vb);
  if (Bm) dv -= sd.tV[B];
  const Vec6 dGv = X_RA.inv_act(dv);
  for (int k = 0; k < cs.row_count[static_cast<size_t>(s)]; ++k) sd.Gv(r0 + k, gv_col) = scale * dGv[cs.row_axis[static_cast<size_t>(s)][k]];
}

// a coupling's or lock's row: its position error moves with the joint (Baumgarte feedback only)
void error_change(const ConstraintSet& cs, WrenchSigmaData& sd, int s, int dof, int col, double scale) {
  if (!cs.stabilize) return;
  const ConstraintSpec& c = cs.specs[static_cast<size_t>(s)];
  const double de = (c.dof == dof ? 1.0 : 0.0) - (c.kind == ConstraintKind::kCouple && c.couple_dof == dof ? c.multiplier : 0.0);
  sd.Gm(cs.row_offset[static_cast<size_t>(s)], col) = -scale * cs.baumgarte_beta * de;
}

// Cd's column: each moved reaction's change in its report frame
void reaction_changes(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const std::vector<int>& outs, int b,
                      const Vec6& delta, int cd_col, double scale) {
  const Model& model = sys.model;
  const WrenchSet& set = sys.wrenches;
  for (int k : outs) {
    const WrenchOutput& o = set.outputs[static_cast<size_t>(k)];
    Vec6 dR = sd.t_moved[o.body] ? sd.tF[o.body] : model.is_ancestor(o.body, b) ? sd.tF[b] : Vec6::Zero();
    Vec6 R = sd.pF[o.body];
    for (int t = set.out_spec_begin[k]; t < set.out_spec_begin[k + 1]; ++t) {
      const int s = set.pass_specs[static_cast<size_t>(set.out_spec[t].first)];
      const ConstraintSpec& c = sys.constraints.specs[static_cast<size_t>(s)];
      const Vec6& Fs = sd.pFs[static_cast<size_t>(s)];
      const int A = frame_body(model, c.frame_a);
      R += set.out_spec[t].second * Fs;
      if (A >= 0 && sd.t_moved[A]) dR += set.out_spec[t].second * cross_force(delta, Fs);
    }
    if (o.frame_body >= 0 && sd.t_moved[o.frame_body]) dR -= cross_force(delta, R);  // the frame turns with it
    const Transform& X = sd.X_WF[static_cast<size_t>(k)];
    const Vec6 W = Transform(X.R, X.p - ws.data.p_ref).inv_act_force(dR);
    const double sg = (o.reversed ? -1.0 : 1.0) * scale;
    for (int c = 0; c < 6; ++c) sd.Cd(6 * static_cast<Eigen::Index>(k) + c, cd_col) = sg * W[c];
  }
}

}  // namespace

namespace {

// entry a of the plan: the tangent along DOF `dof` of body b's joint, when it can be one
void plan_column(const System& sys, WrenchSigmaData& sd, size_t a, int dof, int b) {
  const Model& model = sys.model;
  sd.qt_dof[a] = dof;
  if (!plan_specs(sys, b, dof, sd.qt_specs[a])) return;
  plan_outputs(sys, b, sd.qt_specs[a], sd.qt_outputs[a]);
  for (int i = b; i < model.nbodies(); ++i)
    if (model.is_ancestor(b, i)) sd.qt_bodies[a].push_back(i);
  for (int d : model.support_dofs(b))
    if (model.dof_body[d] != b) sd.qt_path[a].push_back(d);
  sd.qt_tangent[a] = 1;
}

}  // namespace

void position_tangent_plan(const System& sys, WrenchSigmaData& sd) {
  const Model& model = sys.model;
  const size_t nq = sd.q_dofs.size(), n = nq + sd.float_dofs.size();
  sd.qt_dof.assign(n, -1);
  sd.qt_tangent.assign(n, 0);
  sd.qt_bodies.assign(n, {});
  sd.qt_path.assign(n, {});
  sd.qt_specs.assign(n, {});
  sd.qt_outputs.assign(n, {});
  const ConstraintSet& cs = sys.constraints;
  sd.qt_side.assign(cs.specs.size(), {});
  for (size_t s = 0; s < cs.specs.size(); ++s) {
    if (cs.specs[s].kind != ConstraintKind::kWeld) continue;
    const int A = frame_body(model, cs.specs[s].frame_a), B = frame_body(model, cs.specs[s].frame_b);
    for (int d : cs.support[s]) {
      const int bd = model.dof_body[d];
      sd.qt_side[s].push_back(static_cast<signed char>((A >= 0 && model.is_ancestor(bd, A) ? 1 : 0) -
                                                       (B >= 0 && model.is_ancestor(bd, B) ? 1 : 0)));
    }
  }
  for (size_t a = 0; a < nq; ++a) {
    const int dof = sd.q_dofs[a], b = model.dof_body[dof];
    const JointType t = model.bodies[b].joint.type;
    sd.qt_dof[a] = dof;
    if (model.bodies[b].joint.nv != 1 || (t != JointType::kRevolute && t != JointType::kPrismatic)) continue;
    plan_column(sys, sd, a, dof, b);
  }
  // a floating joint's DOF moves its body along its own (body-fixed) motion subspace column: the
  // subtree is carried with the joint's other columns (the first body's, like its 1-DOF joint
  // above: every quantity is carried about the evaluation's p_ref, and what the columns report is
  // free of it)
  for (size_t k = 0; k < sd.float_dofs.size(); ++k)
    plan_column(sys, sd, nq + k, sd.float_dofs[k], model.dof_body[sd.float_dofs[k]]);
}

void position_tangent_setup(const System& sys, const Workspace& ws, WrenchSigmaData& sd) {
  const Model& model = sys.model;
  const Data& data = ws.data;
  Vec6 minus_g;
  minus_g << Vec3::Zero(), -model.gravity_W;
  const int nb = model.nbodies();
  for (int i = 0; i < nb; ++i) {
    const Body& b = model.bodies[i];
    Vec6 a = b.parent >= 0 ? sd.pa[b.parent] : Vec6::Zero();
    for (int k = 0; k < b.joint.nv; ++k) a += data.S_W.col(b.joint.idx_v + k) * ws.vdot[b.joint.idx_v + k];
    sd.pa[i] = a;
    sd.pAt[i] = a + data.A0_W[i] + minus_g;
    sd.I_own[i] = data.I_B[i].transformed(to_ref(data, data.X_WB[i]));
    sd.pP[i] = sd.I_own[i] * data.V_W[i];
    sd.pF[i] = sd.I_own[i] * sd.pAt[i] + cross_force(data.V_W[i], sd.pP[i]);
  }
  for (int i = nb - 1; i > 0; --i)
    if (model.bodies[i].parent >= 0) sd.pF[model.bodies[i].parent] += sd.pF[i];
  const ConstraintSet& cs = sys.constraints;
  for (size_t s = 0; s < cs.specs.size(); ++s)  // the welds' and every spec a reaction subtracts
    if (cs.specs[s].kind == ConstraintKind::kWeld || cs.specs[s].kind == ConstraintKind::kRolling)
      spec_force(cs, ws.cd, ws.lambda.data(), static_cast<int>(s), sd.pFs[s].data());
}

void position_column(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& v, int a,
                     int col, int cd_col, int gv_col, double scale) {
  const Model& model = sys.model;
  const size_t ua = static_cast<size_t>(a);
  const int dof = sd.qt_dof[ua];
  const std::vector<int>& bodies = sd.qt_bodies[ua];
  const int b = bodies.front();
  const Vec6 delta = ws.data.S_W.col(dof);
  sd.X0.col(col).setZero();
  sd.Gm.col(col).setZero();
  sd.Cd.col(cd_col).setZero();
  if (gv_col >= 0) sd.Gv.col(gv_col).setZero();
  carry_down(model, ws.data, sd, bodies, delta, model.bodies[b].parent);
  carry_up(model, ws.data, sd, bodies, sd.qt_path[ua], delta, col, scale);  // X0's entries set, then added to
  for (int s : sd.qt_specs[ua]) {
    if (sys.constraints.specs[static_cast<size_t>(s)].kind == ConstraintKind::kWeld)
      weld_change(sys, ws, sd, v, s, delta, col, gv_col, scale);
    else
      error_change(sys.constraints, sd, s, dof, col, scale);
  }
  reaction_changes(sys, ws, sd, sd.qt_outputs[ua], b, delta, cd_col, scale);
  for (int i : bodies) sd.t_moved[i] = 0;
}

}  // namespace coopdyn
