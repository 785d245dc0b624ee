// The state fit inside the measurement-noise linearization of wrench_sigma.h. In estimate mode the
// load's pose and twist are not measured: fit_state() (state_fit.h) finds them from the measured
// joints. A joint position that is off by dq moves the fitted pose with it (and the fitted twist,
// through G(q)); the wrenches feel both. With a FitRefit set on WrenchSigmaData::refit, each
// position (velocity) column of the linearization refits the omitted coordinates at the perturbed
// measurement, as the daemon does with a measured state, instead of holding them: sigma is then
// the spread of what the estimator reports when the joints' measurements are noisy.
//
// The refit is the fit's first-order response: the pose moves by the change of one Gauss-Newton
// step (fit_position_step) between the moved and the evaluated measurement, -(G_u^T G_u)^+ G_u^T
// G_a dq_a to first order (exact in the linearization, free of the iterative fit's tolerance, which
// a 1e-7 step would amplify); the twist is refitted exactly (the velocity fit is a linear solve) at
// the moved state. A velocity column's twist change is the fit of the velocity change itself
// (fit_velocity_change, from the evaluation's constraint Jacobian). In a workspace of its own (the daemon's warm start is not touched).
// Allocation-free after construction; never throws.
#pragma once

#include <Eigen/Core>

#include "service/dynamics/state_fit.h"
#include "service/dynamics/wrench_sigma.h"

namespace coopdyn {

class FitRefit final : public StateRefit {
 public:
  FitRefit(const System& sys, const StateFitPlan& plan);
  // The evaluated state (q after fit_state()) and what was fitted in it (fit_state's fit_q, fit_v).
  void set(const Eigen::VectorXd& q, bool fit_q, bool fit_v);  // one position step when fit_q
  // Something was fitted: refit() changes a state.
  bool active() const { return (fit_q_ || fit_v_) && !plan_.fit_v.empty(); }
  // a moved position refits the pose (and the twist at it), a moved velocity the twist only
  void refit(Eigen::VectorXd& q, Eigen::VectorXd& v, bool q_moved) override;
  // the twist's change for a change of the measured velocities (fit_velocity_change)
  void refit_velocity_change(const Eigen::MatrixXd& G, Eigen::VectorXd& dv) override;

 private:
  const System& sys_;
  const StateFitPlan& plan_;
  StateFitWorkspace fws_;
  Eigen::VectorXd start_;  // (nq) the evaluated state
  Eigen::VectorXd v0_;     // (nv) scratch: the velocity the position steps are taken at
  Eigen::VectorXd dx0_, dx_;  // (n_fit) the position step at the evaluated state, at the moved one
  Eigen::VectorXd dv_, q_try_;  // (nv), (nq)
  bool fit_q_ = false, fit_v_ = false;
};

}  // namespace coopdyn
