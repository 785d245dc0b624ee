#include "clients/cli/scene_load.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "service/scene/scene.h"

namespace coopdyn::cli {

int load_cli_scene(const SceneArgs& a, const char* cmd, System* sys) {
  if (!a.scene) {
    std::fprintf(stderr, "coopdyn %s: --scene FILE is required\n", cmd);
    return 2;
  }
  SceneOverrides ov;
  if (a.formulation) {
    Formulation f;
    if (!parse_formulation(*a.formulation, &f)) {
      std::fprintf(stderr, "coopdyn %s: unknown formulation '%s' (mobile_platform, classic, pseudo_joint, svd)\n", cmd,
                   a.formulation->c_str());
      return 2;
    }
    ov.formulation = f;
  }
  try {
    *sys = load_scene(*a.scene, ov);
  } catch (const SceneError& e) {
    std::fprintf(stderr, "coopdyn: %s\n", e.what());
    return 1;
  }
  for (const std::string& w : sys->warnings) std::fprintf(stderr, "coopdyn %s: warning: %s\n", cmd, w.c_str());
  return 0;
}

// Reads q, v, tau from a JSON (or YAML) state file; sizes must match the scene.
bool read_state(const std::string& path, const System& sys, Eigen::VectorXd& q, Eigen::VectorXd& v, Eigen::VectorXd& tau) {
  YAML::Node n;
  try {
    n = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    std::fprintf(stderr, "coopdyn: %s: cannot open state file\n", path.c_str());
    return false;
  } catch (const YAML::Exception& e) {
    std::fprintf(stderr, "coopdyn: %s:%d:%d: %s\n", path.c_str(), e.mark.line + 1, e.mark.column + 1, e.msg.c_str());
    return false;
  }
  // a list in the scene's coordinate order, or an object by coordinate name (those not named keep
  // their default)
  auto by_name = [&](const char* key, const YAML::Node& x, Eigen::VectorXd& out,
                     const std::vector<std::string>& names) -> bool {
    for (const auto& kv : x) {
      const std::string name = kv.first.as<std::string>("");
      const auto it = std::find(names.begin(), names.end(), name);
      if (it == names.end()) {
        std::fprintf(stderr,
                     "coopdyn: %s:%d:%d: '%s' has no coordinate '%s' (coopdyn eval lists them as coordinates.%s)\n",
                     path.c_str(), kv.first.Mark().line + 1, kv.first.Mark().column + 1, key, name.c_str(),
                     key[0] == 'q' ? "q" : "v");
        return false;
      }
      try {
        out[it - names.begin()] = kv.second.as<double>();
      } catch (const YAML::Exception&) {
        std::fprintf(stderr, "coopdyn: %s:%d:%d: '%s'.'%s' is not a number\n", path.c_str(), kv.second.Mark().line + 1,
                     kv.second.Mark().column + 1, key, name.c_str());
        return false;
      }
    }
    return true;
  };
  auto get = [&](const char* key, Eigen::VectorXd& out, int size) -> bool {
    const YAML::Node x = n[key];
    if (!x.IsDefined()) return true;  // keep the default
    if (x.IsMap()) return by_name(key, x, out, key[0] == 'q' ? sys.model.q_names : sys.model.v_names);
    if (!x.IsSequence() || static_cast<int>(x.size()) != size) {
      std::fprintf(stderr, "coopdyn: %s: '%s' must be a list of %d numbers (the scene's coordinate order) or an object "
                   "by coordinate name\n", path.c_str(), key, size);
      return false;
    }
    for (int i = 0; i < size; ++i) {
      try {
        out[i] = x[i].as<double>();
      } catch (const YAML::Exception&) {
        std::fprintf(stderr, "coopdyn: %s: '%s'[%d] is not a number\n", path.c_str(), key, i);
        return false;
      }
    }
    return true;
  };
  if (!n.IsMap()) {
    std::fprintf(stderr, "coopdyn: %s: a state file is an object with q, v, tau\n", path.c_str());
    return false;
  }
  return get("q", q, sys.model.nq()) && get("v", v, sys.model.nv()) && get("tau", tau, sys.model.nv());
}

bool holding_torques(const char* cmd, const System& sys, HoldWorkspace& hw, const Eigen::VectorXd& q,
                     const Eigen::VectorXd& v, Eigen::VectorXd& th, bool* said) {
  if (!holding_torque(sys, hw, q, v, th)) {
    std::fprintf(stderr, "coopdyn %s: --hold: the state is not valid (NaN/Inf or a non-unit quaternion)\n", cmd);
    return false;
  }
  if (!*said) {
    for (int i : hw.act)
      if (std::abs(th[i]) > sys.tau_limit[i]) {
        std::fprintf(stderr, "coopdyn %s: warning: --hold: %s needs %.6g to hold, beyond its torque limit %.6g: clamped to it, as coopdynd's hold is\n",
                     cmd, sys.model.v_names[i].c_str(), th[i], sys.tau_limit[i]);
        *said = true;
      }
    if (hw.residual > 1e-6) {
      std::fprintf(stderr, "coopdyn %s: warning: --hold: the actuators cannot hold this state (residual %.6g N*m or N)\n", cmd,
                   hw.residual);
      *said = true;
    }
  }
  clamp_to_torque_limits(sys, hw, th);
  return true;
}

}  // namespace coopdyn::cli
