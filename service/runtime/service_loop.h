// The fixed-rate loop of coopdynd.
//
// Each tick (tick(now)): take the newest input from the receive thread (triple buffer), apply the
// watchdog, then simulate (one integrator step under the command or the safe torque; the outputs
// are those of the step's start state, published with that state and tau, so evaluate(q, v, tau)
// reproduces them) or estimate (the measured state completed by state_fit.h, its closure residual
// checked, evaluate() there); then the scene's wrench outputs; encode output_t into a preallocated
// buffer and publish it; every stats period publish loop_stats_t. A message the bus refuses is
// counted (loop_stats_t outputs_dropped). tick() does not sleep, allocate, lock, log or throw;
// tests call it directly.
// run() calls tick() at absolute deadlines (CLOCK_MONOTONIC), records wake-up lateness and compute
// time and applies the overrun policy (realtime.spin_us: wake early and warm the caches). In the
// event-driven estimate mode (trigger: arrival) it ticks on each accepted measured state, at
// rate_hz while none is fresh; realtime.busy_poll polls instead of sleeping.
// The whole cycle, the lateness measured in each mode: docs/reference/internals.md, "The service loop".
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include <memory>

#include "service/dynamics/contacts.h"
#include "service/dynamics/holding_torque.h"
#include "service/dynamics/integrators.h"
#include "service/dynamics/state_fit.h"
#include "service/dynamics/sigma/state_fit_sigma.h"
#include "service/dynamics/system.h"
#include "service/io/transport/bus.h"
#include "service/io/codec/codec.h"
#include "service/runtime/arrival_source.h"
#include "service/runtime/config.h"
#include "service/runtime/doorbell.h"
#include "service/runtime/event_ring.h"
#include "service/runtime/fifo_guard.h"
#include "service/runtime/histogram.h"
#include "service/runtime/inbox.h"

namespace coopdyn::runtime {

class ServiceLoop {
 public:
  // Sizes every buffer. sys, cfg and bus must outlive the loop. With cfg.auth_key_file, reads the key
  // (io::KeyError naming the file when it cannot be used) and requires signed inputs.
  ServiceLoop(const System& sys, const ServiceConfig& cfg, io::Bus& bus);
  // The largest message the loop publishes for this scene (output_t or loop_stats_t, bytes): what a
  // bus that copies them (runtime::PublisherThread) must hold.
  static int max_message_bytes(const System& sys);
  ServiceLoop(const ServiceLoop&) = delete;
  ServiceLoop& operator=(const ServiceLoop&) = delete;

  // receive side (call from the receive thread)
  CommandInbox& commands() { return commands_; }
  StateInbox& states() { return states_; }
  ControlInbox& controls() { return controls_; }  // control_t: reset, pause, resume, clear fault
  // Event-driven estimate mode: the receive thread rings it after each accepted measured state.
  Doorbell& doorbell() { return bell_; }
  // Event-driven estimate mode without a receive thread: run() waits on (or polls) the source's bell
  // instead of the doorbell, and drains the source itself when it moves (arrival_source.h). Before
  // run(); the source outlives it.
  void take_arrivals_from(ArrivalSource* source) { source_ = source; }
  // The loop's thread runs SCHED_FIFO under realtime.sched_fifo auto: run() watches each stats
  // window with a FifoGuard (fifo_guard.h), fed the thread's CPU time over the window (with
  // busy_poll, the ticks' compute time), and steps the thread down to SCHED_OTHER when it would hog
  // its CPU, once (event kFifoDemoted, fifo_demotions()). Call from the loop's thread before run().
  void guard_fifo(bool on) { guard_on_ = on; }

  // One period at monotonic time now_ns. Loop thread only.
  void tick(long long now_ns);
  // Ticks at the configured rate until stop is set (or max_ticks ticks, if >= 0). Returns at most
  // kStopSliceNs after stop is set, whatever the rate.
  void run(const std::atomic<bool>& stop, long long max_ticks = -1);
  static constexpr long long kStopSliceNs = 10000000;  // 10 ms
  // Where one sleep of run() ends, from monotonic time now_ns toward target_ns (both ns): the target
  // itself, or one slice from now when the target is further, so run() looks at its stop flag at
  // least once per slice whatever the rate.
  static constexpr long long sleep_end_ns(long long now_ns, long long target_ns) {
    return target_ns - now_ns > kStopSliceNs ? now_ns + kStopSliceNs : target_ns;
  }
  // Adds one tick's timing to the statistics (run() does this; tests may too).
  void record_timing(long long lateness_ns, long long compute_ns);

  // --- read by tests and the daemon's monitor ---
  int64_t ticks() const { return ticks_.load(std::memory_order_relaxed); }
  int64_t overruns() const { return overruns_.load(std::memory_order_relaxed); }
  int64_t skipped_periods() const { return skipped_.load(std::memory_order_relaxed); }
  int64_t expirations() const { return expired_.load(std::memory_order_relaxed); }
  int64_t numerical_errors() const { return numerical_errors_.load(std::memory_order_relaxed); }
  // times the guard stepped the loop down from SCHED_FIFO to SCHED_OTHER (0 or 1)
  int64_t fifo_demotions() const { return fifo_demotions_.load(std::memory_order_relaxed); }
  bool faulted() const { return faulted_.load(std::memory_order_relaxed); }
  int64_t closure_rejections() const { return closure_rejected_.load(std::memory_order_relaxed); }
  // ticks whose published state or torque exceeded a joint limit (joint_limits.h): kind 0 any, then
  // 1 position, 2 velocity, 3 effort
  int64_t limit_ticks(int kind = 0) const { return limit_ticks_[kind].load(std::memory_order_relaxed); }
  // the joint limits of the last published output (loop thread)
  const LimitData& limits() const { return limits_; }
  // output_t and loop_stats_t messages the bus refused (publish() != 0: the publisher thread's ring
  // full, lcm_publish failing) or accepted and then failed to send (the publisher thread's
  // lcm_publish failing: Bus::failed_after_accept); loop_stats_t outputs_dropped
  int64_t outputs_dropped() const {
    return outputs_dropped_.load(std::memory_order_relaxed) + bus_.failed_after_accept();
  }
  bool paused() const { return paused_; }  // loop thread
  const InputCounters& input_counters() const;
  // Fed by the daemon's receive supervision (io/transport/rx_isolated.h), any thread; published in loop_stats_t.
  void set_receiver_counters(int64_t restarts, int64_t dropped, int64_t filtered = 0, int64_t malformed = 0) {
    inputs_malformed_.store(malformed, std::memory_order_relaxed);
    receiver_restarts_.store(restarts, std::memory_order_relaxed);
    inputs_dropped_.store(dropped, std::memory_order_relaxed);
    inputs_filtered_.store(filtered, std::memory_order_relaxed);
  }
  // The receive process's own rejections before its ring (io/transport/rx_isolated.h), by reason (io::Reject):
  // of the input channel (commands, or states) and of the control channel; any thread. Counted in
  // loop_stats_t with the inboxes' (received and rejected, by reason; controls_*).
  void set_receiver_rejections(const int64_t (&input_by_reason)[io::kRejectKinds],
                               const int64_t (&control_by_reason)[io::kRejectKinds]) {
    for (int k = 0; k < io::kRejectKinds; ++k) {
      rx_input_rejected_[k].store(input_by_reason[k], std::memory_order_relaxed);
      rx_control_rejected_[k].store(control_by_reason[k], std::memory_order_relaxed);
    }
  }
  EventRing<256>& events() { return events_; }
  // loop thread (or after run() returned)
  const Eigen::VectorXd& q() const { return q_; }
  const Eigen::VectorXd& v() const { return v_; }
  const Eigen::VectorXd& tau() const { return tau_; }
  double sim_time() const { return sim_time_; }
  io::Input last_input() const { return last_input_; }
  // totals since start: lateness and compute percentiles in the frame (for the summary line)
  io::StatsFrame totals() const;

 private:
  // The stages of tick(): inputs -> simulate or estimate -> publish. Each stage fills its part of
  // the output frame f.
  struct InputWatch;  // what one kind of input is called when none, expired or fresh (.cc)
  static const InputWatch kCommandWatch, kStateWatch;
  template <class Inbox>
  io::Input watch_input(Inbox& inbox, bool& have, long long now, const InputWatch& w);
  void take_control(io::OutputFrame& f);
  void simulate(long long now, io::OutputFrame& f);
  void estimate(long long now, io::OutputFrame& f);
  void apply_command(io::Input in, const io::CommandSlot& c);
  void integrate(io::OutputFrame& f);
  void evaluate_held(io::OutputFrame& f);
  void evaluate_measured(const io::StateSlot& s, io::OutputFrame& f);
  // estimated: the evaluated measured state (its q and v noise enters sigma), nullptr when simulating
  void put_evaluation(io::OutputFrame& f, Workspace& ws, const Diagnostics& d, bool ok,
                      const io::StateSlot* estimated = nullptr);
  void publish_output(io::OutputFrame& f);
  void check_limits(io::OutputFrame& f);

  void safe_torque(const Eigen::VectorXd& q, const Eigen::VectorXd& v);
  void handle_control(const io::ControlSlot& c);
  void publish_stats();
  void publish(const std::string& channel, const std::vector<uint8_t>& buf, int len);  // counts a refusal
  void fill_counters(io::StatsFrame& s) const;
  void run_on_arrival(const std::atomic<bool>& stop, long long max_ticks);
  bool wait_for_arrival(uint32_t seen, long long deadline, const std::atomic<bool>& stop, bool* stopped);
  uint32_t bell_value() const { return source_ ? source_->bell() : bell_.value(); }
  void require_auth(const io::AuthKey& key);  // every inbox verifies its channel's MAC
  void watch_fifo(long long now, long long compute_ns);  // the guard, after each tick's timing
  void warm_up();  // spin_us: one evaluation of the held state before the deadline (caches, TLB)

  const System& sys_;
  const ServiceConfig& cfg_;
  io::Bus& bus_;
  const long long period_ns_, watchdog_ns_;
  const double dt_;
  const int64_t stats_every_;

  std::unique_ptr<io::Verifier> cmd_auth_, state_auth_, control_auth_;  // authentication on only
  CommandInbox commands_;
  StateInbox states_;
  ControlInbox controls_;
  Stepper stepper_;                  // simulate
  Workspace ws_;                     // estimate
  StateFitPlan fit_plan_;            // what a measured state may omit; row kinds of the closure
  StateFitWorkspace fit_ws_;         // estimate: fitting the omitted coordinates
  Eigen::VectorXd q_est_, v_est_;    // estimate: the state evaluated (measured, completed)
  Closure closure_;                  // simulate: drift of the step's start state
  bool closure_open_ = false;        // estimate: the last state was above closure_tolerance
  WrenchData wrenches_;              // the published wrenches of the evaluation (either mode)
  ContactData contacts_;             // its rolling contacts (contacts.h)
  WrenchSigmaData sigma_;            // their sigma from the scene's declared noise (wrench_sigma.h)
  FitRefit refit_;                   // estimate: q and v noise moves the fitted load too (state_fit_sigma.h)
  FrictionBoundData bound_;          // estimate: their interval over the friction at rest (friction_bound.h)
  LimitData limits_;                 // the joint limits the published state and torque exceed
  std::vector<uint8_t> limits_said_;  // (nv) the limits each joint passed since start or a reset (events)
  io::JointLosses joint_losses_ = io::JointLosses::kNone;  // estimate: compensated, ignored or none declared
  Eigen::VectorXd q_, v_, tau_;      // (nq), (nv), (nv): simulated state, applied torque
  Eigen::VectorXd q_prev_, v_prev_;  // state at the start of the last step (what is published)
  std::vector<unsigned char> actuated_;  // (nv) finite tau_limit and not a pseudo-joint
  std::vector<int> locks_;               // lock specs whose target a command may set (target_limit > 0)
  std::unique_ptr<HoldWorkspace> hold_;  // safe torque `hold` only
  // the hold computed its torque from stepper_.ws's begin_evaluation() at (q_, v_) this tick: the
  // step (or the paused evaluation) finishes that evaluation instead of starting another
  bool start_begun_ = false;
  io::OutputEncoder out_enc_;
  io::StatsEncoder stats_enc_;
  std::vector<uint8_t> out_buf_, stats_buf_;

  bool started_ = false;
  long long t0_ns_ = 0;
  double sim_time_ = 0;
  bool have_cmd_ = false, have_state_ = false, input_expired_ = false;
  io::Input last_input_ = io::Input::kNoCommand;
  std::atomic<bool> faulted_{false};
  Reason fault_reason_ = Reason::kNone;
  bool in_overrun_ = false;
  bool paused_ = false;  // simulate: a control_t paused the integration
  int64_t ctrl_seq_ = -1;
  io::ControlAction ctrl_action_ = io::ControlAction::kReset;
  io::ControlResult ctrl_result_ = io::ControlResult::kNone;
  Eigen::VectorXd zero_;  // (nv)
  int64_t since_stats_ = 0;

  std::atomic<int64_t> ticks_{0}, overruns_{0}, skipped_{0}, expired_{0}, numerical_errors_{0};
  std::atomic<int64_t> receiver_restarts_{0}, inputs_dropped_{0}, inputs_filtered_{0}, inputs_malformed_{0};
  std::atomic<int64_t> rx_input_rejected_[io::kRejectKinds] = {}, rx_control_rejected_[io::kRejectKinds] = {};
  std::atomic<int64_t> limit_ticks_[4] = {};  // limit_ticks(kind)
  std::atomic<int64_t> closure_rejected_{0};  // estimate: measured states above closure_tolerance
  std::atomic<int64_t> outputs_dropped_{0};   // messages the bus refused
  std::atomic<int64_t> fifo_demotions_{0};
  // the FIFO guard's window: since guard_start_ns_, the ticks' compute ns, ticks, overruns and the
  // thread's CPU time at its start
  FifoGuard guard_;
  bool guard_on_ = false;
  long long guard_start_ns_ = -1, guard_busy_ns_ = 0, guard_cpu0_ns_ = 0;
  int64_t guard_ticks_ = 0, guard_overruns0_ = 0;
  Histogram late_win_, comp_win_, late_all_, comp_all_;
  EventRing<256> events_;
  Doorbell bell_;
  ArrivalSource* source_ = nullptr;  // trigger arrival: inputs drained by the loop itself (else the doorbell)
};

// The text of a kResetRejected event: why reset_to_state was refused, naming the constraint and its
// residual when the state does not close them. Allocates: for the daemon's logger, not the loop.
std::string reset_refusal_text(const System& sys, const Event& e);

}  // namespace coopdyn::runtime
