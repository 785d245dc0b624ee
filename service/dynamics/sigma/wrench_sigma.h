// The uncertainty of every reported wrench (wrench_outputs.h) from declared noise (scene key `noise`):
// the joint torques (System::tau_noise) and, in estimate mode, the measured joint positions and
// velocities (System::q_noise, v_noise). Call after evaluate() on the same workspace (it reads the
// evaluation's factors; the solves use this data's scratch, not the workspace's results).
//
// Contract: sigma[k] is the standard deviation of each component of wrench k (same frame and order),
// exact for torque noise, linearized at the evaluated state for measurement noise (exact tangents,
// or a forward difference with h = 1e-7 where a contact or Baumgarte feedback is in the subtree); a
// load fitted from the joints is held unless WrenchSigmaData::refit is set (state_fit_sigma.h).
// Indeterminate components report the spread of the value the redundancy rule selects; Coulomb
// friction at rest is left free (its bound: friction_bound.h). The derivation: docs/method.md,
// "The uncertainty of the wrenches". From kArmsMin arms on (simulate mode) torque noise takes the arm
// form of wrench_sigma_arms.h, whose C is filled only where keep_C is set.
//
// Supported formulations: mobile_platform and classic (every shipped scene). pseudo_joint and svd,
// a failed evaluation, or a scene without noise: valid = false and sigma zero. Allocation-free
// after construction; never throws.
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/wrenches.h"

namespace coopdyn {

// Estimate mode: the coordinates of a measured state that were fitted from the others (state_fit.h),
// their first-order response to the measured ones, and a refit at a perturbed measurement
// (state_fit_sigma.h).
// The fitted coordinates are the floating joints' (plan_state_fit), n_fit = their DOFs, in the
// model's order (WrenchSigmaData::float_dofs).
struct FitResponse {
  bool positions = false, velocities = false;  // what the evaluated state had fitted
  Eigen::MatrixXd Kq;  // (n_fit x nv) positions: the fitted coordinates' tangent change per unit
                       // change of each measured position (zero columns at the fitted DOFs)
  Eigen::MatrixXd Kv;  // (n_fit x nv) velocities: the fitted velocities' change per unit change of
                       // each measured velocity (zero columns at the fitted DOFs)
  Eigen::MatrixXd Pv;  // (n_fit x rows) velocities: the fitted velocities change by -Pv c for a change
                       // c of the constraint rows' velocity G v (a position change at fixed v)
};
struct StateRefit {
  virtual ~StateRefit() = default;
  // (q, v): the evaluated state with one measured position moved; sets the fitted coordinates
  // from it (the columns that are differences)
  virtual void refit(Eigen::VectorXd& q, Eigen::VectorXd& v) = 0;
  // The response at the evaluated state, G (rows x nv) its constraint rows' Jacobian there;
  // nullptr when nothing was fitted
  virtual const FitResponse* linearize(const Eigen::MatrixXd& G) = 0;
};

// The scene declares noise (torque, or joint position or velocity) on some DOF and its formulation
// propagates it (mobile_platform, classic): the outputs carry sigma.
bool wrench_sigma_supported(const System& sys);

// The arm form of the torque noise's sigma (wrench_sigma_arms.h): the structure, found at
// construction, and its scratch.
struct SigmaArms {
  using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  using Mat6X = Eigen::Matrix<double, 6, Eigen::Dynamic>;
  static constexpr int kMaxPack = 16;  // the most noisy torques of one arm the form takes
  bool usable = false;      // the structure holds (every noisy torque and every output on one arm)
  int count = 0;            // arms with noisy torques
  int pack = 0;             // the packed torque columns: the most noisy torques of one arm
  std::vector<int> common;  // the common DOFs (every spec reaches them), at most 6
  std::vector<int> j0, nj;  // per arm: its noisy torques are the columns j0 .. j0 + nj - 1
  std::vector<int> out_arm; // per output: its arm
  // scratch
  RowMat Cf;                // (6 outputs x (pack + common)) each output's response to the packed
                            // torques, then to a unit force on each common DOF
  Mat6X c, chat, ctot;      // (6 x na) c_j, (6 x na) the other arms' sum at j's slot, (6 x pack)
  std::vector<Mat6> S_arm, S_other;  // per arm: sum of c_j c_j^T over its columns, over the others'
  // per arm: B = [-chat (own columns) | L_o], L_o L_o^T = S_other (lower); an output's row r of
  // [P - V chat | V L_o] is its row of P (zeros after) plus V_r B, one row of nh + 6 entries
  using BMat = Eigen::Matrix<double, 6, kMaxPack + 6, Eigen::RowMajor>;
  std::vector<BMat> B;
  std::vector<Vec6> d_other;       // per arm: sqrt(diag(S_other)) (the quadratic form's error bound)
  std::vector<char> chol_other;    // per arm: S_other positive definite (else the others by columns)
  Mat6 VLinv;               // the common DOFs' acceleration per unit force on them, inverted
  int guarded = 0;          // outputs whose sigma the last compute took column by column (guard)
  double guard = 1e-12;     // the quadratic form's error bound allowed, relative to an output's
                            // largest sigma (tests: 0 takes every output's other arms by columns)
};

struct WrenchSigmaData {
  using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  // what a sigma contains (bits, output_t SIGMA_*)
  static constexpr int kTau = 1, kQ = 2, kV = 4;

  explicit WrenchSigmaData(const System& sys);

  bool declared = false;  // wrench_sigma_supported(sys)
  bool valid = false;     // the last compute_wrench_sigma() filled sigma
  int source = 0;         // kTau | kQ | kV: the noise the last sigma contains (0 when not valid)
  std::vector<int> dofs;  // (na) the velocity indices with torque noise > 0
  Eigen::VectorXd S;      // (na) their standard deviations (N m or N)
  std::vector<int> q_dofs, v_dofs;  // velocity indices of the joints with position / velocity noise
  std::vector<int> q_index;         // (q_dofs) their q indices
  Eigen::VectorXd Sq, Sv;           // their standard deviations (rad or m; rad/s or m/s)
  int ncols = 0;                    // columns of C the last compute filled
  std::vector<Vec6> sigma;  // per output: standard deviation of each component [moment; force] in
                            // the output's report frame (N m, N)
  // C(6 k + c, j): component c of output k per one standard deviation of noise source j: the torque
  // of dofs[j] (j < na), then the position of q_dofs (estimate mode), then the velocity of v_dofs
  // (the square root of the covariance: cov_k = C_k C_k^T over the first ncols columns)
  RowMat C;  // (6 outputs x (na + nq + nv)); filled unless the arm form ran without keep_C (c_filled)

  // The arm form (wrench_sigma_arms.h), torque noise only: from arms_min arms on where the joints
  // fall into arms coupled through the load's DOFs only. keep_C: fill C there too (O(arms^2) 6 x 6
  // products; nothing in the service reads C, tests do).
  static constexpr int kArmsMin = 5;
  int arms_min = kArmsMin;  // a large value: never
  bool keep_C = false;
  bool c_filled = false;   // the last compute filled C
  bool arms_used = false;  // the last compute took the arm form
  SigmaArms arm;
  RowMat Cd;  // (6 outputs x (nq + nv)) the wrenches' own change at fixed vdot, lambda (scratch)

  // scratch (columns: every noise source; X0, Gm and Cd then 2 nf more with measurement noise:
  // the floating joints' position tangents, then their velocity tangents, per unit, for a refit)
  RowMat X, X0, Lam, Lam_prev, Rhs, Gm;  // (nv), (nv), (rows), (rows), (rows), (rows) x columns
  RowMat A, Rb, Acc;                     // (6 bodies x columns): accelerations, reactions, subtree sums
  RowMat dF;                             // (6 pass specs x columns)
  Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor> Tmp, Tmp2;  // (6 x columns)
  std::vector<RigidInertia> I_lin, I_fix;  // per body: the reaction's inertia on its acceleration
  std::vector<Mat6> T_spec;              // per spec: world force at p_ref per unit of each row
  Eigen::VectorXd unit, col_b, col_x;    // (rows)
  std::vector<int> qrow;                 // (rows) the block Q solve with the nominal rows last: the
                                         // row of Lam holding each dropped (nominal) row
  std::vector<Transform> X_WF;           // per output: its report frame

  // The reactions by composite inertias, where that takes fewer multiply-adds a column than the
  // pass over the bodies (composite, chosen at construction): the reaction at body b is linear in
  // the DOFs' accelerations X_d, sum over d on b's path of (Ic_b [+ I_fix_b]) S_d X_d plus over d
  // strictly below b of Ic_body(d) S_d X_d (Ic: a subtree's inertia, world, at p_ref), then its
  // specs' forces and its frame as in the pass: no body accelerations, one small product per output.
  bool composite = false;
  std::vector<std::vector<int>> out_up, out_down;        // per output: the DOFs on its body's path, below it
  std::vector<RigidInertia> Ic;                          // per body of the pass: its subtree's inertia
  Eigen::Matrix<double, 6, Eigen::Dynamic> F_dof;        // (6 x nv) Ic_body(d) S_d
  std::vector<Eigen::Matrix<double, 6, Eigen::Dynamic>> U;  // per output: (6 x out_up) (Ic_b [+ I_fix_b]) S_d

  // measurement noise: the perturbed residuals (allocated when q or v noise is declared)
  std::unique_ptr<Workspace> wp;
  std::unique_ptr<WrenchData> wd0, wd1;
  Eigen::VectorXd qp, vp, tau_id, r0_tau, r_tau;  // (nq), (nv), (nv), (nv), (nv)
  Eigen::VectorXd r0_g, r_g;                       // (rows)
  StateRefit* refit = nullptr;  // estimate mode: refits the fitted coordinates per column (not owned)

  // measurement noise, velocity columns: the tangent along a velocity change (wrench_sigma_velocity.h)
  Eigen::VectorXd tv;                 // (nv) the velocity change of the column (a unit, refitted)
  std::vector<int> tv_nz;             // its nonzero entries
  std::vector<Vec6> tV, tA, tF;       // per body: the change of V_W, of A0_W, of the bias force's
                                      // subtree sum (world, at p_ref)
  std::vector<Vec6> P_W;              // per body: I_W V_W (its momentum, at the evaluated state)
  std::vector<char> t_moved, t_touched;  // per body: tV, tA set (a moved body); tF set
  Eigen::VectorXd tGdot;              // (rows) the change of Gdot v
  std::vector<double> trr;            // per spec: the change of a rolling spec's rr_arm

  // measurement noise, position columns: the tangent along a joint's motion (wrench_sigma_position.h),
  // per q_dofs entry, then per floating-joint DOF (float_dofs: the coordinates a refit fits)
  std::vector<int> float_dofs;                   // (nf) the floating joints' velocity indices
  std::vector<int> qt_dof;                       // (q_dofs + nf) the DOF the tangent moves
  std::vector<char> qt_tangent;                  // (q_dofs + nf) the column is a tangent (else a difference)
  std::vector<std::vector<int>> qt_bodies;       // (q_dofs + nf) the joint's subtree, ascending
  std::vector<std::vector<int>> qt_path;         // (q_dofs + nf) the DOFs above the joint
  std::vector<std::vector<int>> qt_specs;        // (q_dofs + nf) the welds, couplings and locks it moves
  std::vector<std::vector<int>> qt_outputs;      // (q_dofs + nf) the reactions it moves
  std::vector<std::vector<signed char>> qt_side;  // per weld, per support DOF: +1 it moves frame A,
                                                  // -1 frame B, 0 both (G's column is X_A^-1 S_k times it)
  std::vector<RigidInertia> I_own;               // per body: its own inertia (world, at p_ref)
  std::vector<Vec6> pa, pAt, pP, pF;             // per body: vdot-linear and total acceleration,
                                                 // momentum, subtree sum of the body forces
  std::vector<Vec6> pFs;                         // per spec (welds, rolling): its force (spec_force)

  // measurement noise with a refit (state_fit_sigma.h): the fitted coordinates' part of each column
  Eigen::MatrixXd Gv;  // (rows x (q_dofs + nf)) the change of the constraint rows' velocity G v at
                       // fixed v along each position tangent
  std::vector<char> t_column;  // (q_dofs) the last compute's position column was a tangent
  Eigen::MatrixXd K;   // (2 nf x (q_dofs + v_dofs)) per column: the fitted positions' tangent change,
                       // then the fitted velocities' change (the weights of the floating tangents)
};

// Torque noise only (simulate mode: the state is exact). Fills sd.sigma and sd.C for the
// evaluation in ws. Nothing to do (valid = false, sigma zero) when nothing is declared or the
// evaluation failed.
void compute_wrench_sigma(const System& sys, Workspace& ws, WrenchSigmaData& sd);

// Estimate mode: torque noise and the measurement noise of (q, v) at the state the evaluation in ws
// was made at (q, v, tau: its arguments).
void compute_wrench_sigma(const System& sys, Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& q,
                          const Eigen::VectorXd& v, const Eigen::VectorXd& tau);

}  // namespace coopdyn
