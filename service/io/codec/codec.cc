// The loop-side codec: command/state decoders (receive thread), output/stats encoders (loop thread).
#include "service/io/codec/codec.h"

#include <cmath>
#include <cstring>
#include <unordered_map>

#include "coopdyn/control_t.hpp"
#include "coopdyn/loop_stats_t.hpp"
#include "coopdyn/measured_state_t.hpp"
#include "coopdyn/output_t.hpp"
#include "coopdyn/torque_command_t.hpp"
#include "service/dynamics/state_fit.h"
#include "service/io/codec/wire.h"
#include "service/io/codec/wrench_fields.h"

namespace coopdyn::io {

// every code of the tables (service/io/codec/codes.def, service/dynamics/reasons.def) is the LCM constant
// of the same name
// clang-format off
#define COOPDYN_MODE(e, code, key, lcm) static_assert(static_cast<int>(Mode::e) == coopdyn::output_t::lcm, #lcm);
#define COOPDYN_INPUT(e, code, key, name, lcm) \
  static_assert(static_cast<int>(Input::e) == coopdyn::output_t::lcm, #lcm);
#define COOPDYN_SERVICE_REASON(c, code, key, lcm) static_assert(c == coopdyn::output_t::lcm, #lcm);
#define COOPDYN_CONTROL_ACTION(e, code, key, name, lcm) \
  static_assert(static_cast<int>(ControlAction::e) == coopdyn::control_t::lcm, #lcm);
#define COOPDYN_CONTROL_RESULT(e, code, key, name, lcm) \
  static_assert(static_cast<int>(ControlResult::e) == coopdyn::output_t::lcm, #lcm);
#define COOPDYN_JOINT_LOSSES(e, code, key, lcm) \
  static_assert(static_cast<int>(JointLosses::e) == coopdyn::output_t::lcm, #lcm);
#include "service/io/codec/codes.def"
// clang-format on
static_assert(static_cast<int>(Reason::kNone) == coopdyn::output_t::REASON_NONE, "core reasons");
static_assert(static_cast<int>(Reason::kNonFiniteInput) == coopdyn::output_t::REASON_NONFINITE_INPUT, "core reasons");
static_assert(static_cast<int>(Reason::kMassMatrixSingular) == coopdyn::output_t::REASON_MASS_MATRIX_SINGULAR, "core reasons");
static_assert(static_cast<int>(Reason::kPseudoBlockSingular) == coopdyn::output_t::REASON_PSEUDO_BLOCK_SINGULAR, "core reasons");
static_assert(static_cast<int>(Reason::kNonFiniteResult) == coopdyn::output_t::REASON_NONFINITE_RESULT, "core reasons");
static_assert(static_cast<int>(Reason::kOverconstrained) == coopdyn::output_t::REASON_OVERCONSTRAINED, "core reasons");
static_assert(static_cast<int>(Reason::kDiverged) == coopdyn::output_t::REASON_DIVERGED, "core reasons");
static_assert(static_cast<int>(Reason::kSvdDropped) == coopdyn::output_t::REASON_SVD_DROPPED, "core reasons");
static_assert(static_cast<int>(Status::kOk) == coopdyn::output_t::STATUS_OK, "status codes");
static_assert(static_cast<int>(Status::kIndeterminate) == coopdyn::output_t::STATUS_INDETERMINATE, "status codes");
static_assert(static_cast<int>(Status::kError) == coopdyn::output_t::STATUS_ERROR, "status codes");
static_assert(static_cast<int>(FreeClass::kWheelNormal) == coopdyn::output_t::FREE_WHEEL_NORMAL &&
                  static_cast<int>(FreeClass::kWheelLateral) == coopdyn::output_t::FREE_WHEEL_LATERAL &&
                  static_cast<int>(FreeClass::kWheelLongitudinal) == coopdyn::output_t::FREE_WHEEL_LONGITUDINAL &&
                  static_cast<int>(FreeClass::kForce) == coopdyn::output_t::FREE_FORCE &&
                  static_cast<int>(FreeClass::kMoment) == coopdyn::output_t::FREE_MOMENT &&
                  static_cast<int>(FreeClass::kLock) == coopdyn::output_t::FREE_LOCK &&
                  static_cast<int>(FreeClass::kMixed) == coopdyn::output_t::FREE_MIXED && kFreeClasses == 7,
              "free-direction classes");
static_assert(static_cast<int>(WrenchKind::kEndEffector) == coopdyn::output_t::KIND_END_EFFECTOR, "wrench kinds");
static_assert(static_cast<int>(WrenchKind::kBase) == coopdyn::output_t::KIND_BASE, "wrench kinds");
static_assert(static_cast<int>(WrenchKind::kTip) == coopdyn::output_t::KIND_TIP, "wrench kinds");
static_assert(static_cast<int>(WrenchKind::kAxle) == coopdyn::output_t::KIND_AXLE, "wrench kinds");
static_assert(static_cast<int>(WrenchKind::kJoint) == coopdyn::output_t::KIND_JOINT, "wrench kinds");

const char* reject_key(Reject r) {
  switch (r) {
// clang-format off
#define COOPDYN_REJECT(e, key, name) \
  case Reject::e: return #key;
#include "service/io/codec/codes.def"
// clang-format on
  }
  return "?";
}

const char* reject_name(Reject r) {
  switch (r) {
// clang-format off
#define COOPDYN_REJECT(e, key, name) \
  case Reject::e: return name;
#include "service/io/codec/codes.def"
// clang-format on
  }
  return "?";
}

static_assert(kClosureAngularVelocity == coopdyn::output_t::CLOSURE_ANGULAR_VELOCITY, "closure kinds");

const char* control_action_name(ControlAction a) {
  switch (a) {
// clang-format off
#define COOPDYN_CONTROL_ACTION(e, code, key, name, lcm) \
  case ControlAction::e: return name;
#include "service/io/codec/codes.def"
// clang-format on
  }
  return "?";
}
const char* control_result_name(ControlResult r) {
  switch (r) {
// clang-format off
#define COOPDYN_CONTROL_RESULT(e, code, key, name, lcm) \
  case ControlResult::e: return name;
#include "service/io/codec/codes.def"
// clang-format on
  }
  return "?";
}

const char* input_name(Input i) {
  switch (i) {
// clang-format off
#define COOPDYN_INPUT(e, code, key, name, lcm) \
  case Input::e: return name;
#include "service/io/codec/codes.def"
// clang-format on
  }
  return "?";
}

const char* reason_key(int r) {
  switch (r) {
// clang-format off
#define COOPDYN_REASON(e, code, key, text) \
  case code: return #key;
#include "service/dynamics/reasons.def"
// clang-format on
// clang-format off
#define COOPDYN_SERVICE_REASON(c, code, key, lcm) \
  case code: return #key;
#include "service/io/codec/codes.def"
// clang-format on
  }
  return "unknown";
}
const char* input_key(int i) {
  switch (i) {
// clang-format off
#define COOPDYN_INPUT(e, code, key, name, lcm) \
  case code: return #key;
#include "service/io/codec/codes.def"
// clang-format on
  }
  return "unknown";
}
const char* joint_losses_key(int j) {
  switch (j) {
// clang-format off
#define COOPDYN_JOINT_LOSSES(e, code, key, lcm) \
  case code: return #key;
#include "service/io/codec/codes.def"
// clang-format on
  }
  return "unknown";
}
const char* mode_key(int m) {
  switch (m) {
// clang-format off
#define COOPDYN_MODE(e, code, key, lcm) \
  case code: return #key;
#include "service/io/codec/codes.def"
// clang-format on
  }
  return "unknown";
}
const char* control_action_key(int a) {
  if (a == -1) return "none";  // output_t: no control this tick
  switch (a) {
// clang-format off
#define COOPDYN_CONTROL_ACTION(e, code, key, name, lcm) \
  case code: return #key;
#include "service/io/codec/codes.def"
// clang-format on
  }
  return "unknown";
}
const char* control_result_key(int r) {
  switch (r) {
// clang-format off
#define COOPDYN_CONTROL_RESULT(e, code, key, name, lcm) \
  case code: return #key;
#include "service/io/codec/codes.def"
// clang-format on
  }
  return "unknown";
}

namespace {
using NameMap = std::unordered_map<std::string, int>;
NameMap index_of(const std::vector<std::string>& names) {
  NameMap m;
  for (size_t i = 0; i < names.size(); ++i) m.emplace(names[i], static_cast<int>(i));
  return m;
}

// Maps named values onto out (scene order). names empty: values must be the full vector.
// seen: (n) scratch. Unnamed entries keep fill.
Reject map_named(const NameMap& map, const std::vector<std::string>& names, const double* values, int count, int n,
                 std::vector<unsigned char>& seen, double fill, Eigen::VectorXd& out, bool require_all) {
  if (names.empty()) {
    if (count != n) return Reject::kCount;
    for (int i = 0; i < n; ++i) {
      if (!std::isfinite(values[i])) return Reject::kNonFinite;
      out[i] = values[i];
    }
    return Reject::kNone;
  }
  if (static_cast<int>(names.size()) != count || count > n) return Reject::kCount;
  if (require_all && count != n) return Reject::kCount;
  std::fill(seen.begin(), seen.end(), 0);
  out.setConstant(fill);
  for (int i = 0; i < count; ++i) {
    auto it = map.find(names[i]);
    if (it == map.end()) return Reject::kUnknownName;
    if (seen[it->second]) return Reject::kDuplicateName;
    seen[it->second] = 1;
    if (!std::isfinite(values[i])) return Reject::kNonFinite;
    out[it->second] = values[i];
  }
  return Reject::kNone;
}
}  // namespace

std::vector<std::string> wrench_names(const System& s) {
  std::vector<std::string> n;
  for (const WrenchOutput& o : s.wrenches.outputs) n.push_back(o.name);
  return n;
}

// ---------------------------------------------------------------------------------------------
// The inputs' layouts, walked with every count and length checked before the generated decoder
// runs (it trusts them). Each walk stops at the mac_len field; walk_mac() then passes the MAC (the
// state's: walk_state_layout below, which the allocation-free decoder shares).
namespace {
using wire::kMaxMacBytes;

// hash, utime, seq, num_names, names[], num_torques, tau[], num_targets, target_names[], target[]
struct CommandCounts {
  int32_t names = 0, torques = 0, targets = 0;
};
bool walk_command(wire::Reader& r, CommandCounts* c) {
  return r.hash(coopdyn::torque_command_t::getHash()) && r.skip(16) && r.count(&c->names) && r.strings(c->names) &&
         r.count(&c->torques) && r.skip(8LL * c->torques) && r.count(&c->targets) && r.strings(c->targets) &&
         r.skip(8LL * c->targets);
}
// hash, utime, seq, action (1 byte), nq, q[], nv, v[]
struct ControlCounts {
  int32_t q = 0, v = 0;
};
bool walk_control(wire::Reader& r, ControlCounts* c) {
  return r.hash(coopdyn::control_t::getHash()) && r.skip(17) && r.count(&c->q) && r.skip(8LL * c->q) && r.count(&c->v) &&
         r.skip(8LL * c->v);
}
// mac_len, mac[]: any length up to kMaxMacBytes (the decoders accept a signed message with
// authentication off; auth.h checks it when on)
bool walk_mac(wire::Reader& r) {
  int32_t n = 0;
  return r.count(&n) && n <= kMaxMacBytes && r.skip(n);
}
}  // namespace

bool walk_state_layout(const void* data, int len, StateLayout* s) {
  wire::Reader r(data, len);
  if (!r.hash(coopdyn::measured_state_t::getHash()) || !r.i64(&s->utime) || !r.i64(&s->seq)) return false;
  if (!r.count(&s->q_names)) return false;
  s->q_names_at = r.pos();
  if (!r.strings(s->q_names) || !r.count(&s->q)) return false;
  s->q_at = r.pos();
  if (!r.skip(8LL * s->q) || !r.count(&s->v_names)) return false;
  s->v_names_at = r.pos();
  if (!r.strings(s->v_names) || !r.count(&s->v)) return false;
  s->v_at = r.pos();
  if (!r.skip(8LL * s->v)) return false;
  s->tau_at = r.pos();
  if (!r.skip(8LL * s->v) || !r.count(&s->wrenches)) return false;
  s->wrench_names_at = r.pos();
  if (!r.strings(s->wrenches)) return false;
  s->wrench_at = r.pos();
  if (!r.skip(48LL * s->wrenches)) return false;
  s->mac_at = r.pos();
  return r.count(&s->mac) && s->mac <= kMaxMacBytes && r.skip(s->mac);
}

int mac_field_offset(MessageType t, const void* data, int len) {
  wire::Reader r(data, len);
  bool ok = false;
  if (t == MessageType::kTorqueCommand) {
    CommandCounts c;
    ok = walk_command(r, &c);
  } else if (t == MessageType::kMeasuredState) {
    StateLayout s;
    return walk_state_layout(data, len, &s) ? s.mac_at : -1;
  } else if (t == MessageType::kControl) {
    ControlCounts c;
    ok = walk_control(r, &c);
  }
  return ok ? r.pos() : -1;
}

// ---------------------------------------------------------------------------------------------
struct CommandDecoder::Impl {
  const System& sys;
  NameMap v_index;
  std::vector<unsigned char> seen;
  std::vector<int> lock_of_dof;  // (nv) the lock spec holding each DOF, -1: none
  coopdyn::torque_command_t msg;
  explicit Impl(const System& s)
      : sys(s), v_index(index_of(s.model.v_names)), seen(s.model.nv()), lock_of_dof(s.model.nv(), -1) {
    msg.names.reserve(s.model.nv());
    msg.tau.reserve(s.model.nv());
    msg.target_names.reserve(s.model.nv());
    msg.target.reserve(s.model.nv());
    msg.mac.reserve(kMaxMacBytes);
    for (size_t k = 0; k < s.constraints.specs.size(); ++k)
      if (s.constraints.specs[k].kind == ConstraintKind::kLock) lock_of_dof[s.constraints.specs[k].dof] = static_cast<int>(k);
  }
};

CommandDecoder::CommandDecoder(const System& sys) : impl_(new Impl(sys)) {}
CommandDecoder::~CommandDecoder() = default;

Reject CommandDecoder::decode(const void* data, int len, CommandSlot& out) {
  Impl& m = *impl_;
  const int nv = m.sys.model.nv();
  wire::Reader r(data, len);
  CommandCounts c;
  if (!walk_command(r, &c) || !walk_mac(r)) return Reject::kDecode;
  const int32_t num_names = c.names, num_torques = c.torques, num_targets = c.targets;
  if (num_names > 4 * nv + 16 || num_torques > 4 * nv + 16 || num_targets > 4 * nv + 16) return Reject::kCount;
  try {
    if (m.msg.decode(data, 0, len) < 0) return Reject::kDecode;
  } catch (...) {  // the generated decoder on hostile input; not reachable after the scan above
    return Reject::kDecode;
  }
  const Reject rj = map_named(m.v_index, m.msg.names, m.msg.tau.data(), m.msg.num_torques, nv, m.seen, 0.0, out.tau,
                              false);
  if (rj != Reject::kNone) return rj;
  // a slot sized by its owner never resizes
  if (out.named.size() != static_cast<size_t>(nv)) out.named.resize(static_cast<size_t>(nv));
  if (m.msg.names.empty()) std::fill(out.named.begin(), out.named.end(), 1);
  else std::copy(m.seen.begin(), m.seen.begin() + nv, out.named.begin());
  for (int i = 0; i < nv; ++i) {
    const double lim = m.sys.tau_limit[i];
    if (lim == 0) {  // unactuated: only an exact 0 (or -0) is allowed
      if (out.tau[i] != 0) return Reject::kUnactuated;
    } else if (std::abs(out.tau[i]) > lim) {
      return Reject::kOverLimit;
    }
  }
  // lock targets: the scene's, then the named ones (each a lock with a target_limit, once, finite,
  // within its limit)
  const std::vector<ConstraintSpec>& specs = m.sys.constraints.specs;
  if (out.lock_target.size() != static_cast<Eigen::Index>(specs.size()))  // a slot sized by its owner never is
    out.lock_target.setZero(static_cast<Eigen::Index>(specs.size()));
  for (size_t k = 0; k < specs.size(); ++k) out.lock_target[static_cast<Eigen::Index>(k)] = specs[k].q_target;
  std::fill(m.seen.begin(), m.seen.end(), 0);
  for (int i = 0; i < m.msg.num_targets; ++i) {
    auto it = m.v_index.find(m.msg.target_names[static_cast<size_t>(i)]);
    if (it == m.v_index.end()) return Reject::kUnknownName;
    const int lock = m.lock_of_dof[static_cast<size_t>(it->second)];
    if (lock < 0 || specs[static_cast<size_t>(lock)].target_limit <= 0) return Reject::kNotLocked;
    if (m.seen[static_cast<size_t>(it->second)]) return Reject::kDuplicateName;
    m.seen[static_cast<size_t>(it->second)] = 1;
    const double x = m.msg.target[static_cast<size_t>(i)];
    if (!std::isfinite(x)) return Reject::kNonFinite;
    if (std::abs(x) > specs[static_cast<size_t>(lock)].target_limit) return Reject::kOverTargetLimit;
    out.lock_target[lock] = x;
  }
  out.utime = m.msg.utime;
  out.seq = m.msg.seq;
  return Reject::kNone;
}

// ---------------------------------------------------------------------------------------------
struct StateDecoder::Impl {
  const System& sys;
  StateFitPlan plan;
  NameMap q_index, v_index, wrench_index;
  std::vector<unsigned char> seen_q, seen_v;
  std::vector<unsigned char> fit_q_mask, fit_v_mask, pseudo_q_mask, pseudo_v_mask;
  Eigen::VectorXd tmp_tau;
  coopdyn::measured_state_t msg;
  explicit Impl(const System& s)
      : sys(s),
        plan(plan_state_fit(s)),
        q_index(index_of(s.model.q_names)),
        v_index(index_of(s.model.v_names)),
        wrench_index(index_of(wrench_names(s))),
        seen_q(s.model.nq()),
        seen_v(s.model.nv()),
        fit_q_mask(s.model.nq(), 0),
        fit_v_mask(s.model.nv(), 0),
        pseudo_q_mask(s.model.nq(), 0),
        pseudo_v_mask(s.model.nv(), 0),
        tmp_tau(s.model.nv()) {
    msg.mac.reserve(kMaxMacBytes);
    for (int i : plan.fit_q) fit_q_mask[i] = 1;
    for (int i : plan.fit_v) fit_v_mask[i] = 1;
    for (int i : plan.pseudo_q) pseudo_q_mask[i] = 1;
    for (int i : plan.pseudo_v) pseudo_v_mask[i] = 1;
  }
  // After map_named with require_all = false: the coordinates not seen must be pseudo-joints or all
  // of the floating bodies' (and fittable). *fit says whether the floating ones were omitted.
  Reject check_omitted(const std::vector<unsigned char>& seen, const std::vector<unsigned char>& fit_mask,
                       const std::vector<unsigned char>& pseudo_mask, bool fittable, const std::vector<int>& fit_idx,
                       bool* fit) const {
    int missing_fit = 0;
    for (size_t i = 0; i < seen.size(); ++i) {
      if (seen[i]) continue;
      if (fit_mask[i]) ++missing_fit;
      else if (!pseudo_mask[i]) return Reject::kIncomplete;
    }
    if (missing_fit == 0) {
      *fit = false;
      return Reject::kNone;
    }
    if (missing_fit != static_cast<int>(fit_idx.size()) || !fittable) return Reject::kIncomplete;
    *fit = true;
    return Reject::kNone;
  }
};

StateDecoder::StateDecoder(const System& sys) : impl_(new Impl(sys)) {}
StateDecoder::~StateDecoder() = default;
const StateFitPlan& StateDecoder::plan() const { return impl_->plan; }

Reject StateDecoder::decode(const void* data, int len, StateSlot& out) {
  Impl& m = *impl_;
  const int nq = m.sys.model.nq(), nv = m.sys.model.nv();
  const int n_out = static_cast<int>(m.sys.wrenches.outputs.size());
  StateLayout c;
  if (!walk_state_layout(data, len, &c)) return Reject::kDecode;
  if (state_counts_exceed(c, nq, nv, n_out)) return Reject::kCount;
  try {
    if (m.msg.decode(data, 0, len) < 0) return Reject::kDecode;
  } catch (...) {
    return Reject::kDecode;
  }
  // Without names a state is complete (the scene's order); with names it may omit what the daemon
  // can fit (the floating bodies' coordinates) or knows (pseudo-joints, locked at q0).
  Reject rj = map_named(m.q_index, m.msg.q_names, m.msg.q.data(), m.msg.num_q, nq, m.seen_q, 0.0, out.q, false);
  if (rj != Reject::kNone) return rj;
  rj = map_named(m.v_index, m.msg.v_names, m.msg.v.data(), m.msg.num_v, nv, m.seen_v, 0.0, out.v, false);
  if (rj != Reject::kNone) return rj;
  rj = map_named(m.v_index, m.msg.v_names, m.msg.tau.data(), m.msg.num_v, nv, m.seen_v, 0.0, out.tau, false);
  if (rj != Reject::kNone) return rj;
  out.fit_q = out.fit_v = false;
  if (!m.msg.q_names.empty()) {
    rj = m.check_omitted(m.seen_q, m.fit_q_mask, m.pseudo_q_mask, m.plan.q_fittable, m.plan.fit_q, &out.fit_q);
    if (rj != Reject::kNone) return rj;
    for (int i : m.plan.pseudo_q)
      if (!m.seen_q[i]) out.q[i] = m.sys.q0[i];
  }
  if (!m.msg.v_names.empty()) {
    rj = m.check_omitted(m.seen_v, m.fit_v_mask, m.pseudo_v_mask, m.plan.v_fittable, m.plan.fit_v, &out.fit_v);
    if (rj != Reject::kNone) return rj;
    for (int i : m.plan.pseudo_v)
      if (!m.seen_v[i]) out.v[i] = out.tau[i] = 0.0;
  }
  // force/torque sensor readings, by wrench output name (a slot not sized by its owner is sized here once)
  if (out.has_wrench.size() != static_cast<size_t>(n_out)) {
    out.has_wrench.assign(n_out, 0);
    out.wrench.assign(n_out, {});
  }
  std::fill(out.has_wrench.begin(), out.has_wrench.end(), 0);
  out.n_wrenches = 0;
  for (int i = 0; i < m.msg.num_wrenches; ++i) {
    auto it = m.wrench_index.find(m.msg.wrench_names[i]);
    if (it == m.wrench_index.end()) return Reject::kUnknownName;
    if (out.has_wrench[it->second]) return Reject::kDuplicateName;
    for (int k = 0; k < 6; ++k) {
      if (!std::isfinite(m.msg.wrench[i][k])) return Reject::kNonFinite;
      out.wrench[it->second][k] = m.msg.wrench[i][k];
    }
    out.has_wrench[it->second] = 1;
    ++out.n_wrenches;
  }
  out.utime = m.msg.utime;
  out.seq = m.msg.seq;
  return Reject::kNone;
}

// ---------------------------------------------------------------------------------------------
struct ControlDecoder::Impl {
  const System& sys;
  coopdyn::control_t msg;
  explicit Impl(const System& s) : sys(s) {
    msg.q.reserve(s.model.nq());
    msg.v.reserve(s.model.nv());
    msg.mac.reserve(kMaxMacBytes);
  }
};

ControlDecoder::ControlDecoder(const System& sys) : impl_(new Impl(sys)) {}
ControlDecoder::~ControlDecoder() = default;

Reject ControlDecoder::decode(const void* data, int len, ControlSlot& out) {
  Impl& m = *impl_;
  const int nq = m.sys.model.nq(), nv = m.sys.model.nv();
  wire::Reader r(data, len);
  ControlCounts c;
  if (!walk_control(r, &c) || !walk_mac(r)) return Reject::kDecode;
  const int32_t cq = c.q, cv = c.v;
  if (!((cq == 0 && cv == 0) || (cq == nq && cv == nv))) return Reject::kCount;
  try {
    if (m.msg.decode(data, 0, len) < 0) return Reject::kDecode;
  } catch (...) {
    return Reject::kDecode;
  }
  if (m.msg.action < coopdyn::control_t::ACTION_RESET || m.msg.action > coopdyn::control_t::ACTION_CLEAR_FAULT)
    return Reject::kDecode;
  const bool to_state = m.msg.action == coopdyn::control_t::ACTION_RESET_TO_STATE;
  if (to_state != (cq == nq && cq > 0)) return Reject::kCount;  // a state exactly when resetting to one
  for (int i = 0; i < cq; ++i) {
    if (!std::isfinite(m.msg.q[i])) return Reject::kNonFinite;
    out.q[i] = m.msg.q[i];
  }
  for (int i = 0; i < cv; ++i) {
    if (!std::isfinite(m.msg.v[i])) return Reject::kNonFinite;
    out.v[i] = m.msg.v[i];
  }
  out.has_state = to_state;
  out.action = static_cast<ControlAction>(m.msg.action);
  out.utime = m.msg.utime;
  out.seq = m.msg.seq;
  return Reject::kNone;
}

// ---------------------------------------------------------------------------------------------
namespace {
coopdyn::wrench_t zero_wrench() {
  coopdyn::wrench_t w;
  for (auto c : kWrenchComponent) w.*c = 0.0;
  return w;
}
}  // namespace

namespace {
// each wrench's sigma (SIGMA_TAU | SIGMA_Q | SIGMA_V: the noise it contains) when computed, else
// zeros (SIGMA_NONE); false on a non-finite value
bool put_sigma(const WrenchSigmaData* sd, coopdyn::output_t& o) {
  const bool on = sd && sd->valid;
  static_assert(WrenchSigmaData::kTau == coopdyn::output_t::SIGMA_TAU && WrenchSigmaData::kQ == coopdyn::output_t::SIGMA_Q &&
                WrenchSigmaData::kV == coopdyn::output_t::SIGMA_V);
  o.sigma_source = static_cast<int8_t>(on ? sd->source : 0);
  bool ok = true;
  for (size_t t = 0; t < o.wrench_sigma.size(); ++t)
    for (int k = 0; k < 6; ++k) {
      const double x = on ? sd->sigma[t][k] : 0.0;
      o.wrench_sigma[t].*kWrenchComponent[k] = x;
      ok = ok && std::isfinite(x);
    }
  return ok;
}
// each wrench's friction bound (estimate, joint losses compensated) when computed, else zeros;
// false on a non-finite value
bool put_bound(const FrictionBoundData* fb, coopdyn::output_t& o) {
  o.friction_resting = static_cast<int16_t>(fb ? fb->resting : 0);
  bool ok = true;
  for (size_t t = 0; t < o.wrench_bound.size(); ++t)
    for (int k = 0; k < 6; ++k) {
      const double x = fb ? fb->bound[t][k] : 0.0;
      o.wrench_bound[t].*kWrenchComponent[k] = x;
      ok = ok && std::isfinite(x);
    }
  return ok;
}
}  // namespace

namespace {
// on_error values (output_fields.def): keep leaves a field as it is; a number sets every element
struct Keep {};
constexpr Keep keep{};
template <class T>
void reset(T&, Keep) {}
template <class T, class = std::enable_if_t<std::is_arithmetic_v<T>>>
void reset(T& x, double v) {
  x = static_cast<T>(v);
}
void reset(coopdyn::wrench_t& w, double v) {
  for (auto c : kWrenchComponent) w.*c = v;
}
template <class T>
void reset(std::vector<T>& xs, double v) {
  for (T& x : xs) reset(x, v);
}
static_assert(coopdyn::output_t::LIMIT_POSITION == kLimitPosition && coopdyn::output_t::LIMIT_VELOCITY == kLimitVelocity
                  && coopdyn::output_t::LIMIT_EFFORT == kLimitEffort,
              "output_t LIMIT_* are joint_limits.h's bits");
// the joint limits the loop checked (joint_limits.h), else none
void put_limits(const LimitData* l, coopdyn::output_t& o) {
  o.limits = static_cast<int8_t>(l ? l->any : 0);
  for (size_t i = 0; i < o.limit_mask.size(); ++i)
    o.limit_mask[i] = static_cast<int8_t>(l && i < l->mask.size() ? l->mask[i] : 0);
}
// the rolling contacts the loop computed (contacts.h), else their error values; false on a non-finite value
bool put_contacts(const ContactData* c, coopdyn::output_t& o) {
  if (!c) {
    reset(o.contact_normal, 0.0);
    reset(o.contact_friction_needed, -1.0);
    reset(o.contact_utilisation, -1.0);
    reset(o.contact_state, 0.0);
    o.contact_status = 0;
    return true;
  }
  bool ok = true;
  for (size_t i = 0; i < c->spec.size() && i < o.contact_normal.size(); ++i) {
    o.contact_normal[i] = c->normal[i];
    o.contact_friction_needed[i] = c->friction_needed[i];
    o.contact_utilisation[i] = c->utilisation[i];
    o.contact_state[i] = static_cast<int8_t>(c->state[i]);
    ok = ok && std::isfinite(o.contact_normal[i]) && std::isfinite(o.contact_friction_needed[i]) &&
         std::isfinite(o.contact_utilisation[i]);
  }
  o.contact_status = static_cast<int8_t>(c->worst);
  return ok;
}
}  // namespace

struct OutputEncoder::Impl {
  const System& sys;
  coopdyn::output_t msg;
  int size = 0;
  explicit Impl(const System& s) : sys(s) {
    const Model& model = s.model;
    msg = coopdyn::output_t();
    const auto& outs = s.wrenches.outputs;
    msg.num_wrenches = static_cast<int32_t>(outs.size());
    for (const WrenchOutput& o : outs) {
      msg.wrench_names.push_back(o.name);
      msg.wrench_frames.push_back(o.frame);
      msg.wrench_by.push_back(o.by);
      msg.wrench_kind.push_back(static_cast<int8_t>(o.kind));
      msg.constrained_mask.push_back(static_cast<int8_t>(o.constrained));
    }
    msg.version = coopdyn::output_t::VERSION;
    msg.wrench.assign(outs.size(), zero_wrench());
    msg.indeterminate_mask.assign(outs.size(), 0);
    msg.wrench_measured.assign(outs.size(), 0);
    msg.wrench_residual.assign(outs.size(), zero_wrench());
    msg.sigma_source = coopdyn::output_t::SIGMA_NONE;
    msg.wrench_sigma.assign(outs.size(), zero_wrench());
    msg.wrench_bound.assign(outs.size(), zero_wrench());
    // free directions: sized for the most there can be (every row), sent as the first num_free
    const int rows = s.constraints.rows;
    msg.free_class.assign(static_cast<size_t>(rows), 0);
    msg.free_direction.assign(static_cast<size_t>(rows), std::vector<coopdyn::wrench_t>(outs.size(), zero_wrench()));
    const std::vector<int> contacts = ContactData(s).spec;  // the rolling constraints
    msg.num_contacts = static_cast<int32_t>(contacts.size());
    for (int k : contacts) msg.contact_names.push_back(s.constraints.specs[static_cast<size_t>(k)].name);
    msg.contact_normal.assign(contacts.size(), 0.0);
    msg.contact_friction_needed.assign(contacts.size(), -1.0);
    msg.contact_utilisation.assign(contacts.size(), -1.0);
    msg.contact_state.assign(contacts.size(), 0);
    msg.contact_status = 0;
    msg.num_stresses = static_cast<int32_t>(num_stresses(s));
    for (int k = 0; k < num_stresses(s); ++k) msg.stress_names.push_back(stress_name(s, k));
    msg.stress.assign(static_cast<size_t>(num_stresses(s)), 0.0);
    msg.nq = model.nq();
    msg.q_names = model.q_names;
    msg.q.assign(model.nq(), 0.0);
    msg.nv = model.nv();
    msg.v_names = model.v_names;
    msg.v.assign(model.nv(), 0.0);
    msg.tau.assign(model.nv(), 0.0);
    msg.vdot.assign(model.nv(), 0.0);
    msg.limits = 0;
    msg.limit_mask.assign(model.nv(), 0);
    msg.input_seq = msg.input_utime = -1;
    msg.control_seq = -1;
    msg.control_action = msg.control_result = -1;
    msg.num_constraints = static_cast<int32_t>(s.constraints.specs.size());
    for (const ConstraintSpec& c : s.constraints.specs) msg.constraint_names.push_back(c.name);
    for (int k = 0; k < 4; ++k) msg.closure_constraint[k] = -1;
    msg.num_free = rows;
    size = msg.getEncodedSize();  // the largest message
    msg.num_free = 0;
  }
  // every field whose on_error (output_fields.def) is not keep, to that value
  void zero_dynamics() {
#define COOPDYN_OUTPUT_FIELD(name, type, size, since, absent, on_error, csv, doc) reset(msg.name, on_error);
#include "service/io/codec/output_fields.def"
  }
};

OutputEncoder::OutputEncoder(const System& sys) : impl_(new Impl(sys)) {}
OutputEncoder::~OutputEncoder() = default;
int OutputEncoder::max_size() const { return impl_->size; }

namespace {
inline bool copy_finite(const Eigen::VectorXd* src, std::vector<double>& dst) {
  bool ok = true;
  for (size_t i = 0; i < dst.size(); ++i) {
    const double x = src ? (*src)[static_cast<Eigen::Index>(i)] : 0.0;
    ok = ok && std::isfinite(x);
    dst[i] = std::isfinite(x) ? x : 0.0;
  }
  return ok;
}
}  // namespace

int OutputEncoder::encode(const OutputFrame& f, uint8_t* buf, int cap, bool* sanitized) {
  Impl& m = *impl_;
  coopdyn::output_t& o = m.msg;
  o.utime = f.utime;
  o.tick = f.tick;
  o.sim_time = f.sim_time;
  o.mode = static_cast<int8_t>(f.mode);
  o.joint_losses = static_cast<int8_t>(f.joint_losses);
  o.status = f.status;
  o.reason = f.reason;
  o.input = static_cast<int8_t>(f.input);
  o.input_seq = f.input_seq;
  o.input_utime = f.input_utime;
  o.paused = f.paused ? 1 : 0;
  o.control_seq = f.control_seq;
  o.control_action = f.control_seq >= 0 ? static_cast<int8_t>(f.control_action) : int8_t{-1};
  o.control_result = static_cast<int8_t>(f.control_result);
  for (size_t t = 0; t < o.wrench_measured.size(); ++t)
    o.wrench_measured[t] = f.measured && t < f.measured->has_wrench.size() && f.measured->has_wrench[t] ? 1 : 0;
  o.state_fitted = static_cast<int8_t>(f.state_fitted);
  o.fit_iterations = f.fit_iterations;
  for (int k = 0; k < 4; ++k) {
    // a NaN residual (a NaN state) is published as -1: "not available", never as NaN
    const double c = f.closure ? f.closure->value[k] : 0.0;
    o.closure[k] = std::isfinite(c) ? c : -1.0;
    o.closure_constraint[k] = static_cast<int16_t>(f.closure ? f.closure->spec[k] : -1);
  }
  put_limits(f.limits, o);
  bool finite = std::isfinite(f.sim_time);
  finite = copy_finite(f.q, o.q) && finite;
  finite = copy_finite(f.v, o.v) && finite;
  finite = copy_finite(f.tau, o.tau) && finite;
  bool bad = !finite;
  if (f.valid && f.ws) {
    const Workspace& ws = *f.ws;
    o.rows = ws.diag.rows;
    o.rank = ws.diag.rank;
    o.indeterminate = ws.diag.indeterminate;
    o.condition = ws.diag.condition;
    o.residual = ws.diag.residual;
    bool ok = std::isfinite(o.residual);
    if (!std::isfinite(o.condition)) o.condition = -1;  // "infinite": a documented sentinel, not Inf
    if (f.wrenches) {
      const WrenchData& wd = *f.wrenches;
      for (size_t t = 0; t < o.wrench.size(); ++t) {
        for (int k = 0; k < 6; ++k) {
          o.wrench[t].*kWrenchComponent[k] = wd.W[t][k];
          ok = ok && std::isfinite(wd.W[t][k]);
        }
        o.indeterminate_mask[t] = static_cast<int8_t>(wd.indeterminate[t]);
        for (int d = 0; d < wd.num_free; ++d)
          for (int k = 0; k < 6; ++k) {
            const double x = wd.free_W(6 * static_cast<Eigen::Index>(t) + k, d);
            o.free_direction[static_cast<size_t>(d)][t].*kWrenchComponent[k] = x;
            ok = ok && std::isfinite(x);
          }
        const bool meas = f.measured && t < f.measured->has_wrench.size() && f.measured->has_wrench[t];
        for (int k = 0; k < 6; ++k) {
          const double r = meas ? f.measured->wrench[t][k] - wd.W[t][k] : 0.0;
          o.wrench_residual[t].*kWrenchComponent[k] = r;
          ok = ok && std::isfinite(r);
        }
      }
      o.num_free = wd.num_free;
      for (int d = 0; d < wd.num_free; ++d) o.free_class[static_cast<size_t>(d)] = static_cast<int8_t>(wd.free_class[static_cast<size_t>(d)]);
      ok = put_sigma(f.sigma, o) && ok;
      ok = put_bound(f.bound, o) && ok;
    } else {
      put_sigma(nullptr, o);
      put_bound(nullptr, o);
      for (auto& w : o.wrench) w = zero_wrench();
      std::fill(o.indeterminate_mask.begin(), o.indeterminate_mask.end(), 0);
      o.num_free = 0;
    }
    ok = put_contacts(f.contacts, o) && ok;
    ok = copy_finite(&ws.stress, o.stress) && ok;
    ok = copy_finite(&ws.vdot, o.vdot) && ok;
    bad = bad || !ok;
  } else {
    m.zero_dynamics();
  }
  if (bad) {
    m.zero_dynamics();
    o.status = coopdyn::output_t::STATUS_ERROR;
    o.reason = coopdyn::output_t::REASON_NONFINITE_RESULT;
  }
  if (sanitized) *sanitized = bad;
  if (cap < m.size) return -1;
  return o.encode(buf, 0, cap);
}

// ---------------------------------------------------------------------------------------------
struct StatsEncoder::Impl {
  coopdyn::loop_stats_t msg;
  Impl() {
    msg.num_reject_reasons = kRejectKinds - 1;  // every Reject but kNone
    for (int k = 1; k < kRejectKinds; ++k) msg.reject_reasons.push_back(reject_key(static_cast<Reject>(k)));
    msg.rejected_by_reason.assign(kRejectKinds - 1, 0);
  }
};
StatsEncoder::StatsEncoder() : impl_(new Impl) {}
StatsEncoder::~StatsEncoder() = default;
int StatsEncoder::max_size() const { return impl_->msg.getEncodedSize(); }

int StatsEncoder::encode(const StatsFrame& s, uint8_t* buf, int cap) {
  coopdyn::loop_stats_t& o = impl_->msg;
#define COOPDYN_STATS_FIELD(lcm, frame, put, since) o.lcm = s.frame;
#include "service/io/codec/stats_fields.def"
  for (int k = 1; k < kRejectKinds; ++k) o.rejected_by_reason[k - 1] = s.rejected_by_reason[k];
  if (cap < o.getEncodedSize()) return -1;
  return o.encode(buf, 0, cap);
}

}  // namespace coopdyn::io
