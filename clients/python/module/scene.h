// The Python Scene: a loaded System with the buffers of its single-state calls, and the result of
// one evaluation. Every number comes from the library functions `coopdyn eval` and `coopdyn sim`
// call (evaluate, compute_wrenches, compute_wrench_sigma, wrench_frame_pose, step), in the same
// order, so the bindings give the same doubles as the command line.
#pragma once

#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/holding_torque.h"
#include "service/dynamics/system.h"
#include "service/dynamics/sigma/wrench_sigma.h"
#include "service/dynamics/wrenches.h"

namespace coopdyn::py {

// What one evaluation gives, copied out of the workspace: wrenches [moment; force] in each output's
// report frame (N*m, N), that frame's pose in the world, each wrench's sigma (with declared noise),
// the stresses, the diagnostics.
struct EvalResult {
  Eigen::VectorXd vdot;
  std::vector<Vec6> W, sigma;  // sigma empty when the scene declares no noise (or the evaluation failed)
  std::vector<Transform> X_WF;
  Eigen::VectorXd stress;
  Diagnostics diag;
};

// The names a scene reports under (shared by the scene and its results).
struct SceneNames {
  std::vector<std::string> q, v, wrench, frame, stress;
};

// The buffers of one evaluation (sized once; evaluate_into allocates nothing).
struct EvalBuffers {
  explicit EvalBuffers(const System& sys) : ws(sys), wd(sys), sd(sys) {}
  Workspace ws;
  WrenchData wd;
  WrenchSigmaData sd;
};

// evaluate, then the wrenches and their sigma, as `coopdyn eval` does. Never throws.
const Diagnostics& evaluate_into(const System& sys, EvalBuffers& b, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                                 const Eigen::VectorXd& tau);

class Scene {
 public:
  explicit Scene(System sys);
  const System& sys() const { return *sys_; }
  const std::shared_ptr<const SceneNames>& names() const { return names_; }

  // The state arguments (array or dict; None: q0, v0, zero torque) into q_, v_, tau_.
  void read_state(pybind11::handle q, pybind11::handle v, pybind11::handle tau);
  // The evaluation at read_state's state (hold: plus the holding torques, as `coopdyn eval --hold`).
  EvalResult evaluate(bool hold);
  // The holding torques at (q, v) clamped to the torque limits (coopdynd's safe torque `hold`).
  Eigen::VectorXd holding_torque(bool clamp = true);  // clamp: to the torque limits (else as solved)
  Transform frame_pose(const std::string& frame);      // at q_
  Eigen::MatrixXd jacobian(const std::string& frame);  // at q_: 6 x nv, world axes, [angular; linear]
  Eigen::MatrixXd mass_matrix();                       // at q_

  Eigen::VectorXd q_, v_, tau_;

 private:
  int frame_index(const std::string& frame) const;
  void kinematics();  // forward kinematics at (q_, 0) into kin_

  std::shared_ptr<const System> sys_;
  std::shared_ptr<const SceneNames> names_;
  EvalBuffers eval_;
  std::unique_ptr<HoldWorkspace> hold_;  // made at the first call that needs it
  Data kin_;
};

}  // namespace coopdyn::py
