// Constraint specs, compiled into row blocks of G (rows x nv) and its right-hand side.
//
// Every block writes its rows of
//     G vdot = gamma,   gamma = -Gdot v - stab,   stab = alpha * (G v) + beta * e   (Baumgarte)
// and its multipliers lambda enter the equations of motion as  M vdot + h = tau + G^T lambda.
// For a weld or point block, lambda is the wrench [moment; force] that the environment (the world,
// or body B) exerts on tip frame A, at A's origin, in A's coordinates: what a force/torque sensor
// at the tip would read. For a lock block (pseudo-joint), lambda is the generalized force the
// structure carries along the pseudo-joint's axis: the internal stress. For a rolling block, lambda
// is the force [fx; fy; fz] that the ground exerts on the wheel at the contact point, in the contact
// frame C (x forward along the heading, y lateral to the left, z the ground normal).
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "service/model/model.h"

namespace coopdyn {

enum class ConstraintKind {
  kWeld,  // tip frame A held to the world (target pose) or to frame B; any subset of the 6 axes of A
  kLock,  // one pseudo-joint DOF held at its initial value (the paper's (22)-(26))
  // A rigid disk of radius r rolling without slip on a ground plane {x : n.x = d} (by default
  // z = 0, n = z_W), the paper's (27)-(54). The wheel centre is the origin of `body`, `axle` (unit, body
  // coordinates) its spin axis. The contact point P is the lowest point of the rim: p_WP = p_WB -
  // r d, with d the unit vector of the wheel plane closest to the ground normal n,
  // d = (n - (n.a) a) / |n - (n.a) a|, a = R_WB axle. Contact frame C, R_WC = [x_C y_C n]:
  //   x_C = a x n / |a x n|   heading: a positive spin about +axle rolls the wheel towards +x_C
  //   y_C = n x x_C           lateral, to the left of the heading
  // Three rows, the velocity of the wheel's material point at P along x_C, y_C, n:
  //   x, y  longitudinal and lateral no-slip: nonholonomic, err = 0, no Baumgarte beta term
  //   z     ground contact: holonomic, err = n.p_WP - d (height of P above the plane), stabilized
  // Gdot*v is analytic (the motion of P around the rim and the rotation of C included). A wheel
  // lying flat (axle vertical, |a x n| -> 0) has no heading; rows stay finite but meaningless.
  kRolling,
  // A coupling of two 1-DOF joints (a URDF <mimic>): q_j = m q_i + o, j the spec's `dof` (q_index),
  // i its `couple_dof` (couple_q), m `multiplier`, o `offset`. One row: G = e_j - m e_i, position
  // error q_j - m q_i - o, Gdot v = 0. Its multiplier lambda is the generalized force the coupling
  // applies on joint j (-m lambda on joint i): reported with the stresses (constrained_dynamics.h).
  kCouple,
};

struct ConstraintSpec {
  std::string name;
  ConstraintKind kind = ConstraintKind::kWeld;
  int frame_a = -1;              // weld: the tip
  int frame_b = -1;              // weld: the other frame, -1 = the world
  Transform X_WA_target;         // weld to world: where frame A is held
  std::array<bool, 6> axes{{true, true, true, true, true, true}};  // [wx wy wz vx vy vz] of A
  int dof = -1;                  // lock: velocity index (couple: of the mimicking joint j)
  int q_index = -1;              // lock: position index
  double q_target = 0.0;         // lock: held position (the scene's); a workspace may hold it
                                 // elsewhere (ConstraintData::lock_target, a commanded target)
  double target_limit = 0.0;     // lock: |commanded target| allowed (rad or m; the joint's
                                 // `target_limit`); 0 = the target cannot be commanded
  std::array<double, 6> compliance{{0, 0, 0, 0, 0, 0}};  // per axis (rad/(N*m), m/N), for the
                                                         // split of indeterminate forces only;
                                                         // rolling: entries 3..5 (x, y, z of C)
  int body = -1;                 // rolling: the wheel body (its origin is the wheel centre)
  Vec3 axle = Vec3::UnitY();     // rolling: spin axis, unit, in the body frame
  double radius = 0.0;           // rolling: wheel radius (m)
  Vec3 ground_n = Vec3::UnitZ(); // rolling: the ground plane's unit normal (world), pointing up
  double ground_d = 0.0;         // rolling: the plane is {x : ground_n . x = ground_d} (m)
  // rolling: rolling-resistance coefficient c_rr (dimensionless, 0 = none): the normal force acts
  // c_rr r ahead of P, a moment -c_rr r N sgn(u) y_C on the wheel about P, u the wheel centre's
  // speed along x_C and sgn smoothed over kRollingResistanceSpeed (README "Vehicles")
  double rolling_resistance = 0.0;
  double mu = 0.0;               // rolling: friction coefficient for the utilisation report
                                 // (contacts.h); 0 = not given (friction needed still reported)
  int couple_dof = -1;           // couple: velocity index of the mimicked joint i
  int couple_q = -1;             // couple: its position index
  double multiplier = 1.0;       // couple: q_j = multiplier q_i + offset
  double offset = 0.0;
};

// Speed (m/s) over which the rolling-resistance moment's sign is smoothed: sgn(u) ~ u / sqrt(u^2 +
// u0^2), so a wheel at rest feels none and one rolling at 1 m/s 1 - 5e-7 of it.
constexpr double kRollingResistanceSpeed = 1e-3;

// Contact geometry of a rolling spec after forward_kinematics: X_WC (contact frame C at the contact
// point P, see ConstraintKind::kRolling). Allocation-free.
Transform rolling_contact_frame(const Model& model, const Data& data, const ConstraintSpec& c);

// The compiled set: specs plus row layout and supports. Immutable after compile().
struct ConstraintSet {
  std::vector<ConstraintSpec> specs;
  double baumgarte_alpha = 0.0;  // 1/s
  double baumgarte_beta = 0.0;   // 1/s^2
  bool stabilize = false;

  // filled by compile()
  int rows = 0;
  std::vector<int> row_offset;              // first row of each spec
  std::vector<int> row_count;               // rows of each spec
  std::vector<std::array<int, 6>> row_axis; // axis of each row within its spec (weld; rolling:
                                            // 3 4 5 = force along x_C y_C z_C)
  std::vector<std::vector<int>> support;    // DOFs each spec touches, ascending
  std::vector<int> row_spec;                // spec of each row
  Eigen::VectorXd row_compliance;           // (rows)
  bool rolling_resistance = false;          // some rolling spec has a rolling-resistance coefficient
  std::vector<int> couple_specs;            // the kCouple specs, in order (their stresses follow the
                                            // pseudo-joints' in Workspace::stress)

  void compile(const Model& model);
};

// Workspace for constraint rows (sized once).
struct ConstraintData {
  ConstraintData(const Model& model, const ConstraintSet& set);
  Eigen::MatrixXd G;        // (rows x nv)
  Eigen::VectorXd Gdot_v;   // (rows) Gdot * v
  Eigen::VectorXd err;      // (rows) position error (0 for rows without one)
  Eigen::VectorXd Gv;       // (rows) G * v: constraint velocity
  Eigen::VectorXd gamma;    // (rows) right-hand side
  Eigen::Matrix<double, 6, Eigen::Dynamic> J_a, J_b;  // (6 x nv) scratch
  // per spec: its frame (weld: the tip frame A; rolling: the contact frame C) in world axes, its
  // origin relative to data.p_ref (what to_ref() gives); unused for a lock. The wrenches read it
  // (wrenches.h) instead of recomputing the poses of the same evaluation.
  std::vector<Transform> X_RS;
  // per spec (rolling with a resistance coefficient; 0 otherwise): the moment about y_C per newton
  // of normal force, -c_rr r sgn(u) (m); the ground's wrench on the wheel at P in C is
  // [0, rr_arm N, 0; fx, fy, N]
  std::vector<double> rr_arm;
  // per spec (lock; unused otherwise): the position the lock row holds its joint at, rad or m.
  // Starts at the spec's q_target (the scene's); a driver's command moves it (a steer angle,
  // torque_command_t targets). The row's error is q - lock_target: with projection (integrators.h)
  // the joint is at a new target after the next step, the velocity projected onto the constraints
  // at the new angle; with Baumgarte stabilization only, it approaches the target as the response
  // s^2 + alpha s + beta sets, its torque the lock's stress.
  std::vector<double> lock_target;
};

// A rolling spec's wrench on its wheel at P in C ([moment; force], w[5] = the normal force N)
// carries the rolling-resistance moment about y_C: w[1] = rr_arm N. Nothing for other kinds.
inline void set_rolling_resistance_moment(const ConstraintSet& set, const ConstraintData& cd, int s, double* w) {
  if (set.specs[static_cast<size_t>(s)].kind == ConstraintKind::kRolling) w[1] = cd.rr_arm[static_cast<size_t>(s)] * w[5];
}

// Whether constraint_rows fills the position errors cd.err. Only Baumgarte stabilization (gamma),
// the projection, the state fit and the closure reports read them, and a weld's error (the log of
// its pose error's rotation) is a third of its rows' cost; kSkip leaves every entry of cd.err NaN
// (so that a reader that did not ask for them fails loudly), unless set.stabilize: gamma needs them.
enum class PositionErrors { kFill, kSkip };

// Fills G, Gdot_v, err, Gv, gamma and X_RS after forward_kinematics(q, v) (err: see PositionErrors;
// with kFill or kSkip, every other output the same bits).
void constraint_rows(const Model& model, const Data& data, const ConstraintSet& set, const Eigen::VectorXd& q,
                     const Eigen::VectorXd& v, ConstraintData& cd, PositionErrors errors = PositionErrors::kFill);

// The change of Gdot*v (cd.Gdot_v) and of each rolling spec's rr_arm along a change of the velocity
// at a fixed configuration: dV_W, dA0_W the bodies' changes of V_W and A0_W (world, at data.p_ref),
// read only for bodies with moved[body] != 0 (the others did not change). data and cd as
// forward_kinematics and constraint_rows left them at (q, v). Exact: Gdot*v is quadratic in the
// velocities (bilinear in V_W, linear in A0_W), its tangent linear in (dV_W, dA0_W); rr_arm's is
// the derivative of its smoothed sign. The change of G v is G dv (G does not depend on v), not
// computed here. Writes every row of dGdot_v (rows) and every entry of drr_arm (specs).
// Allocation-free.
void constraint_bias_tangent(const Model& model, const Data& data, const ConstraintSet& set, const ConstraintData& cd,
                             const std::vector<Vec6>& dV_W, const std::vector<Vec6>& dA0_W, const std::vector<char>& moved,
                             Eigen::VectorXd& dGdot_v, std::vector<double>& drr_arm);

// Stacked position error of every block at q (needs forward_kinematics at q).
double constraint_position_error(const ConstraintData& cd);

}  // namespace coopdyn
