// coopdyn eval: one constrained evaluation, printed as JSON.
#include <cstdio>

#include "clients/cli/cli.h"
#include "clients/cli/scene_load.h"
#include "service/dynamics/joint_limits.h"
#include "service/scene/scene.h"

namespace coopdyn::cli {

void register_eval(Cli& cli) {
  auto [c, a] = cli.add("eval", cmd_eval);
  scene_options(c, a, true);
  value(c, "--state", a.state, "FILE.json",
        "q, v, tau (each optional): a list in the scene's coordinate order (the JSON's coordinates.q and .v; in the "
        "mobile_platform form an arm's joints run from its tip to its base), or an object by coordinate name "
        "({\"q\": {\"arm1.q1\": 0.3}}: the others keep their default) (default: the scene's initial state, zero torque)");
  flag(c, "--hold", a.hold,
       "add the holding torques at the state to tau (coopdynd's safe torque `hold`: the least torques, as fractions of "
       "each joint's limit, that leave the system at rest, clamped to the limits)");
}

int cmd_eval(const EvalArgs& a) {
  System sys;
  if (const int rc = load_cli_scene(a, "eval", &sys)) return rc;
  Eigen::VectorXd q = sys.q0, v = sys.v0, tau = Eigen::VectorXd::Zero(sys.model.nv());
  if (a.state && !read_state(*a.state, sys, q, v, tau)) return 1;
  if (a.hold) {
    HoldWorkspace hw(sys, default_actuated(sys));
    Eigen::VectorXd th(sys.model.nv());
    bool said = false;
    if (!holding_torques("eval", sys, hw, q, v, th, &said)) return 1;
    tau += th;
  }
  Workspace ws(sys);
  const Diagnostics& d = evaluate(sys, ws, q, v, tau);
  write_eval_json(stdout, sys, ws, q, v, tau);
  warn_contacts(stderr, "eval", sys, ws);
  LimitData ld(sys);
  if (check_joint_limits(sys, ld, q, v, tau) > 0)
    std::fprintf(stderr, "coopdyn eval: warning: %d joint(s) past their limits (limits_exceeded)\n", ld.exceeded);
  return d.status == Status::kError ? 3 : 0;
}

}  // namespace coopdyn::cli
