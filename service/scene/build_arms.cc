// `arms` (+ `load`): the paper's cooperating arms carrying a common load, or arms standing alone.
#include <cmath>
#include <limits>
#include <set>
#include <sstream>

#include "service/algorithms/kinematics.h"
#include "service/scene/builder.h"

namespace coopdyn::scene_detail {

// the end-effector (before the tool) in the robot base frame at the arm's q
Transform chain_forward(const ArmSpec& a) {
  Transform X;
  for (size_t i = 0; i < a.robot->joints.size(); ++i) X = X * a.robot->joints[i].X_origin * chain_motion(a.robot->joints[i], a.q[i]);
  return X * a.robot->X_last_EE;
}

const Robot* find_robot(const Ctx& c, const YAML::Node& n, const std::map<std::string, Robot>& robots, const std::string& what) {
  const std::string rn = get_string(c, n, "robot", "");
  auto it = robots.find(rn);
  if (it == robots.end())
    fail(c, n["robot"].IsDefined() ? n["robot"] : n, what + ": unknown robot '" + rn + "' (declare it under 'robots')");
  return &it->second;
}

void parse_arm_joints(const Ctx& c, const YAML::Node& a, ArmSpec& s) {
  const int n = static_cast<int>(s.robot->joints.size());
  int nm = 0;  // joints that can move (a URDF's own fixed joints take no q)
  for (const ChainJoint& cj : s.robot->joints) nm += cj.fixed ? 0 : 1;
  const std::vector<double> qm = as_list(c, require(c, a, "q", "arm '" + s.name + "'"), nm, "arm '" + s.name + "'.q");
  const std::vector<double> vm = a["v"] ? as_list(c, a["v"], nm, "arm '" + s.name + "'.v") : std::vector<double>(nm, 0.0);
  for (int i = 0, k = 0; i < n; ++i) {
    const ChainJoint& cj = s.robot->joints[i];
    const bool f = cj.fixed;
    s.q.push_back(f ? 0.0 : qm[k]);
    s.v.push_back(f ? 0.0 : vm[k]);
    if (!f) {
      const YAML::Node qk = a["q"][k];
      std::ostringstream os;
      os.precision(6);
      if (!cj.prismatic && std::abs(qm[k]) > 2 * M_PI + 1e-9)
        os << "arm '" << s.name << "' joint " << cj.name << " q = " << qm[k]
           << " rad is more than a full turn: joint values are radians (degrees?)";
      else if (qm[k] < cj.lower - 1e-9 || qm[k] > cj.upper + 1e-9)
        os << "arm '" << s.name << "' joint " << cj.name << " q = " << qm[k] << " is outside its limits [" << cj.lower
           << ", " << cj.upper << "] (" << cj.source << ")";
      if (os.tellp() > 0) warn(c, qk, os.str());
    }
    k += f ? 0 : 1;
  }
  if (a["fixed_joints"]) {
    for (double x : as_list(c, a["fixed_joints"], -1, "arm '" + s.name + "'.fixed_joints")) {
      const int k = static_cast<int>(x);
      if (k < 1 || k > n) fail(c, a["fixed_joints"], "arm '" + s.name + "': fixed joint " + std::to_string(k) + " out of range");
      s.fixed.insert(k);
    }
  }
}

int add_chain(Builder& B, const ArmSpec& s, int parent, const std::string& by_base, bool base_output) {
  Model& model = B.sys.model;
  std::vector<WrenchOutput>& outs = B.sys.wrenches.outputs;
  const auto& J = s.robot->joints;
  const int n = static_cast<int>(J.size());
  const int root = parent;
  for (int i = 1; i <= n; ++i) {
    const ChainJoint& cj = J[i - 1];
    Joint j;
    const bool held = cj.fixed || s.fixed.count(i);
    j.type = held ? JointType::kFixed : (cj.prismatic ? JointType::kPrismatic : JointType::kRevolute);
    j.axis = cj.axis;
    j.name = s.name + "." + cj.name;
    j.armature = cj.armature;
    j.damping = cj.damping;
    j.friction = cj.friction;
    Transform X_PJ = (i == 1 ? s.X_W_base : Transform()) * cj.X_origin;
    if (held) X_PJ = X_PJ * chain_motion(cj, s.q[i - 1]);
    parent = B.add(s.name + "." + cj.link_name, parent, X_PJ, j, cj.I, {s.q[i - 1]}, {s.v[i - 1]}, cj.tau_limit, s.node);
    B.set_limits(parent, cj.lower, cj.upper, cj.v_limit);
    const std::string by = i > 1 ? s.name + "." + J[i - 2].link_name : by_base;
    outs.push_back(joint_output(s.name + "." + cj.name, s.name + "." + cj.link_name, by, parent, false, parent,
                                Transform(), held ? 0x3f : bearing_mask(j.type, cj.axis, cj.axis)));
    if (i == 1) {
      model.add_frame(s.name + ".base", root, s.X_W_base);
      if (base_output) {  // the base wrench is the reaction at joint 1, in the base frame
        WrenchOutput o = joint_output(s.name + ".base", s.name + ".base", "world", parent, false, -1, s.X_W_base, 0x3f);
        o.kind = WrenchKind::kBase;
        outs.push_back(o);
      }
    }
  }
  model.add_frame(s.name + ".ee", parent, s.robot->X_last_EE * s.tool);
  return parent;
}

namespace {

// The scene's `load` (absent: the arms stand alone, and only the name "load" is used).
struct LoadSpec {
  explicit LoadSpec(const YAML::Node& n) : node(n) {}  // copied, not assigned: an absent load may be an invalid node
  YAML::Node node;
  bool given = false;
  bool pose_given = false;  // no `pose`: solved with the grasps (close_grasps)
  std::string name = "load";
  double tau_limit = 0;
  Inertia I;
  Transform X_W_L;
  std::vector<double> q = std::vector<double>(7, 0.0), v = std::vector<double>(6, 0.0);  // its floating joint's
};

LoadSpec read_load(const Ctx& c, const YAML::Node& root) {
  LoadSpec l(root["load"]);
  const YAML::Node& load = l.node;
  l.given = load.IsDefined() && !load.IsNull();
  if (!l.given) return l;
  check_keys(c, load, {"name", "mass", "com", "inertia", "accept_inertia", "pose", "velocity", "actuated"}, "load");
  l.name = get_string(c, load, "name", "load");
  // the platform DOFs of the load take no command force unless the scene declares a drive on it
  // (thrusters, a positioner): tau_limit 0 = a command must be exactly 0 there (Reject::kUnactuated)
  l.tau_limit = get_bool(c, load, "actuated", false) ? std::numeric_limits<double>::infinity() : 0.0;
  l.I = get_inertia(c, load, "load");
  l.pose_given = load["pose"].IsDefined() && !load["pose"].IsNull();
  if (l.pose_given) l.X_W_L = get_pose(c, load["pose"], "load.pose");
  return l;
}

// `arms`: each arm's robot, base, tool, joints, grasp and compliance
std::vector<ArmSpec> read_arms(const Ctx& c, const YAML::Node& root, const std::map<std::string, Robot>& robots, bool has_load) {
  std::vector<ArmSpec> arms;
  const YAML::Node an = require(c, root, "arms", "scene");
  if (!an.IsSequence() || an.size() == 0) fail(c, an, "arms must be a non-empty list");
  for (const auto& a : an) {
    check_keys(c, a, {"name", "robot", "base", "tool", "q", "v", "grasp", "fixed_joints", "compliance"}, "arm");
    ArmSpec s;
    s.node = YAML::Node(a);
    s.name = get_string(c, a, "name", "");
    if (s.name.empty()) fail(c, a, "arm: missing 'name'");
    s.robot = find_robot(c, a, robots, "arm '" + s.name + "'");
    s.X_W_base = get_pose(c, require(c, a, "base", "arm '" + s.name + "'"), "arm '" + s.name + "'.base");
    s.tool = get_pose(c, a["tool"], "arm '" + s.name + "'.tool");
    parse_arm_joints(c, a, s);
    const YAML::Node g = a["grasp"];
    if (g.IsDefined() && !g.IsNull() && !(g.IsScalar() && g.as<std::string>() == "at_initial_state")) {
      s.grasp_given = true;
      s.X_L_EE = get_pose(c, g, "arm '" + s.name + "'.grasp");
    }
    s.compliance = get_compliance(c, a["compliance"], "arm '" + s.name + "'.compliance");
    if (!has_load)
      for (const char* k : {"grasp", "compliance"})
        if (a[k]) fail(c, a[k], "arm '" + s.name + "': '" + k + "' needs a load (the scene has none: its arms' tips are free)");
    arms.push_back(s);
  }
  return arms;
}

// the arm's end-effector (with its tool) in the world at the arm's q
Transform ee_in_world(const ArmSpec& s) { return s.X_W_base * chain_forward(s) * s.tool; }

// The grasp's miss: the end-effector in its grasp frame on the load, [wx wy wz vx vy vz] (rad, m)
// in the end-effector frame; "wx 0.1 wy ..." in messages.
Vec6 grasp_miss(const Transform& X_W_grasp, const Transform& X_W_EE) { return pose_error(X_W_grasp.inverse() * X_W_EE); }
std::string per_axis(const Vec6& e) {
  static const char* const axis[6] = {"wx", "wy", "wz", "vx", "vy", "vz"};
  std::ostringstream os;
  os.precision(6);
  for (int k = 0; k < 6; ++k) os << (k ? " " : "") << axis[k] << " " << e[k];
  return os.str();
}

// close_initial_state: false (an explicit false; a keep list or true closes)
bool closing_off(const Ctx& c, const YAML::Node& root) {
  const YAML::Node ci = root["close_initial_state"];
  return ci.IsDefined() && ci.IsScalar() && !get_bool(c, root, "close_initial_state", true);
}

// Grasps: missing ones are read off the initial state; given ones are closed with the initial state
// later (close_initial_state on the built system, then close_grasps_check) unless closing is off,
// then they must close as given. Without a load pose, the load starts where the first arm's grasp
// puts it (every arm then needs a grasp pose).
void close_grasps(const Ctx& c, bool close, LoadSpec& load, std::vector<ArmSpec>& arms) {
  if (!load.pose_given) {
    for (const ArmSpec& s : arms)
      if (!s.grasp_given)
        fail(c, s.node["grasp"].IsDefined() ? s.node["grasp"] : s.node,
             "arm '" + s.name + "': grasp at_initial_state needs the load's 'pose' (without it the load pose is solved "
             "from the arms' grasps, so every arm needs a grasp pose)");
    load.X_W_L = ee_in_world(arms[0]) * arms[0].X_L_EE.inverse();
  }
  for (ArmSpec& s : arms) {
    const Transform X_W_EE = ee_in_world(s);
    if (!s.grasp_given) {
      s.X_L_EE = load.X_W_L.inverse() * X_W_EE;
      continue;
    }
    const Vec6 e = grasp_miss(load.X_W_L * s.X_L_EE, X_W_EE);
    if (!close && e.cwiseAbs().maxCoeff() > 1e-6) {
      std::ostringstream os;
      os << "initial state does not close: arm '" << s.name << "' end-effector misses its grasp on the load by "
         << e.tail<3>().norm() << " m and " << e.head<3>().norm() << " rad (" << per_axis(e)
         << "; close_initial_state: false)";
      fail(c, s.node, os.str());
    }
  }
}

// The load's floating-joint coordinates: its pose and `velocity` (zero when not given).
void read_load_coordinates(const Ctx& c, LoadSpec& load) {
  Eigen::VectorXd tmp(7);
  set_floating_q(tmp, 0, load.X_W_L);
  for (int k = 0; k < 7; ++k) load.q[k] = tmp[k];
  if (load.given && load.node["velocity"]) {
    auto l = as_list(c, load.node["velocity"], 6, "load.velocity");
    for (int k = 0; k < 6; ++k) load.v[k] = l[k];
  }
}

// Adds the load as a floating body at the root; returns its index. A given pose is held while the
// initial state is closed; a solved one is a coordinate the scene gave no value.
int add_load_body(Builder& B, const LoadSpec& load) {
  Joint jf;
  jf.type = JointType::kFloating;
  jf.name = load.name;
  const int L = B.add(load.name, -1, Transform(), jf, load.I, load.q, load.v, load.tau_limit, load.node);
  const Joint& j = B.sys.model.bodies[L].joint;
  if (load.pose_given)
    B.held_bodies.push_back(L);
  else
    for (int k = 0; k < j.nq; ++k) B.q_given[j.idx_q + k] = 0;
  B.load_body = L;
  return L;
}

// A wrench output of a weld spec (the last one added): a base's to the world, or an end-effector's
// across its grasp.
void add_weld_output(Builder& B, const std::string& name, const std::string& by, WrenchKind kind) {
  WrenchOutput o;
  o.name = o.frame = name;
  o.by = by;
  o.kind = kind;
  o.spec = static_cast<int>(B.sys.constraints.specs.size()) - 1;
  B.sys.wrenches.outputs.push_back(o);
}

// One arm hung from the load L last link first (the paper's (12)-(18)). Body B_k of the reversed
// chain is link k's frame moved to joint k+1 (link_k * X_origin_{k+1}), so that joint k+1
// reversed is a plain motion about -axis at the origin of its parent; the base is welded to the world.
void hang_arm_from_load(Builder& B, const ArmSpec& s, int L, const std::string& load_name) {
  Model& model = B.sys.model;
  ConstraintSet& cs = B.sys.constraints;
  std::vector<WrenchOutput>& outs = B.sys.wrenches.outputs;
  const auto& J = s.robot->joints;
  const int n = static_cast<int>(J.size());
  Joint fixed;
  fixed.type = JointType::kFixed;
  int parent = B.add(s.name + "." + J[n - 1].link_name, L, s.X_L_EE * s.tool.inverse() * s.robot->X_last_EE.inverse(),
                     fixed, J[n - 1].I, {}, {}, 0, s.node);
  // the end-effector wrench is the reaction across the grasp: the load is the tree parent of the
  // arm's last link, framed and named as the classic form's grasp weld
  model.add_frame(s.name + ".ee", parent, s.robot->X_last_EE * s.tool);
  model.add_frame(load_name + "." + s.name, L, s.X_L_EE);
  {
    WrenchOutput o = joint_output(s.name + ".ee", s.name + ".ee", load_name + "." + s.name, parent, false, parent,
                                  s.robot->X_last_EE * s.tool, 0x3f);
    o.kind = WrenchKind::kEndEffector;
    outs.push_back(o);
  }
  std::vector<WrenchOutput> arm_joints;
  int nominal_body = -1;  // the base link, when only its nominal inertia gives joint 1 a mass
  for (int i = n; i >= 1; --i) {
    const ChainJoint& cj = J[i - 1];
    const int link_i = parent;  // the tree parent of joint i reversed is link i's side
    Joint j;
    const bool held = cj.fixed || s.fixed.count(i);
    j.type = held ? JointType::kFixed : (cj.prismatic ? JointType::kPrismatic : JointType::kRevolute);
    j.axis = -cj.axis;
    j.name = s.name + "." + cj.name;
    j.armature = cj.armature;
    j.damping = cj.damping;
    j.friction = cj.friction;
    Transform X_PJ = i == n ? Transform() : J[i].X_origin.inverse();
    if (held) X_PJ = X_PJ * chain_motion(cj, -s.q[i - 1]);
    // the arm's base is welded to the world, so its inertia does no work; a nominal rotational
    // inertia (no mass, hence no weight) keeps M regular for the joint that moves only the base
    const Inertia I = i > 1 ? J[i - 2].I.transformed(cj.X_origin.inverse()) : Inertia(0.0, Vec3::Zero(), 1e-3 * Mat3::Identity());
    const std::string body = s.name + "." + (i > 1 ? J[i - 2].link_name : s.robot->base_link);
    parent = B.add(body, parent, X_PJ, j, I, {s.q[i - 1]}, {s.v[i - 1]}, cj.tau_limit, s.node);
    B.set_limits(parent, cj.lower, cj.upper, cj.v_limit);  // the same coordinate (axis and motion reversed)
    if (i == 1 && !held && cj.armature == 0.0) nominal_body = parent;
    // the reaction of link i-1 on link i is the tree's reaction negated, framed in link i: the
    // joint frame of the reversed joint (X_PJ without a held joint's motion)
    arm_joints.push_back(joint_output(s.name + "." + cj.name, s.name + "." + cj.link_name, body, parent, true, link_i,
                                      i == n ? Transform() : J[i].X_origin.inverse(),
                                      held ? 0x3f : bearing_mask(j.type, cj.axis, cj.axis)));
  }
  outs.insert(outs.end(), arm_joints.rbegin(), arm_joints.rend());  // in the robot's order, as classic
  model.add_frame(s.name + ".base", parent, J[0].X_origin.inverse());
  ConstraintSpec w;
  w.name = s.name + ".base";
  w.kind = ConstraintKind::kWeld;
  w.frame_a = model.frame_index(s.name + ".base");
  w.frame_b = -1;
  w.X_WA_target = s.X_W_base;
  w.compliance = s.compliance;
  cs.specs.push_back(w);
  if (nominal_body >= 0) B.sys.nominal_bases.push_back({nominal_body, static_cast<int>(cs.specs.size()) - 1});
  add_weld_output(B, s.name + ".base", "world", WrenchKind::kBase);
}

// The classic form's grasp: the arm's end-effector welded to its grasp frame on the load L.
void weld_arm_to_load(Builder& B, const ArmSpec& s, int L, const std::string& load_name) {
  Model& model = B.sys.model;
  model.add_frame(load_name + "." + s.name, L, s.X_L_EE);
  ConstraintSpec w;
  w.name = s.name + ".ee";
  w.kind = ConstraintKind::kWeld;
  w.frame_a = model.frame_index(s.name + ".ee");
  w.frame_b = model.frame_index(load_name + "." + s.name);
  w.compliance = s.compliance;
  B.sys.constraints.specs.push_back(w);
  add_weld_output(B, s.name + ".ee", load_name + "." + s.name, WrenchKind::kEndEffector);
}

}  // namespace

void build_arms(Builder& B, const YAML::Node& root, const std::map<std::string, Robot>& robots, bool mobile_platform) {
  const Ctx& c = B.c;
  // without a load the arms stand alone, rooted at the world with free tips (a single arm on a
  // bench): no platform, no grasp rows; their base and joint reactions are still reported
  LoadSpec load = read_load(c, root);
  if (!load.given) mobile_platform = false;
  std::vector<ArmSpec> arms = read_arms(c, root, robots, load.given);
  if (load.given) close_grasps(c, !closing_off(c, root), load, arms);
  read_load_coordinates(c, load);
  if (mobile_platform) {
    // the load is the root; each arm hangs from it
    const int L = add_load_body(B, load);
    for (const ArmSpec& s : arms) hang_arm_from_load(B, s, L, load.name);
    B.arms = arms;
  } else {
    for (const ArmSpec& s : arms) add_chain(B, s, -1, s.name + "." + s.robot->base_link, true);
    if (load.given) {
      const int L = add_load_body(B, load);
      for (const ArmSpec& s : arms) weld_arm_to_load(B, s, L, load.name);
      B.arms = arms;
    }
  }
  // a URDF's <mimic>s: the arm's joints coupled (reversed joints keep their coordinates)
  for (const ArmSpec& s : arms) add_joint_couplings(c, s.node, B.sys.model, placed_mimics(*s.robot, s.name), B.sys.constraints);
}

namespace {
// the arm's joint values in q (a held joint keeps its given value)
void arm_q_from(const Model& model, const Eigen::VectorXd& q, ArmSpec& s) {
  for (size_t i = 0; i < s.robot->joints.size(); ++i) {
    const int b = model.joint_index(s.name + "." + s.robot->joints[i].name);
    if (b >= 0 && model.bodies[b].joint.nq == 1) s.q[i] = q[model.bodies[b].joint.idx_q];
  }
}

// a joint the closing moved outside its limits: a warning at its `q` entry
void warn_closed_limits(const Ctx& c, const ArmSpec& given, const ArmSpec& s) {
  for (size_t i = 0, k = 0; i < s.robot->joints.size(); ++i) {
    const ChainJoint& cj = s.robot->joints[i];
    if (cj.fixed) continue;
    const YAML::Node& n = given.node;
    const YAML::Node qk = n["q"][k++];
    if (std::abs(s.q[i] - given.q[i]) <= 1e-12 || (s.q[i] >= cj.lower - 1e-9 && s.q[i] <= cj.upper + 1e-9)) continue;
    std::ostringstream os;
    os.precision(6);
    os << "arm '" << s.name << "' joint " << cj.name << " q = " << s.q[i] << " (closed from " << given.q[i]
       << ") is outside its limits [" << cj.lower << ", " << cj.upper << "] (" << cj.source << ")";
    warn(c, qk, os.str());
  }
}
}  // namespace

void close_grasps_check(Builder& B, const Eigen::VectorXd& q, bool closed) {
  if (B.arms.empty() || B.load_body < 0) return;
  const Model& model = B.sys.model;
  Data d(model);
  forward_kinematics(model, d, q, Eigen::VectorXd::Zero(model.nv()));
  const std::string load_name = model.bodies[B.load_body].name;
  std::vector<std::pair<const ArmSpec*, Vec6>> missed;
  size_t worst = 0;
  for (const ArmSpec& given : B.arms) {
    ArmSpec s = given;
    arm_q_from(model, q, s);
    const Vec6 e = grasp_miss(frame_pose(model, d, model.frame_index(load_name + "." + s.name)), ee_in_world(s));
    if (closed) warn_closed_limits(B.c, given, s);
    if (e.cwiseAbs().maxCoeff() <= 1e-6) continue;
    if (!missed.empty() && e.cwiseAbs().maxCoeff() > missed[worst].second.cwiseAbs().maxCoeff()) worst = missed.size();
    missed.emplace_back(&given, e);
  }
  if (missed.empty()) return;
  // the error is at the grasp that misses most; the others that miss are named in it
  const ArmSpec& w = *missed[worst].first;
  std::string msg = "arm '" + w.name + "' cannot reach its grasp (close_initial_state could not close the initial state): " +
                    "at the closest state found its end-effector misses the grasp by " + per_axis(missed[worst].second) +
                    " (rad, m; in the end-effector frame)";
  for (size_t k = 0; k < missed.size(); ++k)
    if (k != worst) msg += "; arm '" + missed[k].first->name + "' misses by " + per_axis(missed[k].second);
  const YAML::Node g = w.node["grasp"];
  fail(B.c, g.IsDefined() ? g : w.node, msg);
}

}  // namespace coopdyn::scene_detail
