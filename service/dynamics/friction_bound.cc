#include "service/dynamics/friction_bound.h"

#include <cmath>

#include "service/algorithms/joint_reactions.h"

namespace coopdyn {

FrictionBoundData::FrictionBoundData(const System& sys) {
  const size_t nb = static_cast<size_t>(sys.model.nbodies()), no = sys.wrenches.outputs.size();
  for (const Body& b : sys.model.bodies)
    if (b.joint.friction > 0.0) possible = true;
  bound.assign(no, Vec6::Zero());
  if (!possible) return;
  dvdot.setZero(sys.model.nv());
  dlam.setZero(sys.constraints.rows);
  zero_f.assign(nb, Vec6::Zero());
  a.assign(nb, Vec6::Zero());
  acc.assign(nb, Vec6::Zero());
  R.assign(nb, Vec6::Zero());
  R0.assign(nb, Vec6::Zero());
  dF.assign(sys.wrenches.pass_specs.size(), Vec6::Zero());
  X_WF.assign(no, Transform());
  col.assign(no, Vec6::Zero());
  offset.assign(no, Vec6::Zero());
}

namespace {

// fb.col: every output's change for the response (fb.dvdot, fb.dlam) to a unit torque (tips: their
// rows of dlambda; joint reactions: the vdot-linear part of the backward pass minus the subtree sum
// of the constraint-force change, in the output's report frame)
void response_wrenches(const System& sys, const Workspace& ws, FrictionBoundData& fb) {
  const ConstraintSet& cs = sys.constraints;
  const WrenchSet& set = sys.wrenches;
  if (!set.pass.empty()) {
    joint_reactions(sys.model, ws.data, fb.dvdot, fb.zero_f, set.pass, fb.a, fb.acc, fb.R);
    for (size_t t = 0; t < set.pass_specs.size(); ++t) spec_force(cs, ws.cd, fb.dlam.data(), set.pass_specs[t], fb.dF[t].data());
  }
  for (size_t k = 0; k < set.outputs.size(); ++k) {
    const WrenchOutput& o = set.outputs[k];
    double* w = fb.col[k].data();
    if (o.spec >= 0) {
      for (int c = 0; c < 6; ++c) w[c] = 0.0;
      const int r0 = cs.row_offset[o.spec];
      for (int r = 0; r < cs.row_count[o.spec]; ++r) w[cs.row_axis[o.spec][r]] = fb.dlam[r0 + r];
      set_rolling_resistance_moment(cs, ws.cd, o.spec, w);
      continue;
    }
    Vec6 dR = fb.R[o.body] - fb.R0[o.body];
    for (int t = set.out_spec_begin[k]; t < set.out_spec_begin[k + 1]; ++t)
      dR += static_cast<double>(set.out_spec[t].second) * fb.dF[set.out_spec[t].first];
    // world coordinates at p_ref -> the report frame at its origin
    const Transform& X = fb.X_WF[k];
    const Vec3 p = X.p - ws.data.p_ref;
    const Vec3 f = dR.tail<3>();
    const Vec3 n = dR.head<3>() - p.cross(f);
    const double sg = o.reversed ? -1.0 : 1.0;
    fb.col[k].head<3>().noalias() = sg * (X.R.transpose() * n);
    fb.col[k].tail<3>().noalias() = sg * (X.R.transpose() * f);
  }
}

}  // namespace

void compute_friction_bound(const System& sys, const Workspace& ws, FrictionBoundData& fb) {
  const WrenchSet& set = sys.wrenches;
  for (Vec6& b : fb.bound) b.setZero();
  fb.resting = ws.diag.status == Status::kError ? 0 : ws.rest_count;
  if (!fb.possible || fb.resting == 0) return;
  if (!set.pass.empty()) {  // the reactions' part independent of vdot (bias forces), subtracted per column
    fb.dvdot.setZero();
    joint_reactions(sys.model, ws.data, fb.dvdot, fb.zero_f, set.pass, fb.a, fb.acc, fb.R0);
  }
  for (size_t k = 0; k < set.outputs.size(); ++k)
    if (set.outputs[k].spec < 0) fb.X_WF[k] = wrench_frame_pose(sys, ws.data, static_cast<int>(k));
  // bound = |sum_j W_j f*_j| + sum_j |W_j| F_j: the reported value's offset from the one without
  // resting friction, plus the half-width of the interval about that one
  for (Vec6& o : fb.offset) o.setZero();
  for (int j = 0; j < fb.resting; ++j) {
    fb.dvdot = ws.rest_dvdot.col(j);
    fb.dlam = ws.rest_dlambda.col(j);
    response_wrenches(sys, ws, fb);
    const double F = ws.friction[ws.rest_dofs[j]], f = ws.lcp.f[j];
    for (size_t k = 0; k < fb.bound.size(); ++k) {
      fb.bound[k] += F * fb.col[k].cwiseAbs();
      fb.offset[k] += f * fb.col[k];
    }
  }
  for (size_t k = 0; k < fb.bound.size(); ++k) fb.bound[k] += fb.offset[k].cwiseAbs();
}

}  // namespace coopdyn
