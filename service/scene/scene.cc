// The scene compiler: YAML -> System, running the passes of builder.h in order.
#include "service/scene/scene.h"

#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "service/algorithms/crba.h"
#include "service/algorithms/kinematics.h"
#include "service/algorithms/tree_cholesky.h"
#include "service/scene/builder.h"
#include "service/scene/scene_noise.h"
#include "service/scene/scene_settings.h"
#include "service/text/input_limits.h"

namespace bounded = coopdyn::text;  // size and depth limits of user files

namespace coopdyn {

using namespace scene_detail;

namespace {

YAML::Node parse_yaml(const std::string& text, const std::string& file) {
  check_yaml_text(text, file);
  try {
    return YAML::Load(text);
  } catch (const YAML::DeepRecursion& e) {
    throw SceneError(file + ": YAML nested deeper than yaml-cpp's limit of " + std::to_string(e.depth()) + " levels");
  } catch (const YAML::ParserException& e) {
    throw SceneError(bounded::cut_values(file + ":" + std::to_string(e.mark.line + 1) + ":" +
                                      std::to_string(e.mark.column + 1) + ": YAML syntax error: " + e.msg));
  }
}

// The tree: `arms` (with or without a `load`) or `bodies`, with their frames and constraints.
void build_tree(Builder& B, YAML::Node root, const std::map<std::string, Robot>& robots) {
  const Ctx& c = B.c;
  System& sys = B.sys;
  const bool has_arms = root["arms"].IsDefined(), has_bodies = root["bodies"].IsDefined();
  if (has_arms == has_bodies) fail(c, root, "a scene declares either 'arms' (with or without a 'load') or 'bodies', not both or neither");
  if (root["load"] && !has_arms) fail(c, root["load"], "a 'load' is carried by 'arms' (in a 'bodies' scene it is a body with a floating joint)");
  if (has_arms && !root["load"] && root["formulation"] &&
      (sys.options.formulation == Formulation::kPseudoJointSchur || sys.options.formulation == Formulation::kSvdBaseline))
    fail(c, root["formulation"], "formulation '" + get_string(c, root, "formulation", "mobile_platform") +
                                     "' is about arms closed through a load; this scene has none "
                                     "(its arms are rooted at the world with free tips in every formulation)");
  if (has_arms && !root["load"]) sys.options.formulation = Formulation::kClassic;  // what the tree is: no platform
  if (has_arms) {
    // the SVD baseline is the paper's, in its classic setting (the paper's (19)-(21)): arms rooted at the world
    build_arms(B, root, robots,
               sys.options.formulation != Formulation::kClassic && sys.options.formulation != Formulation::kSvdBaseline);
  } else {
    if (sys.options.formulation == Formulation::kClassic && root["formulation"].as<std::string>("") != "classic")
      fail(c, root, "formulation classic applies to scenes with arms holding a load");
    build_bodies(B, root, robots);
  }
}

// the initial state, the builder's per-coordinate lists as vectors
void copy_initial_state(const Builder& B, System& sys) {
  sys.q0 = Eigen::Map<const Eigen::VectorXd>(B.q0.data(), static_cast<Eigen::Index>(B.q0.size()));
  sys.v0 = Eigen::Map<const Eigen::VectorXd>(B.v0.data(), static_cast<Eigen::Index>(B.v0.size()));
  sys.tau_limit = Eigen::Map<const Eigen::VectorXd>(B.tau_lim.data(), static_cast<Eigen::Index>(B.tau_lim.size()));
  sys.q_lower = Eigen::Map<const Eigen::VectorXd>(B.q_lo.data(), static_cast<Eigen::Index>(B.q_lo.size()));
  sys.q_upper = Eigen::Map<const Eigen::VectorXd>(B.q_hi.data(), static_cast<Eigen::Index>(B.q_hi.size()));
  sys.v_limit = Eigen::Map<const Eigen::VectorXd>(B.v_lim.data(), static_cast<Eigen::Index>(B.v_lim.size()));
}

// pseudo-joint locks are rows of the solve, except in the explicit Schur form (24)-(26)
void add_lock_constraints(const Builder& B, System& sys) {
  if (sys.options.formulation == Formulation::kPseudoJointSchur) return;
  const Model& model = sys.model;
  for (int d : model.pseudo_dofs) {
    ConstraintSpec s;
    s.kind = ConstraintKind::kLock;
    s.dof = d;
    const Body& body = model.bodies[model.dof_body[d]];
    s.name = "lock:" + body.joint.name;
    s.q_index = body.joint.idx_q + (d - body.joint.idx_v);
    s.q_target = sys.q0[s.q_index];
    for (const auto& tl : B.target_limits)
      if (tl.first == d) s.target_limit = tl.second;
    if (s.target_limit > 0 && std::abs(s.q_target) > s.target_limit)
      throw SceneError(B.c.file + ": pseudo-joint '" + body.joint.name + "': its q is beyond its target_limit");
    sys.constraints.specs.push_back(s);
  }
}

// welds to the world without an explicit target hold the frame where q0 puts it
void hold_welds_where_q0_puts_them(System& sys, Data& data) {
  forward_kinematics(sys.model, data, sys.q0, sys.v0);
  for (ConstraintSpec& s : sys.constraints.specs)
    if (s.kind == ConstraintKind::kWeld && s.frame_b < 0 && !s.X_WA_target.p.allFinite())
      s.X_WA_target = frame_pose(sys.model, data, s.frame_a);
}

// close_initial_state: true (default) | false | {keep: [JOINT, ...]}: the joints whose given
// values are kept (then every other joint may move). Returns whether to close; keep is per body
// (its joint is kept), empty without a keep list.
bool read_close_initial_state(const Ctx& c, YAML::Node root, const Model& model, std::vector<unsigned char>& keep) {
  const YAML::Node ci = root["close_initial_state"];
  if (!ci || !ci.IsMap()) return get_bool(c, root, "close_initial_state", true);
  check_keys(c, ci, {"keep"}, "close_initial_state");
  keep.assign(model.nbodies(), 0);
  const YAML::Node kl = ci["keep"];
  if (!kl || !kl.IsSequence()) fail(c, ci, "close_initial_state.keep must be a list of joint names");
  for (const YAML::Node& k : kl) {
    const int b = k.IsScalar() ? model.joint_index(k.Scalar()) : -1;
    if (b < 0) fail(c, k, "close_initial_state.keep: unknown joint '" + (k.IsScalar() ? k.Scalar() : std::string("?")) + "'");
    keep[b] = 1;
  }
  return true;
}

// What cannot be closed is an error at the constraint, per axis.
void check_initial_state_closes(const Ctx& c, const YAML::Node& root, const System& sys, Data& data, bool close) {
  const Model& model = sys.model;
  ConstraintData cd(model, sys.constraints);
  forward_kinematics(model, data, sys.q0, sys.v0);
  constraint_rows(model, data, sys.constraints, sys.q0, sys.v0, cd);
  for (size_t s = 0; s < sys.constraints.specs.size(); ++s) {
    const int r0 = sys.constraints.row_offset[s], n = sys.constraints.row_count[s];
    const double pe = cd.err.segment(r0, n).cwiseAbs().maxCoeff();
    const double ve = cd.Gv.segment(r0, n).cwiseAbs().maxCoeff();
    if (pe > 1e-6 || ve > 1e-6) {
      static const char* const axis[6] = {"rx", "ry", "rz", "x", "y", "z"};
      const ConstraintSpec& sp = sys.constraints.specs[s];
      std::ostringstream os;
      os << (pe > 1e-6 ? "initial state does not close constraint '" : "initial velocity violates constraint '") << sp.name
         << "'" << (close ? " (close_initial_state could not close it)" : "") << ": "
         << (pe > 1e-6 ? "position error" : "velocity error") << " per axis";
      for (int k = 0; k < n; ++k) {
        const int ax = sys.constraints.row_axis[s][k];
        os << " " << (sp.kind == ConstraintKind::kLock || sp.kind == ConstraintKind::kCouple ? "q" : axis[ax]) << " " << (pe > 1e-6 ? cd.err[r0 + k] : cd.Gv[r0 + k]);
      }
      os << (sp.kind == ConstraintKind::kWeld ? " (rad, m; in the tip frame)" : "");
      fail(c, constraint_node(root, sp.name), os.str());
    }
  }
}

// every velocity coordinate must move some mass at the initial state; the message names every
// coordinate that moves none (a massless hand and its mimic fingers), its leaders apart
void check_mass_matrix_regular(const Ctx& c, const YAML::Node& root, const Model& model, const ConstraintSet& cs,
                               Data& data) {
  crba(model, data);
  int bad = -1;
  const Eigen::VectorXd d = data.M.diagonal();
  if (tree_cholesky_factor(model, data, 1e-13, &bad)) return;
  std::set<int> followers;
  for (const ConstraintSpec& s : cs.specs)
    if (s.kind == ConstraintKind::kCouple) followers.insert(s.dof);
  std::string group, leaders;
  int n = 0;
  for (int i = 0; i < model.nv(); ++i)
    if (i == bad || !(d[i] > 1e-13 * d.cwiseAbs().maxCoeff())) {
      group += (n++ < 30 ? (group.empty() ? "'" : ", '") + model.v_names[i] + "'" : "");
      const std::string& v = model.v_names[i];  // PREFIX.JOINT: the URDF's name after the robot body's
      if (!followers.count(i)) leaders += (leaders.empty() ? "" : ", ") + v.substr(v.find('.') == std::string::npos ? 0 : v.find('.') + 1);
    }
  if (n > 30) group += ", ... (" + std::to_string(n) + " in all)";
  fail(c, root, "mass matrix is singular at the initial state: velocity coordinate" + std::string(n > 1 ? "s " : " ") + group +
                    (n > 1 ? " move" : " moves") + " no mass (a massless subtree). Either hold " + (n > 1 ? "them" : "it") +
                    ": a robot body's fixed_joints: [" + leaders + "] (the URDF's joint names; a mimic leader held holds "
                    "its followers), or give " + (n > 1 ? "them" : "it") + " an armature: robots.<name>.armature (a number "
                    "for every joint, or {joint: armature}) or a body joint's armature; or give the subtree a mass");
}

// The scene compiler's passes, in order, on a parsed scene. root and the stages that look keys up
// in it directly take it by a non-const handle: an absent key looked up there reads back later as
// an undefined node, not an invalid one, to the passes that read it afterwards.
System compile_scene(Builder& B, YAML::Node root, const SceneOverrides& ov) {
  const Ctx& c = B.c;
  System& sys = B.sys;
  check_keys(c, root, {"name", "description", "source", "gravity", "formulation", "redundancy", "stabilization", "solver",
                       "robots", "load", "arms", "bodies", "frames", "constraints", "ground", "reactions", "close_initial_state",
                       "noise", "friction"},
             "scene");
  read_settings(c, root, ov, sys);
  const std::map<std::string, Robot> robots = read_robots(c, root);
  for (const auto& [rn, rb] : robots) sys.warnings.insert(sys.warnings.end(), rb.warnings.begin(), rb.warnings.end());
  build_tree(B, root, robots);
  copy_initial_state(B, sys);
  read_noise(c, root, sys);
  read_friction_settings(c, root, sys);
  add_lock_constraints(B, sys);
  build_wrench_outputs(c, root, sys);
  Data data(sys.model);
  hold_welds_where_q0_puts_them(sys, data);
  sys.constraints.compile(sys.model);
  sys.wrenches.compile(sys.model, sys.constraints);
  // The initial state must satisfy the constraints: loops close themselves (close_initial_state,
  // on by default) by moving the coordinates the scene left without a value, else all of them,
  // and the velocity is projected onto the constraints; what moved is reported in the warnings.
  std::vector<unsigned char> keep;
  const bool close = read_close_initial_state(c, root, sys.model, keep);
  Eigen::VectorXd q_closest = sys.q0;
  std::vector<std::pair<int, double>> beyond;  // closing the limits forbid
  const bool closed = !close || close_initial_state(sys, B.q_given, keep, &sys.warnings, B.held_bodies, &q_closest, &beyond);
  if (!closed && !beyond.empty()) refuse_beyond_limits(B, root, q_closest, beyond);
  close_grasps_check(B, closed ? sys.q0 : q_closest, closed);  // arms + load: a grasp that stays open, at its line
  check_initial_state_closes(c, root, sys, data, close);
  check_mass_matrix_regular(c, root, sys.model, sys.constraints, data);
  return sys;
}

}  // namespace

System load_scene_string(const std::string& text, const std::string& file, const SceneOverrides& ov) {
  Builder B;
  B.c.file = file;
  B.c.dir = std::filesystem::path(file).parent_path().string();
  B.c.warnings = &B.sys.warnings;
  YAML::Node root = parse_yaml(text, file);
  if (!root.IsMap()) fail(B.c, root, "a scene must be a YAML mapping");
  try {
    return compile_scene(B, root, ov);
  } catch (const SceneError& e) {
    throw SceneError(bounded::cut_values(e.what()));  // no echoed value longer than 80 characters
  } catch (const YAML::Exception& e) {
    throw SceneError(bounded::cut_values(file + ":" + std::to_string(e.mark.line + 1) + ":" +
                                      std::to_string(e.mark.column + 1) + ": " + e.msg));
  }
}

System load_scene(const std::string& path, const SceneOverrides& ov) {
  std::string text, why;
  if (!bounded::read_file(path, bounded::kMaxYamlBytes, "scene file", &text, &why)) throw SceneError(path + ": " + why);
  return load_scene_string(text, path, ov);
}

}  // namespace coopdyn
