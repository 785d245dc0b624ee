// coopdyn view's uncertainty bands: a scene that declares noise gives each wrench a sigma (its
// per-step CSV's NAME.sigma_* columns, output_t wrench_sigma), and the page draws, at the tip of each
// arrow, the ellipsoid of +-sigma along the report frame's axes in the arrow's scale; the friction
// bound (output_t wrench_bound) as a box. In headless Chromium the ellipsoid's half-axes, read back
// from the mesh in the scene, are sigma / scale; without noise there is none.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "service/dynamics/sigma/wrench_sigma.h"
#include "service/io/codec/codec.h"
#include "tests/clients/view/view_test_util.h"

namespace coopdyn {
namespace {
using namespace view_test;

const char kNoise[] = "\nnoise: {tau: 0.2, joints: {arm1.q2: 1.5}}\n";

// The +-sigma band of arm1.ee's component c at time t, interpolated linearly between the CSV rows
// about t (the band's fill is straight between frames): {lo, hi}.
std::pair<double, double> band_at(const coopdyn::testing::CsvText& csv, int c, double t) {
  const auto col = [&](const std::string& name) {
    return static_cast<size_t>(std::find(csv.head.begin(), csv.head.end(), name) - csv.head.begin());
  };
  const size_t iv = col(std::string("arm1.ee.") + kComponents[c]), is = col(std::string("arm1.ee.sigma_") + kComponents[c]);
  for (size_t r = 0; r + 1 < csv.rows.size(); ++r) {
    const double ta = std::stod(csv.rows[r][0]), tb = std::stod(csv.rows[r + 1][0]);
    if (t < ta || t > tb) continue;
    const double a = (t - ta) / (tb - ta);
    const auto edge = [&](double sign) {
      const auto at = [&](size_t row) { return std::stod(csv.rows[row][iv]) + sign * std::stod(csv.rows[row][is]); };
      return (1 - a) * at(r) + a * at(r + 1);
    };
    return {edge(-1), edge(1)};
  }
  return {NAN, NAN};
}

// In the column of the plot two CSS px right of the cursor: every pixel of the axes that the bands
// change (on against off, any channel by more than 8) lies inside one of the three bands of that
// axes there (+-1.5 px of antialiasing), and of the rows inside a band taller than 6 px, at most 3
// per curve that crosses it (drawn over the band, 1.25 px wide: its own curve always) are unchanged.
void expect_bands_in_column(const Image& on, const Image& off, const PageState& p, const std::vector<PlotAxes>& axes,
                            const std::string& csv_path) {
  const coopdyn::testing::CsvText csv = coopdyn::testing::read_csv_text(csv_path);
  const std::string plot = between(p.probe, "\"plot\":{", "\"axes\"");
  const double t0 = num_after(plot, "\"t0\":"), t1 = num_after(plot, "\"t1\":");
  const int x = static_cast<int>(std::lround(num_after(plot, "\"cursor_x\":"))) + 2;
  ASSERT_TRUE(on.w == off.w && on.h == off.h && x > 0 && x < on.w) << x;
  const auto changed = [&](int y) {
    const unsigned char *a = on.at(x, y), *b = off.at(x, y);
    return std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])}) > 8;
  };
  for (int pa = 0; pa < 2; ++pa) {
    const PlotAxes& ax = axes[static_cast<size_t>(pa)];
    const double t = t0 + (x + 0.5 - ax.left) / ax.width * (t1 - t0);
    std::vector<std::pair<double, double>> ys;  // [top, bottom] of each band in the column, px
    std::vector<double> curve;                  // y of each curve there, px
    for (int j = 0; j < 3; ++j) {
      const auto b = band_at(csv, 3 * pa + j, t);
      ASSERT_TRUE(std::isfinite(b.first)) << t;
      ys.emplace_back(ax.y(b.second), ax.y(b.first));
      curve.push_back(ax.y(0.5 * (b.first + b.second)));
    }
    int n_changed = 0;
    for (int y = static_cast<int>(ax.top) + 2; y < static_cast<int>(ax.top + ax.height) - 2; ++y) {
      if (!changed(y)) continue;
      ++n_changed;
      const double yc = y + 0.5;
      EXPECT_TRUE(std::any_of(ys.begin(), ys.end(), [&](const auto& b) { return yc >= b.first - 1.5 && yc <= b.second + 1.5; }))
          << "axes " << pa << ": the bands changed the pixel at (" << x << ", " << y << "), outside every band";
    }
    EXPECT_GT(n_changed, 0) << "axes " << pa << ": no band drawn in column " << x;
    for (int j = 0; j < 3; ++j) {
      if (ys[j].second - ys[j].first <= 6) continue;
      int inside = 0, unchanged = 0;
      for (int y = static_cast<int>(std::ceil(ys[j].first + 1.5)); y + 0.5 <= ys[j].second - 1.5; ++y, ++inside)
        unchanged += !changed(y);
      std::printf("axes %d component %s: band %.1f .. %.1f px in column %d, %d of its %d rows changed\n", pa,
                  kComponents[3 * pa + j], ys[j].first, ys[j].second, x, inside - unchanged, inside);
      const long crossing = std::count_if(curve.begin(), curve.end(), [&](double y) { return y >= ys[j].first && y <= ys[j].second; });
      EXPECT_LE(unchanged, 3 * crossing) << "axes " << pa << " component " << kComponents[3 * pa + j] << ": of " << inside
                              << " rows inside the band, " << unchanged << " unchanged";
    }
  }
}

// The force's +-sigma ellipsoid of arm1's end-effector wrench sits at the arrow's tip with half-axes
// sigma_f / force_scale (N per metre), the moment's at the moment arrow's tip with sigma_m /
// moment_scale: the CSV row's numbers, the arrow's origin and direction from this process's own
// forward kinematics. The legend says so; unticked (&bands=0) nothing is drawn; a scene without
// noise has no band and no legend.
TEST(ViewSigma, BandHalfAxesAreSigmaOverTheArrowScale) {
  REQUIRE_BROWSER();
  TempDir dir("sigma");
  const std::string scene = noisy_scene(dir, kNoise);
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

// A sigma of at least 5 % of its force stays visible however short the arrow: arm1's end-effector
// force under 30 N*m of torque noise, its arrow zoomed down 1000 times (#zoom=0.001), has its
// ellipsoid's largest half-axis at 1 % of the scene's radius, its half-axes in the ratios of the CSV
// row's sigma, at the arrow's tip; at zoom 1 it is sigma over the scale, not floored.
TEST(ViewSigma, EllipsoidVisibleWhenSigmaIsFivePercent) {
  REQUIRE_BROWSER();
  TempDir dir("sigmafloor");
  const std::string scene = noisy_scene(dir, "\nnoise: {tau: 30}\n");
  std::string err;
  ASSERT_EQ(run("'" + kBin + "' sim --scene '" + scene + "' --duration 0.8 --dt 0.005 --out '" + dir / "p.csv" + "'", dir / "sim.err", &err), 0)
      << err;
  ASSERT_EQ(view(scene, dir / "p.csv", dir / "p.html", dir / "e", &err), 0) << err;
  const auto row = csv_row(dir / "p.csv", 0.7);
  ASSERT_FALSE(row.empty());
  static const char* axis[3] = {"x", "y", "z"};
  Vec3 sf, f;
  for (int j = 0; j < 3; ++j) {
    sf[j] = std::stod(row.at(std::string("arm1.ee.sigma_f") + axis[j]));
    f[j] = std::stod(row.at(std::string("arm1.ee.f") + axis[j]));
  }
  ASSERT_GE(sf.maxCoeff(), 0.05 * f.norm()) << "the case this test is about: sigma " << sf.transpose() << " N, |f| " << f.norm();
  DevTools browser(chromium, dir / "b");
  const Browse small = browse(browser, dir / "p.html", "t=0.7&paused=1&wrench=arm1.ee&zoom=0.001", false);
  const Browse plain = browse(browser, dir / "p.html", "t=0.7&paused=1&wrench=arm1.ee", false);
  ASSERT_TRUE(small.ok && plain.ok) << small.log.substr(0, 2000) << plain.log.substr(0, 2000);
  const PageState ps = page_state(small.dom), pp = page_state(plain.dom);
  const double radius = num_after(ps.probe, "\"radius\":");
  ASSERT_GT(radius, 0);
  const Drawn d = drawn(ps.probe, "arm1.ee", "sigma_f");
  ASSERT_TRUE(d.found) << ps.probe;
  EXPECT_NEAR(d.half.maxCoeff(), 0.01 * radius, 1e-9 * radius) << d.half.transpose();
  for (int j = 0; j < 3; ++j)
    EXPECT_NEAR(d.half[j] / d.half.maxCoeff(), sf[j] / sf.maxCoeff(), 1e-6) << "along " << axis[j];
  const std::string at = ps.probe.substr(ps.probe.find("{\"name\":\"arm1.ee\",\"group\""));
  EXPECT_LT((d.centre - vec_after(at, "\"tip_f\":[")).norm(), 1e-9 * radius + 1e-12);
  EXPECT_NE(ps.probe.find("\"floored\":true"), std::string::npos);
  const Drawn d1 = drawn(pp.probe, "arm1.ee", "sigma_f");
  ASSERT_TRUE(d1.found);
  for (int j = 0; j < 3; ++j) EXPECT_NEAR(d1.half[j], sf[j] / pp.force_scale, 1e-7 * sf[j] / pp.force_scale + 1e-12) << axis[j];
  EXPECT_GT(d1.half.maxCoeff(), 0.01 * radius) << "at its own scale the ellipsoid needs no floor";
}

// The plot of arm1.ee with declared torque noise (20 N*m on every joint): about each of its six
// curves, at the cursor's frame, a band from value - sigma to value + sigma of the CSV row (to
// round-off), at the y its axes map those values to; no friction joint, no bound. In the
// screenshot the band is where the probe says: in the column two CSS px right of the cursor, the plot differs
// from the same page with #bands=0 (same axes: the checkbox does not rescale them) only inside the
// three bands there (interpolated between the rows about that column's time), and inside each band
// taller than 6 px on all its rows but those a curve crosses.
TEST(ViewSigma, PlotBandIsTheValuePlusMinusSigma) {
  REQUIRE_BROWSER();
  TempDir dir("sigma_plot");
  const std::string scene = noisy_scene(dir, "\nnoise: {tau: 20}\n");
  std::string err;
  ASSERT_EQ(run("'" + kBin + "' sim --scene '" + scene + "' --duration 0.8 --dt 0.005 --out '" + dir / "p.csv" + "'", dir / "sim.err", &err), 0)
      << err;
  ASSERT_EQ(view(scene, dir / "p.csv", dir / "p.html", dir / "e", &err), 0) << err;
  DevTools browser(chromium, dir / "b");
  const Browse on = browse(browser, dir / "p.html", "t=0.7&paused=1&wrench=arm1.ee", true);
  ASSERT_TRUE(on.ok) << on.log.substr(0, 3000);
  const PageState p = page_state(on.dom);
  ASSERT_EQ(p.title, "coopdyn view: two_puma_load");
  ASSERT_DOUBLE_EQ(p.t, 0.7);
  const std::vector<PlotAxes> axes = plot_axes(p.probe);
  ASSERT_EQ(axes.size(), 2u) << p.probe;
  const auto row = csv_row(dir / "p.csv", 0.7);
  ASSERT_FALSE(row.empty());
  std::vector<PlotBand> bands;
  for (int c = 0; c < 6; ++c) {
    const PlotBand b = plot_band(p.probe, kComponents[c]);
    const PlotAxes& ax = axes[c < 3 ? 0 : 1];
    ASSERT_TRUE(b.found && b.sigma.found) << kComponents[c] << ": " << p.probe;
    const double v = std::stod(row.at(std::string("arm1.ee.") + kComponents[c]));
    const double s = std::stod(row.at(std::string("arm1.ee.sigma_") + kComponents[c]));
    ASSERT_GT(s, 0) << kComponents[c];
    const double eps = 1e-12 * (std::abs(v) + s);
    EXPECT_EQ(b.value, v) << kComponents[c];
    EXPECT_NEAR(b.sigma.lo, v - s, eps) << kComponents[c];
    EXPECT_NEAR(b.sigma.hi, v + s, eps) << kComponents[c];
    EXPECT_NEAR(b.sigma.y_lo, ax.y(v - s), 1e-6) << kComponents[c];
    EXPECT_NEAR(b.sigma.y_hi, ax.y(v + s), 1e-6) << kComponents[c];
    EXPECT_LE(ax.top, b.sigma.y_hi) << kComponents[c] << ": the band leaves its axes";
    EXPECT_LE(b.sigma.y_lo, ax.top + ax.height) << kComponents[c] << ": the band leaves its axes";
    EXPECT_FALSE(b.bound.found) << kComponents[c] << ": a friction bound without friction joints";
    bands.push_back(b);
  }
  const Browse off = browse(browser, dir / "p.html", "t=0.7&paused=1&wrench=arm1.ee&bands=0", true);
  ASSERT_TRUE(off.ok) << off.log.substr(0, 3000);
  const PageState po = page_state(off.dom);
  EXPECT_FALSE(plot_band(po.probe, "fx").found) << po.probe;
  ASSERT_EQ(plot_axes(po.probe).size(), 2u);
  EXPECT_EQ(plot_axes(po.probe)[1].lo, axes[1].lo);
  EXPECT_EQ(plot_axes(po.probe)[1].hi, axes[1].hi);
  expect_bands_in_column(on.shot, off.shot, p, axes, dir / "p.csv");
}

// A log of two output_t of two_puma_load with declared noise (kNoise): the first with each wrench's
// sigma and a friction bound (as if friction joints rested: 0.25 (c + 1) + 0.01 k for component c of
// output k), the second without. The messages are encoded as coopdynd does (io::OutputEncoder) and
// written with LCM's event-log API as lcm-logger would. What the first says of each output:
struct SigmaLog {
  std::vector<std::string> names;           // per output
  std::vector<bool> drawn;                  // per output: the view draws it (not a joint reaction)
  std::vector<Vec6> w, sigma, bound;        // per output: [moment; force] in its report frame
};
SigmaLog write_sigma_log(const TempDir& dir, const std::string& log) {
  SigmaLog out;
  const System sys = load_scene(noisy_scene(dir, kNoise));
  Workspace ws(sys);
  WrenchData wd(sys);
  WrenchSigmaData sd(sys);
  FrictionBoundData fb(sys);
  const Eigen::VectorXd tau = Eigen::VectorXd::Constant(sys.model.nv(), 0.3);
  evaluate(sys, ws, sys.q0, sys.v0, tau);
  compute_wrenches(sys, ws, wd);
  compute_wrench_sigma(sys, ws, sd);
  EXPECT_TRUE(sd.declared);
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
  lcm::LogFile lf(log, "w");
  EXPECT_TRUE(lf.good());
  for (int i = 0; i < 2; ++i) {  // with sigma and bound, then without
    fr.tick = i;
    fr.sim_time = 0.01 * i;
    fr.sigma = i == 0 ? &sd : nullptr;
    fr.bound = i == 0 ? &fb : nullptr;
    const int len = enc.encode(fr, buf.data(), static_cast<int>(buf.size()));
    EXPECT_GT(len, 0);
    lcm::LogEvent ev{};
    ev.eventnum = i;
    ev.timestamp = static_cast<int64_t>(i) * 10000;
    ev.channel = "COOPDYN_OUTPUT";
    ev.datalen = len;
    ev.data = buf.data();
    EXPECT_EQ(lf.writeEvent(&ev), 0);
  }
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k) {
    out.names.push_back(sys.wrenches.outputs[k].name);
    out.drawn.push_back(sys.wrenches.outputs[k].kind != WrenchKind::kJoint);
    out.w.push_back(wd.W[k]);
    out.sigma.push_back(sd.sigma[k]);
    out.bound.push_back(fb.bound[k]);
  }
  return out;
}

// A daemon log: the page's sigma and bound of each frame are the message's wrench_sigma and
// wrench_bound, the same doubles, by drawn wrench; a message without them (SIGMA_NONE, no friction
// joint at rest) gives none; the report frame's orientation comes with them.
TEST(ViewSigma, LogFramesCarryTheMessagesSigmaAndBound) {
  TempDir dir("sigma_log");
  const std::string log = dir / "run.lcmlog";
  const SigmaLog sl = write_sigma_log(dir, log);
  std::ofstream(dir / "three.min.js") << "/* stand-in */ var THREE_STAND_IN = 'WebGLRenderer';\n";
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
  for (size_t k = 0; k < sl.names.size(); ++k)
    if (sl.drawn[k]) drawn_k.push_back(k);
  ASSERT_FALSE(drawn_k.empty());
  ASSERT_EQ(sg.size(), 2u) << page.substr(0, 200);
  ASSERT_EQ(bd.size(), 2u);
  ASSERT_EQ(wr.size(), 2u);
  ASSERT_EQ(sg[0].size(), 6 * drawn_k.size());
  ASSERT_EQ(bd[0].size(), 6 * drawn_k.size());
  EXPECT_EQ(wr[0].size(), 4 * drawn_k.size());
  for (size_t j = 0; j < drawn_k.size(); ++j)
    for (int c = 0; c < 6; ++c) {
      EXPECT_EQ(sg[0][6 * j + static_cast<size_t>(c)], sl.sigma[drawn_k[j]][c]) << j << " " << c;
      EXPECT_EQ(bd[0][6 * j + static_cast<size_t>(c)], sl.bound[drawn_k[j]][c]) << j << " " << c;
    }
  EXPECT_TRUE(sg[1].empty());
  EXPECT_TRUE(bd[1].empty());
  EXPECT_TRUE(wr[1].empty());
}

// The same log's page in Chromium, arm1.ee's plot: at the first frame each component has its band,
// the message's value -+ sigma, and its friction bound (dashed), value -+ bound, to round-off, at
// the y its axes map them to; at the second frame (a message without either) neither is drawn.
TEST(ViewSigma, PlotBoundFromALogIsTheValuePlusMinusBound) {
  REQUIRE_BROWSER();
  TempDir dir("sigma_log_plot");
  const std::string log = dir / "run.lcmlog";
  const SigmaLog sl = write_sigma_log(dir, log);
  const size_t k = static_cast<size_t>(std::find(sl.names.begin(), sl.names.end(), "arm1.ee") - sl.names.begin());
  ASSERT_LT(k, sl.names.size());
  std::string err;
  ASSERT_EQ(run("'" + kBin + "' view --scene '" + dir / "noisy.yaml" + "' --log '" + log + "' --out '" + dir / "v.html" + "'",
                dir / "e", &err),
            0)
      << err;
  DevTools browser(chromium, dir / "b");
  const Browse b0 = browse(browser, dir / "v.html", "frame=0&paused=1&wrench=arm1.ee", false);
  ASSERT_TRUE(b0.ok) << b0.log.substr(0, 3000);
  const PageState p = page_state(b0.dom);
  ASSERT_EQ(p.title, "coopdyn view: two_puma_load");
  ASSERT_EQ(p.frame, 0);
  const std::vector<PlotAxes> axes = plot_axes(p.probe);
  ASSERT_EQ(axes.size(), 2u) << p.probe;
  for (int c = 0; c < 6; ++c) {
    const PlotBand b = plot_band(p.probe, kComponents[c]);
    const PlotAxes& ax = axes[c < 3 ? 0 : 1];
    const double v = sl.w[k][c], s = sl.sigma[k][c], d = sl.bound[k][c], eps = 1e-12 * (std::abs(v) + s + d);
    ASSERT_TRUE(b.sigma.found && b.bound.found) << kComponents[c] << ": " << p.probe;
    EXPECT_EQ(b.value, v) << kComponents[c];
    EXPECT_NEAR(b.sigma.lo, v - s, eps) << kComponents[c];
    EXPECT_NEAR(b.sigma.hi, v + s, eps) << kComponents[c];
    EXPECT_NEAR(b.bound.lo, v - d, eps) << kComponents[c];
    EXPECT_NEAR(b.bound.hi, v + d, eps) << kComponents[c];
    EXPECT_NEAR(b.bound.y_lo, ax.y(v - d), 1e-6) << kComponents[c];
    EXPECT_NEAR(b.bound.y_hi, ax.y(v + d), 1e-6) << kComponents[c];
  }
  const Browse b1 = browse(browser, dir / "v.html", "frame=1&paused=1&wrench=arm1.ee", false);
  ASSERT_TRUE(b1.ok) << b1.log.substr(0, 3000);
  const PageState p1 = page_state(b1.dom);
  ASSERT_EQ(p1.frame, 1);
  EXPECT_NE(p1.probe.find("\"axes\":["), std::string::npos) << p1.probe;
  EXPECT_FALSE(plot_band(p1.probe, "fx").found) << "a band at a frame without sigma or bound: " << p1.probe;
}

}  // namespace
}  // namespace coopdyn
