// Client-side conversions (allocate freely; never on the loop path): message encoding for
// `coopdyn send` and tests, decoding and CSV rows for `coopdyn log`.
#include <cstdio>
#include <cstring>

#include "coopdyn/control_t.hpp"
#include "coopdyn/loop_stats_t.hpp"
#include "coopdyn/measured_state_t.hpp"
#include "coopdyn/output_t.hpp"
#include "coopdyn/output_v1_t.hpp"
#include "coopdyn/output_v2_t.hpp"
#include "coopdyn/output_v3_t.hpp"
#include "coopdyn/torque_command_t.hpp"
#include "service/io/codec.h"

namespace coopdyn::io {

namespace {
template <class M>
std::vector<uint8_t> encode_msg(const M& m) {
  std::vector<uint8_t> buf(static_cast<size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}
// The fingerprints of the inputs before they carried a MAC (mac_len, mac[] appended: auth.h), so that
// logs recorded before still read: such a message is the current one with mac_len 0 removed.
constexpr uint64_t kPreMacCommandHash = 0xb5f5b8e960348f9cULL, kPreMacStateHash = 0x1a87938cb56bb24bULL,
                   kPreMacControlHash = 0x489f6be38cd3846eULL;
template <class M>
bool decode_msg(const void* data, int len, M* m) {
  if (len < 8) return false;
  const uint8_t* b = static_cast<const uint8_t*>(data);
  uint64_t h = 0;
  for (int i = 0; i < 8; ++i) h = (h << 8) | b[i];
  std::vector<uint8_t> now;  // a pre-MAC input rewritten as the current type with mac_len 0
  if (h == kPreMacCommandHash || h == kPreMacStateHash || h == kPreMacControlHash) {
    now.assign(b, b + len);
    const uint64_t cur = static_cast<uint64_t>(M::getHash());
    for (int i = 0; i < 8; ++i) now[static_cast<size_t>(i)] = static_cast<uint8_t>(cur >> (56 - 8 * i));
    now.insert(now.end(), 4, 0);
    data = now.data();
    len = static_cast<int>(now.size());
  }
  try {
    return m->decode(data, 0, len) >= 0;
  } catch (...) {
    return false;
  }
}
// loop_stats_t's fingerprints before fields were appended (stats_fields.def), and how many bytes of
// int64 fields the current encoding has after such a message's last: a log recorded then reads as
// the current message with those fields 0
struct StatsBefore {
  uint64_t hash;
  int missing_bytes;
};
constexpr StatsBefore kStatsBefore[] = {
    {0x7f11746fd02903b9ULL, 8 * 8},  // before inputs_malformed (and the fields after it)
    {0x48bcc81f9a071c5aULL, 8 * 7},  // before controls_received ... controls_replayed, outputs_dropped
    {0x5f3a349535103d01ULL, 8 * 1},  // before outputs_dropped
};
int stats_missing_bytes(uint64_t hash) {
  for (const StatsBefore& b : kStatsBefore)
    if (b.hash == hash) return b.missing_bytes;
  return -1;
}

int64_t hash_of(const void* data, int len) {
  if (len < 8) return 0;
  const uint8_t* b = static_cast<const uint8_t*>(data);
  uint64_t h = 0;
  for (int i = 0; i < 8; ++i) h = (h << 8) | b[i];
  return static_cast<int64_t>(h);
}
void num(std::string* s, double x) {
  char b[32];
  std::snprintf(b, sizeof b, ",%.17g", x);  // round-trips
  *s += b;
}
void inum(std::string* s, long long x) {
  char b[32];
  std::snprintf(b, sizeof b, ",%lld", x);
  *s += b;
}

// output_t's wrench_t fields in the order [mx my mz fx fy fz]
constexpr double coopdyn::wrench_t::*kComp[6] = {&coopdyn::wrench_t::mx, &coopdyn::wrench_t::my, &coopdyn::wrench_t::mz,
                                                 &coopdyn::wrench_t::fx, &coopdyn::wrench_t::fy, &coopdyn::wrench_t::fz};
// Component k ([mx my mz fx fy fz]) of a wrench row: output_t's wrench_t, or a log recorded before
// it (output_v1_t: wrenches as 6-arrays, no version field).
double component(const coopdyn::wrench_t& w, int k) { return w.*kComp[k]; }
double component(const std::vector<double>& w, int k) { return k < static_cast<int>(w.size()) ? w[static_cast<size_t>(k)] : 0.0; }
}  // namespace

std::vector<uint8_t> encode_torque_command(int64_t utime, int64_t seq, const std::vector<std::string>& names,
                                           const std::vector<double>& tau, const std::vector<std::string>& target_names,
                                           const std::vector<double>& targets) {
  coopdyn::torque_command_t m;
  m.utime = utime;
  m.seq = seq;
  m.num_names = static_cast<int32_t>(names.size());
  m.names = names;
  m.num_torques = static_cast<int32_t>(tau.size());
  m.tau = tau;
  m.num_targets = static_cast<int32_t>(target_names.size());
  m.target_names = target_names;
  m.target = targets;
  m.target.resize(target_names.size(), 0.0);  // the encoder writes num_targets values
  m.mac_len = 0;  // unsigned (auth.h: sign())
  return encode_msg(m);
}

std::vector<uint8_t> encode_measured_state(int64_t utime, int64_t seq, const std::vector<std::string>& q_names,
                                           const std::vector<double>& q, const std::vector<std::string>& v_names,
                                           const std::vector<double>& v, const std::vector<double>& tau,
                                           const std::vector<std::string>& wrench_names,
                                           const std::vector<std::array<double, 6>>& wrenches) {
  coopdyn::measured_state_t m;
  m.utime = utime;
  m.seq = seq;
  m.num_q_names = static_cast<int32_t>(q_names.size());
  m.q_names = q_names;
  m.num_q = static_cast<int32_t>(q.size());
  m.q = q;
  m.num_v_names = static_cast<int32_t>(v_names.size());
  m.v_names = v_names;
  m.num_v = static_cast<int32_t>(v.size());
  m.v = v;
  m.tau = tau;
  m.tau.resize(v.size(), 0.0);
  m.num_wrenches = static_cast<int32_t>(wrench_names.size());
  m.wrench_names = wrench_names;
  for (size_t i = 0; i < wrench_names.size(); ++i)
    m.wrench.push_back(i < wrenches.size() ? std::vector<double>(wrenches[i].begin(), wrenches[i].end()) : std::vector<double>(6, 0.0));
  m.mac_len = 0;
  return encode_msg(m);
}

std::vector<uint8_t> encode_control(int64_t utime, int64_t seq, ControlAction action, const std::vector<double>& q,
                                    const std::vector<double>& v) {
  coopdyn::control_t m;
  m.utime = utime;
  m.seq = seq;
  m.action = static_cast<int8_t>(action);
  m.nq = static_cast<int32_t>(q.size());
  m.q = q;
  m.nv = static_cast<int32_t>(v.size());
  m.v = v;
  m.mac_len = 0;
  return encode_msg(m);
}

namespace {
// each wrench's sigma: output_t's (version 3); none in the layouts before it
template <class M>
void fill_sigma(const M& m, DecodedOutput* out) {
  out->sigma_source = 0;
  out->wrench_sigma.assign(m.wrench.size(), {});
}
template <class M>
void fill_sigma_v3(const M& m, DecodedOutput* out) {
  out->sigma_source = m.sigma_source;
  out->wrench_sigma.assign(m.wrench.size(), {});
  for (size_t t = 0; t < m.wrench_sigma.size() && t < m.wrench.size(); ++t)
    for (int k = 0; k < 6; ++k) out->wrench_sigma[t][k] = component(m.wrench_sigma[t], k);
}
template <>
void fill_sigma(const coopdyn::output_v3_t& m, DecodedOutput* out) {
  fill_sigma_v3(m, out);
}
template <>
void fill_sigma(const coopdyn::output_t& m, DecodedOutput* out) {
  fill_sigma_v3(m, out);
}
// the joint losses and each wrench's friction bound: output_t's (version 4); none before it
template <class M>
void fill_bound(const M& m, DecodedOutput* out) {
  out->joint_losses = 0;
  out->friction_resting = 0;
  out->wrench_bound.assign(m.wrench.size(), {});
}
template <>
void fill_bound(const coopdyn::output_t& m, DecodedOutput* out) {
  out->joint_losses = m.joint_losses;
  out->friction_resting = m.friction_resting;
  out->wrench_bound.assign(m.wrench.size(), {});
  for (size_t t = 0; t < m.wrench_bound.size() && t < m.wrench.size(); ++t)
    for (int k = 0; k < 6; ++k) out->wrench_bound[t][k] = component(m.wrench_bound[t], k);
}

// output_t and output_v1_t .. output_v3_t have the same fields but for the wrench rows' type, the
// sigma of version 3 and the joint losses and friction bound of version 4
template <class M>
void fill_decoded(const M& m, DecodedOutput* out) {
  fill_sigma(m, out);
  fill_bound(m, out);
  out->utime = m.utime;
  out->tick = m.tick;
  out->sim_time = m.sim_time;
  out->mode = m.mode;
  out->status = m.status;
  out->reason = m.reason;
  out->input = m.input;
  out->input_seq = m.input_seq;
  out->input_utime = m.input_utime;
  out->paused = m.paused;
  out->control_seq = m.control_seq;
  out->control_action = m.control_action;
  out->control_result = m.control_result;
  out->state_fitted = m.state_fitted;
  out->fit_iterations = m.fit_iterations;
  for (int k = 0; k < 4; ++k) {
    out->closure[k] = m.closure[k];
    out->closure_constraint[k] = m.closure_constraint[k];
  }
  out->constraint_names = m.constraint_names;
  out->rows = m.rows;
  out->rank = m.rank;
  out->indeterminate = m.indeterminate;
  out->condition = m.condition;
  out->residual = m.residual;
  out->wrench_names = m.wrench_names;
  out->wrench_frames = m.wrench_frames;
  out->wrench_by = m.wrench_by;
  out->wrench_kind.assign(m.wrench_kind.begin(), m.wrench_kind.end());
  out->wrench.assign(m.wrench.size(), {});
  for (size_t t = 0; t < m.wrench.size(); ++t)
    for (int k = 0; k < 6; ++k) out->wrench[t][k] = component(m.wrench[t], k);
  out->constrained_mask.assign(m.constrained_mask.begin(), m.constrained_mask.end());
  out->indeterminate_mask.assign(m.indeterminate_mask.begin(), m.indeterminate_mask.end());
  out->wrench_measured.assign(m.wrench_measured.begin(), m.wrench_measured.end());
  out->wrench_residual.assign(m.wrench_residual.size(), {});
  for (size_t t = 0; t < m.wrench_residual.size(); ++t)
    for (int k = 0; k < 6; ++k) out->wrench_residual[t][k] = component(m.wrench_residual[t], k);
  out->free_class.assign(m.free_class.begin(), m.free_class.begin() + m.num_free);
  out->free_direction.assign(static_cast<size_t>(m.num_free), std::vector<std::array<double, 6>>(m.wrench.size()));
  for (int d = 0; d < m.num_free; ++d)
    for (size_t t = 0; t < m.wrench.size(); ++t)
      for (int k = 0; k < 6; ++k) out->free_direction[static_cast<size_t>(d)][t][static_cast<size_t>(k)] = component(m.free_direction[static_cast<size_t>(d)][t], k);
  out->contact_status = m.contact_status;
  out->contact_names = m.contact_names;
  out->contact_normal = m.contact_normal;
  out->contact_friction_needed = m.contact_friction_needed;
  out->contact_utilisation = m.contact_utilisation;
  out->contact_state.assign(m.contact_state.begin(), m.contact_state.end());
  out->stress_names = m.stress_names;
  out->stress = m.stress;
  out->q_names = m.q_names;
  out->v_names = m.v_names;
  out->q = m.q;
  out->v = m.v;
  out->tau = m.tau;
  out->vdot = m.vdot;
}
}  // namespace

bool decode_output(const void* data, int len, DecodedOutput* out) {
  if (hash_of(data, len) == coopdyn::output_v1_t::getHash()) {
    coopdyn::output_v1_t v1;
    if (!decode_msg(data, len, &v1)) return false;
    fill_decoded(v1, out);
    return true;
  }
  if (hash_of(data, len) == coopdyn::output_v2_t::getHash()) {
    coopdyn::output_v2_t v2;
    if (!decode_msg(data, len, &v2)) return false;
    fill_decoded(v2, out);
    return true;
  }
  if (hash_of(data, len) == coopdyn::output_v3_t::getHash()) {
    coopdyn::output_v3_t v3;
    if (!decode_msg(data, len, &v3)) return false;
    fill_decoded(v3, out);
    return true;
  }
  coopdyn::output_t m;
  if (!decode_msg(data, len, &m)) return false;
  fill_decoded(m, out);
  return true;
}

bool decode_stats(const void* data, int len, StatsFrame* s) {
  coopdyn::loop_stats_t o;
  if (const int missing = stats_missing_bytes(static_cast<uint64_t>(hash_of(data, len))); missing >= 0) {
    std::vector<uint8_t> now(static_cast<const uint8_t*>(data), static_cast<const uint8_t*>(data) + len);
    const uint64_t h = static_cast<uint64_t>(coopdyn::loop_stats_t::getHash());
    for (int i = 0; i < 8; ++i) now[static_cast<size_t>(i)] = static_cast<uint8_t>(h >> (56 - 8 * i));
    now.insert(now.end(), static_cast<size_t>(missing), 0);
    if (!decode_msg(now.data(), static_cast<int>(now.size()), &o)) return false;
  } else if (!decode_msg(data, len, &o)) {
    return false;
  }
#define COOPDYN_STATS_FIELD(lcm, frame, put) s->frame = o.lcm;
#include "service/io/stats_fields.def"
  // by the reasons' keys, so that a sender built with another set of reasons still reads the ones it knows
  for (int k = 1; k < kRejectKinds; ++k) {
    s->rejected_by_reason[k] = 0;
    for (int i = 0; i < o.num_reject_reasons; ++i)
      if (o.reject_reasons[i] == reject_key(static_cast<Reject>(k))) s->rejected_by_reason[k] = o.rejected_by_reason[i];
  }
  return true;
}

MessageType identify(const void* data, int len) {
  if (hash_of(data, len) == coopdyn::output_v2_t::getHash()) return MessageType::kOutput;  // a log of version 2
  if (hash_of(data, len) == coopdyn::output_v3_t::getHash()) return MessageType::kOutput;  // a log of version 3
  const int64_t h = hash_of(data, len);
  const uint64_t u = static_cast<uint64_t>(h);
  if (h == coopdyn::torque_command_t::getHash() || u == kPreMacCommandHash) return MessageType::kTorqueCommand;
  if (h == coopdyn::measured_state_t::getHash() || u == kPreMacStateHash) return MessageType::kMeasuredState;
  if (h == coopdyn::output_t::getHash() || h == coopdyn::output_v1_t::getHash()) return MessageType::kOutput;
  if (h == coopdyn::loop_stats_t::getHash() || stats_missing_bytes(u) >= 0) return MessageType::kLoopStats;
  if (h == coopdyn::control_t::getHash() || u == kPreMacControlHash) return MessageType::kControl;
  return MessageType::kUnknown;
}

int64_t fingerprint(MessageType t) {
  switch (t) {
    case MessageType::kTorqueCommand: return coopdyn::torque_command_t::getHash();
    case MessageType::kMeasuredState: return coopdyn::measured_state_t::getHash();
    case MessageType::kOutput: return coopdyn::output_t::getHash();
    case MessageType::kLoopStats: return coopdyn::loop_stats_t::getHash();
    case MessageType::kControl: return coopdyn::control_t::getHash();
    case MessageType::kUnknown: break;
  }
  return 0;
}

const char* type_name(MessageType t) {
  switch (t) {
    case MessageType::kTorqueCommand: return "coopdyn.torque_command_t";
    case MessageType::kMeasuredState: return "coopdyn.measured_state_t";
    case MessageType::kOutput: return "coopdyn.output_t";
    case MessageType::kLoopStats: return "coopdyn.loop_stats_t";
    case MessageType::kControl: return "coopdyn.control_t";
    case MessageType::kUnknown: break;
  }
  return "unknown";
}

bool to_csv(MessageType t, const void* data, int len, std::string* header, std::string* row) {
  header->clear();
  row->clear();
  switch (t) {
    case MessageType::kTorqueCommand: {
      coopdyn::torque_command_t m;
      if (!decode_msg(data, len, &m)) return false;
      *header = "utime,seq";
      inum(row, m.utime);
      inum(row, m.seq);
      for (int i = 0; i < m.num_torques; ++i) {
        *header += ",tau:" + (i < m.num_names ? m.names[i] : std::to_string(i));
        num(row, m.tau[i]);
      }
      for (int i = 0; i < m.num_targets; ++i) {
        *header += ",target:" + m.target_names[static_cast<size_t>(i)];
        num(row, m.target[static_cast<size_t>(i)]);
      }
      break;
    }
    case MessageType::kMeasuredState: {
      coopdyn::measured_state_t m;
      if (!decode_msg(data, len, &m)) return false;
      *header = "utime,seq";
      inum(row, m.utime);
      inum(row, m.seq);
      for (int i = 0; i < m.num_q; ++i) {
        *header += ",q:" + (i < m.num_q_names ? m.q_names[i] : std::to_string(i));
        num(row, m.q[i]);
      }
      for (int i = 0; i < m.num_v; ++i) {
        *header += ",v:" + (i < m.num_v_names ? m.v_names[i] : std::to_string(i));
        num(row, m.v[i]);
      }
      for (int i = 0; i < m.num_v; ++i) {
        *header += ",tau:" + (i < m.num_v_names ? m.v_names[i] : std::to_string(i));
        num(row, m.tau[i]);
      }
      break;
    }
    case MessageType::kOutput:  // the step CSV schema (clients/csv/step_csv.h) from decode_output
      return false;
    case MessageType::kLoopStats: {
      StatsFrame s;
      if (!decode_stats(data, len, &s)) return false;
      header->clear();
#define COOPDYN_STATS_FIELD(lcm, frame, put) \
  *header += header->empty() ? #lcm : "," #lcm; \
  put(row, s.frame);
#include "service/io/stats_fields.def"
      for (int k = 1; k < kRejectKinds; ++k) *header += std::string(",rejected_") + reject_key(static_cast<Reject>(k));
      for (int k = 1; k < kRejectKinds; ++k) inum(row, s.rejected_by_reason[k]);
      break;
    }
    case MessageType::kControl: {
      coopdyn::control_t m;
      if (!decode_msg(data, len, &m)) return false;
      *header = "utime,seq,action";
      inum(row, m.utime);
      inum(row, m.seq);
      inum(row, m.action);
      break;
    }
    case MessageType::kUnknown: return false;
  }
  if (!row->empty() && (*row)[0] == ',') row->erase(0, 1);
  return true;
}

}  // namespace coopdyn::io
