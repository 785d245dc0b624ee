// Time integration of the constrained dynamics. Each step evaluates the full constrained system
// (accelerations and constraint forces) through evaluate(); the Stepper owns every buffer.
#pragma once

#include <string>

#include <Eigen/Core>
#include <Eigen/LU>

#include "service/dynamics/constrained_dynamics.h"

namespace coopdyn {

enum class Integrator {
  kSemiImplicitEuler,  // v+ = v + h vdot(q, v);  q+ = q (+) h v+   (symplectic Euler)
  kRk4,                // classical Runge-Kutta in (q, v), quaternions renormalized after the step
  kImplicitEuler,      // linearly implicit (Rosenbrock) Euler for stiff cases: with A = dvdot/dq,
                       // B = dvdot/dv by finite differences (2 nv evaluations),
                       //   (I - h B - h^2 A) dv = h (vdot + h A v),  v+ = v + dv,  q+ = q (+) h v+
                       // L-stable on the linearized system, first order
};
const char* integrator_name(Integrator i);
bool parse_integrator(const std::string& s, Integrator* i);

struct Stepper {
  explicit Stepper(const System& sys);
  Workspace ws;        // the evaluation at the start of the last step (wrenches and position errors are read here)
  Workspace ws_stage;  // RK4 stages
  Eigen::VectorXd k_q[4], k_v[4];  // (nq), (nv)
  Eigen::VectorXd q_s, v_s;        // stage state
  // implicit Euler scratch (nv x nv and nv)
  Eigen::MatrixXd Ja, Jb, K;
  Eigen::PartialPivLU<Eigen::MatrixXd> lu;
  Eigen::VectorXd vdot0, dq, rhs_v;
  // projection scratch: x = G^T (G G^T)^+ b through the rank-revealing Cholesky of the solve
  // (q_solve.h: fast path, else pivoted, minimum norm); kEigen keeps the former Jacobi
  // eigen-decomposition (eigenvalues <= rank_tol * the largest dropped) as a reference for tests
  enum class ProjectionSolve { kCholesky, kEigen };
  ProjectionSolve projection_solve = ProjectionSolve::kCholesky;
  QSolver proj_qs;                 // (rows)
  SolverOptions proj_opt;          // the scene's tolerances, minimum norm
  Eigen::MatrixXd GGt, eA, eV;     // (rows x rows); eA, eV only for kEigen
  Eigen::VectorXd ew, r, dv;       // (rows), (rows), (nv)
  // start state of the last step, restored when the step diverges
  Eigen::VectorXd q_start, v_start;  // (nq), (nv)
  double diverged_speed = 0.0;       // |v_i| that tripped the detector in the last diverged step
};

// Projects (q, v) onto the constraint manifold (see SolverOptions::projection_iterations). Returns
// the largest position error left. A lock's error is measured from its target in st.ws_stage
// (ConstraintData::lock_target, set_lock_target): a commanded target is reached at the projection
// of the step after it is set. Allocation-free.
double project_state(const System& sys, Stepper& st, Eigen::VectorXd& q, Eigen::VectorXd& v);

// Sets the target of lock spec `spec` (ConstraintKind::kLock) in both of the stepper's workspaces,
// rad or m. Allocation-free.
inline void set_lock_target(Stepper& st, int spec, double target) {
  st.ws.cd.lock_target[static_cast<size_t>(spec)] = target;
  st.ws_stage.cd.lock_target[static_cast<size_t>(spec)] = target;
}

// Advances (q, v) by dt under tau. Returns the diagnostics of the evaluation at the start state;
// on an error status, q and v are left unchanged. Projects afterwards if the scene asks.
// Divergence detector: when the new state is not finite or a velocity coordinate exceeds
// SolverOptions::max_speed, q and v are restored to the start state and the returned diagnostics
// (st.ws.diag) say kError / Reason::kDiverged, with bad_index the offending DOF (velocity index;
// -1 for a non-finite q). st.ws keeps the (finite) evaluation at the start state.
const Diagnostics& step(const System& sys, Stepper& st, Integrator integ, double dt, const Eigen::VectorXd& tau,
                        Eigen::VectorXd& q, Eigen::VectorXd& v);

// step() after its first evaluation: st.ws already holds the evaluation at (q, v, tau) (evaluate(),
// or begin_evaluation() and finish_evaluation(), as the safe torque `hold` does to compute tau from
// it). Bit for bit step(); an error status in st.ws.diag is returned as is, q and v unchanged.
const Diagnostics& step_evaluated(const System& sys, Stepper& st, Integrator integ, double dt, const Eigen::VectorXd& tau,
                                  Eigen::VectorXd& q, Eigen::VectorXd& v);

}  // namespace coopdyn
