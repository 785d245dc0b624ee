#include "service/algorithms/joint_reactions.h"

namespace coopdyn {

namespace {
// [n; f] += I [w; v] for a rigid inertia (m, h, Io) about the reference point: n += Io w + h x v,
// f += m v - h x w
template <class Io>
inline void inertial_force(double m, double h0, double h1, double h2, const Io& J, double w0, double w1, double w2,
                           double v0, double v1, double v2, double n[3], double f[3]) {
  n[0] += J(0, 0) * w0 + J(0, 1) * w1 + J(0, 2) * w2 + h1 * v2 - h2 * v1;
  n[1] += J(1, 0) * w0 + J(1, 1) * w1 + J(1, 2) * w2 + h2 * v0 - h0 * v2;
  n[2] += J(2, 0) * w0 + J(2, 1) * w1 + J(2, 2) * w2 + h0 * v1 - h1 * v0;
  f[0] += m * v0 - (h1 * w2 - h2 * w1);
  f[1] += m * v1 - (h2 * w0 - h0 * w2);
  f[2] += m * v2 - (h0 * w1 - h1 * w0);
}
inline void inertial_force(const RigidInertia& I, double w0, double w1, double w2, double v0, double v1, double v2,
                           double n[3], double f[3]) {
  inertial_force(I.m, I.h[0], I.h[1], I.h[2], I.Io, w0, w1, w2, v0, v1, v2, n, f);
}
struct Sym3 {  // a 3x3 matrix as scalars on the stack (J(u, w) as Mat3's)
  double a[3][3];
  double operator()(int u, int w) const { return a[u][w]; }
};
}  // namespace

// In scalars throughout, every spatial vector stored and reloaded element by element: Eigen's
// 3-vector halves and cross products of fresh 3-vectors reload them in packets that span several
// earlier stores, which stalls store-to-load forwarding (see kinematics.cc).
void joint_reactions(const Model& model, const Data& data, const Eigen::VectorXd& vdot,
                     const std::vector<Vec6>& f_ext, const std::vector<int>& pass, std::vector<Vec6>& a_W,
                     std::vector<Vec6>& acc_W, std::vector<Vec6>& R_W) {
  if (pass.empty()) return;
  // down: a_i = a_parent + S_i vdot_i (every body up to the deepest one asked for)
  const int last = pass.front();  // the largest index
  const double* S = data.S_W.data();
  const double* qdd = vdot.data();
  for (int i = 0; i <= last; ++i) {
    const Body& b = model.bodies[i];
    const Joint& j = b.joint;
    double a0 = 0, a1 = 0, a2 = 0, a3 = 0, a4 = 0, a5 = 0;
    if (b.parent >= 0) {
      const double* ap = a_W[b.parent].data();
      a0 = ap[0], a1 = ap[1], a2 = ap[2], a3 = ap[3], a4 = ap[4], a5 = ap[5];
    }
    for (int k = 0; k < j.nv; ++k) {
      const double q = qdd[j.idx_v + k];
      const double* s = S + 6 * (j.idx_v + k);
      a0 += s[0] * q, a1 += s[1] * q, a2 += s[2] * q, a3 += s[3] * q, a4 += s[4] * q, a5 += s[5] * q;
    }
    double* a = a_W[i].data();
    a[0] = a0, a[1] = a1, a[2] = a2, a[3] = a3, a[4] = a4, a[5] = a5;
  }
  for (int i : pass) {
    double* acc = acc_W[i].data();
    for (int k = 0; k < 6; ++k) acc[k] = 0.0;
  }
  const double g0 = model.gravity_W[0], g1 = model.gravity_W[1], g2 = model.gravity_W[2];
  // up: acc_i = subtree sum of I a - f_ext (group inertias at their heads); R_i = acc_i + bias sums
  for (int i : pass) {
    const Body& b = model.bodies[i];
    const double* e = f_ext[i].data();
    const double* acc = acc_W[i].data();
    double n[3] = {acc[0] - e[0], acc[1] - e[1], acc[2] - e[2]}, f[3] = {acc[3] - e[3], acc[4] - e[4], acc[5] - e[5]};
    const double* a = a_W[i].data();
    if (data.has_inertia[i]) inertial_force(data.I_W[i], a[0], a[1], a[2], a[3], a[4], a[5], n, f);
    const double* fb = data.f_W[i].data();
    double r[6] = {n[0] + fb[0], n[1] + fb[1], n[2] + fb[2], f[0] + fb[3], f[1] + fb[4], f[2] + fb[5]};
    if (b.joint.type == JointType::kFixed && b.parent >= 0) {
      // welded: the group's inertia sits in the head's I_W and f_W; its share is added here,
      // I (a + A0 - g) + V x* (I V) with I the group's inertia I_Bw in the world about p_ref
      // (RigidInertia::transformed, in scalars)
      const RigidInertia& IB = data.I_Bw[i];
      const Mat3& Rb = data.X_WB[i].R;
      const Vec3& pb = data.X_WB[i].p;
      const double p[3] = {pb[0] - data.p_ref[0], pb[1] - data.p_ref[1], pb[2] - data.p_ref[2]};
      const double m = IB.m;
      double hR[3], g[3];
      for (int k = 0; k < 3; ++k) {
        hR[k] = Rb(k, 0) * IB.h[0] + Rb(k, 1) * IB.h[1] + Rb(k, 2) * IB.h[2];
        g[k] = hR[k] + (0.5 * m) * p[k];
      }
      const double c = 2.0 * (g[0] * p[0] + g[1] * p[1] + g[2] * p[2]);
      double T[3][3];
      Sym3 J;
      for (int u = 0; u < 3; ++u)
        for (int w = 0; w < 3; ++w) T[u][w] = Rb(u, 0) * IB.Io(0, w) + Rb(u, 1) * IB.Io(1, w) + Rb(u, 2) * IB.Io(2, w);
      for (int u = 0; u < 3; ++u)
        for (int w = u; w < 3; ++w) {
          double x = T[u][0] * Rb(w, 0) + T[u][1] * Rb(w, 1) + T[u][2] * Rb(w, 2) - g[u] * p[w] - p[u] * g[w];
          if (u == w) x += c;
          J.a[u][w] = x;
          J.a[w][u] = x;
        }
      const double h0 = hR[0] + m * p[0], h1 = hR[1] + m * p[1], h2 = hR[2] + m * p[2];
      const double* A0 = data.A0_W[i].data();
      double rn[3] = {0, 0, 0}, rf[3] = {0, 0, 0};
      inertial_force(m, h0, h1, h2, J, a[0] + A0[0], a[1] + A0[1], a[2] + A0[2], a[3] + A0[3] - g0, a[4] + A0[4] - g1,
                     a[5] + A0[5] - g2, rn, rf);
      const double* V = data.V_W[i].data();
      double hn[3] = {0, 0, 0}, hf[3] = {0, 0, 0};  // I V
      inertial_force(m, h0, h1, h2, J, V[0], V[1], V[2], V[3], V[4], V[5], hn, hf);
      // V x* (I V) = [w x hn + v x hf; w x hf]
      r[0] += rn[0] + (V[1] * hn[2] - V[2] * hn[1] + V[4] * hf[2] - V[5] * hf[1]);
      r[1] += rn[1] + (V[2] * hn[0] - V[0] * hn[2] + V[5] * hf[0] - V[3] * hf[2]);
      r[2] += rn[2] + (V[0] * hn[1] - V[1] * hn[0] + V[3] * hf[1] - V[4] * hf[0]);
      r[3] += rf[0] + (V[1] * hf[2] - V[2] * hf[1]);
      r[4] += rf[1] + (V[2] * hf[0] - V[0] * hf[2]);
      r[5] += rf[2] + (V[0] * hf[1] - V[1] * hf[0]);
    }
    double* R = R_W[i].data();
    for (int k = 0; k < 6; ++k) R[k] = r[k];
    if (b.parent >= 0) {
      double* ap = acc_W[b.parent].data();
      ap[0] += n[0], ap[1] += n[1], ap[2] += n[2], ap[3] += f[0], ap[4] += f[1], ap[5] += f[2];
    }
  }
}

}  // namespace coopdyn
