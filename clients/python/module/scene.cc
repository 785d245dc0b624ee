#include "clients/python/module/scene.h"

#include <pybind11/pybind11.h>

#include "clients/python/module/inputs.h"
#include "service/algorithms/crba.h"
#include "service/algorithms/jacobians.h"
#include "service/algorithms/kinematics.h"

namespace coopdyn::py {

namespace {
std::shared_ptr<const SceneNames> scene_names(const System& sys) {
  auto n = std::make_shared<SceneNames>();
  n->q = sys.model.q_names;
  n->v = sys.model.v_names;
  for (const WrenchOutput& o : sys.wrenches.outputs) n->wrench.push_back(o.name);
  for (const Frame& f : sys.model.frames) n->frame.push_back(f.name);
  for (int k = 0; k < num_stresses(sys); ++k) n->stress.push_back(stress_name(sys, k));
  return n;
}
}  // namespace

const Diagnostics& evaluate_into(const System& sys, EvalBuffers& b, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                                 const Eigen::VectorXd& tau) {
  const Diagnostics& d = evaluate(sys, b.ws, q, v, tau);
  compute_wrenches(sys, b.ws, b.wd);
  compute_wrench_sigma(sys, b.ws, b.sd);
  return d;
}

Scene::Scene(System sys)
    : sys_(std::make_shared<const System>(std::move(sys))),
      names_(scene_names(*sys_)),
      eval_(*sys_),
      kin_(sys_->model) {
  q_ = sys_->q0;
  v_ = sys_->v0;
  tau_ = Eigen::VectorXd::Zero(sys_->model.nv());
}

void Scene::read_state(pybind11::handle q, pybind11::handle v, pybind11::handle tau) {
  q_ = sys_->q0;
  v_ = sys_->v0;
  tau_.setZero();
  read_vector(q, "q", names_->q, "q_names", q_);
  read_vector(v, "v", names_->v, "v_names", v_);
  read_vector(tau, "tau", names_->v, "v_names", tau_);
}

EvalResult Scene::evaluate(bool hold) {
  if (hold) tau_ += holding_torque();
  const System& sys = *sys_;
  const Diagnostics& d = evaluate_into(sys, eval_, q_, v_, tau_);
  EvalResult r;
  r.vdot = eval_.ws.vdot;
  r.W = eval_.wd.W;
  if (eval_.sd.valid) r.sigma = eval_.sd.sigma;
  r.X_WF.resize(sys.wrenches.outputs.size());
  for (size_t k = 0; k < r.X_WF.size(); ++k) r.X_WF[k] = wrench_frame_pose(sys, eval_.ws.data, static_cast<int>(k));
  r.stress = eval_.ws.stress;
  r.diag = d;
  return r;
}

Eigen::VectorXd Scene::holding_torque(bool clamp) {
  if (!hold_) hold_ = std::make_unique<HoldWorkspace>(*sys_, default_actuated(*sys_));
  Eigen::VectorXd th(sys_->model.nv());
  if (!coopdyn::holding_torque(*sys_, *hold_, q_, v_, th))
    throw pybind11::value_error(
        "holding_torque: the state is not valid (a non-unit quaternion, or a singular mass matrix)");
  if (clamp) clamp_to_torque_limits(*sys_, *hold_, th);
  return th;
}

int Scene::frame_index(const std::string& frame) const {
  return index_of(names_->frame, frame, "name", "frame", " (see Scene.frame_names)");
}

void Scene::kinematics() { forward_kinematics(sys_->model, kin_, q_, Eigen::VectorXd::Zero(sys_->model.nv())); }

Transform Scene::frame_pose(const std::string& frame) {
  const int f = frame_index(frame);
  kinematics();
  return coopdyn::frame_pose(sys_->model, kin_, f);
}

Eigen::MatrixXd Scene::jacobian(const std::string& frame) {
  const int f = frame_index(frame);
  kinematics();
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(6, sys_->model.nv());
  frame_jacobian(sys_->model, kin_, f, sys_->model.frame_support(f), J);  // V_WF_F: frame axes
  const Mat3 R = coopdyn::frame_pose(sys_->model, kin_, f).R;
  J.topRows<3>() = R * J.topRows<3>();  // world axes, the frame's origin
  J.bottomRows<3>() = R * J.bottomRows<3>();
  return J;
}

Eigen::MatrixXd Scene::mass_matrix() {
  kinematics();
  crba(sys_->model, kin_);
  return kin_.M;
}

}  // namespace coopdyn::py
