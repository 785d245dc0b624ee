// The interval every reported wrench may take while the Coulomb friction of the joints at rest is
// unknown: the friction bound of an estimate from measured joint torques (estimate mode, `eval`).
//
// A friction joint that moves (|v| > Workspace::rest_speed) has its friction known from the
// measured velocity, -F sign(v), and its damping -b v: evaluate() applies both (the estimate is
// compensated). At rest its friction f_j is anywhere in [-F_j, F_j] as far as a measurement can
// tell (stuck: whatever holds it; about to move: the bound). The estimate reports the value the
// exact stiction solve gives (friction_lcp.h: the friction that keeps the joint at rest when it can,
// which is what the simulator applies), f*_j. Every wrench is affine in the resting joints' friction
// forces, w(f) = w(f*) + sum_j W_j (f_j - f*_j), with W_j the response to a unit torque at resting
// joint j (Workspace::rest_dvdot, rest_dlambda, from the evaluation's own factors). Over the box
// |f_j| <= F_j component c spans w_0,c +- sum_j |W_j,c| F_j about w_0 = w(0), so it departs from
// the reported value by at most
//   bound_c = |sum_j W_j,c f*_j| + sum_j |W_j,c| F_j
// attained at a corner of the box: the half-width of the smallest interval about the reported
// wrench that holds every value the unknown friction allows (at most twice the interval's own
// half-width, which it equals when f* = 0). It is a bound, not a standard
// deviation: reported apart from sigma (wrench_sigma.h), zero when no friction joint is at rest.
// Any formulation; allocation-free after construction; never throws.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/wrenches.h"

namespace coopdyn {

struct FrictionBoundData {
  explicit FrictionBoundData(const System& sys);

  bool possible = false;     // some joint of the scene declares Coulomb friction
  int resting = 0;           // friction joints at rest in the last evaluation (0: every bound zero)
  std::vector<Vec6> bound;   // per output: half-widths [moment; force] in its report frame (N*m, N)

  // scratch
  Eigen::VectorXd dvdot, dlam;                    // (nv), (rows)
  std::vector<Vec6> zero_f, a, acc, R, R0, dF;    // per body (dF: per pass spec)
  std::vector<Transform> X_WF;                    // per output: its report frame
  std::vector<Vec6> col;                          // per output: the response to one resting joint
  std::vector<Vec6> offset;                       // per output: sum_j W_j f*_j
};

// Fills fb.bound and fb.resting for the evaluation in ws (zeros when it failed, when no friction
// joint rests, or when the workspace ignores joint losses).
void compute_friction_bound(const System& sys, const Workspace& ws, FrictionBoundData& fb);

}  // namespace coopdyn
