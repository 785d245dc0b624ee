#include "service/algorithms/joint_reactions.h"

namespace coopdyn {

void joint_reactions(const Model& model, const Data& data, const Eigen::VectorXd& vdot,
                     const std::vector<Vec6>& f_ext_W, const std::vector<int>& pass, std::vector<Vec6>& a_W,
                     std::vector<Vec6>& acc_W, std::vector<Vec6>& R_W) {
  if (pass.empty()) return;
  // down: a_i = a_parent + S_i vdot_i (every body up to the deepest one asked for)
  const int last = pass.front();  // the largest index
  for (int i = 0; i <= last; ++i) {
    const Body& b = model.bodies[i];
    const Joint& j = b.joint;
    Vec6 a = b.parent >= 0 ? a_W[b.parent] : Vec6::Zero();
    for (int k = 0; k < j.nv; ++k) a += data.S_W.col(j.idx_v + k) * vdot[j.idx_v + k];
    a_W[i] = a;
  }
  for (int i : pass) acc_W[i].setZero();
  Vec6 minus_g;
  minus_g << Vec3::Zero(), -model.gravity_W;
  // up: acc_i = subtree sum of I a - f_ext (group inertias at their heads); R_i = acc_i + bias sums
  for (int i : pass) {
    const Body& b = model.bodies[i];
    Vec6& acc = acc_W[i];
    if (data.has_inertia[i]) acc += data.I_W[i] * a_W[i];
    acc -= f_ext_W[i];
    Vec6 R = acc + data.f_W[i];
    if (b.joint.type == JointType::kFixed && b.parent >= 0) {
      // welded: the group's inertia sits in the head's I_W and f_W; its share is added here
      const RigidInertia Iw = data.I_Bw[i].transformed(to_ref(data, data.X_WB[i]));
      const Vec6& V = data.V_W[i];
      R += Iw * (a_W[i] + data.A0_W[i] + minus_g) + cross_force(V, Iw * V);
    }
    R_W[i] = R;
    if (b.parent >= 0) acc_W[b.parent] += acc;
  }
}

}  // namespace coopdyn
