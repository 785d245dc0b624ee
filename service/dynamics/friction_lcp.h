// Coulomb friction at the joints at rest: the box-constrained problem their stiction forces solve.
//
// The constrained accelerations of the resting friction joints are affine in their friction forces
// f (k of them): a = b + A f, with A (k x k) the constrained inverse inertia restricted to them
// (symmetric positive semidefinite) and b their accelerations without friction. Coulomb's law at
// rest is, per joint i with bound F_i > 0:
//   |f_i| < F_i  =>  a_i = 0            (stuck)
//   f_i = +F_i   =>  a_i <= 0           (slides in -, friction opposes it)
//   f_i = -F_i   =>  a_i >= 0           (slides in +)
// which are the optimality conditions of  min 1/2 f^T A f + b^T f  subject to |f_i| <= F_i. An
// active set over the k joints finds it: solve the stuck joints' equations with the sliding ones at
// their bounds, move the joint that most exceeds its bound to it, release a bound joint whose
// acceleration turned against its friction, repeat (at most 4 k + 8 times); the final state is
// checked against the conditions above (converged). When the stuck block of A is singular (a joint
// the constraints lock, whose friction moves nothing; friction joints around a closed loop, which
// hold the loop's internal torques between them) the stuck forces are statically indeterminate:
// the minimum-norm ones are taken and the missing rank counted (indeterminate).
// Sized once; nothing allocates in solve().
#pragma once

#include <vector>

#include <Eigen/Core>

namespace coopdyn {

struct FrictionLcp {
  explicit FrictionLcp(int kmax = 0);
  // inputs: the top-left k x k of A, the first k entries of b and bound
  Eigen::MatrixXd A;      // (kmax x kmax) 1/(kg m^2) or 1/kg
  Eigen::VectorXd b;      // (kmax) rad/s^2 or m/s^2
  Eigen::VectorXd bound;  // (kmax) F_i > 0, N*m or N
  // outputs
  Eigen::VectorXd f;                // (kmax) friction forces
  Eigen::VectorXd a;                // (kmax) b + A f
  std::vector<signed char> state;   // (kmax) 0 stuck, +1 at +F (sliding in -), -1 at -F (sliding in +)
  int indeterminate = 0;            // stuck directions without a pivot (forces set to zero)
  int iterations = 0;
  bool converged = true;            // the final state meets the conditions (to 1e-9 relative)
  // Solves for the first k joints.
  void solve(int k);

 private:
  Eigen::MatrixXd W_;     // (kmax x kmax) factor scratch
  Eigen::VectorXd r_, t_;  // (kmax)
  Eigen::MatrixXd C_;      // (kmax x kmax)
  std::vector<int> idx_;  // (kmax) the stuck joints
  std::vector<int> perm_; // (kmax)
  void solve_stuck(int k);
  bool check(int k, double tol_a) const;
};

}  // namespace coopdyn
