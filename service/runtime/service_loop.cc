#include "service/runtime/service_loop.h"

#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>

#include "service/io/transport/lcm_bus.h"
#include "service/runtime/realtime.h"

namespace coopdyn::runtime {

namespace {
double us(int64_t ns) { return static_cast<double>(ns) * 1e-3; }
void percentiles(const Histogram& h, double out[4]) {
  out[0] = us(h.percentile(0.50));
  out[1] = us(h.percentile(0.99));
  out[2] = us(h.percentile(0.999));
  out[3] = us(h.max());
}
}  // namespace

ServiceLoop::ServiceLoop(const System& sys, const ServiceConfig& cfg, io::Bus& bus)
    : sys_(sys),
      cfg_(cfg),
      bus_(bus),
      period_ns_(cfg.period_ns()),
      watchdog_ns_(cfg.watchdog_ns()),
      dt_(1.0 / cfg.rate_hz),
      stats_every_(std::max<int64_t>(1, std::llround(cfg.stats_period_s * cfg.rate_hz))),
      commands_(sys, cfg.max_input_age_us(),
                [&](io::CommandSlot& s) {
                  s.tau = Eigen::VectorXd::Zero(sys.model.nv());
                  s.named.assign(static_cast<size_t>(sys.model.nv()), 1);
                  s.lock_target = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(sys.constraints.specs.size()));
                }),
      states_(sys, cfg.max_input_age_us(),
              [&](io::StateSlot& s) {
                s.q = sys.q0;
                s.v = sys.v0;
                s.tau = Eigen::VectorXd::Zero(sys.model.nv());
                s.has_wrench.assign(sys.wrenches.outputs.size(), 0);
                s.wrench.assign(sys.wrenches.outputs.size(), {});
              }),
      controls_(sys, cfg.max_input_age_us(),
                [&](io::ControlSlot& s) {
                  s.q = sys.q0;
                  s.v = sys.v0;
                }),
      stepper_(sys),
      ws_(sys),
      fit_plan_(plan_state_fit(sys)),
      fit_ws_(sys, fit_plan_),
      q_est_(sys.q0),
      v_est_(sys.v0),
      wrenches_(sys),
      contacts_(sys),
      sigma_(sys),
      refit_(sys, fit_plan_),
      bound_(sys),
      limits_(sys),
      limits_said_(static_cast<size_t>(sys.model.nv()), 0),
      q_(sys.q0),
      v_(sys.v0),
      tau_(Eigen::VectorXd::Zero(sys.model.nv())),
      q_prev_(sys.q0),
      v_prev_(sys.v0),
      actuated_(sys.model.nv(), 0),
      out_enc_(sys),
      out_buf_(static_cast<size_t>(out_enc_.max_size())),
      stats_buf_(static_cast<size_t>(stats_enc_.max_size())) {
  const Model& m = sys.model;
  for (int i = 0; i < m.nv(); ++i) actuated_[i] = std::isfinite(sys.tau_limit[i]) ? 1 : 0;
  for (int d : m.pseudo_dofs) actuated_[d] = 0;
  for (size_t k = 0; k < sys.constraints.specs.size(); ++k)
    if (sys.constraints.specs[k].kind == ConstraintKind::kLock && sys.constraints.specs[k].target_limit > 0)
      locks_.push_back(static_cast<int>(k));
  zero_ = Eigen::VectorXd::Zero(m.nv());
  if (!ws_.damped_dofs.empty() || !ws_.friction_dofs.empty())
    joint_losses_ = cfg.compensate_joint_losses ? io::JointLosses::kCompensated : io::JointLosses::kIgnored;
  if (!cfg.compensate_joint_losses) ws_.ignore_joint_losses();
  if (cfg.safe_torque == SafeTorque::kHold) hold_ = std::make_unique<HoldWorkspace>(sys, default_actuated(sys));
  last_input_ = cfg.mode == ServiceMode::kSimulate ? io::Input::kNoCommand : io::Input::kNoState;
  if (!cfg.auth_key_file.empty()) require_auth(io::read_key_file(cfg.auth_key_file));
}

void ServiceLoop::require_auth(const io::AuthKey& key) {
  cmd_auth_ = std::make_unique<io::Verifier>(key, cfg_.command_channel, io::MessageType::kTorqueCommand);
  state_auth_ = std::make_unique<io::Verifier>(key, cfg_.state_channel, io::MessageType::kMeasuredState);
  control_auth_ = std::make_unique<io::Verifier>(key, cfg_.control_channel, io::MessageType::kControl);
  commands_.require_auth(cmd_auth_.get());
  states_.require_auth(state_auth_.get());
  controls_.require_auth(control_auth_.get());
}

const InputCounters& ServiceLoop::input_counters() const {
  return cfg_.mode == ServiceMode::kSimulate ? commands_.counters() : states_.counters();
}

void ServiceLoop::safe_torque(const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  tau_.setZero();
  if (cfg_.safe_torque == SafeTorque::kHold) {
    // from the step's own first evaluation (h and G at (q, v)), which the step then finishes;
    // latched in a fault, the stepper's workspace keeps the last good evaluation
    if (faulted_.load(std::memory_order_relaxed)) {
      braking_torque(sys_, *hold_, q, v, cfg_.time_constant, tau_);
    } else {
      start_begun_ = begin_evaluation(sys_, stepper_.ws, q, v);
      if (start_begun_) braking_torque(sys_, *hold_, stepper_.ws, v, cfg_.time_constant, tau_);
    }
    for (int i : hold_->act) tau_[i] -= cfg_.damping * v[i];
    clamp_to_torque_limits(sys_, *hold_, tau_);
    return;
  }
  if (cfg_.safe_torque != SafeTorque::kDamping) return;
  for (Eigen::Index i = 0; i < tau_.size(); ++i) {
    if (!actuated_[i]) continue;
    const double lim = sys_.tau_limit[i];
    tau_[i] = std::max(-lim, std::min(lim, -cfg_.damping * v[i]));
  }
}

void ServiceLoop::handle_control(const io::ControlSlot& c) {
  using io::ControlAction;
  using io::ControlResult;
  ctrl_seq_ = c.seq;
  ctrl_action_ = c.action;
  ctrl_result_ = ControlResult::kOk;
  if (cfg_.mode != ServiceMode::kSimulate) {
    ctrl_result_ = ControlResult::kNotApplicable;
  } else {
    switch (c.action) {
      case ControlAction::kReset:
        std::fill(limits_said_.begin(), limits_said_.end(), 0);
        q_ = sys_.q0;
        v_ = sys_.v0;
        faulted_.store(false, std::memory_order_relaxed);
        fault_reason_ = Reason::kNone;
        break;
      case ControlAction::kResetToState: {
        // a valid configuration whose evaluation succeeds and that closes the constraints (1e-6);
        // a refusal says why (event kResetRejected): which check, and for the closure its largest
        // residual and the constraint it is in
        ResetRefusal why = ResetRefusal::kNone;
        Closure cl;
        if (!configuration_valid(sys_.model, c.q)) why = ResetRefusal::kConfiguration;
        else if (!c.v.allFinite()) why = ResetRefusal::kVelocity;
        else {
          const Diagnostics& d = evaluate(sys_, stepper_.ws, c.q, c.v, zero_);
          const ConstraintData& cd = stepper_.ws.cd;
          if (d.status == Status::kError) why = ResetRefusal::kEvaluation;
          else if (cd.err.size() != 0 && (cd.err.cwiseAbs().maxCoeff() > 1e-6 || cd.Gv.cwiseAbs().maxCoeff() > 1e-6)) {
            why = ResetRefusal::kClosure;
            closure_residual(sys_.constraints, fit_plan_, cd, &cl);
          }
        }
        const bool ok = why == ResetRefusal::kNone;
        if (!ok) {
          int kind = 0;  // the closure kind with the largest residual
          for (int k = 1; k < 4; ++k)
            if (cl.value[k] > cl.value[kind]) kind = k;
          events_.push({EventCode::kResetRejected, c.seq,
                        (static_cast<int64_t>(why) * 4 + (why == ResetRefusal::kClosure ? kind : 0)) * 65536 +
                            (why == ResetRefusal::kClosure ? cl.spec[kind] + 1 : 0),
                        why == ResetRefusal::kClosure ? cl.value[kind] : 0.0});
        }
        if (ok) {
          std::fill(limits_said_.begin(), limits_said_.end(), 0);
          q_ = c.q;
          v_ = c.v;
          faulted_.store(false, std::memory_order_relaxed);
          fault_reason_ = Reason::kNone;
        } else {
          ctrl_result_ = ControlResult::kRejectedState;
        }
        break;
      }
      case ControlAction::kPause: paused_ = true; break;
      case ControlAction::kResume: paused_ = false; break;
      case ControlAction::kClearFault:
        faulted_.store(false, std::memory_order_relaxed);
        fault_reason_ = Reason::kNone;
        break;
    }
  }
  events_.push({EventCode::kControl, c.seq, static_cast<int64_t>(c.action) * 16 + (static_cast<int64_t>(ctrl_result_) + 1), 0});
}

// What an input is called this tick and which events its watchdog reports, per mode.
struct ServiceLoop::InputWatch {
  io::Input none, expired, fresh;
  EventCode expired_event, resumed_event;
};
const ServiceLoop::InputWatch ServiceLoop::kCommandWatch{io::Input::kNoCommand, io::Input::kCommandExpired,
                                                         io::Input::kCommand, EventCode::kCommandExpired,
                                                         EventCode::kCommandResumed};
const ServiceLoop::InputWatch ServiceLoop::kStateWatch{io::Input::kNoState, io::Input::kStateExpired, io::Input::kState,
                                                       EventCode::kStateExpired, EventCode::kStateResumed};

namespace {

// An output that carries no evaluation: the status error and why.
void put_error(io::OutputFrame& f, int16_t reason) {
  f.valid = false;
  f.status = static_cast<int8_t>(Status::kError);
  f.reason = reason;
}
}  // namespace

void ServiceLoop::tick(long long now) {
  if (!started_) {
    started_ = true;
    t0_ns_ = now;
  }
  io::OutputFrame f;
  f.tick = ticks_.load(std::memory_order_relaxed);
  take_control(f);
  if (cfg_.mode == ServiceMode::kSimulate) simulate(now, f);
  else estimate(now, f);
  check_limits(f);
  publish_output(f);
}

// The joint limits the published state and torque exceed: in the frame, and counted per kind.
void ServiceLoop::check_limits(io::OutputFrame& f) {
  if (!f.q || !f.v || !f.tau) return;
  f.limits = &limits_;
  if (check_joint_limits(sys_, limits_, *f.q, *f.v, *f.tau) == 0) return;
  limit_ticks_[0].fetch_add(1, std::memory_order_relaxed);
  for (int k = 0; k < 3; ++k)
    if (limits_.any & (1u << k)) limit_ticks_[k + 1].fetch_add(1, std::memory_order_relaxed);
  for (int d : limits_.dofs) {  // each joint's first pass of each limit, to the daemon's log
    const size_t i = static_cast<size_t>(d);
    const uint8_t fresh = static_cast<uint8_t>(limits_.mask[i] & ~limits_said_[i]);
    if (!fresh) continue;
    limits_said_[i] |= fresh;
    events_.push({EventCode::kLimitPassed, d, fresh, f.sim_time});
  }
}

void ServiceLoop::take_control(io::OutputFrame& f) {
  if (controls_.update()) handle_control(controls_.latest());
  f.paused = paused_;
  f.control_seq = ctrl_seq_;
  f.control_action = ctrl_action_;
  f.control_result = ctrl_result_;
}

// The watchdog: takes the newest input, and says whether there is none yet, it expired or it is
// fresh; an expiry is counted and reported once, and so is the return of a fresh input.
template <class Inbox>
io::Input ServiceLoop::watch_input(Inbox& inbox, bool& have, long long now, const InputWatch& w) {
  if (inbox.update()) have = true;
  const auto& x = inbox.latest();
  const io::Input in = !have ? w.none : now - x.recv_ns > watchdog_ns_ ? w.expired : w.fresh;
  if (in == w.expired && !input_expired_) {
    input_expired_ = true;
    expired_.fetch_add(1, std::memory_order_relaxed);
    inbox.note_expired();  // counted here, then the sequence rule may follow a restart
    events_.push({w.expired_event, x.seq, (now - x.recv_ns) / 1000000, 0});
  } else if (in == w.fresh && input_expired_) {
    input_expired_ = false;
    events_.push({w.resumed_event, x.seq, 0, 0});
  }
  last_input_ = in;
  return in;
}

void ServiceLoop::simulate(long long now, io::OutputFrame& f) {
  f.mode = io::Mode::kSimulate;
  const io::Input in = watch_input(commands_, have_cmd_, now, kCommandWatch);
  const io::CommandSlot& c = commands_.latest();
  apply_command(in, c);
  f.input = in;
  f.input_seq = have_cmd_ ? c.seq : -1;
  f.input_utime = have_cmd_ ? c.utime : -1;
  f.sim_time = sim_time_;
  f.tau = &tau_;
  if (faulted_.load(std::memory_order_relaxed)) {
    // latched: the state stays where it was last good, nothing is integrated
    put_error(f, static_cast<int16_t>(fault_reason_));
    f.q = &q_;
    f.v = &v_;
  } else if (paused_) {
    evaluate_held(f);
  } else {
    integrate(f);
  }
}

// The torque and lock targets of this step: the command's, or without a fresh one the safe torque
// and the scene's lock targets.
void ServiceLoop::apply_command(io::Input in, const io::CommandSlot& c) {
  start_begun_ = false;
  if (in == io::Input::kCommand) {
    for (int k : locks_) set_lock_target(stepper_, k, c.lock_target[k]);
    bool partial = false;  // an actuated DOF the command does not name: it takes the safe torque
    for (int i = 0; i < sys_.model.nv() && !partial; ++i) partial = actuated_[i] && !c.named[i];
    if (!partial) {
      tau_ = c.tau;
      return;
    }
    safe_torque(q_, v_);  // after the targets: the hold's evaluation reads them
    for (int i = 0; i < sys_.model.nv(); ++i)
      if (c.named[i]) tau_[i] = c.tau[i];
  } else {
    // no command, or it expired: every lock holds the scene's q again (before the safe torque: the
    // hold begins the step's evaluation, whose constraint errors read the targets)
    for (int k : locks_) set_lock_target(stepper_, k, sys_.constraints.specs[static_cast<size_t>(k)].q_target);
    safe_torque(q_, v_);
  }
}

// paused: nothing is integrated; the outputs are the evaluation at the held state
void ServiceLoop::evaluate_held(io::OutputFrame& f) {
  const Diagnostics& d =
      start_begun_ ? finish_evaluation(sys_, stepper_.ws, v_, tau_) : evaluate(sys_, stepper_.ws, q_, v_, tau_);
  f.q = &q_;
  f.v = &v_;
  put_evaluation(f, stepper_.ws, d, d.status != Status::kError);
  if (f.valid) {
    closure_residual(sys_.constraints, fit_plan_, stepper_.ws.cd, &closure_);
    f.closure = &closure_;
  }
}

// One step; the outputs are those of its start state. A failed step latches the fault and keeps
// the start state.
void ServiceLoop::integrate(io::OutputFrame& f) {
  q_prev_ = q_;
  v_prev_ = v_;
  if (start_begun_) finish_evaluation(sys_, stepper_.ws, v_, tau_);
  const Diagnostics& d = start_begun_ ? step_evaluated(sys_, stepper_, cfg_.integrator, dt_, tau_, q_, v_)
                                      : step(sys_, stepper_, cfg_.integrator, dt_, tau_, q_, v_);
  const bool ok = d.status != Status::kError && q_.allFinite() && v_.allFinite();
  f.q = &q_prev_;
  f.v = &v_prev_;
  put_evaluation(f, stepper_.ws, d, ok);
  if (ok) {
    closure_residual(sys_.constraints, fit_plan_, stepper_.ws.cd, &closure_);
    f.closure = &closure_;
    sim_time_ += dt_;
    return;
  }
  q_ = q_prev_;
  v_ = v_prev_;
  fault_reason_ = d.status == Status::kError ? d.reason : Reason::kNonFiniteResult;
  faulted_.store(true, std::memory_order_relaxed);
  numerical_errors_.fetch_add(1, std::memory_order_relaxed);
  events_.push({EventCode::kFault, static_cast<int64_t>(fault_reason_), f.tick, sim_time_});
  put_error(f, static_cast<int16_t>(fault_reason_));
}

void ServiceLoop::estimate(long long now, io::OutputFrame& f) {
  f.mode = io::Mode::kEstimate;
  f.joint_losses = joint_losses_;
  const io::Input in = watch_input(states_, have_state_, now, kStateWatch);
  const io::StateSlot& s = states_.latest();
  f.input = in;
  f.input_seq = have_state_ ? s.seq : -1;
  f.input_utime = have_state_ ? s.utime : -1;
  f.sim_time = static_cast<double>(now - t0_ns_) * 1e-9;
  f.q = &s.q;
  f.v = &s.v;
  f.tau = &s.tau;
  if (in == io::Input::kState) evaluate_measured(s, f);
  else put_error(f, in == io::Input::kNoState ? io::kReasonNoState : io::kReasonStateStale);
}

// Completes the state (the load's pose and twist from the joints, when omitted), measures how well
// it closes the constraints, and evaluates it when it closes them within closure_tolerance.
void ServiceLoop::evaluate_measured(const io::StateSlot& s, io::OutputFrame& f) {
  q_est_ = s.q;
  v_est_ = s.v;
  const Closure& cl = fit_state(sys_, fit_plan_, fit_ws_, s.fit_q, s.fit_v, q_est_, v_est_);
  f.q = &q_est_;
  f.v = &v_est_;
  f.closure = &cl;
  f.measured = &s;
  f.state_fitted = static_cast<uint8_t>((s.fit_q ? 1 : 0) | (s.fit_v ? 2 : 0));
  f.fit_iterations = cl.iterations;
  int over = -1;  // the kind furthest above its tolerance (NaN counts as above)
  double worst = 1.0;
  for (int k = 0; k < 4; ++k) {
    const double ratio = cl.value[k] / cfg_.closure_tolerance[k];
    if (!(ratio <= worst)) {
      worst = std::isnan(ratio) ? HUGE_VAL : ratio;
      over = k;
    }
  }
  if (over >= 0) {
    // the arms disagree (or the measurement is far from the constraints): no wrenches
    put_error(f, io::kReasonClosure);
    closure_rejected_.fetch_add(1, std::memory_order_relaxed);
    if (!closure_open_)
      events_.push({EventCode::kClosureOpen, s.seq, static_cast<int64_t>(over) * 65536 + (cl.spec[over] + 1), cl.value[over]});
    closure_open_ = true;
    return;
  }
  if (closure_open_) events_.push({EventCode::kClosureBack, s.seq, 0, 0});
  closure_open_ = false;
  const Diagnostics& d = evaluate(sys_, ws_, q_est_, v_est_, s.tau);
  put_evaluation(f, ws_, d, d.status != Status::kError, &s);
  if (!f.valid) numerical_errors_.fetch_add(1, std::memory_order_relaxed);
  if (f.valid && joint_losses_ == io::JointLosses::kCompensated && bound_.possible) {
    compute_friction_bound(sys_, ws_, bound_);
    f.bound = &bound_;
  }
}

// The frame's evaluation: its workspace, status and reason, and when it succeeded (ok) the
// scene's wrenches of it.
void ServiceLoop::put_evaluation(io::OutputFrame& f, Workspace& ws, const Diagnostics& d, bool ok,
                                 const io::StateSlot* estimated) {
  f.ws = &ws;
  f.valid = ok;
  f.status = static_cast<int8_t>(d.status);
  f.reason = static_cast<int16_t>(d.reason);
  if (!ok) return;
  compute_wrenches(sys_, ws, wrenches_);
  f.wrenches = &wrenches_;
  compute_contacts(sys_, ws, contacts_);
  f.contacts = &contacts_;
  if (sigma_.declared) {
    if (estimated) {
      sigma_.refit = nullptr;
      if (!sigma_.q_dofs.empty() || !sigma_.v_dofs.empty()) {  // measurement noise moves the fitted load
        refit_.set(q_est_, estimated->fit_q, estimated->fit_v);   // what fit_state() filled in
        if (refit_.active()) sigma_.refit = &refit_;
      }
      compute_wrench_sigma(sys_, ws, sigma_, q_est_, v_est_, estimated->tau);
    } else {
      compute_wrench_sigma(sys_, ws, sigma_);
    }
    f.sigma = &sigma_;
  }
}

void ServiceLoop::publish_output(io::OutputFrame& f) {
  f.utime = io::wall_us();
  bool sanitized = false;
  const int len = out_enc_.encode(f, out_buf_.data(), static_cast<int>(out_buf_.size()), &sanitized);
  if (sanitized && f.valid) numerical_errors_.fetch_add(1, std::memory_order_relaxed);
  if (len > 0) publish(cfg_.output_channel, out_buf_, len);
  ticks_.fetch_add(1, std::memory_order_relaxed);
  // on arrival, run_on_arrival() publishes the stats by wall time (the ticks follow the states)
  if (++since_stats_ >= stats_every_ && cfg_.trigger == Trigger::kTick) {
    publish_stats();
    since_stats_ = 0;
  }
}

void ServiceLoop::fill_counters(io::StatsFrame& s) const {
  const InputCounters& c = input_counters();
  s.tick = ticks();
  s.period_us = static_cast<double>(period_ns_) * 1e-3;
  s.overruns = overruns();
  s.skipped_periods = skipped_periods();
  s.received = c.received.load(std::memory_order_relaxed);
  s.accepted = c.accepted.load(std::memory_order_relaxed);
  s.rejected = c.rejected.load(std::memory_order_relaxed);
  s.out_of_order = c.out_of_order.load(std::memory_order_relaxed);
  s.expired = expirations();
  s.numerical_errors = numerical_errors();
  s.receiver_restarts = receiver_restarts_.load(std::memory_order_relaxed);
  s.inputs_dropped = inputs_dropped_.load(std::memory_order_relaxed);
  s.missed = c.missed.load(std::memory_order_relaxed);
  s.inputs_filtered = inputs_filtered_.load(std::memory_order_relaxed);
  for (int k = 0; k < io::kRejectKinds; ++k) s.rejected_by_reason[k] = c.by_reason[k].load(std::memory_order_relaxed);
  s.closure_rejected = closure_rejected_.load(std::memory_order_relaxed);
  s.inputs_malformed = inputs_malformed_.load(std::memory_order_relaxed);
  // controls; then what the receive process rejected before the ring, with the inboxes' own
  const InputCounters& ctl = controls_.counters();
  s.controls_received = ctl.received.load(std::memory_order_relaxed);
  s.controls_accepted = ctl.accepted.load(std::memory_order_relaxed);
  s.controls_rejected = ctl.rejected.load(std::memory_order_relaxed);
  int64_t ctl_by[io::kRejectKinds];
  for (int k = 0; k < io::kRejectKinds; ++k) ctl_by[k] = ctl.by_reason[k].load(std::memory_order_relaxed);
  for (int k = 1; k < io::kRejectKinds; ++k) {
    const int64_t in = rx_input_rejected_[k].load(std::memory_order_relaxed),
                  cn = rx_control_rejected_[k].load(std::memory_order_relaxed);
    s.received += in;
    s.rejected += in;
    s.rejected_by_reason[k] += in;
    s.controls_received += cn;
    s.controls_rejected += cn;
    ctl_by[k] += cn;
  }
  s.controls_unauthenticated = ctl_by[static_cast<int>(io::Reject::kUnauthenticated)];
  s.controls_bad_mac = ctl_by[static_cast<int>(io::Reject::kBadMac)];
  s.controls_replayed = ctl_by[static_cast<int>(io::Reject::kReplayed)];
  s.outputs_dropped = outputs_dropped();
  for (int k = 0; k < 4; ++k) s.limit_ticks[k] = limit_ticks(k);
}

void ServiceLoop::publish_stats() {
  io::StatsFrame s;
  s.utime = io::wall_us();
  fill_counters(s);
  s.window_ticks = since_stats_;
  percentiles(late_win_, s.lateness_us);
  percentiles(comp_win_, s.compute_us);
  late_win_.reset();
  comp_win_.reset();
  const int len = stats_enc_.encode(s, stats_buf_.data(), static_cast<int>(stats_buf_.size()));
  if (len > 0) publish(cfg_.stats_channel, stats_buf_, len);
}

void ServiceLoop::publish(const std::string& channel, const std::vector<uint8_t>& buf, int len) {
  if (bus_.publish(channel.c_str(), buf.data(), len) != 0) outputs_dropped_.fetch_add(1, std::memory_order_relaxed);
}

int ServiceLoop::max_message_bytes(const System& sys) {
  return std::max(io::OutputEncoder(sys).max_size(), io::StatsEncoder().max_size());
}

io::StatsFrame ServiceLoop::totals() const {
  io::StatsFrame s;
  s.utime = io::wall_us();
  fill_counters(s);
  s.window_ticks = late_all_.total();
  percentiles(late_all_, s.lateness_us);
  percentiles(comp_all_, s.compute_us);
  return s;
}

void ServiceLoop::record_timing(long long lateness_ns, long long compute_ns) {
  late_win_.record(lateness_ns);
  comp_win_.record(compute_ns);
  late_all_.record(lateness_ns);
  comp_all_.record(compute_ns);
}

// The guard's busy time: the thread's CPU time over the window (all it did: ticks, a spin, a flood
// read on its thread with receive_in_loop), or with busy_poll, whose polling is meant to take its
// CPU, the ticks' compute time alone.
void ServiceLoop::watch_fifo(long long now, long long compute_ns) {
  if (!guard_on_) return;
  if (guard_start_ns_ < 0) {
    guard_start_ns_ = now;
    guard_overruns0_ = overruns();
    guard_cpu0_ns_ = io::clock_ns(CLOCK_THREAD_CPUTIME_ID);  // a system call: once per window
  }
  guard_busy_ns_ += compute_ns;
  ++guard_ticks_;
  const long long window = now - guard_start_ns_;
  if (window < static_cast<long long>(cfg_.stats_period_s * 1e9)) return;
  const long long cpu = io::clock_ns(CLOCK_THREAD_CPUTIME_ID);
  if (!cfg_.realtime.busy_poll) guard_busy_ns_ = cpu - guard_cpu0_ns_;
  guard_cpu0_ns_ = cpu;
  const FifoGuard::Verdict v = guard_.window(window, guard_busy_ns_, guard_ticks_, overruns() - guard_overruns0_);
  if (v != FifoGuard::Verdict::kKeep) {
    const bool ok = demote_to_other();
    if (ok) fifo_demotions_.fetch_add(1, std::memory_order_relaxed);
    events_.push({EventCode::kFifoDemoted, ok ? static_cast<int64_t>(v) : -static_cast<int64_t>(v), ticks(),
                  static_cast<double>(guard_busy_ns_) / static_cast<double>(window)});
    guard_on_ = false;  // once: SCHED_OTHER from here on
  }
  guard_start_ns_ = now;
  guard_busy_ns_ = 0;
  guard_ticks_ = 0;
  guard_overruns0_ = overruns();
}

void ServiceLoop::warm_up() {
  // the tick's own workspace and state: the tick recomputes everything it publishes
  if (cfg_.mode == ServiceMode::kSimulate) {
    if (!faulted_.load(std::memory_order_relaxed)) evaluate(sys_, stepper_.ws, q_, v_, tau_);
  } else {
    evaluate(sys_, ws_, q_est_, v_est_, zero_);
  }
}

namespace {
inline void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}
}  // namespace

// run_on_arrival's wait: true as soon as the doorbell moved from `seen` (a state was handed over),
// false at the absolute monotonic deadline or when stop is set (then *stopped). Sleeps on the
// doorbell in slices of at most kStopSliceNs; with realtime.busy_poll it polls it instead.
bool ServiceLoop::wait_for_arrival(uint32_t seen, long long deadline, const std::atomic<bool>& stop, bool* stopped) {
  const bool poll = cfg_.realtime.busy_poll;
  for (;;) {
    if (bell_value() != seen) return true;
    const long long now = io::monotonic_ns();
    if (now >= deadline) return false;
    if (stop.load(std::memory_order_relaxed)) {
      *stopped = true;
      return false;
    }
    if (poll) {
      if (source_) source_->poll();
      cpu_relax();
    } else if (source_) source_->wait(seen, sleep_end_ns(now, deadline));
    else bell_.wait(seen, sleep_end_ns(now, deadline));
  }
}

void ServiceLoop::run_on_arrival(const std::atomic<bool>& stop, long long max_ticks) {
  const long long stats_ns = period_ns_ * stats_every_;
  long long now = io::monotonic_ns();
  long long next_beat = now + period_ns_, next_stats = now + stats_ns;
  uint32_t seen = bell_value();
  if (source_) source_->drain();  // what arrived before run()
  long long n = 0;
  auto fresh = [&](long long t) { return have_state_ && t - states_.latest().recv_ns <= watchdog_ns_; };
  while (!stop.load(std::memory_order_relaxed) && (max_ticks < 0 || n < max_ticks)) {
    // the next thing due without a state: the held state's expiry (its expired output), else the
    // heartbeat; and the stats
    const long long beat = fresh(now) ? states_.latest().recv_ns + watchdog_ns_ + 1 : next_beat;
    const long long deadline = next_stats < beat ? next_stats : beat;
    bool stopped = false;
    wait_for_arrival(seen, deadline, stop, &stopped);
    if (stopped) break;
    seen = bell_value();
    const long long wake = io::monotonic_ns();
    bool ticked = false, heartbeat = false;
    long long late = 0;
    // offered here, on the loop's thread, at every wake-up: a state the source rang in while the loop
    // was not waiting (a heartbeat's tick) is in the inbox before `seen` is taken as handled
    if (source_) source_->drain();
    // a new state in the inbox is evaluated now, whether the bell woke the loop or a deadline did: a
    // state handed over and rung after the wait timed out but before `seen` was read is in the inbox
    // with its ring already in `seen`, and waiting for the bell again would leave it unevaluated
    // until it expired. One output per state taken: a ring whose state an earlier tick already took
    // computes nothing.
    if (states_.update()) {
      have_state_ = true;
      late = wake - states_.latest().recv_ns;
      tick(wake);
      ticked = true;
    } else if (wake >= beat && !fresh(wake)) {  // no state yet, or the held one just expired
      late = wake - beat;
      tick(wake);
      ticked = heartbeat = true;
    }
    now = io::monotonic_ns();
    if (ticked) {
      record_timing(late, now - wake);
      watch_fifo(now, now - wake);
      ++n;
      // heartbeats keep the period's cadence; after a state, the next one is a period away
      if (heartbeat && beat == next_beat && next_beat + period_ns_ > now) next_beat += period_ns_;
      else next_beat = now + period_ns_;
    }
    if (now >= next_stats) {
      publish_stats();
      since_stats_ = 0;
      next_stats += stats_ns;
      if (next_stats <= now) next_stats = now + stats_ns;
    }
  }
}

void ServiceLoop::run(const std::atomic<bool>& stop, long long max_ticks) {
  if (cfg_.trigger == Trigger::kArrival && cfg_.mode == ServiceMode::kEstimate) {
    run_on_arrival(stop, max_ticks);
    return;
  }
  const long long spin_ns = static_cast<long long>(cfg_.realtime.spin_us) * 1000;
  long long next = io::monotonic_ns() + period_ns_;
  long long n = 0;
  while (!stop.load(std::memory_order_relaxed) && (max_ticks < 0 || n < max_ticks)) {
    // Sleep to the absolute deadline in slices of at most kStopSliceNs, so a stop request (SIGINT,
    // SIGTERM, --duration) ends run() within one slice even at the lowest rate (1 Hz); at 1 kHz
    // the period is shorter than a slice and this is one clock_nanosleep.
    // With spin_us, the sleep ends spin_us early and the clock is polled from there to the deadline.
    bool stopped = false;
    const long long target = next - spin_ns;
    for (;;) {
      const long long now = io::monotonic_ns();
      if (now >= target) break;
      if (stop.load(std::memory_order_relaxed)) {
        stopped = true;
        break;
      }
      const long long until = sleep_end_ns(now, target);
      timespec ts;
      ts.tv_sec = static_cast<time_t>(until / 1000000000LL);
      ts.tv_nsec = static_cast<long>(until % 1000000000LL);
      const int rc = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
      if (rc != 0 && rc != EINTR) break;  // cannot happen with a valid timespec; never spin
      if (until == target && rc == 0) break;
    }
    if (stopped) break;
    if (spin_ns > 0) {
      warm_up();
      while (io::monotonic_ns() < next) {
      }
    }
    const long long wake = io::monotonic_ns();
    tick(wake);
    const long long end = io::monotonic_ns();
    record_timing(wake - next, end - wake);
    ++n;
    next += period_ns_;
    if (end > next) {
      // overrun: this tick ended after the next deadline; `behind` deadlines have passed
      overruns_.fetch_add(1, std::memory_order_relaxed);
      const long long behind = (end - next) / period_ns_ + 1;
      if (!in_overrun_) events_.push({EventCode::kOverrun, behind, ticks(), 0});
      in_overrun_ = true;
      long long skip = cfg_.overrun == OverrunPolicy::kSkip ? behind : std::max(0LL, behind - cfg_.max_catch_up);
      if (skip > 0) {
        next += skip * period_ns_;
        skipped_.fetch_add(skip, std::memory_order_relaxed);
      }
    } else {
      in_overrun_ = false;
    }
    watch_fifo(end, end - wake);
  }
}

std::string reset_refusal_text(const System& sys, const Event& e) {
  const int code = static_cast<int>(e.b / 65536), spec = static_cast<int>(e.b % 65536) - 1;
  const int kind = code % 4;
  std::string t = "reset_to_state refused, the simulation goes on from its own state: ";
  switch (static_cast<ResetRefusal>(code / 4)) {
    case ResetRefusal::kConfiguration:
      return t + "q is not a valid configuration (a non-finite coordinate or a quaternion not of unit norm)";
    case ResetRefusal::kVelocity: return t + "v has a non-finite entry";
    case ResetRefusal::kEvaluation: return t + "the evaluation at (q, v) failed (singular or non-finite)";
    case ResetRefusal::kClosure: {
      const auto& specs = sys.constraints.specs;
      char r[64];
      std::snprintf(r, sizeof r, "%.3g %s", e.x, closure_kind_unit(kind));
      return t + "(q, v) does not close the constraints to 1e-6: " + closure_kind_name(kind) + " residual " + r + " at '" +
             (spec >= 0 && spec < static_cast<int>(specs.size()) ? specs[static_cast<size_t>(spec)].name : std::string("?")) + "'";
    }
    case ResetRefusal::kNone: break;
  }
  return t + "unknown reason";
}

}  // namespace coopdyn::runtime
