// Plain data that crosses the LCM boundary, free of generated lcmtypes: the codec (codec.h) fills
// and reads these; the runtime and the clients see only these.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace coopdyn::io {

// Why an input was not applied (service/io/codec/codes.def: the table, with each reason's key and name).
enum class Reject {
#define COOPDYN_REJECT(e, key, name) e,
#include "service/io/codec/codes.def"
};
constexpr int kRejectKinds = 0
#define COOPDYN_REJECT(e, key, name) +1
#include "service/io/codec/codes.def"
    ;

const char* reject_name(Reject r);
const char* reject_key(Reject r);  // the same as one word (loop_stats_t reject_reasons, CSV columns)

// A validated torque command, in the scene's velocity order. Sized once (nv).
struct CommandSlot {
  int64_t utime = -1;   // publisher's clock, us
  int64_t seq = -1;
  int64_t recv_ns = 0;  // CLOCK_MONOTONIC at receipt, ns
  int64_t id = 0;       // acceptance number (1, 2, ...), set by the inbox
  Eigen::VectorXd tau;  // (nv) N*m or N
  // (nv) 1 where the command gives the DOF's torque: every DOF of a command without names, the named
  // ones of a command with names; the others (tau 0 here) take the daemon's safe torque
  std::vector<unsigned char> named;
  // (constraint specs) the target of each lock spec, rad or m: the command's where it names the
  // lock's joint, else the scene's (ConstraintSpec::q_target); unused entries of other kinds
  Eigen::VectorXd lock_target;
};

// A validated measured state, in the scene's coordinate order. Sized once (nq, nv).
struct StateSlot {
  int64_t utime = -1;
  int64_t seq = -1;
  int64_t recv_ns = 0;
  int64_t id = 0;
  Eigen::VectorXd q, v, tau;  // (nq), (nv), (nv)
  // the floating bodies' positions / velocities were omitted: the loop fits them (state_fit.h); their
  // entries in q / v are meaningless until then (tau is 0 there); omitted pseudo-joints are already
  // set to their locked value
  bool fit_q = false, fit_v = false;
  // force/torque sensor readings by wrench output (measured_state_t wrenches): sized to the scene's
  // wrench outputs once; has_wrench[i] says whether output i was measured in this state
  std::vector<unsigned char> has_wrench;
  std::vector<std::array<double, 6>> wrench;
  int n_wrenches = 0;  // how many were measured
};

// A validated control request (control_t), sized once (nq, nv for RESET_TO_STATE).
enum class ControlAction : int8_t {
#define COOPDYN_CONTROL_ACTION(e, code, key, name, lcm) e = code,
#include "service/io/codec/codes.def"
};
enum class ControlResult : int8_t {
#define COOPDYN_CONTROL_RESULT(e, code, key, name, lcm) e = code,
#include "service/io/codec/codes.def"
};
const char* control_action_name(ControlAction a);
const char* control_result_name(ControlResult r);
struct ControlSlot {
  int64_t utime = -1;
  int64_t seq = -1;
  int64_t recv_ns = 0;
  int64_t id = 0;
  ControlAction action = ControlAction::kReset;
  bool has_state = false;
  Eigen::VectorXd q, v;  // (nq), (nv)
};

// Codes carried by output_t (mirrors its constants; the codec checks they agree).
enum class Mode : int8_t {
#define COOPDYN_MODE(e, code, key, lcm) e = code,
#include "service/io/codec/codes.def"
};
enum class Input : int8_t {
#define COOPDYN_INPUT(e, code, key, name, lcm) e = code,
#include "service/io/codec/codes.def"
};
const char* input_name(Input i);
enum class JointLosses : int8_t {
#define COOPDYN_JOINT_LOSSES(e, code, key, lcm) e = code,
#include "service/io/codec/codes.def"
};
#define COOPDYN_SERVICE_REASON(c, code, key, lcm) constexpr int16_t c = code;
#include "service/io/codec/codes.def"

// One-word keys of the codes (the CSV and JSON outputs); "unknown" for a code not in the tables.
const char* reason_key(int reason);          // Reason or the service's 100+: "none", "diverged", "no_state", ...
const char* input_key(int input);            // Input: "command", "no_command", "command_expired", ...
const char* mode_key(int mode);              // "simulate", "estimate"
const char* joint_losses_key(int j);         // JointLosses: "none", "compensated", "ignored"
const char* control_action_key(int action);  // "none" (-1), "reset", "reset_to_state", "pause", ...
const char* control_result_key(int result);  // "none", "ok", "rejected_state", "not_applicable"

// Loop statistics (loop_stats_t).
struct StatsFrame {
  int64_t utime = 0, tick = 0;
  double period_us = 0;
  int64_t window_ticks = 0;
  double lateness_us[4] = {0, 0, 0, 0};  // p50, p99, p99.9, max
  double compute_us[4] = {0, 0, 0, 0};
  int64_t overruns = 0, skipped_periods = 0;
  int64_t received = 0, accepted = 0, rejected = 0, out_of_order = 0, expired = 0, numerical_errors = 0;
  int64_t receiver_restarts = 0, inputs_dropped = 0;
  int64_t missed = 0, inputs_filtered = 0;
  int64_t rejected_by_reason[kRejectKinds] = {};  // index: Reject (kNone stays 0)
  int64_t closure_rejected = 0;
  int64_t inputs_malformed = 0;  // datagrams refused by the receive process's wire parser
  // control_t: received, accepted, rejected (every reason), and rejected as unauthenticated, bad MAC, replayed
  int64_t controls_received = 0, controls_accepted = 0, controls_rejected = 0;
  int64_t controls_unauthenticated = 0, controls_bad_mac = 0, controls_replayed = 0;
  int64_t outputs_dropped = 0;  // output_t and loop_stats_t messages the loop's bus refused (publish() != 0)
  // ticks past a joint limit: any, then position, velocity, effort (ServiceLoop::limit_ticks)
  int64_t limit_ticks[4] = {0, 0, 0, 0};
  // decode_stats: bit k set when field k of stats_fields.def is absent from the layout the message
  // was recorded in (it reads 0)
  uint64_t missing = 0;
};

// A decoded output_t, for clients and tests (allocates; never used by the loop): one member per field
// of output_fields.def (its types there), whatever layout the message was recorded in; a field that
// layout lacks holds its `absent` value and its bit in `missing` (OutputField) is set.
enum class OutputField {
#define COOPDYN_OUTPUT_FIELD(name, type, size, since, absent, on_error, csv, doc) name,
#include "service/io/codec/output_fields.def"
};
constexpr int kOutputFields = 0
#define COOPDYN_OUTPUT_FIELD(name, type, size, since, absent, on_error, csv, doc) +1
#include "service/io/codec/output_fields.def"
    ;
static_assert(kOutputFields <= 64, "DecodedOutput::missing holds a bit per field");

#define COOPDYN_DECODED_i(n, absent) int n = absent;
#define COOPDYN_DECODED_i64(n, absent) int64_t n = absent;
#define COOPDYN_DECODED_f(n, absent) double n = absent;
#define COOPDYN_DECODED_f4(n, absent) std::array<double, 4> n{{absent, absent, absent, absent}};
#define COOPDYN_DECODED_i4(n, absent) std::array<int, 4> n{{absent, absent, absent, absent}};
#define COOPDYN_DECODED_names(n, absent) std::vector<std::string> n;
#define COOPDYN_DECODED_ints(n, absent) std::vector<int> n;
#define COOPDYN_DECODED_reals(n, absent) std::vector<double> n;
#define COOPDYN_DECODED_wrenches(n, absent) std::vector<std::array<double, 6>> n;
#define COOPDYN_DECODED_dirs(n, absent) std::vector<std::vector<std::array<double, 6>>> n;
#define COOPDYN_DECODED_count(n, absent)
struct DecodedOutput {
#define COOPDYN_OUTPUT_FIELD(name, type, size, since, absent, on_error, csv, doc) COOPDYN_DECODED_##type(name, absent)
#include "service/io/codec/output_fields.def"
  uint64_t missing = 0;  // bit OutputField: absent from the layout the message was recorded in
  bool has(OutputField f) const { return !(missing >> static_cast<int>(f) & 1); }
};

}  // namespace coopdyn::io
