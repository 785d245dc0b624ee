// LCM codec: the only code that includes the generated lcmtypes (in codec.cc / convert.cc).
//
// Incoming bytes are untrusted: every count and string length is bounds-checked before the
// generated decoder runs (it would otherwise resize to a hostile count), then names, sizes, NaN/Inf
// and the scene's torque limits are checked (tau_limit 0: the DOF is unactuated, any nonzero force
// there is Reject::kUnactuated). Decoders run on the receive thread and reuse one
// message object, so after the first few messages they do not allocate either.
// Encoders run on the loop thread: the message object is sized and named once in the constructor,
// each tick overwrites numbers only and encodes into a caller's preallocated buffer. No allocation,
// no exceptions, no logging.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/contacts.h"
#include "service/dynamics/state_fit.h"
#include "service/dynamics/system.h"
#include "service/dynamics/friction_bound.h"
#include "service/dynamics/sigma/wrench_sigma.h"
#include "service/dynamics/joint_limits.h"
#include "service/dynamics/wrenches.h"
#include "service/io/codec/messages.h"

namespace coopdyn::io {

class CommandDecoder {
 public:
  explicit CommandDecoder(const System& sys);
  ~CommandDecoder();
  // Decodes and validates a torque_command_t into out (out.tau sized nv). On a reject, out is
  // partly written and must not be used. Never throws.
  Reject decode(const void* data, int len, CommandSlot& out);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class StateDecoder {
 public:
  explicit StateDecoder(const System& sys);
  ~StateDecoder();
  Reject decode(const void* data, int len, StateSlot& out);  // measured_state_t, as above
  const StateFitPlan& plan() const;  // what a state may omit (state_fit.h)

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class ControlDecoder {
 public:
  explicit ControlDecoder(const System& sys);
  ~ControlDecoder();
  Reject decode(const void* data, int len, ControlSlot& out);  // control_t, as above

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// What one tick publishes. valid = false: the dynamics numbers are published as 0 (error status).
struct OutputFrame {
  int64_t utime = 0, tick = 0;
  double sim_time = 0;
  Mode mode = Mode::kSimulate;
  int8_t status = 0;   // Status of the core (0 ok, 1 indeterminate, 2 error)
  int16_t reason = 0;  // Reason of the core, or kReason* of the service
  Input input = Input::kNoCommand;
  int64_t input_seq = -1, input_utime = -1;
  bool paused = false;
  int64_t control_seq = -1;
  ControlAction control_action = ControlAction::kReset;
  ControlResult control_result = ControlResult::kNone;
  uint8_t state_fitted = 0;           // bit 0 positions, bit 1 velocities fitted (state_fit.h)
  int fit_iterations = 0;
  const Closure* closure = nullptr;  // closure residual of the state (published whatever the status)
  const StateSlot* measured = nullptr;  // estimate: the state with its force/torque sensor readings
  bool valid = false;
  const Eigen::VectorXd* q = nullptr;    // (nq) state the evaluation used
  const Eigen::VectorXd* v = nullptr;    // (nv)
  const Eigen::VectorXd* tau = nullptr;  // (nv) applied torque
  const Workspace* ws = nullptr;         // evaluation (vdot, lambda, stress, diag) when valid
  const WrenchData* wrenches = nullptr;  // compute_wrenches() of that evaluation when valid
  const WrenchSigmaData* sigma = nullptr;  // compute_wrench_sigma() of it (declared noise) when valid
  JointLosses joint_losses = JointLosses::kNone;  // estimate: how the joints' damping and friction were taken
  const FrictionBoundData* bound = nullptr;  // estimate, compensated: compute_friction_bound() of it
  const ContactData* contacts = nullptr;     // compute_contacts() of it when valid (none: 0 and -1, as on error)
  // the joint limits (q, v, tau) exceed (check_joint_limits(); null: not checked): output_t limits, limit_mask
  const LimitData* limits = nullptr;
};

class OutputEncoder {
 public:
  explicit OutputEncoder(const System& sys);
  ~OutputEncoder();
  int max_size() const;  // bytes; constant for a scene
  // Encodes into buf; returns the length, or -1 if cap is too small. If any published number
  // would be NaN/Inf, all dynamics numbers are zeroed and the status becomes error
  // (kNonFiniteResult); *sanitized (optional) tells.
  int encode(const OutputFrame& f, uint8_t* buf, int cap, bool* sanitized = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class StatsEncoder {
 public:
  StatsEncoder();
  ~StatsEncoder();
  int max_size() const;
  int encode(const StatsFrame& s, uint8_t* buf, int cap);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// --- for clients and tests (these allocate) ---

// torque_command_t; names empty: tau in the scene's order. target_names / targets: lock targets
// (rad or m) by joint name; targets is padded with 0 or cut to target_names' size.
std::vector<uint8_t> encode_torque_command(int64_t utime, int64_t seq, const std::vector<std::string>& names,
                                           const std::vector<double>& tau, const std::vector<std::string>& target_names = {},
                                           const std::vector<double>& targets = {});
// measured_state_t; empty name lists: scene order.
std::vector<uint8_t> encode_measured_state(int64_t utime, int64_t seq, const std::vector<std::string>& q_names,
                                           const std::vector<double>& q, const std::vector<std::string>& v_names,
                                           const std::vector<double>& v, const std::vector<double>& tau,
                                           const std::vector<std::string>& wrench_names = {},
                                           const std::vector<std::array<double, 6>>& wrenches = {});
// control_t; q, v empty unless the action is kResetToState.
std::vector<uint8_t> encode_control(int64_t utime, int64_t seq, ControlAction action, const std::vector<double>& q = {},
                                    const std::vector<double>& v = {});
bool decode_output(const void* data, int len, DecodedOutput* out);
bool decode_stats(const void* data, int len, StatsFrame* out);

// Message types by their LCM fingerprint (the first 8 bytes).
enum class MessageType { kUnknown, kTorqueCommand, kMeasuredState, kOutput, kLoopStats, kControl };
MessageType identify(const void* data, int len);
int64_t fingerprint(MessageType t);  // the generated type's hash (the first 8 bytes of its encoding); 0: kUnknown
const char* type_name(MessageType t);
// Where the mac_len field (auth.h) of an encoded input (kTorqueCommand, kMeasuredState, kControl)
// starts, found by walking its fields with every count and length checked; -1 if the bytes are not
// such a message up to there. No allocation.
int mac_field_offset(MessageType t, const void* data, int len);  // "coopdyn.output_t", ...

// Where each field of an encoded measured_state_t starts (byte offsets into it) and its counts:
// hash, utime, seq, num_q_names, q_names[], num_q, q[], num_v_names, v_names[], num_v, v[], tau[],
// num_wrenches, wrench_names[], wrench[][6], mac_len, mac[].
struct StateLayout {
  int64_t utime = 0, seq = 0;
  int32_t q_names = 0, q = 0, v_names = 0, v = 0, wrenches = 0, mac = 0;
  int q_names_at = 0, q_at = 0, v_names_at = 0, v_at = 0, tau_at = 0, wrench_names_at = 0, wrench_at = 0, mac_at = 0;
};
// Walks the whole message, every count and string length checked against the bytes left and the
// MAC's length against kMaxMacBytes; false if the bytes are not a measured_state_t. No allocation.
// Both state decoders (StateDecoder, direct_decoder.h) start with it.
bool walk_state_layout(const void* data, int len, StateLayout* s);
// Counts that no state of a system with these sizes needs (n_out: its wrench outputs): the
// decoders refuse them as Reject::kCount before reading further.
inline bool state_counts_exceed(const StateLayout& s, int nq, int nv, int n_out) {
  return s.q_names > 4 * nq + 16 || s.q > 4 * nq + 16 || s.v_names > 4 * nv + 16 || s.v > 4 * nv + 16 ||
         s.wrenches > n_out;
}
// One CSV line per message: *header describes this message's columns (it depends on the scene's
// names), *row its values, neither with a trailing newline. False if it does not decode, and for
// kOutput: outputs are written in the per-step CSV schema (clients/csv/step_csv.h) from decode_output.
bool to_csv(MessageType t, const void* data, int len, std::string* header, std::string* row);

}  // namespace coopdyn::io
