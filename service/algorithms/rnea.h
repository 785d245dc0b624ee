// Recursive Newton-Euler inverse dynamics (RBDA table 5.1) on the data of forward_kinematics.
#pragma once

#include <Eigen/Core>

#include "service/model/model.h"

namespace coopdyn {

// data.h = C(q,v) v + g(q): the generalized forces that give vdot = 0 (Coriolis, centrifugal,
// gravity; the paper's "C"). Requires forward_kinematics(q, v). Fills data.f_W (body forces,
// world coordinates).
void rnea_bias(const Model& model, Data& data);

// tau = M vdot + h - sum of J_k^T F_k of the external body forces f_ext (per body, in B at Bo); M
// includes the joint armatures, as crba's does.
// After the call, data.f[i] is the spatial force that body i's parent transmits to body i across
// joint i, in B coordinates (the joint reaction, "full force propagation").
// f_ext may be nullptr. data.a_W holds the vdot-linear part of the body accelerations (world).
// Requires forward_kinematics(q, v).
void rnea(const Model& model, Data& data, const Eigen::VectorXd& vdot, const std::vector<Vec6>* f_ext,
          Eigen::VectorXd& tau);

}  // namespace coopdyn
