#include "service/algorithms/rnea.h"

namespace coopdyn {

namespace {

// Net force of body i for its total acceleration a (world, gravity included as -g of the root,
// RBDA s.5.3): f = I a + V x* (I V).
inline Vec6 body_force(const RigidInertia& I, const Vec6& V, const Vec6& a) {
  return I * a + cross_force(V, I * V);
}

}  // namespace

void rnea_bias(const Model& model, Data& data) {
  // in 3-vector halves throughout (see kinematics.cc: store-to-load forwarding)
  const int nb = model.nbodies();
  const Vec3 minus_g = -model.gravity_W;
  for (int i = 0; i < nb; ++i) {
    if (!data.has_inertia[i]) {  // nothing to move: a massless body, or one folded into its parent
      data.f_W[i].setZero();
      continue;
    }
    const RigidInertia& I = data.I_W[i];
    const Vec3 w = data.V_W[i].head<3>(), v = data.V_W[i].tail<3>();
    const Vec3 aw = data.A0_W[i].head<3>(), av = data.A0_W[i].tail<3>() + minus_g;
    // f = I a + V x* (I V)
    const Vec3 nV = I.Io * w + I.h.cross(v), fV = I.m * v - I.h.cross(w);
    data.f_W[i].head<3>() = I.Io * aw + I.h.cross(av) + w.cross(nV) + v.cross(fV);
    data.f_W[i].tail<3>() = I.m * av - I.h.cross(aw) + w.cross(fV);
  }
  for (int i = nb - 1; i >= 0; --i) {
    const Body& b = model.bodies[i];
    const Joint& j = b.joint;
    const Vec3 n = data.f_W[i].head<3>(), f = data.f_W[i].tail<3>();
    for (int k = 0; k < j.nv; ++k)
      data.h[j.idx_v + k] = data.S_W.col(j.idx_v + k).head<3>().dot(n) + data.S_W.col(j.idx_v + k).tail<3>().dot(f);
    if (b.parent >= 0) {
      data.f_W[b.parent].head<3>() += n;
      data.f_W[b.parent].tail<3>() += f;
    }
  }
}

void rnea(const Model& model, Data& data, const Eigen::VectorXd& vdot, const std::vector<Vec6>* f_ext,
          Eigen::VectorXd& tau) {
  const int nb = model.nbodies();
  Vec6 minus_g;
  minus_g << Vec3::Zero(), -model.gravity_W;
  // body accelerations: the vdot-linear part propagated down the tree, plus A0 and gravity
  for (int i = 0; i < nb; ++i) {
    const Body& b = model.bodies[i];
    const Joint& j = b.joint;
    Vec6 a = b.parent >= 0 ? data.a_W[b.parent] : Vec6::Zero();
    for (int k = 0; k < j.nv; ++k) a += data.S_W.col(j.idx_v + k) * vdot[j.idx_v + k];
    data.a_W[i] = a;
    // each body's own inertia (not I_W, where welded children are folded into their parent), so
    // that the reactions across fixed joints come out too
    const Transform X_RB = to_ref(data, data.X_WB[i]);
    data.f_W[i] = body_force(data.I_B[i].transformed(X_RB), data.V_W[i], a + data.A0_W[i] + minus_g);
    if (f_ext) data.f_W[i] -= X_RB.act_force((*f_ext)[i]);
  }
  for (int i = nb - 1; i >= 0; --i) {
    const Body& b = model.bodies[i];
    const Joint& j = b.joint;
    for (int k = 0; k < j.nv; ++k)
      tau[j.idx_v + k] = data.S_W.col(j.idx_v + k).dot(data.f_W[i]) + j.armature * vdot[j.idx_v + k];
    if (b.parent >= 0) data.f_W[b.parent] += data.f_W[i];
  }
  for (int i = 0; i < nb; ++i) data.f[i] = to_ref(data, data.X_WB[i]).inv_act_force(data.f_W[i]);
}

}  // namespace coopdyn
