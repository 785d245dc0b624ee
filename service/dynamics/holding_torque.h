// The torques that hold a constrained system still: the safe-torque policy `hold` of coopdynd.
//
// At (q, v), the actuator torques tau (on the actuated DOFs only; a floating platform, a
// pseudo-joint or a DOF with a zero torque limit carries none) that balance the bias forces h along
// every motion the constraints allow, N^T (S_a^T tau_a - h) = 0 (N: the null space of G), of least
// sum (tau_i / limit_i)^2 (plain minimum norm where no limit is given): no squeeze beyond what
// balance needs. The residual |N^T (S_a^T tau_a - h)| says how well the actuators can hold it.
// Solved in the m multipliers from the loop's own h and G (begin_evaluation(): nothing evaluated
// twice) by a pivoted Cholesky and a Schur complement; where a rank decision is not clear, by the
// reference solve (two SVDs, rank tolerance 1e-10 relative). No allocation after construction.
// The derivation and the rank thresholds: docs/method.md, "The holding torque".
#pragma once

#include <Eigen/SVD>
#include <vector>

#include "service/dynamics/constrained_dynamics.h"

namespace coopdyn {

struct HoldWorkspace {
  HoldWorkspace(const System& sys, const std::vector<unsigned char>& actuated);
  Workspace ws;                    // h and G at (q, v) for holding_torque(sys, hw, q, v, tau)
  std::vector<int> act, unact;     // actuated / unactuated velocity indices
  // factorization path
  static constexpr double kKeep = 1e-8, kDrop = 1e-12;
  using Block = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>;
  Eigen::VectorXd scale;           // (nv) 1 / limit on an actuated DOF (1 without a limit), 1 elsewhere
  std::vector<Block> Gb;           // per spec: (nv x 6) its rows of Gs as columns, one DOF per row
  std::vector<std::vector<int>> common;  // per pair of specs s <= t (index s * nspecs + t): DOFs both touch
  std::vector<int> row_spec;       // (rows) the spec of each row
  Eigen::MatrixXd H;               // (rows x rows) Gs Gs^T, then its pivoted factor in place
  std::vector<int> perm;           // (rows) pivot order: perm[0..rank) are the kept rows
  Eigen::MatrixXd Z;               // (rows x nu) L^-1 G_u on the kept rows
  Eigen::MatrixXd S;               // (nu x nu)
  Eigen::VectorXd g, mu, nu_rhs, f;  // (rows), (rows), (nu), (nv)
  bool factored = false;           // the last solve took the factorization path (else the SVDs)
  // reference path (SVD)
  Eigen::JacobiSVD<Eigen::MatrixXd> svd_G, svd_A;
  Eigen::MatrixXd Gt, A;           // (nv x rows) G^T padded, (nv x na) V^T S_a^T with the range rows zeroed
  Eigen::VectorXd b, x;            // (nv), (na)
  Eigen::VectorXd w;               // (na) column weights: each joint's torque limit (1 without one)
  Eigen::VectorXd hb;              // (nv) braking_torque(): the bias it balances, h - M v / T
  double residual = 0;             // |N^T (S_a^T tau_a - h)| of the last solve (N*m or N); on the
                                   // factorization path |h_u + G_u^T mu|, an upper bound of it
};

// Default actuation: every DOF but a floating joint's and a pseudo-joint's, and none with a zero
// torque limit.
std::vector<unsigned char> default_actuated(const System& sys);

// Fills tau (nv) with the holding torques from the bias forces and constraint rows of ws, an
// evaluation at (q, v) (begin_evaluation() suffices: the torque is then passed to
// finish_evaluation(), as the daemon's loop does). Factorization path, else the SVDs. False (tau
// zero) if the result is not finite.
bool holding_torque(const System& sys, HoldWorkspace& hw, const Workspace& ws, Eigen::VectorXd& tau);

// The same at (q, v), evaluated in hw.ws; false (tau zero) if the state is not valid or its mass
// matrix singular.
bool holding_torque(const System& sys, HoldWorkspace& hw, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                    Eigen::VectorXd& tau);

// The reference solve (two SVDs) from ws: the definition above, the factorization path's fallback
// and its test oracle. Allocation-free, ~10x slower.
bool holding_torque_svd(const System& sys, HoldWorkspace& hw, const Workspace& ws, Eigen::VectorXd& tau);

// The braking hold (the safe torque `hold` of coopdynd): torques that give every motion the
// constraints allow the acceleration -v / T, M (-v / T) + h = S_a^T tau_a + G^T lambda, the load's
// and every other unactuated body's inertia included: each velocity decays as exp(-t / T) while
// the actuators can supply it (a first-order, overdamped brake; at rest it is the holding torque).
// It is holding_torque() for the bias h - M v / T (the same rule and paths). T <= 0: the holding
// torque. Allocation-free; the (q, v) form evaluates in hw.ws as holding_torque()'s does.
bool braking_torque(const System& sys, HoldWorkspace& hw, const Workspace& ws, const Eigen::VectorXd& v,
                    double time_constant, Eigen::VectorXd& tau);
bool braking_torque(const System& sys, HoldWorkspace& hw, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                    double time_constant, Eigen::VectorXd& tau);
// out = M v from the path-compact rows Data::Mc (filled by every evaluation), O(tree nonzeros).
void mass_times(const Model& model, const Data& data, const Eigen::VectorXd& v, Eigen::VectorXd& out);

// The holding torques as coopdynd applies them: each actuated DOF's (hw.act) clamped to +-its torque
// limit (sys.tau_limit), a joint that cannot hold its share then holds what it can. Returns how many
// DOFs were clamped. Allocation-free.
int clamp_to_torque_limits(const System& sys, const HoldWorkspace& hw, Eigen::VectorXd& tau);

}  // namespace coopdyn
