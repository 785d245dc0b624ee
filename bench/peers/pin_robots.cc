// An independent reference for coopdyn's scenes of whole robots holding a load: Pinocchio's own
// URDF reader (urdfdom underneath, as coopdyn) and its algorithms, nothing of coopdyn's code.
//
//   pin_robots PROBLEM_FILE        (written by bench/peers/pin_robots_compare.py)
//
// The problem file, one item per line (lengths in m, angles in rad, quaternions w x y z):
//   gravity gx gy gz
//   robot PREFIX URDF fixed|floating x y z qw qx qy qz    a URDF's whole tree; fixed: its root link at
//                                   that placement in the world; floating: a free-flyer named PREFIX
//   body NAME mass cx cy cz ixx iyy izz ixy ixz iyz      a rigid body on a free-flyer NAME (inertia about
//                                   the centre of mass c, in the body frame)
//   weld NAME FRAME_A BODY_B at_state | x y z qw qx qy qz
//                                   6D weld of frame A (PREFIX.link) to a frame on B (a body or a
//                                   PREFIX.link), given in B's frame or taken where the state puts A
//   point NAME FRAME_A radius       a wheel at v = 0: a 3D point contact at the lowest point of the
//                                   wheel (centre - radius * world z), fixed to A's body
//   nomimic                         ignore the URDFs' <mimic> couplings
//   q N name value ...   v N name value ...   tau N name value ...   (coopdyn's names and order)
// Coordinates: PREFIX.<joint> for a URDF joint; a free-flyer NAME has NAME.x NAME.y NAME.z NAME.qw
// NAME.qx NAME.qy NAME.qz and NAME.wx .. NAME.wz NAME.vx .. NAME.vz (coopdyn: q = [p; qw qx qy qz],
// v = [w; v] of the body in its own frame; Pinocchio: q = [p; qx qy qz qw], v = [v; w] LOCAL).
// A continuous joint is cos/sin in Pinocchio. A <mimic> joint absent from the coordinates follows
// its leader (q = m q_leader + o, zero torque); present, it has its own torque. Either way the
// coupling is one more constraint row (Pinocchio's constrained algorithms refuse mimic joints).
//
// Two solutions are printed:
//   KKT:  M vdot + h = tau + G' lambda, G vdot = gamma, with Pinocchio's crba, nonLinearEffects,
//         frame Jacobians (LOCAL) and frame accelerations at vdot = 0 (the drift), lambda the
//         minimum-norm solution of (G M^-1 G') lambda = gamma - G M^-1 (tau - h) (a complete
//         orthogonal decomposition: redundant wheel contacts have many); mimic rows included.
//   PIN:  pinocchio::constraintDynamics with one RigidConstraintModel per weld (CONTACT_6D, LOCAL)
//         and per point (CONTACT_3D, LOCAL_WORLD_ALIGNED), ProximalSettings(1e-14, mu, 200),
//         without the mimic rows; printed with the KKT solution without mimic rows beside it, as a
//         check of the KKT assembly.
// Output lines: "vdot NAME value" (coopdyn's v order, KKT with mimic), "wrench NAME mx my mz fx fy fz"
// (B's wrench on A at A's origin in A's frame, coopdyn's [moment; force]; a point: the ground's force
// on the wheel in world axes, zero moment), "frame NAME p R" (A in the world, to check the frame maps),
// "check ..." lines.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "pinocchio/algorithm/constrained-dynamics.hpp"
#include "pinocchio/algorithm/contact-info.hpp"
#include "pinocchio/algorithm/crba.hpp"
#include "pinocchio/algorithm/frames.hpp"
#include "pinocchio/algorithm/jacobian.hpp"
#include "pinocchio/algorithm/joint-configuration.hpp"
#include "pinocchio/algorithm/kinematics.hpp"
#include "pinocchio/algorithm/model.hpp"
#include "pinocchio/algorithm/proximal.hpp"
#include "pinocchio/algorithm/rnea.hpp"
#include "pinocchio/multibody/data.hpp"
#include "pinocchio/multibody/model.hpp"
#include "pinocchio/parsers/urdf.hpp"

#include <Eigen/QR>
#include <urdf_parser/urdf_parser.h>

namespace pin = pinocchio;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

[[noreturn]] void die(const std::string& msg) {
  std::fprintf(stderr, "pin_robots: %s\n", msg.c_str());
  std::exit(2);
}

pin::SE3 read_pose(std::istream& in) {
  double x, y, z, qw, qx, qy, qz;
  if (!(in >> x >> y >> z >> qw >> qx >> qy >> qz)) die("a pose needs x y z qw qx qy qz");
  Eigen::Quaterniond Q(qw, qx, qy, qz);
  return pin::SE3(Q.normalized().toRotationMatrix(), Eigen::Vector3d(x, y, z));
}

struct Weld { std::string name, a, b; bool at_state = true; pin::SE3 bMc; };
struct Point { std::string name, a; double radius = 0; };
struct Mimic { std::string follower, leader; double m, o; };
struct Coords { std::vector<std::string> names; std::vector<double> values; };

struct Problem {
  Eigen::Vector3d gravity{0, 0, -9.81};
  pin::Model model;
  std::vector<std::string> free_flyers;  // Pinocchio joint names of free-flyers (robots and bodies)
  std::vector<Weld> welds;
  std::vector<Point> points;
  std::vector<Mimic> mimics;
  bool use_mimic = true;
  Coords q, v, tau;
};

// Prefix every joint and frame name of m (but the universe) with "PREFIX.".
void prefix_names(pin::Model& m, const std::string& prefix) {
  for (size_t j = 1; j < m.names.size(); ++j) m.names[j] = prefix + "." + m.names[j];
  for (size_t f = 1; f < m.frames.size(); ++f) m.frames[f].name = prefix + "." + m.frames[f].name;
}

void add_robot(Problem& P, std::istream& in) {
  std::string prefix, urdf, root;
  if (!(in >> prefix >> urdf >> root)) die("robot PREFIX URDF fixed|floating POSE");
  const pin::SE3 X = read_pose(in);
  pin::Model m;
  if (root == "floating") {
    pin::urdf::buildModel(urdf, pin::JointModelFreeFlyer(), m);
    prefix_names(m, prefix);
    m.names[1] = prefix;  // the free-flyer: coordinates PREFIX.x ...
    for (auto& f : m.frames)
      if (f.type == pin::JOINT && f.parentJoint == 1) f.name = prefix;
    P.free_flyers.push_back(prefix);
  } else if (root == "fixed") {
    pin::urdf::buildModel(urdf, m);
    prefix_names(m, prefix);
  } else {
    die("robot " + prefix + ": root must be fixed or floating, not " + root);
  }
  // The links on fixed joints are already folded into their joint's inertia; their frames keep a
  // copy, which Pinocchio 3.7.0's appendModel takes out of the joint as it stands in the frame
  // (no placement) and puts back placed: the joint gains m d^2 (PR2's laser_tilt_link: 9e-7 kg m^2).
  // The frames' copies are dropped before appending.
  for (auto& f : m.frames) f.inertia = pin::Inertia::Zero();
  P.model = pin::appendModel(P.model, m, 0, root == "fixed" ? X : pin::SE3::Identity());
  const auto tree = urdf::parseURDFFile(urdf);
  if (!tree) die("urdfdom cannot read " + urdf);
  for (const auto& [name, joint] : tree->joints_)
    if (joint->mimic)
      P.mimics.push_back({prefix + "." + name, prefix + "." + joint->mimic->joint_name,
                          joint->mimic->multiplier, joint->mimic->offset});
}

void add_body(Problem& P, std::istream& in) {
  std::string name;
  double mass, c[3], I[6];
  if (!(in >> name >> mass >> c[0] >> c[1] >> c[2] >> I[0] >> I[1] >> I[2] >> I[3] >> I[4] >> I[5]))
    die("body NAME mass cx cy cz ixx iyy izz ixy ixz iyz");
  Eigen::Matrix3d J;
  J << I[0], I[3], I[4], I[3], I[1], I[5], I[4], I[5], I[2];
  const auto j = P.model.addJoint(0, pin::JointModelFreeFlyer(), pin::SE3::Identity(), name);
  P.model.appendBodyToJoint(j, pin::Inertia(mass, Eigen::Vector3d(c[0], c[1], c[2]), J));
  const auto jf = P.model.addJointFrame(j);
  P.model.addBodyFrame(name, j, pin::SE3::Identity(), (int)jf);
  P.free_flyers.push_back(name);
}

void read_coords(std::istream& in, Coords& c) {
  int n;
  if (!(in >> n) || n < 0) die("q/v/tau N name value ...");
  c.names.resize(n);
  c.values.resize(n);
  for (int i = 0; i < n; ++i)
    if (!(in >> c.names[i] >> c.values[i])) die("q/v/tau: " + std::to_string(n) + " name value pairs");
}

Problem read_problem(const char* path) {
  std::ifstream file(path);
  if (!file) die(std::string("cannot read ") + path);
  Problem P;
  std::string line;
  while (std::getline(file, line)) {
    std::istringstream in(line);
    std::string key;
    if (!(in >> key) || key[0] == '#') continue;
    if (key == "gravity") {
      in >> P.gravity[0] >> P.gravity[1] >> P.gravity[2];
    } else if (key == "robot") {
      add_robot(P, in);
    } else if (key == "body") {
      add_body(P, in);
    } else if (key == "weld") {
      Weld w;
      std::string how;
      in >> w.name >> w.a >> w.b >> how;
      if (how != "at_state") {
        std::istringstream rest(how + " " + std::string(std::istreambuf_iterator<char>(in), {}));
        w.bMc = read_pose(rest);
        w.at_state = false;
      }
      P.welds.push_back(w);
    } else if (key == "point") {
      Point p;
      if (!(in >> p.name >> p.a >> p.radius)) die("point NAME FRAME radius");
      P.points.push_back(p);
    } else if (key == "nomimic") {
      P.use_mimic = false;
    } else if (key == "q" || key == "v" || key == "tau") {
      read_coords(in, key == "q" ? P.q : key == "v" ? P.v : P.tau);
    } else {
      die("unknown line: " + line);
    }
  }
  P.model.gravity = pin::Motion(P.gravity, Eigen::Vector3d::Zero());
  return P;
}

// coopdyn coordinate name -> (Pinocchio index, kind): kind 0 plain, 1 continuous (cos, sin).
struct Map {
  std::map<std::string, int> q_idx, v_idx;
  std::map<std::string, bool> continuous;
};

Map coordinate_map(const Problem& P) {
  const pin::Model& m = P.model;
  Map M;
  static const char* fq[7] = {"x", "y", "z", "qx", "qy", "qz", "qw"};  // Pinocchio's order
  static const char* fv[6] = {"vx", "vy", "vz", "wx", "wy", "wz"};
  for (pin::JointIndex j = 1; j < (pin::JointIndex)m.njoints; ++j) {
    const std::string& n = m.names[j];
    const int iq = m.idx_qs[j], iv = m.idx_vs[j], nq = m.nqs[j], nv = m.nvs[j];
    if (nq == 7 && nv == 6) {
      for (int k = 0; k < 7; ++k) M.q_idx[n + "." + fq[k]] = iq + k;
      for (int k = 0; k < 6; ++k) M.v_idx[n + "." + fv[k]] = iv + k;
    } else if (nv == 1) {
      M.q_idx[n] = iq;
      M.v_idx[n] = iv;
      M.continuous[n] = (nq == 2);
    } else {
      die("joint " + n + ": only 1-DOF joints and free-flyers are mapped");
    }
  }
  return M;
}

const Mimic* mimic_of(const Problem& P, const std::string& joint) {
  for (const Mimic& mm : P.mimics)
    if (mm.follower == joint) return &mm;
  return nullptr;
}

// Pinocchio q, v, tau from coopdyn's named values; followers of a <mimic> absent from them follow.
void fill_state(const Problem& P, const Map& M, VectorXd& q, VectorXd& v, VectorXd& tau) {
  const pin::Model& m = P.model;
  q = pin::neutral(m);
  v = VectorXd::Zero(m.nv);
  tau = VectorXd::Zero(m.nv);
  std::map<std::string, double> angle, rate;
  for (size_t i = 0; i < P.q.names.size(); ++i) {
    const std::string& n = P.q.names[i];
    const double x = P.q.values[i];
    auto it = M.q_idx.find(n);
    if (it == M.q_idx.end()) die("coopdyn coordinate " + n + " has no Pinocchio joint");
    angle[n] = x;
    if (M.continuous.count(n) && M.continuous.at(n)) {
      q[it->second] = std::cos(x);
      q[it->second + 1] = std::sin(x);
    } else {
      q[it->second] = x;  // a free-flyer's components land by name (qw last in Pinocchio)
    }
  }
  for (size_t i = 0; i < P.v.names.size(); ++i) {
    auto it = M.v_idx.find(P.v.names[i]);
    if (it == M.v_idx.end()) die("coopdyn velocity " + P.v.names[i] + " has no Pinocchio joint");
    v[it->second] = P.v.values[i];
    rate[P.v.names[i]] = P.v.values[i];
  }
  for (size_t i = 0; i < P.tau.names.size(); ++i) {
    auto it = M.v_idx.find(P.tau.names[i]);
    if (it == M.v_idx.end()) die("coopdyn torque " + P.tau.names[i] + " has no Pinocchio joint");
    tau[it->second] = P.tau.values[i];
  }
  for (const auto& [name, iv] : M.v_idx) {  // coordinates coopdyn does not have
    if (rate.count(name)) continue;
    const Mimic* mm = P.use_mimic ? mimic_of(P, name) : nullptr;
    if (!mm || !angle.count(mm->leader))
      die("Pinocchio coordinate " + name + " is not among coopdyn's (and follows no <mimic> leader there)");
    const double x = mm->m * angle.at(mm->leader) + mm->o;
    const int iq = M.q_idx.at(name);
    if (M.continuous.at(name)) {
      q[iq] = std::cos(x);
      q[iq + 1] = std::sin(x);
    } else {
      q[iq] = x;
    }
    v[iv] = mm->m * rate.at(mm->leader);
  }
}

}  // namespace

namespace {

struct Rows {
  MatrixXd G;            // constraint rows, nc x nv
  VectorXd gamma;        // G vdot = gamma
  std::vector<int> start, size;  // per weld, then per point, then the mimic rows
};

// A link's frame (BODY) first; then an operational frame, a fixed joint's, a joint's.
pin::FrameIndex frame_of(const pin::Model& m, const std::string& name) {
  for (const pin::FrameType t : {pin::BODY, pin::OP_FRAME, pin::FIXED_JOINT, pin::JOINT, pin::SENSOR})
    if (m.existFrame(name, t)) return m.getFrameId(name, t);
  die("no frame " + name + " in the Pinocchio model");
}

// Adds, for every weld and point, Pinocchio frames for its two sides (A at the link frame, C on B),
// placed at the state for at_state welds and points; returns the frame ids (A, C) per item.
std::vector<std::pair<pin::FrameIndex, pin::FrameIndex>> add_frames(Problem& P, const VectorXd& q) {
  pin::Data d(P.model);
  pin::framesForwardKinematics(P.model, d, q);
  std::vector<std::pair<pin::FrameIndex, pin::FrameIndex>> ids;
  std::vector<pin::Frame> extra;
  for (const Weld& w : P.welds) {
    const pin::FrameIndex a = frame_of(P.model, w.a), b = frame_of(P.model, w.b);
    const pin::SE3 bMc = w.at_state ? d.oMf[b].actInv(d.oMf[a]) : w.bMc;
    const pin::Frame& B = P.model.frames[b];
    extra.emplace_back(w.name + ".B", B.parentJoint, b, B.placement * bMc, pin::OP_FRAME);
    ids.emplace_back(a, 0);
  }
  for (const Point& p : P.points) {
    const pin::FrameIndex a = frame_of(P.model, p.a);
    const Eigen::Vector3d P_W = d.oMf[a].translation() - p.radius * Eigen::Vector3d::UnitZ();
    const pin::Frame& A = P.model.frames[a];
    const pin::SE3 oMa = d.oMf[a];
    const pin::SE3 aMp(oMa.rotation().transpose(), oMa.rotation().transpose() * (P_W - oMa.translation()));
    extra.emplace_back(p.name + ".P", A.parentJoint, a, A.placement * aMp, pin::OP_FRAME);
    ids.emplace_back(0, 0);
  }
  size_t k = 0;
  for (pin::Frame& f : extra) {
    const pin::FrameIndex id = P.model.addFrame(f);
    if (k < P.welds.size()) ids[k].second = id; else ids[k].first = id;
    ++k;
  }
  return ids;
}

Rows constraint_rows(const Problem& P, pin::Data& d, const std::vector<std::pair<pin::FrameIndex, pin::FrameIndex>>& ids,
                     const Map& M, const VectorXd& q, const VectorXd& v, bool with_mimic) {
  const pin::Model& m = P.model;
  const int nv = m.nv;
  std::vector<const Mimic*> mimic_rows;
  if (with_mimic)
    for (const Mimic& mm : P.mimics)
      if (M.v_idx.count(mm.follower) && M.v_idx.count(mm.leader)) mimic_rows.push_back(&mm);
  const int nc = 6 * (int)P.welds.size() + 3 * (int)P.points.size() + (int)mimic_rows.size();
  Rows R;
  R.G = MatrixXd::Zero(nc, nv);
  R.gamma = VectorXd::Zero(nc);
  pin::forwardKinematics(m, d, q, v, VectorXd::Zero(nv));
  pin::computeJointJacobians(m, d, q);
  pin::updateFramePlacements(m, d);
  int r = 0;
  for (size_t i = 0; i < P.welds.size(); ++i) {
    const auto [a, c] = ids[i];
    MatrixXd Ja = MatrixXd::Zero(6, nv), Jc = MatrixXd::Zero(6, nv);
    pin::getFrameJacobian(m, d, a, pin::LOCAL, Ja);
    pin::getFrameJacobian(m, d, c, pin::LOCAL, Jc);
    const pin::SE3 aMc = d.oMf[a].actInv(d.oMf[c]);
    R.G.middleRows(r, 6) = Ja - aMc.toActionMatrix() * Jc;
    const pin::Motion va = pin::getFrameVelocity(m, d, a, pin::LOCAL);
    const pin::Motion vc = aMc.act(pin::getFrameVelocity(m, d, c, pin::LOCAL));
    const pin::Motion aa = pin::getFrameAcceleration(m, d, a, pin::LOCAL);
    const pin::Motion ac = aMc.act(pin::getFrameAcceleration(m, d, c, pin::LOCAL));
    R.gamma.segment(r, 6) = -(aa - ac + va.cross(vc)).toVector();
    R.start.push_back(r);
    R.size.push_back(6);
    r += 6;
  }
  for (size_t i = 0; i < P.points.size(); ++i) {
    const pin::FrameIndex p = ids[P.welds.size() + i].first;
    MatrixXd Jp = MatrixXd::Zero(6, nv);
    pin::getFrameJacobian(m, d, p, pin::LOCAL_WORLD_ALIGNED, Jp);
    R.G.middleRows(r, 3) = Jp.topRows(3);
    R.gamma.segment(r, 3) = -pin::getFrameClassicalAcceleration(m, d, p, pin::LOCAL_WORLD_ALIGNED).linear();
    R.start.push_back(r);
    R.size.push_back(3);
    r += 3;
  }
  for (const Mimic* mm : mimic_rows) {
    R.G(r, M.v_idx.at(mm->follower)) = 1;
    R.G(r, M.v_idx.at(mm->leader)) = -mm->m;
    R.start.push_back(r);
    R.size.push_back(1);
    ++r;
  }
  return R;
}

// The KKT system by the Schur complement, lambda of minimum norm.
void solve_kkt(const pin::Model& m, pin::Data& d, const Rows& R, const VectorXd& q, const VectorXd& v,
               const VectorXd& tau, VectorXd& vdot, VectorXd& lambda) {
  pin::crba(m, d, q, pin::Convention::WORLD);
  MatrixXd Mq = d.M;
  Mq.triangularView<Eigen::StrictlyLower>() = Mq.transpose().triangularView<Eigen::StrictlyLower>();
  const VectorXd h = pin::nonLinearEffects(m, d, q, v);
  const Eigen::LLT<MatrixXd> llt(Mq);
  const VectorXd a0 = llt.solve(tau - h);
  if (R.G.rows() == 0) {  // nothing closed: the tree's own dynamics
    vdot = a0;
    lambda.resize(0);
    return;
  }
  const MatrixXd MiGt = llt.solve(R.G.transpose());
  const MatrixXd K = R.G * MiGt;
  Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod(K);
  cod.setThreshold(1e-12);
  lambda = cod.solve(R.gamma - R.G * a0);
  vdot = a0 + MiGt * lambda;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) die("usage: pin_robots PROBLEM_FILE");
  Problem P = read_problem(argv[1]);
  const Map M = coordinate_map(P);
  VectorXd q, v, tau;
  fill_state(P, M, q, v, tau);
  const auto ids = add_frames(P, q);
  const pin::Model& m = P.model;
  pin::Data d(m);
  std::printf("check model nq %d nv %d, %zu welds, %zu points, %zu <mimic> couplings%s\n", m.nq, m.nv,
              P.welds.size(), P.points.size(), P.mimics.size(), P.use_mimic ? "" : " (ignored)");

  // Reference: KKT with the mimic rows.
  const Rows R = constraint_rows(P, d, ids, M, q, v, P.use_mimic);
  VectorXd vdot, lambda;
  solve_kkt(m, d, R, q, v, tau, vdot, lambda);
  const double res = (R.G * vdot - R.gamma).norm();
  std::printf("check KKT rows %d, constraint residual |G vdot - gamma| = %.3e\n", (int)R.G.rows(), res);
  for (size_t i = 0; i < P.welds.size(); ++i) {  // closure of the welds at this state
    const pin::SE3 err = d.oMf[ids[i].first].actInv(d.oMf[ids[i].second]);
    std::printf("check weld %s closure: position %.3e m, rotation %.3e rad\n", P.welds[i].name.c_str(),
                err.translation().norm(), pin::log3(err.rotation()).norm());
  }
  for (size_t i = 0; i < P.v.names.size(); ++i)
    std::printf("vdot %s %.17g\n", P.v.names[i].c_str(), vdot[M.v_idx.at(P.v.names[i])]);
  for (size_t i = 0; i < P.welds.size(); ++i) {
    const VectorXd f = lambda.segment(R.start[i], 6);  // Pinocchio [f; n] on A in A
    const pin::SE3& X = d.oMf[ids[i].first];
    std::printf("wrench %s %.17g %.17g %.17g %.17g %.17g %.17g\n", P.welds[i].name.c_str(), f[3], f[4], f[5],
                f[0], f[1], f[2]);
    std::printf("frame %s %.17g %.17g %.17g", P.welds[i].name.c_str(), X.translation()[0], X.translation()[1],
                X.translation()[2]);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) std::printf(" %.17g", X.rotation()(r, c));
    std::printf("\n");
  }
  for (size_t i = 0; i < P.points.size(); ++i) {
    const VectorXd f = lambda.segment(R.start[P.welds.size() + i], 3);
    std::printf("wrench %s 0 0 0 %.17g %.17g %.17g\n", P.points[i].name.c_str(), f[0], f[1], f[2]);
  }

  // Check of the KKT assembly: constraintDynamics against the KKT, both without the mimic rows.
  pin::context::RigidConstraintModelVector cm;
  for (size_t i = 0; i < P.welds.size(); ++i) {
    const pin::Frame& A = m.frames[ids[i].first];
    const pin::Frame& C = m.frames[ids[i].second];
    cm.emplace_back(pin::CONTACT_6D, m, A.parentJoint, A.placement, C.parentJoint, C.placement, pin::LOCAL);
  }
  for (size_t i = 0; i < P.points.size(); ++i) {
    const pin::Frame& A = m.frames[ids[P.welds.size() + i].first];
    pin::framesForwardKinematics(m, d, q);
    cm.emplace_back(pin::CONTACT_3D, m, A.parentJoint, A.placement, 0, d.oMf[ids[P.welds.size() + i].first],
                    pin::LOCAL_WORLD_ALIGNED);
  }
  if (cm.empty()) {
    std::printf("check constraintDynamics: no constraint, not run\n");
    return 0;
  }
  pin::context::RigidConstraintDataVector cd;
  for (const auto& c : cm) cd.emplace_back(c);
  const bool redundant = !P.points.empty();
  pin::ProximalSettings settings(1e-14, redundant ? 1e-8 : 0.0, redundant ? 2000 : 200);
  pin::initConstraintDynamics(m, d, cm);
  const VectorXd a_pin = pin::constraintDynamics(m, d, q, v, tau, cm, cd, settings);
  const VectorXd lambda_pin = d.lambda_c;
  pin::Data d2(m);
  const Rows R0 = constraint_rows(P, d2, ids, M, q, v, false);
  VectorXd vdot0, lambda0;
  solve_kkt(m, d2, R0, q, v, tau, vdot0, lambda0);
  double dl = 0, lmax = 1e-300;
  for (size_t i = 0; i < P.welds.size(); ++i) {
    dl = std::max(dl, (lambda_pin.segment(6 * i, 6) - lambda0.segment(R0.start[i], 6)).cwiseAbs().maxCoeff());
    lmax = std::max(lmax, lambda0.segment(R0.start[i], 6).cwiseAbs().maxCoeff());
  }
  std::printf("check constraintDynamics vs KKT without <mimic> rows: max |vdot diff| %.3e (max |vdot| %.3e), "
              "max |weld wrench diff| %.3e (max %.3e), proximal iterations %d%s\n",
              (a_pin - vdot0).cwiseAbs().maxCoeff(), vdot0.cwiseAbs().maxCoeff(), dl, lmax, settings.iter,
              redundant ? " (point contacts: mu 1e-8)" : "");
  return 0;
}
