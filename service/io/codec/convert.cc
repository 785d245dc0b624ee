// Client-side conversions (allocate freely; never on the loop path): message encoding for
// `coopdyn send` and tests, decoding and CSV rows for `coopdyn log`.
#include <cstdio>
#include <cstring>
#include <tuple>
#include <type_traits>
#include <utility>

#include "coopdyn/control_t.hpp"
#include "coopdyn/loop_stats_t.hpp"
#include "coopdyn/measured_state_t.hpp"
#include "coopdyn/output_t.hpp"
#include "coopdyn/output_v1_t.hpp"
#include "coopdyn/output_v2_t.hpp"
#include "coopdyn/output_v3_t.hpp"
#include "coopdyn/output_v4_t.hpp"
#include "coopdyn/torque_command_t.hpp"
#include "service/io/codec/codec.h"
#include "service/io/codec/output_traits.h"

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
// loop_stats_t's layouts: each fingerprint with the `since` (stats_fields.def) it has the fields of.
// An older layout lacks the int64 fields appended after it (at the end of the message): it reads as
// the current one with them 0.
struct StatsLayout {
  uint64_t hash;
  int version;
};
constexpr int kStatsVersion = 5;
constexpr StatsLayout kStatsLayouts[] = {
#define COOPDYN_STATS_LAYOUT(hash, version) {hash, version},
#include "service/io/codec/stats_fields.def"
};
constexpr int stats_fields_after(int version) {
  return 0
#define COOPDYN_STATS_FIELD(lcm, frame, put, since) +((since) > version ? 1 : 0)
#include "service/io/codec/stats_fields.def"
      ;
}
static_assert(stats_fields_after(kStatsVersion) == 0, "stats_fields.def: a since above kStatsVersion");
int stats_version(uint64_t hash) {
  for (const StatsLayout& b : kStatsLayouts)
    if (b.hash == hash) return b.version;
  return -1;
}
// the bytes an old layout lacks, -1 for the current one or another type
int stats_missing_bytes(uint64_t hash) {
  const int v = stats_version(hash);
  return v < 0 ? -1 : 8 * stats_fields_after(v);
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
// Copies a decoded message's field into DecodedOutput's, whatever the layout's element types (int8_t
// codes, int16_t arrays, 6-arrays or wrench_t rows).
template <class T, class U>
void get(T& out, const U& in) {
  out = static_cast<T>(in);
}
template <class T, class U, size_t N>
void get(std::array<T, N>& out, const U (&in)[N]) {
  for (size_t k = 0; k < N; ++k) out[k] = static_cast<T>(in[k]);
}
void get(std::array<double, 6>& out, const coopdyn::wrench_t& w) {
  for (int k = 0; k < 6; ++k) out[static_cast<size_t>(k)] = component(w, k);
}
void get(std::array<double, 6>& out, const std::vector<double>& w) {
  for (int k = 0; k < 6; ++k) out[static_cast<size_t>(k)] = component(w, k);
}
void get(std::string& out, const std::string& in) { out = in; }
template <class T, class U>
void get(std::vector<T>& out, const std::vector<U>& in) {
  out.resize(in.size());
  for (size_t i = 0; i < in.size(); ++i) get(out[i], in[i]);
}

// A field the layout lacks: its `absent` value, as many as the message's count for it.
template <class T, class V>
void put_absent(T& out, V absent, size_t) {
  out = static_cast<T>(absent);
}
template <class T, size_t N, class V>
void put_absent(std::array<T, N>& out, V absent, size_t) {
  out.fill(static_cast<T>(absent));
}
template <class V>
void put_absent(std::string& out, V, size_t) {
  out.clear();
}
template <class T, class V>
void put_absent(std::vector<T>& out, V absent, size_t n) {
  out.resize(n);
  for (T& x : out) put_absent(x, absent, 0);
}
template <class T, class V>
void put_absent(std::vector<std::vector<T>>& out, V, size_t) {
  out.clear();  // free directions are in every layout; a new one would need its own rule
}

// How many elements a field of this size has, from the fields every layout has.
size_t elements(const DecodedOutput& o, const char* size) {
  const std::string s = size;
  if (s == "constraints") return o.constraint_names.size();
  if (s == "wrenches") return o.wrench_names.size();
  if (s == "free") return o.free_class.size();
  if (s == "contacts") return o.contact_names.size();
  if (s == "stresses") return o.stress_names.size();
  if (s == "q") return o.q_names.size();
  if (s == "v") return o.v_names.size();
  return s == "four" ? 4 : 1;
}

// The layouts output_t was published in, each with its VERSION: a field is in a layout exactly when
// its `since` is not above the layout's version (checked here at compile time for every field).
template <class M, int V>
struct Layout {
  using Message = M;
  static constexpr int kVersion = V;
#define COOPDYN_OUTPUT_FIELD(name, type, size, since, absent, on_error, csv, doc) \
  static_assert(has_##name<M>::value == ((since) <= V), "output_fields.def: since of " #name);
#include "service/io/codec/output_fields.def"
};
static_assert(coopdyn::output_t::VERSION == 5, "a new VERSION: freeze the old layout (messages.md, Adding a field)");
using OutputLayouts = std::tuple<Layout<coopdyn::output_t, 5>, Layout<coopdyn::output_v4_t, 4>,
                                 Layout<coopdyn::output_v3_t, 3>,
                                 Layout<coopdyn::output_v2_t, 2>, Layout<coopdyn::output_v1_t, 1>>;

// The one upgrader: a message of any layout into the current fields, the absent ones marked. The
// count fields (type count) are the vectors' sizes.
#define COOPDYN_UPGRADE_count(name, size, absent)
#define COOPDYN_UPGRADE_FIELD(name, size, absent)                                        \
  if constexpr (has_##name<M>::value) {                                                 \
    get(out->name, m.name);                                                             \
  } else {                                                                              \
    put_absent(out->name, absent, elements(*out, #size));                              \
    out->missing |= uint64_t{1} << static_cast<int>(OutputField::name);                 \
  }
#define COOPDYN_UPGRADE_i COOPDYN_UPGRADE_FIELD
#define COOPDYN_UPGRADE_i64 COOPDYN_UPGRADE_FIELD
#define COOPDYN_UPGRADE_f COOPDYN_UPGRADE_FIELD
#define COOPDYN_UPGRADE_f4 COOPDYN_UPGRADE_FIELD
#define COOPDYN_UPGRADE_i4 COOPDYN_UPGRADE_FIELD
#define COOPDYN_UPGRADE_names COOPDYN_UPGRADE_FIELD
#define COOPDYN_UPGRADE_ints COOPDYN_UPGRADE_FIELD
#define COOPDYN_UPGRADE_reals COOPDYN_UPGRADE_FIELD
#define COOPDYN_UPGRADE_wrenches COOPDYN_UPGRADE_FIELD
#define COOPDYN_UPGRADE_dirs COOPDYN_UPGRADE_FIELD
template <class M>
void upgrade(const M& m, DecodedOutput* out) {
  out->missing = 0;
#define COOPDYN_OUTPUT_FIELD(name, type, size, since, absent, on_error, csv, doc) \
  COOPDYN_UPGRADE_##type(name, size, absent)
#include "service/io/codec/output_fields.def"
}

template <size_t I = 0>
int decode_layout(int64_t hash, const void* data, int len, DecodedOutput* out) {
  if constexpr (I == std::tuple_size_v<OutputLayouts>) {
    return -1;  // not an output_t of any layout
  } else {
    using L = std::tuple_element_t<I, OutputLayouts>;
    if (hash != L::Message::getHash()) return decode_layout<I + 1>(hash, data, len, out);
    typename L::Message m;
    if (!decode_msg(data, len, &m)) return 0;
    upgrade(m, out);
    if (!out->has(OutputField::version)) out->version = L::kVersion;
    return 1;
  }
}
template <size_t... I>
bool is_output_layout(int64_t hash, std::index_sequence<I...>) {
  return ((hash == std::tuple_element_t<I, OutputLayouts>::Message::getHash()) || ...);
}
bool is_output_layout(int64_t hash) {
  return is_output_layout(hash, std::make_index_sequence<std::tuple_size_v<OutputLayouts>>());
}
}  // namespace

bool decode_output(const void* data, int len, DecodedOutput* out) {
  return decode_layout(hash_of(data, len), data, len, out) == 1;
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
  const int version = stats_version(static_cast<uint64_t>(hash_of(data, len)));
  s->missing = 0;
  int field = 0;
#define COOPDYN_STATS_FIELD(lcm, frame, put, since)                      \
  s->frame = o.lcm;                                                      \
  if (version >= 0 && (since) > version) s->missing |= uint64_t{1} << field; \
  ++field;
#include "service/io/codec/stats_fields.def"
  // by the reasons' keys, so that a sender built with another set of reasons still reads the ones it knows
  for (int k = 1; k < kRejectKinds; ++k) {
    s->rejected_by_reason[k] = 0;
    for (int i = 0; i < o.num_reject_reasons; ++i)
      if (o.reject_reasons[i] == reject_key(static_cast<Reject>(k))) s->rejected_by_reason[k] = o.rejected_by_reason[i];
  }
  return true;
}

MessageType identify(const void* data, int len) {
  const int64_t h = hash_of(data, len);
  const uint64_t u = static_cast<uint64_t>(h);
  if (h == coopdyn::torque_command_t::getHash() || u == kPreMacCommandHash) return MessageType::kTorqueCommand;
  if (h == coopdyn::measured_state_t::getHash() || u == kPreMacStateHash) return MessageType::kMeasuredState;
  if (is_output_layout(h)) return MessageType::kOutput;  // output_t of any layout
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
#define COOPDYN_STATS_FIELD(lcm, frame, put, since) \
  *header += header->empty() ? #lcm : "," #lcm; \
  put(row, s.frame);
#include "service/io/codec/stats_fields.def"
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
