// coopdyn sim: fixed-step simulation to CSV (time, state, wrenches, stresses, diagnostics).
//
// The CSV is the per-step schema of clients/csv/step_csv.h (docs/conventions.md), the columns every
// source shares plus position_error. Numbers are written by std::to_chars in their shortest
// round-trip form (strtod reads back the exact double, like %.17g, in fewer characters) into one
// line buffer, one fwrite per row. --every N writes every N-th step (rows t = 0, N dt, 2 N dt, ...:
// row k is row k N of the full run, bit for bit; a step that fails is written too) and skips the
// wrenches of the steps not written. Progress goes to stderr when it is a terminal, or on
// --progress.
#include <unistd.h>

#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "clients/cli/cli.h"
#include "clients/cli/progress.h"
#include "clients/csv/step_csv.h"
#include "service/dynamics/contacts.h"
#include "service/dynamics/integrators.h"
#include "service/dynamics/wrenches.h"
#include "service/scene/scene.h"

namespace coopdyn::cli {


void register_sim(Cli& cli) {
  auto [c, a] = cli.add("sim",
                        "Simulate a scene with a fixed step and write CSV: time, state, torques, every reported wrench, "
                        "stresses, diagnostics (exit 3 on a numerical failure).",
                        cmd_sim);
  scene_options(c, a, true);
  number(c, "--duration", a.duration, "T", "simulated time, s")->required();
  number(c, "--dt", a.dt, "H", "step, s")->required();
  value(c, "--integrator", a.integrator, "NAME", "semi_implicit_euler, rk4 or implicit_euler", Default::kShown);
  profile_options(c, a, "applied torque; repeat to combine (see below)",
                  "target of a locked joint (a steer angle, rad); repeat to combine (see below)");
  value(c, "--out", a.out, "FILE.csv", "where to write the CSV (default: stdout)");
  number(c, "--every", a.every, "N", "write every N-th step only (t = 0, N dt, 2 N dt, ...)", Default::kShown);
  flag(c, "--progress", a.progress, "report progress on stderr (default: only when stderr is a terminal)");
}

int cmd_sim(const SimArgs& a) {
  const double T = a.duration, h = a.dt;
  if (!(T >= 0) || !(h > 0) || !std::isfinite(T) || !std::isfinite(h)) {
    std::fprintf(stderr, "coopdyn sim: need duration >= 0 and dt > 0\n");
    return 2;
  }
  if (!a.every.whole || a.every.value < 1) {
    std::fprintf(stderr, "coopdyn sim: --every must be a whole number >= 1 (got '%s')\n", a.every.text.c_str());
    return 2;
  }
  const long every = a.every.value;
  Integrator integ = Integrator::kRk4;
  if (!parse_integrator(a.integrator, &integ)) {
    std::fprintf(stderr, "coopdyn sim: unknown integrator '%s' (semi_implicit_euler, rk4, implicit_euler)\n", a.integrator.c_str());
    return 2;
  }
  System sys;
  if (const int rc = load_cli_scene(a, "sim", &sys)) return rc;
  TorqueProfile prof;
  if (const int rc = load_cli_profile(a, "sim", sys, &prof)) return rc;
  TorqueProfile steer;
  std::vector<int> steer_locks;  // lock spec of each of steer.dofs()
  if (const int rc = load_cli_targets(a, "sim", sys, &steer, &steer_locks)) return rc;
  const std::vector<int> steer_dofs = steer.dofs();
  std::FILE* out = stdout;
  if (a.out) {
    out = std::fopen(a.out->c_str(), "w");
    if (!out) {
      std::fprintf(stderr, "coopdyn sim: cannot write '%s'\n", a.out->c_str());
      return 1;
    }
  }
  static std::vector<char> iobuf(1 << 16);  // outlives stdout's last flush at exit
  std::setvbuf(out, iobuf.data(), _IOFBF, iobuf.size());
  const Model& model = sys.model;
  ContactData cts(sys);  // per rolling contact: friction needed, utilisation, state (contacts.h)
  std::vector<ContactState> last_state(cts.spec.size(), ContactState::kOk);
  // the per-step CSV schema (clients/csv/step_csv.h): the shared columns, then position_error
  const StepSchema schema = step_schema(sys, "sim");
  CsvColumns cols = shared_step_columns(schema);
  cols.add("position_error", "m or rad");
  write_step_csv_header(out, schema, cols);

  Stepper st(sys);
  WrenchData wd(sys);
  Eigen::VectorXd q = sys.q0, v = sys.v0, tau(model.nv()), target(model.nv());
  Eigen::VectorXd q_prev(model.nq()), v_prev(model.nv());
  CsvLine line(cols.names.size());
  const long steps = std::lround(T / h);
  Progress progress("coopdyn sim", a.progress);
  int rc = 0;
  for (long i = 0; i <= steps; ++i) {
    const double t = i * h;
    prof.eval(t, tau);
    if (!steer_dofs.empty()) {  // the locks' targets at the step's start, held over the step
      steer.eval(t, target);
      for (size_t k = 0; k < steer_dofs.size(); ++k) set_lock_target(st, steer_locks[k], target[steer_dofs[k]]);
    }
    q_prev = q;  // no allocation: sized above
    v_prev = v;
    const Diagnostics& d = i < steps ? step(sys, st, integ, h, tau, q, v) : evaluate(sys, st.ws, q, v, tau);
    compute_contacts(sys, st.ws, cts);  // every step: a change of a contact's state is said when it happens
    for (size_t k = 0; k < cts.spec.size(); ++k) {
      if (cts.state[k] == last_state[k]) continue;
      const char* n = sys.constraints.specs[static_cast<size_t>(cts.spec[k])].name.c_str();
      if (cts.state[k] == ContactState::kOk)
        std::fprintf(stderr, "coopdyn sim: t=%g: wheel '%s' is back within its contact (ok)\n", t, n);
      else
        std::fprintf(stderr, "coopdyn sim: warning: t=%g: wheel '%s' %s (normal %.6g N, friction needed %.4g)\n", t, n,
                     cts.state[k] == ContactState::kLiftOff ? "lifts off" : "needs more friction than its mu", cts.normal[k],
                     cts.friction_needed[k]);
      last_state[k] = cts.state[k];
    }
    if (i % every == 0 || d.status == Status::kError) {  // the failing step's row is always written
      line.clear();
      line.num(t);
      for (int k = 0; k < q_prev.size(); ++k) line.sep(), line.num(q_prev[k]);
      for (int k = 0; k < v_prev.size(); ++k) line.sep(), line.num(v_prev[k]);
      for (int k = 0; k < tau.size(); ++k) line.sep(), line.num(tau[k]);
      for (Eigen::Index k = 0; k < st.ws.vdot.size(); ++k) line.sep(), line.num(st.ws.vdot[k]);
      compute_wrenches(sys, st.ws, wd);
      for (const Vec6& w : wd.W)
        for (int k = 0; k < 6; ++k) line.sep(), line.num(w[k]);
      for (Eigen::Index k = 0; k < st.ws.stress.size(); ++k) line.sep(), line.num(st.ws.stress[k]);
      for (size_t k = 0; k < cts.spec.size(); ++k) {
        line.sep(), line.num(cts.friction_needed[k]);
        line.sep(), line.num(cts.utilisation[k]);
        line.sep(), line.text(contact_state_name(cts.state[k]));
      }
      line.sep(), line.text(status_name(d.status));
      line.sep(), line.text(reason_key(static_cast<int>(d.reason)));
      line.sep(), line.integer(d.rows);
      line.sep(), line.integer(d.rank);
      line.sep(), line.integer(d.indeterminate);
      line.sep(), line.num(std::isfinite(d.condition) ? d.condition : -1.0);  // -1: infinite, as output_t
      line.sep(), line.num(d.residual);
      line.sep(), line.num(st.ws.cd.err.size() ? st.ws.cd.err.cwiseAbs().maxCoeff() : 0.0);
      line.end();
      line.write(out);
    }
    if (d.status == Status::kError) {
      progress.break_line();
      std::fprintf(stderr, "coopdyn sim: stopped at t=%g: %s", t, reason_text(d.reason));
      if (d.reason == Reason::kDiverged && d.bad_index >= 0)
        std::fprintf(stderr, " (v:%s reached %.3g, bound solver.max_speed %.3g; the last row is the last good state)",
                     model.v_names[d.bad_index].c_str(), st.diverged_speed, sys.options.max_speed);
      std::fprintf(stderr, "\n");
      rc = 3;
      break;
    }
    if (progress.on() && (i & 255) == 0) {
      const double frac = steps > 0 ? double(i) / steps : 1.0;
      char what[96];
      std::snprintf(what, sizeof what, "t = %.3f of %.3f s (%.0f %%)", t, T, 100 * frac);
      progress.report(frac, what);
    }
  }
  if (rc == 0) progress.done(std::to_string(steps) + " steps");
  if (out != stdout) std::fclose(out);
  else std::fflush(out);
  return rc;
}

}  // namespace coopdyn::cli
