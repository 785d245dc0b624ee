// A URDF's whole tree (urdf_tree.h) as a subtree of a `bodies` scene: a robot entry whose robot is
// declared without base and tip. Every link is a body and a frame PREFIX.<link>, every joint
// PREFIX.<joint> with its reaction; the root link is welded at `placement` (root: fixed) or free
// (root: floating, a 6-DOF joint named PREFIX).
#include <cmath>
#include <set>
#include <stdexcept>
#include <sstream>

#include "service/scene/builder.h"
#include "service/scene/urdf_tree.h"

namespace coopdyn::scene_detail {

namespace {

// A robot entry of `bodies` with a whole tree, as read.
struct TreeSpec {
  std::string name;  // the prefix
  const UrdfTree* t = nullptr;
  bool floating = false, planar = false;  // root: floating (6 DOF) or planar (x, y along the plane, a rotation about its normal)
  Transform X_P_root;              // the root link's pose in the parent (initial pose when floating)
  std::vector<double> root_v;      // floating root: its 6 velocity coordinates
  std::vector<double> q, v;        // per tree joint (0 for a fixed one)
  std::vector<unsigned char> q_given, v_given;
  std::set<int> held;              // tree joints held fixed (fixed_joints, and the followers of a held or fixed leader)
  Transform tool;                  // an unbranched tree's PREFIX.ee frame on its last link
  std::vector<UrdfMimic> couplings;  // the <mimic>s between moving joints, as rows (URDF joint names)
};

// the tree joint named jn (the URDF's name), -1 if none
int tree_joint(const UrdfTree& t, const std::string& jn) {
  for (size_t k = 0; k < t.joints.size(); ++k)
    if (t.joints[k].j.name == jn) return static_cast<int>(k);
  return -1;
}

std::string moving_joint_list(const UrdfTree& t) {
  std::string s;
  int n = 0;
  for (const UrdfTreeJoint& tj : t.joints)
    if (!tj.j.fixed && n++ < 12) s += (s.empty() ? "" : ", ") + tj.j.name;
  return n > 12 ? s + ", ... (" + std::to_string(n) + ")" : s;
}

// "" when the tree's moving joints lie on one chain (each below the one before: a list of values
// is then unambiguous), else which two do not
std::string off_chain(const UrdfTree& t) {
  std::map<std::string, int> above;  // link -> the joint above it
  for (size_t k = 0; k < t.joints.size(); ++k) above[t.joints[k].j.link_name] = static_cast<int>(k);
  int prev = -1;
  for (size_t k = 0; k < t.joints.size(); ++k) {
    if (t.joints[k].j.fixed) continue;
    bool below = prev < 0;
    for (auto it = above.find(t.joints[k].parent_link); !below && it != above.end(); it = above.find(t.joints[it->second].parent_link))
      below = it->second == prev;
    if (!below) return "joints '" + t.joints[prev].j.name + "' and '" + t.joints[k].j.name + "' are on different branches";
    prev = static_cast<int>(k);
  }
  return "";
}

// `q` or `v`: a mapping {URDF joint: value} (the others 0, not given), or, when the moving joints
// lie on one chain, a list over them in order (as a chain's)
void read_tree_values(const Ctx& c, const YAML::Node& n, const TreeSpec& s, const std::string& key,
                      std::vector<double>& out, std::vector<unsigned char>& given) {
  const UrdfTree& t = *s.t;
  const std::string what = "robot body '" + s.name + "'." + key;
  out.assign(t.joints.size(), 0.0);
  given.assign(t.joints.size(), 0);
  if (!n.IsDefined() || n.IsNull()) return;
  if (n.IsSequence()) {
    const std::string off = off_chain(t);
    if (!off.empty())
      fail(c, n, what + ": a list needs the moving joints on one chain, but " + off + ": give a mapping {joint: value} (joints: " +
                     moving_joint_list(t) + ")");
    int nm = 0;
    for (const UrdfTreeJoint& tj : t.joints) nm += tj.j.fixed ? 0 : 1;
    const std::vector<double> l = as_list(c, n, nm, what);
    for (size_t k = 0, i = 0; k < t.joints.size(); ++k)
      if (!t.joints[k].j.fixed) out[k] = l[i++], given[k] = 1;
    return;
  }
  if (!n.IsMap()) fail(c, n, what + " must be a mapping {joint: value} (the URDF's joint names)");
  for (const auto& kv : n) {
    const std::string jn = kv.first.IsScalar() ? kv.first.Scalar() : "";
    const int k = tree_joint(t, jn);
    if (k < 0)
      fail(c, kv.first, what + ": unknown joint '" + jn + "' (URDF " + t.file->path + "; its moving joints: " +
                            moving_joint_list(t) + ")");
    if (t.joints[k].j.fixed) fail(c, kv.first, what + ": joint '" + jn + "' is fixed in the URDF: it takes no value");
    if (given[k]) fail(c, kv.first, what + ": joint '" + jn + "' given twice");
    out[k] = as_double(c, kv.second, what + "." + jn);
    given[k] = 1;
  }
}

// the warnings a chain's q gets (parse_arm_joints): more than a full turn, outside the URDF limits
void warn_tree_values(const Ctx& c, const YAML::Node& qn, const TreeSpec& s) {
  for (size_t k = 0; k < s.t->joints.size(); ++k) {
    const ChainJoint& cj = s.t->joints[k].j;
    if (!s.q_given[k]) continue;
    const double q = s.q[k];
    std::ostringstream os;
    os.precision(6);
    if (!cj.prismatic && std::abs(q) > 2 * M_PI + 1e-9)
      os << "robot body '" << s.name << "' joint " << cj.name << " q = " << q << " rad is more than a full turn: joint values are radians (degrees?)";
    else if (q < cj.lower - 1e-9 || q > cj.upper + 1e-9)
      os << "robot body '" << s.name << "' joint " << cj.name << " q = " << q << " is outside its limits [" << cj.lower << ", "
         << cj.upper << "] (" << cj.source << ")";
    if (os.tellp() > 0) warn(c, qn.IsMap() && qn[cj.name] ? qn[cj.name] : qn, os.str());
  }
}

// `fixed_joints: [JOINT or joint number (1-based, the URDF's order), ...]`
void read_held(const Ctx& c, const YAML::Node& fj, TreeSpec& s) {
  if (!fj.IsDefined() || fj.IsNull()) return;
  if (!fj.IsSequence()) fail(c, fj, "robot body '" + s.name + "'.fixed_joints must be a list of joint names");
  for (const YAML::Node& x : fj) {
    const std::string jn = x.IsScalar() ? x.Scalar() : "";
    int k = tree_joint(*s.t, jn);
    if (k < 0 && !jn.empty() && jn.find_first_not_of("0123456789") == std::string::npos) k = std::stoi(jn.substr(0, 9)) - 1;
    if (k < 0 || k >= static_cast<int>(s.t->joints.size()))
      fail(c, x, "robot body '" + s.name + "'.fixed_joints: unknown joint '" + jn + "' (its moving joints: " +
                     moving_joint_list(*s.t) + ")");
    s.held.insert(k);
  }
}

// The file's <mimic>s read against what the scene moves: one between two moving joints is a
// coupling row; a follower of a joint held by fixed_joints is held with it, at m * q_leader + o; a
// follower of a joint the file makes fixed is held at m * 0 + o (a warning); a mimic of a joint the
// file lacks, or of a follower the file makes fixed, couples nothing (a warning: the follower moves
// on its own, or stays fixed). A follower held while its leader moves is an error (hold the leader).
void resolve_tree_mimics(const Ctx& c, const YAML::Node& b, TreeSpec& s) {
  const UrdfTree& t = *s.t;
  std::vector<UrdfMimic> pending = read_mimics(*t.file);
  for (bool changed = true; changed;) {  // a follower of a held follower is held in a later pass
    changed = false;
    for (auto it = pending.begin(); it != pending.end();) {
      const UrdfMimic& mm = *it;
      const int j = tree_joint(t, mm.joint), i = tree_joint(t, mm.mimicked);
      const std::string what = mm.source + ": joint '" + mm.joint + "' mimics '" + mm.mimicked + "'";
      bool done = true;
      if (j < 0 || t.joints[j].j.fixed) {
        warn(c, b, what + (j < 0 ? ", but the file has no joint of that name" : ", but the file makes it fixed") +
                       ": the mimic couples nothing");
      } else if (i < 0) {
        warn(c, b, what + ", which the file does not have: '" + mm.joint + "' moves on its own");
      } else if (t.joints[i].j.fixed || s.held.count(i)) {
        const double qi = t.joints[i].j.fixed ? 0.0 : s.q[i];
        const double qj = mm.multiplier * qi + mm.offset;
        if (s.q_given[j] && std::abs(s.q[j] - qj) > 1e-12 * (1 + std::abs(qj)))
          warn(c, b, what + ": its given q " + std::to_string(s.q[j]) + " is replaced by m * q_leader + o = " + std::to_string(qj));
        if (t.joints[i].j.fixed)
          warn(c, b, what + ", which the file makes fixed: '" + mm.joint + "' is held at m * 0 + o = " + std::to_string(qj));
        s.q[j] = qj;
        s.q_given[j] = 1;
        s.held.insert(j);
        changed = true;
      } else if (s.held.count(j)) {
        fail(c, b["fixed_joints"], "robot body '" + s.name + "'.fixed_joints holds '" + mm.joint + "', which mimics '" +
                                       mm.mimicked + "' (" + mm.source + "): hold its leader '" + mm.mimicked +
                                       "' instead (a leader held holds its followers)");
      } else {
        done = false;  // both move: a coupling row, unless its leader is held in a later pass
      }
      it = done ? pending.erase(it) : it + 1;
    }
  }
  s.couplings = pending;
}

TreeSpec read_tree_spec(const Ctx& c, const YAML::Node& b, const Robot& r, const std::string& name) {
  check_keys(c, b, {"name", "robot", "parent", "placement", "root", "root_v", "q", "v", "fixed_joints", "tool"}, "robot body");
  TreeSpec s;
  s.name = name;
  s.t = r.tree.get();
  // the default: the file's own free base joint (floating or planar), else fixed
  const std::string root = get_string(c, b, "root", s.t->root_joint.empty() ? "fixed" : s.t->root_joint);
  if (root != "fixed" && root != "floating" && root != "planar")
    fail(c, b["root"], "robot body '" + name + "': root must be fixed (welded at its placement), floating (a 6-DOF joint) "
                       "or planar (three coordinates in the plane of the URDF's planar joint)");
  if (root == "planar" && s.t->root_joint != "planar")
    fail(c, b["root"], "robot body '" + name + "': root: planar takes its plane from the URDF's planar root joint, which "
                       "this file does not have (use floating, or a `bodies` chain of joints)");
  s.floating = root == "floating";
  s.planar = root == "planar";
  // placement places the link above the file's free joint (its `world`); the joint's origin follows
  s.X_P_root = get_pose(c, b["placement"], "robot body '" + name + "'.placement") * s.t->X_above_root;
  if (b["root_v"] && !s.floating) fail(c, b["root_v"], "robot body '" + name + "': root_v applies to a floating root (root: floating)");
  s.root_v = b["root_v"] ? as_list(c, b["root_v"], 6, "robot body '" + name + "'.root_v") : std::vector<double>(6, 0.0);
  read_tree_values(c, b["q"], s, "q", s.q, s.q_given);
  read_tree_values(c, b["v"], s, "v", s.v, s.v_given);
  warn_tree_values(c, b["q"], s);
  read_held(c, b["fixed_joints"], s);
  resolve_tree_mimics(c, b, s);
  if (b["tool"] && !s.t->branch_link.empty())
    fail(c, b["tool"], "robot body '" + name + "': tool applies to a chain's end-effector; the URDF branches below '" +
                           s.t->branch_link + "' (name a link frame '" + name + ".<link>' or add one under 'frames')");
  s.tool = get_pose(c, b["tool"], "robot body '" + name + "'.tool");
  return s;
}

// The tree's couplings (resolve_tree_mimics): each q_j = m q_i + o appended as a constraint row on
// the joints the model now has as PREFIX.<joint> (a loop of mimics: an error there).
void tree_mimics(const Ctx& c, const YAML::Node& where, const TreeSpec& s, const std::string& prefix, Builder& B) {
  std::vector<UrdfMimic> m = s.couplings;
  for (UrdfMimic& x : m) {
    x.joint = prefix + "." + x.joint;
    x.mimicked = prefix + "." + x.mimicked;
  }
  add_joint_couplings(c, where, B.sys.model, m, B.sys.constraints);
}

}  // namespace

void add_robot_tree(Builder& B, const YAML::Node& b, const Robot& r, const std::string& name, int parent, const std::string& by) {
  const Ctx& c = B.c;
  Model& model = B.sys.model;
  std::vector<WrenchOutput>& outs = B.sys.wrenches.outputs;
  const TreeSpec s = read_tree_spec(c, b, r, name);
  const UrdfTree& t = *s.t;
  // the root link: welded at its placement, or on a floating joint whose q is the placement
  if (s.planar) {  // two massless carriages along the plane, the root link turning about its normal
    const Vec3 n = t.root_normal;
    const Vec3 e1 = (std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(n).cross(n).normalized() * -1.0;
    const Vec3 e2 = n.cross(e1);
    int at = parent;
    for (const auto& [suffix, axis] : {std::pair<const char*, Vec3>{".planar_x", e1}, {".planar_y", e2}}) {
      Joint jp;
      jp.name = name + suffix;
      jp.type = JointType::kPrismatic;
      jp.axis = axis;
      at = B.add(name + suffix, at, at == parent ? s.X_P_root : Transform(), jp, Inertia(), {}, {}, 0.0, b);
    }
    parent = at;
  }
  Joint jr;
  jr.name = name;
  jr.type = s.floating ? JointType::kFloating : s.planar ? JointType::kRevolute : JointType::kFixed;
  jr.axis = t.root_normal;
  std::vector<double> rq;
  if (s.floating) {
    Eigen::VectorXd tmp(7);
    set_floating_q(tmp, 0, s.X_P_root);
    rq.assign(tmp.data(), tmp.data() + 7);
  }
  const std::string root_body = name + "." + t.root_link;
  const int root = B.add(root_body, parent, s.floating || s.planar ? Transform() : s.X_P_root, jr, t.root_inertia, rq,
                         s.floating ? s.root_v : std::vector<double>{}, 0.0, b);  // a free root is unactuated
  if (!s.floating && !s.planar)  // the parent's wrench on the root link (a floating joint transmits nothing)
    outs.push_back(joint_output(name, root_body, by, root, false, root, Transform(), 0x3f));
  std::map<std::string, int> body_of = {{t.root_link, root}};
  for (size_t k = 0; k < t.joints.size(); ++k) {
    const ChainJoint& cj = t.joints[k].j;
    const bool held = cj.fixed || s.held.count(static_cast<int>(k));
    Joint j;
    j.type = held ? JointType::kFixed : (cj.prismatic ? JointType::kPrismatic : JointType::kRevolute);
    j.axis = cj.axis;
    j.name = name + "." + cj.name;
    j.armature = cj.armature;
    j.damping = cj.damping;
    j.friction = cj.friction;
    Transform X_PJ = cj.X_origin;
    if (held) X_PJ = X_PJ * chain_motion(cj, s.q[k]);
    const std::string parent_body = name + "." + t.joints[k].parent_link;
    const int id = B.add(name + "." + cj.link_name, body_of.at(t.joints[k].parent_link), X_PJ, j, cj.I,
                         s.q_given[k] ? std::vector<double>{s.q[k]} : std::vector<double>{},
                         s.v_given[k] ? std::vector<double>{s.v[k]} : std::vector<double>{}, cj.tau_limit, b);
    B.set_limits(id, cj.lower, cj.upper, cj.v_limit);
    body_of[cj.link_name] = id;
    outs.push_back(joint_output(j.name, name + "." + cj.link_name, parent_body, id, false, id, Transform(),
                                held ? 0x3f : bearing_mask(j.type, cj.axis, cj.axis)));
  }
  // every link is a frame of its own name; PREFIX.base (the root link) and, for an unbranched
  // tree, PREFIX.ee (its last link, with `tool`) as for a chain, unless a link has that name
  try {
    for (const auto& [link, id] : body_of) {
      model.add_frame(name + "." + link, id, Transform());
      B.urdf_links[name + "." + link] = {r.tree, link};
    }
    if (!body_of.count("base")) model.add_frame(name + ".base", root, Transform());
    if (t.branch_link.empty() && !body_of.count("ee"))
      model.add_frame(name + ".ee", t.joints.empty() ? root : body_of.at(t.joints.back().j.link_name), s.tool);
  } catch (const std::invalid_argument& e) {
    fail(c, b, e.what());
  }
  tree_mimics(c, b, s, name, B);  // the tree's joints are in the model now, as PREFIX.<joint>
}

}  // namespace coopdyn::scene_detail
