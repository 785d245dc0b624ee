#include "service/scene/scene_settings.h"

#include <filesystem>
#include <limits>

#include "service/scene/urdf_tree.h"

namespace coopdyn::scene_detail {

namespace {

// `stabilization: none | {baumgarte: {alpha, beta}, projection: {iterations}}`
void read_stabilization(const Ctx& c, const YAML::Node& st, System& sys) {
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

// `solver: {max_speed}`: the divergence bound of step() (SolverOptions::max_speed)
void read_solver(const Ctx& c, const YAML::Node& so, System& sys) {
  if (!so.IsMap()) fail(c, so, "'solver' must be a mapping, e.g. {max_speed: 1e4}");
  check_keys(c, so, {"max_speed"}, "solver");
  const YAML::Node ms = so["max_speed"];
  if (ms.IsScalar() && ms.as<std::string>() == "off") sys.options.max_speed = std::numeric_limits<double>::infinity();
  else sys.options.max_speed = get_double(c, so, "max_speed", sys.options.max_speed, "solver");
  if (!(sys.options.max_speed > 0)) fail(c, ms, "solver.max_speed must be > 0 (rad/s or m/s per DOF) or 'off'");
}

// `armature: A` (every moving joint, kg*m^2 or kg) or `{JOINT: A, ...}` (the URDF's joint names) of
// a URDF robot entry, applied to the chain's or the whole tree's joints
void read_urdf_armature(const Ctx& c, const YAML::Node& a, const std::string& rn, std::vector<ChainJoint*> joints) {
  const std::string what = "robot '" + rn + "'.armature";
  auto value = [&](const YAML::Node& n, const std::string& w) {
    const double x = as_double(c, n, w);
    if (!(x >= 0)) fail(c, n, w + " must be >= 0 (kg*m^2 for a revolute joint, kg for a prismatic one)");
    return x;
  };
  if (a.IsScalar()) {
    const double x = value(a, what);
    for (ChainJoint* j : joints)
      if (!j->fixed) j->armature = x;
    return;
  }
  if (!a.IsMap()) fail(c, a, what + " must be a number (every moving joint) or a mapping {joint: armature}");
  for (const auto& kv : a) {
    const std::string jn = kv.first.IsScalar() ? kv.first.Scalar() : "";
    ChainJoint* hit = nullptr;
    for (ChainJoint* j : joints)
      if (j->name == jn) hit = j;
    if (!hit) fail(c, kv.first, what + ": no joint '" + jn + "' in the robot");
    if (hit->fixed) fail(c, kv.first, what + ": joint '" + jn + "' is fixed in the URDF: it has no armature");
    hit->armature = value(kv.second, what + "." + jn);
  }
}

// one entry of `robots`; whole: a URDF without base and tip is read as its whole tree (a `bodies`
// scene places it whole; `arms` take a chain)
Robot read_robot(const Ctx& c, const std::string& rn, YAML::Node rnode, bool whole) {
  if (rnode["urdf"]) {
    check_keys(c, rnode, {"urdf", "base", "tip", "source", "branches", "repair_inertia", "armature"}, "robot '" + rn + "'");
    const bool repair = get_bool(c, rnode, "repair_inertia", false);
    const std::string path = (std::filesystem::path(c.dir) / rnode["urdf"].as<std::string>()).string();
    if (whole && !rnode["base"] && !rnode["tip"]) {
      if (rnode["branches"])
        fail(c, rnode["branches"], "robot '" + rn + "': branches applies to a chain (give tip); without base and tip a "
                                   "robot of a `bodies` scene is loaded whole, every branch included");
      Robot r;
      r.name = rn;
      auto tree = std::make_shared<UrdfTree>(*read_urdf_tree(c, rnode["urdf"], path, &r.warnings, rn, repair));
      if (rnode["armature"]) {
        std::vector<ChainJoint*> js;
        for (UrdfTreeJoint& tj : tree->joints) js.push_back(&tj.j);
        read_urdf_armature(c, rnode["armature"], rn, js);
      }
      r.tree = tree;
      r.base_link = r.tree->root_link;
      return r;
    }
    const std::string br = get_string(c, rnode, "branches", "report");
    if (br != "report" && br != "keep")
      fail(c, rnode["branches"], "robot '" + rn + "': branches must be report (default: listed as left out) or keep");
    Robot r = parse_urdf(c, rnode["urdf"], path, rn, get_string(c, rnode, "base", ""), get_string(c, rnode, "tip", ""),
                         br == "keep", repair);
    if (rnode["armature"]) {
      std::vector<ChainJoint*> js;
      for (ChainJoint& j : r.joints) js.push_back(&j);
      read_urdf_armature(c, rnode["armature"], rn, js);
    }
    return r;
  }
  if (rnode["file"]) {
    const std::string rel = rnode["file"].as<std::string>();
    const std::string path = (std::filesystem::path(c.dir) / rel).string();
    Ctx rc{path, std::filesystem::path(path).parent_path().string(), c.warnings};
    YAML::Node rf = load_yaml_file(c, path, rnode["file"]);
    return parse_robot(rc, rf, rn);
  }
  return parse_robot(c, rnode, rn);
}

}  // namespace

void read_settings(const Ctx& c, YAML::Node root, const SceneOverrides& ov, System& sys) {
  sys.name = get_string(c, root, "name", std::filesystem::path(c.file).stem().string());
  if (root["gravity"]) sys.model.gravity_W = as_vec3(c, root["gravity"], "gravity");
  const std::string fs = get_string(c, root, "formulation", "mobile_platform");
  if (!parse_formulation(fs, &sys.options.formulation))
    fail(c, root["formulation"], "unknown formulation '" + fs + "' (mobile_platform, classic, pseudo_joint, svd)");
  if (ov.formulation) sys.options.formulation = *ov.formulation;
  const std::string red = get_string(c, root, "redundancy", "min_norm");
  if (red == "min_norm") sys.options.redundancy = Redundancy::kMinNorm;
  else if (red == "compliance") sys.options.redundancy = Redundancy::kCompliance;
  else fail(c, root["redundancy"], "unknown redundancy rule '" + red + "' (min_norm, compliance)");
  if (root["stabilization"]) read_stabilization(c, root["stabilization"], sys);
  if (root["solver"]) read_solver(c, root["solver"], sys);
}

std::map<std::string, Robot> read_robots(const Ctx& c, YAML::Node root) {
  std::map<std::string, Robot> robots;
  if (root["robots"])
    for (const auto& kv : root["robots"]) {
      const std::string rn = kv.first.as<std::string>();
      robots[rn] = read_robot(c, rn, kv.second, !root["arms"].IsDefined());
    }
  return robots;
}

}  // namespace coopdyn::scene_detail
