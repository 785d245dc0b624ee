#include "clients/control/cooperative_controller.h"

#include <cmath>
#include <stdexcept>

#include <Eigen/QR>

#include "service/algorithms/kinematics.h"
#include "service/dynamics/holding_torque.h"

namespace coopdyn::cli {

CooperativeController::CooperativeController(const System& sys, const TrackOptions& opt)
    : sys_(sys), opt_(opt), ws_(sys), wd_(sys) {
  const Model& m = sys.model;
  int load_body = -1;
  for (int b = 0; b < m.nbodies(); ++b)
    if (m.bodies[b].joint.type == JointType::kFloating) {
      if (load_body >= 0) throw std::runtime_error("coopdyn track: the scene has more than one floating body");
      load_body = b;
      iq_ = m.bodies[b].joint.idx_q;
      iv_ = m.bodies[b].joint.idx_v;
    }
  if (load_body < 0) throw std::runtime_error("coopdyn track: the scene has no floating load");
  int n_ee = 0;
  for (size_t i = 0; i < sys.wrenches.outputs.size(); ++i)
    if (sys.wrenches.outputs[i].kind == WrenchKind::kEndEffector) {
      if (n_ee < 2) ee_[n_ee] = static_cast<int>(i);
      ++n_ee;
    }
  if (n_ee != 2) throw std::runtime_error("coopdyn track: the scene must have two end-effectors (it has " + std::to_string(n_ee) + ")");
  const std::vector<unsigned char> a = default_actuated(sys);
  for (int i = 0; i < m.nv(); ++i)
    if (a[i]) act_.push_back(i);
  if (act_.size() < 7) throw std::runtime_error("coopdyn track: fewer than 7 actuated joints cannot set 6 load accelerations and a squeeze");
  w_.setOnes(static_cast<Eigen::Index>(act_.size()));
  for (size_t c = 0; c < act_.size(); ++c)
    if (std::isfinite(sys.tau_limit[act_[c]])) w_[static_cast<Eigen::Index>(c)] = sys.tau_limit[act_[c]];
  forward_kinematics(m, ws_.data, sys.q0, sys.v0);
  p0_ = ws_.data.X_WB[load_body].p;
  R0_ = ws_.data.X_WB[load_body].R;
  tau_.setZero(m.nv());
  tau_probe_.setZero(m.nv());
  K_.setZero(7, static_cast<Eigen::Index>(act_.size()));
  rhs_.setZero(7);
  opt_.axis_a.normalize();
  opt_.axis_b.normalize();
}

CooperativeController::~CooperativeController() = default;

void CooperativeController::reference(double t, Vec3* p, Vec3* pd, Vec3* pdd) const {
  // p = p0 + r g(t) (sin(wt) a + (1 - cos(wt)) b), g a C2 smoothstep from 0 to 1 over `ramp`
  const double w = 2 * M_PI / opt_.period;
  double g = 1, gd = 0, gdd = 0;
  if (opt_.ramp > 0 && t < opt_.ramp) {
    const double x = std::max(0.0, t) / opt_.ramp;
    g = x * x * x * (10 - 15 * x + 6 * x * x);
    gd = 30 * x * x * (1 - x) * (1 - x) / opt_.ramp;
    gdd = 60 * x * (1 - x) * (1 - 2 * x) / (opt_.ramp * opt_.ramp);
  }
  const Vec3 f = std::sin(w * t) * opt_.axis_a + (1 - std::cos(w * t)) * opt_.axis_b;
  const Vec3 fd = w * (std::cos(w * t) * opt_.axis_a + std::sin(w * t) * opt_.axis_b);
  const Vec3 fdd = w * w * (-std::sin(w * t) * opt_.axis_a + std::cos(w * t) * opt_.axis_b);
  *p = p0_ + opt_.radius * g * f;
  *pd = opt_.radius * (gd * f + g * fd);
  *pdd = opt_.radius * (gdd * f + 2 * gd * fd + g * fdd);
}

namespace {
// s = (f1 - f2).u / 2 from the end-effector wrenches W_k ([m; f] of the load on end-effector k, in
// frame E_k) and the poses of the end-effector frames
double squeeze_from(const Transform& X_WE1, const Transform& X_WE2, const Vec3& f_ee1, const Vec3& f_ee2) {
  const Vec3 f1 = -(X_WE1.R * f_ee1), f2 = -(X_WE2.R * f_ee2);  // the arms' forces on the load, world
  Vec3 u = X_WE2.p - X_WE1.p;
  const double n = u.norm();
  if (!(n > 0)) return 0.0;
  u /= n;
  return 0.5 * (f1 - f2).dot(u);
}
Transform ee_pose(const System& sys, const Data& data, const WrenchOutput& o) {
  return o.frame_body >= 0 ? data.X_WB[o.frame_body] * o.X_BF : o.X_BF;
}
}  // namespace

double CooperativeController::squeeze_of(const Workspace& ws, const WrenchData& wd) const {
  const WrenchOutput &o1 = sys_.wrenches.outputs[ee_[0]], &o2 = sys_.wrenches.outputs[ee_[1]];
  return squeeze_from(ee_pose(sys_, ws.data, o1), ee_pose(sys_, ws.data, o2), wd.W[ee_[0]].tail<3>(), wd.W[ee_[1]].tail<3>());
}

double CooperativeController::squeeze(const Eigen::VectorXd& q, const std::array<double, 6>& ee1, const std::array<double, 6>& ee2) {
  forward_kinematics(sys_.model, ws_.data, q, Eigen::VectorXd::Zero(sys_.model.nv()));
  const WrenchOutput &o1 = sys_.wrenches.outputs[ee_[0]], &o2 = sys_.wrenches.outputs[ee_[1]];
  return squeeze_from(ee_pose(sys_, ws_.data, o1), ee_pose(sys_, ws_.data, o2), Vec3(ee1[3], ee1[4], ee1[5]),
                      Vec3(ee2[3], ee2[4], ee2[5]));
}

const Eigen::VectorXd& CooperativeController::compute(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                                                       double s_measured, double dt) {
  const int na = static_cast<int>(act_.size());
  // 1. the affine maps tau -> (load acceleration, squeeze), exact from 1 + na evaluations
  tau_probe_.setZero();
  const Diagnostics& d0 = evaluate(sys_, ws_, q, v, tau_probe_);
  if (d0.status == Status::kError) {
    tau_.setZero();
    return tau_;
  }
  compute_wrenches(sys_, ws_, wd_);
  const Vec6 b = ws_.vdot.segment<6>(iv_);
  const double dsq = squeeze_of(ws_, wd_);
  // the load's pose and twist (body frame [w; v]) at this state
  const int load_body = sys_.model.dof_body[iv_];
  const Mat3 R = ws_.data.X_WB[load_body].R;
  p_ = ws_.data.X_WB[load_body].p;
  const Vec3 w_B = v.segment<3>(iv_), v_B = v.segment<3>(iv_ + 3);
  for (int c = 0; c < na; ++c) {
    tau_probe_.setZero();
    tau_probe_[act_[c]] = w_[c];  // one unit of the weighted variable
    evaluate(sys_, ws_, q, v, tau_probe_);
    compute_wrenches(sys_, ws_, wd_);
    K_.block<6, 1>(0, c) = ws_.vdot.segment<6>(iv_) - b;
    K_(6, c) = squeeze_of(ws_, wd_) - dsq;
  }
  // 2. the desired load acceleration
  Vec3 pr, prd, prdd;
  reference(t, &pr, &prd, &prdd);
  const Vec3 pd = R * v_B;
  const Vec3 p_dd = prdd + opt_.kp * (pr - p_) + opt_.kd * (prd - pd);
  const Vec3 e_R = log_so3(R.transpose() * R0_);
  Vec6 a_d;
  a_d.head<3>() = opt_.kp * e_R - opt_.kd * w_B;
  a_d.tail<3>() = R.transpose() * p_dd - w_B.cross(v_B);
  pos_err_ = (pr - p_).norm();
  rot_err_ = e_R.norm();
  // 3. the squeeze target: the ramped set-point plus the integral of the measured error
  double g = 1;
  if (opt_.ramp > 0 && t < opt_.ramp) {
    const double x = std::max(0.0, t) / opt_.ramp;
    g = x * x * x * (10 - 15 * x + 6 * x * x);
  }
  const double s_set = g * opt_.squeeze;
  // s_measured NaN: this state was not reached under our torques (the daemon held it with its safe
  // torque after a stall): no integration then, and the integral bounded (anti-windup)
  if (std::isfinite(s_measured) && dt > 0) {
    s_int_ += opt_.ki_squeeze * (s_set - s_measured) * dt;
    s_int_ = std::max(-opt_.max_squeeze_correction, std::min(opt_.max_squeeze_correction, s_int_));
  }
  s_target_ = s_set + s_int_;
  // 4. least squares in fractions of the limits, clamped
  rhs_.head<6>() = a_d - b;
  rhs_[6] = s_target_ - dsq;
  const Eigen::VectorXd x = K_.completeOrthogonalDecomposition().solve(rhs_);
  tau_.setZero();
  saturated_ = false;
  for (int c = 0; c < na; ++c) {
    double tc = w_[c] * x[c];
    const double lim = sys_.tau_limit[act_[c]];
    if (std::isfinite(lim) && std::abs(tc) > lim) {
      tc = std::copysign(lim, tc);
      saturated_ = true;
    }
    tau_[act_[c]] = tc;
  }
  return tau_;
}

}  // namespace coopdyn::cli
