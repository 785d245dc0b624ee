#include "service/algorithms/kinematics.h"

#include <cmath>

namespace coopdyn {

// Spatial vectors are handled here as pairs of 3-vectors, [angular; linear], and stored and reloaded
// as such: assembling a 6-vector from two 3-vector halves and reading it back in 2-element packets
// defeats the processor's store-to-load forwarding, which cost more than the arithmetic.
void forward_kinematics(const Model& model, Data& data, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  const int nb = model.nbodies();
  Vec3 p_ref = Vec3::Zero();  // kept in a register; stored in data.p_ref at the end
  for (int i = 0; i < nb; ++i) {
    const Body& b = model.bodies[i];
    const Joint& j = b.joint;
    Transform& X_WB = data.X_WB[i];
    // X_WJ: the joint frame in the world; V, A0 start from the parent's
    Transform X_WJ;
    Vec3 Vw, Vv, Aw, Av;
    if (b.parent >= 0) {
      const Transform& X_WP = data.X_WB[b.parent];
      X_WJ.R.noalias() = X_WP.R * b.X_PJ.R;
      X_WJ.p.noalias() = X_WP.R * b.X_PJ.p;
      X_WJ.p += X_WP.p;
      Vw = data.V_W[b.parent].head<3>();
      Vv = data.V_W[b.parent].tail<3>();
      Aw = data.A0_W[b.parent].head<3>();
      Av = data.A0_W[b.parent].tail<3>();
    } else {
      X_WJ = b.X_PJ;
      Vw.setZero();
      Vv.setZero();
      Aw.setZero();
      Av.setZero();
    }
    // adds a joint velocity [jw; jv] (world, at the origin) and its velocity-product term V x vJ
    auto add_joint_motion = [&](const Vec3& jw, const Vec3& jv) {
      Vw += jw;
      Vv += jv;
      Aw += Vw.cross(jw);
      Av += Vw.cross(jv) + Vv.cross(jw);
    };
    auto set_column = [&](int col, const Vec3& sw, const Vec3& sv) {
      data.S_W.col(col).head<3>() = sw;
      data.S_W.col(col).tail<3>() = sv;
    };
    // a point relative to R; body 0 (a root) sets R at its own origin before anything uses it
    auto rel = [&](const Vec3& p_W) -> Vec3 { return p_W - p_ref; };
    switch (j.type) {
      case JointType::kFixed:
        X_WB = X_WJ;
        if (i == 0) p_ref = X_WB.p;
        break;
      case JointType::kRevolute: {
        const double sn = std::sin(q[j.idx_q]), cs = std::cos(q[j.idx_q]);
        X_WB.p = X_WJ.p;
        Vec3 w;
        if (j.axis_z != 0) {
          // R_JB = Rz(+-q): two columns mix, the axis column stays
          const double s = j.axis_z * sn;
          X_WB.R.col(0) = cs * X_WJ.R.col(0) + s * X_WJ.R.col(1);
          X_WB.R.col(1) = cs * X_WJ.R.col(1) - s * X_WJ.R.col(0);
          X_WB.R.col(2) = X_WJ.R.col(2);
          w = j.axis_z > 0 ? Vec3(X_WJ.R.col(2)) : Vec3(-X_WJ.R.col(2));
        } else {
          // Rodrigues with one sin/cos: R = c I + s [a]x + (1 - c) a a^T
          const Vec3& a = j.axis;
          const Vec3 t = (1.0 - cs) * a;
          Mat3 R_JB;
          R_JB << cs + t.x() * a.x(), t.x() * a.y() - sn * a.z(), t.x() * a.z() + sn * a.y(),
                  t.y() * a.x() + sn * a.z(), cs + t.y() * a.y(), t.y() * a.z() - sn * a.x(),
                  t.z() * a.x() - sn * a.y(), t.z() * a.y() + sn * a.x(), cs + t.z() * a.z();
          X_WB.R.noalias() = X_WJ.R * R_JB;
          w.noalias() = X_WJ.R * a;
        }
        if (i == 0) p_ref = X_WB.p;
        const Vec3 sv = rel(X_WB.p).cross(w);  // the line [w; p x w] through the joint
        set_column(j.idx_v, w, sv);
        const double qd = v[j.idx_v];
        add_joint_motion(w * qd, sv * qd);
        break;
      }
      case JointType::kPrismatic: {
        const Vec3 a_W = X_WJ.R * j.axis;
        X_WB.R = X_WJ.R;
        X_WB.p = X_WJ.p + a_W * q[j.idx_q];
        if (i == 0) p_ref = X_WB.p;
        set_column(j.idx_v, Vec3::Zero(), a_W);
        add_joint_motion(Vec3::Zero(), a_W * v[j.idx_v]);
        break;
      }
      case JointType::kRevolute2: {
        const Mat3 R1 = Eigen::AngleAxisd(q[j.idx_q], j.axis).toRotationMatrix();
        const Mat3 R2 = Eigen::AngleAxisd(q[j.idx_q + 1], j.axis2).toRotationMatrix();
        const Mat3 R_W1 = X_WJ.R * R1;
        X_WB.R.noalias() = R_W1 * R2;
        X_WB.p = X_WJ.p;
        if (i == 0) p_ref = X_WB.p;
        const Vec3 a1 = X_WJ.R * j.axis, a2 = R_W1 * j.axis2;  // the second axis turns with the first
        const Vec3 l1 = rel(X_WB.p).cross(a1), l2 = rel(X_WB.p).cross(a2);
        set_column(j.idx_v, a1, l1);
        set_column(j.idx_v + 1, a2, l2);
        const double qd0 = v[j.idx_v], qd1 = v[j.idx_v + 1];
        add_joint_motion(a1 * qd0 + a2 * qd1, l1 * qd0 + l2 * qd1);
        // S' qdot: the second axis is carried by the first rotation
        const Vec3 c = qd0 * qd1 * a1.cross(a2);
        Aw += c;
        Av += rel(X_WB.p).cross(c);
        break;
      }
      case JointType::kFloating: {
        const Quat quat(q[j.idx_q + 3], q[j.idx_q + 4], q[j.idx_q + 5], q[j.idx_q + 6]);
        const Mat3 R_JB = quat.normalized().toRotationMatrix();
        X_WB.R.noalias() = X_WJ.R * R_JB;
        X_WB.p = X_WJ.p + X_WJ.R * q.segment<3>(j.idx_q);
        if (i == 0) p_ref = X_WB.p;
        // v = V_B in B: columns [R e_k; p x R e_k] (rotations) and [0; R e_k] (translations)
        Vec3 jw = Vec3::Zero(), jv = Vec3::Zero();
        for (int k = 0; k < 3; ++k) {
          const Vec3 e = X_WB.R.col(k);
          const Vec3 l = rel(X_WB.p).cross(e);
          set_column(j.idx_v + k, e, l);
          set_column(j.idx_v + 3 + k, Vec3::Zero(), e);
          jw += e * v[j.idx_v + k];
          jv += l * v[j.idx_v + k] + e * v[j.idx_v + 3 + k];
        }
        add_joint_motion(jw, jv);
        break;
      }
    }
    data.V_W[i].head<3>() = Vw;
    data.V_W[i].tail<3>() = Vv;
    data.A0_W[i].head<3>() = Aw;
    data.A0_W[i].tail<3>() = Av;
    if (data.has_inertia[i]) data.I_W[i] = data.I_Bm[i].transformed(X_WB.R, rel(X_WB.p));
  }
  data.p_ref = p_ref;
}

Transform frame_pose(const Model& model, const Data& data, int frame) {
  const Frame& F = model.frames[frame];
  return F.body >= 0 ? data.X_WB[F.body] * F.X_BF : F.X_BF;
}

Vec6 frame_velocity(const Model& model, const Data& data, int frame) {
  const Frame& F = model.frames[frame];
  return F.body >= 0 ? to_ref(data, frame_pose(model, data, frame)).inv_act(data.V_W[F.body]) : Vec6::Zero();
}

Vec6 frame_bias_acceleration(const Model& model, const Data& data, int frame) {
  const Frame& F = model.frames[frame];
  return F.body >= 0 ? to_ref(data, frame_pose(model, data, frame)).inv_act(data.A0_W[F.body]) : Vec6::Zero();
}

}  // namespace coopdyn
