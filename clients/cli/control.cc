// coopdyn control: send one control_t (reset, reset to a state, pause, resume, clear a fault) and
// wait for the daemon's acknowledgement in its output (control_seq, control_result).
#include <chrono>
#include <cstdio>
#include <mutex>
#include <thread>

#include "clients/cli/cli.h"
#include "clients/cli/key_file.h"
#include "service/io/codec/codec.h"
#include "service/io/transport/lcm_bus.h"
#include "clients/cli/lcm_route.h"
#include "service/scene/scene.h"

namespace coopdyn::cli {

void register_control(Cli& cli) {
  auto [c, a] = cli.add("control", cmd_control);
  value(c, "--action", a.action, "ACTION", "reset, reset_to_state, pause, resume or clear_fault")->required();
  scene_options(c, a, false);
  value(c, "--state", a.state, "FILE.json",
        "reset_to_state: q, v, each a list in the scene's coordinate order or an object by coordinate name (needs --scene)");
  value(c, "--lcm-url", a.lcm_url, "URL", "LCM URL to send on", Default::kShown);
  value(c, "--output-url", a.output_url, "URL", "LCM URL of the daemon's outputs (default: --lcm-url)");
  value(c, "--channel", a.channel, "C", "control channel", Default::kShown);
  value(c, "--output-channel", a.output_channel, "C", "the daemon's output channel (the acknowledgement)", Default::kShown);
  number(c, "--seq", a.seq, "N", "the control's seq (default: the wall clock in microseconds, so that it keeps increasing)");
  flag(c, "--no-wait", a.no_wait, "send and exit without waiting for the acknowledgement");
  number(c, "--timeout", a.timeout, "S", "how long to wait for the acknowledgement (s)", Default::kShown);
  value(c, "--key-file", a.key_file, "FILE", kKeyFileHelp);
}

int cmd_control(const ControlArgs& a) {
  static const std::pair<const char*, io::ControlAction> actions[] = {
      {"reset", io::ControlAction::kReset},   {"reset_to_state", io::ControlAction::kResetToState},
      {"pause", io::ControlAction::kPause},   {"resume", io::ControlAction::kResume},
      {"clear_fault", io::ControlAction::kClearFault}};
  const std::string& name = a.action;
  int found = -1;
  for (int i = 0; i < 5; ++i)
    if (name == actions[i].first) found = i;
  if (found < 0) {
    std::fprintf(stderr, "coopdyn control: --action must be reset, reset_to_state, pause, resume or clear_fault\n");
    return 2;
  }
  const io::ControlAction action = actions[found].second;
  if (!(a.timeout > 0.0 && a.timeout <= 3600.0)) {
    std::fprintf(stderr, "coopdyn control: --timeout must be in (0, 3600] s, got %g\n", a.timeout);
    return 2;
  }
  std::optional<io::AuthKey> key;
  if (const int rc = load_cli_key(a.key_file, "control", &key)) return rc;
  std::vector<double> q, v;
  if (action == io::ControlAction::kResetToState) {
    if (!a.scene || !a.state) {
      std::fprintf(stderr, "coopdyn control: reset_to_state needs --scene FILE and --state FILE.json (q, v)\n");
      return 2;
    }
    System sys;
    if (const int rc = load_cli_scene(a, "control", &sys)) return rc;
    Eigen::VectorXd qs = sys.q0, vs = sys.v0, tau = Eigen::VectorXd::Zero(sys.model.nv());
    if (!read_state(*a.state, sys, qs, vs, tau)) return 1;
    q.assign(qs.data(), qs.data() + qs.size());
    v.assign(vs.data(), vs.data() + vs.size());
  }
  const std::string url = a.lcm_url;
  const std::string out_url = a.output_url.value_or(url);
  const std::string channel = a.channel;
  const std::string out_channel = a.output_channel;
  // seq: the wall clock in us unless given, so that successive invocations keep increasing
  const int64_t seq = a.seq ? *a.seq : io::wall_us();
  warn_loopback_multicast("control", url, out_url);
  try {
    io::LcmBus bus(url);
    std::unique_ptr<io::LcmBus> out_bus;
    std::mutex mu;
    int result = -2;
    bool paused = false;
    const bool wait = !a.no_wait;
    if (wait) {
      io::LcmBus* ob = &bus;
      if (out_url != url) {
        out_bus = std::make_unique<io::LcmBus>(out_url);
        ob = out_bus.get();
      }
      ob->subscribe(out_channel, [&](const void* d, int n, long long) {
        io::DecodedOutput o;
        if (!io::decode_output(d, n, &o) || o.control_seq != seq) return;
        std::lock_guard<std::mutex> lk(mu);
        result = o.control_result;
        paused = o.paused != 0;
      });
      ob->start();
    }
    auto b = io::encode_control(io::wall_us(), seq, action, q, v);
    sign_if(b, key, channel, io::MessageType::kControl);
    bus.publish(channel.c_str(), b.data(), static_cast<int>(b.size()));
    if (!wait) {
      std::printf("coopdyn control: %s sent (seq %lld)\n", name.c_str(), static_cast<long long>(seq));
      return 0;
    }
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                            std::chrono::duration<double>(a.timeout));
    while (std::chrono::steady_clock::now() < end) {
      {
        std::lock_guard<std::mutex> lk(mu);
        if (result != -2) break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    std::lock_guard<std::mutex> lk(mu);
    if (result == -2) {
      std::fprintf(stderr, "coopdyn control: %s (seq %lld): no acknowledgement on %s within %g s (daemon running? "
                   "same URL and channels?)\n", name.c_str(), static_cast<long long>(seq), out_channel.c_str(), a.timeout);
      return 1;
    }
    std::printf("coopdyn control: %s (seq %lld): %s%s\n", name.c_str(), static_cast<long long>(seq),
                io::control_result_name(static_cast<io::ControlResult>(result)), paused ? "; the simulation is paused" : "");
    return result == static_cast<int>(io::ControlResult::kOk) ? 0 : 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "coopdyn control: %s\n", e.what());
    return 1;
  }
}

}  // namespace coopdyn::cli
