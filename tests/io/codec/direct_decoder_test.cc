// The allocation-free state decoder (service/io/codec/direct_decoder.h) against the generated one
// (StateDecoder, codec.h): on every scene, valid states of every form (in order, named, named in
// reverse, joints only with the load fitted, pseudo-joints omitted, sensor readings) decode to the
// same slot, bit for bit, and to the values sent; truncated, oversized and hostile messages and
// random mutations of valid ones get the same reason from both; and decoding alternating forms and
// hostile messages allocates nothing (the generated decoder does, on the same messages).
#include "tests/support/counting_allocator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "service/dynamics/state_fit.h"
#include "service/io/codec/codec.h"
#include "service/io/codec/direct_decoder.h"
#include "service/scene/scene.h"
#include "tests/support/daemon_test_util.h"

using namespace coopdyn;
using namespace coopdyn::daemon_test;
using coopdyn::testing::AllocationCounter;
using coopdyn::testing::kCountingAvailable;

namespace {

io::StateSlot sized_slot(const System& sys) {
  io::StateSlot s;
  s.q = Eigen::VectorXd::Zero(sys.model.nq());
  s.v = Eigen::VectorXd::Zero(sys.model.nv());
  s.tau = Eigen::VectorXd::Zero(sys.model.nv());
  s.has_wrench.assign(sys.wrenches.outputs.size(), 0);
  s.wrench.assign(sys.wrenches.outputs.size(), {});
  return s;
}

// "" when the two slots hold the same decoded state (exact: the same bits were read)
std::string differ(const io::StateSlot& a, const io::StateSlot& b) {
  if (a.utime != b.utime || a.seq != b.seq) return "utime or seq";
  if (a.q != b.q) return "q";
  if (a.v != b.v) return "v";
  if (a.tau != b.tau) return "tau";
  if (a.fit_q != b.fit_q || a.fit_v != b.fit_v) return "fit flags";
  if (a.has_wrench != b.has_wrench || a.n_wrenches != b.n_wrenches) return "which wrenches were measured";
  for (size_t t = 0; t < a.has_wrench.size(); ++t)
    if (a.has_wrench[t] && a.wrench[t] != b.wrench[t]) return "wrench " + std::to_string(t);
  return "";
}

// Both decoders on one input: the same reason, and on acceptance the same slot. "" when they agree.
struct Pair {
  const System& sys;
  io::StateDecoder generated;
  io::DirectStateDecoder direct;
  io::StateSlot a, b;
  explicit Pair(const System& s) : sys(s), generated(s), direct(s), a(sized_slot(s)), b(sized_slot(s)) {}
  std::string agree(const std::vector<uint8_t>& m, io::Reject* why = nullptr) {
    const io::Reject rg = generated.decode(m.data(), static_cast<int>(m.size()), a);
    const io::Reject rd = direct.decode(m.data(), static_cast<int>(m.size()), b);
    if (why) *why = rd;
    if (rg != rd) return std::string("generated: ") + io::reject_name(rg) + ", direct: " + io::reject_name(rd);
    return rg == io::Reject::kNone ? differ(a, b) : "";
  }
};

// The valid states of a scene, in every form it allows.
struct Forms {
  std::vector<std::vector<uint8_t>> msgs;
  std::vector<std::string> labels;
  void add(const std::string& l, std::vector<uint8_t> m) {
    labels.push_back(l);
    msgs.push_back(std::move(m));
  }
};
Forms valid_states(const System& sys) {
  Forms f;
  const int nq = sys.model.nq(), nv = sys.model.nv();
  std::vector<double> q = stdvec(sys.q0), v(static_cast<size_t>(nv)), tau = stdvec(some_torque(sys, 3, 0.7));
  for (int i = 0; i < nv; ++i) v[static_cast<size_t>(i)] = 0.01 * (i + 1) * (i % 2 ? -1 : 1);
  for (int d : sys.model.pseudo_dofs) v[static_cast<size_t>(d)] = 0;
  const int64_t t = 1718000000000000LL;
  f.add("in order", io::encode_measured_state(t, 1, {}, q, {}, v, tau));
  f.add("named", io::encode_measured_state(t, 2, sys.model.q_names, q, sys.model.v_names, v, tau));
  {  // named, in reverse order
    std::vector<std::string> qn(sys.model.q_names.rbegin(), sys.model.q_names.rend()), vn(sys.model.v_names.rbegin(), sys.model.v_names.rend());
    f.add("named in reverse", io::encode_measured_state(t, 3, qn, std::vector<double>(q.rbegin(), q.rend()), vn,
                                                        std::vector<double>(v.rbegin(), v.rend()), std::vector<double>(tau.rbegin(), tau.rend())));
  }
  const StateFitPlan plan = plan_state_fit(sys);
  auto without = [](const std::vector<int>& drop, int n, const std::vector<std::string>& names, const std::vector<double>& x,
                    std::vector<std::string>* on, std::vector<double>* ox) {
    for (int i = 0; i < n; ++i)
      if (std::find(drop.begin(), drop.end(), i) == drop.end()) {
        on->push_back(names[static_cast<size_t>(i)]);
        ox->push_back(x[static_cast<size_t>(i)]);
      }
  };
  if (plan.q_fittable && plan.v_fittable && !plan.fit_q.empty()) {  // the joints only, the load fitted
    std::vector<std::string> jq, jv, jv2;
    std::vector<double> qj, vj, tj;
    without(plan.fit_q, nq, sys.model.q_names, q, &jq, &qj);
    without(plan.fit_v, nv, sys.model.v_names, v, &jv, &vj);
    without(plan.fit_v, nv, sys.model.v_names, tau, &jv2, &tj);
    f.add("joints only", io::encode_measured_state(t, 4, jq, qj, jv, vj, tj));
    if (!sys.wrenches.outputs.empty())
      f.add("joints only, a sensor", io::encode_measured_state(t, 5, jq, qj, jv, vj, tj, {sys.wrenches.outputs.back().name},
                                                               {{0.1, -0.2, 0.3, 1.0, -2.0, 30.0}}));
  }
  if (!plan.pseudo_q.empty()) {  // pseudo-joints omitted (set to q0 and 0)
    std::vector<std::string> pq, pv, pv2;
    std::vector<double> qp, vp, tp;
    without(plan.pseudo_q, nq, sys.model.q_names, q, &pq, &qp);
    without(plan.pseudo_v, nv, sys.model.v_names, v, &pv, &vp);
    without(plan.pseudo_v, nv, sys.model.v_names, tau, &pv2, &tp);
    f.add("pseudo-joints omitted", io::encode_measured_state(t, 6, pq, qp, pv, vp, tp));
  }
  if (!sys.wrenches.outputs.empty()) {  // every sensor, in reverse order
    std::vector<std::string> wn;
    std::vector<std::array<double, 6>> w;
    for (size_t k = sys.wrenches.outputs.size(); k-- > 0;) {
      wn.push_back(sys.wrenches.outputs[k].name);
      w.push_back({double(k), -1.5, 2.25, 1e-300, -0.0, 1e300});
    }
    f.add("every sensor", io::encode_measured_state(t, 7, {}, q, {}, v, tau, wn, w));
  }
  return f;
}

void put_i32(std::vector<uint8_t>& m, size_t at, int32_t x) {
  for (int k = 0; k < 4; ++k) m[at + static_cast<size_t>(k)] = static_cast<uint8_t>(static_cast<uint32_t>(x) >> (24 - 8 * k));
}

}  // namespace

// Every form of a valid state decodes to the same slot with both decoders, on every scene; the
// values land where their names say (checked against what was sent, not only between the two).
TEST(DirectStateDecoder, ValidStatesDecodeAsTheGeneratedDecoderOnEveryScene) {
  for (const std::string& name : loadable_scenes()) {
    SCOPED_TRACE(name);
    const System sys = load_scene(scene_path(name));
    Pair p(sys);
    const Forms f = valid_states(sys);
    io::StateSlot in_order;  // f.msgs[0]
    for (size_t k = 0; k < f.msgs.size(); ++k) {
      io::Reject why;
      EXPECT_EQ(p.agree(f.msgs[k], &why), "") << f.labels[k];
      EXPECT_EQ(why, io::Reject::kNone) << f.labels[k] << ": " << io::reject_name(why);
      if (why != io::Reject::kNone) continue;
      if (k == 0) in_order = p.b;
      if (f.labels[k] == "named" || f.labels[k] == "named in reverse") {  // each value where its name says
        EXPECT_EQ(p.b.q, in_order.q) << f.labels[k];
        EXPECT_EQ(p.b.v, in_order.v) << f.labels[k];
        EXPECT_EQ(p.b.tau, in_order.tau) << f.labels[k];
      }
      if (f.labels[k] == "every sensor") {
        EXPECT_EQ(p.b.n_wrenches, static_cast<int>(sys.wrenches.outputs.size()));
        EXPECT_EQ(p.b.wrench[0][0], 0.0);
        EXPECT_EQ(p.b.wrench.back()[5], 1e300);
        EXPECT_TRUE(std::signbit(p.b.wrench[0][4]));  // -0 read as -0
      }
      if (f.labels[k] == "joints only") {
        EXPECT_TRUE(p.b.fit_q);
        EXPECT_TRUE(p.b.fit_v);
      }
    }
    // the forms in turn, twice: nothing carries over from one message to the next
    for (int round = 0; round < 2; ++round)
      for (size_t k = 0; k < f.msgs.size(); ++k) EXPECT_EQ(p.agree(f.msgs[k]), "") << f.labels[k] << " again";
  }
}

// Truncated at every length, counts and string lengths set to hostile values, bytes appended, names
// without their NUL, unknown, repeated, values not finite: the same reason from both decoders, and
// the ones a message must be refused with.
TEST(DirectStateDecoder, TruncatedOversizedAndHostileStatesAreRefusedAsByTheGeneratedDecoder) {
  const System sys = load_scene(scene_path("two_puma_load"));
  Pair p(sys);
  const Forms f = valid_states(sys);
  for (size_t k = 0; k < f.msgs.size(); ++k) {
    SCOPED_TRACE(f.labels[k]);
    const std::vector<uint8_t>& m = f.msgs[k];
    for (size_t n = 0; n < m.size(); ++n) {  // every prefix: the mac_len field is last, so each is cut short
      const std::vector<uint8_t> cut(m.begin(), m.begin() + static_cast<long>(n));
      io::Reject why;
      ASSERT_EQ(p.agree(cut, &why), "") << "cut at " << n;
      ASSERT_EQ(why, io::Reject::kDecode) << "cut at " << n;
    }
    // every 4-byte window set to a hostile int32 (counts, string lengths, parts of doubles)
    for (size_t at = 8; at + 4 <= m.size(); ++at)
      for (int32_t x : {-1, 0, 1, 7, 1 << 16, (1 << 16) + 1, std::numeric_limits<int32_t>::max(), std::numeric_limits<int32_t>::min()}) {
        std::vector<uint8_t> h = m;
        put_i32(h, at, x);
        ASSERT_EQ(p.agree(h), "") << "int32 " << x << " at " << at;
      }
    std::vector<uint8_t> longer = m;
    longer.insert(longer.end(), {1, 2, 3});
    EXPECT_EQ(p.agree(longer), "") << "bytes appended";
  }
  const int64_t t = 1718000000000000LL;
  const std::vector<double> q = stdvec(sys.q0), v(static_cast<size_t>(sys.model.nv()), 0.0);
  std::vector<std::string> qn = sys.model.q_names;
  struct Case {
    const char* what;
    std::vector<uint8_t> m;
    io::Reject want;
  };
  std::vector<std::string> unknown = qn, twice = qn, long_name = qn;
  unknown[1] = "no_such_joint";
  twice[1] = twice[0];
  long_name[2] = std::string(300, 'x');
  std::vector<double> q_nan = q;
  q_nan[3] = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> v_inf = v;
  v_inf[2] = -std::numeric_limits<double>::infinity();
  const std::vector<Case> cases = {
      {"an unknown name", io::encode_measured_state(t, 1, unknown, q, {}, v, v), io::Reject::kUnknownName},
      {"a name twice", io::encode_measured_state(t, 1, twice, q, {}, v, v), io::Reject::kDuplicateName},
      {"a long unknown name", io::encode_measured_state(t, 1, long_name, q, {}, v, v), io::Reject::kUnknownName},
      {"NaN in q", io::encode_measured_state(t, 1, {}, q_nan, {}, v, v), io::Reject::kNonFinite},
      {"-Inf in v", io::encode_measured_state(t, 1, {}, q, {}, v_inf, v), io::Reject::kNonFinite},
      {"q one short", io::encode_measured_state(t, 1, {}, std::vector<double>(q.begin(), q.end() - 1), {}, v, v), io::Reject::kCount},
      {"an unknown sensor", io::encode_measured_state(t, 1, {}, q, {}, v, v, {"no.such"}, {{0, 0, 0, 0, 0, 0}}), io::Reject::kUnknownName},
      {"a sensor twice",
       io::encode_measured_state(t, 1, {}, q, {}, v, v, {sys.wrenches.outputs[0].name, sys.wrenches.outputs[0].name}, {{}, {}}),
       io::Reject::kDuplicateName},
      {"a NaN sensor reading",
       io::encode_measured_state(t, 1, {}, q, {}, v, v, {sys.wrenches.outputs[0].name}, {{0, 0, std::nan(""), 0, 0, 0}}),
       io::Reject::kNonFinite},
  };
  for (const Case& c : cases) {
    io::Reject why;
    EXPECT_EQ(p.agree(c.m, &why), "") << c.what;
    EXPECT_EQ(why, c.want) << c.what << ": " << io::reject_name(why);
  }
  {  // a name whose last byte is not its NUL: not an LCM string
    std::vector<uint8_t> m = io::encode_measured_state(t, 1, qn, q, {}, v, v);
    const size_t first_name = 8 + 16 + 4 + 4;  // hash, utime, seq, num_q_names, the first length
    m[first_name + qn[0].size()] = 'x';
    io::Reject why;
    EXPECT_EQ(p.agree(m, &why), "");
    EXPECT_EQ(why, io::Reject::kDecode);
  }
  {  // another type's fingerprint
    std::vector<uint8_t> m = io::encode_measured_state(t, 1, {}, q, {}, v, v);
    m[7] ^= 1;
    io::Reject why;
    EXPECT_EQ(p.agree(m, &why), "");
    EXPECT_EQ(why, io::Reject::kDecode);
  }
}

// Random mutations of every form on three scenes (bytes overwritten, flipped, cut, repeated): the two
// decoders agree on each, accepted ones included.
TEST(DirectStateDecoder, MutatedStatesAgreeWithTheGeneratedDecoder) {
  long accepted = 0, total = 0;
  for (const char* name : {"two_puma_load", "four_wheel_car", "pr2_box"}) {
    SCOPED_TRACE(name);
    const System sys = load_scene(scene_path(name));
    Pair p(sys);
    const Forms f = valid_states(sys);
    std::mt19937_64 rng(20261204);
    for (int i = 0; i < 6000; ++i) {
      std::vector<uint8_t> m = f.msgs[static_cast<size_t>(i) % f.msgs.size()];
      const int edits = 1 + static_cast<int>(rng() % 3);
      for (int e = 0; e < edits && !m.empty(); ++e) {
        const size_t at = rng() % m.size();
        switch (rng() % 4) {
          case 0: m[at] = static_cast<uint8_t>(rng()); break;
          case 1: m[at] ^= static_cast<uint8_t>(1u << (rng() % 8)); break;
          case 2: m.resize(at); break;
          case 3: m.insert(m.begin() + static_cast<long>(at), m[at]); break;
        }
      }
      io::Reject why;
      ASSERT_EQ(p.agree(m, &why), "") << "input " << i;
      accepted += why == io::Reject::kNone;
      ++total;
    }
  }
  EXPECT_GT(accepted, 0);  // values were judged, not only framing
  EXPECT_LT(accepted, total);
}

// Full, joints-only, every-sensor and hostile states in turn (names of every length, a 300-byte
// unknown name, counts beyond the scene): the direct decoder allocates nothing once constructed. The
// generated decoder, on the same messages, does (the loop's thread could not run it).
TEST(DirectStateDecoderNoAllocation, AlternatingFormsAndHostileStates) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  const System sys = load_scene(scene_path("two_puma_load"));
  Forms f = valid_states(sys);
  const int64_t t = 1718000000000000LL;
  std::vector<std::string> long_name = sys.model.q_names;
  long_name[0] = std::string(300, 'y');
  f.add("a long unknown name", io::encode_measured_state(t, 1, long_name, stdvec(sys.q0), {}, stdvec(sys.v0), stdvec(sys.v0)));
  std::vector<uint8_t> huge = f.msgs[0];
  put_i32(huge, 24, std::numeric_limits<int32_t>::max());
  f.add("a huge count", huge);
  io::DirectStateDecoder direct(sys);
  io::StateDecoder generated(sys);
  io::StateSlot a = sized_slot(sys), b = sized_slot(sys);
  long direct_allocations = 0, generated_allocations = 0, accepted = 0;
  for (int round = 0; round < 50; ++round)
    for (const auto& m : f.msgs) {
      {
        AllocationCounter c;
        accepted += direct.decode(m.data(), static_cast<int>(m.size()), b) == io::Reject::kNone;
        direct_allocations += c.count();
      }
      AllocationCounter c;
      generated.decode(m.data(), static_cast<int>(m.size()), a);
      generated_allocations += c.count();
    }
  EXPECT_EQ(direct_allocations, 0);
  EXPECT_EQ(accepted, 50 * static_cast<long>(f.msgs.size() - 2));
  EXPECT_GT(generated_allocations, 0);
}
