#include "service/dynamics/wrench_sigma.h"

#include <cmath>

#include "service/algorithms/joint_reactions.h"
#include "service/algorithms/tree_cholesky.h"

namespace coopdyn {

bool wrench_sigma_supported(const System& sys) {
  const Formulation f = sys.options.formulation;
  return (f == Formulation::kMobilePlatform || f == Formulation::kClassic) && sys.tau_noise.size() > 0 &&
         sys.tau_noise.maxCoeff() > 0.0;
}

WrenchSigmaData::WrenchSigmaData(const System& sys) {
  const int n = sys.model.nv(), m = sys.constraints.rows;
  const size_t nb = static_cast<size_t>(sys.model.nbodies()), no = sys.wrenches.outputs.size();
  for (int i = 0; i < sys.tau_noise.size(); ++i)
    if (sys.tau_noise[i] > 0.0) dofs.push_back(i);
  declared = wrench_sigma_supported(sys);
  if (!declared) dofs.clear();
  const int na = static_cast<int>(dofs.size());
  S.setZero(na);
  for (int j = 0; j < na; ++j) S[j] = sys.tau_noise[dofs[static_cast<size_t>(j)]];
  sigma.assign(no, Vec6::Zero());
  C.setZero(6 * static_cast<Eigen::Index>(no), na);
  du.setZero(n);
  du0.setZero(n);
  dvdot.setZero(n);
  dlam.setZero(m);
  dlam_prev.setZero(m);
  rhs.setZero(m);
  zero_f.assign(nb, Vec6::Zero());
  a.assign(nb, Vec6::Zero());
  acc.assign(nb, Vec6::Zero());
  R.assign(nb, Vec6::Zero());
  R0.assign(nb, Vec6::Zero());
  dF.assign(sys.wrenches.pass_specs.size(), Vec6::Zero());
  X_WF.assign(no, Transform());
}

namespace {

// sd.dlam and sd.dvdot for a change sd.du0 of the torques, through the evaluation's factors of M and
// Q (schur_solve of constrained_dynamics.cc with gamma and the bias forces left out). With rolling
// resistance the wheels' moments (linear in their normal forces) are iterated to the same fixed point
// as the evaluation's.
void column_response(const System& sys, Workspace& ws, WrenchSigmaData& sd) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  const int ns = static_cast<int>(cs.specs.size());
  const bool rr = cs.rolling_resistance;
  for (int it = 0; it < (rr ? 50 : 1); ++it) {
    sd.du = sd.du0;
    if (it > 0) {
      for (int s = 0; s < ns; ++s) {
        const double arm = ws.cd.rr_arm[static_cast<size_t>(s)];
        if (arm == 0.0) continue;
        const Vec3 mm = (arm * sd.dlam[cs.row_offset[s] + 2]) * ws.cd.X_RS[static_cast<size_t>(s)].R.col(1);
        for (int d : cs.support[static_cast<size_t>(s)]) sd.du[d] += ws.data.S_W.col(d).head<3>().dot(mm);
      }
      sd.dlam_prev = sd.dlam;
    }
    tree_solve_Lt(model, ws.data, sd.du);
    for (int s = 0; s < ns; ++s) {
      const double* y = ws.Yb[static_cast<size_t>(s)].data();
      Vec6 acc = Vec6::Zero();
      for (int d : ws.y_support[static_cast<size_t>(s)]) acc += sd.du[d] * Eigen::Map<const Vec6>(y + 6 * d);
      const int r0 = cs.row_offset[s];
      for (int k = 0; k < cs.row_count[s]; ++k) sd.rhs[r0 + k] = -acc[k];
    }
    if (ws.q_blocks_active) ws.qb.solve(sd.rhs, sd.dlam);
    else ws.qs.solve(sd.rhs, sd.dlam);
    if (it > 0) {
      const double step = (sd.dlam - sd.dlam_prev).cwiseAbs().maxCoeff();
      if (!(step > 1e-14 * sd.dlam.cwiseAbs().maxCoeff())) break;
    }
  }
  sd.dvdot = sd.du;
  for (int s = 0; s < ns; ++s) {
    const double* y = ws.Yb[static_cast<size_t>(s)].data();
    Vec6 lam = Vec6::Zero();
    const int r0 = cs.row_offset[s];
    for (int k = 0; k < cs.row_count[s]; ++k) lam[k] = sd.dlam[r0 + k];
    for (int d : ws.y_support[static_cast<size_t>(s)]) sd.dvdot[d] += Eigen::Map<const Vec6>(y + 6 * d).dot(lam);
  }
  tree_solve_L(model, ws.data, sd.dvdot);
}

// column j of C: every output's change for the response in sd (tips: their rows of dlambda; joint
// reactions: the vdot-linear part of the backward pass minus the subtree sum of the force change,
// in the output's report frame)
void column_wrenches(const System& sys, const Workspace& ws, WrenchSigmaData& sd, int j) {
  const ConstraintSet& cs = sys.constraints;
  const WrenchSet& set = sys.wrenches;
  const size_t no = set.outputs.size();
  double* Cj = sd.C.col(j).data();
  if (!set.pass.empty()) {
    joint_reactions(sys.model, ws.data, sd.dvdot, sd.zero_f, set.pass, sd.a, sd.acc, sd.R);
    for (size_t t = 0; t < set.pass_specs.size(); ++t) spec_force(cs, ws.cd, sd.dlam.data(), set.pass_specs[t], sd.dF[t].data());
  }
  for (size_t k = 0; k < no; ++k) {
    const WrenchOutput& o = set.outputs[k];
    double* w = Cj + 6 * k;
    if (o.spec >= 0) {
      for (int c = 0; c < 6; ++c) w[c] = 0.0;
      const int r0 = cs.row_offset[o.spec];
      for (int r = 0; r < cs.row_count[o.spec]; ++r) w[cs.row_axis[o.spec][r]] = sd.dlam[r0 + r];
      set_rolling_resistance_moment(cs, ws.cd, o.spec, w);
      continue;
    }
    Vec6 dR = sd.R[o.body] - sd.R0[o.body];
    for (int t = set.out_spec_begin[k]; t < set.out_spec_begin[k + 1]; ++t)
      dR += static_cast<double>(set.out_spec[t].second) * sd.dF[set.out_spec[t].first];
    // world coordinates at p_ref -> the report frame at its origin (reaction_in_frame of wrenches.cc)
    const Transform& X = sd.X_WF[k];
    const Vec3 p = X.p - ws.data.p_ref;
    const Vec3 f = dR.tail<3>();
    const Vec3 n = dR.head<3>() - p.cross(f);
    const double sg = o.reversed ? -1.0 : 1.0;
    Eigen::Map<Vec6> out(w);
    out.head<3>().noalias() = sg * (X.R.transpose() * n);
    out.tail<3>().noalias() = sg * (X.R.transpose() * f);
  }
}

}  // namespace

void compute_wrench_sigma(const System& sys, Workspace& ws, WrenchSigmaData& sd) {
  const WrenchSet& set = sys.wrenches;
  const size_t no = set.outputs.size();
  // joints at rest: their friction is free within its bound (friction_bound.h reports that
  // interval); the noise's spread is the response with it left free, the one computed here
  sd.valid = sd.declared && ws.diag.status != Status::kError;
  if (!sd.valid) {
    if (sd.declared) {
      for (Vec6& s : sd.sigma) s.setZero();
      sd.C.setZero();
    }
    return;
  }
  if (!set.pass.empty()) {  // the reactions' part independent of vdot (bias forces), subtracted per column
    sd.dvdot.setZero();
    joint_reactions(sys.model, ws.data, sd.dvdot, sd.zero_f, set.pass, sd.a, sd.acc, sd.R0);
  }
  for (size_t k = 0; k < no; ++k)
    if (set.outputs[k].spec < 0) sd.X_WF[k] = wrench_frame_pose(sys, ws.data, static_cast<int>(k));
  for (int j = 0; j < static_cast<int>(sd.dofs.size()); ++j) {
    sd.du0.setZero();
    sd.du0[sd.dofs[static_cast<size_t>(j)]] = sd.S[j];
    column_response(sys, ws, sd);
    column_wrenches(sys, ws, sd, j);
  }
  for (size_t k = 0; k < no; ++k)
    for (int c = 0; c < 6; ++c) sd.sigma[k][c] = sd.C.row(6 * static_cast<Eigen::Index>(k) + c).norm();
}

}  // namespace coopdyn
