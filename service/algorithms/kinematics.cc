#include "service/algorithms/kinematics.h"

#include <cmath>

namespace coopdyn {

// Spatial vectors are handled here as pairs of 3-vectors, [angular; linear], and stored and reloaded
// as such: assembling a 6-vector from two 3-vector halves and reading it back in 2-element packets
// defeats the processor's store-to-load forwarding, which cost more than the arithmetic.
namespace {

// One body's pass: its joint frame in the world X_WJ, its pose X_WB, and its velocity V = [Vw; Vv]
// and velocity-product acceleration A0 = [Aw; Av], started from the parent's and kept in registers
// until stored. p_ref is the point R (body 0 sets it at its own origin before anything uses it).
struct BodyPass {
  // X_WJ = [J0 J1 J2 | Jp], by columns: 3-vectors the compiler keeps in registers. Held as a
  // Transform, X_WJ lived on the stack, written entry by entry (the placement rotation) and read
  // back by 2-wide column loads that spanned two stores: a missed store-to-load forwarding on the
  // chain of poses at every body (the same arithmetic; the kinematics 25-28% slower).
  Vec3 J0, J1, J2, Jp;
  Mat3 R_WJ() const {
    Mat3 R;
    R.col(0) = J0;
    R.col(1) = J1;
    R.col(2) = J2;
    return R;
  }
  Transform X_WJ() const { return Transform(R_WJ(), Jp); }
  Transform& X_WB;
  Vec3 Vw, Vv, Aw, Av;
  Vec3& p_ref;
  Eigen::Matrix<double, 6, Eigen::Dynamic>& S_W;
  bool is_root;

  // a point relative to R
  Vec3 rel(const Vec3& p_W) const { return p_W - p_ref; }
  void pose_set() {
    if (is_root) p_ref = X_WB.p;
  }
  void set_column(int col, const Vec3& sw, const Vec3& sv) {
    S_W.col(col).head<3>() = sw;
    S_W.col(col).tail<3>() = sv;
  }
  // adds a joint velocity [jw; jv] (world, at R) and its velocity-product term V x vJ
  void add_joint_motion(const Vec3& jw, const Vec3& jv) {
    Vw += jw;
    Vv += jv;
    Aw += Vw.cross(jw);
    Av += Vw.cross(jv) + Vv.cross(jw);
  }
};

// R_WJ = R_WP R_PJ into s.J0..J2, without the products by the exact zeros of R_PJ's form
// (Body::placement_rotation): each remaining entry the sum of the remaining products in the order
// of the full product, so the same bits (up to the sign of an entry that is exactly zero); each
// column built whole, so that it is stored and read back whole
inline void joint_frame_rotation(const Mat3& R_WP, const Body& b, BodyPass& s) {
  const Mat3& R_PJ = b.X_PJ.R;
  switch (b.placement_rotation) {
    case PlacementRotation::kIdentity:
      s.J0 = R_WP.col(0);
      s.J1 = R_WP.col(1);
      s.J2 = R_WP.col(2);
      return;
    case PlacementRotation::kAboutX: {
      s.J0 = R_WP.col(0);
      const Vec3 a1 = R_WP.col(1), a2 = R_WP.col(2);
      const double c11 = R_PJ(1, 1), c21 = R_PJ(2, 1), c12 = R_PJ(1, 2), c22 = R_PJ(2, 2);
      s.J1 = Vec3(std::fma(a2.x(), c21, a1.x() * c11), std::fma(a2.y(), c21, a1.y() * c11), std::fma(a2.z(), c21, a1.z() * c11));
      s.J2 = Vec3(std::fma(a2.x(), c22, a1.x() * c12), std::fma(a2.y(), c22, a1.y() * c12), std::fma(a2.z(), c22, a1.z() * c12));
      return;
    }
    case PlacementRotation::kGeneral: {
      Mat3 R;
      R.noalias() = R_WP * R_PJ;
      s.J0 = R.col(0);
      s.J1 = R.col(1);
      s.J2 = R.col(2);
      return;
    }
  }
}

// X_WJ, V and A0 from the parent's (zero at a root)
void start_from_parent(const Data& data, const Body& b, BodyPass& s) {
  if (b.parent >= 0) {
    const Transform& X_WP = data.X_WB[b.parent];
    joint_frame_rotation(X_WP.R, b, s);
    if (b.placement_at_origin) {
      s.Jp = X_WP.p;
    } else {
      s.Jp.noalias() = X_WP.R * b.X_PJ.p;
      s.Jp += X_WP.p;
    }
    s.Vw = data.V_W[b.parent].head<3>();
    s.Vv = data.V_W[b.parent].tail<3>();
    s.Aw = data.A0_W[b.parent].head<3>();
    s.Av = data.A0_W[b.parent].tail<3>();
  } else {
    s.J0 = b.X_PJ.R.col(0);
    s.J1 = b.X_PJ.R.col(1);
    s.J2 = b.X_PJ.R.col(2);
    s.Jp = b.X_PJ.p;
    s.Vw.setZero();
    s.Vv.setZero();
    s.Aw.setZero();
    s.Av.setZero();
  }
}

inline void fixed_joint(BodyPass& s) {
  s.X_WB.R.col(0) = s.J0;
  s.X_WB.R.col(1) = s.J1;
  s.X_WB.R.col(2) = s.J2;
  s.X_WB.p = s.Jp;
  s.pose_set();
}

// sn, cs: the sine and cosine of the joint angle (joint_sines)
inline void revolute_joint(const Joint& j, double sn, double cs, double qd, BodyPass& s) {
  Transform& X_WB = s.X_WB;
  X_WB.p = s.Jp;
  Vec3 w;
  if (j.axis_z != 0) {
    // R_JB = Rz(+-q): two columns mix, the axis column stays
    const double sz = j.axis_z * sn;
    X_WB.R.col(0) = cs * s.J0 + sz * s.J1;
    X_WB.R.col(1) = cs * s.J1 - sz * s.J0;
    X_WB.R.col(2) = s.J2;
    w = j.axis_z > 0 ? Vec3(s.J2) : Vec3(-s.J2);
  } else {
    const Mat3 R_WJ = s.R_WJ();
    // Rodrigues with one sin/cos: R = c I + s [a]x + (1 - c) a a^T
    const Vec3& a = j.axis;
    const Vec3 t = (1.0 - cs) * a;
    Mat3 R_JB;
    R_JB << cs + t.x() * a.x(), t.x() * a.y() - sn * a.z(), t.x() * a.z() + sn * a.y(),
            t.y() * a.x() + sn * a.z(), cs + t.y() * a.y(), t.y() * a.z() - sn * a.x(),
            t.z() * a.x() - sn * a.y(), t.z() * a.y() + sn * a.x(), cs + t.z() * a.z();
    X_WB.R.noalias() = R_WJ * R_JB;
    w.noalias() = R_WJ * a;
  }
  s.pose_set();
  const Vec3 sv = s.rel(X_WB.p).cross(w);  // the line [w; p x w] through the joint
  s.set_column(j.idx_v, w, sv);
  s.add_joint_motion(w * qd, sv * qd);
}

inline void prismatic_joint(const Joint& j, double q, double qd, BodyPass& s) {
  const Mat3 R_WJ = s.R_WJ();
  const Vec3 a_W = R_WJ * j.axis;
  s.X_WB.R = R_WJ;
  s.X_WB.p = s.Jp + a_W * q;
  s.pose_set();
  s.set_column(j.idx_v, Vec3::Zero(), a_W);
  s.add_joint_motion(Vec3::Zero(), a_W * qd);
}

inline void revolute2_joint(const Joint& j, const Eigen::VectorXd& q, const Eigen::VectorXd& v, BodyPass& s) {
  const Transform X_WJ = s.X_WJ();
  Transform& X_WB = s.X_WB;
  const Mat3 R1 = Eigen::AngleAxisd(q[j.idx_q], j.axis).toRotationMatrix();
  const Mat3 R2 = Eigen::AngleAxisd(q[j.idx_q + 1], j.axis2).toRotationMatrix();
  const Mat3 R_W1 = X_WJ.R * R1;
  X_WB.R.noalias() = R_W1 * R2;
  X_WB.p = X_WJ.p;
  s.pose_set();
  const Vec3 a1 = X_WJ.R * j.axis, a2 = R_W1 * j.axis2;  // the second axis turns with the first
  const Vec3 l1 = s.rel(X_WB.p).cross(a1), l2 = s.rel(X_WB.p).cross(a2);
  s.set_column(j.idx_v, a1, l1);
  s.set_column(j.idx_v + 1, a2, l2);
  const double qd0 = v[j.idx_v], qd1 = v[j.idx_v + 1];
  s.add_joint_motion(a1 * qd0 + a2 * qd1, l1 * qd0 + l2 * qd1);
  // S' qdot: the second axis is carried by the first rotation
  const Vec3 c = qd0 * qd1 * a1.cross(a2);
  s.Aw += c;
  s.Av += s.rel(X_WB.p).cross(c);
}

inline void floating_joint(const Joint& j, const Eigen::VectorXd& q, const Eigen::VectorXd& v, BodyPass& s) {
  const Transform X_WJ = s.X_WJ();
  Transform& X_WB = s.X_WB;
  const Quat quat(q[j.idx_q + 3], q[j.idx_q + 4], q[j.idx_q + 5], q[j.idx_q + 6]);
  const Mat3 R_JB = quat.normalized().toRotationMatrix();
  X_WB.R.noalias() = X_WJ.R * R_JB;
  X_WB.p = X_WJ.p + X_WJ.R * q.segment<3>(j.idx_q);
  s.pose_set();
  // v = V_B in B: columns [R e_k; p x R e_k] (rotations) and [0; R e_k] (translations)
  Vec3 jw = Vec3::Zero(), jv = Vec3::Zero();
  for (int k = 0; k < 3; ++k) {
    const Vec3 e = X_WB.R.col(k);
    const Vec3 l = s.rel(X_WB.p).cross(e);
    s.set_column(j.idx_v + k, e, l);
    s.set_column(j.idx_v + 3 + k, Vec3::Zero(), e);
    jw += e * v[j.idx_v + k];
    jv += l * v[j.idx_v + k] + e * v[j.idx_v + 3 + k];
  }
  s.add_joint_motion(jw, jv);
}

// V, A0 and the world inertia of the body, from the pass
void store_body_motion(Data& data, int i, const BodyPass& s) {
  data.V_W[i].head<3>() = s.Vw;
  data.V_W[i].tail<3>() = s.Vv;
  data.A0_W[i].head<3>() = s.Aw;
  data.A0_W[i].tail<3>() = s.Av;
  if (data.has_inertia[i]) data.I_Bm[i].transform_into(s.X_WB.R, s.rel(s.X_WB.p), data.I_W[i]);
}

}  // namespace

namespace {

// body i's pass (its parent's entries current); p_ref: the reference point (body 0 sets it)
inline void body_kinematics(const Model& model, Data& data, const Eigen::VectorXd& q, const Eigen::VectorXd& v, int i,
                            Vec3& p_ref) {
  const Body& b = model.bodies[i];
  const Joint& j = b.joint;
  BodyPass s{Vec3(), Vec3(), Vec3(), Vec3(), data.X_WB[i], Vec3(), Vec3(), Vec3(), Vec3(), p_ref, data.S_W, i == 0};
  start_from_parent(data, b, s);
  switch (j.type) {
    case JointType::kFixed: fixed_joint(s); break;
    case JointType::kRevolute: revolute_joint(j, data.sin_q[j.idx_v], data.cos_q[j.idx_v], v[j.idx_v], s); break;
    case JointType::kPrismatic: prismatic_joint(j, q[j.idx_q], v[j.idx_v], s); break;
    case JointType::kRevolute2: revolute2_joint(j, q, v, s); break;
    case JointType::kFloating: floating_joint(j, q, v, s); break;
  }
  store_body_motion(data, i, s);
}

// The sine and cosine of every revolute joint in the subtree of body root (0: all), taken before the
// pass over the bodies: the calls then run back to back, off the chain of poses, and the pass makes
// no call that would spill its registers. The same calls as inside the pass: bit for bit the same
// rotations.
void joint_sines(const Model& model, Data& data, const Eigen::VectorXd& q, int root) {
  for (int i = root; i < model.nbodies(); ++i) {
    const Joint& j = model.bodies[i].joint;
    if (j.type != JointType::kRevolute || (root > 0 && !model.is_ancestor(root, i))) continue;
    const double a = q[j.idx_q];
    data.sin_q[j.idx_v] = std::sin(a);
    data.cos_q[j.idx_v] = std::cos(a);
  }
}

}  // namespace

void forward_kinematics(const Model& model, Data& data, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  const int nb = model.nbodies();
  joint_sines(model, data, q, 0);
  Vec3 p_ref = Vec3::Zero();  // kept in a register; stored in data.p_ref at the end
  for (int i = 0; i < nb; ++i) body_kinematics(model, data, q, v, i, p_ref);
  data.p_ref = p_ref;
}

void forward_kinematics_subtree(const Model& model, Data& data, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                                int root) {
  if (root <= 0) return forward_kinematics(model, data, q, v);
  Vec3 p_ref = data.p_ref;
  joint_sines(model, data, q, root);
  for (int i = root; i < model.nbodies(); ++i)
    if (model.is_ancestor(root, i)) body_kinematics(model, data, q, v, i, p_ref);
}

Transform frame_pose(const Model& model, const Data& data, int frame) {
  const Frame& F = model.frames[frame];
  return F.body >= 0 ? data.X_WB[F.body] * F.X_BF : F.X_BF;
}

Vec6 frame_velocity(const Model& model, const Data& data, int frame) {
  const Frame& F = model.frames[frame];
  return F.body >= 0 ? to_ref(data, frame_pose(model, data, frame)).inv_act(data.V_W[F.body]) : Vec6::Zero();
}

Vec6 frame_bias_acceleration(const Model& model, const Data& data, int frame) {
  const Frame& F = model.frames[frame];
  return F.body >= 0 ? to_ref(data, frame_pose(model, data, frame)).inv_act(data.A0_W[F.body]) : Vec6::Zero();
}

}  // namespace coopdyn
