#include "service/algorithms/kinematics.h"

#include <cmath>

namespace coopdyn {

namespace {

// [w; p x w]: a rotation about the axis w (world) through the point p, at the world origin.
inline Vec6 line(const Vec3& w, const Vec3& p) {
  Vec6 s;
  s.head<3>() = w;
  s.tail<3>() = p.cross(w);
  return s;
}

}  // namespace

void forward_kinematics(const Model& model, Data& data, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  const int nb = model.nbodies();
  for (int i = 0; i < nb; ++i) {
    const Body& b = model.bodies[i];
    const Joint& j = b.joint;
    Transform& X_WB = data.X_WB[i];
    // X_WJ: the joint frame in the world
    Transform X_WJ;
    if (b.parent >= 0) {
      const Transform& X_WP = data.X_WB[b.parent];
      X_WJ.R.noalias() = X_WP.R * b.X_PJ.R;
      X_WJ.p.noalias() = X_WP.R * b.X_PJ.p;
      X_WJ.p += X_WP.p;
      data.V_W[i] = data.V_W[b.parent];
      data.A0_W[i] = data.A0_W[b.parent];
    } else {
      X_WJ = b.X_PJ;
      data.V_W[i].setZero();
      data.A0_W[i].setZero();
    }
    Vec6& V = data.V_W[i];
    Vec6& A0 = data.A0_W[i];
    switch (j.type) {
      case JointType::kFixed: X_WB = X_WJ; break;
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
        const Vec6 s = line(w, X_WB.p);
        data.S_W.col(j.idx_v) = s;
        const Vec6 vJ = s * v[j.idx_v];
        V += vJ;
        A0 += cross_motion(V, vJ);
        break;
      }
      case JointType::kPrismatic: {
        const Vec3 a_W = X_WJ.R * j.axis;
        X_WB.R = X_WJ.R;
        X_WB.p = X_WJ.p + a_W * q[j.idx_q];
        Vec6 s;
        s << Vec3::Zero(), a_W;
        data.S_W.col(j.idx_v) = s;
        const Vec6 vJ = s * v[j.idx_v];
        V += vJ;
        A0 += cross_motion(V, vJ);
        break;
      }
      case JointType::kRevolute2: {
        const Mat3 R1 = Eigen::AngleAxisd(q[j.idx_q], j.axis).toRotationMatrix();
        const Mat3 R2 = Eigen::AngleAxisd(q[j.idx_q + 1], j.axis2).toRotationMatrix();
        const Mat3 R_W1 = X_WJ.R * R1;
        X_WB.R.noalias() = R_W1 * R2;
        X_WB.p = X_WJ.p;
        const Vec3 a1 = X_WJ.R * j.axis, a2 = R_W1 * j.axis2;  // the second axis turns with the first
        const Vec6 s0 = line(a1, X_WB.p), s1 = line(a2, X_WB.p);
        data.S_W.col(j.idx_v) = s0;
        data.S_W.col(j.idx_v + 1) = s1;
        const double qd0 = v[j.idx_v], qd1 = v[j.idx_v + 1];
        const Vec6 vJ = s0 * qd0 + s1 * qd1;
        V += vJ;
        // S' qdot: the second axis is carried by the first rotation
        A0 += cross_motion(V, vJ) + line(qd0 * qd1 * a1.cross(a2), X_WB.p);
        break;
      }
      case JointType::kFloating: {
        const Quat quat(q[j.idx_q + 3], q[j.idx_q + 4], q[j.idx_q + 5], q[j.idx_q + 6]);
        const Mat3 R_JB = quat.normalized().toRotationMatrix();
        X_WB.R.noalias() = X_WJ.R * R_JB;
        X_WB.p = X_WJ.p + X_WJ.R * q.segment<3>(j.idx_q);
        // v = V_B in B: columns [R e_k; p x R e_k] (rotations) and [0; R e_k] (translations)
        for (int k = 0; k < 3; ++k) {
          data.S_W.col(j.idx_v + k) = line(X_WB.R.col(k), X_WB.p);
          data.S_W.col(j.idx_v + 3 + k) << Vec3::Zero(), X_WB.R.col(k);
        }
        const Vec6 vJ = data.S_W.middleCols<6>(j.idx_v) * v.segment<6>(j.idx_v);
        V += vJ;
        A0 += cross_motion(V, vJ);
        break;
      }
    }
    data.I_W[i] = data.I_B[i].transformed(X_WB);
  }
}

Transform frame_pose(const Model& model, const Data& data, int frame) {
  const Frame& F = model.frames[frame];
  return F.body >= 0 ? data.X_WB[F.body] * F.X_BF : F.X_BF;
}

Vec6 frame_velocity(const Model& model, const Data& data, int frame) {
  const Frame& F = model.frames[frame];
  return F.body >= 0 ? frame_pose(model, data, frame).inv_act(data.V_W[F.body]) : Vec6::Zero();
}

Vec6 frame_bias_acceleration(const Model& model, const Data& data, int frame) {
  const Frame& F = model.frames[frame];
  return F.body >= 0 ? frame_pose(model, data, frame).inv_act(data.A0_W[F.body]) : Vec6::Zero();
}

}  // namespace coopdyn
