// The position columns of the measurement-noise linearization (wrench_sigma.h), as tangents.
//
// A change dq of a measured joint moves its subtree as one rigid body relative to its parent; the
// column is the exact derivative of the residuals (equal to central differences in the limit of
// their step), found by carrying the subtree's motions, forces and inertias along that twist and
// visiting only the subtree, its path to the root, the welds that touch it and the reactions above
// or inside it: a column costs the joint's subtree, not an evaluation. Floating DOFs and the first
// body's joint are tangents the same way.
// Not covered, the column then being a difference of the whole residual (wrench_sigma.cc): a rolling
// contact in the subtree (its contact frame is not carried: it turns with the wheel's tilt), a weld
// in it under Baumgarte position feedback (its pose error's logarithm). Allocation-free; never throws.
// The carried quantities: docs/method.md, "Position columns of the noise linearization".
#pragma once

#include "service/dynamics/sigma/wrench_sigma.h"

namespace coopdyn {

// At construction (topology only): per position column, then per floating-joint DOF (what a refit
// fits), whether it is a tangent and what it visits (sd.qt_*).
void position_tangent_plan(const System& sys, WrenchSigmaData& sd);

// Per evaluation, before the columns: each body's own world inertia, vdot-linear and total
// acceleration, momentum, body force and subtree sum, each weld's constraint force (sd.p*).
void position_tangent_setup(const System& sys, const Workspace& ws, WrenchSigmaData& sd);

// Column `col` of sd.X0 and sd.Gm and column `cd_col` of sd.Cd (as velocity_column) for the
// tangent a of the plan (along sd.qt_dof[a], sd.qt_tangent[a] set), times `scale`; with gv_col >=
// 0 also column gv_col of sd.Gv, the change of the constraint rows' velocity G v at fixed v (the
// velocity fit's right-hand side, state_fit_sigma.h). ws: the evaluation at (q, v);
// position_tangent_setup and batch_setup (sd.X_WF) done for it.
void position_column(const System& sys, const Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& v, int a,
                     int col, int cd_col, int gv_col, double scale);

}  // namespace coopdyn
