// A System is what a scene compiles to: the tree, its constraints and how to solve them.
// Immutable once built; every workspace is sized from it.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "service/constraints/constraints.h"
#include "service/dynamics/wrench_outputs.h"
#include "service/model/model.h"

namespace coopdyn {

enum class Formulation {
  kMobilePlatform,    // s.3: the load is the floating root, arm bases are tips welded to the world;
                      //      pseudo-joints (if any) are locked by rows of the same solve
  kClassic,           // s.2, (11): world-rooted arms, the load a free body, tips welded to the load
  kPseudoJointSchur,  // s.4, (22)-(26): vdot = D tau_c + E of the unlocked system, then the
                      //      pseudo-joint block eliminated by d4^{-1}
  kSvdBaseline,       // s.6, (19)-(21): per-tip SVD keeps the directions a tip can move in, then an
                      //      SVD pseudo-inverse of the reduced Q
};
const char* formulation_name(Formulation f);
bool parse_formulation(const std::string& s, Formulation* f);

enum class Redundancy {
  kMinNorm,     // indeterminate part of lambda set to zero (the paper's eta = 0, (41)-(42))
  kCompliance,  // minimizes lambda^T C lambda over the indeterminate directions, C the per-row
                // compliances: the elastic (Menabrea) split of a statically indeterminate load
};

struct SolverOptions {
  Formulation formulation = Formulation::kMobilePlatform;
  Redundancy redundancy = Redundancy::kMinNorm;
  // Rank path: a Cholesky with diagonal pivoting stops at the first remaining pivot <= rank_tol * the
  // largest diagonal of Q; a dropped direction has eigenvalue <= (rows - rank) * rank_tol * max Q(i, i)
  // (q_solve.h: what is and is not guaranteed).
  double rank_tol = 1e-10;
  // The Cholesky fast path is taken when every pivot of Q is >= fast_tol * the largest pivot;
  // otherwise the pivoted Cholesky of q_solve.h decides the rank.
  double fast_tol = 1e-8;
  // Projection onto the constraint manifold after every integrator step: Gauss-Newton iterations
  // on the position error, then the velocity projected onto the null space of G (Euclidean metric,
  // rank-safe pseudo-inverse). 0 = off.
  int projection_iterations = 0;
  // Divergence bound (scene key `solver: {max_speed: S}`): after every integrator step each
  // velocity coordinate must satisfy |v_i| <= max_speed (rad/s for joints and platform rotation,
  // m/s for translation); otherwise step() reports Reason::kDiverged and keeps the start state.
  // 1e4 rad/s is ~95,000 rpm (beyond any motor) and 1e4 m/s beyond any vehicle, while a wheel at
  // 200 rad/s stays legal. One pass over v per step, no allocation. inf disables the check (NaN
  // and Inf states are still caught).
  double max_speed = 1e4;
};

struct System {
  std::string name;
  Model model;
  ConstraintSet constraints;  // compiled; includes pseudo-joint locks except in kPseudoJointSchur
  SolverOptions options;
  Eigen::VectorXd q0, v0;     // initial state (satisfies the constraints)
  Eigen::VectorXd tau_limit;  // (nv) |tau| allowed per DOF (commands above are rejected); inf = none,
                              // 0 = unactuated (load platform, floating root, pseudo-joint unless declared)
  // (nv) each 1-DOF joint's limits, by velocity index: position lower and upper (rad or m; URDF
  // <limit lower upper>, a DH link's `limits: [LO, HI]`; the joint's q index is
  // model.bodies[dof_body[d]].joint.idx_q) and speed (rad/s or m/s; URDF <limit velocity>, a DH link's
  // `v_limit`). -inf / +inf = none. Reported when exceeded (joint_limits.h), never enforced.
  Eigen::VectorXd q_lower, q_upper, v_limit;
  WrenchSet wrenches;         // what is reported as wrenches (wrench_outputs.h); compiled
  Eigen::VectorXd tau_noise;  // (nv) standard deviation of each DOF's torque noise, N m or N (scene key
                              // `noise`; 0 = none, on every DOF when the scene declares none):
                              // propagated into each wrench's sigma (wrench_sigma.h)
  // (nv) standard deviation of each measured joint's position (rad or m) and velocity (rad/s or m/s)
  // noise (scene key `noise: {q: S, v: S}`; 0 = none): 1-DOF joints only, the joint's q index is
  // model.bodies[dof_body[d]].joint.idx_q. Propagated in estimate mode by the linearization at the
  // evaluated state (wrench_sigma.h)
  Eigen::VectorXd q_noise, v_noise;
  // A friction joint is at rest when |v| <= rest_speed (rad/s or m/s): its friction is then solved as
  // stiction (friction_lcp.h); faster, it slides with -friction sign(v). Scene key
  // `friction: {rest_speed: S}`, default kDefaultRestSpeed.
  static constexpr double kDefaultRestSpeed = 1e-9;
  double rest_speed = kDefaultRestSpeed;
  // The arms' base links in the mobile-platform form whose joint 1 has no armature: the base link
  // carries a nominal inertia (no mass) only so that M stays regular for joint 1, which moves
  // nothing else; the weld of spec `spec` holds it, so that inertia does no work and the results do
  // not depend on it, but it puts an eigenvalue ~1 / inertia into Q. The condition diagnostic is
  // measured with that direction (G's column of joint 1 in the weld's rows) eliminated.
  struct NominalBase {
    int body = -1;  // the base link (its joint is joint 1 reversed)
    int spec = -1;  // the base weld
  };
  std::vector<NominalBase> nominal_bases;
  std::vector<std::string> warnings;  // what the loader left out or found missing (a URDF link without
                                      // mass, links off the arm's chain); printed by every client
};

}  // namespace coopdyn
