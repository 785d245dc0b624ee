// coopdyn eval: one constrained evaluation, printed as JSON.
#include <yaml-cpp/yaml.h>

#include <cstdio>

#include "clients/cli/cli.h"
#include "service/scene/scene.h"

namespace coopdyn::cli {

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
  auto get = [&](const char* key, Eigen::VectorXd& out, int size) -> bool {
    const YAML::Node x = n[key];
    if (!x.IsDefined()) return true;  // keep the default
    if (!x.IsSequence() || static_cast<int>(x.size()) != size) {
      std::fprintf(stderr, "coopdyn: %s: '%s' must be a list of %d numbers (the scene's coordinate order)\n", path.c_str(),
                   key, size);
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

void register_eval(Cli& cli) {
  auto [c, a] = cli.add("eval",
                        "Evaluate one state of a scene and print it as JSON: accelerations, wrenches, stresses, "
                        "diagnostics (exit 3 on an error status).",
                        cmd_eval);
  scene_options(c, a, true);
  value(c, "--state", a.state, "FILE.json",
        "q, v, tau (each optional) in the scene's coordinate order (default: the scene's initial state, zero torque)");
}

int cmd_eval(const EvalArgs& a) {
  System sys;
  if (const int rc = load_cli_scene(a, "eval", &sys)) return rc;
  Eigen::VectorXd q = sys.q0, v = sys.v0, tau = Eigen::VectorXd::Zero(sys.model.nv());
  if (a.state && !read_state(*a.state, sys, q, v, tau)) return 1;
  Workspace ws(sys);
  const Diagnostics& d = evaluate(sys, ws, q, v, tau);
  write_eval_json(stdout, sys, ws, q, v, tau);
  warn_contacts(stderr, "eval", sys, ws);
  return d.status == Status::kError ? 3 : 0;
}

}  // namespace coopdyn::cli
