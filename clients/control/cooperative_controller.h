// A reference controller for cooperating arms carrying one load (coopdyn track): object-level
// computed torque with internal-force (squeeze) regulation, on the daemon's own model.
//
// The law, at the state (q, v) the daemon published:
//   1. The constrained dynamics are affine in the joint torques: the load's acceleration
//      vdot_L = A tau + b and the squeeze s = c^T tau + d (A, b, c, d from 1 + n_a evaluations of
//      the scene at (q, v): exact, since evaluate() is affine in tau).
//   2. The desired load acceleration (body frame, as the load's v): a PD law on the pose error to
//      the reference (a circle in a vertical plane, ramped in smoothly) with the reference's
//      acceleration fed forward,
//        p_dd = p_ref_dd + kp (p_ref - p) + kd (p_ref_d - p_d),   w_d = kp log(R^T R_ref) - kd w,
//      taken into the body frame (vdot_lin = R^T p_dd - w x v_B).
//   3. The squeeze target: the set-point (ramped in over the same time) plus an integral of the
//      squeeze the daemon measured (its end-effector wrenches), which corrects what the model misses
//      (the one-tick delay of a command).
//   4. tau: the least-squares solution of [A; c^T] tau = [vdot_d - b; s_target - d] in fractions of
//      each joint's torque limit (the strong joints carry more), clamped to the limits.
// The squeeze is the internal force between the grasps: with f_k the force arm k exerts on the load
// (the negative of the load's wrench on its end-effector) and u the unit vector from grasp 1 to
// grasp 2, s = (f1 - f2).u / 2, positive when the arms press the load between them (as
// docs/plot_squeeze.py). Needs a scene with one floating load and two end-effector outputs.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/wrenches.h"

namespace coopdyn::cli {

struct TrackOptions {
  double radius = 0.05;         // m: the reference circle
  double period = 4.0;          // s: one lap
  Vec3 axis_a = Vec3::UnitY();  // the circle's plane (world): p = p0 + r (sin(wt) a + (1 - cos(wt)) b)
  Vec3 axis_b = Vec3::UnitZ();
  double ramp = 1.0;            // s: radius and squeeze grow smoothly from 0 over this time
  double squeeze = 20.0;        // N: the internal force set-point
  double kp = 400.0;            // 1/s^2 (translation and rotation): 20 rad/s, critically damped with
  double kd = 40.0;             // 1/s
  double ki_squeeze = 10.0;     // 1/s: integral gain on the measured squeeze
  double max_squeeze_correction = 20.0;  // N: bound of that integral
};

class CooperativeController {
 public:
  // Throws std::runtime_error when the scene is not one load carried by two arms.
  CooperativeController(const System& sys, const TrackOptions& opt);
  ~CooperativeController();

  // The reference position of the load at time t (s since the controller started) and its first
  // two derivatives.
  void reference(double t, Vec3* p, Vec3* pd, Vec3* pdd) const;
  // The squeeze at (q) with the end-effector wrenches ee1, ee2 ([m; f] in the end-effector frames, as
  // output_t publishes them).
  double squeeze(const Eigen::VectorXd& q, const std::array<double, 6>& ee1, const std::array<double, 6>& ee2);
  // Torques for the state (q, v) at controller time t. s_measured: the squeeze the daemon reported
  // at this state (NaN: none, or the state was not reached under this controller's torques: the
  // integral is not updated); dt: the time since the last call.
  const Eigen::VectorXd& compute(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& v, double s_measured, double dt);

  // after compute(): the pose error (m, rad), the squeeze target (N), whether a torque was clamped
  double position_error() const { return pos_err_; }
  double orientation_error() const { return rot_err_; }
  double squeeze_target() const { return s_target_; }
  bool saturated() const { return saturated_; }
  const Vec3& load_position() const { return p_; }
  int ee_output(int k) const { return ee_[k]; }  // index of arm k's end-effector among the wrench outputs

 private:
  double squeeze_of(const Workspace& ws, const WrenchData& wd) const;
  const System& sys_;
  TrackOptions opt_;
  int iq_ = -1, iv_ = -1;       // the load's first q and v index
  int ee_[2] = {-1, -1};        // wrench outputs of the two end-effectors
  std::vector<int> act_;        // actuated DOFs
  Eigen::VectorXd w_;           // their torque limits (weights; 1 without one)
  Vec3 p0_;
  Mat3 R0_;
  Workspace ws_;
  WrenchData wd_;
  Eigen::VectorXd tau_, tau_probe_;
  Eigen::MatrixXd K_;           // (7 x na) [A; c^T] W
  Eigen::VectorXd rhs_;
  double s_int_ = 0, pos_err_ = 0, rot_err_ = 0, s_target_ = 0;
  bool saturated_ = false;
  Vec3 p_ = Vec3::Zero();
};

}  // namespace coopdyn::cli
