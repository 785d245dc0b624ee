#include "service/dynamics/sigma/state_fit_sigma.h"

#include <stdexcept>
#include <string>
#include <vector>

namespace coopdyn {

namespace {

// The sigma reads row k of the fit's response as the k-th floating-joint DOF in model order
// (WrenchSigmaData::float_dofs): the plan must fit exactly those, in that order (plan_state_fit does).
const StateFitPlan& checked(const System& sys, const StateFitPlan& plan) {
  std::vector<int> q, v;
  for (const Body& b : sys.model.bodies)
    if (b.joint.type == JointType::kFloating) {
      for (int k = 0; k < b.joint.nq; ++k) q.push_back(b.joint.idx_q + k);
      for (int k = 0; k < b.joint.nv; ++k) v.push_back(b.joint.idx_v + k);
    }
  if (plan.fit_q != q || plan.fit_v != v)
    throw std::invalid_argument("scene '" + sys.name + "': the state fit's plan fits " + std::to_string(plan.fit_v.size()) +
                                " velocity coordinates that are not the " + std::to_string(v.size()) +
                                " of its floating joints in model order: the sigma's refit needs exactly those");
  return plan;
}

}  // namespace

FitRefit::FitRefit(const System& sys, const StateFitPlan& plan)
    : sys_(sys), plan_(checked(sys, plan)), fws_(sys, plan), start_(sys.q0), v0_(Eigen::VectorXd::Zero(sys.model.nv())),
      dx0_(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(plan.fit_v.size()))), dx_(dx0_),
      dv_(Eigen::VectorXd::Zero(sys.model.nv())), q_try_(sys.q0) {
  const Eigen::Index nu = static_cast<Eigen::Index>(plan.fit_v.size()), nv = sys.model.nv();
  response_.Kq.setZero(nu, nv);
  response_.Kv.setZero(nu, nv);
  response_.Pv.setZero(nu, sys.constraints.rows);
}

void FitRefit::set(const Eigen::VectorXd& q, bool fit_q, bool fit_v) {
  start_ = q;
  fit_q_ = fit_q && plan_.q_fittable;
  fit_v_ = fit_v && plan_.v_fittable;
  have_dx0_ = false;
}

void FitRefit::refit(Eigen::VectorXd& q, Eigen::VectorXd& v) {
  if (!active()) return;
  if (fit_q_) {
    if (!have_dx0_) fit_position_step(sys_, plan_, fws_, start_, v0_, &dx0_);
    have_dx0_ = true;
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

const FitResponse* FitRefit::linearize(const Eigen::MatrixXd& G) {
  if (!active()) return nullptr;
  fit_operators(plan_, fws_, G, fit_q_, fit_v_);
  response_.positions = fit_q_;
  response_.velocities = fit_v_;
  if (fit_q_) response_.Kq.noalias() = -fws_.Pq * G;
  if (fit_v_) {
    response_.Kv.noalias() = -fws_.Pv * G;
    response_.Pv = fws_.Pv;
  }
  for (size_t k = 0; k < plan_.fit_v.size(); ++k) {  // a fitted coordinate is not a measured one
    response_.Kq.col(plan_.fit_v[k]).setZero();
    response_.Kv.col(plan_.fit_v[k]).setZero();
  }
  return &response_;
}

}  // namespace coopdyn
