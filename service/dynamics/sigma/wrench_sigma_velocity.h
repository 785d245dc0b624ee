// The velocity columns of the measurement-noise linearization (wrench_sigma.h), as tangents.
//
// At a fixed configuration q the velocity v enters the evaluation's residuals and the reported
// wrenches only through
//   - the bias forces h(q, v) (RNEA at vdot = 0: quadratic in v) and their subtree sums, which the
//     joint reactions carry (joint_reactions.h),
//   - the constraint rows' gamma = -Gdot v - alpha G v (Gdot v quadratic, G v linear),
//   - the joints' damping (linear) and a rolling spec's rolling-resistance arm (its smoothed sign).
// Friction is held (set-valued at rest, its sign constant while sliding), as in the differences.
// So a change dv moves them by their tangents, computed here by forward mode through the
// velocity recursion, RBDA table 5.1 differentiated at fixed q:
//   dV_i  = dV_parent + S_i dv_i,                 (S_i: the joint's columns of data.S_W)
//   dA0_i = dA0_parent + dV_i x J_i + V_i x dJ_i   (J_i = S_i v_i, dJ_i = S_i dv_i; x: crm)
//   df_i  = I_i dA0_i + dV_i x* (I_i V_i) + V_i x* (I_i dV_i),  dF_i = df_i + sum of children's dF
//   dtau_k = S_k . dF_i(k)
// and constraint_bias_tangent() for Gdot v and rr_arm. Only the bodies below a DOF with dv != 0
// move, only they and their ancestors are visited: a joint's column costs its subtree and its path
// to the root. Exact (no step, no truncation error): equal to the directional differences of the
// residuals in the limit of their step (tests/dynamics/sigma/wrench_sigma_velocity_test.cc).
// Allocation-free; never throws.
#pragma once

#include <Eigen/Core>

#include "service/dynamics/sigma/wrench_sigma.h"

namespace coopdyn {

// Per evaluation, before the columns: each body's momentum I_W V_W (sd.P_W).
void velocity_tangent_setup(const System& sys, const Workspace& ws, WrenchSigmaData& sd);

// Column `col` of sd.X0 and sd.Gm (the change of E1 and E2 of wrench_sigma.h) and column `cd_col`
// of sd.Cd (the wrenches' own change at fixed vdot, lambda, in each output's report frame) along
// the velocity change sd.tv (its nonzero entries in sd.tv_nz), times `scale`. ws: the evaluation
// at (q, v); sd.I_fix and sd.X_WF set for it (wrench_sigma.cc's batch_setup).
void velocity_column(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& v, int col,
                     int cd_col, double scale);

}  // namespace coopdyn
