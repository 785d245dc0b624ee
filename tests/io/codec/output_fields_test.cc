// output_t's one field list (service/io/codec/output_fields.def): every older layout (output_v1_t ..
// output_v4_t) decodes through the one upgrader into the current fields, equal to the current
// message's where the layout has the field, its absent value and marked missing where it does not;
// and docs/reference/messages.md's output_t table is the list's.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "coopdyn/output_t.hpp"
#include "coopdyn/output_v1_t.hpp"
#include "coopdyn/output_v2_t.hpp"
#include "coopdyn/output_v3_t.hpp"
#include "coopdyn/output_v4_t.hpp"
#include "service/dynamics/contacts.h"
#include "service/dynamics/joint_limits.h"
#include "service/dynamics/sigma/wrench_sigma.h"
#include "service/io/codec/codec.h"
#include "service/io/codec/output_schema.h"
#include "service/io/codec/output_traits.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {
using namespace io;  // has_NAME<M> (output_traits.h)


// A field of the current generated message into an old layout's (wrench_t rows to 6-arrays for v1).
template <class T, class U>
void put(T& d, const U& s) {
  d = s;
}
template <class T, class U, size_t N>
void put(T (&d)[N], const U (&s)[N]) {
  for (size_t k = 0; k < N; ++k) d[k] = s[k];
}
void put(std::vector<double>& d, const coopdyn::wrench_t& w) { d = {w.mx, w.my, w.mz, w.fx, w.fy, w.fz}; }
template <class T, class U>
void put(std::vector<T>& d, const std::vector<U>& s) {
  d.resize(s.size());
  for (size_t i = 0; i < s.size(); ++i) put(d[i], s[i]);
}

// The message m in layout L: the fields L has, copied; version V where L has it.
template <class L>
std::vector<uint8_t> encode_as(const coopdyn::output_t& m, int version) {
  L old;
#define COOPDYN_OUTPUT_FIELD(name, type, size, since, absent, on_error, csv, doc) \
  if constexpr (has_##name<L>::value) put(old.name, m.name);
#include "service/io/codec/output_fields.def"
  if constexpr (has_version<L>::value) old.version = static_cast<int16_t>(version);
  std::vector<uint8_t> b(static_cast<size_t>(old.getEncodedSize()));
  EXPECT_GT(old.encode(b.data(), 0, static_cast<int>(b.size())), 0);
  return b;
}

// A value shaped as cur with every element `absent`.
template <class T, class V>
T absent_like(const T&, V a) {
  return static_cast<T>(a);
}
template <class V>
std::string absent_like(const std::string&, V) {
  return "";
}
template <class T, size_t N, class V>
std::array<T, N> absent_like(const std::array<T, N>&, V a) {
  std::array<T, N> r;
  r.fill(static_cast<T>(a));
  return r;
}
template <class T, class V>
std::vector<T> absent_like(const std::vector<T>& c, V a) {
  std::vector<T> r;
  for (const T& x : c) r.push_back(absent_like(x, a));
  return r;
}

struct Published {
  System sys = load_scene_string(scene_text("four_wheel_car") + "\nnoise: {tau: 0.2}\n", scene_path("four_wheel_car"));
  coopdyn::output_t msg;
  io::DecodedOutput now;
  Published() {
    Workspace ws(sys);
    WrenchData wd(sys);
    WrenchSigmaData sd(sys);
    ContactData cd(sys);
    Eigen::VectorXd tau = Eigen::VectorXd::Constant(sys.model.nv(), 0.3);
    evaluate(sys, ws, sys.q0, sys.v0, tau);
    compute_wrenches(sys, ws, wd);
    compute_wrench_sigma(sys, ws, sd);
    compute_contacts(sys, ws, cd);
    io::OutputFrame f;
    f.valid = true;
    f.q = &sys.q0;
    f.v = &sys.v0;
    f.tau = &tau;
    f.ws = &ws;
    f.wrenches = &wd;
    f.sigma = sd.declared ? &sd : nullptr;
    f.contacts = &cd;
    // a joint past its velocity and effort limits, as the loop's check_joint_limits() leaves it
    LimitData ld(sys);
    ld.mask[1] = kLimitVelocity | kLimitEffort;
    ld.exceeded = 1;
    ld.any = ld.mask[1];
    f.limits = &ld;
    f.input_seq = 7;
    io::OutputEncoder enc(sys);
    std::vector<uint8_t> b(static_cast<size_t>(enc.max_size()));
    const int n = enc.encode(f, b.data(), static_cast<int>(b.size()));
    EXPECT_GT(n, 0);
    EXPECT_GT(msg.decode(b.data(), 0, n), 0);
    EXPECT_TRUE(io::decode_output(b.data(), n, &now));
  }
};

template <class L>
void expect_upgraded(const Published& p, int version) {
  const std::vector<uint8_t> b = encode_as<L>(p.msg, version);
  EXPECT_EQ(io::identify(b.data(), static_cast<int>(b.size())), io::MessageType::kOutput);
  io::DecodedOutput old;
  ASSERT_TRUE(io::decode_output(b.data(), static_cast<int>(b.size()), &old));
  int missing = 0;
#define COOPDYN_CHECK_count(name, since, absent)
#define COOPDYN_CHECK_FIELD(name, since, absent)                                                     \
  if ((since) <= version) {                                                                          \
    EXPECT_TRUE(old.has(io::OutputField::name)) << #name;                                            \
    if (std::string(#name) != "version") EXPECT_EQ(old.name, p.now.name) << #name;                   \
  } else {                                                                                           \
    ++missing;                                                                                       \
    EXPECT_FALSE(old.has(io::OutputField::name)) << #name;                                           \
    if (std::string(#name) != "version") EXPECT_EQ(old.name, absent_like(p.now.name, absent)) << #name; \
  }
#define COOPDYN_OUTPUT_FIELD(name, type, size, since, absent, on_error, csv, doc) \
  COOPDYN_CHECK_##type(name, since, absent)
#define COOPDYN_CHECK_i COOPDYN_CHECK_FIELD
#define COOPDYN_CHECK_i64 COOPDYN_CHECK_FIELD
#define COOPDYN_CHECK_f COOPDYN_CHECK_FIELD
#define COOPDYN_CHECK_f4 COOPDYN_CHECK_FIELD
#define COOPDYN_CHECK_i4 COOPDYN_CHECK_FIELD
#define COOPDYN_CHECK_names COOPDYN_CHECK_FIELD
#define COOPDYN_CHECK_ints COOPDYN_CHECK_FIELD
#define COOPDYN_CHECK_reals COOPDYN_CHECK_FIELD
#define COOPDYN_CHECK_wrenches COOPDYN_CHECK_FIELD
#define COOPDYN_CHECK_dirs COOPDYN_CHECK_FIELD
#include "service/io/codec/output_fields.def"
  EXPECT_EQ(old.version, version);
  EXPECT_EQ(missing > 0, version < coopdyn::output_t::VERSION);
}

TEST(OutputFields, EveryLayoutReadsAsTheCurrentFieldsTheAbsentOnesMarked) {
  const Published p;
  // the message carries what the upgrade must keep or mark: contacts, sigma, a state
  ASSERT_EQ(p.now.contact_names.size(), 4u);
  ASSERT_NE(p.now.sigma_source, 0);
  ASSERT_GT(std::abs(p.now.wrench_sigma[0][5]), 0.0);
  // the limits as the loop handed them over: the union, and each velocity coordinate's bits
  EXPECT_EQ(p.now.limits, coopdyn::output_t::LIMIT_VELOCITY | coopdyn::output_t::LIMIT_EFFORT);
  std::vector<int> mask(p.sys.model.v_names.size(), 0);
  mask[1] = coopdyn::output_t::LIMIT_VELOCITY | coopdyn::output_t::LIMIT_EFFORT;
  EXPECT_EQ(p.now.limit_mask, mask);
  EXPECT_EQ(p.now.missing, 0u);
  EXPECT_EQ(p.now.version, int{coopdyn::output_t::VERSION});
  expect_upgraded<coopdyn::output_t>(p, coopdyn::output_t::VERSION);
  expect_upgraded<coopdyn::output_v4_t>(p, 4);
  expect_upgraded<coopdyn::output_v3_t>(p, 3);
  expect_upgraded<coopdyn::output_v2_t>(p, 2);
  expect_upgraded<coopdyn::output_v1_t>(p, 1);
}

// loop_stats_t by the same rule: each older layout (its fingerprint, the 8 bytes of each field added
// after it cut from the end) reads with exactly those fields marked missing and 0; the current one
// with none.
TEST(OutputFields, StatsLayoutsMarkTheFieldsTheyLack) {
  io::StatsFrame s;
  s.tick = 50;
  s.outputs_dropped = 13;
  for (int k = 0; k < 4; ++k) s.limit_ticks[k] = 20 + k;
  io::StatsEncoder enc;
  std::vector<uint8_t> b(static_cast<size_t>(enc.max_size()));
  const int n = enc.encode(s, b.data(), static_cast<int>(b.size()));
  ASSERT_GT(n, 8);
  io::StatsFrame back;
  ASSERT_TRUE(io::decode_stats(b.data(), n, &back));
  EXPECT_EQ(back.missing, 0u);
  EXPECT_EQ(back.outputs_dropped, 13);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(back.limit_ticks[k], 20 + k);
  struct Layout {
    uint64_t hash;
    int version;
  };
  const std::vector<Layout> layouts = {
#define COOPDYN_STATS_LAYOUT(hash, version) {hash, version},
#include "service/io/codec/stats_fields.def"
  };
  ASSERT_EQ(layouts.size(), 4u);
  for (const Layout& l : layouts) {
    uint64_t lacks = 0;
    int fields = 0, after = 0;
#define COOPDYN_STATS_FIELD(lcm, frame, put, since) \
  if ((since) > l.version) lacks |= uint64_t{1} << fields, ++after; \
  ++fields;
#include "service/io/codec/stats_fields.def"
    std::vector<uint8_t> old(b.begin(), b.begin() + (n - 8 * after));
    for (int i = 0; i < 8; ++i) old[static_cast<size_t>(i)] = static_cast<uint8_t>(l.hash >> (56 - 8 * i));
    ASSERT_TRUE(io::decode_stats(old.data(), static_cast<int>(old.size()), &back)) << l.version;
    EXPECT_EQ(back.tick, 50);
    EXPECT_EQ(back.missing, lacks) << l.version;
    EXPECT_EQ(back.outputs_dropped, l.version >= 4 ? 13 : 0) << l.version;
    for (int k = 0; k < 4; ++k) EXPECT_EQ(back.limit_ticks[k], 0) << l.version;
  }
}

TEST(OutputFields, MessagesMdTableIsTheFieldList) {
  const std::string path = std::string(COOPDYN_SOURCE_DIR) + "/docs/reference/messages.md";
  std::ifstream f(path);
  ASSERT_TRUE(f) << path;
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string md = ss.str();
  const std::string begin = "<!-- output_t fields: generated from service/io/codec/output_fields.def -->\n";
  const std::string end = "<!-- end of output_t fields -->";
  const size_t a = md.find(begin), b = md.find(end);
  ASSERT_TRUE(a != std::string::npos && b != std::string::npos && a < b) << path << ": no output_t field markers";
  EXPECT_EQ(md.substr(a + begin.size(), b - a - begin.size()), io::output_fields_markdown())
      << path << ": replace the output_t table by the text expected above";
}

}  // namespace
}  // namespace coopdyn::testing
