// Cost of decoding a measured state (two_puma_load) with the allocation-free decoder the loop's
// thread runs on arrival (service/io/codec/direct_decoder.h) against the generated one (StateDecoder,
// codec.h), per message: in the scene's order, by name, joints only (the load fitted later), and
// full and joints-only states alternating (names of other lengths: where the generated decoder
// reallocates its strings).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <string>
#include <vector>

#include "service/dynamics/state_fit.h"
#include "service/io/codec/codec.h"
#include "service/io/codec/direct_decoder.h"
#include "service/scene/scene.h"

using namespace coopdyn;

namespace {

const System& puma() {
  static const System s = load_scene(std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/two_puma_load.yaml");
  return s;
}
std::vector<double> stdvec(const Eigen::VectorXd& x) { return std::vector<double>(x.data(), x.data() + x.size()); }

enum Form { kOrdered, kNamed, kJointsOnly, kAlternating };

std::vector<std::vector<uint8_t>> messages(Form f) {
  const System& sys = puma();
  const std::vector<double> q = stdvec(sys.q0), v(static_cast<size_t>(sys.model.nv()), 0.01);
  const int64_t t = 1718000000000000LL;
  const StateFitPlan plan = plan_state_fit(sys);
  std::vector<std::string> jq, jv;
  std::vector<double> qj, vj;
  for (int i = 0; i < sys.model.nq(); ++i)
    if (std::find(plan.fit_q.begin(), plan.fit_q.end(), i) == plan.fit_q.end()) jq.push_back(sys.model.q_names[i]), qj.push_back(q[i]);
  for (int i = 0; i < sys.model.nv(); ++i)
    if (std::find(plan.fit_v.begin(), plan.fit_v.end(), i) == plan.fit_v.end()) jv.push_back(sys.model.v_names[i]), vj.push_back(0.01);
  const auto ordered = io::encode_measured_state(t, 1, {}, q, {}, v, v);
  const auto named = io::encode_measured_state(t, 1, sys.model.q_names, q, sys.model.v_names, v, v);
  const auto joints = io::encode_measured_state(t, 1, jq, qj, jv, vj, vj);
  switch (f) {
    case kOrdered: return {ordered};
    case kNamed: return {named};
    case kJointsOnly: return {joints};
    case kAlternating: return {named, joints};
  }
  return {};
}

template <class Decoder>
void BM_DecodeState(benchmark::State& st) {
  const System& sys = puma();
  Decoder dec(sys);
  io::StateSlot slot;
  slot.q = Eigen::VectorXd::Zero(sys.model.nq());
  slot.v = slot.tau = Eigen::VectorXd::Zero(sys.model.nv());
  slot.has_wrench.assign(sys.wrenches.outputs.size(), 0);
  slot.wrench.assign(sys.wrenches.outputs.size(), {});
  const auto msgs = messages(static_cast<Form>(st.range(0)));
  size_t k = 0;
  for (auto _ : st) {
    const auto& m = msgs[k++ % msgs.size()];
    benchmark::DoNotOptimize(dec.decode(m.data(), static_cast<int>(m.size()), slot));
    benchmark::ClobberMemory();
  }
  st.SetLabel(st.range(0) == kOrdered ? "in order" : st.range(0) == kNamed ? "named" : st.range(0) == kJointsOnly ? "joints only" : "named / joints only");
}

}  // namespace

BENCHMARK_TEMPLATE(BM_DecodeState, io::DirectStateDecoder)->DenseRange(kOrdered, kAlternating);
BENCHMARK_TEMPLATE(BM_DecodeState, io::StateDecoder)->DenseRange(kOrdered, kAlternating);
BENCHMARK_MAIN();
