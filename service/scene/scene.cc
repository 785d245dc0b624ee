// The scene compiler: YAML -> System, running the passes of builder.h in order.
#include "service/scene/scene.h"

#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <sstream>

#include "service/algorithms/crba.h"
#include "service/algorithms/kinematics.h"
#include "service/algorithms/tree_cholesky.h"
#include "service/scene/builder.h"
#include "service/text/input_limits.h"

namespace bounded = coopdyn::text;  // size and depth limits of user files

namespace coopdyn {

using namespace scene_detail;

System load_scene_string(const std::string& text, const std::string& file, const SceneOverrides& ov) {
  Builder B;
  B.c.file = file;
  B.c.dir = std::filesystem::path(file).parent_path().string();
  B.c.warnings = &B.sys.warnings;
  const Ctx& c = B.c;
  check_yaml_text(text, file);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::DeepRecursion& e) {
    throw SceneError(file + ": YAML nested deeper than yaml-cpp's limit of " + std::to_string(e.depth()) + " levels");
  } catch (const YAML::ParserException& e) {
    throw SceneError(bounded::cut_values(file + ":" + std::to_string(e.mark.line + 1) + ":" +
                                      std::to_string(e.mark.column + 1) + ": YAML syntax error: " + e.msg));
  }
  if (!root.IsMap()) fail(c, root, "a scene must be a YAML mapping");
  try {
    check_keys(c, root, {"name", "description", "source", "gravity", "formulation", "redundancy", "stabilization", "solver",
                         "robots", "load", "arms", "bodies", "frames", "constraints", "ground", "reactions", "close_initial_state"},
               "scene");
    System& sys = B.sys;
    sys.name = get_string(c, root, "name", std::filesystem::path(file).stem().string());
    if (root["gravity"]) sys.model.gravity_W = as_vec3(c, root["gravity"], "gravity");
    const std::string fs = get_string(c, root, "formulation", "mobile_platform");
    if (!parse_formulation(fs, &sys.options.formulation))
      fail(c, root["formulation"], "unknown formulation '" + fs + "' (mobile_platform, classic, pseudo_joint, svd)");
    if (ov.formulation) sys.options.formulation = *ov.formulation;
    const std::string red = get_string(c, root, "redundancy", "min_norm");
    if (red == "min_norm") sys.options.redundancy = Redundancy::kMinNorm;
    else if (red == "compliance") sys.options.redundancy = Redundancy::kCompliance;
    else fail(c, root["redundancy"], "unknown redundancy rule '" + red + "' (min_norm, compliance)");
    if (root["stabilization"]) {
      const YAML::Node st = root["stabilization"];
      if (st.IsScalar() && st.as<std::string>() == "none") {
      } else {
        check_keys(c, st, {"baumgarte", "projection"}, "stabilization");
        if (st["projection"]) {
          check_keys(c, st["projection"], {"iterations"}, "stabilization.projection");
          const double it = get_double(c, st["projection"], "iterations", 3, "projection");
          if (it < 1 || it > 50) fail(c, st["projection"], "projection iterations must be in 1..50");
          sys.options.projection_iterations = static_cast<int>(it);
        }
      }
      if (st.IsMap() && st["baumgarte"]) {
        const YAML::Node bg = st["baumgarte"];
        check_keys(c, bg, {"alpha", "beta"}, "stabilization.baumgarte");
        sys.constraints.stabilize = true;
        sys.constraints.baumgarte_alpha = get_double(c, bg, "alpha", 0.0, "baumgarte");
        sys.constraints.baumgarte_beta = get_double(c, bg, "beta", 0.0, "baumgarte");
        if (sys.constraints.baumgarte_alpha < 0 || sys.constraints.baumgarte_beta < 0)
          fail(c, bg, "Baumgarte gains must be >= 0");
      }
    }
    if (root["solver"]) {  // divergence bound of step() (SolverOptions::max_speed)
      const YAML::Node so = root["solver"];
      if (!so.IsMap()) fail(c, so, "'solver' must be a mapping, e.g. {max_speed: 1e4}");
      check_keys(c, so, {"max_speed"}, "solver");
      const YAML::Node ms = so["max_speed"];
      if (ms.IsScalar() && ms.as<std::string>() == "off") sys.options.max_speed = std::numeric_limits<double>::infinity();
      else sys.options.max_speed = get_double(c, so, "max_speed", sys.options.max_speed, "solver");
      if (!(sys.options.max_speed > 0)) fail(c, ms, "solver.max_speed must be > 0 (rad/s or m/s per DOF) or 'off'");
    }
    std::map<std::string, Robot> robots;
    if (root["robots"]) {
      for (const auto& kv : root["robots"]) {
        const std::string rn = kv.first.as<std::string>();
        YAML::Node rnode = kv.second;
        if (rnode["urdf"]) {
          check_keys(c, rnode, {"urdf", "base", "tip", "source", "branches"}, "robot '" + rn + "'");
          const std::string path = (std::filesystem::path(c.dir) / rnode["urdf"].as<std::string>()).string();
          const std::string br = get_string(c, rnode, "branches", "report");
          if (br != "report" && br != "keep")
            fail(c, rnode["branches"], "robot '" + rn + "': branches must be report (default: listed as left out) or keep");
          robots[rn] = parse_urdf(c, rnode["urdf"], path, rn, get_string(c, rnode, "base", ""), get_string(c, rnode, "tip", ""),
                                  br == "keep");
        } else if (rnode["file"]) {
          const std::string rel = rnode["file"].as<std::string>();
          const std::string path = (std::filesystem::path(c.dir) / rel).string();
          Ctx rc{path, std::filesystem::path(path).parent_path().string(), c.warnings};
          YAML::Node rf = load_yaml_file(c, path, rnode["file"]);
          robots[rn] = parse_robot(rc, rf, rn);
        } else {
          robots[rn] = parse_robot(c, rnode, rn);
        }
      }
    }
    for (const auto& [rn, rb] : robots) sys.warnings.insert(sys.warnings.end(), rb.warnings.begin(), rb.warnings.end());
    const bool has_arms = root["arms"].IsDefined(), has_bodies = root["bodies"].IsDefined();
    if (has_arms == has_bodies) fail(c, root, "a scene declares either 'arms' (with or without a 'load') or 'bodies', not both or neither");
    if (root["load"] && !has_arms) fail(c, root["load"], "a 'load' is carried by 'arms' (in a 'bodies' scene it is a body with a floating joint)");
    if (has_arms && !root["load"] && root["formulation"] &&
        (sys.options.formulation == Formulation::kPseudoJointSchur || sys.options.formulation == Formulation::kSvdBaseline))
      fail(c, root["formulation"], "formulation '" + fs + "' is about arms closed through a load; this scene has none "
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
    Model& model = sys.model;
    sys.q0 = Eigen::Map<Eigen::VectorXd>(B.q0.data(), static_cast<Eigen::Index>(B.q0.size()));
    sys.v0 = Eigen::Map<Eigen::VectorXd>(B.v0.data(), static_cast<Eigen::Index>(B.v0.size()));
    sys.tau_limit = Eigen::Map<Eigen::VectorXd>(B.tau_lim.data(), static_cast<Eigen::Index>(B.tau_lim.size()));

    // pseudo-joint locks are rows of the solve, except in the explicit Schur form (24)-(26)
    if (sys.options.formulation != Formulation::kPseudoJointSchur) {
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
    build_wrench_outputs(c, root, sys);
    // welds to the world without an explicit target hold the frame where q0 puts it
    Data data(model);
    forward_kinematics(model, data, sys.q0, sys.v0);
    for (ConstraintSpec& s : sys.constraints.specs)
      if (s.kind == ConstraintKind::kWeld && s.frame_b < 0 && !s.X_WA_target.p.allFinite())
        s.X_WA_target = frame_pose(model, data, s.frame_a);
    sys.constraints.compile(model);
    sys.wrenches.compile(model, sys.constraints);

    // The initial state must satisfy the constraints: loops close themselves (close_initial_state,
    // on by default) by moving the coordinates the scene left without a value, else all of them,
    // and the velocity is projected onto the constraints; what moved is reported in the warnings.
    // What cannot be closed is an error at the constraint, per axis.
    // close_initial_state: true (default) | false | {keep: [JOINT, ...]}: the joints whose given
    // values are kept (then every other joint may move)
    bool close = true;
    std::vector<unsigned char> keep;  // per body: its joint is kept; empty: no keep list
    if (const YAML::Node ci = root["close_initial_state"]; ci && ci.IsMap()) {
      check_keys(c, ci, {"keep"}, "close_initial_state");
      keep.assign(model.nbodies(), 0);
      const YAML::Node kl = ci["keep"];
      if (!kl || !kl.IsSequence()) fail(c, ci, "close_initial_state.keep must be a list of joint names");
      for (const YAML::Node& k : kl) {
        const int b = k.IsScalar() ? model.joint_index(k.Scalar()) : -1;
        if (b < 0) fail(c, k, "close_initial_state.keep: unknown joint '" + (k.IsScalar() ? k.Scalar() : std::string("?")) + "'");
        keep[b] = 1;
      }
    } else {
      close = get_bool(c, root, "close_initial_state", true);
    }
    if (close) close_initial_state(sys, B.q_given, keep, &sys.warnings);
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
          os << " " << (sp.kind == ConstraintKind::kLock ? "q" : axis[ax]) << " " << (pe > 1e-6 ? cd.err[r0 + k] : cd.Gv[r0 + k]);
        }
        os << (sp.kind == ConstraintKind::kWeld ? " (rad, m; in the tip frame)" : "");
        fail(c, constraint_node(root, sp.name), os.str());
      }
    }
    crba(model, data);
    int bad = -1;
    if (!tree_cholesky_factor(model, data, 1e-13, &bad)) {
      fail(c, root, "mass matrix is singular at the initial state: velocity coordinate '" + model.v_names[bad] +
                        "' moves no mass (give its subtree a mass or inertia, or the joint an armature)");
    }
    return sys;
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
