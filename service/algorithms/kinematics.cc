#include "service/algorithms/kinematics.h"

#include <cmath>

namespace coopdyn {

void forward_kinematics(const Model& model, Data& data, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  const int nb = model.nbodies();
  for (int i = 0; i < nb; ++i) {
    const Body& b = model.bodies[i];
    const Joint& j = b.joint;
    Transform X_JB;
    Vec6 vJ = Vec6::Zero();
    Vec6& cJ = data.cJ[i];
    cJ.setZero();
    Mat6& S = data.S[i];
    switch (j.type) {
      case JointType::kFixed: break;
      case JointType::kRevolute: {
        // Rodrigues with one sin/cos: R = c I + s [a]x + (1 - c) a a^T
        const double sn = std::sin(q[j.idx_q]), cs = std::cos(q[j.idx_q]);
        const Vec3& a = j.axis;
        const Vec3 t = (1.0 - cs) * a;
        X_JB.R << cs + t.x() * a.x(), t.x() * a.y() - sn * a.z(), t.x() * a.z() + sn * a.y(),
                  t.y() * a.x() + sn * a.z(), cs + t.y() * a.y(), t.y() * a.z() - sn * a.x(),
                  t.z() * a.x() - sn * a.y(), t.z() * a.y() + sn * a.x(), cs + t.z() * a.z();
        S.col(0) << j.axis, Vec3::Zero();
        vJ = S.col(0) * v[j.idx_v];
        break;
      }
      case JointType::kPrismatic: {
        X_JB.p = j.axis * q[j.idx_q];
        S.col(0) << Vec3::Zero(), j.axis;
        vJ = S.col(0) * v[j.idx_v];
        break;
      }
      case JointType::kRevolute2: {
        const Mat3 R1 = Eigen::AngleAxisd(q[j.idx_q], j.axis).toRotationMatrix();
        const Mat3 R2 = Eigen::AngleAxisd(q[j.idx_q + 1], j.axis2).toRotationMatrix();
        X_JB.R = R1 * R2;
        const Vec3 a1_B = R2.transpose() * j.axis;
        S.col(0) << a1_B, Vec3::Zero();
        S.col(1) << j.axis2, Vec3::Zero();
        const double qd0 = v[j.idx_v], qd1 = v[j.idx_v + 1];
        vJ = S.col(0) * qd0 + S.col(1) * qd1;
        cJ.head<3>() = qd0 * qd1 * a1_B.cross(j.axis2);
        break;
      }
      case JointType::kFloating: {
        const Quat quat(q[j.idx_q + 3], q[j.idx_q + 4], q[j.idx_q + 5], q[j.idx_q + 6]);
        X_JB.R = quat.normalized().toRotationMatrix();
        X_JB.p = q.segment<3>(j.idx_q);
        S.setIdentity();
        vJ = v.segment<6>(j.idx_v);
        break;
      }
    }
    data.X_PB[i] = b.X_PJ * X_JB;
    if (b.parent >= 0) {
      data.X_WB[i] = data.X_WB[b.parent] * data.X_PB[i];
      data.V[i] = data.X_PB[i].inv_act(data.V[b.parent]) + vJ;
      data.A0[i] = data.X_PB[i].inv_act(data.A0[b.parent]) + cJ + cross_motion(data.V[i], vJ);
    } else {
      data.X_WB[i] = data.X_PB[i];
      data.V[i] = vJ;
      data.A0[i] = cJ + cross_motion(data.V[i], vJ);
    }
    for (int k = 0; k < j.nv; ++k) data.S_W.col(j.idx_v + k) = data.X_WB[i].act(S.col(k));
  }
}

Transform frame_pose(const Model& model, const Data& data, int frame) {
  const Frame& F = model.frames[frame];
  return F.body >= 0 ? data.X_WB[F.body] * F.X_BF : F.X_BF;
}

Vec6 frame_velocity(const Model& model, const Data& data, int frame) {
  const Frame& F = model.frames[frame];
  return F.body >= 0 ? F.X_BF.inv_act(data.V[F.body]) : Vec6::Zero();
}

Vec6 frame_bias_acceleration(const Model& model, const Data& data, int frame) {
  const Frame& F = model.frames[frame];
  return F.body >= 0 ? F.X_BF.inv_act(data.A0[F.body]) : Vec6::Zero();
}

}  // namespace coopdyn
