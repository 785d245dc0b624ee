#include "service/model/model.h"

#include <algorithm>

#include <stdexcept>

namespace coopdyn {

namespace {

PlacementRotation placement_rotation(const Mat3& R) {
  if (R == Mat3::Identity()) return PlacementRotation::kIdentity;
  if (R(0, 0) == 1.0 && R(0, 1) == 0.0 && R(0, 2) == 0.0 && R(1, 0) == 0.0 && R(2, 0) == 0.0)
    return PlacementRotation::kAboutX;
  return PlacementRotation::kGeneral;
}

}  // namespace

int joint_nq(JointType t) {
  switch (t) {
    case JointType::kFixed: return 0;
    case JointType::kRevolute:
    case JointType::kPrismatic: return 1;
    case JointType::kRevolute2: return 2;
    case JointType::kFloating: return 7;
  }
  return 0;
}

int joint_nv(JointType t) {
  switch (t) {
    case JointType::kFixed: return 0;
    case JointType::kRevolute:
    case JointType::kPrismatic: return 1;
    case JointType::kRevolute2: return 2;
    case JointType::kFloating: return 6;
  }
  return 0;
}

const char* joint_type_name(JointType t) {
  switch (t) {
    case JointType::kFixed: return "fixed";
    case JointType::kRevolute: return "revolute";
    case JointType::kPrismatic: return "prismatic";
    case JointType::kRevolute2: return "revolute2";
    case JointType::kFloating: return "floating";
  }
  return "?";
}

void Model::plan_elimination_steps() {
  const int n = static_cast<int>(dof_parent.size());
  std::vector<int> children(n, 0);
  for (int k = 0; k < n; ++k)
    if (dof_parent[k] >= 0) ++children[dof_parent[k]];
  std::vector<char> done(n, 0);
  dof_elim_steps.clear();
  for (int k : dof_elim_order) {
    if (done[k]) continue;
    const int j = dof_parent[k];
    const bool pair = j >= 0 && children[j] == 1;
    dof_elim_steps.emplace_back(k, pair ? j : -1);
    if (pair) done[j] = 1;
  }
}

int Model::add_body(const std::string& name, int parent, const Transform& X_PJ, Joint joint, const Inertia& I) {
  if (parent < -1 || parent >= nbodies()) throw std::invalid_argument("body '" + name + "': bad parent index");
  if (body_index(name) >= 0) throw std::invalid_argument("duplicate body name '" + name + "'");
  if (!(I.m >= 0.0) || !std::isfinite(I.m)) throw std::invalid_argument("body '" + name + "': mass must be >= 0");
  if (joint.name.empty()) joint.name = name;
  if (joint.type != JointType::kFixed && joint_index(joint.name) >= 0)
    throw std::invalid_argument("duplicate joint name '" + joint.name + "'");
  if (joint.type == JointType::kRevolute || joint.type == JointType::kPrismatic ||
      joint.type == JointType::kRevolute2) {
    if (!(joint.axis.norm() > 1e-9)) throw std::invalid_argument("joint '" + joint.name + "': zero axis");
    joint.axis.normalize();
    if (joint.type == JointType::kRevolute2) {
      if (!(joint.axis2.norm() > 1e-9)) throw std::invalid_argument("joint '" + joint.name + "': zero axis2");
      joint.axis2.normalize();
    }
  }
  if (joint.type == JointType::kRevolute && joint.axis.x() == 0.0 && joint.axis.y() == 0.0)
    joint.axis_z = joint.axis.z() > 0.0 ? 1 : -1;
  joint.nq = joint_nq(joint.type);
  joint.nv = joint_nv(joint.type);
  joint.idx_q = nq_;
  joint.idx_v = nv_;

  // DOF-level parent: nearest ancestor DOF
  int anc_dof = -1;
  for (int b = parent; b >= 0; b = bodies[b].parent) {
    if (bodies[b].joint.nv > 0) {
      anc_dof = bodies[b].joint.idx_v + bodies[b].joint.nv - 1;
      break;
    }
  }
  const int body_id = nbodies();
  for (int k = 0; k < joint.nv; ++k) {
    const int par = k == 0 ? anc_dof : nv_ + k - 1;
    std::vector<int> path;
    if (par >= 0) {
      path.assign(dof_path.begin() + dof_path_offset[par], dof_path.begin() + dof_path_offset[par] + dof_depth[par]);
      path.push_back(par);
    }
    dof_path_offset.push_back(static_cast<int>(dof_path.size()));
    dof_depth.push_back(static_cast<int>(path.size()));
    dof_path.insert(dof_path.end(), path.begin(), path.end());
    dof_row_offset.push_back(factor_size);
    factor_size += (static_cast<int>(path.size()) + kFactorRowPad) / kFactorRowPad * kFactorRowPad;
    dof_parent.push_back(par);
    dof_body.push_back(body_id);
    if (joint.pseudo) pseudo_dofs.push_back(nv_ + k);
  }
  // deepest DOFs first; DOFs of equal depth lie in different branches, so consecutive steps of a
  // leaves-to-root sweep in this order are independent and overlap in the processor
  dof_elim_order.resize(dof_depth.size());
  for (size_t k = 0; k < dof_elim_order.size(); ++k) dof_elim_order[k] = static_cast<int>(k);
  std::stable_sort(dof_elim_order.begin(), dof_elim_order.end(), [this](int a, int b) {
    return dof_depth[a] != dof_depth[b] ? dof_depth[a] > dof_depth[b] : a > b;
  });
  plan_elimination_steps();
  const std::string& jn = joint.name;
  switch (joint.type) {
    case JointType::kFixed: break;
    case JointType::kRevolute:
    case JointType::kPrismatic:
      q_names.push_back(jn);
      v_names.push_back(jn);
      break;
    case JointType::kRevolute2:
      for (const char* s : {".0", ".1"}) {
        q_names.push_back(jn + s);
        v_names.push_back(jn + s);
      }
      break;
    case JointType::kFloating:
      for (const char* s : {".x", ".y", ".z", ".qw", ".qx", ".qy", ".qz"}) q_names.push_back(jn + s);
      for (const char* s : {".wx", ".wy", ".wz", ".vx", ".vy", ".vz"}) v_names.push_back(jn + s);
      break;
  }
  nq_ += joint.nq;
  nv_ += joint.nv;
  bodies.push_back(Body{name, parent, X_PJ, joint, I, placement_rotation(X_PJ.R), X_PJ.p.isZero(0.0)});
  body_support.push_back(support_dofs(body_id));
  return body_id;
}

int Model::add_frame(const std::string& name, int body, const Transform& X_BF) {
  if (body < -1 || body >= nbodies()) throw std::invalid_argument("frame '" + name + "': bad body index");
  if (frame_index(name) >= 0) throw std::invalid_argument("duplicate frame name '" + name + "'");
  frames.push_back(Frame{name, body, X_BF});
  return static_cast<int>(frames.size()) - 1;
}

int Model::body_index(const std::string& name) const {
  for (int i = 0; i < nbodies(); ++i)
    if (bodies[i].name == name) return i;
  return -1;
}

int Model::frame_index(const std::string& name) const {
  for (size_t i = 0; i < frames.size(); ++i)
    if (frames[i].name == name) return static_cast<int>(i);
  return -1;
}

int Model::joint_index(const std::string& name) const {
  for (int i = 0; i < nbodies(); ++i)
    if (bodies[i].joint.type != JointType::kFixed && bodies[i].joint.name == name) return i;
  return -1;
}

bool Model::is_ancestor(int a, int b) const {
  for (int x = b; x >= 0; x = bodies[x].parent)
    if (x == a) return true;
  return false;
}

std::vector<int> Model::support_dofs(int body) const {
  std::vector<int> out;
  for (int b = body; b >= 0; b = bodies[b].parent)
    for (int k = bodies[b].joint.nv - 1; k >= 0; --k) out.push_back(bodies[b].joint.idx_v + k);
  std::vector<int> asc(out.rbegin(), out.rend());
  return asc;
}

Eigen::VectorXd Model::neutral() const {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(nq_);
  for (const Body& b : bodies)
    if (b.joint.type == JointType::kFloating) q[b.joint.idx_q + 3] = 1.0;
  return q;
}

Data::Data(const Model& model) {
  const int nb = model.nbodies(), nv = model.nv();
  X_WB.resize(nb);
  S_W.setZero(6, nv);
  V_W.assign(nb, Vec6::Zero());
  A0_W.assign(nb, Vec6::Zero());
  sin_q.setZero(nv);
  cos_q.setZero(nv);
  for (int i = 0; i < nb; ++i) I_B.push_back(RigidInertia(model.bodies[i].inertia));
  I_Bm = I_B;
  for (int i = nb - 1; i >= 0; --i) {  // children come after their parents: chains of welds fold up
    const Body& b = model.bodies[i];
    if (b.joint.type != JointType::kFixed || b.parent < 0) continue;
    I_Bm[b.parent] += I_Bm[i].transformed(b.X_PJ);
  }
  I_Bw = I_Bm;
  for (int i = 0; i < nb; ++i)
    if (model.bodies[i].joint.type == JointType::kFixed && model.bodies[i].parent >= 0) I_Bm[i] = RigidInertia();
  has_inertia.assign(nb, 0);
  for (int i = 0; i < nb; ++i)
    has_inertia[i] = I_Bm[i].m != 0.0 || !I_Bm[i].h.isZero(0.0) || !I_Bm[i].Io.isZero(0.0);
  I_W.assign(nb, RigidInertia());  // entries of bodies without inertia stay zero
  Ic_W = I_W;
  f_W.assign(nb, Vec6::Zero());
  a_W.assign(nb, Vec6::Zero());
  f.assign(nb, Vec6::Zero());
  h.setZero(nv);
  M.setZero(nv, nv);
  Lc.setZero(model.factor_size);
  Mc = Lc;
  Ld_inv.setZero(nv);
  tmp_v.setZero(nv);
}

void integrate(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& v, double dt,
               Eigen::VectorXd& q_out) {
  for (const Body& b : model.bodies) {
    const Joint& j = b.joint;
    switch (j.type) {
      case JointType::kFixed: break;
      case JointType::kRevolute:
      case JointType::kPrismatic: q_out[j.idx_q] = q[j.idx_q] + dt * v[j.idx_v]; break;
      case JointType::kRevolute2:
        q_out[j.idx_q] = q[j.idx_q] + dt * v[j.idx_v];
        q_out[j.idx_q + 1] = q[j.idx_q + 1] + dt * v[j.idx_v + 1];
        break;
      case JointType::kFloating: {
        // exact exponential on SE(3) with constant body twist [w; v]
        const Vec3 w = v.segment<3>(j.idx_v) * dt, u = v.segment<3>(j.idx_v + 3) * dt;
        const Quat quat(q[j.idx_q + 3], q[j.idx_q + 4], q[j.idx_q + 5], q[j.idx_q + 6]);
        const Mat3 R = quat.normalized().toRotationMatrix();
        const double th2 = w.squaredNorm(), th = std::sqrt(th2);
        double b1, b2;  // (1-cos)/th^2, (th - sin)/th^3
        if (th < 1e-4) {
          b1 = 0.5 - th2 / 24.0;
          b2 = 1.0 / 6.0 - th2 / 120.0;
        } else {
          b1 = (1.0 - std::cos(th)) / th2;
          b2 = (th - std::sin(th)) / (th2 * th);
        }
        const Mat3 W = skew(w);
        const Vec3 dp = u + b1 * W * u + b2 * W * W * u;  // V(w) u, left Jacobian of SO(3)
        const Vec3 p_new = q.segment<3>(j.idx_q) + R * dp;
        Quat dq;
        if (th < 1e-12) dq = Quat::Identity();
        else dq = Quat(Eigen::AngleAxisd(th, w / th));
        Quat qn = (quat * dq).normalized();
        q_out.segment<3>(j.idx_q) = p_new;
        q_out[j.idx_q + 3] = qn.w();
        q_out[j.idx_q + 4] = qn.x();
        q_out[j.idx_q + 5] = qn.y();
        q_out[j.idx_q + 6] = qn.z();
        break;
      }
    }
  }
}

void q_derivative(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& v, Eigen::VectorXd& qdot) {
  for (const Body& b : model.bodies) {
    const Joint& j = b.joint;
    switch (j.type) {
      case JointType::kFixed: break;
      case JointType::kRevolute:
      case JointType::kPrismatic: qdot[j.idx_q] = v[j.idx_v]; break;
      case JointType::kRevolute2:
        qdot[j.idx_q] = v[j.idx_v];
        qdot[j.idx_q + 1] = v[j.idx_v + 1];
        break;
      case JointType::kFloating: {
        const Quat quat(q[j.idx_q + 3], q[j.idx_q + 4], q[j.idx_q + 5], q[j.idx_q + 6]);
        const Vec3 w = v.segment<3>(j.idx_v);
        qdot.segment<3>(j.idx_q) = quat.toRotationMatrix() * v.segment<3>(j.idx_v + 3);
        // qdot = 1/2 q (x) [0; w]
        const Quat wq(0.0, w.x(), w.y(), w.z());
        const Quat d = quat * wq;
        qdot[j.idx_q + 3] = 0.5 * d.w();
        qdot[j.idx_q + 4] = 0.5 * d.x();
        qdot[j.idx_q + 5] = 0.5 * d.y();
        qdot[j.idx_q + 6] = 0.5 * d.z();
        break;
      }
    }
  }
}

void normalize_configuration(const Model& model, Eigen::VectorXd& q) {
  for (const Body& b : model.bodies)
    if (b.joint.type == JointType::kFloating) {
      auto s = q.segment<4>(b.joint.idx_q + 3);
      const double n = s.norm();
      if (n > 0) s /= n;
    }
}

bool configuration_valid(const Model& model, const Eigen::VectorXd& q) {
  if (q.size() != model.nq() || !q.allFinite()) return false;
  for (const Body& b : model.bodies)
    if (b.joint.type == JointType::kFloating) {
      const double n = q.segment<4>(b.joint.idx_q + 3).norm();
      if (std::abs(n - 1.0) > 1e-3) return false;
    }
  return true;
}

}  // namespace coopdyn
