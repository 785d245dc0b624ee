// Joint reactions: the spatial force that each body's parent transmits to it across its joint
// (RBDA s.5.3, the backward pass of the recursive Newton-Euler algorithm), for known accelerations.
//
//   R_i = sum over the subtree of i of ( I_j a_j + V_j x* I_j V_j - I_j a_g ) - f_ext,j
//
// with a_j the body's spatial acceleration, a_g gravity and f_ext,j the external forces on body j
// (here: the constraint forces). The velocity-product and gravity terms are read from data.f_W as
// rnea_bias leaves it (their subtree sums), so only the vdot-linear part is propagated: one pass
// down for the accelerations, one pass up over the bodies asked for, O(n), no allocation.
// Bodies welded to their parent (fixed joints) have their inertia folded into the parent's
// (Data::I_Bm); the reaction across such a joint adds the inertial force of the welded group
// (Data::I_Bw), so a grasp or a welded tool reports its reaction exactly.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "service/model/model.h"

namespace coopdyn {

// Requires data as evaluate() leaves it: forward_kinematics(q, v) then rnea_bias (data.f_W holds the
// subtree sums of the bias forces). f_ext_W: per body, world coordinates at data.p_ref (read for the
// bodies of `pass` only). pass: the bodies whose reaction is wanted together with all their
// descendants, in decreasing index (leaves first). Writes a_W (every body: the vdot-linear part of
// its acceleration), acc_W (scratch) and R_W[i] for every i in pass (world coordinates at p_ref).
void joint_reactions(const Model& model, const Data& data, const Eigen::VectorXd& vdot,
                     const std::vector<Vec6>& f_ext_W, const std::vector<int>& pass, std::vector<Vec6>& a_W,
                     std::vector<Vec6>& acc_W, std::vector<Vec6>& R_W);

}  // namespace coopdyn
