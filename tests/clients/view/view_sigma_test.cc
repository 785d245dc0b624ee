// coopdyn view's uncertainty bands: a scene that declares noise gives each wrench a sigma (its
// per-step CSV's NAME.sigma_* columns, output_t wrench_sigma), and the page draws, at the tip of each
// arrow, the ellipsoid of +-sigma along the report frame's axes in the arrow's scale; the friction
// bound (output_t wrench_bound) as a box. In headless Chromium the ellipsoid's half-axes, read back
// from the mesh in the scene, are sigma / scale; without noise there is none.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "service/dynamics/wrench_sigma.h"
#include "service/io/codec.h"
#include "tests/clients/view/view_test_util.h"

namespace coopdyn {
namespace {
using namespace view_test;

const char kNoise[] = "\nnoise: {tau: 0.2, joints: {arm1.q2: 1.5}}\n";

// two_puma_load with declared torque noise, written into `dir` (its robot file by absolute path).
std::string noisy_scene(const TempDir& dir) {
  std::string text = slurp(scene_file("two_puma_load"));
  const std::string from = "file: ../robots/", to = "file: " + kSrc + "/config/robots/";
  for (size_t at = 0; (at = text.find(from, at)) != std::string::npos; at += to.size()) text.replace(at, from.size(), to);
  const std::string path = dir / "noisy.yaml";
  std::ofstream(path) << text << kNoise;
  return path;
}

// {"centre":[x,y,z],"half":[a,b,c]} of `key` in the band entry of wrench `name` in the probe.
struct Drawn {
  bool found = false;
  Vec3 centre = Vec3::Constant(NAN), half = Vec3::Constant(NAN);
};
Drawn drawn(const std::string& probe, const std::string& name, const std::string& key) {
  Drawn d;
  const size_t at = probe.find("{\"name\":\"" + name + "\",\"sigma_f\"");
  if (at == std::string::npos) return d;
  const std::string entry = probe.substr(at, probe.find('}', probe.find("\"bound_m\"", at)) - at + 1);
  const size_t k = entry.find("\"" + key + "\":{");
  if (k == std::string::npos) return d;
  d.found = true;
  d.centre = vec_after(entry.substr(k), "\"centre\":[");
  d.half = vec_after(entry.substr(k), "\"half\":[");
  return d;
}

// The force's +-sigma ellipsoid of arm1's end-effector wrench sits at the arrow's tip with half-axes
// sigma_f / force_scale (N per metre), the moment's at the moment arrow's tip with sigma_m /
// moment_scale: the CSV row's numbers, the arrow's origin and direction from this process's own
// forward kinematics. The legend says so; unticked (&bands=0) nothing is drawn; a scene without
// noise has no band and no legend.
TEST(ViewSigma, BandHalfAxesAreSigmaOverTheArrowScale) {
  REQUIRE_BROWSER();
  TempDir dir("sigma");
  const std::string scene = noisy_scene(dir);
  std::string err;
  ASSERT_EQ(run("'" + kBin + "' sim --scene '" + scene + "' --duration 0.8 --dt 0.005 --out '" + dir / "p.csv" + "'", dir / "sim.err", &err), 0)
      << err;
  ASSERT_EQ(view(scene, dir / "p.csv", dir / "p.html", dir / "e", &err), 0) << err;
  DevTools browser(chromium, dir / "b");
  const Browse b = browse(browser, dir / "p.html", "t=0.7&paused=1&wrench=arm1.ee", false);
  ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
  const PageState p = page_state(b.dom);
  ASSERT_EQ(p.title, "coopdyn view: two_puma_load");
  ASSERT_DOUBLE_EQ(p.t, 0.7);
  EXPECT_NE(b.dom.find("<span id=\"sigmalegend\" style=\"\">"), std::string::npos) << "the legend of the bands is hidden";

  const System sys = load_scene(scene);
  const auto row = csv_row(dir / "p.csv", 0.7);
  ASSERT_FALSE(row.empty());
  const WorldForce wf = world_force(sys, dir / "p.csv", 0.7, "arm1.ee");
  const double moment_scale = num_after(p.probe, "\"moment_scale\":");
  ASSERT_GT(p.force_scale, 0);
  ASSERT_GT(moment_scale, 0);
  const Drawn f = drawn(p.probe, "arm1.ee", "sigma_f"), m = drawn(p.probe, "arm1.ee", "sigma_m");
  ASSERT_TRUE(f.found) << p.probe;
  ASSERT_TRUE(m.found) << p.probe;
  static const char* axis[3] = {"x", "y", "z"};
  for (int j = 0; j < 3; ++j) {
    const double sf = std::stod(row.at(std::string("arm1.ee.sigma_f") + axis[j]));
    const double sm = std::stod(row.at(std::string("arm1.ee.sigma_m") + axis[j]));
    ASSERT_GT(sf, 0) << axis[j];
    EXPECT_NEAR(f.half[j], sf / p.force_scale, 1e-7 * sf / p.force_scale + 1e-12) << "force sigma along " << axis[j];
    EXPECT_NEAR(m.half[j], sm / moment_scale, 1e-7 * sm / moment_scale + 1e-12) << "moment sigma along " << axis[j];
  }
  // at the tips (the page's origins and forces are written to 6 digits)
  const double r = (wf.force / p.force_scale).norm();
  EXPECT_LT((f.centre - (wf.origin + wf.force / p.force_scale)).norm(), 1e-5 * (1 + r)) << f.centre.transpose();
  EXPECT_LT((m.centre - (wf.origin + wf.moment / moment_scale)).norm(), 1e-5 * (1 + r)) << m.centre.transpose();
  // no friction joint: no bound box
  EXPECT_FALSE(drawn(p.probe, "arm1.ee", "bound_f").found);
  EXPECT_NE(p.probe.find("\"bound_f\":null"), std::string::npos) << p.probe;

  const Browse off = browse(browser, dir / "p.html", "t=0.7&paused=1&wrench=arm1.ee&bands=0", false);
  ASSERT_TRUE(off.ok) << off.log.substr(0, 3000);
  EXPECT_NE(page_state(off.dom).probe.find("\"bands\":null"), std::string::npos) << page_state(off.dom).probe;

  // the same run without noise: no sigma column, no band, no legend
  ASSERT_EQ(sim("two_puma_load", 0.8, 0.005, dir / "q.csv", dir / "sim.err"), 0) << slurp(dir / "sim.err");
  ASSERT_EQ(view(scene_file("two_puma_load"), dir / "q.csv", dir / "q.html", dir / "e", &err), 0) << err;
  const Browse plain = browse(browser, dir / "q.html", "t=0.7&paused=1", false);
  ASSERT_TRUE(plain.ok) << plain.log.substr(0, 3000);
  const PageState pp = page_state(plain.dom);
  ASSERT_EQ(pp.title, "coopdyn view: two_puma_load");
  EXPECT_NE(pp.probe.find("\"bands\":null"), std::string::npos) << pp.probe;
  const std::string legend = between(plain.dom, "<span id=\"sigmalegend\" style=\"", "\"");
  EXPECT_TRUE(legend == "display:none" || legend == "display: none;") << "the legend of the bands shows: " << legend;
}

// A daemon log: the page's sigma and bound of each frame are the message's wrench_sigma and
// wrench_bound, the same doubles, by drawn wrench; a message without them (SIGMA_NONE, no friction
// joint at rest) gives none; the report frame's orientation comes with them. The message is encoded as coopdynd does (io::OutputEncoder) and written
// with LCM's event-log API as lcm-logger would.
TEST(ViewSigma, LogFramesCarryTheMessagesSigmaAndBound) {
  TempDir dir("sigma_log");
  const System sys = load_scene(noisy_scene(dir));
  Workspace ws(sys);
  WrenchData wd(sys);
  WrenchSigmaData sd(sys);
  FrictionBoundData fb(sys);
  const Eigen::VectorXd tau = Eigen::VectorXd::Constant(sys.model.nv(), 0.3);
  evaluate(sys, ws, sys.q0, sys.v0, tau);
  compute_wrenches(sys, ws, wd);
  compute_wrench_sigma(sys, ws, sd);
  ASSERT_TRUE(sd.declared);
  for (size_t k = 0; k < fb.bound.size(); ++k)  // a bound to carry (as if friction joints rested)
    for (int c = 0; c < 6; ++c) fb.bound[k][c] = 0.25 * (c + 1) + 0.01 * static_cast<double>(k);
  fb.resting = 2;
  io::OutputEncoder enc(sys);
  std::vector<uint8_t> buf(static_cast<size_t>(enc.max_size()));
  io::OutputFrame fr;
  fr.valid = true;
  fr.q = &sys.q0;
  fr.v = &sys.v0;
  fr.tau = &tau;
  fr.ws = &ws;
  fr.wrenches = &wd;
  std::vector<std::vector<uint8_t>> msgs;
  for (int i = 0; i < 2; ++i) {  // with sigma and bound, then without
    fr.tick = i;
    fr.sim_time = 0.01 * i;
    fr.sigma = i == 0 ? &sd : nullptr;
    fr.bound = i == 0 ? &fb : nullptr;
    const int len = enc.encode(fr, buf.data(), static_cast<int>(buf.size()));
    ASSERT_GT(len, 0);
    msgs.emplace_back(buf.begin(), buf.begin() + len);
  }
  const std::string log = dir / "run.lcmlog";
  std::ofstream(dir / "three.min.js") << "/* stand-in */ var THREE_STAND_IN = 'WebGLRenderer';\n";
  {
    lcm::LogFile lf(log, "w");
    ASSERT_TRUE(lf.good());
    for (size_t i = 0; i < msgs.size(); ++i) {
      lcm::LogEvent ev{};
      ev.eventnum = static_cast<int64_t>(i);
      ev.timestamp = static_cast<int64_t>(i) * 10000;
      ev.channel = "COOPDYN_OUTPUT";
      ev.datalen = static_cast<int32_t>(msgs[i].size());
      ev.data = msgs[i].data();
      ASSERT_EQ(lf.writeEvent(&ev), 0);
    }
  }
  std::string err;
  ASSERT_EQ(run("'" + kBin + "' view --scene '" + dir / "noisy.yaml" + "' --log '" + log + "' --out '" + dir / "v.html" +
                    "' --three-js '" + dir / "three.min.js" + "'",
                dir / "e", &err),
            0)
      << err;
  const std::string page = slurp(dir / "v.html");
  // per frame: [6 per drawn wrench] or [] (the page's "wrench_sigma", "wrench_bound", "wrench_R")
  auto frames = [&](const std::string& key, const std::string& next) {
    const std::string all = between(page, "\"" + key + "\":[[", "]],\"" + next + "\"");
    std::vector<std::vector<double>> out;
    for (size_t at = 0, n; at <= all.size(); at = n + 3) {
      n = all.find("],[", at);
      if (n == std::string::npos) n = all.size();
      out.push_back(numbers(all.substr(at, n - at)));
    }
    return out;
  };
  const auto sg = frames("wrench_sigma", "wrench_bound"), bd = frames("wrench_bound", "wrench_R"), wr = frames("wrench_R", "contact_p");
  std::vector<size_t> drawn_k;
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k)
    if (sys.wrenches.outputs[k].kind != WrenchKind::kJoint) drawn_k.push_back(k);
  ASSERT_FALSE(drawn_k.empty());
  ASSERT_EQ(sg.size(), 2u) << page.substr(0, 200);
  ASSERT_EQ(bd.size(), 2u);
  ASSERT_EQ(wr.size(), 2u);
  ASSERT_EQ(sg[0].size(), 6 * drawn_k.size());
  ASSERT_EQ(bd[0].size(), 6 * drawn_k.size());
  EXPECT_EQ(wr[0].size(), 4 * drawn_k.size());
  for (size_t j = 0; j < drawn_k.size(); ++j)
    for (int c = 0; c < 6; ++c) {
      EXPECT_EQ(sg[0][6 * j + static_cast<size_t>(c)], sd.sigma[drawn_k[j]][c]) << j << " " << c;
      EXPECT_EQ(bd[0][6 * j + static_cast<size_t>(c)], fb.bound[drawn_k[j]][c]) << j << " " << c;
    }
  EXPECT_TRUE(sg[1].empty());
  EXPECT_TRUE(bd[1].empty());
  EXPECT_TRUE(wr[1].empty());
}

}  // namespace
}  // namespace coopdyn
