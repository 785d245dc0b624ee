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
}  // namespace

void read_noise(const Ctx& c, const YAML::Node& root, System& sys) {
  const Model& model = sys.model;
  sys.tau_noise.setZero(model.nv());
  const YAML::Node no = root["noise"];
  if (!no) return;
  if (!no.IsMap()) fail(c, no, "'noise' must be a mapping, e.g. {tau: 0.1, joints: {arm1.q1: 0.5}}");
  check_keys(c, no, {"tau", "joints"}, "noise");
  const std::vector<unsigned char> act = default_actuated(sys);
  const double all = no["tau"] ? noise_value(c, no["tau"], "noise.tau") : 0.0;
  for (int i = 0; i < model.nv(); ++i) sys.tau_noise[i] = act[static_cast<size_t>(i)] ? all : 0.0;
  const YAML::Node js = no["joints"];
  if (!js) return;
  if (!js.IsMap()) fail(c, js, "noise.joints must be a mapping of joint names (velocity names, e.g. arm1.q3) to N m or N");
  for (const auto& kv : js) {
    const std::string name = kv.first.as<std::string>();
    int dof = -1;
    for (int i = 0; i < model.nv(); ++i)
      if (model.v_names[static_cast<size_t>(i)] == name) dof = i;
    if (dof < 0) fail(c, kv.first, "noise.joints: unknown joint '" + name + "' (the scene's velocity names, e.g. arm1.q3)");
    if (!act[static_cast<size_t>(dof)])
      fail(c, kv.first, "noise.joints: joint '" + name + "' is not actuated (no torque to be noisy: a floating base, a "
                        "pseudo-joint or tau_limit 0)");
    sys.tau_noise[dof] = noise_value(c, kv.second, "noise.joints." + name);
  }
}

}  // namespace coopdyn::scene_detail
