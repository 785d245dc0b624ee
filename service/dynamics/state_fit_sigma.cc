#include "service/dynamics/state_fit_sigma.h"

namespace coopdyn {

FitRefit::FitRefit(const System& sys, const StateFitPlan& plan)
    : sys_(sys), plan_(plan), fws_(sys, plan), start_(sys.q0), v0_(Eigen::VectorXd::Zero(sys.model.nv())),
      dx0_(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(plan.fit_v.size()))), dx_(dx0_),
      dv_(Eigen::VectorXd::Zero(sys.model.nv())), q_try_(sys.q0) {}

void FitRefit::set(const Eigen::VectorXd& q, bool fit_q, bool fit_v) {
  start_ = q;
  fit_q_ = fit_q && plan_.q_fittable;
  fit_v_ = fit_v && plan_.v_fittable;
  if (fit_q_ && !plan_.fit_v.empty()) fit_position_step(sys_, plan_, fws_, start_, v0_, &dx0_);
}

void FitRefit::refit(Eigen::VectorXd& q, Eigen::VectorXd& v, bool q_moved) {
  if (!active()) return;
  if (q_moved && fit_q_) {
    for (int i : plan_.fit_q) q[i] = start_[i];
    fit_position_step(sys_, plan_, fws_, q, v0_, &dx_);
    dv_.setZero();
    for (size_t k = 0; k < plan_.fit_v.size(); ++k) dv_[plan_.fit_v[k]] = dx_[static_cast<Eigen::Index>(k)] - dx0_[static_cast<Eigen::Index>(k)];
    integrate(sys_.model, q, dv_, 1.0, q_try_);
    normalize_configuration(sys_.model, q_try_);
    for (int i : plan_.fit_q) q[i] = q_try_[i];
  }
  if (fit_v_) fit_state(sys_, plan_, fws_, false, true, q, v);
}

void FitRefit::refit_velocity_change(const Eigen::MatrixXd& G, Eigen::VectorXd& dv) {
  if (active() && fit_v_) fit_velocity_change(plan_, fws_, G, dv);
}

}  // namespace coopdyn
