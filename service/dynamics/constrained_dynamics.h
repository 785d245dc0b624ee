// Constrained forward dynamics with constraint-force estimation (the paper's (12)-(26), and
// over-constrained systems beyond it).
//
//   M vdot + h = tau + G^T lambda,   G vdot = gamma
//   Q lambda = gamma - G M^-1 (tau - h),   Q = G M^-1 G^T       (paper (16)-(18))
//
// with M = L^T L factored tree-sparsely, Y = G L^-1, Q = Y Y^T. Q is solved by Cholesky when it is
// well conditioned, else by a factorization that reveals the rank (README: over-constrained systems): the
// accelerations stay exact and finite, the indeterminate part of lambda follows the scene's rule
// and is flagged per row. Nothing here allocates after the Workspace is built, logs or throws.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "service/constraints/constraints.h"
#include "service/dynamics/friction_lcp.h"
#include "service/dynamics/q_blocks.h"
#include "service/dynamics/q_solve.h"
#include "service/dynamics/system.h"
#include "service/model/model.h"

namespace coopdyn {

enum class Status { kOk = 0, kIndeterminate = 1, kError = 2 };
const char* status_name(Status s);

// Why a status is not plain ok (the table, with each reason's key and text: reasons.def).
enum class Reason {
#define COOPDYN_REASON(e, code, key, text) e = code,
#include "service/dynamics/reasons.def"
};
const char* reason_text(Reason r);  // "" for kNone
const char* reason_key(Reason r);   // one word: "none", "diverged", ...

struct Diagnostics {
  int rows = 0;            // constraint rows
  int rank = 0;            // numerical rank of Q
  int indeterminate = 0;   // rows - rank: directions of lambda the physics leaves free
  double condition = 1.0;  // condition estimate of Q on its range (pivot ratio; without the
                           // nominal base-link directions of System::nominal_bases, see there)
  double residual = 0.0;   // max |G vdot - gamma|
  Status status = Status::kOk;
  Reason reason = Reason::kNone;
  int dropped = 0;         // SVD baseline: directions dropped (along N(J_k^T), summed over the tips)
  int bad_index = -1;      // velocity index: the DOF that moves no mass (kMassMatrixSingular) or
                           // that broke solver.max_speed (kDiverged)
};

// The stresses a system reports (Workspace::stress): each pseudo-joint's locking force, then each
// joint coupling's (ConstraintKind::kCouple, a URDF <mimic>) force on its mimicking joint. Names are
// the joints' velocity names, units "N*m" (rotation) or "N" (translation).
int num_stresses(const System& sys);
std::string stress_name(const System& sys, int k);
const char* stress_unit(const System& sys, int k);

struct Workspace {
  explicit Workspace(const System& sys);

  Data data;
  ConstraintData cd;
  // Whether an evaluation fills the position errors cd.err (constraint_rows' PositionErrors): set
  // by those that read them after evaluate() (Stepper::ws: the loop's and sim's closure reports);
  // otherwise cd.err is NaN after an evaluation without Baumgarte stabilization (the rows' error
  // terms are computed only where read). Nothing else an evaluation gives depends on it.
  bool position_errors = false;
  Eigen::VectorXd tau_c;   // (nv) tau - h
  Eigen::VectorXd vdot;    // (nv) accelerations
  Eigen::VectorXd lambda;  // (rows) constraint multipliers
  Eigen::VectorXd stress;  // (num_stresses) generalized force locking each pseudo-joint, then each
                           // coupling's force on its mimicking joint (stress_names)
  Diagnostics diag;

  // Joint losses (Joint::damping, Joint::friction): the generalized force each joint's damping and
  // Coulomb friction exerted in the last evaluation, included in tau_c, vdot, lambda and every wrench
  Eigen::VectorXd tau_loss;           // (nv) -damping v + friction force; 0 at joints without
  std::vector<int> damped_dofs;       // DOFs with damping > 0
  std::vector<int> friction_dofs;     // DOFs with friction > 0
  Eigen::VectorXd damping, friction;  // (nv) per DOF (zero elsewhere)
  // A friction joint is at rest when |v| <= rest_speed (rad/s or m/s; System::rest_speed, scene key
  // `friction: {rest_speed}`, default kRestSpeed): its friction is then solved as stiction
  // (friction_lcp.h); faster, it slides with -friction sign(v).
  static constexpr double kRestSpeed = System::kDefaultRestSpeed;
  double rest_speed = kRestSpeed;
  std::vector<int> rest_dofs;          // (<= friction_dofs) the resting friction DOFs of the last evaluation
  int rest_count = 0;
  FrictionLcp lcp;                     // their stiction problem (A, b: one column per resting DOF)
  Eigen::VectorXd tau_c_fr, vdot_fr;   // (nv) tau_c without the resting friction, its accelerations
  Eigen::VectorXd lambda_fr;           // (rows) the multipliers without the resting friction
  // the response to a unit generalized force (1 N*m or 1 N) at each resting friction DOF, column j
  // for rest_dofs[j] (the first rest_count columns; exact for the affine solve up to rounding):
  // what friction_bound.h maps to every wrench's interval over the unknown friction at rest
  Eigen::MatrixXd rest_dvdot;          // (nv x friction DOFs)
  Eigen::MatrixXd rest_dlambda;        // (rows x friction DOFs)
  int friction_stuck = 0;              // resting friction joints held by stiction (vdot exactly 0)
  int friction_indeterminate = 0;      // of those, forces the physics leaves free (set to zero)
  bool friction_converged = true;      // the active set met Coulomb's conditions
  // Takes the torques as reaching the links: the joints' damping and friction left out of every
  // later evaluation (estimate mode without joint-loss compensation, `estimate.joint_losses`).
  // Start-up only; allocation-free.
  void ignore_joint_losses();

  // Schur solve
  Eigen::MatrixXd Yt;  // (nv x rows) (G L^-1)^T
  Eigen::MatrixXd Q;   // (rows x rows)
  Eigen::VectorXd u;   // (nv)
  Eigen::VectorXd rhs; // (rows)
  // sparsity of Y = G L^-1: the DOFs each spec's rows touch after the L^-T solve (ancestor-closed),
  // and for each pair of specs s <= t the contiguous ranges of DOFs both touch (where Q_st sums)
  std::vector<std::vector<int>> y_support;
  // a DOF's row of YBlock: the spec's (up to) 6 rows of Y at that DOF, then zeros to kYStride
  // doubles (one 64-byte row: each step of the L^-T sweep one 8-wide multiply-add, not three 2-wide)
  static constexpr int kYStride = 8;
  using YBlock = Eigen::Matrix<double, Eigen::Dynamic, kYStride, Eigen::RowMajor>;
  std::vector<YBlock> Yb;  // per spec: (nv x kYStride) its rows of Y as columns, one DOF per row
  // (spec, DOF k, its parent j or -1) in model.dof_elim_steps, specs interleaved: j is eliminated
  // with k where the step pairs them (the spec reaches j whenever it reaches k: its support is
  // ancestor-closed)
  struct YStep {
    int spec, k, j;
  };
  std::vector<YStep> y_sweep;
  std::vector<std::vector<std::pair<int, int>>> pair_ranges;  // index s * nspecs + t
  QSolver qs;                     // Q lambda = b: fast path, rank, indeterminate rows, rule
  // Q per group of specs coupled through the common (platform) DOFs only (q_blocks.h): used when
  // the structure holds with at least kQBlocksMinGroups groups (mobile_platform and classic; the
  // nominal bases' condition from the reduced blocks), falling back to the dense Q and qs when Q,
  // or Q without the nominal directions, is not safely positive definite.
  // use_q_blocks may be set to false (tests: the dense path on the same workspace).
  // With nominal bases both paths factor Q once with the nominal directions last (the blocks:
  // QBlocks' single factor; the dense path: QSolver::factor_nominal_last): the reduced Q's pivots
  // lead, so one factor gives the condition and the solve. The blocks are the faster from
  // kQBlocksMinGroupsNominal groups on (bench/README.md, "Arms on one load").
  static constexpr int kQBlocksMinGroups = 3, kQBlocksMinGroupsNominal = 3;
  QBlocks qb;
  bool use_q_blocks = false;
  bool q_blocks_active = false;  // the last factorization took the block path (ws.Q not formed)
  // the condition without the nominal base-link directions (System::nominal_bases)
  std::vector<std::pair<int, int>> nominal_rows;  // (velocity index of joint 1, first row of the weld)
  Eigen::MatrixXd Qn;                             // (rows x rows) work copy of Q (the rank path's condition)
  // The dense path with nominal bases (mobile_platform and classic): build_q forms R Q R^T (q_solve.h)
  // straight into qs.Nq from the reflected rows of Y, H Q H = (H Y)(H Y)^T, and Q itself only where
  // the fast path fails (q_reflected then false). Y itself (Yb) stays as it is for every reader.
  std::vector<int> spec_nominal;  // (specs) the nominal direction whose weld the spec is, or -1
  std::vector<YBlock> Yr;         // per spec: H Y's rows as Yb's (nominal welds only; others empty)
  bool q_reflected = false;       // the last build_q formed R Q R^T only (ws.Q not formed)
  Eigen::MatrixXd eig_A, eig_V;  // (rows x rows) SVD baseline's eigen-decomposition of Q_r
  Eigen::VectorXd eig_w;         // (rows)
  Eigen::VectorXd tmp_m, tmp_m2;  // (rows)
  Eigen::VectorXd tau_c0;        // (nv) tau - h before the rolling-resistance moments
  int rr_iterations = 0;         // fixed-point iterations of the rolling-resistance moments (0: none)

  // kPseudoJointSchur only (empty otherwise)
  Eigen::MatrixXd Minv, P, QinvPt, D;  // (nv x nv), (nv x rows), (rows x nv), (nv x nv)
  Eigen::VectorXd E;                   // (nv)
  Eigen::MatrixXd d4;                  // (p x p)
  Eigen::LLT<Eigen::MatrixXd> d4_llt;
  Eigen::VectorXd tp;                  // (p)

  // kSvdBaseline only (empty otherwise)
  std::vector<std::vector<int>> own_cols;      // per spec: the DOFs of the tip's own Jacobian J_k (they
                                               // move frame A but not frame B: an arm's joints, not the load's)
  std::vector<Eigen::MatrixXd> tip_B, tip_U;  // per spec: (rows_k x nv) J_k (G_k on own_cols), its U
  std::vector<Eigen::VectorXd> tip_s;          // per spec: singular values of J_k, descending
  std::vector<int> tip_rank;                   // per spec: directions kept (rank of J_k)
  int dropped = 0;                             // directions dropped, all specs
  Eigen::MatrixXd R;         // (rows x rows) block-diagonal reduction, first mr rows used
  Eigen::MatrixXd Gr;        // (rows x nv) reduced G
  int mr = 0;
};

// Evaluates accelerations, constraint forces and diagnostics at (q, v, tau). Never throws.
const Diagnostics& evaluate(const System& sys, Workspace& ws, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                            const Eigen::VectorXd& tau);

// evaluate() in two halves, for a caller whose torque depends on the state's bias forces and
// constraint rows (the safe torque `hold`, holding_torque.h): begin_evaluation() computes what does
// not depend on tau (kinematics, h, M and its factor, G, gamma); false, with ws.diag the error, when
// (q, v) is not valid or M is singular. Once it succeeded, finish_evaluation() completes the
// evaluation for tau (any number of times): the result is bit for bit evaluate(sys, ws, q, v, tau).
bool begin_evaluation(const System& sys, Workspace& ws, const Eigen::VectorXd& q, const Eigen::VectorXd& v);
const Diagnostics& finish_evaluation(const System& sys, Workspace& ws, const Eigen::VectorXd& v, const Eigen::VectorXd& tau);

// Wrench [moment; force] on the tip of weld spec s, in the tip frame; unconstrained axes are 0.
// *indeterminate (optional) gets a 6-bit mask of components the physics leaves free.
Vec6 tip_wrench(const System& sys, const Workspace& ws, int spec, unsigned* indeterminate = nullptr);

}  // namespace coopdyn
