#include "service/algorithms/joint_reactions.h"

namespace coopdyn {

namespace {
// [n; f] += I [w; v] for a rigid inertia about the reference point: n += Io w + h x v, f += m v - h x w
inline void inertial_force(const RigidInertia& I, double w0, double w1, double w2, double v0, double v1, double v2,
                           double n[3], double f[3]) {
  const Mat3& J = I.Io;
  const double h0 = I.h[0], h1 = I.h[1], h2 = I.h[2];
  n[0] += J(0, 0) * w0 + J(0, 1) * w1 + J(0, 2) * w2 + h1 * v2 - h2 * v1;
  n[1] += J(1, 0) * w0 + J(1, 1) * w1 + J(1, 2) * w2 + h2 * v0 - h0 * v2;
  n[2] += J(2, 0) * w0 + J(2, 1) * w1 + J(2, 2) * w2 + h0 * v1 - h1 * v0;
  f[0] += I.m * v0 - (h1 * w2 - h2 * w1);
  f[1] += I.m * v1 - (h2 * w0 - h0 * w2);
  f[2] += I.m * v2 - (h0 * w1 - h1 * w0);
}
}  // namespace

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
  for (int i : pass) acc_W[i].setZero();
  const double g0 = model.gravity_W[0], g1 = model.gravity_W[1], g2 = model.gravity_W[2];
  // up: acc_i = subtree sum of I a - f_ext (group inertias at their heads); R_i = acc_i + bias sums.
  // In scalars: Eigen's cross products of fresh 3-vectors reload them from the stack in overlapping
  // pairs, which stalls store-to-load forwarding.
  for (int i : pass) {
    const Body& b = model.bodies[i];
    const double* e = f_ext_W[i].data();
    double* acc = acc_W[i].data();
    double n[3] = {acc[0] - e[0], acc[1] - e[1], acc[2] - e[2]}, f[3] = {acc[3] - e[3], acc[4] - e[4], acc[5] - e[5]};
    const double* a = a_W[i].data();
    if (data.has_inertia[i]) inertial_force(data.I_W[i], a[0], a[1], a[2], a[3], a[4], a[5], n, f);
    const double* fb = data.f_W[i].data();
    double* R = R_W[i].data();
    R[0] = n[0] + fb[0];
    R[1] = n[1] + fb[1];
    R[2] = n[2] + fb[2];
    R[3] = f[0] + fb[3];
    R[4] = f[1] + fb[4];
    R[5] = f[2] + fb[5];
    if (b.joint.type == JointType::kFixed && b.parent >= 0) {
      // welded: the group's inertia sits in the head's I_W and f_W; its share is added here,
      // I (a + A0 - g) + V x* (I V)
      const RigidInertia Iw = data.I_Bw[i].transformed(to_ref(data, data.X_WB[i]));
      const double* A0 = data.A0_W[i].data();
      double rn[3] = {0, 0, 0}, rf[3] = {0, 0, 0};
      inertial_force(Iw, a[0] + A0[0], a[1] + A0[1], a[2] + A0[2], a[3] + A0[3] - g0, a[4] + A0[4] - g1,
                     a[5] + A0[5] - g2, rn, rf);
      const double* V = data.V_W[i].data();
      double hn[3] = {0, 0, 0}, hf[3] = {0, 0, 0};  // I V
      inertial_force(Iw, V[0], V[1], V[2], V[3], V[4], V[5], hn, hf);
      // V x* (I V) = [w x hn + v x hf; w x hf]
      rn[0] += V[1] * hn[2] - V[2] * hn[1] + V[4] * hf[2] - V[5] * hf[1];
      rn[1] += V[2] * hn[0] - V[0] * hn[2] + V[5] * hf[0] - V[3] * hf[2];
      rn[2] += V[0] * hn[1] - V[1] * hn[0] + V[3] * hf[1] - V[4] * hf[0];
      rf[0] += V[1] * hf[2] - V[2] * hf[1];
      rf[1] += V[2] * hf[0] - V[0] * hf[2];
      rf[2] += V[0] * hf[1] - V[1] * hf[0];
      for (int k = 0; k < 3; ++k) {
        R[k] += rn[k];
        R[3 + k] += rf[k];
      }
    }
    if (b.parent >= 0) {
      double* ap = acc_W[b.parent].data();
      for (int k = 0; k < 3; ++k) {
        ap[k] += n[k];
        ap[3 + k] += f[k];
      }
    }
  }
}

}  // namespace coopdyn
