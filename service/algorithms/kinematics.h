// Forward kinematics: poses, velocities, motion subspaces and the velocity-product accelerations.
#pragma once

#include <Eigen/Core>

#include "service/model/model.h"

namespace coopdyn {

// Fills data.X_WB, S_W, V_W, A0_W and the world-coordinate body inertias I_W for configuration q (nq) and velocity v (nv), all in world
// coordinates at the reference point data.p_ref, which it sets to body 0's origin (see Data). A0_W is each body's spatial acceleration with
// vdot = 0 and no gravity: the velocity-product term from which every Jdot*v is read.
void forward_kinematics(const Model& model, Data& data, const Eigen::VectorXd& q, const Eigen::VectorXd& v);

// The same for the bodies of the subtree of body `root` only, the others' entries left as they
// are: after forward_kinematics(q0, v0), with (q, v) differing from (q0, v0) only in the subtree's
// joints, data is then that of forward_kinematics(q, v) (root 0, whose pose sets data.p_ref: the
// whole tree). Allocation-free.
void forward_kinematics_subtree(const Model& model, Data& data, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                                int root);

// Pose of an operational frame in the world, after forward_kinematics.
Transform frame_pose(const Model& model, const Data& data, int frame);
// V_WF_F: spatial velocity of a frame in its own coordinates.
Vec6 frame_velocity(const Model& model, const Data& data, int frame);
// Jdot*v of a frame: its spatial acceleration at vdot = 0 (no gravity), in F.
Vec6 frame_bias_acceleration(const Model& model, const Data& data, int frame);

}  // namespace coopdyn
