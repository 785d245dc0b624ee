#include "service/scene/scene_noise.h"

#include <cmath>

#include "service/dynamics/holding_torque.h"

namespace coopdyn::scene_detail {

namespace {
double noise_value(const Ctx& c, const YAML::Node& n, const std::string& what) {
  if (!n.IsScalar()) fail(c, n, what + " must be a number (a standard deviation, N m or N)");
  const double s = as_double(c, n, what);
  if (!(s >= 0.0) || !std::isfinite(s)) fail(c, n, what + " must be a finite standard deviation >= 0 (N m or N)");
  return s;
}

// the DOFs whose position and velocity are measured: 1-DOF joints that are not pseudo-joints
std::vector<unsigned char> measured_joints(const Model& model) {
  std::vector<unsigned char> a(static_cast<size_t>(model.nv()), 0);
  for (int i = 0; i < model.nv(); ++i) {
    const Joint& j = model.bodies[model.dof_body[i]].joint;
    a[static_cast<size_t>(i)] = j.nv == 1 && j.nq == 1 && !j.pseudo && j.type != JointType::kFloating ? 1 : 0;
  }
  return a;
}

// one entry of noise.joints: S (the torque's) or {tau: S, q: S, v: S}
void read_joint_noise(const Ctx& c, const YAML::Node& key, const YAML::Node& val, int dof, bool actuated, bool measured,
                      System& sys) {
  const std::string name = key.as<std::string>();
  const std::string what = "noise.joints." + name;
  const char* unact = "is not actuated (no torque to be noisy: a floating base, a pseudo-joint or tau_limit 0)";
  if (!val.IsMap()) {
    if (!actuated) fail(c, key, "noise.joints: joint '" + name + "' " + unact);
    sys.tau_noise[dof] = noise_value(c, val, what);
    return;
  }
  check_keys(c, val, {"tau", "q", "v"}, what);
  if (val["tau"]) {
    if (!actuated) fail(c, val["tau"], what + ".tau: joint '" + name + "' " + unact);
    sys.tau_noise[dof] = noise_value(c, val["tau"], what + ".tau");
  }
  for (const char* k : {"q", "v"}) {
    if (!val[k]) continue;
    if (!measured)
      fail(c, val[k], what + "." + k + ": joint '" + name + "' is not a measured 1-DOF joint (a floating joint or a pseudo-joint)");
    (k[0] == 'q' ? sys.q_noise : sys.v_noise)[dof] = noise_value(c, val[k], what + "." + k);
  }
}
}  // namespace

void read_noise(const Ctx& c, const YAML::Node& root, System& sys) {
  const Model& model = sys.model;
  sys.tau_noise.setZero(model.nv());
  sys.q_noise.setZero(model.nv());
  sys.v_noise.setZero(model.nv());
  const YAML::Node no = root["noise"];
  if (!no) return;
  if (!no.IsMap()) fail(c, no, "'noise' must be a mapping, e.g. {tau: 0.1, q: 1e-4, v: 1e-3, joints: {arm1.q1: 0.5}}");
  check_keys(c, no, {"tau", "q", "v", "joints"}, "noise");
  const std::vector<unsigned char> act = default_actuated(sys);
  const std::vector<unsigned char> meas = measured_joints(model);
  const double all = no["tau"] ? noise_value(c, no["tau"], "noise.tau") : 0.0;
  const double all_q = no["q"] ? noise_value(c, no["q"], "noise.q") : 0.0;
  const double all_v = no["v"] ? noise_value(c, no["v"], "noise.v") : 0.0;
  for (int i = 0; i < model.nv(); ++i) {
    sys.tau_noise[i] = act[static_cast<size_t>(i)] ? all : 0.0;
    sys.q_noise[i] = meas[static_cast<size_t>(i)] ? all_q : 0.0;
    sys.v_noise[i] = meas[static_cast<size_t>(i)] ? all_v : 0.0;
  }
  const YAML::Node js = no["joints"];
  if (!js) return;
  if (!js.IsMap())
    fail(c, js, "noise.joints must be a mapping of joint names (velocity names, e.g. arm1.q3) to N m or N, or to {tau, q, v}");
  for (const auto& kv : js) {
    const std::string name = kv.first.as<std::string>();
    int dof = -1;
    for (int i = 0; i < model.nv(); ++i)
      if (model.v_names[static_cast<size_t>(i)] == name) dof = i;
    if (dof < 0) fail(c, kv.first, "noise.joints: unknown joint '" + name + "' (the scene's velocity names, e.g. arm1.q3)");
    read_joint_noise(c, kv.first, kv.second, dof, act[static_cast<size_t>(dof)] != 0, meas[static_cast<size_t>(dof)] != 0, sys);
  }
}

void read_friction_settings(const Ctx& c, const YAML::Node& root, System& sys) {
  sys.rest_speed = System::kDefaultRestSpeed;
  const YAML::Node fr = root["friction"];
  if (!fr) return;
  if (!fr.IsMap()) fail(c, fr, "'friction' must be a mapping, e.g. {rest_speed: 1e-6}");
  check_keys(c, fr, {"rest_speed"}, "friction");
  const YAML::Node rs = fr["rest_speed"];
  if (!rs) return;
  if (!rs.IsScalar()) fail(c, rs, "friction.rest_speed must be a number (rad/s or m/s)");
  const double s = as_double(c, rs, "friction.rest_speed");
  if (!(s >= 0.0) || !std::isfinite(s)) fail(c, rs, "friction.rest_speed must be a finite speed >= 0 (rad/s or m/s)");
  sys.rest_speed = s;
}

}  // namespace coopdyn::scene_detail
