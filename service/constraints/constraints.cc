#include "service/constraints/constraints.h"

#include <algorithm>
#include <stdexcept>

#include "service/algorithms/jacobians.h"
#include "service/algorithms/kinematics.h"

namespace coopdyn {

void ConstraintSet::compile(const Model& model) {
  rows = 0;
  row_offset.clear();
  row_count.clear();
  row_axis.clear();
  support.clear();
  row_spec.clear();
  std::vector<double> comp;
  for (size_t s = 0; s < specs.size(); ++s) {
    const ConstraintSpec& c = specs[s];
    std::array<int, 6> ax{{-1, -1, -1, -1, -1, -1}};
    int n = 0;
    std::vector<int> sup;
    if (c.kind == ConstraintKind::kWeld) {
      if (c.frame_a < 0 || c.frame_a >= static_cast<int>(model.frames.size()))
        throw std::invalid_argument("constraint '" + c.name + "': unknown tip frame");
      if (c.frame_b >= static_cast<int>(model.frames.size()))
        throw std::invalid_argument("constraint '" + c.name + "': unknown second frame");
      for (int k = 0; k < 6; ++k)
        if (c.axes[k]) {
          ax[n++] = k;
          comp.push_back(c.compliance[k]);
        }
      if (n == 0) throw std::invalid_argument("constraint '" + c.name + "': no axes selected");
      const int ba = model.frames[c.frame_a].body;
      if (ba >= 0) sup = model.support_dofs(ba);
      if (c.frame_b >= 0) {
        const int bb = model.frames[c.frame_b].body;
        if (bb >= 0) {
          std::vector<int> sb = model.support_dofs(bb), u;
          std::set_union(sup.begin(), sup.end(), sb.begin(), sb.end(), std::back_inserter(u));
          sup = u;
        }
      }
    } else {
      if (c.dof < 0 || c.dof >= model.nv()) throw std::invalid_argument("constraint '" + c.name + "': bad DOF");
      ax[0] = 0;
      n = 1;
      comp.push_back(c.compliance[0]);
      sup = {c.dof};
    }
    row_offset.push_back(rows);
    row_count.push_back(n);
    row_axis.push_back(ax);
    support.push_back(sup);
    for (int k = 0; k < n; ++k) row_spec.push_back(static_cast<int>(s));
    rows += n;
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
}

void constraint_rows(const Model& model, const Data& data, const ConstraintSet& set, const Eigen::VectorXd& q,
                     const Eigen::VectorXd& v, ConstraintData& cd) {
  for (size_t s = 0; s < set.specs.size(); ++s) {
    const ConstraintSpec& c = set.specs[s];
    const int r0 = set.row_offset[s], n = set.row_count[s];
    const std::vector<int>& sup = set.support[s];
    if (c.kind == ConstraintKind::kLock) {
      cd.G(r0, c.dof) = 1.0;
      cd.Gdot_v[r0] = 0.0;
      cd.err[r0] = q[c.q_index] - c.q_target;
      cd.Gv[r0] = v[c.dof];
      continue;
    }
    Vec6 a_rel, V_rel, e;
    const Transform X_WA = frame_pose(model, data, c.frame_a);
    const Vec6 V_A = frame_velocity(model, data, c.frame_a);
    for (int d : sup) cd.J_a.col(d).setZero();
    frame_jacobian(model, data, c.frame_a, model.frame_support(c.frame_a), cd.J_a);
    if (c.frame_b < 0) {
      a_rel = frame_bias_acceleration(model, data, c.frame_a);
      V_rel = V_A;
      e = pose_error(c.X_WA_target.inverse() * X_WA);
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
      e = pose_error(X_AB.inverse());
    }
    for (int k = 0; k < n; ++k) {
      const int ax = set.row_axis[s][k], r = r0 + k;
      for (int d : sup) cd.G(r, d) = cd.J_a(ax, d);
      cd.Gdot_v[r] = a_rel[ax];
      cd.err[r] = e[ax];
      cd.Gv[r] = V_rel[ax];
    }
  }
  if (set.stabilize)
    cd.gamma = -cd.Gdot_v - set.baumgarte_alpha * cd.Gv - set.baumgarte_beta * cd.err;
  else
    cd.gamma = -cd.Gdot_v;
}

double constraint_position_error(const ConstraintData& cd) {
  return cd.err.size() ? cd.err.cwiseAbs().maxCoeff() : 0.0;
}

}  // namespace coopdyn
