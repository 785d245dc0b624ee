// coopdyn track: the reference controller in the loop. It subscribes to the daemon's outputs, and for
// each new one computes the torques of clients/control/cooperative_controller.h (the load along a circle,
// the squeeze between the arms at its set-point) and publishes them as a torque_command_t. The
// newest output always wins: if the controller falls behind, it skips outputs rather than acting
// on old states. Writes one CSV row per command (--out) and prints the tracking summary.
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <mutex>
#include <thread>

#include "clients/cli/cli.h"
#include "clients/cli/key_file.h"
#include "clients/control/cooperative_controller.h"
#include "service/io/codec/codec.h"
#include "service/io/transport/lcm_bus.h"
#include "clients/cli/lcm_route.h"
#include "service/scene/scene.h"

namespace coopdyn::cli {

namespace {
std::atomic<bool> g_track_stop{false};
void on_track_signal(int) { g_track_stop = true; }

// The newest output's bytes, handed from the LCM thread to the control loop: a newer one replaces
// one not yet taken.
struct LatestOutput {
  std::mutex mu;
  std::condition_variable cv;
  std::vector<uint8_t> bytes;
  bool fresh = false;

  void put(const void* d, int n) {
    std::lock_guard<std::mutex> lk(mu);
    bytes.assign(static_cast<const uint8_t*>(d), static_cast<const uint8_t*>(d) + n);
    fresh = true;
    cv.notify_one();
  }
};

// What the summary reports: counts over the run, and the errors after the ramp and its transient.
struct TrackTally {
  long long used = 0, skipped_errors = 0, saturated = 0, n_sync = 0, n_stat = 0;
  double t_last = std::nan(""), max_pos = 0, max_rot = 0, max_sq = 0, sum2 = 0;
  bool daemon_gone = false;  // the outputs stopped before --duration
};

// The CSV of --out with its comment, units and header lines; prints the reason and returns nullptr
// when it cannot be written.
std::FILE* open_track_csv(const std::string& path, const System& sys) {
  std::FILE* csv = std::fopen(path.c_str(), "w");
  if (!csv) {
    std::fprintf(stderr, "coopdyn track: cannot write '%s'\n", path.c_str());
    return nullptr;
  }
  // the naming rules of the per-step CSV (docs/conventions.md): units in a '# units:' line, words for codes
  std::fprintf(csv, "# coopdyn track CSV 1: scene %s, one row per command (docs/conventions.md)\n", sys.name.c_str());
  std::fprintf(csv, "# units: s,m,m,m,m,m,m,m,rad,N,N,N,1,text,1,1\n");
  std::fprintf(csv, "t,ref_x,ref_y,ref_z,x,y,z,position_error,orientation_error,squeeze,squeeze_target,"
                    "squeeze_set,saturated,status,input_seq,in_sync\n");
  return csv;
}

void write_track_row(std::FILE* csv, const CooperativeController& ctl, const TrackOptions& opt, double t, const Vec3& pr,
                     double s, const io::DecodedOutput& o, bool in_sync) {
  const Vec3& p = ctl.load_position();
  std::fprintf(csv, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%d,%s,%lld,%d\n", t, pr.x(),
               pr.y(), pr.z(), p.x(), p.y(), p.z(), ctl.position_error(), ctl.orientation_error(), s,
               ctl.squeeze_target(), opt.squeeze, ctl.saturated() ? 1 : 0,
               o.status >= 0 && o.status <= 2 ? status_name(static_cast<Status>(o.status)) : "unknown",
               static_cast<long long>(o.input_seq), in_sync ? 1 : 0);
}

// The control loop: for each new output the controller's torques, published as a command, until
// --duration of the daemon's time, a signal, or the outputs stop (5 s for the first, then 1 s).
// Returns 0, or 1 when the outputs do not match the scene.
int control_loop(const TrackArgs& a, const System& sys, CooperativeController& ctl, io::LcmBus& bus,
                 LatestOutput& latest, std::FILE* csv, TrackTally* tally, const std::optional<io::AuthKey>& key) {
  const TrackOptions& opt = a.control;
  const long long seq0 = io::wall_us();
  long long seq = seq0;
  double t0 = std::nan("");
  const double settle = opt.ramp + 0.5;  // the summary covers the run after the ramp and its transient
  std::vector<uint8_t> bytes;
  auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (!g_track_stop) {
    {
      std::unique_lock<std::mutex> lk(latest.mu);
      latest.cv.wait_for(lk, std::chrono::milliseconds(100), [&] { return latest.fresh; });
      if (!latest.fresh) {
        if (std::chrono::steady_clock::now() > give_up) {
          tally->daemon_gone = !std::isnan(t0);
          break;
        }
        continue;
      }
      give_up = std::chrono::steady_clock::now() + std::chrono::seconds(1);
      bytes.swap(latest.bytes);
      latest.fresh = false;
    }
    io::DecodedOutput o;
    if (!io::decode_output(bytes.data(), static_cast<int>(bytes.size()), &o)) continue;
    if (o.q.size() != static_cast<size_t>(sys.model.nq()) || o.v.size() != static_cast<size_t>(sys.model.nv())) {
      std::fprintf(stderr, "coopdyn track: the daemon's outputs do not match the scene (%zu q, %zu v; the scene has %d, %d)\n",
                   o.q.size(), o.v.size(), sys.model.nq(), sys.model.nv());
      return 1;
    }
    if (o.status == 2) {  // STATUS_ERROR: no wrenches to regulate from; the daemon holds
      ++tally->skipped_errors;
      continue;
    }
    if (std::isnan(t0)) t0 = o.sim_time;
    const double t = o.sim_time - t0;
    if (t >= a.duration) break;
    const Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(o.q.data(), sys.model.nq());
    const Eigen::VectorXd v = Eigen::Map<const Eigen::VectorXd>(o.v.data(), sys.model.nv());
    const double s = ctl.squeeze(q, o.wrench[ctl.ee_output(0)], o.wrench[ctl.ee_output(1)]);
    // in sync: this output came from a step under one of the controller's last 3 commands (computed
    // from one of the last 3 outputs). A stall of either process breaks it: the daemon then applies
    // an old command or, once the watchdog expires, its safe torque
    const bool own = o.input == 0 && o.input_seq > seq0;  // INPUT_COMMAND, one of ours
    const bool in_sync = own && o.input_seq >= seq - 2;
    tally->n_sync += in_sync ? 1 : 0;
    const double dt = std::isnan(tally->t_last) ? 0.0 : t - tally->t_last;
    tally->t_last = t;
    const Eigen::VectorXd& tau = ctl.compute(t, q, v, own ? s : std::nan(""), dt);
    auto cmd = io::encode_torque_command(io::wall_us(), ++seq, {}, std::vector<double>(tau.data(), tau.data() + tau.size()));
    sign_if(cmd, key, a.channel, io::MessageType::kTorqueCommand);
    bus.publish(a.channel.c_str(), cmd.data(), static_cast<int>(cmd.size()));
    ++tally->used;
    tally->saturated += ctl.saturated() ? 1 : 0;
    Vec3 pr, prd, prdd;
    ctl.reference(t, &pr, &prd, &prdd);
    if (t >= settle) {
      tally->max_pos = std::max(tally->max_pos, ctl.position_error());
      tally->max_rot = std::max(tally->max_rot, ctl.orientation_error());
      tally->max_sq = std::max(tally->max_sq, std::abs(s - opt.squeeze));
      tally->sum2 += ctl.position_error() * ctl.position_error();
      ++tally->n_stat;
    }
    if (csv) write_track_row(csv, ctl, opt, t, pr, s, o, in_sync);
  }
  return 0;
}

void print_track_summary(const TrackArgs& a, const TrackTally& k) {
  const TrackOptions& opt = a.control;
  std::printf("coopdyn track: %lld commands on %s (radius %g m, period %g s, squeeze %g N); %lld error outputs skipped, "
              "%lld commands clamped to tau_limit; %.1f %% of the outputs in sync (stepped under one of its last 3 "
              "commands)\n",
              k.used, a.channel.c_str(), opt.radius, opt.period, opt.squeeze, k.skipped_errors, k.saturated,
              100.0 * static_cast<double>(k.n_sync) / static_cast<double>(k.used));
  if (k.daemon_gone) std::printf("coopdyn track: the daemon's outputs stopped at t = %.3f s (before --duration)\n", k.t_last);
  if (k.n_stat > 0)
    std::printf("coopdyn track: after %.1f s: position error max %.3g m, rms %.3g m; orientation error max %.3g rad; "
                "squeeze max |s - %g| = %.3g N\n",
                opt.ramp + 0.5, k.max_pos, std::sqrt(k.sum2 / static_cast<double>(k.n_stat)), k.max_rot, opt.squeeze,
                k.max_sq);
}
}  // namespace

void register_track(Cli& cli) {
  auto [c, a] = cli.add("track", cmd_track);
  scene_options(c, a, true);
  number(c, "--duration", a.duration, "S", "how long to control", Default::kShown);
  number(c, "--radius", a.control.radius, "M", "radius of the circle (y-z plane), [0, 10)", Default::kShown);
  number(c, "--period", a.control.period, "S", "one lap, > 0.1", Default::kShown);
  number(c, "--squeeze", a.control.squeeze, "N", "internal force set-point between the grasps", Default::kShown);
  value(c, "--out", a.out, "FILE.csv", "one row per command: reference, load, errors, squeeze, in_sync (default: none)");
  value(c, "--lcm-url", a.lcm_url, "URL", "LCM URL to send the commands on", Default::kShown);
  value(c, "--output-url", a.output_url, "URL", "LCM URL of the daemon's outputs (default: --lcm-url)");
  value(c, "--channel", a.channel, "C", "command channel", Default::kShown);
  value(c, "--key-file", a.key_file, "FILE", kKeyFileHelp);
  value(c, "--output-channel", a.output_channel, "C", "the daemon's output channel", Default::kShown);
}

int cmd_track(const TrackArgs& a) {
  const TrackOptions& opt = a.control;
  const double duration = a.duration;
  if (!(duration > 0 && duration < 1e6) || !(opt.radius >= 0 && opt.radius < 10) || !(opt.period > 0.1) ||
      !std::isfinite(opt.squeeze)) {
    std::fprintf(stderr, "coopdyn track: need 0 < duration, 0 <= radius < 10 m, period > 0.1 s, a finite squeeze\n");
    return 2;
  }
  System sys;
  if (const int rc = load_cli_scene(a, "track", &sys)) return rc;
  std::optional<io::AuthKey> key;
  if (const int rc = load_cli_key(a.key_file, "track", &key)) return rc;
  std::unique_ptr<CooperativeController> ctl;
  try {
    ctl = std::make_unique<CooperativeController>(sys, opt);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  const std::string& url = a.lcm_url;
  const std::string out_url = a.output_url.value_or(url);
  std::FILE* csv = nullptr;
  if (a.out && !(csv = open_track_csv(*a.out, sys))) return 1;
  LatestOutput latest;
  warn_loopback_multicast("track", url, out_url);
  try {
    io::LcmBus bus(url);
    std::unique_ptr<io::LcmBus> out_bus;
    io::LcmBus* ob = &bus;
    if (out_url != url) {
      out_bus = std::make_unique<io::LcmBus>(out_url);
      ob = out_bus.get();
    }
    ob->subscribe(a.output_channel, [&latest](const void* d, int n, long long) { latest.put(d, n); });
    ob->start();
    std::signal(SIGINT, on_track_signal);
    std::signal(SIGTERM, on_track_signal);
    TrackTally tally;
    if (const int rc = control_loop(a, sys, *ctl, bus, latest, csv, &tally, key)) return rc;
    ob->stop();
    if (csv) std::fclose(csv);
    if (tally.used == 0) {
      std::fprintf(stderr, "coopdyn track: no usable output from the daemon on %s (%s): is it running (simulate mode), on this URL?\n",
                   a.output_channel.c_str(), out_url.c_str());
      return 1;
    }
    print_track_summary(a, tally);
  } catch (const std::exception& e) {
    if (csv) std::fclose(csv);
    std::fprintf(stderr, "coopdyn track: %s\n", e.what());
    return 1;
  }
  return 0;
}

}  // namespace coopdyn::cli
