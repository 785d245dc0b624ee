// The position columns of the measurement-noise linearization (wrench_sigma.h), as tangents.
//
// A change dq of a measured 1-DOF joint j (body b, parent p) moves b's subtree as one rigid body
// relative to p, by the twist delta = S_j dq (world, at data.p_ref: the joint's column of S_W).
// Every quantity of the subtree made of its geometry is carried along: a motion m changes by
// delta x m, a force f by delta x* f, an inertia I by delta x* I - I delta x (x: crm, x*: crf; S_j
// itself does not move, delta x S_j = 0). Velocities and accelerations are relative to p's, which
// stays (RBDA table 5.1 with V_i = V_p + V_r, the Jacobi identity for the velocity products):
//   dV_i   = delta x (V_i - V_p)
//   dA0_i  = delta x (A0_i - A0_p) - (delta x V_p) x (V_i - V_p)
//   da_i   = delta x (a_i - a_p)                 (a: the vdot-linear part, vdot held)
//   df_i   = dI (a + A0 - g) + I (da + dA0) + dV x* (I V) + V x* (dI V + I dV)
// (each body's own inertia, as rnea's), dF_i their subtree sums, and
//   dtau_k = S_k . (dF_i - delta x* F_i)  below b (S_k carried),  S_k . dF_b  above it.
// A weld's rows are G(:, k) = s_k X_A^-1 S_k (s_k: +1 if k moves frame A, -1 if B) and its
// generalized force s_k S_k . F_s (F_s: spec_force), its Gdot v = X_A^-1 (A0_a - A0_b + V_a x V_b):
// they change where A and S_k are not carried together. A joint reaction is the subtree sum of the
// body forces less the constraint forces inside it, seen in its report frame: it changes with the
// sums, the carried constraint forces and, on a moved body, its frame. Only the subtree, the path
// to the root, the welds that touch the subtree and the reactions above or inside it are visited:
// a column costs the joint's subtree, not an evaluation. Exact (no step): equal to central
// differences of the residuals in the limit of their step (tests/dynamics/sigma/wrench_sigma_position_test.cc).
//
// A floating joint's DOF (what a refit fits, state_fit_sigma.h) is a tangent the same way: its
// motion subspace is body-fixed, so its own other columns are carried too. The first body's joint
// (1-DOF or floating) is one as well: it moves p_ref, but every quantity is carried about the
// evaluation's p_ref and what the columns are (generalized forces, rows in frame A, wrenches in
// their report frames) is free of it.
// Not covered, the column then being a difference of the whole residual (wrench_sigma.cc): a rolling
// contact in the subtree (its contact frame is not carried: it turns with the wheel's tilt), a weld
// in it under Baumgarte position feedback (its pose error's logarithm). Allocation-free; never throws.
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
