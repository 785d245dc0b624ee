// Frame Jacobians J_F (V_WF_F = J_F v) after forward_kinematics.
#pragma once

#include <Eigen/Core>

#include "service/model/model.h"

namespace coopdyn {

// Writes the columns of the frame's support DOFs into J (6 x nv); other columns are left as they
// are (the caller zeroes J once: the support of a frame never changes).
template <typename Mat>
inline void frame_jacobian(const Model& model, const Data& data, int frame, const std::vector<int>& support, Mat&& J) {
  const Frame& F = model.frames[frame];
  if (F.body < 0) return;
  const Transform X_RF = to_ref(data, data.X_WB[F.body] * F.X_BF);
  for (int d : support) J.col(d) = X_RF.inv_act(data.S_W.col(d));
}

}  // namespace coopdyn
