// The torques that hold a constrained system still: the safe-torque policy `hold` of coopdynd.
//
// At (q, v), find actuator torques tau (on the actuated DOFs only; a floating platform, a
// pseudo-joint or a DOF with a zero torque limit carries none) such that the constrained
// accelerations vanish: M 0 + h = tau + G^T lambda for some lambda, i.e. the torques balance the bias
// forces h (gravity, Coriolis, centrifugal) along every motion the constraints allow:
//     N^T (S_a^T tau_a - h) = 0,        N: an orthonormal basis of the null space of G.
// For cooperating arms this has many solutions (an internal squeeze is free); the rule is the
// least squares of the torques as fractions of each joint's limit, min sum (tau_i / limit_i)^2
// (plain minimum norm where no limit is given): the strong joints carry more, and no squeeze is
// added beyond what balance needs. At rest (v = 0, gamma = 0) the system
// then stays where it is; the residual |N^T (S_a^T tau_a - h)| says how well the actuators can
// hold it (nonzero when they cannot balance some motion, e.g. a free platform nobody reaches).
// Both solves are SVDs of fixed-size, preallocated matrices (rank tolerance 1e-10 relative); no
// allocation after construction.
#pragma once

#include <Eigen/SVD>
#include <vector>

#include "service/dynamics/constrained_dynamics.h"

namespace coopdyn {

struct HoldWorkspace {
  HoldWorkspace(const System& sys, const std::vector<unsigned char>& actuated);
  Workspace ws;                    // h and G at (q, v)
  std::vector<int> act;            // actuated velocity indices
  Eigen::JacobiSVD<Eigen::MatrixXd> svd_G, svd_A;
  Eigen::MatrixXd Gt, A;           // (nv x rows) G^T padded, (nv x na) V^T S_a^T with the range rows zeroed
  Eigen::VectorXd b, x;            // (nv), (na)
  Eigen::VectorXd w;               // (na) column weights: each joint's torque limit (1 without one)
  double residual = 0;             // |N^T (S_a^T tau_a - h)| of the last solve (N*m or N)
};

// Default actuation: every DOF but a floating joint's and a pseudo-joint's, and none with a zero
// torque limit.
std::vector<unsigned char> default_actuated(const System& sys);

// Fills tau (nv) with the holding torques at (q, v); false (tau zero) if the state is not valid.
bool holding_torque(const System& sys, HoldWorkspace& hw, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                    Eigen::VectorXd& tau);

// The holding torques as coopdynd applies them: each actuated DOF's (hw.act) clamped to +-its torque
// limit (sys.tau_limit), a joint that cannot hold its share then holds what it can. Returns how many
// DOFs were clamped. Allocation-free.
int clamp_to_torque_limits(const System& sys, const HoldWorkspace& hw, Eigen::VectorXd& tau);

}  // namespace coopdyn
