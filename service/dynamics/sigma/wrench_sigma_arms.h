// Each wrench's sigma under torque noise, arm by arm (wrench_sigma.h): a form linear in the arms.
//
// Where the joints fall into arms that couple only through a few common DOFs (the load's, which
// every constraint row reaches: the same structure as the block factor of Q, q_blocks.h) the
// constrained solve [M -G^T; G 0] is block-arrow: each arm's unknowns (its accelerations and its
// rows' multipliers) couple to the other arms' only through the common DOFs' accelerations a. The
// response to a torque column j of arm b is then its response with a held at 0 (nonzero on arm b
// only) plus the response to the force on the common DOFs that holds them, so for an output k on
// arm h
//   C_kj = H_kj + E_k T_j   (j on arm h),     C_kj = E_k T_j   (j on another arm),
// E_k (6 x 6) output k's response per unit acceleration of the common DOFs (its arm following),
// T_j (6) their acceleration under column j. Three things through the full solve:
//   * the packed torque columns: column s the sum over the arms of their s-th noisy torque (the
//     held parts do not overlap): P_ks = H_ks + E_k sum_b T_{b,s};
//   * V, the response to a unit force on each common DOF: E_k = V_k V_L^-1, V_L (6 x 6, SPD) the
//     common DOFs' own rows of it;
//   * T_j = S_j times V's accelerations at j's DOF (the solve's map from generalized force to
//     acceleration, M^-1 - M^-1 G^T Q^-1 G M^-1, is symmetric).
// With c_j = V_L^-1 T_j, an arm's own columns are C_kj = P_ks - V_k (sum_{b != h} c_{b,s}), and the
// other arms' part of the variance is one 6 x 6 quadratic form per output,
//   sigma_k^2 = |own columns|^2 (by rows) + diag(V_k (sum_{b != h} sum_{j on b} c_j c_j^T) V_k^T),
// the sums over the other arms from prefix and suffix sums: O(arms) in all, against the column
// form's outputs x columns. The quadratic form carries an error of ~n eps (|V_k| sqrt(diag))^2 in
// sigma^2, which a component near zero would turn into sqrt(eps) in sigma: where that bound is
// above 1e-12 of the output's largest sigma, that output's other arms are summed column by column
// (C_kj = V_k c_j), exact like the column form.
//
// Falls back (returns false: the column form) where the structure does not hold (plan), with
// rolling resistance (the solve is iterated, not symmetric), an over-constrained or rank-revealing
// solve, or V_L not safely positive definite (a singular arm). Allocation-free after the plan.
#pragma once

#include "service/dynamics/sigma/wrench_sigma.h"

namespace coopdyn {

// sd.arm: the arms, their noisy torques and each output's arm (construction; usable false where
// the structure does not hold)
void sigma_arms_plan(const System& sys, WrenchSigmaData& sd);

// The arm form applies to this evaluation (torque noise only): the plan holds, from sd.arms_min
// arms, and the solve is the symmetric one
bool sigma_arms_apply(const System& sys, const Workspace& ws, const WrenchSigmaData& sd);

// The packed columns (sd.arm.pack) and the common DOFs' unit forces as the torque columns of X
// (nv x columns, zeroed by the caller)
void sigma_arms_columns(const WrenchSigmaData& sd, WrenchSigmaData::RowMat& X);

// After the full solve and the outputs of those columns (sd.X, sd.arm.Cf): sd.sigma, and C where
// sd.keep_C. False: V_L not safely positive definite (nothing written).
bool sigma_arms_finish(WrenchSigmaData& sd);

}  // namespace coopdyn
