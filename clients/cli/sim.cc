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
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "clients/cli/cli.h"
#include "clients/cli/progress.h"
#include "clients/cli/scene_load.h"
#include "clients/csv/step_csv.h"
#include "service/dynamics/contacts.h"
#include "service/dynamics/holding_torque.h"
#include "service/dynamics/joint_limits.h"
#include "service/dynamics/integrators.h"
#include "service/dynamics/sigma/wrench_sigma.h"
#include "service/dynamics/wrenches.h"
#include "service/scene/scene.h"

namespace coopdyn::cli {

namespace {

// What the options asked for (read by cmd_sim).
struct SimPlan {
  double T, h;
  long every;
  Integrator integ;
  const TorqueProfile& prof;
  const TorqueProfile& steer;
  const std::vector<int>& steer_dofs;   // steer.dofs()
  const std::vector<int>& steer_locks;  // lock spec of each of steer_dofs
  HoldWorkspace* hold;                  // --hold: the holding torques added every step; null without
};

// The loop's state, sized once: a step allocates nothing.
struct SimRun {
  SimRun(const System& sys, size_t columns)
      : cts(sys),
        last_state(cts.spec.size(), ContactState::kOk),
        st(sys),
        wd(sys),
        sigma(sys),
        q(sys.q0),
        v(sys.v0),
        tau(sys.model.nv()),
        target(sys.model.nv()),
        q_prev(sys.model.nq()),
        v_prev(sys.model.nv()),
        lim(sys),
        said(sys.model.nv(), 0),
        line(columns) {
    row.contact_state.resize(cts.spec.size());
  }
  ContactData cts;  // per rolling contact: friction needed, utilisation, state (contacts.h)
  std::vector<ContactState> last_state;
  Stepper st;
  WrenchData wd;
  WrenchSigmaData sigma;  // with declared noise (the scene's `noise`), each wrench's sigma
  Eigen::VectorXd q, v, tau, target, q_prev, v_prev;
  Eigen::VectorXd tau_hold = Eigen::VectorXd::Zero(tau.size());
  bool hold_said = false;  // --hold: what the holding torques cannot do, said once
  LimitData lim;              // the joint limits the step's start state and torque exceed
  std::vector<uint8_t> said;  // (nv) the limit kinds already said per DOF
  StepRow row;
  CsvLine line;
};

// The applied torques and the locks' targets at the step's start, held over the step.
void apply_inputs(const System& sys, const SimPlan& p, double t, SimRun& r) {
  p.prof.eval(t, r.tau);
  if (p.hold && holding_torques("sim", sys, *p.hold, r.q, r.v, r.tau_hold, &r.hold_said)) r.tau += r.tau_hold;
  if (p.steer_dofs.empty()) return;
  p.steer.eval(t, r.target);
  for (size_t k = 0; k < p.steer_dofs.size(); ++k) set_lock_target(r.st, p.steer_locks[k], r.target[p.steer_dofs[k]]);
}

// Every step: a change of a contact's state is said when it happens.
void say_contact_changes(const System& sys, double t, SimRun& r) {
  const ContactData& cts = r.cts;
  for (size_t k = 0; k < cts.spec.size(); ++k) {
    if (cts.state[k] == r.last_state[k]) continue;
    const char* n = sys.constraints.specs[static_cast<size_t>(cts.spec[k])].name.c_str();
    if (cts.state[k] == ContactState::kOk)
      std::fprintf(stderr, "coopdyn sim: t=%g: wheel '%s' is back within its contact (ok)\n", t, n);
    else
      std::fprintf(stderr, "coopdyn sim: warning: t=%g: wheel '%s' %s (normal %.6g N, friction needed %.4g)\n", t, n,
                   cts.state[k] == ContactState::kLiftOff ? "lifts off" : "needs more friction than its mu", cts.normal[k],
                   cts.friction_needed[k]);
    r.last_state[k] = cts.state[k];
  }
}

// Every step: the joint limits (q, v, tau) at the step's start exceed; each joint's first pass of
// each of its limits is said when it happens.
void check_limits(const System& sys, double t, SimRun& r) {
  if (check_joint_limits(sys, r.lim, r.q_prev, r.v_prev, r.tau) == 0) return;
  for (int d : r.lim.dofs) {
    const uint8_t fresh = r.lim.mask[d] & ~r.said[d];
    if (!fresh) continue;
    r.said[d] |= fresh;
    for (LimitBit b : {kLimitPosition, kLimitVelocity, kLimitEffort}) {
      if (!(fresh & b)) continue;
      const int qi = sys.model.bodies[sys.model.dof_body[d]].joint.idx_q;
      const double x = b == kLimitPosition ? r.q_prev[qi] : b == kLimitVelocity ? r.v_prev[d] : r.tau[d];
      const double lo = b == kLimitPosition ? sys.q_lower[d] : b == kLimitVelocity ? -sys.v_limit[d] : -sys.tau_limit[d];
      const double hi = b == kLimitPosition ? sys.q_upper[d] : b == kLimitVelocity ? sys.v_limit[d] : sys.tau_limit[d];
      const char* name = sys.model.v_names[d].c_str();
      std::fprintf(stderr,
                   "coopdyn sim: warning: t=%g: joint '%s' passes its %s limit: %.6g outside [%.6g, %.6g] "
                   "(column limit:%s)\n", t, name, limit_word(b), x, lo, hi, name);
    }
  }
}

// The row of the step that started at t from the state before it (the wrenches are computed here:
// only for the rows written), then position_error and each limited joint's limits exceeded.
void write_sim_row(const System& sys, double t, const Diagnostics& d, SimRun& r, std::FILE* out) {
  const Workspace& ws = r.st.ws;
  compute_wrenches(sys, ws, r.wd);
  if (r.sigma.declared) compute_wrench_sigma(sys, r.st.ws, r.sigma);
  StepRow& row = r.row;
  row.t = t;
  row.q = csv_numbers(r.q_prev);
  row.v = csv_numbers(r.v_prev);
  row.tau = csv_numbers(r.tau);
  row.vdot = csv_numbers(ws.vdot);
  row.wrenches = csv_wrenches(r.wd.W);
  if (r.sigma.declared) row.wrench_sigma = csv_wrenches(r.sigma.sigma);
  row.stress = csv_numbers(ws.stress);
  row.friction_needed = r.cts.friction_needed.data();
  row.utilisation = r.cts.utilisation.data();
  for (size_t k = 0; k < r.cts.spec.size(); ++k) row.contact_state[k] = contact_state_name(r.cts.state[k]);
  row.status = status_name(d.status);
  row.reason = reason_key(static_cast<int>(d.reason));
  row.rows = d.rows;
  row.rank = d.rank;
  row.indeterminate = d.indeterminate;
  row.condition = std::isfinite(d.condition) ? d.condition : -1.0;  // -1: infinite, as output_t
  row.residual = d.residual;
  write_step_cells(r.line, row);
  r.line.sep(), r.line.num(ws.cd.err.size() ? ws.cd.err.cwiseAbs().maxCoeff() : 0.0);
  for (int dof : r.lim.dofs) r.line.sep(), r.line.num(static_cast<double>(r.lim.mask[dof]));
  r.line.end();
  r.line.write(out);
}

void say_stop(const System& sys, double t, const Diagnostics& d, const SimRun& r) {
  std::fprintf(stderr, "coopdyn sim: stopped at t=%g: %s", t, reason_text(d.reason));
  if (d.reason == Reason::kDiverged && d.bad_index >= 0)
    std::fprintf(stderr, " (v:%s reached %.3g, bound solver.max_speed %.3g; the last row is the last good state)",
                 sys.model.v_names[d.bad_index].c_str(), r.st.diverged_speed, sys.options.max_speed);
  std::fprintf(stderr, "\n");
}

void report_progress(Progress& progress, long i, long steps, double t, double T) {
  if (!progress.on() || (i & 255) != 0) return;
  const double frac = steps > 0 ? double(i) / steps : 1.0;
  char what[96];
  std::snprintf(what, sizeof what, "t = %.3f of %.3f s (%.0f %%)", t, T, 100 * frac);
  progress.report(frac, what);
}

// The run, one row per written step; 3 when a step fails (its row is written, then why).
int simulate(const System& sys, const SimPlan& p, SimRun& r, Progress& progress, std::FILE* out) {
  const long steps = std::lround(p.T / p.h);
  for (long i = 0; i <= steps; ++i) {
    const double t = i * p.h;
    apply_inputs(sys, p, t, r);
    r.q_prev = r.q;  // no allocation: sized above
    r.v_prev = r.v;
    const Diagnostics& d =
        i < steps ? step(sys, r.st, p.integ, p.h, r.tau, r.q, r.v) : evaluate(sys, r.st.ws, r.q, r.v, r.tau);
    compute_contacts(sys, r.st.ws, r.cts);
    say_contact_changes(sys, t, r);
    check_limits(sys, t, r);
    if (i % p.every == 0 || d.status == Status::kError) write_sim_row(sys, t, d, r, out);
    if (d.status == Status::kError) {
      progress.break_line();
      say_stop(sys, t, d, r);
      return 3;
    }
    report_progress(progress, i, steps, t, p.T);
  }
  progress.done(std::to_string(steps) + " steps");
  return 0;
}

}  // namespace

void register_sim(Cli& cli) {
  auto [c, a] = cli.add("sim", cmd_sim);
  scene_options(c, a, true);
  number(c, "--duration", a.duration, "T", "simulated time, s")->required();
  number(c, "--dt", a.dt, "H", "step, s")->required();
  value(c, "--integrator", a.integrator, "NAME", "semi_implicit_euler, rk4 or implicit_euler", Default::kShown);
  profile_options(c, a, "applied torque; repeat to combine (see below)",
                  "target of a locked joint (a steer angle, rad); repeat to combine (see below)");
  value(c, "--out", a.out, "FILE.csv", "where to write the CSV (default: stdout)");
  number(c, "--every", a.every, "N", "write every N-th step only (t = 0, N dt, 2 N dt, ...)", Default::kShown);
  flag(c, "--progress", a.progress, "report progress on stderr (default: only when stderr is a terminal)");
  flag(c, "--hold", a.hold,
       "add, every step, the holding torques at the step's start state (coopdynd's safe torque `hold`, clamped to the torque limits) to the profiles");
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
  // the per-step CSV schema (clients/csv/step_csv.h): the shared columns, then position_error
  const StepSchema schema = step_schema(sys, "sim");
  CsvColumns cols = shared_step_columns(schema);
  cols.add("position_error", "m or rad");
  // per joint with a limit: the limits the row's q, v, tau exceed, bits 1 position, 2 velocity, 4 effort
  for (int d : LimitData(sys).dofs) cols.add("limit:" + sys.model.v_names[d], "bits");
  write_step_csv_header(out, schema, cols);

  SimRun run(sys, cols.names.size());
  std::optional<HoldWorkspace> hold;
  if (a.hold) hold.emplace(sys, default_actuated(sys));
  Progress progress("coopdyn sim", a.progress);
  const int rc = simulate(sys, {T, h, every, integ, prof, steer, steer_dofs, steer_locks, hold ? &*hold : nullptr}, run, progress, out);
  if (out != stdout) std::fclose(out);
  else std::fflush(out);
  return rc;
}

}  // namespace coopdyn::cli
