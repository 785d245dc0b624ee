#include "service/io/codec/direct_decoder.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string_view>

#include "service/io/codec/codec.h"
#include "service/io/codec/wire.h"

namespace coopdyn::io {

NameTable::NameTable(const std::vector<std::string>& names) {
  for (size_t i = 0; i < names.size(); ++i) sorted_.emplace_back(names[i], static_cast<int>(i));
  std::sort(sorted_.begin(), sorted_.end());  // by name, then index: the first of equal names first
}

int NameTable::find(const char* p, int len) const {
  const std::string_view key(p, static_cast<size_t>(len));
  const auto it = std::lower_bound(sorted_.begin(), sorted_.end(), key,
                                   [](const std::pair<std::string, int>& e, std::string_view k) { return std::string_view(e.first) < k; });
  return it != sorted_.end() && std::string_view(it->first) == key ? it->second : -1;
}

namespace {

int32_t be_i32(const uint8_t* b) {
  return static_cast<int32_t>((uint32_t{b[0]} << 24) | (uint32_t{b[1]} << 16) | (uint32_t{b[2]} << 8) | uint32_t{b[3]});
}
double be_double(const uint8_t* b) {  // LCM's double: the IEEE 754 bits, big-endian
  uint64_t u = 0;
  for (int k = 0; k < 8; ++k) u = (u << 8) | b[k];
  double d;
  std::memcpy(&d, &u, sizeof d);
  return d;
}

// The next of a walked list of strings (int32 length counting the NUL, then the bytes): its bytes
// without the NUL.
struct Names {
  const uint8_t* p;
  std::string_view next() {
    const int32_t l = be_i32(p);
    const std::string_view s(reinterpret_cast<const char*>(p + 4), static_cast<size_t>(l - 1));
    p += 4 + l;
    return s;
  }
};

// count values from the bytes at `values` onto out (n, scene order): without names, all n in order;
// with n_names names (at `names`), each onto its named entry, the others 0. seen: (n) scratch. The
// generated path's map_named (codec.cc), the same checks in the same order.
Reject map_named(const NameTable& table, const uint8_t* names, int32_t n_names, const uint8_t* values, int32_t count,
                 int n, std::vector<unsigned char>& seen, Eigen::VectorXd& out) {
  if (n_names == 0) {
    if (count != n) return Reject::kCount;
    for (int i = 0; i < n; ++i) {
      const double x = be_double(values + 8 * i);
      if (!std::isfinite(x)) return Reject::kNonFinite;
      out[i] = x;
    }
    return Reject::kNone;
  }
  if (n_names != count || count > n) return Reject::kCount;
  std::fill(seen.begin(), seen.end(), 0);
  out.setZero();
  Names it{names};
  for (int i = 0; i < count; ++i) {
    const std::string_view name = it.next();
    const int k = table.find(name.data(), static_cast<int>(name.size()));
    if (k < 0) return Reject::kUnknownName;
    if (seen[static_cast<size_t>(k)]) return Reject::kDuplicateName;
    seen[static_cast<size_t>(k)] = 1;
    const double x = be_double(values + 8 * i);
    if (!std::isfinite(x)) return Reject::kNonFinite;
    out[k] = x;
  }
  return Reject::kNone;
}

std::vector<std::string> wrench_output_names(const System& s) {
  std::vector<std::string> n;
  for (const WrenchOutput& o : s.wrenches.outputs) n.push_back(o.name);
  return n;
}

std::vector<unsigned char> mask(const std::vector<int>& idx, int n) {
  std::vector<unsigned char> m(static_cast<size_t>(n), 0);
  for (int i : idx) m[static_cast<size_t>(i)] = 1;
  return m;
}

}  // namespace

DirectStateDecoder::DirectStateDecoder(const System& sys)
    : sys_(sys),
      plan_(plan_state_fit(sys)),
      q_names_(sys.model.q_names),
      v_names_(sys.model.v_names),
      wrench_names_(wrench_output_names(sys)),
      seen_q_(static_cast<size_t>(sys.model.nq())),
      seen_v_(static_cast<size_t>(sys.model.nv())),
      fit_q_mask_(mask(plan_.fit_q, sys.model.nq())),
      fit_v_mask_(mask(plan_.fit_v, sys.model.nv())),
      pseudo_q_mask_(mask(plan_.pseudo_q, sys.model.nq())),
      pseudo_v_mask_(mask(plan_.pseudo_v, sys.model.nv())) {}

// The coordinates not seen must be pseudo-joints or all of the floating bodies' (and fittable);
// *fit says whether the floating ones were omitted.
Reject DirectStateDecoder::omitted(const std::vector<unsigned char>& seen, const std::vector<unsigned char>& fit_mask,
                                   const std::vector<unsigned char>& pseudo_mask, bool fittable, int n_fit, bool* fit) const {
  int missing_fit = 0;
  for (size_t i = 0; i < seen.size(); ++i) {
    if (seen[i]) continue;
    if (fit_mask[i]) ++missing_fit;
    else if (!pseudo_mask[i]) return Reject::kIncomplete;
  }
  *fit = false;
  if (missing_fit == 0) return Reject::kNone;
  if (missing_fit != n_fit || !fittable) return Reject::kIncomplete;
  *fit = true;
  return Reject::kNone;
}

Reject DirectStateDecoder::decode(const void* data, int len, StateSlot& out) {
  const int nq = sys_.model.nq(), nv = sys_.model.nv();
  const int n_out = static_cast<int>(sys_.wrenches.outputs.size());
  const uint8_t* b = static_cast<const uint8_t*>(data);
  StateLayout m;
  if (!b || !walk_state_layout(data, len, &m)) return Reject::kDecode;
  if (state_counts_exceed(m, nq, nv, n_out)) return Reject::kCount;
  // Without names a state is complete (the scene's order); with names it may omit what the daemon
  // can fit (the floating bodies' coordinates) or knows (pseudo-joints, locked at q0).
  Reject rj = map_named(q_names_, b + m.q_names_at, m.q_names, b + m.q_at, m.q, nq, seen_q_, out.q);
  if (rj != Reject::kNone) return rj;
  rj = map_named(v_names_, b + m.v_names_at, m.v_names, b + m.v_at, m.v, nv, seen_v_, out.v);
  if (rj != Reject::kNone) return rj;
  rj = map_named(v_names_, b + m.v_names_at, m.v_names, b + m.tau_at, m.v, nv, seen_v_, out.tau);
  if (rj != Reject::kNone) return rj;
  out.fit_q = out.fit_v = false;
  if (m.q_names > 0) {
    rj = omitted(seen_q_, fit_q_mask_, pseudo_q_mask_, plan_.q_fittable, static_cast<int>(plan_.fit_q.size()), &out.fit_q);
    if (rj != Reject::kNone) return rj;
    for (int i : plan_.pseudo_q)
      if (!seen_q_[static_cast<size_t>(i)]) out.q[i] = sys_.q0[i];
  }
  if (m.v_names > 0) {
    rj = omitted(seen_v_, fit_v_mask_, pseudo_v_mask_, plan_.v_fittable, static_cast<int>(plan_.fit_v.size()), &out.fit_v);
    if (rj != Reject::kNone) return rj;
    for (int i : plan_.pseudo_v)
      if (!seen_v_[static_cast<size_t>(i)]) out.v[i] = out.tau[i] = 0.0;
  }
  // force/torque sensor readings, by wrench output name (a slot not sized by its owner is sized here once)
  if (out.has_wrench.size() != static_cast<size_t>(n_out)) {
    out.has_wrench.assign(static_cast<size_t>(n_out), 0);
    out.wrench.assign(static_cast<size_t>(n_out), {});
  }
  std::fill(out.has_wrench.begin(), out.has_wrench.end(), 0);
  out.n_wrenches = 0;
  Names names{b + m.wrench_names_at};
  for (int i = 0; i < m.wrenches; ++i) {
    const std::string_view name = names.next();
    const int k = wrench_names_.find(name.data(), static_cast<int>(name.size()));
    if (k < 0) return Reject::kUnknownName;
    if (out.has_wrench[static_cast<size_t>(k)]) return Reject::kDuplicateName;
    for (int c = 0; c < 6; ++c) {
      const double x = be_double(b + m.wrench_at + 48 * i + 8 * c);
      if (!std::isfinite(x)) return Reject::kNonFinite;
      out.wrench[static_cast<size_t>(k)][static_cast<size_t>(c)] = x;
    }
    out.has_wrench[static_cast<size_t>(k)] = 1;
    ++out.n_wrenches;
  }
  out.utime = m.utime;
  out.seq = m.seq;
  return Reject::kNone;
}

}  // namespace coopdyn::io
