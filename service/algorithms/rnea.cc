#include "service/algorithms/rnea.h"

namespace coopdyn {

namespace {
// -gravity as a spatial acceleration of the root, in body i coordinates (RBDA s.5.3 trick).
inline Vec6 gravity_offset(const Model& model, const Data& data, int i) {
  Vec6 a;
  a.head<3>().setZero();
  a.tail<3>() = -(data.X_WB[i].R.transpose() * model.gravity_W);
  return a;
}
}  // namespace

void rnea_bias(const Model& model, Data& data) {
  const int nb = model.nbodies();
  for (int i = 0; i < nb; ++i) {
    const RigidInertia& I = data.I[i];
    const Vec6 a = data.A0[i] + gravity_offset(model, data, i);
    data.f[i] = I * a + cross_force(data.V[i], I * data.V[i]);
  }
  for (int i = nb - 1; i >= 0; --i) {
    const Body& b = model.bodies[i];
    const Joint& j = b.joint;
    for (int k = 0; k < j.nv; ++k) data.h[j.idx_v + k] = data.S[i].col(k).dot(data.f[i]);
    if (b.parent >= 0) data.f[b.parent] += data.X_PB[i].act_force(data.f[i]);
  }
}

void rnea(const Model& model, Data& data, const Eigen::VectorXd& vdot, const std::vector<Vec6>* f_ext,
          Eigen::VectorXd& tau) {
  const int nb = model.nbodies();
  // body accelerations: the vdot-linear part propagated down the tree, plus A0 and gravity
  for (int i = 0; i < nb; ++i) {
    const Body& b = model.bodies[i];
    const Joint& j = b.joint;
    Vec6 a = Vec6::Zero();
    if (b.parent >= 0) a = data.X_PB[i].inv_act(data.a[b.parent]);
    for (int k = 0; k < j.nv; ++k) a += data.S[i].col(k) * vdot[j.idx_v + k];
    data.a[i] = a;  // vdot-linear part
    const Vec6 a_full = a + data.A0[i] + gravity_offset(model, data, i);
    const RigidInertia& I = data.I[i];
    data.f[i] = I * a_full + cross_force(data.V[i], I * data.V[i]);
    if (f_ext) data.f[i] -= (*f_ext)[i];
  }
  for (int i = nb - 1; i >= 0; --i) {
    const Body& b = model.bodies[i];
    const Joint& j = b.joint;
    for (int k = 0; k < j.nv; ++k) tau[j.idx_v + k] = data.S[i].col(k).dot(data.f[i]) + j.armature * vdot[j.idx_v + k];
    if (b.parent >= 0) data.f[b.parent] += data.X_PB[i].act_force(data.f[i]);
  }
}

}  // namespace coopdyn
