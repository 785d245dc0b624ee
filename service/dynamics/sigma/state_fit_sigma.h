// The state fit inside the measurement-noise linearization of wrench_sigma.h. In estimate mode the
// load's pose and twist are not measured: fit_state() (state_fit.h) finds them from the measured
// joints. A joint position that is off by dq moves the fitted pose with it (and the fitted twist,
// through G(q)); the wrenches feel both. With a FitRefit set on WrenchSigmaData::refit, each
// position (velocity) column of the linearization carries the fitted coordinates' response to the
// measured coordinate, as the daemon refits them from a measured state, instead of holding them:
// sigma is then the spread of what the estimator reports when the joints' measurements are noisy.
//
// The response is the fit's first-order one, from one factorization of each least squares at the
// evaluated state (fit_operators of state_fit.h, every column at once): a measured position change
// dq moves the fitted pose by the tangent step -(G_u^T G_u)^+ G_u^T G_h dq over the holonomic rows
// (FitResponse::Kq), a measured velocity change the fitted twist by -(G_u^T G_u)^+ G_u^T G dv
// (Kv, the velocity fit being linear), and a change c of G v at fixed v (the configuration moved)
// the fitted twist by -Pv c. Where a column is still a difference (wrench_sigma.cc), refit() moves
// the pose by the change of one Gauss-Newton step (fit_position_step) between the moved and the
// evaluated measurement (the same first order, free of the iterative fit's tolerance, which a 1e-7
// step would amplify) and refits the twist at the moved state. In a workspace of its own (the
// daemon's warm start is not touched). The constructor allocates, and throws std::invalid_argument
// naming the scene when the plan does not fit exactly the floating joints' coordinates in model
// order (what the sigma's columns assume; plan_state_fit's plan does); after it: allocation-free,
// never throws.
#pragma once

#include <Eigen/Core>

#include "service/dynamics/state_fit.h"
#include "service/dynamics/sigma/wrench_sigma.h"

namespace coopdyn {

class FitRefit final : public StateRefit {
 public:
  FitRefit(const System& sys, const StateFitPlan& plan);
  // The evaluated state (q after fit_state()) and what was fitted in it (fit_state's fit_q, fit_v).
  void set(const Eigen::VectorXd& q, bool fit_q, bool fit_v);
  // Something was fitted: refit() changes a state.
  bool active() const { return (fit_q_ || fit_v_) && !plan_.fit_v.empty(); }
  // a moved position refits the pose (and the twist at it)
  void refit(Eigen::VectorXd& q, Eigen::VectorXd& v) override;
  // Kq, Kv, Pv at the evaluated state (fit_operators)
  const FitResponse* linearize(const Eigen::MatrixXd& G) override;

 private:
  const System& sys_;
  const StateFitPlan& plan_;
  StateFitWorkspace fws_;
  FitResponse response_;
  Eigen::VectorXd start_;  // (nq) the evaluated state
  Eigen::VectorXd v0_;     // (nv) scratch: the velocity the position steps are taken at
  Eigen::VectorXd dx0_, dx_;  // (n_fit) the position step at the evaluated state, at the moved one
  Eigen::VectorXd dv_, q_try_;  // (nv), (nq)
  bool fit_q_ = false, fit_v_ = false;
  bool have_dx0_ = false;  // dx0_ is the step at start_ (taken at the first refit() after set())
};

}  // namespace coopdyn
