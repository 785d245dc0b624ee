// Each wrench's sigma from torque noise arm by arm (wrench_sigma.h), where Q is factored by blocks
// (q_blocks.h: arms that share only the load's DOFs, the common ones).
//
// The torques of arm h' reach arm h != h' only through the load's acceleration a: arm h's
// equations (its DOFs' rows of M vdot - G^T lambda = tau, its constraint rows G vdot = gamma) hold
// only its own DOFs, the common ones and its own rows, so with a given they fix arm h's vdot and
// lambda, and so its reported wrenches, when arm h moves the load in every direction (its own rows'
// Y Y^T, A_h, nonsingular). Then every torque column j of arm g is
//   R_j = H_j + V c_j,
// H_j the response with the load held (a = 0): nonzero on arm g only, solved on its own DOFs and
// rows (M restricted to them is L_g^T L_g, the tree factor's own rows; A_g lambda = the held
// right-hand side); V the responses to a unit force on each common DOF (6 columns through the
// evaluation's full block solve and reaction pass); c_j = A_v^-1 a_j with a_j the load's
// acceleration under column j and A_v the load's accelerations under V. a_j needs no solve: the
// system [M G^T; G 0] on (vdot, -lambda) is symmetric, so the load's acceleration per unit torque
// at DOF d is V's acceleration at d (a_j = S_j Xv(d_j, :)). R_j - H_j - V c_j is the response to a
// force on the load alone with no load acceleration: zero when A_v is nonsingular.
//
// Cost: 6 columns through the full path, one held solve and reaction pass over each arm's own
// columns (linear in the arms), and C = V_k c + H_k per output row (6 multiply-adds per entry).
// Applies where the plan holds (every torque column an arm's own DOF, every reported wrench within
// one arm: its reaction subtree and constraint forces) and, per evaluation, where the blocks
// factored Q, A_v and every A_h are positive definite to QSolver's fast-path tolerance; else
// compute_wrench_sigma takes the full path. Allocation-free after planning; never throws.
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/wrench_sigma.h"

namespace coopdyn {

struct SigmaArms {
  using RowMat = WrenchSigmaData::RowMat;
  using GMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, QBlocks::kMaxGroupRows, QBlocks::kMaxGroupRows>;
  using GVec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, QBlocks::kMaxGroupRows, 1>;
  struct Arm {
    int spec0 = 0, spec1 = 0;  // its constraint specs (its QBlocks group)
    int row0 = 0, rows = 0;    // its rows of Q
    int j0 = 0, nj = 0;        // its torque columns [j0, j0 + nj)
    std::vector<int> elim;     // its own DOFs in dof_elim_order (leaves to root)
    std::vector<int> bodies;   // the bodies its DOFs move and those of its reactions' subtrees, ascending
    std::vector<char> in;      // (bodies) membership of bodies
    std::vector<int> pass;     // those in the reaction pass, in its order (decreasing)
    std::vector<int> specs_t;  // its specs' indices into WrenchSet::pass_specs
    std::vector<int> outputs;  // the reported wrenches within it
    GMat A;                    // (rows x rows) Y Y^T over its own DOFs, then its Cholesky factor (lower)
    GVec dinv;                 // (rows) 1 / diag of the factor
  };
  std::vector<int> common;   // the DOFs every spec reaches (the load's), 6
  std::vector<int> dof_arm;  // (nv) the arm owning each DOF, -1 for a common one
  std::vector<Arm> arms;
  RowMat V;   // (6 outputs x 6) each output per unit force on each common DOF
  RowMat Xv;  // (nv x 6) the accelerations per unit force on each common DOF
  RowMat Cc;  // (6 x torque columns) c_j
  Mat6 Av;    // the load's accelerations per unit force on each common DOF (symmetric)
};

// The plan, from the scene alone (start-up; allocates): null where the arm-by-arm sigma does not
// apply (another formulation, rolling contacts, no block structure, a torque column or a reported
// wrench not within one arm).
std::unique_ptr<SigmaArms> plan_sigma_arms(const System& sys, const WrenchSigmaData& sd);

// After the evaluation in ws and the 6 columns of unit forces on the common DOFs through the full
// path (sd.X and sd.C, columns 0..5): fills sd.C's torque columns. False (nothing usable written)
// where A_v or an arm's A_h is not safely positive definite: then the full path.
bool sigma_arms_torque(const System& sys, const Workspace& ws, WrenchSigmaData& sd, SigmaArms& sa);

}  // namespace coopdyn
