// Completing a measured state from joint measurements alone, and the closure residual of a state.
//
// fit_state() finds what the joints do not give (the floating joints' coordinates: the load's
// pose and twist; pseudo-joints, set to their initial value) by least squares over all the
// constraints together (Gauss-Newton on the holonomic rows' position error, then the velocities
// minimizing |G v|), and reports how far the arms disagree. What may be omitted is decided once
// from the System at q0 (StateFitPlan): floating positions when the holonomic rows fix them,
// floating velocities when all rows do; a vehicle's chassis pose never (its wheels do not fix it).
// Rows are weighted as written (rad for rotation rows, m for translation rows, in the tip frame).
// Allocation-free after the plan.
//
// Closure residual (of any state, fitted or fully measured): the largest |e| over the position-type
// rows (m) and the orientation-type rows (rad), and the largest |G v| over the velocity rows of
// linear (m/s) and angular (rad/s) type, each with the constraint it is found in.
// The iterations, their stopping rules and the omission rules: docs/method.md, "Completing a
// measured state".
#pragma once

#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "service/constraints/constraints.h"
#include "service/dynamics/system.h"

namespace coopdyn {

struct StateFitPlan {
  std::vector<int> fit_q;         // q indices of the floating joints (the coordinates fitted)
  std::vector<int> fit_v;         // v indices of the floating joints
  std::vector<int> pseudo_q, pseudo_v;  // pseudo-joint coordinates (set to q0, 0 when omitted)
  bool q_fittable = false;        // the holonomic rows fix the floating joints' positions
  bool v_fittable = false;        // all rows fix their velocities (and none of them is actuated)
  std::vector<unsigned char> holonomic;  // (rows) the row has a position error (weld, lock, contact height)
  std::vector<unsigned char> angular;    // (rows) rad / rad/s (weld rotation rows, revolute locks), else m, m/s
  const char* why_not_q = "";    // when !q_fittable: a short reason (for error messages)
  const char* why_not_v = "";
};
// Allocates (start-up only).
StateFitPlan plan_state_fit(const System& sys);

// position m, orientation rad, linear velocity m/s, angular velocity rad/s
enum ClosureKind { kClosurePosition = 0, kClosureOrientation = 1, kClosureLinearVelocity = 2, kClosureAngularVelocity = 3 };
// "position", "orientation", "linear velocity", "angular velocity"; and "m", "rad", "m/s", "rad/s"
inline const char* closure_kind_name(int kind) {
  static const char* const k[4] = {"position", "orientation", "linear velocity", "angular velocity"};
  return k[kind & 3];
}
inline const char* closure_kind_unit(int kind) {
  static const char* const u[4] = {"m", "rad", "m/s", "rad/s"};
  return u[kind & 3];
}
struct Closure {
  double value[4] = {0, 0, 0, 0};  // the largest residual of each kind
  int spec[4] = {-1, -1, -1, -1};  // the constraint (ConstraintSet::specs index) it is in, -1 if none
  int iterations = 0;              // Gauss-Newton iterations of the position fit (0: not fitted)
};

struct StateFitWorkspace {
  StateFitWorkspace(const System& sys, const StateFitPlan& plan);
  Data data;
  ConstraintData cd;
  Eigen::VectorXd q_start;  // (nq) start of the next position fit (the last fit, or q0)
  bool have_start = false;
  int n_hol = 0;            // holonomic rows
  Eigen::MatrixXd Gu;       // (rows x n_fit) columns of the fitted DOFs (first n_hol rows: holonomic)
  Eigen::VectorXd r;        // (rows)
  Eigen::MatrixXd N, V;     // (n_fit x n_fit) normal matrix (destroyed by the decomposition), eigenvectors
  Eigen::LLT<Eigen::MatrixXd> llt;  // of N, when N is well conditioned
  Eigen::VectorXd w, b, x;  // (n_fit)
  Eigen::VectorXd dv;       // (nv) tangent step
  Eigen::VectorXd q_try;    // (nq)
  Eigen::MatrixXd Pq, Pv;   // (n_fit x rows) the fits' operators (fit_operators)
  Closure closure;
};

// Fills the omitted coordinates of (q, v): positions when fit_q (q's fitted entries are ignored on
// input), velocities when fit_v; pseudo-joint coordinates are not touched (the decoder sets them).
// Then computes the closure residual of the result. Allocation-free; q, v sized (nq), (nv).
const Closure& fit_state(const System& sys, const StateFitPlan& plan, StateFitWorkspace& ws, bool fit_q, bool fit_v,
                         Eigen::VectorXd& q, Eigen::VectorXd& v);

// One Gauss-Newton step of the position fit at q as it is (no stopping test, no step halving):
// *dx (n_fit, the fitted floating DOFs' tangent step, in plan.fit_v's order) = -(G_u^T G_u)^+ G_u^T e.
// Its change between two measurements is the fit's first-order response to the measured joints
// (state_fit_sigma.h). Allocation-free; q is not changed.
void fit_position_step(const System& sys, const StateFitPlan& plan, StateFitWorkspace& ws, const Eigen::VectorXd& q,
                       const Eigen::VectorXd& v, Eigen::VectorXd* dx);

// The fits' linear operators at a configuration, G (rows x nv) the constraint rows' Jacobian there:
// one factorization of each least squares (Cholesky or the rank-safe pseudo-inverse, as the fit),
// every right-hand side at once.
//   Pq = (G_u^T G_u)^+ G_u^T over the holonomic rows (zero columns at the others), when positions:
//        a change c of the holonomic rows' position error moves the fitted coordinates by the
//        tangent step -Pq c, so a measured position change dq moves them by -Pq G dq to first
//        order (the position fit's response; its terms in the closure residual left over are
//        second order, residual times dq, and dropped);
//   Pv = the same over all rows, when velocities: the fitted velocities are -Pv (G_m v_m) (the
//        velocity fit, exactly linear), so a change c of the rows' velocity G v moves them by -Pv c.
// Allocation-free.
void fit_operators(const StateFitPlan& plan, StateFitWorkspace& ws, const Eigen::MatrixXd& G, bool positions,
                   bool velocities);

// The closure residual of cd (constraint_rows at the state), rows classified by plan.
void closure_residual(const ConstraintSet& set, const StateFitPlan& plan, const ConstraintData& cd, Closure* out);

}  // namespace coopdyn
