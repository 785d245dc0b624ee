#include "service/algorithms/crba.h"

namespace coopdyn {

void crba_compact(const Model& model, Data& data) {
  // With world-coordinate inertias the composites are plain sums and every entry of M is one dot
  // product: M(i, j) = S_j . (Ic_i S_i) for DOF j an ancestor of (or equal to) DOF i (RBDA s.6.2
  // with all quantities in the world frame).
  const int nb = model.nbodies();
  for (int i = 0; i < nb; ++i) data.Ic_W[i] = data.I_W[i];
  for (int i = nb - 1; i >= 0; --i) {
    const int p = model.bodies[i].parent;
    if (p >= 0) data.Ic_W[p] += data.Ic_W[i];
  }
  const double* __restrict S = data.S_W.data();
  double* __restrict mc = data.Mc.data();
  for (int i = 0; i < nb; ++i) {
    const Joint& ji = model.bodies[i].joint;
    for (int k = 0; k < ji.nv; ++k) {
      const int col = ji.idx_v + k;
      // F = Ic S, in halves (see kinematics.cc)
      const RigidInertia& Ic = data.Ic_W[i];
      const Vec3 sw = data.S_W.col(col).head<3>(), sv = data.S_W.col(col).tail<3>();
      const Vec3 Fn = Ic.Io * sw + Ic.h.cross(sv), Ff = Ic.m * sv - Ic.h.cross(sw);
      const double F[6] = {Fn.x(), Fn.y(), Fn.z(), Ff.x(), Ff.y(), Ff.z()};
      const int* path = model.dof_path.data() + model.dof_path_offset[col];
      const int depth = model.dof_depth[col];
      double* __restrict row = mc + model.dof_row_offset[col];
      for (int p = 0; p < depth; ++p) {
        const double* s = S + 6 * path[p];
        row[p] = s[0] * F[0] + s[1] * F[1] + s[2] * F[2] + s[3] * F[3] + s[4] * F[4] + s[5] * F[5];
      }
      row[depth] = sw.dot(Fn) + sv.dot(Ff) + ji.armature;
    }
  }
}

void crba(const Model& model, Data& data) {
  crba_compact(model, data);
  // the dense matrix (both triangles) for callers that want it
  const double* mc = data.Mc.data();
  Eigen::MatrixXd& M = data.M;
  for (int col = 0; col < model.nv(); ++col) {
    const int* path = model.dof_path.data() + model.dof_path_offset[col];
    const double* row = mc + model.dof_row_offset[col];
    for (int p = 0; p < model.dof_depth[col]; ++p) {
      M(path[p], col) = row[p];
      M(col, path[p]) = row[p];
    }
    M(col, col) = row[model.dof_depth[col]];
  }
}

}  // namespace coopdyn
