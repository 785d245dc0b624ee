// Cost of the MAC check of an authenticated input (service/io/transport/auth.h, Verifier::check: HMAC-SHA256
// through libsodium over the channel's name and the message's bytes, the key's part precomputed),
// per message, for the three input types at the default scene's sizes (two_puma_load: a torque
// command, a measured state, a pause control and a reset_to_state control), and what rejecting junk
// costs: a forged MAC (the whole HMAC), an unsigned message and garbage after the fingerprint (the
// field walk only). The receive process runs this check on every complete message of an input channel
// when authentication is on: its rate bounds the flood it can reject (bench/README.md, "Commands
// under a flood of junk").
#include <benchmark/benchmark.h>

#include <random>
#include <string>
#include <vector>

#include "service/io/transport/auth.h"
#include "service/io/codec/codec.h"
#include "service/scene/scene.h"

using namespace coopdyn;

namespace {

const io::AuthKey& key() {
  static const io::AuthKey k = io::parse_key("00112233445566778899aabbccddeeff0123456789abcdef0f1e2d3c4b5a6978", "bench key");
  return k;
}
const System& puma() {
  static const System s = load_scene(std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/two_puma_load.yaml");
  return s;
}
std::vector<double> stdvec(const Eigen::VectorXd& x) { return std::vector<double>(x.data(), x.data() + x.size()); }

enum Kind { kCommand, kState, kControl, kControlReset };
enum Case { kSigned, kForged, kUnsigned, kGarbage };

struct Input {
  std::vector<uint8_t> bytes;
  const char* channel;
  io::MessageType type;
};

Input make(Kind k, Case c) {
  const System& sys = puma();
  Input in;
  switch (k) {
    case kCommand:
      in = {io::encode_torque_command(1700000000000000, 7, {}, std::vector<double>(static_cast<size_t>(sys.model.nv()), 0.5)),
            "COOPDYN_COMMAND", io::MessageType::kTorqueCommand};
      break;
    case kState:
      in = {io::encode_measured_state(1700000000000000, 7, {}, stdvec(sys.q0), {}, stdvec(sys.v0),
                                      std::vector<double>(static_cast<size_t>(sys.model.nv()), 0.5)),
            "COOPDYN_STATE", io::MessageType::kMeasuredState};
      break;
    case kControl:
      in = {io::encode_control(1700000000000000, 7, io::ControlAction::kPause), "COOPDYN_CONTROL", io::MessageType::kControl};
      break;
    case kControlReset:
      in = {io::encode_control(1700000000000000, 7, io::ControlAction::kResetToState, stdvec(sys.q0), stdvec(sys.v0)),
            "COOPDYN_CONTROL", io::MessageType::kControl};
      break;
  }
  if (c == kSigned || c == kForged) io::sign(in.bytes, in.channel, key(), in.type);
  if (c == kForged) in.bytes[in.bytes.size() - 1] ^= 1;
  if (c == kGarbage) {
    std::mt19937 rng(3);
    for (size_t i = 8; i < in.bytes.size(); ++i) in.bytes[i] = static_cast<uint8_t>(rng());
  }
  return in;
}

void BM_Verify(benchmark::State& state) {
  const Kind k = static_cast<Kind>(state.range(0));
  const Case c = static_cast<Case>(state.range(1));
  const Input in = make(k, c);
  const io::Verifier v(key(), in.channel, in.type);
  const io::Reject expect = c == kSigned     ? io::Reject::kNone
                            : c == kForged   ? io::Reject::kBadMac
                            : c == kUnsigned ? io::Reject::kUnauthenticated
                                             : io::Reject::kDecode;
  const io::Reject got = v.check(in.bytes.data(), static_cast<int>(in.bytes.size()));
  if (got != expect) {
    state.SkipWithError("the check's result is not the expected one");
    return;
  }
  for (auto _ : state) {
    io::Reject r = v.check(in.bytes.data(), static_cast<int>(in.bytes.size()));
    benchmark::DoNotOptimize(r);
  }
  static const char* kinds[] = {"torque_command_t", "measured_state_t", "control_t pause", "control_t reset_to_state"};
  static const char* cases[] = {"signed", "forged MAC", "unsigned", "garbage"};
  state.SetLabel(std::string(kinds[k]) + ", " + cases[c]);
  state.counters["bytes"] = static_cast<double>(in.bytes.size());
  state.counters["per_s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Verify)->ArgsProduct({{kCommand, kState, kControl, kControlReset}, {kSigned, kForged, kUnsigned, kGarbage}});

}  // namespace

BENCHMARK_MAIN();
