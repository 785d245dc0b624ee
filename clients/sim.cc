// coopdyn sim: fixed-step simulation to CSV (time, state, wrenches, stresses, diagnostics).
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include "clients/cli.h"
#include "service/dynamics/contacts.h"
#include "service/dynamics/integrators.h"
#include "service/dynamics/wrenches.h"
#include "service/scene/scene.h"

namespace coopdyn::cli {

void register_sim(Cli& cli) {
  Command& c = cli.add("sim",
                       "Simulate a scene with a fixed step and write CSV: time, state, torques, every reported wrench, "
                       "stresses, diagnostics (exit 3 on a numerical failure).",
                       cmd_sim);
  scene_options(c, true);
  c.number("--duration", "T", "simulated time, s")->required();
  c.number("--dt", "H", "step, s")->required();
  c.value("--integrator", "NAME", "semi_implicit_euler, rk4 or implicit_euler", "rk4");
  c.repeated("--torque", "PROFILE", "applied torque; repeat to combine (see below)");
  c.value("--out", "FILE.csv", "where to write the CSV (default: stdout)");
  c.app->footer(kProfileHelp);
}

int cmd_sim(const Args& a) {
  if (!a.has("duration") || !a.has("dt")) {
    std::fprintf(stderr, "coopdyn sim: --duration and --dt are required\n");
    return 2;
  }
  double T, h;
  try {
    T = std::stod(a.get("duration"));
    h = std::stod(a.get("dt"));
  } catch (const std::exception&) {
    std::fprintf(stderr, "coopdyn sim: --duration and --dt must be numbers\n");
    return 2;
  }
  if (!(T >= 0) || !(h > 0) || !std::isfinite(T) || !std::isfinite(h)) {
    std::fprintf(stderr, "coopdyn sim: need duration >= 0 and dt > 0\n");
    return 2;
  }
  Integrator integ = Integrator::kRk4;
  if (a.has("integrator") && !parse_integrator(a.get("integrator"), &integ)) {
    std::fprintf(stderr, "coopdyn sim: unknown integrator '%s' (semi_implicit_euler, rk4, implicit_euler)\n", a.get("integrator").c_str());
    return 2;
  }
  System sys;
  if (const int rc = load_cli_scene(a, "sim", &sys)) return rc;
  TorqueProfile prof;
  if (const int rc = load_cli_profile(a, "sim", sys, &prof)) return rc;
  std::FILE* out = stdout;
  if (a.has("out")) {
    out = std::fopen(a.get("out").c_str(), "w");
    if (!out) {
      std::fprintf(stderr, "coopdyn sim: cannot write '%s'\n", a.get("out").c_str());
      return 1;
    }
  }
  const Model& model = sys.model;
  static const char* comp[6] = {"mx", "my", "mz", "fx", "fy", "fz"};
  std::fprintf(out, "t");
  for (const auto& n : model.q_names) std::fprintf(out, ",q:%s", n.c_str());
  for (const auto& n : model.v_names) std::fprintf(out, ",v:%s", n.c_str());
  for (const auto& n : model.v_names) std::fprintf(out, ",tau:%s", n.c_str());
  for (const auto& n : model.v_names) std::fprintf(out, ",vdot:%s", n.c_str());
  for (const WrenchOutput& o : sys.wrenches.outputs)
    for (int k = 0; k < 6; ++k) std::fprintf(out, ",%s.%s", o.name.c_str(), comp[k]);
  for (int d : model.pseudo_dofs) std::fprintf(out, ",stress:%s", model.v_names[d].c_str());
  ContactData cts(sys);  // per rolling contact: friction needed, utilisation, state (contacts.h)
  for (int s : cts.spec) {
    const char* n = sys.constraints.specs[static_cast<size_t>(s)].name.c_str();
    std::fprintf(out, ",%s.friction_needed,%s.utilisation,%s.contact", n, n, n);
  }
  std::vector<ContactState> last_state(cts.spec.size(), ContactState::kOk);
  std::fprintf(out, ",status,rank,residual,position_error\n");

  Stepper st(sys);
  WrenchData wd(sys);
  Eigen::VectorXd q = sys.q0, v = sys.v0, tau(model.nv());
  const long steps = std::lround(T / h);
  int rc = 0;
  for (long i = 0; i <= steps; ++i) {
    const double t = i * h;
    prof.eval(t, tau);
    Eigen::VectorXd q_prev = q, v_prev = v;
    const Diagnostics& d = i < steps ? step(sys, st, integ, h, tau, q, v) : evaluate(sys, st.ws, q, v, tau);
    std::fprintf(out, "%.17g", t);
    for (int k = 0; k < q_prev.size(); ++k) std::fprintf(out, ",%.17g", q_prev[k]);
    for (int k = 0; k < v_prev.size(); ++k) std::fprintf(out, ",%.17g", v_prev[k]);
    for (int k = 0; k < tau.size(); ++k) std::fprintf(out, ",%.17g", tau[k]);
    for (Eigen::Index k = 0; k < st.ws.vdot.size(); ++k) std::fprintf(out, ",%.17g", st.ws.vdot[k]);
    compute_wrenches(sys, st.ws, wd);
    for (const Vec6& w : wd.W)
      for (int k = 0; k < 6; ++k) std::fprintf(out, ",%.17g", w[k]);
    for (Eigen::Index k = 0; k < st.ws.stress.size(); ++k) std::fprintf(out, ",%.17g", st.ws.stress[k]);
    compute_contacts(sys, st.ws, cts);
    for (size_t k = 0; k < cts.spec.size(); ++k) {
      std::fprintf(out, ",%.17g,%.17g,%s", cts.friction_needed[k], cts.utilisation[k], contact_state_name(cts.state[k]));
      if (cts.state[k] != last_state[k]) {  // never silent: each change of a contact's state, once
        const char* n = sys.constraints.specs[static_cast<size_t>(cts.spec[k])].name.c_str();
        if (cts.state[k] == ContactState::kOk)
          std::fprintf(stderr, "coopdyn sim: t=%g: wheel '%s' is back within its contact (ok)\n", t, n);
        else
          std::fprintf(stderr, "coopdyn sim: warning: t=%g: wheel '%s' %s (normal %.6g N, friction needed %.4g)\n", t, n,
                       cts.state[k] == ContactState::kLiftOff ? "lifts off" : "needs more friction than its mu",
                       cts.normal[k], cts.friction_needed[k]);
        last_state[k] = cts.state[k];
      }
    }
    std::fprintf(out, ",%s,%d,%.3g,%.3g\n", status_name(d.status), d.rank, d.residual,
                 st.ws.cd.err.size() ? st.ws.cd.err.cwiseAbs().maxCoeff() : 0.0);
    if (d.status == Status::kError) {
      std::fprintf(stderr, "coopdyn sim: stopped at t=%g: %s", t, reason_text(d.reason));
      if (d.reason == Reason::kDiverged && d.bad_index >= 0)
        std::fprintf(stderr, " (v:%s reached %.3g, bound solver.max_speed %.3g; the last row is the last good state)",
                     model.v_names[d.bad_index].c_str(), st.diverged_speed, sys.options.max_speed);
      std::fprintf(stderr, "\n");
      rc = 3;
      break;
    }
  }
  if (out != stdout) std::fclose(out);
  return rc;
}

}  // namespace coopdyn::cli
