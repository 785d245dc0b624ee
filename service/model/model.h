// The immutable kinematic tree (Model) and the workspace sized from it (Data).
//
// A Model is built once (by the scene loader or a test), then only read. Every algorithm is a free
// function f(const Model&, Data&, inputs...) and allocates nothing: Data's constructor sizes every
// buffer from the Model.
//
// Bodies are numbered in topological order (a parent before its children); the world is -1. Each
// body has one joint connecting it to its parent:  X_PB(q) = X_PJ * X_JB(q), where X_PJ is the
// fixed placement of the joint frame J in the parent body frame P and X_JB(q) the joint motion.
// The body frame B is the joint's moving frame.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "service/spatial/spatial.h"

namespace coopdyn {

using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

enum class JointType {
  kFixed,      // 0 DOF
  kRevolute,   // 1 DOF, rotation about `axis` (unit, in J)
  kPrismatic,  // 1 DOF, translation along `axis`
  kRevolute2,  // 2 DOF, R = Rot(axis, q0) * Rot(axis2, q1): two revolute axes through one point,
               //        as the paper's wheel contact joint (yaw, then lean about the rotated axis)
  kFloating,   // 6 DOF mobile platform: q = [p_PB (3); quaternion w,x,y,z (4)], v = V_PB_B [w; v]
};

int joint_nq(JointType t);
int joint_nv(JointType t);
const char* joint_type_name(JointType t);

struct Joint {
  JointType type = JointType::kFixed;
  Vec3 axis = Vec3::UnitZ();
  Vec3 axis2 = Vec3::UnitX();
  std::string name;
  double armature = 0.0;  // rotor inertia reflected at the joint (kg*m^2 or kg), added to M
  // Joint losses (revolute and prismatic joints only; URDF <dynamics damping friction>):
  double damping = 0.0;   // viscous: a generalized force -damping * v (N*m*s/rad or N*s/m)
  double friction = 0.0;  // Coulomb bound (N*m or N): -friction * sign(v) while the joint moves; at
                          // rest any force within the bound (stiction), solved exactly by evaluate()
  bool pseudo = false;  // a joint the real structure lacks; locked by computed torques (the paper's (22)-(26))
  int nq = 0, nv = 0;
  int axis_z = 0;  // revolute: +1 / -1 when axis is exactly +z / -z (the DH case: a cheaper kinematics step)
  int idx_q = 0, idx_v = 0;  // first coordinate in q and in v
};

// The form of a joint placement's rotation, for forward_kinematics to skip its exact zeros: the
// identity, a rotation about x (a Denavit-Hartenberg link twist: R(0, 0) = 1 and the rest of row
// and column 0 zero), or any rotation.
enum class PlacementRotation { kGeneral, kIdentity, kAboutX };

struct Body {
  std::string name;
  int parent = -1;
  Transform X_PJ;  // joint placement in the parent body frame
  Joint joint;
  Inertia inertia;  // in the body frame
  PlacementRotation placement_rotation = PlacementRotation::kGeneral;  // X_PJ.R's form (add_body sets it)
  bool placement_at_origin = false;                                     // X_PJ.p exactly zero
};

// An operational frame rigidly attached to a body (a tip, a grasp point, a contact frame).
struct Frame {
  std::string name;
  int body = -1;  // -1: the world
  Transform X_BF;
};

class Model {
 public:
  Vec3 gravity_W = Vec3(0, 0, -9.81);  // m/s^2 in world coordinates

  // Adds a body and returns its index. Throws std::invalid_argument on a bad parent or name.
  int add_body(const std::string& name, int parent, const Transform& X_PJ, Joint joint, const Inertia& I);
  int add_frame(const std::string& name, int body, const Transform& X_BF);

  int nbodies() const { return static_cast<int>(bodies.size()); }
  int nq() const { return nq_; }
  int nv() const { return nv_; }
  int body_index(const std::string& name) const;   // -1 if absent
  int frame_index(const std::string& name) const;  // -1 if absent
  int joint_index(const std::string& name) const;  // body index of the joint, -1 if absent

  // true if body a is b or an ancestor of b
  bool is_ancestor(int a, int b) const;
  // velocity indices that move body b (its own joint and all ancestors'), ascending
  std::vector<int> support_dofs(int body) const;
  // the same for the body of an operational frame (empty for the world), without allocating
  const std::vector<int>& frame_support(int frame) const {
    const int b = frames[frame].body;
    return b >= 0 ? body_support[b] : empty_;
  }

  std::vector<Body> bodies;
  std::vector<Frame> frames;
  // DOF-level parent (Featherstone's lambda over velocity indices, RBDA s.6.5): the previous DOF of
  // the same joint, or the last DOF of the nearest ancestor with DOFs; -1 at a root.
  std::vector<int> dof_parent;
  std::vector<int> dof_body;  // body that owns each velocity index
  // The ancestors of each DOF (the chain of dof_parent), ascending: DOF k's path is
  // dof_path[dof_path_offset[k] .. + dof_depth[k]). The path of an ancestor of k is a prefix of k's
  // path, which the tree-sparse factorization uses to make every update one contiguous loop.
  std::vector<int> dof_depth, dof_path_offset, dof_path;
  // Where row k of the tree factor (and of M, Data::Mc and Lc) starts: each row, its dof_depth[k]
  // entries over the path and then the diagonal, padded with zeros to a multiple of kFactorRowPad
  // doubles, so that every row starts on a 64-byte boundary and the factorization updates it in
  // whole 8-wide chunks that no other row shares (tree_cholesky.cc). factor_size: the total.
  static constexpr int kFactorRowPad = 8;
  std::vector<int> dof_row_offset;
  int factor_size = 0;
  // A leaves-to-root order of the DOFs (every DOF after all its descendants) that interleaves the
  // branches: by depth, deepest first. Sweeps that eliminate DOFs one by one (the factorization,
  // L^-T solves) use it, and its reverse for root-to-leaves sweeps.
  std::vector<int> dof_elim_order;
  // The tree factorization's steps (tree_cholesky.h), leaves to root: (k, j) eliminates DOF k, then
  // its parent j = dof_parent[k] in the same pass over their ancestors' rows when k is j's only child
  // DOF (a chain: the joints of an arm, the DOFs of a floating joint), else (k, -1). Every DOF
  // appears once, after all its descendants; the order is dof_elim_order's with each such parent
  // moved up to its child.
  std::vector<std::pair<int, int>> dof_elim_steps;
  std::vector<std::string> q_names, v_names;
  std::vector<int> pseudo_dofs;  // velocity indices of pseudo-joints, ascending
  std::vector<std::vector<int>> body_support;  // support_dofs of every body

  // Neutral configuration (zero angles, identity quaternions).
  Eigen::VectorXd neutral() const;

 private:
  void plan_elimination_steps();  // dof_elim_steps from dof_elim_order and dof_parent
  int nq_ = 0, nv_ = 0;
  std::vector<int> empty_;
};

// Workspace for all algorithms on one Model. Construct once; nothing resizes later.
struct Data {
  explicit Data(const Model& model);

  // kinematics. Spatial vectors are Featherstone's, in world coordinates and taken at one common
  // point (RBDA s.2.2): a body's velocity V_W = [w; v_R], v_R the velocity of the body point that
  // is at the reference point R. In this form velocities and forces of different bodies add without
  // transforms, which makes RNEA and CRBA transform-free over the tree (RBDA s.6.2, as Pinocchio).
  // R is not the world origin but p_ref, the first body's position, refreshed by every
  // forward_kinematics: inertias about the world origin carry a rounding error of about
  // eps m |p|^2, which grows with the square of the distance travelled (a vehicle 100 km out lost
  // three digits of its accelerations); about R they stay as accurate anywhere as at the origin.
  // Poses (X_WB, frame_pose) stay in the world; to_ref() gives the pose a spatial transform needs.
  std::vector<Transform> X_WB;  // body pose in the world
  Vec3 p_ref = Vec3::Zero();    // the point R, in the world
  Eigen::Matrix<double, 6, Eigen::Dynamic> S_W;  // (6 x nv) motion subspace columns, world coords
  std::vector<Vec6> V_W;        // body spatial velocity
  std::vector<Vec6> A0_W;       // body spatial acceleration at vdot = 0, no gravity: the velocity-
                                // product term every Jdot*v is read from
  Eigen::VectorXd sin_q, cos_q;  // (nv) sine and cosine of each revolute joint's angle, at its
                                 // velocity index (forward_kinematics; other entries unused)

  // dynamics
  std::vector<RigidInertia> I_B;   // body inertias in B (constant, from the model)
  // The inertias the bias and mass-matrix passes use: a body welded to its parent by a fixed joint
  // moves with it, so its inertia is folded into the parent's (in the parent's frame) and its own
  // entry is zero; bodies whose entry is exactly zero (folded, or massless like a base link held
  // by a constraint) are skipped by forward_kinematics' inertia transform and by rnea_bias.
  std::vector<RigidInertia> I_Bm;
  // The inertia of each body together with every body welded below it (its rigid group), in B:
  // I_Bm before the fold. The joint-reaction pass needs it at fixed joints (a grasp, a welded tool).
  std::vector<RigidInertia> I_Bw;
  std::vector<char> has_inertia;   // I_Bm[i] nonzero
  std::vector<RigidInertia> I_W;   // I_Bm in world coordinates, about p_ref
  std::vector<RigidInertia> Ic_W;  // composite (subtree) inertias, world coordinates
  std::vector<Vec6> f_W;           // body forces of RNEA, world coordinates
  std::vector<Vec6> a_W;           // rnea(): vdot-linear part of the body accelerations
  std::vector<Vec6> f;             // rnea(): joint reactions, B coordinates at Bo (see rnea.h)
  Eigen::VectorXd h;          // (nv) bias forces: Coriolis, centrifugal, gravity
  Eigen::MatrixXd M;          // (nv x nv) joint-space inertia
  Eigen::VectorXd Mc;         // M by rows over the ancestor paths, the layout of Lc (crba fills both)
  // Tree-sparse factor M = L^T L (L lower triangular with the sparsity of M), stored by rows over
  // the ancestor paths: row k of L is Lc[dof_row_offset[k] .. + dof_depth[k]], its entries in
  // the columns dof_path (ascending), then the diagonal L(k, k), then zeros up to the next row
  // (Model::kFactorRowPad). Dense L: tree_factor_dense().
  Eigen::VectorXd Lc;
  Eigen::VectorXd Ld_inv;     // (nv) 1 / L(k, k): the solves multiply, keeping divisions off their critical paths
  bool L_ok = false;
  Eigen::VectorXd tmp_v;      // (nv) scratch
};


// X_WF with its origin taken relative to data.p_ref: the transform that carries spatial vectors of
// Data (taken at R) into frame F (X.inv_act, X.inv_act_force) and back.
inline Transform to_ref(const Data& data, const Transform& X_WF) { return Transform(X_WF.R, X_WF.p - data.p_ref); }

// Configuration integration: q_out = q (+) v*dt on the joint manifolds (exact on SO(3) x R^3 with
// body-frame velocity). q_out may alias q.
void integrate(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& v, double dt,
               Eigen::VectorXd& q_out);
// Time derivative of q in the embedding coordinates (quaternion rates) for a given v.
void q_derivative(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& v, Eigen::VectorXd& qdot);
// Renormalizes the quaternions of floating joints in place.
void normalize_configuration(const Model& model, Eigen::VectorXd& q);
// Returns false if any coordinate is NaN/Inf or a quaternion is far from unit length.
bool configuration_valid(const Model& model, const Eigen::VectorXd& q);

}  // namespace coopdyn
