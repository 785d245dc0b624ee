// Each wrench's sigma under torque noise, arm by arm (wrench_sigma.h): a form linear in the arms.
//
// Where the joints fall into arms that couple only through a few common DOFs (the load's: the same
// structure as the block factor of Q, q_blocks.h) the constrained solve is block-arrow, and each
// output's variance is its own arm's columns plus one 6 x 6 quadratic form for the other arms
// (prefix and suffix sums): O(arms) in all, against the column form's outputs x columns. Where that
// form's round-off bound exceeds 1e-12 of the output's largest sigma, the other arms are summed
// column by column, exact like the column form.
//
// Falls back (returns false: the column form) where the structure does not hold (plan), with
// rolling resistance (the solve is iterated, not symmetric), an over-constrained or rank-revealing
// solve, or V_L not safely positive definite (a singular arm). Allocation-free after the plan.
// The decomposition: docs/method.md, "Sigma arm by arm".
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
