#include "service/algorithms/joint_reactions.h"

namespace coopdyn {

// Spatial vectors in 3-vector halves, stored and reloaded as halves (see kinematics.cc: assembling
// 6-vectors from halves and reading them back whole defeats store-to-load forwarding).
void joint_reactions(const Model& model, const Data& data, const Eigen::VectorXd& vdot,
                     const std::vector<Vec6>& f_ext_W, const std::vector<int>& pass, std::vector<Vec6>& a_W,
                     std::vector<Vec6>& acc_W, std::vector<Vec6>& R_W) {
  if (pass.empty()) return;
  // down: a_i = a_parent + S_i vdot_i (every body up to the deepest one asked for)
  const int last = pass.front();  // the largest index
  for (int i = 0; i <= last; ++i) {
    const Body& b = model.bodies[i];
    const Joint& j = b.joint;
    Vec3 aw = Vec3::Zero(), av = Vec3::Zero();
    if (b.parent >= 0) {
      aw = a_W[b.parent].head<3>();
      av = a_W[b.parent].tail<3>();
    }
    for (int k = 0; k < j.nv; ++k) {
      const double qdd = vdot[j.idx_v + k];
      aw += data.S_W.col(j.idx_v + k).head<3>() * qdd;
      av += data.S_W.col(j.idx_v + k).tail<3>() * qdd;
    }
    a_W[i].head<3>() = aw;
    a_W[i].tail<3>() = av;
  }
  for (int i : pass) {
    acc_W[i].head<3>().setZero();
    acc_W[i].tail<3>().setZero();
  }
  const Vec3 minus_g = -model.gravity_W;
  // up: acc_i = subtree sum of I a - f_ext (group inertias at their heads); R_i = acc_i + bias sums
  for (int i : pass) {
    const Body& b = model.bodies[i];
    Vec3 n = acc_W[i].head<3>() - f_ext_W[i].head<3>(), f = acc_W[i].tail<3>() - f_ext_W[i].tail<3>();
    if (data.has_inertia[i]) {
      const RigidInertia& I = data.I_W[i];
      const Vec3 w = a_W[i].head<3>(), v = a_W[i].tail<3>();
      n += I.Io * w + I.h.cross(v);
      f += I.m * v - I.h.cross(w);
    }
    Vec3 Rn = n + data.f_W[i].head<3>(), Rf = f + data.f_W[i].tail<3>();
    if (b.joint.type == JointType::kFixed && b.parent >= 0) {
      // welded: the group's inertia sits in the head's I_W and f_W; its share is added here,
      // I (a + A0 - g) + V x* (I V)
      const RigidInertia Iw = data.I_Bw[i].transformed(to_ref(data, data.X_WB[i]));
      const Vec3 w = a_W[i].head<3>() + data.A0_W[i].head<3>(), v = a_W[i].tail<3>() + data.A0_W[i].tail<3>() + minus_g;
      const Vec3 Vw = data.V_W[i].head<3>(), Vv = data.V_W[i].tail<3>();
      const Vec3 nV = Iw.Io * Vw + Iw.h.cross(Vv), fV = Iw.m * Vv - Iw.h.cross(Vw);
      Rn += Iw.Io * w + Iw.h.cross(v) + Vw.cross(nV) + Vv.cross(fV);
      Rf += Iw.m * v - Iw.h.cross(w) + Vw.cross(fV);
    }
    R_W[i].head<3>() = Rn;
    R_W[i].tail<3>() = Rf;
    if (b.parent >= 0) {
      acc_W[b.parent].head<3>() += n;
      acc_W[b.parent].tail<3>() += f;
    }
  }
}

}  // namespace coopdyn
