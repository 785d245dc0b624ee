// coopdyn send: publish torque commands (coopdyn.torque_command_t) at a fixed rate from a profile.
// With --measure-latency it also subscribes to the daemon's output and reports, per command, the
// time from its publish to the first output that used it (input_seq == its seq).
#include <time.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <mutex>
#include <random>
#include <stdexcept>
#include <thread>
#include <unordered_map>

#include "clients/cli/cli.h"
#include "clients/cli/key_file.h"
#include "clients/csv/step_csv.h"
#include "service/io/codec/codec.h"
#include "service/io/transport/lcm_bus.h"
#include "clients/cli/lcm_route.h"
#include "service/scene/scene.h"

namespace coopdyn::cli {

namespace {
std::atomic<bool> g_send_stop{false};
void on_sigint(int) { g_send_stop = true; }

// A `coopdyn sim --out` CSV read as measured states: columns t, q:NAME..., v:NAME..., tau:NAME...
struct StateTable {
  std::vector<std::string> q_names, v_names;
  std::vector<double> t;
  std::vector<std::vector<double>> q, v, tau;
};
bool read_states(const std::string& path, StateTable* st, std::string* err) {
  std::ifstream f(path);
  if (!f) {
    *err = "cannot open '" + path + "'";
    return false;
  }
  auto split = [](const std::string& line) {
    std::vector<std::string> out;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) out.push_back(cell);
    return out;
  };
  std::string line;
  CsvHeader hdr;  // the per-step CSV's comment and units lines, then its header (clients/csv/step_csv.h)
  if (!read_step_csv_header(f, path, &hdr, err)) return false;
  const auto& head = hdr.names;
  std::vector<int> qc, vc, tc;
  int tcol = -1;
  for (size_t i = 0; i < head.size(); ++i) {
    const std::string& h = head[i];
    if (h == "t") tcol = static_cast<int>(i);
    else if (h.rfind("q:", 0) == 0) st->q_names.push_back(h.substr(2)), qc.push_back(static_cast<int>(i));
    else if (h.rfind("v:", 0) == 0) st->v_names.push_back(h.substr(2)), vc.push_back(static_cast<int>(i));
    else if (h.rfind("tau:", 0) == 0) tc.push_back(static_cast<int>(i));
  }
  if (tcol < 0 || qc.empty() || vc.empty() || tc.size() != vc.size()) {
    *err = path + ":" + std::to_string(hdr.line_no) + ": expected the columns of 'coopdyn sim --out': t, q:..., v:..., tau:...";
    return false;
  }
  int ln = hdr.line_no;
  while (std::getline(f, line)) {
    ++ln;
    const auto cells = split(line);
    if (cells.size() != head.size()) continue;  // a trailing partial line
    try {
      auto pick = [&](const std::vector<int>& cols) {
        std::vector<double> x;
        for (int c : cols) x.push_back(std::stod(cells[c]));
        return x;
      };
      st->t.push_back(std::stod(cells[tcol]));
      st->q.push_back(pick(qc));
      st->v.push_back(pick(vc));
      st->tau.push_back(pick(tc));
    } catch (const std::exception&) {
      *err = path + ":" + std::to_string(ln) + ": not a number";
      return false;
    }
  }
  if (st->t.empty()) {
    *err = path + ": no rows";
    return false;
  }
  return true;
}

double pct(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t i = static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(i, v.size() - 1)];
}

// What is published: commands from the --torque and --steer profiles, or the rows of a sim CSV
// (--states), with the scratch vectors the commands are computed in.
struct Source {
  bool replay = false;
  TorqueProfile torque, steer;
  std::vector<int> steer_locks, steer_dofs;  // lock spec and velocity index of each steered joint
  std::vector<std::string> target_names;
  // the joints the commands name: those of --torque (the others take the daemon's safe torque), or
  // none (every joint, the unnamed ones 0: --others zero, or --steer alone)
  std::vector<int> torque_dofs;
  std::vector<std::string> torque_names;
  std::vector<double> torque_values;
  StateTable states;
  Eigen::VectorXd tau, target_v;
  std::vector<double> targets;
};

// --joints-only: what a robot's drivers publish, the joints only; the daemon fits the floating
// bodies' pose and twist (the load's) from them (state_fit.h). Prints the reason and returns 2 when
// the scene cannot be fitted.
int drop_fitted_coordinates(const System& sys, StateTable* states) {
  const StateFitPlan plan = plan_state_fit(sys);
  if (!plan.q_fittable || !plan.v_fittable) {
    std::fprintf(stderr, "coopdyn send: --joints-only: %s\n", !plan.q_fittable ? plan.why_not_q : plan.why_not_v);
    return 2;
  }
  auto is_fit = [](const std::vector<int>& idx, const std::vector<std::string>& names, const std::string& n) {
    for (int i : idx)
      if (names[i] == n) return true;
    return false;
  };
  std::vector<size_t> keep_q, keep_v;
  for (size_t i = 0; i < states->q_names.size(); ++i)
    if (!is_fit(plan.fit_q, sys.model.q_names, states->q_names[i])) keep_q.push_back(i);
  for (size_t i = 0; i < states->v_names.size(); ++i)
    if (!is_fit(plan.fit_v, sys.model.v_names, states->v_names[i])) keep_v.push_back(i);
  auto pick = [](const std::vector<size_t>& keep, auto& row) {
    std::remove_reference_t<decltype(row)> out;
    for (size_t i : keep) out.push_back(row[i]);
    row = out;
  };
  pick(keep_q, states->q_names);
  pick(keep_v, states->v_names);
  for (auto& r : states->q) pick(keep_q, r);
  for (auto& r : states->v) pick(keep_v, r);
  for (auto& r : states->tau) pick(keep_v, r);
  return 0;
}

// The profiles, or with --states the CSV (whose time span is the default duration); prints the
// reason and returns the exit status on a bad one.
int load_source(const SendArgs& a, const System& sys, Source* src, double* duration) {
  src->replay = a.states.has_value();
  if (const int rc = load_cli_profile(a, "send", sys, &src->torque)) return rc;
  if (const int rc = load_cli_targets(a, "send", sys, &src->steer, &src->steer_locks)) return rc;
  src->steer_dofs = src->steer.dofs();
  for (int d : src->steer_dofs) src->target_names.push_back(sys.model.v_names[static_cast<size_t>(d)]);
  src->targets.resize(src->target_names.size());
  if (a.others == "hold") src->torque_dofs = src->torque.dofs();
  for (int d : src->torque_dofs) src->torque_names.push_back(sys.model.v_names[static_cast<size_t>(d)]);
  src->tau.resize(sys.model.nv());
  src->target_v.resize(sys.model.nv());
  if (!src->replay) return 0;
  std::string err;
  if (!read_states(*a.states, &src->states, &err)) {
    std::fprintf(stderr, "coopdyn send: %s\n", err.c_str());
    return 2;
  }
  if (!a.duration) *duration = src->states.t.back() - src->states.t.front();
  return a.joints_only ? drop_fitted_coordinates(sys, &src->states) : 0;
}

// The message at profile (or replay) time t.
std::vector<uint8_t> message_at(Source& src, double t, long long seq) {
  if (src.replay) {
    // the last row at or before t (rows are piecewise constant in time), the times compared to
    // within a millionth of the rows' mean spacing: message i at the CSV's own rate then sends row i
    // exactly, although its time i / rate may round just below the row's t_i = i h (at 1 kHz 282 of
    // 2001 rows went twice and as many never, with an exact comparison)
    const StateTable& st = src.states;
    const double spacing = st.t.size() > 1 ? (st.t.back() - st.t.front()) / static_cast<double>(st.t.size() - 1) : 0.0;
    const double tr = st.t.front() + t + 1e-6 * spacing;
    size_t r = static_cast<size_t>(std::upper_bound(st.t.begin(), st.t.end(), tr) - st.t.begin());
    r = r == 0 ? 0 : r - 1;
    return io::encode_measured_state(io::wall_us(), seq, st.q_names, st.q[r], st.v_names, st.v[r], st.tau[r]);
  }
  src.torque.eval(t, src.tau);
  src.steer.eval(t, src.target_v);
  for (size_t k = 0; k < src.targets.size(); ++k) src.targets[k] = src.target_v[src.steer_dofs[k]];
  if (src.torque_dofs.empty())
    src.torque_values.assign(src.tau.data(), src.tau.data() + src.tau.size());
  else {
    src.torque_values.clear();
    for (int d : src.torque_dofs) src.torque_values.push_back(src.tau[d]);
  }
  return io::encode_torque_command(io::wall_us(), seq, src.torque_names, src.torque_values, src.target_names,
                                   src.targets);
}

// What the daemon did with the messages, read back from its outputs and its loop_stats_t (every
// member under mu): the seqs its outputs used, the latency of each, and its counters at the first and
// the last stats message.
struct Readback {
  std::mutex mu;
  std::unordered_map<long long, long long> sent_ns;  // publish time per seq (monotonic ns), until its first output
  std::vector<double> latency_us;
  long long last_seen = -1;
  std::unordered_map<long long, char> used;
  long long outputs = 0;
  io::StatsFrame stats_first, stats_last;
  long long stats_n = 0;
  bool have_baseline = false;

  void on_output(const void* d, int n, long long recv_ns) {
    io::DecodedOutput o;
    if (!io::decode_output(d, n, &o)) return;
    std::lock_guard<std::mutex> lk(mu);
    ++outputs;
    if (o.input_seq < 0) return;
    used[o.input_seq] = 1;
    if (o.input_seq == last_seen) return;
    last_seen = o.input_seq;
    auto it = sent_ns.find(o.input_seq);
    if (it != sent_ns.end()) {
      latency_us.push_back(static_cast<double>(recv_ns - it->second) * 1e-3);
      sent_ns.erase(it);
    }
  }
  void on_stats(const void* d, int n) {
    io::StatsFrame st;
    if (!io::decode_stats(d, n, &st)) return;
    std::lock_guard<std::mutex> lk(mu);
    if (stats_n++ == 0) stats_first = st;
    stats_last = st;
  }
  // polls done() under the lock every 10 ms, up to 10 s; done(k) gets the number of polls so far
  template <class Done>
  void wait_until(Done done) {
    for (int k = 0; k < 1000; ++k) {
      {
        std::lock_guard<std::mutex> lk(mu);
        if (done(k)) return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  // The daemon's counters before the first command (loop_stats_t comes every stats_period_s, 1 s by
  // default, longer in wall time when a loaded machine runs the loop below its rate): what it
  // rejected of this run is its later counters less these, whatever it rejected before the run.
  // Waits up to 10 s for one while the daemon's outputs come, and only 1 s when no daemon answers.
  void take_baseline() {
    wait_until([&](int k) { return stats_n > 0 || (k >= 100 && outputs == 0); });
    std::lock_guard<std::mutex> lk(mu);
    if (stats_n > 0) {
      stats_first = stats_last;  // the baseline: the newest before the first command
      stats_n = 1;
      have_baseline = true;
    }
  }
  // And a stats message after the last command: loop_stats_t comes every stats_period_s of ticks
  // (1 s by default, longer in wall time when a loaded machine runs the loop below its rate), so
  // wait up to 10 s for one, but not at all when no daemon answered; with a baseline from before
  // the run, one whose counters have received every command sent.
  void wait_for_final_stats(long long sent) {
    long long n0, outs;
    {
      std::lock_guard<std::mutex> lk(mu);
      n0 = stats_n;
      outs = outputs;
    }
    if (outs > 0)
      wait_until([&](int) { return stats_n > n0 && (!have_baseline || stats_last.received - stats_first.received >= sent); });
  }
};

// The messages: n_msgs at `rate` from now, until SIGINT or SIGTERM; returns how many were sent.
long long publish_all(const SendArgs& a, io::LcmBus& bus, const std::string& channel, Source& src, long long n_msgs,
                      Readback& rb, const std::optional<io::AuthKey>& key) {
  const long long period = static_cast<long long>(1e9 / a.rate + 0.5);
  long long next = io::monotonic_ns();
  long long sent = 0;
  // With --measure-latency each command leaves at a random phase within a millisecond, so the
  // latency samples the daemon's tick phase uniformly instead of one fixed offset between the two
  // clocks' schedules.
  std::mt19937_64 rng(static_cast<unsigned long long>(next));
  std::uniform_int_distribution<long long> phase(0, 999999);
  for (long long i = 0; i < n_msgs && !g_send_stop; ++i) {
    const long long at = next + (a.measure_latency ? phase(rng) : 0);
    timespec ts{static_cast<time_t>(at / 1000000000LL), static_cast<long>(at % 1000000000LL)};
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
    const double t = a.t0 + static_cast<double>(i) / a.rate;
    const long long seq = a.seq + i;
    std::vector<uint8_t> bytes = message_at(src, t, seq);
    sign_if(bytes, key, channel, src.replay ? io::MessageType::kMeasuredState : io::MessageType::kTorqueCommand);
    if (a.measure_latency) {
      std::lock_guard<std::mutex> lk(rb.mu);
      rb.sent_ns[seq] = io::monotonic_ns();
    }
    if (bus.publish(channel.c_str(), bytes.data(), static_cast<int>(bytes.size())) != 0)
      std::fprintf(stderr, "coopdyn send: publish failed (seq %lld)\n", seq);
    ++sent;
    next += period;
  }
  return sent;
}

// The daemon's counters as the judgement of unused commands reads them: deltas over the run when two
// stats messages came, else its totals; -1 with no stats at all.
long long counter(const Readback& rb, int64_t io::StatsFrame::*field) {
  return rb.stats_n >= 2 ? rb.stats_last.*field - rb.stats_first.*field : rb.stats_n == 1 ? rb.stats_last.*field : -1;
}

// Why the daemon left commands unused, from its counters, on stderr (after "the daemon used N of M").
void explain_unused(const Readback& rb) {
  if (rb.stats_n >= 2)
    std::fprintf(stderr, "; its counters over the run: rejected +%lld (malformed, wrong names or count, NaN, over "
                 "tau_limit, stale or future utime, not authenticated), out of order +%lld (seq not above the last accepted)",
                 static_cast<long long>(rb.stats_last.rejected - rb.stats_first.rejected),
                 static_cast<long long>(rb.stats_last.out_of_order - rb.stats_first.out_of_order));
  else if (rb.stats_n == 1)
    std::fprintf(stderr, "; its counters since it started: rejected %lld (malformed, wrong names or count, NaN, "
                 "over tau_limit, stale or future utime, not authenticated), out of order %lld (seq not above the last accepted)",
                 static_cast<long long>(rb.stats_last.rejected), static_cast<long long>(rb.stats_last.out_of_order));
  // by reason (loop_stats_t rejected_by_reason): over the run, or since start with one stats message
  std::string by;
  for (int k = 1; k < io::kRejectKinds; ++k) {
    const long long n = rb.stats_n >= 2 ? rb.stats_last.rejected_by_reason[k] - rb.stats_first.rejected_by_reason[k]
                        : rb.stats_n == 1 ? rb.stats_last.rejected_by_reason[k] : 0;
    if (n > 0) by += (by.empty() ? "" : ", ") + std::string(io::reject_name(static_cast<io::Reject>(k))) + " " + std::to_string(n);
  }
  if (!by.empty()) std::fprintf(stderr, "; rejected by reason: %s", by.c_str());
  std::fprintf(stderr, "; the daemon's log names each reason\n");
}

// The exit status from what the daemon did with the `sent` messages: 1 when it never answered, 4
// when it left commands unused and rejected some, else 0.
int judge_readback(const SendArgs& a, Readback& rb, const std::string& url, long long sent) {
  std::lock_guard<std::mutex> lk(rb.mu);
  if (rb.outputs == 0) {
    std::fprintf(stderr, "coopdyn send: no output from the daemon on %s (%s): is it running, on this URL? "
                 "(--no-check skips this)\n", a.output_channel.c_str(), url.c_str());
    return 1;
  }
  long long n_used = 0;
  for (long long i = 0; i < sent; ++i) n_used += rb.used.count(a.seq + i) ? 1 : 0;
  const long long unused = sent - n_used;
  // The daemon applies the newest command each tick, so a command can be overtaken by the next one
  // within a tick (at high rates, or when a loaded machine delays a tick): unused commands are an
  // error only when the daemon's counters show rejections, or, with no stats at all, when most of
  // them went unused.
  const long long refused = rb.stats_n == 0 ? -1 : counter(rb, &io::StatsFrame::rejected) + counter(rb, &io::StatsFrame::out_of_order);
  if (unused > std::max(2LL, sent / 20) && (refused > 0 || (refused < 0 && 2 * unused > sent))) {
    std::fprintf(stderr, "coopdyn send: the daemon used %lld of %lld %s (seq %lld..%lld)", n_used, sent,
                 a.states ? "measured states" : "commands", a.seq, a.seq + sent - 1);
    explain_unused(rb);
    return 4;
  }
  return 0;
}

// The summary line and, with --measure-latency, the latency percentiles, on stdout.
void print_summary(const SendArgs& a, const std::string& channel, long long sent, Readback& rb) {
  if (!a.quiet)
    std::printf("coopdyn send: %lld %s on %s at %g Hz (seq %lld..%lld)\n", sent, a.states ? "measured states" : "commands",
                channel.c_str(), a.rate, a.seq, a.seq + sent - 1);
  if (a.measure_latency) {
    std::lock_guard<std::mutex> lk(rb.mu);
    const std::vector<double>& l = rb.latency_us;
    std::printf(
        "coopdyn send: end-to-end latency (command publish -> first output using it) over %zu commands: "
        "min %.1f us, p50 %.1f us, p99 %.1f us, p99.9 %.1f us, max %.1f us\n",
        l.size(), pct(l, 0.0), pct(l, 0.5), pct(l, 0.99), pct(l, 0.999), pct(l, 1.0));
  }
}

// The option combinations and ranges the parser does not check; prints the reason and returns 2.
int check_send_args(const SendArgs& a, double duration) {
  if (a.torque.empty() && a.steer.empty() && !a.states) {
    std::fprintf(stderr,
                 "coopdyn send: --scene FILE and at least one --torque or --steer PROFILE (commands) or --states FILE.csv "
                 "(measured states, estimate mode) are required\n");
    return 2;
  }
  if (a.states && !a.steer.empty()) {
    std::fprintf(stderr, "coopdyn send: --steer goes with commands, not with --states\n");
    return 2;
  }
  if (a.others != "hold" && a.others != "zero") {
    std::fprintf(stderr, "coopdyn send: --others must be hold or zero, got '%s'\n", a.others.c_str());
    return 2;
  }
  if (!(a.rate > 0 && a.rate <= 10000) || !(duration >= 0) || !std::isfinite(duration)) {
    std::fprintf(stderr, "coopdyn send: need 0 < rate <= 10000 and duration >= 0\n");
    return 2;
  }
  return 0;
}

}  // namespace

void register_send(Cli& cli) {
  auto [c, a] = cli.add("send", cmd_send);
  scene_options(c, a, true);
  profile_options(c, a, "torque commands; repeat to combine (see below)",
                  "lock targets in the commands (a steer angle, rad); repeat to combine (see below)");
  value(c, "--others", a.others, "MODE",
        "hold or zero: the joints --torque does not name: `hold` leaves them to the daemon's safe torque (its policy, `hold` by "
        "default: they hold the system and brake it), `zero` commands 0 N*m (or N) on them (with --steer alone "
        "every joint is commanded 0)",
        Default::kShown);
  value(c, "--states", a.states, "SIM.csv", "replay the states of a coopdyn sim CSV as measured_state_t instead");
  flag(c, "--joints-only", a.joints_only, "with --states: leave out the floating bodies' coordinates (the daemon fits them)");
  number(c, "--rate", a.rate, "HZ", "messages per second, (0, 10000]", Default::kShown);
  number(c, "--duration", a.duration, "S", "how long to send (default: 2; with --states the file's time span)");
  number(c, "--t0", a.t0, "S", "profile (or replay) time of the first message", Default::kShown);
  number(c, "--seq", a.seq, "N", "seq of the first message (then +1 per message)", Default::kShown);
  value(c, "--lcm-url", a.lcm_url, "URL", "LCM URL", Default::kShown);
  value(c, "--channel", a.channel, "C", "channel to publish on (default: COOPDYN_COMMAND; with --states COOPDYN_STATE)");
  value(c, "--output-channel", a.output_channel, "C", "the daemon's output channel (read back, latency)", Default::kShown);
  value(c, "--output-url", a.output_url, "URL",
        "LCM URL of the daemon's outputs and stats, when its inputs come on another (its lcm_url_in; default: --lcm-url)");
  value(c, "--stats-channel", a.stats_channel, "C", "the daemon's loop_stats_t channel (read back)", Default::kShown);
  flag(c, "--measure-latency", a.measure_latency, "report the time from each command's publish to the first output that used it");
  flag(c, "--busy-poll", a.busy_poll,
       "read the outputs back by polling LCM without sleeping (a whole CPU), as a real-time controller polls each "
       "cycle: the latency without this client's own wake-up");
  flag(c, "--no-check", a.no_check, "do not read back what the daemon did");
  flag(c, "--quiet", a.quiet, "no summary line");
  value(c, "--key-file", a.key_file, "FILE", kKeyFileHelp);
}

int cmd_send(const SendArgs& a) {
  double duration = a.duration.value_or(2);
  if (const int rc = check_send_args(a, duration)) return rc;
  System sys;
  if (const int rc = load_cli_scene(a, "send", &sys)) return rc;
  Source src;
  if (const int rc = load_source(a, sys, &src, &duration)) return rc;
  std::optional<io::AuthKey> key;
  if (const int rc = load_cli_key(a.key_file, "send", &key)) return rc;
  const std::string& url = a.lcm_url;
  const std::string channel = a.channel.value_or(src.replay ? "COOPDYN_STATE" : "COOPDYN_COMMAND");
  warn_loopback_multicast("send", url, a.output_url.value_or(""));
  std::unique_ptr<io::LcmBus> bus, out_bus;
  try {
    bus = std::make_unique<io::LcmBus>(url);
    if (a.output_url && *a.output_url != url) out_bus = std::make_unique<io::LcmBus>(*a.output_url);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "coopdyn send: %s\n", e.what());
    return 1;
  }
  // Read back what the daemon did (unless --no-check) and the latency (--measure-latency).
  const bool check = !a.no_check, read_back = a.measure_latency || check;
  Readback rb;
  io::LcmBus& rx_bus = out_bus ? *out_bus : *bus;  // where the outputs are read back
  if (read_back) {
    rx_bus.subscribe(a.output_channel, [&rb](const void* d, int n, long long recv_ns) { rb.on_output(d, n, recv_ns); });
    rx_bus.subscribe(a.stats_channel, [&rb](const void* d, int n, long long) { rb.on_stats(d, n); });
    rx_bus.start(a.busy_poll);
  }
  std::signal(SIGINT, on_sigint);
  std::signal(SIGTERM, on_sigint);
  if (check) rb.take_baseline();
  const long long n_msgs = static_cast<long long>(std::floor(duration * a.rate + 1e-9)) + 1;
  const long long sent = publish_all(a, *bus, channel, src, n_msgs, rb, key);
  if (read_back) std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the last outputs
  if (check) rb.wait_for_final_stats(sent);
  rx_bus.stop();
  print_summary(a, channel, sent, rb);
  if (!check || sent == 0) return 0;
  return judge_readback(a, rb, url, sent);
}

}  // namespace coopdyn::cli
