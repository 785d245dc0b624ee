// coopdyn view's page of a daemon log: coopdynd runs over udpm on a private loopback port, this
// process receives its messages (a real LCM round trip) and writes them with LCM's event-log API
// as lcm-logger would; the page's frames, stresses, indeterminate forces and contact report are
// the messages'.
#include <signal.h>

#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "service/io/codec/codec.h"
#include "tests/support/child_process.h"
#include "tests/clients/view/view_test_util.h"

namespace coopdyn {
namespace {
using namespace view_test;

struct Received {
  std::string channel;
  std::vector<uint8_t> data;
  int64_t utime;
};

// Runs coopdynd on `scene` at `rate` Hz until this process has received `outputs` of its output
// messages and one of its stats messages (waiting up to 60 s for them, however slowly the machine
// runs it), stops it with SIGTERM, and returns every message it published on the output and stats
// channels, in arrival order; empty when LCM cannot start (no multicast route).
std::vector<Received> record_daemon(const std::string& url, const std::string& scene, int rate, size_t outputs,
                                    std::string* daemon_err, const std::string& config = "",
                                    const std::function<void()>& during = {}) {
  auto bus = daemon_test::try_bus(url);
  if (!bus) return {};
  std::mutex mu;
  std::condition_variable cv;
  std::vector<Received> got;
  size_t n_out = 0, n_stats = 0;
  for (const char* ch : {"COOPDYN_OUTPUT", "COOPDYN_STATS"})
    bus->subscribe(ch, [&, ch](const void* d, int n, long long) {
      std::lock_guard<std::mutex> lk(mu);
      got.push_back({ch, std::vector<uint8_t>(static_cast<const uint8_t*>(d), static_cast<const uint8_t*>(d) + n),
                     io::wall_us()});
      ++(got.back().channel == "COOPDYN_OUTPUT" ? n_out : n_stats);
      cv.notify_all();
    });
  bus->start();
  const std::string cfg = daemon_test::tmp_path("view_cfg.yaml");
  std::ofstream(cfg) << "stats_period_s: 0.1\n" << config;
  daemon_test::Child d({COOPDYND_PATH, "--scene", scene_file(scene), "--config", cfg, "--lcm-url", url, "--rate",
                        std::to_string(rate)},
                       "view_daemon");
  {
    std::unique_lock<std::mutex> lk(mu);
    EXPECT_TRUE(cv.wait_for(lk, std::chrono::seconds(60), [&] { return n_out >= outputs && n_stats >= 1; }))
        << "in 60 s: " << n_out << " of " << outputs << " outputs, " << n_stats << " stats messages received";
  }
  if (during) {  // then as many outputs again after it
    during();
    std::unique_lock<std::mutex> lk(mu);
    const size_t want = n_out + outputs;
    EXPECT_TRUE(cv.wait_for(lk, std::chrono::seconds(60), [&] { return n_out >= want; }))
        << "in 60 s after: " << n_out << " of " << want << " outputs";
  }
  d.signal(SIGTERM);
  EXPECT_EQ(d.wait(), 0) << daemon_test::slurp(d.err);
  *daemon_err = daemon_test::slurp(d.err);
  std::remove(cfg.c_str());
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // (what is still on its way, for the log)
  bus->stop();
  std::lock_guard<std::mutex> lk(mu);
  return got;
}

void write_log(const std::string& path, const std::vector<Received>& msgs) {
  lcm::LogFile log(path, "w");
  ASSERT_TRUE(log.good()) << path;
  int64_t n = 0;
  for (const Received& r : msgs) {
    lcm::LogEvent ev{};
    ev.eventnum = n++;
    ev.timestamp = r.utime;
    ev.channel = r.channel;
    ev.datalen = static_cast<int32_t>(r.data.size());
    ev.data = const_cast<uint8_t*>(r.data.data());
    ASSERT_EQ(log.writeEvent(&ev), 0);
  }
}

// The page of a recorded daemon log has one frame per output_t message: the message's simulation
// time and status, and its wrenches turned into world axes with the message's own configuration
// (this process's forward kinematics). It loads in Chromium without a JavaScript error.
TEST(ViewLog, FramesAreTheDaemonsMessages) {
  TempDir dir("log");
  std::string derr;
  const std::vector<Received> msgs = record_daemon(private_udpm_url(1), "two_puma_load", 200, 100, &derr);
  if (msgs.empty()) GTEST_SKIP() << "LCM over udpm unavailable (multicast route? ip route add 224.0.0.0/4 dev lo)";
  std::vector<io::DecodedOutput> outs;
  for (const Received& r : msgs) {
    if (r.channel != "COOPDYN_OUTPUT") continue;
    io::DecodedOutput o;
    ASSERT_TRUE(io::decode_output(r.data.data(), static_cast<int>(r.data.size()), &o));
    outs.push_back(std::move(o));
  }
  ASSERT_GE(outs.size(), 100u) << derr;  // (record_daemon waited for them)
  const std::string log = dir / "run.lcmlog";
  write_log(log, msgs);

  std::string err;
  ASSERT_EQ(run("'" + kBin + "' view --scene '" + scene_file("two_puma_load") + "' --log '" + log + "' --out '" +
                    dir / "v.html" + "'",
                dir / "e", &err),
            0)
      << err;
  const std::string page = slurp(dir / "v.html");
  const std::vector<double> t = numbers(between(page, "\"t\":[", "]"));
  ASSERT_EQ(t.size(), outs.size());
  const std::string all_w = between(page, "\"wrench\":[[", "]],\"pj\"");
  std::vector<std::vector<double>> w;
  for (size_t at = 0, next; at < all_w.size(); at = next + 3) {
    next = all_w.find("],[", at);
    if (next == std::string::npos) next = all_w.size();
    w.push_back(numbers(all_w.substr(at, next - at)));
  }
  ASSERT_EQ(w.size(), outs.size());
  const System sys = load_scene(scene_file("two_puma_load"));
  std::vector<int> drawn;
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k)
    if (sys.wrenches.outputs[k].kind != WrenchKind::kJoint) drawn.push_back(static_cast<int>(k));
  Data data(sys.model);
  int checked = 0;
  double fmax = 0;
  for (size_t i = 0; i < outs.size(); ++i) {
    const io::DecodedOutput& o = outs[i];
    EXPECT_NEAR(t[i], o.sim_time, 1e-8 * (1 + o.sim_time)) << "frame " << i;
    ASSERT_EQ(w[i].size(), 9 * drawn.size());
    Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(o.q.data(), static_cast<Eigen::Index>(o.q.size()));
    normalize_configuration(sys.model, q);
    forward_kinematics(sys.model, data, q, Eigen::VectorXd::Zero(sys.model.nv()));
    for (size_t j = 0; j < drawn.size(); ++j) {
      const Transform X = wrench_frame_pose(sys, data, drawn[j]);
      const Vec3 f = X.R * Vec3(o.wrench[drawn[j]][3], o.wrench[drawn[j]][4], o.wrench[drawn[j]][5]);
      const Vec3 m = X.R * Vec3(o.wrench[drawn[j]][0], o.wrench[drawn[j]][1], o.wrench[drawn[j]][2]);
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(w[i][9 * j + k], X.p[k], 1e-5 * (1 + X.p.norm())) << o.wrench_names[drawn[j]];
        EXPECT_NEAR(w[i][9 * j + 3 + k], f[k], 1e-5 * (1 + f.norm())) << o.wrench_names[drawn[j]] << " frame " << i;
        EXPECT_NEAR(w[i][9 * j + 6 + k], m[k], 1e-5 * (1 + m.norm())) << o.wrench_names[drawn[j]] << " frame " << i;
      }
      fmax = std::max(fmax, f.norm());
      ++checked;
    }
  }
  EXPECT_GT(fmax, 10) << "the wrenches compared are not all zero";
  EXPECT_EQ(checked, static_cast<int>(outs.size() * drawn.size()));
  EXPECT_NE(page.find("\"source\":\"" + log + "\""), std::string::npos);

  // bad input: another scene, another channel, a missing log, a file that is not a log
  EXPECT_EQ(run("'" + kBin + "' view --scene '" + scene_file("four_bar") + "' --log '" + log + "' --out '" + dir / "x.html" + "'",
                dir / "e", &err),
            1);
  EXPECT_NE(err.find(log + ": output_t 1 on channel 'COOPDYN_OUTPUT'"), std::string::npos) << err;
  EXPECT_NE(err.find("scene 'four_bar'"), std::string::npos) << err;
  EXPECT_NE(err.find("another scene"), std::string::npos) << err;
  EXPECT_EQ(run("'" + kBin + "' view --scene '" + scene_file("two_puma_load") + "' --log '" + log +
                    "' --channel COOPDYN_STATS --out '" + dir / "x.html" + "'",
                dir / "e", &err),
            1);
  EXPECT_NE(err.find(log + ": no coopdyn.output_t messages on channel 'COOPDYN_STATS'"), std::string::npos) << err;
  EXPECT_NE(err.find("COOPDYN_OUTPUT (coopdyn.output_t, " + std::to_string(outs.size()) + ")"), std::string::npos) << err;
  EXPECT_NE(err.find("COOPDYN_STATS (coopdyn.loop_stats_t"), std::string::npos) << err;
  EXPECT_EQ(run("'" + kBin + "' view --scene '" + scene_file("two_puma_load") + "' --log '" + dir / "none.lcmlog" +
                    "' --out '" + dir / "x.html" + "'",
                dir / "e", &err),
            1);
  EXPECT_NE(err.find("cannot read '" + dir / "none.lcmlog" + "' as an LCM log"), std::string::npos) << err;
  EXPECT_EQ(run("'" + kBin + "' view --scene '" + scene_file("two_puma_load") + "' --log '" + scene_file("two_puma_load") +
                    "' --out '" + dir / "x.html" + "'",
                dir / "e", &err),
            1);
  EXPECT_NE(err.find(scene_file("two_puma_load") + ": no coopdyn.output_t messages"), std::string::npos) << err;
  std::ofstream(dir / "broken.yaml") << "name: broken\nrobots: [\n";
  EXPECT_EQ(run("'" + kBin + "' view --scene '" + dir / "broken.yaml" + "' --log '" + log + "' --out '" + dir / "x.html" + "'",
                dir / "e", &err),
            1);
  EXPECT_NE(err.find(dir / "broken.yaml"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "x.html"));

  const std::string chromium = find_chromium();
  if (chromium.empty() || !fs::exists(kThree)) {
    std::printf("[  SKIPPED ] the browser part: Chromium or three.js not installed\n");
    return;
  }
  DevTools browser(chromium, dir / "v");
  std::string why;
  const PageState p = page_state(browser.load("file://" + dir / "v.html" + "#frame=20&paused=1", &why));
  ASSERT_EQ(why, "");
  EXPECT_EQ(p.title, "coopdyn view: two_puma_load") << "a JavaScript error, or the page did not finish";
  EXPECT_TRUE(p.ready);
  EXPECT_EQ(p.frame, 20);
  EXPECT_NEAR(p.t, outs[20].sim_time, 1e-8);
}

// Decoded outputs of a recorded run, and its log.
std::vector<io::DecodedOutput> outputs_of(const std::vector<Received>& msgs) {
  std::vector<io::DecodedOutput> outs;
  for (const Received& r : msgs) {
    io::DecodedOutput o;
    if (r.channel == "COOPDYN_OUTPUT" && io::decode_output(r.data.data(), static_cast<int>(r.data.size()), &o))
      outs.push_back(std::move(o));
  }
  return outs;
}

// Stresses as colours: each pseudo-joint of the four-bar is a ball at the joint whose colour is the
// page's map of the message's stress (grey at 0, pure red / blue at the largest positive / negative
// stress of that joint over the run), computed here from the messages; the ball is where this
// process's forward kinematics of the message's q projects.
TEST(ViewLog, StressColoursOnThePseudoJoints) {
  REQUIRE_BROWSER();
  TempDir dir("stress");
  std::string derr;
  // no torque (not the default hold): the four-bar falls and its stresses change
  const std::vector<Received> msgs =
      record_daemon(private_udpm_url(4), "four_bar", 200, 100, &derr, "safe_torque:\n  policy: zero\n");
  if (msgs.empty()) GTEST_SKIP() << "LCM over udpm unavailable (multicast route? ip route add 224.0.0.0/4 dev lo)";
  const std::vector<io::DecodedOutput> outs = outputs_of(msgs);
  ASSERT_GE(outs.size(), 100u) << derr;
  write_log(dir / "run.lcmlog", msgs);
  std::string err;
  ASSERT_EQ(run("'" + kBin + "' view --scene '" + scene_file("four_bar") + "' --log '" + dir / "run.lcmlog" + "' --out '" +
                    dir / "v.html" + "'",
                dir / "e", &err),
            0)
      << err;
  const System sys = load_scene(scene_file("four_bar"));
  const Model& m = sys.model;
  ASSERT_EQ(m.pseudo_dofs.size(), 2u);
  std::vector<double> smax(m.pseudo_dofs.size(), 0.0);
  std::vector<std::vector<double>> st(outs.size());
  for (size_t i = 0; i < outs.size(); ++i)
    for (size_t k = 0; k < m.pseudo_dofs.size(); ++k) {
      const auto& names = outs[i].stress_names;
      const auto it = std::find(names.begin(), names.end(), m.v_names[m.pseudo_dofs[k]]);
      ASSERT_NE(it, names.end()) << m.v_names[m.pseudo_dofs[k]];
      st[i].push_back(outs[i].stress[static_cast<size_t>(it - names.begin())]);
      smax[k] = std::max(smax[k], std::abs(st[i][k]));
    }
  auto expected = [&](double s, double mx) {  // the page's map
    const double r = mx > 0 ? std::min(1.0, std::abs(s) / mx) : 0;
    return s >= 0 ? Vec3(128 + 127 * r, 128 - 128 * r, 128 - 128 * r) : Vec3(128 - 128 * r, 128 - 128 * r, 128 + 127 * r);
  };
  // the frames of the smallest and the largest |stress| of the first pseudo-joint
  size_t frames[2] = {0, 0};
  for (size_t i = 0; i < outs.size(); ++i) {
    if (std::abs(st[i][0]) < std::abs(st[frames[0]][0])) frames[0] = i;
    if (std::abs(st[i][0]) > std::abs(st[frames[1]][0])) frames[1] = i;
  }
  std::vector<Vec3> seen;
  DevTools browser(chromium, dir / "v");
  for (size_t i : frames) {
    const Browse b = browse(browser, dir / "v.html", "frame=" + std::to_string(i) + "&paused=1", true);
    ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
    const PageState p = page_state(b.dom);
    ASSERT_EQ(p.title, "coopdyn view: four_bar");
    ASSERT_EQ(p.frame, static_cast<int>(i));
    Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(outs[i].q.data(), static_cast<Eigen::Index>(outs[i].q.size()));
    Data data(m);
    forward_kinematics(m, data, q, Eigen::VectorXd::Zero(m.nv()));
    for (size_t k = 0; k < m.pseudo_dofs.size(); ++k) {
      const Vec3 x = data.X_WB[m.dof_body[m.pseudo_dofs[k]]].p;
      const Eigen::Vector2d px = project(p, x);
      const Vec3 want = expected(st[i][k], smax[k]);
      Vec3 got = Vec3::Zero();  // the mean of 3 x 3 pixels at the projection
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const unsigned char* c = b.shot.at(static_cast<int>(px.x()) + dx, static_cast<int>(px.y()) + dy);
          got += Vec3(c[0], c[1], c[2]) / 9;
        }
      EXPECT_LT((got - want).cwiseAbs().maxCoeff(), 12)
          << m.v_names[m.pseudo_dofs[k]] << " at frame " << i << ": stress " << st[i][k] << " of max " << smax[k]
          << ", expected colour " << want.transpose() << ", got " << got.transpose() << " at " << px.transpose();
      seen.push_back(want);
    }
  }
  // the map told the frames apart (else the check above could not tell a stress from a constant)
  EXPECT_GT((seen[0] - seen[2]).cwiseAbs().maxCoeff() + (seen[1] - seen[3]).cwiseAbs().maxCoeff(), 40)
      << "the stresses barely changed over the run";
}

// Indeterminate components highlighted: on the two-wheel vehicle (a rigid axle, over-constrained)
// a wheel's contact force with components the physics does not determine is drawn orange, not
// magenta, where its projection says; the status shows the free directions.
TEST(ViewLog, IndeterminateForceIsHighlighted) {
  REQUIRE_BROWSER();
  TempDir dir("indet");
  std::string derr;
  const std::vector<Received> msgs = record_daemon(private_udpm_url(5), "two_wheel_vehicle", 200, 60, &derr);
  if (msgs.empty()) GTEST_SKIP() << "LCM over udpm unavailable (multicast route? ip route add 224.0.0.0/4 dev lo)";
  const std::vector<io::DecodedOutput> outs = outputs_of(msgs);
  ASSERT_GE(outs.size(), 60u) << derr;
  write_log(dir / "run.lcmlog", msgs);
  std::string err;
  ASSERT_EQ(run("'" + kBin + "' view --scene '" + scene_file("two_wheel_vehicle") + "' --log '" + dir / "run.lcmlog" +
                    "' --out '" + dir / "v.html" + "'",
                dir / "e", &err),
            0)
      << err;
  const System sys = load_scene(scene_file("two_wheel_vehicle"));
  // a frame and a drawn wrench with an indeterminate force component and a force long enough to see
  const size_t i = outs.size() / 2;
  const io::DecodedOutput& o = outs[i];
  int pick = -1;
  double fbest = 0;
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k) {
    if (sys.wrenches.outputs[k].kind == WrenchKind::kJoint || !(o.indeterminate_mask[k] & 0x38)) continue;
    const double f = Vec3(o.wrench[k][3], o.wrench[k][4], o.wrench[k][5]).norm();
    if (f > fbest) fbest = f, pick = static_cast<int>(k);
  }
  ASSERT_GE(pick, 0) << "no indeterminate force in the vehicle's output (status " << o.status << ")";
  ASSERT_FALSE(o.free_class.empty());
  const std::string name = sys.wrenches.outputs[static_cast<size_t>(pick)].name;
  DevTools browser(chromium, dir / "v");
  const Browse b = browse(browser, dir / "v.html", "frame=" + std::to_string(i) + "&paused=1&wrench=" + name, true);
  ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
  const PageState p = page_state(b.dom);
  ASSERT_EQ(p.title, "coopdyn view: two_wheel_vehicle");
  ASSERT_EQ(p.frame, static_cast<int>(i));
  const std::string status = between(b.dom, "<span id=\"status\" class=\"indeterminate\">", "</span>");
  EXPECT_EQ(status.rfind("indeterminate (free: ", 0), 0u) << b.dom.substr(b.dom.find("id=\"status\""), 120);
  Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(o.q.data(), static_cast<Eigen::Index>(o.q.size()));
  Data data(sys.model);
  forward_kinematics(sys.model, data, q, Eigen::VectorXd::Zero(sys.model.nv()));
  const Transform X = wrench_frame_pose(sys, data, pick);
  const Vec3 f = X.R * Vec3(o.wrench[pick][3], o.wrench[pick][4], o.wrench[pick][5]);
  const Eigen::Vector2d po = project(p, X.p), tip = project(p, X.p + f / p.force_scale);
  expect_arrow_at(b.shot, p, po, tip, name + " (indeterminate) at frame " + std::to_string(i), is_indet_force_colour);
  const int magenta = count_in_canvas(b.shot, p, is_force_colour);
  EXPECT_EQ(magenta, 0) << "an indeterminate force drawn in the determinate colour";
}

// From a daemon log: each frame's contact report is the message's (output_t contact_*, the same
// doubles), by name.
TEST(ViewLog, ContactReportIsTheMessages) {
  TempDir dir("logcontacts");
  std::string derr;
  const std::vector<Received> msgs = record_daemon(private_udpm_url(5), "four_wheel_car", 200, 60, &derr);
  if (msgs.empty()) GTEST_SKIP() << "LCM over udpm unavailable (multicast route? ip route add 224.0.0.0/4 dev lo)";
  const std::vector<io::DecodedOutput> outs = outputs_of(msgs);
  ASSERT_GE(outs.size(), 60u) << derr;
  write_log(dir / "run.lcmlog", msgs);
  std::string err;
  ASSERT_EQ(run("'" + kBin + "' view --scene '" + scene_file("four_wheel_car") + "' --log '" + dir / "run.lcmlog" +
                    "' --out '" + dir / "v.html" + "'",
                dir / "e", &err),
            0)
      << err;
  const std::string page = slurp(dir / "v.html");
  const std::vector<std::string> names = {"fl", "fr", "rl", "rr"};
  for (size_t k = 0; k < names.size(); ++k)
    EXPECT_NE(page.find("{\"name\":\"" + names[k] + "\",\"mu\":0.84999999999999998"), std::string::npos) << names[k];
  auto frames_of = [&](const std::string& key) {
    std::vector<std::vector<double>> out;
    const std::string all = between(page, "\"" + key + "\":[[", "]]");
    for (size_t at = 0, next; at < all.size(); at = next + 3) {
      next = all.find("],[", at);
      if (next == std::string::npos) next = all.size();
      out.push_back(numbers(all.substr(at, next - at)));
    }
    return out;
  };
  const auto cu = frames_of("contact_u"), cs = frames_of("contact_state");
  ASSERT_EQ(cu.size(), outs.size());
  ASSERT_EQ(cs.size(), outs.size());
  double umax = 0;
  for (size_t i = 0; i < outs.size(); ++i) {
    const io::DecodedOutput& o = outs[i];
    ASSERT_EQ(cu[i].size(), 2 * names.size()) << "frame " << i;
    for (size_t k = 0; k < names.size(); ++k) {
      const size_t j = static_cast<size_t>(std::find(o.contact_names.begin(), o.contact_names.end(), names[k]) - o.contact_names.begin());
      ASSERT_LT(j, o.contact_names.size()) << names[k];
      EXPECT_EQ(cu[i][2 * k], o.contact_utilisation[j]) << names[k] << " frame " << i;
      EXPECT_EQ(cu[i][2 * k + 1], o.contact_friction_needed[j]) << names[k] << " frame " << i;
      EXPECT_EQ(cs[i][k], o.contact_state[j]) << names[k] << " frame " << i;
      umax = std::max(umax, o.contact_utilisation[j]);
    }
  }
  std::printf("largest utilisation of the car held at rest: %.3g\n", umax);
}

// The numbers of a JSON array's text, NaN for null.
std::vector<double> numbers_or_null(const std::string& s) {
  std::vector<double> out;
  for (size_t at = 0; at < s.size();) {
    size_t end = s.find(',', at);
    if (end == std::string::npos) end = s.size();
    const std::string cell = s.substr(at, end - at);
    out.push_back(cell == "null" ? NAN : std::stod(cell));
    at = end + 1;
  }
  return out;
}

// Frames of a page's per-frame key: frame i's array.
std::vector<std::string> frame_arrays(const std::string& page, const std::string& key) {
  std::vector<std::string> out;
  const std::string all = between(page, "\"" + key + "\":[[", "]]");
  for (size_t at = 0, next; at < all.size(); at = next + 3) {
    next = all.find("],[", at);
    if (next == std::string::npos) next = all.size();
    out.push_back(all.substr(at, next - at));
  }
  return out;
}

// An estimate-mode log whose states expire: before the first state (no state: the outputs' q is
// no state, with a free body not even a configuration), while `coopdyn send --states` replays a simulated run, and after
// the last one expired. `coopdyn view --log` shows every output: an error output in the last valid
// pose (the scene's initial one before any), greyed, its reason on the status line, no arrows, and
// a gap in the page's plot (null in the plotted series, in Chromium) where its numbers are zeros.
TEST(ViewLog, EstimateLogWithExpiredStatesRenders) {
  TempDir dir("estimate");
  ASSERT_EQ(sim("two_puma_load", 0.2, 0.005, dir / "sim.csv", dir / "e"), 0);
  const std::string url = private_udpm_url(6);
  std::string derr;
  const std::vector<Received> msgs = record_daemon(url, "two_puma_load", 200, 40, &derr, "mode: estimate\n", [&] {
    daemon_test::Child s({kBin, "send", "--scene", scene_file("two_puma_load"), "--lcm-url", url, "--states",
                          dir / "sim.csv", "--rate", "200"},
                         "view_send");
    s.wait();  // (its exit status: whether the daemon rejected a state on a loaded machine; not this test's)
  });
  if (msgs.empty()) GTEST_SKIP() << "LCM over udpm unavailable (multicast route? ip route add 224.0.0.0/4 dev lo)";
  const std::vector<io::DecodedOutput> outs = outputs_of(msgs);
  ASSERT_GE(outs.size(), 80u) << derr;
  // the log has each kind: no state yet, a valid estimate, a stale state
  const auto reason_of = [](const io::DecodedOutput& o) { return std::string(io::reason_key(o.reason)); };
  size_t first_ok = outs.size(), last_ok = 0, stale_after = 0;
  for (size_t i = 0; i < outs.size(); ++i) {
    if (outs[i].status != static_cast<int>(Status::kError)) {
      first_ok = std::min(first_ok, i), last_ok = i;
    } else if (reason_of(outs[i]) == "state_stale" && i > last_ok && first_ok < i) {
      stale_after = stale_after ? stale_after : i;
    }
  }
  ASSERT_LT(first_ok, outs.size()) << "no output of a state";
  ASSERT_GT(first_ok, 0u);
  EXPECT_EQ(reason_of(outs[0]), "no_state");
  ASSERT_GT(stale_after, last_ok) << "no expired state after the replay";
  write_log(dir / "est.lcmlog", msgs);

  std::string err;
  ASSERT_EQ(run("'" + kBin + "' view --scene '" + scene_file("two_puma_load") + "' --log '" + dir / "est.lcmlog" +
                    "' --out '" + dir / "v.html" + "' --max-frames 100000",
                dir / "e", &err),
            0)
      << err;
  const std::string page = slurp(dir / "v.html");
  const std::vector<std::string> poses = frame_arrays(page, "shape_pose"), wrenches = frame_arrays(page, "wrench");
  ASSERT_EQ(poses.size(), outs.size());
  const std::string notes = between(page, "\"note\":[", "]");
  const std::string statuses = "," + between(page, "\"status\":[", "]") + ",";
  size_t at = 0;
  for (size_t i = 0; i < outs.size(); ++i) {
    const bool error = outs[i].status == static_cast<int>(Status::kError);
    // the page's status: the message's
    const std::string want = std::string(",\"") + status_name(static_cast<Status>(outs[i].status)) + "\",";
    EXPECT_EQ(statuses.compare(at, want.size(), want), 0) << "frame " << i;
    at = statuses.find(',', at + 1);
    if (!error) continue;
    const std::vector<double> ww = numbers(wrenches[i]);
    for (size_t k = 0; k < ww.size(); k += 9)
      for (int j = 3; j < 9; ++j) EXPECT_EQ(ww[k + j], 0.0) << "an arrow in error frame " << i;
    if (i > last_ok) EXPECT_EQ(poses[i], poses[last_ok]) << "frame " << i << ": not the last valid pose";
    if (i < first_ok) EXPECT_EQ(poses[i], poses[0]) << "frame " << i;
  }
  char held[64];
  std::snprintf(held, sizeof held, "state_stale; the pose of t = %.3f s held", outs[last_ok].sim_time);
  EXPECT_NE(notes.find(held), std::string::npos) << notes.substr(0, 400);
  EXPECT_NE(notes.find("no_state; no pose yet: the scene's initial pose shown"), std::string::npos)
      << notes.substr(0, 400);

  REQUIRE_BROWSER();
  DevTools browser(chromium, dir / "v");
  const size_t shown = stale_after;
  const Browse b =
      browse(browser, dir / "v.html", "frame=" + std::to_string(shown) + "&paused=1&wrench=arm1.ee&plotdata=1", true);
  ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
  const PageState p = page_state(b.dom);
  ASSERT_EQ(p.title, "coopdyn view: two_puma_load") << "a JavaScript error, or the page did not finish";
  ASSERT_EQ(p.frame, static_cast<int>(shown));
  const std::string status = between(b.dom, "<span id=\"status\" class=\"error\">", "</span>");
  EXPECT_EQ(status, std::string("error: ") + held) << b.dom.substr(b.dom.find("id=\"status\""), 160);
  // the plotted series: the message's numbers where it has them, null (a gap) in every error frame
  std::vector<std::vector<double>> series;
  const std::string values = between(b.dom, "\"values\":[[", "]]}");
  for (size_t at = 0, next; at < values.size(); at = next + 3) {
    next = values.find("],[", at);
    if (next == std::string::npos) next = values.size();
    series.push_back(numbers_or_null(values.substr(at, next - at)));
  }
  ASSERT_EQ(series.size(), 6u);
  size_t ee = 0;
  while (outs[0].wrench_names[ee] != "arm1.ee") ++ee;
  for (int j = 0; j < 6; ++j) {
    ASSERT_EQ(series[static_cast<size_t>(j)].size(), outs.size());
    for (size_t i = 0; i < outs.size(); ++i) {
      const double v = series[static_cast<size_t>(j)][i];
      if (outs[i].status == static_cast<int>(Status::kError)) EXPECT_TRUE(std::isnan(v)) << "frame " << i << ": " << v;
      else EXPECT_EQ(v, outs[i].wrench[ee][static_cast<size_t>(j)]) << "frame " << i;
    }
  }
}

}  // namespace
}  // namespace coopdyn
