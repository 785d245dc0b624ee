// `bodies` + `frames` + `constraints`: a tree of bodies closed by constraints.
#include <cmath>
#include <limits>

#include "service/scene/builder.h"
#include "service/scene/urdf_tree.h"

namespace coopdyn::scene_detail {

namespace {
// The plane a wheel rolls on and its friction coefficient (0: not given).
struct GroundSpec {
  Vec3 n = Vec3::UnitZ();
  Vec3 point = Vec3::Zero();
  double mu = 0.0;
  double rolling_resistance = 0.0;
};

// `ground: {normal: [nx, ny, nz], point: [x, y, z], mu: MU}`, each key optional (from `def`).
GroundSpec read_ground(const Ctx& c, const YAML::Node& g, const GroundSpec& def, const std::string& what) {
  if (!g.IsMap()) fail(c, g, what + " must be a mapping {normal, point, mu}");
  check_keys(c, g, {"normal", "point", "mu", "rolling_resistance"}, what);
  GroundSpec out = def;
  if (g["normal"]) {
    const Vec3 n = as_vec3(c, g["normal"], what + ".normal");
    const double len = n.norm();
    if (!(len >= 1e-9 && len <= 1e150)) fail(c, g["normal"], what + ": normal must be a nonzero vector");
    out.n = n / len;
  }
  if (g["point"]) out.point = as_vec3(c, g["point"], what + ".point");
  if (g["mu"]) {
    out.mu = as_double(c, g["mu"], what + ".mu");
    if (!(out.mu > 0)) fail(c, g["mu"], what + ": mu must be > 0 (leave it out for no friction coefficient)");
  }
  if (g["rolling_resistance"]) {
    out.rolling_resistance = as_double(c, g["rolling_resistance"], what + ".rolling_resistance");
    if (!(out.rolling_resistance >= 0 && out.rolling_resistance <= 0.1))
      fail(c, g["rolling_resistance"], what + ": rolling_resistance must be in [0, 0.1] (tires: 0.005-0.03)");
  }
  return out;
}

// The body `pn` names (-1: the world); an unknown one is an error at b's parent.
int parent_body(const Ctx& c, const Model& model, const YAML::Node& b, const std::string& pn, const std::string& what) {
  if (pn == "world") return -1;
  const int parent = model.body_index(pn);
  if (parent < 0) fail(c, b["parent"], what + ": unknown parent '" + pn + "' (parents must come first)");
  return parent;
}

// a robot's chain as a subtree (a mobile base with an arm), or its whole URDF tree (build_tree.cc)
void add_robot_body(Builder& B, const YAML::Node& b, const std::map<std::string, Robot>& robots) {
  const Ctx& c = B.c;
  ArmSpec s;
  s.node = YAML::Node(b);
  s.name = get_string(c, b, "name", "");
  if (s.name.empty()) fail(c, b, "robot body: missing 'name' (the prefix of its links and joints)");
  s.robot = find_robot(c, b, robots, "robot body '" + s.name + "'");
  const std::string pn = get_string(c, b, "parent", "world");
  const int parent = parent_body(c, B.sys.model, b, pn, "robot body '" + s.name + "'");
  if (s.robot->tree) return add_robot_tree(B, b, *s.robot, s.name, parent, pn);
  check_keys(c, b, {"name", "robot", "parent", "placement", "q", "v", "fixed_joints", "tool"}, "robot body");
  s.X_W_base = get_pose(c, b["placement"], "robot body '" + s.name + "'.placement");
  s.tool = get_pose(c, b["tool"], "robot body '" + s.name + "'.tool");
  parse_arm_joints(c, b, s);
  add_chain(B, s, parent, pn, false);
  add_joint_couplings(c, b, B.sys.model, placed_mimics(*s.robot, s.name), B.sys.constraints);
}

JointType read_joint_type(const Ctx& c, const YAML::Node& jn, const std::string& name) {
  const std::string t = get_string(c, jn, "type", "");
  if (t == "fixed") return JointType::kFixed;
  if (t == "revolute") return JointType::kRevolute;
  if (t == "prismatic") return JointType::kPrismatic;
  if (t == "revolute2") return JointType::kRevolute2;
  if (t == "floating") return JointType::kFloating;
  fail(c, jn["type"].IsDefined() ? jn["type"] : jn, "body '" + name + "': unknown joint type '" + t +
       "' (fixed, revolute, prismatic, revolute2, floating)");
}

// A body's `joint` entry (given, not null): its type, axes, name, flags and initial q, v.
void read_joint(const Ctx& c, const YAML::Node& jn, const std::string& name, Joint& j, std::vector<double>& jq,
                std::vector<double>& jv) {
  check_keys(c, jn, {"type", "axis", "axis2", "name", "pseudo", "q", "v", "armature", "damping", "friction", "tau_limit", "actuated", "target_limit"},
             "joint of '" + name + "'");
  j.type = read_joint_type(c, jn, name);
  if (jn["axis"]) j.axis = as_vec3(c, jn["axis"], "joint axis");
  if (jn["axis2"]) j.axis2 = as_vec3(c, jn["axis2"], "joint axis2");
  j.name = get_string(c, jn, "name", name);
  j.pseudo = get_bool(c, jn, "pseudo", false);
  j.armature = get_double(c, jn, "armature", 0.0, "joint");
  if (!(j.armature >= 0)) fail(c, jn["armature"], "body '" + name + "': armature must be >= 0");
  if (j.pseudo && j.type != JointType::kRevolute && j.type != JointType::kPrismatic)
    fail(c, jn, "body '" + name + "': a pseudo-joint must be revolute or prismatic");
  j.damping = get_joint_loss(c, jn, "damping", "body '" + name + "' joint");
  j.friction = get_joint_loss(c, jn, "friction", "body '" + name + "' joint");
  for (const char* key : {"damping", "friction"})
    if (jn[key] && (j.pseudo || (j.type != JointType::kRevolute && j.type != JointType::kPrismatic)))
      fail(c, jn[key], "body '" + name + "': " + key + " applies to a real revolute or prismatic joint");
  if (j.type == JointType::kFloating) {
    Eigen::VectorXd tmp(7);
    set_floating_q(tmp, 0, get_pose(c, jn["q"], "floating joint q"));
    jq.assign(tmp.data(), tmp.data() + 7);
    jv = jn["v"] ? as_list(c, jn["v"], 6, "joint v") : std::vector<double>(6, 0.0);
  } else {
    const int nq = joint_nq(j.type);
    if (jn["q"]) jq = jn["q"].IsSequence() ? as_list(c, jn["q"], nq, "joint q") : std::vector<double>{as_double(c, jn["q"], "joint q")};
    if (jn["v"]) jv = jn["v"].IsSequence() ? as_list(c, jn["v"], nq, "joint v") : std::vector<double>{as_double(c, jn["v"], "joint v")};
    if (static_cast<int>(jq.size()) > nq || static_cast<int>(jv.size()) > nq) fail(c, jn, "body '" + name + "': too many q/v values");
  }
}

// A floating joint (a vehicle's body, a free wheel) and a pseudo-joint (absent from the real
// structure) have no drive: unactuated (tau_limit 0) unless declared; any other joint is actuated
// unless `actuated: false` (a passive joint).
double joint_tau_limit(const Ctx& c, const YAML::Node& jn, const Joint& j, const std::string& name) {
  const bool by_default = j.type != JointType::kFloating && !j.pseudo;
  const bool actuated = get_bool(c, jn, "actuated", by_default);
  if (actuated && j.pseudo) fail(c, jn["actuated"], "body '" + name + "': a pseudo-joint cannot be actuated");
  if (!actuated && jn["tau_limit"])
    fail(c, jn["tau_limit"], "body '" + name + "': tau_limit on an unactuated joint (" +
                                 (j.type == JointType::kFloating ? "a floating joint needs 'actuated: true'" : "it is declared or pseudo") + ")");
  const double lim = actuated ? get_double(c, jn, "tau_limit", std::numeric_limits<double>::infinity(), "joint") : 0.0;
  if (!(lim >= 0)) fail(c, jn["tau_limit"], "body '" + name + "': tau_limit must be >= 0 (N*m or N; absent = no limit)");
  return lim;
}

// A pseudo-joint's lock target may be commanded (torque_command_t targets: a steer angle) within
// |target| <= target_limit (rad or m); absent (0): it holds the scene's q.
double joint_target_limit(const Ctx& c, const YAML::Node& jn, const Joint& j, const std::string& name) {
  if (!jn["target_limit"]) return 0.0;
  if (!j.pseudo) fail(c, jn["target_limit"], "body '" + name + "': target_limit applies to a pseudo-joint (its lock's commanded target)");
  const double target_lim = get_double(c, jn, "target_limit", 0.0, "joint");
  if (!(target_lim > 0) || !std::isfinite(target_lim))
    fail(c, jn["target_limit"], "body '" + name + "': target_limit must be > 0 and finite (rad or m)");
  return target_lim;
}

// a body with its joint (none: fixed to its parent) and the joint's reaction output
void add_plain_body(Builder& B, const YAML::Node& b) {
  const Ctx& c = B.c;
  Model& model = B.sys.model;
  check_keys(c, b, {"name", "parent", "placement", "joint", "mass", "com", "inertia", "accept_inertia"}, "body");
  const std::string name = get_string(c, b, "name", "");
  if (name.empty()) fail(c, b, "body: missing 'name'");
  const int parent = parent_body(c, model, b, get_string(c, b, "parent", "world"), "body '" + name + "'");
  const Transform X_PJ = get_pose(c, b["placement"], "body '" + name + "'.placement");
  const Inertia I = get_inertia(c, b, "body '" + name + "'");
  Joint j;
  std::vector<double> jq, jv;
  double lim = std::numeric_limits<double>::infinity(), target_lim = 0.0;
  const YAML::Node jn = b["joint"];
  if (!jn.IsDefined() || jn.IsNull()) {
    j.type = JointType::kFixed;
  } else {
    read_joint(c, jn, name, j, jq, jv);
    lim = joint_tau_limit(c, jn, j, name);
    target_lim = joint_target_limit(c, jn, j, name);
  }
  const int id = B.add(name, parent, X_PJ, j, I, jq, jv, lim, b);
  if (target_lim > 0) B.target_limits.emplace_back(model.bodies[id].joint.idx_v, target_lim);
  if (j.type != JointType::kFloating)  // a floating joint transmits nothing
    B.sys.wrenches.outputs.push_back(joint_output(j.name.empty() ? name : j.name, name,
                                                  parent >= 0 ? model.bodies[parent].name : "world", id, false, id,
                                                  Transform(), bearing_mask(j.type, j.axis, j.axis2)));
}

// `frames`: named frames on bodies (or the world)
void add_frames(const Ctx& c, const YAML::Node& frames, Model& model) {
  for (const auto& f : frames) {
    check_keys(c, f, {"name", "body", "xyz", "rpy", "quat", "R"}, "frame");
    const std::string fname = get_string(c, f, "name", "");
    const std::string bname = get_string(c, f, "body", "world");
    int body = -1;
    if (bname != "world") {
      body = model.body_index(bname);
      if (body < 0) fail(c, f, "frame '" + fname + "': unknown body '" + bname + "'");
    }
    const Transform X = read_pose_fields(c, f, "frame '" + fname + "'");
    try {
      model.add_frame(fname, body, X);
    } catch (const std::invalid_argument& e) {
      fail(c, f, e.what());
    }
  }
}

// A wheel's axle and radius, given, or read off the URDF of a body placed from a whole tree
// (build_tree.cc): the axis of its joint, the radius of its cylinder about that axis.
void read_wheel_geometry(const Builder& B, const YAML::Node& k, const std::string& bname, ConstraintSpec& s) {
  const Ctx& c = B.c;
  const auto u = B.urdf_links.find(bname);
  const std::string what = "constraint '" + s.name + "'";
  Vec3 axle;
  if (k["axle"] || u == B.urdf_links.end()) {
    axle = as_vec3(c, require(c, k, "axle", what), what + ".axle");
  } else if (!urdf_spin_axis(*u->second.first, u->second.second, &axle)) {
    fail(c, k, what + ": missing 'axle' (the URDF joint above link '" + u->second.second + "' does not move: give axle)");
  }
  const double axle_norm = axle.norm();  // inf when a component is near DBL_MAX (the square overflows)
  if (!(axle_norm >= 1e-9 && axle_norm <= 1e150))
    fail(c, k["axle"], what + ": axle must be a nonzero vector of norm at most 1e150");
  s.axle = axle.normalized();
  if (k["radius"] || u == B.urdf_links.end()) {
    s.radius = as_double(c, require(c, k, "radius", what), what + ".radius");
  } else {
    std::string why;
    s.radius = urdf_wheel_radius(*u->second.first, u->second.second, s.axle, &why);
    if (!(s.radius > 0)) fail(c, k, what + ": missing 'radius', and it cannot be read from the URDF: " + why);
  }
  if (!(s.radius > 0)) fail(c, k["radius"], what + ": radius must be > 0");
}

// a wheel rolling without slip on the ground (ConstraintKind::kRolling), into s
void read_rolling(const Builder& B, const YAML::Node& k, const GroundSpec& ground, ConstraintSpec& s) {
  const Ctx& c = B.c;
  for (const char* key : {"frame", "to", "axes", "target"})
    if (k[key]) fail(c, k[key], "constraint '" + s.name + "': '" + key + "' does not apply to a rolling wheel");
  s.kind = ConstraintKind::kRolling;
  const std::string bname = get_string(c, k, "body", "");
  s.body = B.sys.model.body_index(bname);
  if (s.body < 0) fail(c, k["body"].IsDefined() ? k["body"] : k, "constraint '" + s.name + "': unknown wheel body '" + bname + "'");
  if (s.name.empty()) s.name = bname;
  read_wheel_geometry(B, k, bname, s);
  if (k["compliance"]) {  // scalar or [x, y, z] of the contact frame (m/N)
    const YAML::Node cn = k["compliance"];
    std::vector<double> l = cn.IsScalar() ? std::vector<double>(3, as_double(c, cn, "compliance"))
                                          : as_list(c, cn, 3, "constraint '" + s.name + "'.compliance");
    for (int i = 0; i < 3; ++i) {
      if (l[i] < 0) fail(c, cn, "constraint '" + s.name + "': compliance must be >= 0");
      s.compliance[3 + i] = l[i];
    }
  }
  const GroundSpec g = k["ground"] ? read_ground(c, k["ground"], ground, "constraint '" + s.name + "'.ground") : ground;
  s.ground_n = g.n;
  s.ground_d = g.n.dot(g.point);
  s.mu = g.mu;
  s.rolling_resistance = g.rolling_resistance;
  const Formulation f = B.sys.options.formulation;
  if (s.rolling_resistance > 0 && f != Formulation::kMobilePlatform && f != Formulation::kClassic)
    fail(c, k, "constraint '" + s.name + "': rolling resistance is solved in the mobile_platform and classic "
               "formulations only (this scene is " + formulation_name(f) + ")");
  if (k["mu"]) {
    if (k["ground"] && k["ground"]["mu"]) fail(c, k["mu"], "constraint '" + s.name + "': 'mu' is given twice (also in its 'ground')");
    s.mu = as_double(c, k["mu"], "constraint '" + s.name + "'.mu");
    if (!(s.mu > 0)) fail(c, k["mu"], "constraint '" + s.name + "': mu must be > 0 (leave it out for no friction coefficient)");
  }
  s.axes = {{false, false, false, true, true, true}};
}

// a weld or point of frame `frame` to frame `to` (or the world), into s
void read_weld(const Ctx& c, const Model& model, const YAML::Node& k, const std::string& type, ConstraintSpec& s) {
  for (const char* key : {"body", "axle", "radius"})
    if (k[key]) fail(c, k[key], "constraint '" + s.name + "': '" + key + "' only applies to type rolling");
  if (type != "weld" && type != "point") fail(c, k, "constraint '" + s.name + "': unknown type '" + type + "' (weld, point, rolling)");
  const std::string fa = get_string(c, k, "frame", "");
  s.frame_a = model.frame_index(fa);
  if (s.frame_a < 0) fail(c, k["frame"].IsDefined() ? k["frame"] : k, "constraint '" + s.name + "': unknown frame '" + fa + "'");
  if (s.name.empty()) s.name = fa;
  const std::string to = get_string(c, k, "to", "world");
  if (to != "world") {
    s.frame_b = model.frame_index(to);
    if (s.frame_b < 0) fail(c, k["to"], "constraint '" + s.name + "': unknown frame '" + to + "'");
  }
  s.axes = type == "point" ? std::array<bool, 6>{{false, false, false, true, true, true}} : get_axes(c, k["axes"], "constraint '" + s.name + "'");
  s.compliance = get_compliance(c, k["compliance"], "constraint '" + s.name + "'.compliance");
  if (k["target"]) {
    if (s.frame_b >= 0) fail(c, k["target"], "constraint '" + s.name + "': 'target' only applies to welds to the world");
    s.X_WA_target = get_pose(c, k["target"], "constraint target");
  } else {
    s.X_WA_target.p.setConstant(std::numeric_limits<double>::quiet_NaN());  // read off q0 by the scene compiler
  }
}

// `constraints`: welds, points and rolling wheels on `ground`
void add_constraints(Builder& B, const YAML::Node& constraints, const GroundSpec& ground) {
  const Ctx& c = B.c;
  for (const auto& k : constraints) {
    check_keys(c, k, {"name", "type", "frame", "to", "axes", "target", "compliance", "body", "axle", "radius", "mu", "ground"},
               "constraint");
    ConstraintSpec s;
    s.name = get_string(c, k, "name", "");
    const std::string type = get_string(c, k, "type", "weld");
    if (type == "rolling")
      read_rolling(B, k, ground, s);
    else
      read_weld(c, B.sys.model, k, type, s);
    B.sys.constraints.specs.push_back(s);
  }
}

}  // namespace

void build_bodies(Builder& B, const YAML::Node& root, const std::map<std::string, Robot>& robots) {
  const Ctx& c = B.c;
  const YAML::Node bn = require(c, root, "bodies", "scene");
  if (!bn.IsSequence() || bn.size() == 0) fail(c, bn, "bodies must be a non-empty list");
  for (const auto& b : bn) {
    if (b.IsMap() && b["robot"])
      add_robot_body(B, b, robots);
    else
      add_plain_body(B, b);
  }
  if (root["frames"]) add_frames(c, root["frames"], B.sys.model);
  // the ground the wheels roll on: the scene's `ground` (default z = 0, no friction coefficient),
  // which a wheel's own `ground` overrides key by key
  GroundSpec ground;
  if (root["ground"]) ground = read_ground(c, root["ground"], ground, "ground");
  if (root["constraints"]) add_constraints(B, root["constraints"], ground);
}

}  // namespace coopdyn::scene_detail
