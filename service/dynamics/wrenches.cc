#include "service/dynamics/wrenches.h"

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
}

WrenchData::WrenchData(const System& sys) {
  const size_t nb = static_cast<size_t>(sys.model.nbodies()), no = sys.wrenches.outputs.size();
  W.assign(no, Vec6::Zero());
  indeterminate.assign(no, 0);
  f_ext.assign(nb, Vec6::Zero());
  a.assign(nb, Vec6::Zero());
  acc.assign(nb, Vec6::Zero());
  R.assign(nb, Vec6::Zero());
  df_ext = dacc = f_ext;
  X_W_spec.assign(sys.constraints.specs.size(), Transform());
  dlam.setZero(sys.constraints.rows);
}

namespace {

// [moment; force] of spec s for multipliers lambda, in the spec's own frame (tip_wrench's layout)
Vec6 spec_wrench(const ConstraintSet& cs, const Eigen::VectorXd& lambda, int s) {
  Vec6 w = Vec6::Zero();
  for (int k = 0; k < cs.row_count[s]; ++k) w[cs.row_axis[s][k]] = lambda[cs.row_offset[s] + k];
  return w;
}

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

// A spatial force (world coordinates at p_ref, in halves n, f) expressed in output o's frame F at its
// origin, negated for a reversed output. The frame F = X_WB * X_BF of a reaction is not formed: the
// rotations are applied one after the other (cheaper, and no 3x3 product through memory).
void reaction_in_frame(const Data& data, const ConstraintSet& cs, const std::vector<Transform>& X_W_spec,
                       const WrenchOutput& o, const Vec3& n, const Vec3& f, Vec6& out) {
  Vec3 mF, fF;
  if (o.centre_of >= 0) {  // the wheel's spec is in the pass: its contact frame is cached
    const ConstraintSpec& c = cs.specs[o.centre_of];
    const Mat3& R = X_W_spec[o.centre_of].R;
    const Vec3 p = data.X_WB[c.body].p - data.p_ref;
    mF.noalias() = R.transpose() * (n - p.cross(f));
    fF.noalias() = R.transpose() * f;
  } else if (o.frame_body >= 0) {
    const Transform& X = data.X_WB[o.frame_body];
    const Vec3 p = X.p + X.R * o.X_BF.p - data.p_ref;
    const Vec3 mb = X.R.transpose() * (n - p.cross(f)), fb = X.R.transpose() * f;
    mF.noalias() = o.X_BF.R.transpose() * mb;
    fF.noalias() = o.X_BF.R.transpose() * fb;
  } else {
    const Vec3 p = o.X_BF.p - data.p_ref;
    mF.noalias() = o.X_BF.R.transpose() * (n - p.cross(f));
    fF.noalias() = o.X_BF.R.transpose() * f;
  }
  if (o.reversed) {
    mF = -mF;
    fF = -fF;
  }
  out.head<3>() = mF;
  out.tail<3>() = fF;
}

}  // namespace

Transform wrench_frame_pose(const System& sys, const Data& data, int k) {
  return report_frame(sys.model, data, sys.constraints, sys.wrenches.outputs[k]);
}

namespace {

// The constraint forces of multipliers lambda on the bodies of the reaction pass (world coordinates
// at data.p_ref) into f_ext, zeroed first on those bodies; the specs' frames from wd.X_W_spec.
void constraint_body_forces(const System& sys, const Data& data, const Eigen::VectorXd& lambda,
                            const std::vector<Transform>& X_W_spec, std::vector<Vec6>& f_ext) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  const WrenchSet& ws = sys.wrenches;
  for (int i : ws.pass) f_ext[i].setZero();
  for (int s : ws.pass_specs) {
    const ConstraintSpec& c = cs.specs[s];
    const Vec6 F = to_ref(data, X_W_spec[s]).act_force(spec_wrench(cs, lambda, s));
    if (c.kind == ConstraintKind::kRolling) {
      f_ext[c.body] += F;
      continue;
    }
    // the other side's wrench on tip frame A; its opposite acts on frame B's body
    const int ba = model.frames[c.frame_a].body, bb = c.frame_b >= 0 ? model.frames[c.frame_b].body : -1;
    if (ba >= 0 && ws.in_pass[ba]) f_ext[ba] += F;
    if (bb >= 0 && ws.in_pass[bb]) f_ext[bb] -= F;
  }
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
    return;
  }
  if (!set.pass.empty()) {
    for (int s : set.pass_specs) {
      const ConstraintSpec& c = cs.specs[s];
      wd.X_W_spec[s] = c.kind == ConstraintKind::kRolling ? rolling_contact_frame(model, data, c) : frame_pose(model, data, c.frame_a);
    }
    constraint_body_forces(sys, data, ws.lambda, wd.X_W_spec, wd.f_ext);
    joint_reactions(model, data, ws.vdot, wd.f_ext, set.pass, wd.a, wd.acc, wd.R);
  }
  for (size_t k = 0; k < no; ++k) {
    const WrenchOutput& o = set.outputs[k];
    if (o.spec >= 0) {
      unsigned mask = 0;
      wd.W[k] = tip_wrench(sys, ws, o.spec, &mask);
      wd.indeterminate[k] = static_cast<uint8_t>(mask);
      continue;
    }
    reaction_in_frame(data, cs, wd.X_W_spec, o, wd.R[o.body].head<3>(), wd.R[o.body].tail<3>(), wd.W[k]);
    wd.indeterminate[k] = 0;
  }
  // Free directions of lambda (an over-constrained system): a reaction component that moves along
  // one is not determined by the physics. The directions are the null space of Q where the solve
  // computed it, else (the SVD baseline) every indeterminate row on its own.
  if (ws.diag.indeterminate <= 0 || set.pass.empty()) return;
  const int m = cs.rows;
  const bool basis = sys.options.formulation != Formulation::kSvdBaseline && !ws.qs.fast_path;
  const int ndir = basis ? m - ws.qs.rank : m;
  for (int d = 0; d < ndir; ++d) {
    if (basis) {
      wd.dlam = ws.qs.Nq.col(d);
    } else {
      if (!ws.qs.row_indeterminate[d]) continue;
      wd.dlam.setZero();
      wd.dlam[d] = 1.0;
    }
    constraint_body_forces(sys, data, wd.dlam, wd.X_W_spec, wd.df_ext);
    for (int i : set.pass) wd.dacc[i].setZero();
    for (int i : set.pass) {  // the reactions' change: minus the subtree sums of the force change
      wd.dacc[i] -= wd.df_ext[i];
      const int p = model.bodies[i].parent;
      if (p >= 0 && set.in_pass[p]) wd.dacc[p] += wd.dacc[i];
    }
    for (size_t k = 0; k < no; ++k) {
      const WrenchOutput& o = set.outputs[k];
      if (o.spec >= 0) continue;
      Vec6 dF;
      reaction_in_frame(data, cs, wd.X_W_spec, o, wd.dacc[o.body].head<3>(), wd.dacc[o.body].tail<3>(), dF);
      for (int c = 0; c < 6; ++c)
        if (std::abs(dF[c]) > 1e-6) wd.indeterminate[k] = static_cast<uint8_t>(wd.indeterminate[k] | (1u << c));
    }
  }
}

}  // namespace coopdyn
