#include "service/scene/builder.h"

#include <cmath>

namespace coopdyn::scene_detail {

uint8_t bearing_mask(JointType t, const Vec3& axis, const Vec3& axis2) {
  auto clear = [](uint8_t m, const Vec3& a, int offset) -> uint8_t {
    for (int k = 0; k < 3; ++k)
      if (std::abs(std::abs(a[k]) - a.norm()) <= 1e-12 * a.norm()) m = static_cast<uint8_t>(m & ~(1u << (offset + k)));
    return m;
  };
  switch (t) {
    case JointType::kRevolute: return clear(0x3f, axis, 0);
    case JointType::kPrismatic: return clear(0x3f, axis, 3);
    case JointType::kRevolute2: return clear(clear(0x3f, axis, 0), axis2, 0);  // exact when both stay frame axes
    case JointType::kFloating: return 0;
    case JointType::kFixed: break;
  }
  return 0x3f;
}

WrenchOutput joint_output(const std::string& name, const std::string& frame, const std::string& by, int body,
                          bool reversed, int frame_body, const Transform& X_BF, uint8_t mask) {
  WrenchOutput o;
  o.name = name;
  o.frame = frame;
  o.by = by;
  o.kind = WrenchKind::kJoint;
  o.body = body;
  o.reversed = reversed;
  o.frame_body = frame_body;
  o.X_BF = X_BF;
  o.constrained = mask;
  return o;
}

void set_floating_q(Eigen::VectorXd& q, int idx, const Transform& X) {
  q.segment<3>(idx) = X.p;
  Quat qu(X.R);
  qu.normalize();
  q[idx + 3] = qu.w();
  q[idx + 4] = qu.x();
  q[idx + 5] = qu.y();
  q[idx + 6] = qu.z();
}

}  // namespace coopdyn::scene_detail
