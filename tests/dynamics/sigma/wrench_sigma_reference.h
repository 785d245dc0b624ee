// The definition of each wrench's sigma before its fast path: the reference the fast path is
// tested against (same arguments and results as compute_wrench_sigma of wrench_sigma.h).
#pragma once

#include "service/dynamics/sigma/wrench_sigma.h"

namespace coopdyn::reference {

// The velocity columns' step (rad/s, m/s): central differences of this step (default 1e-2), or
// the forward differences of 1e-7 the fast path used before its tangents when <= 0.
extern double velocity_step;
// The position columns' step (rad, m): when > 0 (default 1e-3), five-point central differences of
// this step for the columns the fast path takes as tangents (WrenchSigmaData::qt_tangent, no
// refit) and the forward differences of 1e-7 for the others, as the fast path; when <= 0, forward
// differences of 1e-7 for every column, the fast path's before its tangents.
extern double position_step;

// One of the steps above set for a scope, the previous value put back when it ends (an ASSERT's
// early return included), so that no test leaves another its step.
class ScopedStep {
 public:
  ScopedStep(double& step, double value) : step_(step), saved_(step) { step = value; }
  ~ScopedStep() { step_ = saved_; }
  ScopedStep(const ScopedStep&) = delete;
  ScopedStep& operator=(const ScopedStep&) = delete;

 private:
  double& step_;
  double saved_;
};

void compute_wrench_sigma(const System& sys, Workspace& ws, WrenchSigmaData& sd);
void compute_wrench_sigma(const System& sys, Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& q,
                          const Eigen::VectorXd& v, const Eigen::VectorXd& tau);

// A test state near the scene's initial one, the same draw for the same seed: v = v0 + 0.3 U(-1, 1),
// tau = 2 U(-1, 1) on every DOF.
void random_v_tau(const System& sys, unsigned seed, Eigen::VectorXd& v, Eigen::VectorXd& tau);

}  // namespace coopdyn::reference
