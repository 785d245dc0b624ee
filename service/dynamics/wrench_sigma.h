// The uncertainty of every reported wrench (wrench_outputs.h) from declared joint-torque noise
// (System::tau_noise, scene key `noise`). Call after evaluate() on the same workspace (it reads the
// evaluation's factors; the solves use the workspace's scratch, not its results).
//
// At a fixed state (q, v) every reported wrench is affine in the torques: w_k = W_k tau + c_k (the
// factorization of M and of Q does not depend on tau, nor does the rank decision or the redundancy
// rule, which are linear in the right-hand side). With tau ~ N(tau, diag(S^2)) the covariance of
// w_k is exactly W_k diag(S^2) W_k^T; it is computed through its square root
//   C_k = W_k diag(S)          (6 x na, na = the DOFs with noise), sigma_k = the row norms of C_k
// one column per noisy DOF j, from the evaluation's factors (constrained_dynamics.h):
//   du = L^-T e_j S_j,  dlambda = Q^-1 (-Y du),  dvdot = L^-1 (du + Y^T dlambda)
// then the tips' rows of dlambda and the joint reactions' change (joint_reactions.h, the part linear
// in vdot, minus the subtree sum of the constraint-force change). With rolling resistance the
// wheels' moments depend on lambda: the column is the same fixed point as the evaluation's.
//
// Indeterminate components (WrenchData::indeterminate, an over-constrained system) report the
// spread of the value the scene's redundancy rule selects (minimum norm or compliance-weighted):
// the physics does not determine them, the rule is linear, and that is the value reported.
//
// Coulomb friction at a joint at rest is free within its bound (stuck, it would absorb a torque
// change): sigma is the spread with that friction left free, the same map as without it, and the
// interval the friction itself may move each wrench over is the separate bound of friction_bound.h.
//
// Supported formulations: mobile_platform and classic (every shipped scene). pseudo_joint and svd,
// a failed evaluation, or a scene without noise: valid = false and sigma zero. Allocation-free
// after construction; never throws.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/wrenches.h"

namespace coopdyn {

// The scene declares torque noise on some DOF and its formulation propagates it (mobile_platform,
// classic): the outputs carry sigma.
bool wrench_sigma_supported(const System& sys);

struct WrenchSigmaData {
  explicit WrenchSigmaData(const System& sys);

  bool declared = false;  // wrench_sigma_supported(sys)
  bool valid = false;     // the last compute_wrench_sigma() filled sigma
  std::vector<int> dofs;  // (na) the velocity indices with noise > 0
  Eigen::VectorXd S;      // (na) their standard deviations (N m or N)
  std::vector<Vec6> sigma;  // per output: standard deviation of each component [moment; force] in
                            // the output's report frame (N m, N)
  // C(6 k + c, j): component c of output k per one standard deviation of DOF dofs[j]'s torque
  // (the square root of the covariance: cov_k = C_k C_k^T)
  Eigen::MatrixXd C;  // (6 outputs x na)

  // scratch
  Eigen::VectorXd du, du0, dlam, dlam_prev, dvdot, rhs;  // (nv), (nv), (rows), (rows), (nv), (rows)
  std::vector<Vec6> zero_f, a, acc, R, R0, dF;           // per body (dF: per pass spec)
  std::vector<Transform> X_WF;                           // per output: its report frame
};

// Fills sd.sigma and sd.C for the evaluation in ws.
// Nothing to do (valid = false, sigma zero) when nothing is declared or the evaluation failed.
void compute_wrench_sigma(const System& sys, Workspace& ws, WrenchSigmaData& sd);

}  // namespace coopdyn
