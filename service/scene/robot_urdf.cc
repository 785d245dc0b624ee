// A URDF file (urdf_file.h) compiled into a serial chain: the chain base..tip, each link's inertial
// checked, the links off the chain reported or kept rigidly, each joint converted.
#include <algorithm>
#include <functional>
#include <map>
#include <cmath>
#include <cstdlib>
#include <regex>
#include <set>
#include <sstream>

#include "service/scene/robot_chain.h"
#include "service/scene/urdf_file.h"

namespace coopdyn::scene_detail {

namespace {

// The joints from `base` down to `tip`, in order; an empty base is the root, an empty tip the only
// leaf below base (both filled in).
std::vector<urdf::JointConstSharedPtr> chain_joints(const Ctx& c, const YAML::Node& where, const UrdfFile& f,
                                                    std::string& base, std::string& tip) {
  const urdf::ModelInterfaceSharedPtr& u = f.model;
  if (base.empty()) base = u->getRoot()->name;
  urdf::LinkConstSharedPtr lk = u->getLink(tip.empty() ? base : tip);
  if (!u->getLink(base)) fail(c, where, urdf_at(f) + ": no link '" + base + "'");
  if (tip.empty()) {
    urdf::LinkConstSharedPtr l = u->getLink(base);
    while (l->child_links.size() == 1) l = l->child_links[0];
    if (!l->child_links.empty())
      fail(c, where, urdf_at(f) + ": branches below '" + l->name + "': give robots.<name>.tip, or load the whole tree in `bodies:`");
    tip = l->name;
    lk = l;
  }
  if (!lk) fail(c, where, urdf_at(f) + ": no link '" + tip + "'");
  std::vector<urdf::JointConstSharedPtr> chain;
  for (urdf::LinkConstSharedPtr l = lk; l && l->name != base; l = l->getParent()) {
    if (!l->parent_joint) fail(c, where, urdf_at(f) + ": '" + tip + "' is not below '" + base + "'");
    chain.push_back(l->parent_joint);
  }
  std::reverse(chain.begin(), chain.end());
  return chain;
}

// The links off the chain, reported as left out when one of them moves (a finger) or has mass; a
// bare frame is no loss.
void report_left_out_links(const UrdfFile& f, const std::set<std::string>& on_chain, const std::string& base,
                           const std::string& tip, Robot& r) {
  std::string left;
  double mass = 0;
  bool moving = false;
  std::vector<urdf::LinkConstSharedPtr> stack;
  for (const std::string& l : on_chain)
    for (const auto& ch : f.model->getLink(l)->child_links)
      if (!on_chain.count(ch->name)) stack.push_back(ch);
  while (!stack.empty()) {
    urdf::LinkConstSharedPtr l = stack.back();
    stack.pop_back();
    left += (left.empty() ? "" : ", ") + l->name;
    if (l->inertial) mass += l->inertial->mass;
    if (l->parent_joint && l->parent_joint->type != urdf::Joint::FIXED) moving = true;
    for (const auto& ch : l->child_links) stack.push_back(ch);
  }
  if (!left.empty() && (mass > 0 || moving)) {
    std::ostringstream os;
    os << urdf_at(f) << ": links off the chain " << base << " .. " << tip << " are left out: " << left << " ("
       << mass << " kg; robots.<name>.branches: keep adds them rigidly)";
    r.warnings.push_back(os.str());
  }
}

// The value a joint off the chain is kept at (branches: keep): 0, or m * (its mimicked joint's
// value) + o for a <mimic>, following the mimics (a loop or a mimicked chain joint is an error).
double kept_joint_value(const Ctx& c, const YAML::Node& where, const UrdfFile& f, const std::set<std::string>& chain_joints,
                        const std::map<std::string, UrdfMimic>& mimic_of, const std::string& joint, int depth = 0) {
  const auto it = mimic_of.find(joint);
  if (it == mimic_of.end()) return 0.0;
  const UrdfMimic& mm = it->second;
  if (depth > static_cast<int>(mimic_of.size()))
    fail(c, where, mm.source + ": joint '" + joint + "' is in a loop of mimics (it follows itself)");
  if (chain_joints.count(mm.mimicked))
    fail(c, where, mm.source + ": joint '" + joint + "' off the chain mimics chain joint '" + mm.mimicked +
                       "': a side branch kept rigidly (branches: keep) cannot follow it (make its link the tip, or leave the branch out)");
  return mm.multiplier * kept_joint_value(c, where, f, chain_joints, mimic_of, mm.mimicked, depth + 1) + mm.offset;
}

// the placement of a kept side link in its parent: the joint's origin and its motion at `q`
Transform kept_joint_pose(const urdf::Joint& jt, double q) {
  const Transform X = urdf_pose(jt.parent_to_joint_origin_transform);
  if (q == 0.0 || jt.type == urdf::Joint::FIXED) return X;
  ChainJoint cj;
  cj.axis = Vec3(jt.axis.x, jt.axis.y, jt.axis.z);
  cj.prismatic = jt.type == urdf::Joint::PRISMATIC;
  return X * chain_motion(cj, q);
}

// branches: keep: each side subtree (a gripper's fingers) is added rigidly, its joints at zero (a
// mimic joint at m * 0 + o), to the chain link it hangs from, so its mass and inertia count.
// Returns chain link -> the side subtrees' inertia in its frame.
std::map<std::string, Inertia> keep_side_branches(const Ctx& c, const YAML::Node& where, const UrdfFile& f,
                                                  const std::set<std::string>& on_chain, const std::string& base, Robot& r) {
  std::map<std::string, Inertia> side;
  std::map<std::string, UrdfMimic> mimic_of;
  for (const UrdfMimic& mm : read_mimics(f)) mimic_of[mm.joint] = mm;
  std::set<std::string> chain_joints;
  for (const std::string& ln : on_chain)
    if (ln != base) chain_joints.insert(f.model->getLink(ln)->parent_joint->name);
  bool mimics = false;
  auto pose = [&](const urdf::LinkConstSharedPtr& ch) {
    const double q = kept_joint_value(c, where, f, chain_joints, mimic_of, ch->parent_joint->name);
    mimics = mimics || mimic_of.count(ch->parent_joint->name);
    return kept_joint_pose(*ch->parent_joint, q);
  };
  std::function<void(const urdf::LinkConstSharedPtr&, const Transform&, Inertia&, double&, std::string&)> add;
  add = [&](const urdf::LinkConstSharedPtr& l, const Transform& X_CL, Inertia& acc, double& m, std::string& names) {
    check_urdf_inertial(c, where, f, l->name, &r.warnings);
    if (l->inertial) {
      acc += link_inertia(c, where, *l).transformed(X_CL);
      m += l->inertial->mass;
    }
    names += (names.empty() ? "" : ", ") + l->name;
    for (const auto& ch : l->child_links) add(ch, X_CL * pose(ch), acc, m, names);
  };
  for (const std::string& ln : on_chain)
    for (const auto& ch : f.model->getLink(ln)->child_links) {
      if (on_chain.count(ch->name)) continue;
      Inertia acc;
      double m = 0;
      std::string names;
      mimics = false;
      add(ch, pose(ch), acc, m, names);
      if (m <= 0) continue;
      side[ln] += acc;
      std::ostringstream os;
      os << urdf_at(f) << ": " << names << " (" << m << " kg) kept rigidly on '" << ln
         << "' with their joints at zero" << (mimics ? " (a mimic joint at its offset)" : "") << " (branches: keep)";
      if (ln == base) os << "; on the base link it is carried by the base and moves nothing";
      r.warnings.push_back(os.str());
    }
  return side;
}

}  // namespace

// One joint of the chain with its child link's inertia (plus the side branches kept on it).
ChainJoint urdf_chain_joint(const Ctx& c, const YAML::Node& where, const UrdfFile& f, const urdf::Joint& jt,
                       const std::map<std::string, Inertia>& side) {
  urdf::LinkConstSharedPtr child = f.model->getLink(jt.child_link_name);
  Inertia I;
  if (child->inertial) I = link_inertia(c, where, *child);
  if (auto it = side.find(child->name); it != side.end()) I += it->second;
  ChainJoint j;
  j.name = jt.name;
  j.link_name = child->name;
  j.X_origin = urdf_pose(jt.parent_to_joint_origin_transform);
  j.axis = Vec3(jt.axis.x, jt.axis.y, jt.axis.z);
  j.I = I;
  switch (jt.type) {
    case urdf::Joint::REVOLUTE:
    case urdf::Joint::CONTINUOUS: break;
    case urdf::Joint::PRISMATIC: j.prismatic = true; break;
    case urdf::Joint::FIXED: j.fixed = true; break;
    default: {
      size_t at = 0, end = 0;
      const bool base = jt.type == urdf::Joint::FLOATING || jt.type == urdf::Joint::PLANAR;
      fail(c, where,
           (urdf_element(f, "joint", jt.name, &at, &end) ? urdf_at(f, at) : urdf_at(f)) + ": joint '" + jt.name + "' is " +
               (jt.type == urdf::Joint::FLOATING ? "floating" : jt.type == urdf::Joint::PLANAR ? "planar" : "of an unknown type") +
               ": coopdyn reads revolute, continuous, prismatic and fixed joints" +
               (base ? "; a free base is the scene's (a whole robot's `root: floating`, or a `floating` body joint): "
                       "load the robot from the joint's child link ('" + jt.child_link_name +
                       "'), i.e. a copy of the file without this joint and its parent link"
                     : ""));
    }
  }
  if (!j.fixed && !(j.axis.norm() > 0)) fail(c, where, "URDF joint '" + jt.name + "': zero axis");
  if (!j.fixed && jt.limits && jt.limits->effort > 0) j.tau_limit = jt.limits->effort;
  if (!j.fixed && jt.limits && jt.limits->velocity > 0) j.v_limit = jt.limits->velocity;
  // a continuous joint has no position limits; urdfdom leaves lower = upper = 0 when none is given
  if (jt.limits && jt.type != urdf::Joint::CONTINUOUS && !j.fixed && jt.limits->upper > jt.limits->lower) {
    j.lower = jt.limits->lower;
    j.upper = jt.limits->upper;
  }
  size_t at = 0, end = 0;
  j.source = urdf_element(f, "joint", jt.name, &at, &end) ? urdf_at(f, at) : urdf_at(f);
  if (jt.dynamics && !j.fixed) {  // <dynamics damping friction>: modelled (a fixed joint's do nothing)
    for (const auto& [key, x] : {std::pair<const char*, double>{"damping", jt.dynamics->damping}, {"friction", jt.dynamics->friction}})
      if (!(std::isfinite(x) && x >= 0))
        fail(c, where, j.source + ": joint '" + jt.name + "': <dynamics " + key + "> must be a finite number >= 0");
    j.damping = jt.dynamics->damping;
    j.friction = jt.dynamics->friction;
  }
  return j;
}


namespace {

// Where a chain ending at a mimic follower could keep its coupling: the advice of the error.
std::string keep_coupling_advice(const UrdfFile& f, const UrdfMimic& mm, const std::string& base) {
  const urdf::JointConstSharedPtr ji = f.model->getJoint(mm.mimicked), jj = f.model->getJoint(mm.joint);
  std::set<std::string> above_j;  // the links above the follower's child link, itself included
  for (urdf::LinkConstSharedPtr l = f.model->getLink(jj->child_link_name); l; l = l->getParent()) above_j.insert(l->name);
  if (above_j.count(ji->child_link_name))  // the leader is above the follower: the chain starts below it
    return "give a base at or above '" + ji->parent_link_name + "' (the leader's parent link; the base is '" + base +
           "') so that both joints are on the chain, or load the whole tree (a `bodies` robot without base and tip)";
  urdf::LinkConstSharedPtr common = f.model->getLink(ji->child_link_name);
  while (common && !above_j.count(common->name)) common = common->getParent();
  const std::string fork = common ? common->name : base;
  return "no chain holds both (the leader is on a branch beside it, from '" + fork + "'): load the whole tree (a "
         "`bodies` robot without base and tip) to keep the coupling, or end the chain at '" + fork +
         "' (tip) with branches: keep to carry both at their values m * 0 + o, rigidly";
}

// The file's <mimic>s read against the chain: one between chain joints is kept for the builders; a
// follower on the chain whose leader the file makes fixed is made fixed at m * 0 + o, and one whose
// leader the file lacks moves on its own (warnings); a mimic off the chain concerns a part the scene
// does not load (nothing, or a warning when the chain's joint leads it and its link is left out); a
// chain joint that follows a moving joint off the chain is an error that says which tip or branches
// choice keeps the coupling.
void read_chain_mimics(const Ctx& c, const YAML::Node& where, const UrdfFile& f,
                       const std::vector<urdf::JointConstSharedPtr>& chain, bool keep_branches, Robot& r) {
  std::set<std::string> on;
  for (const auto& jt : chain) on.insert(jt->name);
  for (const UrdfMimic& mm : read_mimics(f)) {
    const urdf::JointConstSharedPtr ji = f.model->getJoint(mm.mimicked), jj = f.model->getJoint(mm.joint);
    const std::string what = mm.source + ": joint '" + mm.joint + "' mimics '" + mm.mimicked + "'";
    const bool j_on = on.count(mm.joint) > 0, i_on = on.count(mm.mimicked) > 0;
    if (!j_on) {
      if (i_on && !keep_branches) r.warnings.push_back(what + " on the chain; its link is left out with the links off the chain");
      continue;  // a part the scene does not load (branches: keep holds it at m * 0 + o)
    }
    if (jj->type == urdf::Joint::FIXED) {
      r.warnings.push_back(what + ", but the file makes it fixed: the mimic couples nothing");
    } else if (!ji) {
      r.warnings.push_back(what + ", which the file does not have: '" + mm.joint + "' moves on its own");
    } else if (ji->type == urdf::Joint::FIXED) {
      for (ChainJoint& cj : r.joints)
        if (cj.name == mm.joint) {
          cj.X_origin = cj.X_origin * chain_motion(cj, mm.offset);
          cj.fixed = true;
          cj.lower = -std::numeric_limits<double>::infinity(), cj.upper = std::numeric_limits<double>::infinity();
        }
      std::ostringstream os;
      os.precision(17);
      os << what << ", which the file makes fixed: '" << mm.joint << "' is held at m * 0 + o = " << mm.offset;
      r.warnings.push_back(os.str());
    } else if (i_on) {
      r.mimics.push_back(mm);
    } else {
      fail(c, where, what + ", which is off the chain " + r.base_link + " .. " + chain.back()->child_link_name +
                         ": the coupling would be lost; " + keep_coupling_advice(f, mm, r.base_link));
    }
  }
}

}  // namespace

std::vector<UrdfMimic> placed_mimics(const Robot& r, const std::string& prefix) {
  std::vector<UrdfMimic> out = r.mimics;
  for (UrdfMimic& m : out) {
    m.joint = prefix + "." + m.joint;
    m.mimicked = prefix + "." + m.mimicked;
  }
  return out;
}

void add_joint_couplings(const Ctx& c, const YAML::Node& where, const Model& model, const std::vector<UrdfMimic>& couplings,
                         ConstraintSet& cs) {
  std::map<std::string, std::string> follows;  // joint -> the joint it mimics
  for (const UrdfMimic& m : couplings) {
    const std::string what = m.source + ": joint '" + m.joint + "' mimics '" + m.mimicked + "'";
    ConstraintSpec s;
    s.kind = ConstraintKind::kCouple;
    s.name = "mimic:" + m.joint;
    s.multiplier = m.multiplier;
    s.offset = m.offset;
    for (const std::string* nm : {&m.joint, &m.mimicked}) {
      const int b = model.joint_index(*nm);
      if (b < 0 || model.bodies[b].joint.nv != 1 || model.bodies[b].joint.pseudo)
        fail(c, where, what + ", but '" + *nm + "' is not a moving one-DOF joint of the scene (a fixed joint, or one held by fixed_joints?)");
      const Joint& j = model.bodies[b].joint;
      (nm == &m.joint ? s.dof : s.couple_dof) = j.idx_v;
      (nm == &m.joint ? s.q_index : s.couple_q) = j.idx_q;
    }
    if (m.joint == m.mimicked) fail(c, where, what + ": a joint cannot mimic itself");
    if (!std::isfinite(m.multiplier) || !std::isfinite(m.offset)) fail(c, where, what + ": multiplier and offset must be numbers");
    if (!follows.emplace(m.joint, m.mimicked).second) fail(c, where, what + ": the joint already mimics another");
    cs.specs.push_back(s);
  }
  for (const auto& kv : follows) {  // a loop of mimics: the rows would contradict each other
    std::string at = kv.first;
    for (size_t n = 0; n <= follows.size() && follows.count(at); ++n) {
      at = follows.at(at);
      if (at == kv.first)
        fail(c, where, "joint '" + kv.first + "' is in a loop of mimics (it follows itself through '" + kv.second + "')");
    }
  }
}

Robot parse_urdf(const Ctx& c, const YAML::Node& where, const std::string& path, const std::string& name,
                 std::string base, std::string tip, bool keep_branches, bool repair_inertia) {
  const UrdfFile f = read_urdf(c, where, path, repair_inertia, "robots." + name + ".repair_inertia: true");
  const std::vector<urdf::JointConstSharedPtr> chain = chain_joints(c, where, f, base, tip);
  Robot r;
  r.name = name;
  r.base_link = base;
  std::set<std::string> on_chain = {base};
  for (const auto& jt : chain) on_chain.insert(jt->child_link_name);
  for (const auto& jt : chain) check_link_inertial(c, where, f, *jt, &r.warnings);
  std::map<std::string, Inertia> side;
  if (keep_branches)
    side = keep_side_branches(c, where, f, on_chain, base, r);
  else
    report_left_out_links(f, on_chain, base, tip, r);
  for (const auto& jt : chain) r.joints.push_back(urdf_chain_joint(c, where, f, *jt, side));
  if (!chain.empty()) read_chain_mimics(c, where, f, chain, keep_branches, r);
  if (r.joints.empty()) fail(c, where, urdf_at(f) + ": no joints between '" + base + "' and '" + tip + "'");
  return r;
}

}  // namespace coopdyn::scene_detail
