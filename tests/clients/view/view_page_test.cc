// coopdyn view's page of a sim CSV: self-contained, and in headless Chromium every shipped scene,
// the force arrows where projected, the time slider, playing, the contact report, the ground as
// declared and the plot of a clicked wrench.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/clients/view/view_test_util.h"

namespace coopdyn {
namespace {
using namespace view_test;

// The page holds everything (no address to fetch), three.js inline, at most --max-frames frames,
// the first and the last row always among them.
TEST(ViewPage, SelfContainedAndSubsampled) {
  TempDir dir("page");
  ASSERT_EQ(sim("unicycle", 3, 0.001, dir / "u.csv", dir / "sim.err"), 0) << slurp(dir / "sim.err");
  const std::string fake_three = dir / "three.min.js";
  std::ofstream(fake_three) << "/* stand-in */ var THREE_STAND_IN = 'WebGLRenderer';\n";
  std::string err;
  ASSERT_EQ(view(scene_file("unicycle"), dir / "u.csv", dir / "u.html", dir / "e", &err, "--three-js '" + fake_three + "'"), 0) << err;
  const std::string page = slurp(dir / "u.html");
  EXPECT_NE(page.find("var THREE_STAND_IN = 'WebGLRenderer';"), std::string::npos);
  for (const char* ref : {"src=", "href=", "http:", "https:", "<link", "import("}) EXPECT_EQ(page.find(ref), std::string::npos) << ref;
  const std::string t = between(page, "\"t\":[", "]");
  ASSERT_FALSE(t.empty());
  const long commas = std::count(t.begin(), t.end(), ',');
  EXPECT_EQ(commas + 1, 2000);  // 3001 rows -> the default cap
  EXPECT_EQ(t.substr(0, 2), "0,");
  EXPECT_EQ(t.substr(t.rfind(',') + 1), "3");

  ASSERT_EQ(view(scene_file("unicycle"), dir / "u.csv", dir / "v.html", dir / "e", &err,
                 "--max-frames 7 --three-js '" + fake_three + "'"), 0) << err;
  EXPECT_EQ(between(slurp(dir / "v.html"), "\"t\":[", "]"), "0,0.5,1,1.5,2,2.5,3");
}


// Every shipped scene's page loads and renders with no JavaScript error, at the frame the hash asks.
TEST(ViewBrowser, EveryShippedSceneLoads) {
  REQUIRE_BROWSER();
  TempDir dir("scenes");
  std::vector<std::string> scenes;
  for (const auto& e : fs::directory_iterator(kSrc + "/config/scenes"))
    if (e.path().extension() == ".yaml") scenes.push_back(e.path().stem().string());
  std::sort(scenes.begin(), scenes.end());
  ASSERT_GE(scenes.size(), 6u);
  for (const auto& s : scenes) {
    // 2.5 ms: at 5 ms, explicit RK4 on tiago_pro_box diverges (a clear status) under its URDF's
    // joint damping (1 N*m*s/rad on light joints), which is modelled
    ASSERT_EQ(sim(s, 0.5, 0.0025, dir / (s + ".csv"), dir / "sim.err"), 0) << s << ": " << slurp(dir / "sim.err");
    std::string err;
    ASSERT_EQ(view(scene_file(s), dir / (s + ".csv"), dir / (s + ".html"), dir / "e", &err), 0) << s << ": " << err;
  }
  // one browser, one page after the other, each judged once it has set itself up
  DevTools browser(chromium, dir / "scenes");
  for (const auto& s : scenes) {
    std::string why;
    const std::string dom = browser.load("file://" + dir / (s + ".html") + "#t=0.25&paused=1", &why);
    ASSERT_EQ(why, "") << s;
    const PageState p = page_state(dom);
    const System sys = load_scene(scene_file(s));
    EXPECT_EQ(p.title, "coopdyn view: " + sys.name) << s << ": a JavaScript error, or the page did not finish";
    EXPECT_EQ(p.title.find("JSERROR"), std::string::npos) << s << ": " << p.title;
    EXPECT_TRUE(p.ready) << s;
    EXPECT_EQ(p.error, ">") << s << ": the page shows an error";  // <div id="error"></div>, empty
    EXPECT_EQ(p.frame, 100) << s << ": " << p.probe;  // t = 0.25 s at 2.5 ms
    EXPECT_DOUBLE_EQ(p.t, 0.25) << s;
    EXPECT_EQ(p.time_text, "t = 0.250 s") << s;
  }
}

// A wrench in a rotated frame: arm1's end-effector wrench of two_puma_load (in frame arm1.ee),
// drawn where its world direction projects, at a time picked by #t.
TEST(ViewBrowser, ForceArrowWhereProjected) {
  REQUIRE_BROWSER();
  TempDir dir("arrow");
  // with zero torque the arms fall and pull the box apart: 855 N on arm1's end-effector at 0.7 s
  ASSERT_EQ(sim("two_puma_load", 0.8, 0.005, dir / "p.csv", dir / "sim.err"), 0) << slurp(dir / "sim.err");
  std::string err;
  ASSERT_EQ(view(scene_file("two_puma_load"), dir / "p.csv", dir / "p.html", dir / "e", &err), 0) << err;
  DevTools browser(chromium, dir / "p");
  const Browse b = browse(browser, dir / "p.html", "t=0.7&paused=1&wrench=arm1.ee", true);
  ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
  const PageState p = page_state(b.dom);
  ASSERT_EQ(p.title, "coopdyn view: two_puma_load");
  ASSERT_DOUBLE_EQ(p.t, 0.7);
  ASSERT_LT(p.canvas_w, b.shot.w) << "the plot's panel beside the 3D view while a wrench is selected";
  ASSERT_GT(p.force_scale, 0);
  EXPECT_NE(b.dom.find("force <span id=\"fscale\">1 m = " + between(p.probe, "\"force_scale\":", ",") + " N</span>"), std::string::npos)
      << "the scale shown is not the one drawn";

  const System sys = load_scene(scene_file("two_puma_load"));
  const WorldForce wf = world_force(sys, dir / "p.csv", 0.7, "arm1.ee");
  EXPECT_GT(wf.force.norm(), 800);
  const Eigen::Vector2d o = project(p, wf.origin), tip = project(p, wf.origin + wf.force / p.force_scale);
  expect_arrow_at(b.shot, p, o, tip, "arm1.ee at t=0.7");
  // the moment arrow, in its own colour, when it is long enough to see
  const double moment_scale = num_after(p.probe, "\"moment_scale\":");
  const double lm = (project(p, wf.origin + wf.moment / moment_scale) - o).norm();
  const int cyan = count_in_canvas(b.shot, p, is_moment_colour);
  if (lm > 15) {
    EXPECT_GT(cyan, 10) << "no moment arrow (" << lm << " px long)";
  }
}

// Moving the time slider (the hash sets it and fires its input event, the handler dragging runs)
// shows another frame: the time text and the probe follow, and the rolling wheel's contact force,
// which has no moment, is drawn where each frame's projection says.
TEST(ViewBrowser, TimeSliderChangesFrame) {
  REQUIRE_BROWSER();
  TempDir dir("slider");
  ASSERT_EQ(sim("unicycle", 1, 0.005, dir / "u.csv", dir / "sim.err"), 0) << slurp(dir / "sim.err");
  std::string err;
  ASSERT_EQ(view(scene_file("unicycle"), dir / "u.csv", dir / "u.html", dir / "e", &err), 0) << err;
  const System sys = load_scene(scene_file("unicycle"));
  DevTools browser(chromium, dir / "u");
  const Browse b0 = browse(browser, dir / "u.html", "slider=40&paused=1", true);
  const Browse b = browse(browser, dir / "u.html", "slider=160&paused=1", true);
  std::vector<Eigen::Vector2d> tips;
  for (int k = 0; k < 2; ++k) {
    const Browse& br = k == 0 ? b0 : b;
    const int frame = k == 0 ? 40 : 160;
    ASSERT_TRUE(br.ok) << br.log.substr(0, 3000);
    const PageState p = page_state(br.dom);
    ASSERT_EQ(p.title, "coopdyn view: unicycle");
    EXPECT_EQ(p.frame, frame);
    const double t = frame * 0.005;
    EXPECT_NEAR(p.t, t, 1e-12);
    char text[32];
    std::snprintf(text, sizeof text, "t = %.3f s", t);
    EXPECT_EQ(p.time_text, text);
    const WorldForce wf = world_force(sys, dir / "u.csv", t, "wheel");
    EXPECT_NEAR(wf.force.z(), 3 * 9.81, 0.5);  // the wheel's weight, up, at the contact point
    const Eigen::Vector2d o = project(p, wf.origin), tip = project(p, wf.origin + wf.force / wrench_scale(p.probe, "wheel"));
    expect_arrow_at(br.shot, p, o, tip, "wheel at frame " + std::to_string(frame));
    tips.push_back(tip);
    const int cyan = count_in_canvas(br.shot, p, is_moment_colour);
    EXPECT_EQ(cyan, 0) << "a moment arrow for a point contact";
  }
  ASSERT_EQ(tips.size(), 2u);
  EXPECT_GT((tips[1] - tips[0]).norm(), 50) << "the wheel rolled 1.2 m between the frames";
}

// Play: without `paused` the page advances on its own, on its animation clock, at the speed asked.
// Chromium runs in real time, driven over DevTools: the test waits until the page has played
// 400 ms (a run time of 0.1 s, 20 frames at a quarter of the speed), however long the machine
// takes to give it that, and judges the render that reported it.
TEST(ViewBrowser, Plays) {
  REQUIRE_BROWSER();
  TempDir dir("play");
  ASSERT_EQ(sim("four_bar", 2, 0.005, dir / "f.csv", dir / "sim.err"), 0) << slurp(dir / "sim.err");
  std::string err;
  ASSERT_EQ(view(scene_file("four_bar"), dir / "f.csv", dir / "f.html", dir / "e", &err), 0) << err;
  DevTools browser(chromium, dir / "f");
  const std::string opened = browser.open("file://" + dir / "f.html" + "#t=0&speed=0.25");
  ASSERT_EQ(opened, "");
  std::string dom;
  const bool played = browser.wait_until(
      [](const std::string& d) { return num_after(page_state(d).probe, "\"played_ms\":") >= 400; }, 60, &dom);
  const PageState p = page_state(dom);
  ASSERT_TRUE(played) << "the page did not play 400 ms in 60 s: " << p.title << " " << p.probe << "\n" << browser.log();
  ASSERT_EQ(p.title, "coopdyn view: four_bar");
  EXPECT_NE(p.probe.find("\"playing\":true"), std::string::npos) << p.probe;
  // the run advanced at a quarter of the animation clock (the 2 s run loops after 8 s of it), and
  // the frame shown is the last one at or before the run time
  const double played_ms = num_after(p.probe, "\"played_ms\":"), played_sim = num_after(p.probe, "\"played_sim\":");
  EXPECT_NEAR(played_sim, 0.25 * played_ms / 1000, 1e-9) << p.probe;
  EXPECT_LE(p.t, played_sim + 1e-12) << p.probe;
  EXPECT_GT(p.t, played_sim - 0.005 - 1e-12) << p.probe;
  EXPECT_GT(p.frame, 0) << p.probe;
}


// Numbers of the probe's JSON after `"key":` inside the object that starts at `from`.
double probe_num(const std::string& probe, const std::string& from, const std::string& key) {
  const size_t at = probe.find(from);
  return at == std::string::npos ? NAN : num_after(probe.substr(at), "\"" + key + "\":");
}
std::string probe_str(const std::string& probe, const std::string& from, const std::string& key) {
  const size_t at = probe.find(from);
  return at == std::string::npos ? "" : between(probe.substr(at), "\"" + key + "\":\"", "\"");
}

// The page's colour of a contact within its friction (utilisation u in [0, 1)): HSL hue 120 deg
// (green) at 0 to 55 deg (yellow) at 1, saturation 0.8, lightness 0.45 (three.js Color.setHSL).
Vec3 utilisation_colour(double u) {
  const double h = (120 - 65 * std::min(u, 1.0)) / 360, s = 0.8, l = 0.45;
  const double p = l <= 0.5 ? l * (1 + s) : l + s - l * s, q = 2 * l - p;
  auto hue = [&](double t) {
    t = t - std::floor(t);
    if (t < 1.0 / 6) return q + (p - q) * 6 * t;
    if (t < 0.5) return p;
    if (t < 2.0 / 3) return q + (p - q) * 6 * (2.0 / 3 - t);
    return q;
  };
  return 255 * Vec3(hue(h + 1.0 / 3), hue(h), hue(h - 1.0 / 3));
}
bool is_slip_colour(const unsigned char* p) { return p[0] > 200 && p[1] < 50 && p[2] < 50; }  // #ff0000

// The car driven hard on its left rear wheel alone: that wheel needs more friction than mu = 0.85
// and slips, the others do not. The page reports each wheel's utilisation, friction needed and
// state as the CSV's row has them (the same doubles), colours each contact's disc by that
// utilisation where this process's projection of the contact point says (red for the slipping
// wheel, the green-to-yellow map of the CSV's utilisation for the others), has red nowhere else,
// and names the slipping wheel in its status row.
TEST(ViewContacts, SlippingWheelHighlightedWhereProjected) {
  REQUIRE_BROWSER();
  TempDir dir("slip");
  ASSERT_EQ(run("'" + kBin + "' sim --scene '" + scene_file("four_wheel_car") +
                    "' --duration 0.3 --dt 0.01 --torque rl_spin:constant:2000 --out '" + dir / "c.csv" + "'",
                dir / "sim.err"),
            0)
      << slurp(dir / "sim.err");
  std::string err;
  ASSERT_EQ(view(scene_file("four_wheel_car"), dir / "c.csv", dir / "c.html", dir / "e", &err), 0) << err;
  const double t = 0.2;
  const auto row = csv_row(dir / "c.csv", t);
  ASSERT_FALSE(row.empty());
  const std::vector<std::string> wheels = {"fl", "fr", "rl", "rr"};
  for (const auto& w : wheels) EXPECT_EQ(row.at(w + ".contact"), w == "rl" ? "slip" : "ok") << w << " at t=" << t;

  DevTools browser(chromium, dir / "c");
  const Browse b = browse(browser, dir / "c.html", "t=0.2&paused=1", true);
  ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
  const PageState p = page_state(b.dom);
  ASSERT_EQ(p.title, "coopdyn view: four_wheel_car");
  ASSERT_DOUBLE_EQ(p.t, t);
  for (const auto& w : wheels) {
    const std::string at = "{\"name\":\"" + w + "\",\"utilisation\"";
    EXPECT_EQ(probe_num(p.probe, at, "utilisation"), std::stod(row.at(w + ".utilisation"))) << w << ": " << p.probe;
    EXPECT_EQ(probe_num(p.probe, at, "friction_needed"), std::stod(row.at(w + ".friction_needed"))) << w;
    EXPECT_EQ(probe_str(p.probe, at, "state"), row.at(w + ".contact")) << w;
  }
  EXPECT_EQ(between(b.dom, "<span id=\"cwarn\" class=\"bad\">", "</span>"), "slipping: rl");

  // where each contact projects: its disc's colour about there (the disc's pixels within its
  // projected radius of the point, of which the contact's and the axle's arrows, drawn over it,
  // cover a part)
  const System sys = load_scene(scene_file("four_wheel_car"));
  const Model& m = sys.model;
  Eigen::VectorXd q(m.nq());
  for (int i = 0; i < m.nq(); ++i) q[i] = std::stod(row.at("q:" + m.q_names[i]));
  Data data(m);
  forward_kinematics(m, data, q, Eigen::VectorXd::Zero(m.nv()));
  Eigen::Vector2d rl_centre;
  double rl_reach = 0;
  for (const ConstraintSpec& c : sys.constraints.specs) {
    if (c.kind != ConstraintKind::kRolling) continue;
    const Transform X = rolling_contact_frame(m, data, c);
    const Vec3 right = (p.up.cross(p.eye - p.target)).normalized();  // the camera's, in the flat ground
    const Eigen::Vector2d at = project(p, X.p);
    const double reach = (project(p, X.p + 0.6 * c.radius * right) - at).norm();  // the disc's radius
    const double u = std::stod(row.at(c.name + ".utilisation"));
    const Vec3 want = c.name == "rl" ? Vec3(255, 0, 0) : utilisation_colour(u);
    int match = 0;
    for (int y = static_cast<int>(at.y() - reach); y <= static_cast<int>(at.y() + reach); ++y)
      for (int x = static_cast<int>(at.x() - reach); x <= static_cast<int>(at.x() + reach); ++x) {
        if ((Eigen::Vector2d(x + 0.5, y + 0.5) - at).norm() > reach) continue;
        const unsigned char* q = b.shot.at(x, y);
        match += (Vec3(q[0], q[1], q[2]) - want).cwiseAbs().maxCoeff() < 12;
      }
    EXPECT_GT(match, 20) << c.name << " (utilisation " << u << "): no disc of colour " << want.transpose()
                         << " within " << reach << " px of " << at.transpose();
    if (c.name == "rl") {
      const Vec3 centre = X.p + c.radius * X.R.col(2);
      rl_centre = project(p, centre);
      for (int k = 0; k < 3; ++k)
        rl_reach = std::max(rl_reach, 1.6 * (project(p, centre + c.radius * Vec3::Unit(k)) - rl_centre).norm());
    }
  }
  // red (the disc and the wheel) about the slipping wheel only
  int near = 0, far = 0;
  for (int y = static_cast<int>(p.canvas_y); y < static_cast<int>(p.canvas_y + p.canvas_h); ++y)
    for (int x = static_cast<int>(p.canvas_x); x < static_cast<int>(p.canvas_x + p.canvas_w); ++x)
      if (is_slip_colour(b.shot.at(x, y))) ((Eigen::Vector2d(x + 0.5, y + 0.5) - rl_centre).norm() < rl_reach ? near : far)++;
  EXPECT_GT(near, 50) << "the slipping wheel is not red";
  EXPECT_EQ(far, 0) << "red away from the slipping wheel (within " << rl_reach << " px of " << rl_centre.transpose() << ")";
}

// The ground as declared: a unicycle on an inclined plane {normal, point, mu} off the origin; the
// page's grid (three.js's own vertices, in the world) lies in that plane with its normal, not at
// z = 0, and the page reports the friction a disk rolling down it needs.
TEST(ViewGround, InclinedGridLiesOnThePlane) {
  REQUIRE_BROWSER();
  TempDir dir("incline");
  const Vec3 n = Vec3(-0.3, 0, 1).normalized(), point(0.5, 0, 0.1);
  const double r = 0.25;
  const Vec3 c = point + r * n;  // the wheel's centre, its axle along y: its lowest rim point on the plane
  std::ofstream(dir / "incline.yaml") << "name: incline\ngravity: [0, 0, -9.81]\nformulation: mobile_platform\n"
                                         "stabilization: {baumgarte: {alpha: 20, beta: 100}}\n"
                                         "ground: {normal: [-0.3, 0, 1], point: [0.5, 0, 0.1], mu: 0.5}\n"
                                         "bodies:\n  - name: wheel\n    parent: world\n"
                                         "    joint: {type: floating, name: wheel, q: {xyz: ["
                                      << c.x() << ", 0, " << c.z() << "]}}\n"
                                         "    mass: 3.0\n    inertia: [0.046875, 0.09375, 0.046875, 0, 0, 0]\n"
                                         "constraints:\n  - {name: wheel, type: rolling, body: wheel, axle: [0, 1, 0], radius: 0.25}\n";
  ASSERT_EQ(run("'" + kBin + "' sim --scene '" + dir / "incline.yaml" + "' --duration 0.5 --dt 0.01 --out '" + dir / "i.csv" + "'",
                dir / "sim.err"),
            0)
      << slurp(dir / "sim.err");
  std::string err;
  ASSERT_EQ(view(dir / "incline.yaml", dir / "i.csv", dir / "i.html", dir / "e", &err), 0) << err;
  DevTools browser(chromium, dir / "i");
  std::string why;
  const PageState p = page_state(browser.load("file://" + dir / "i.html" + "#t=0.5&paused=1", &why));
  ASSERT_EQ(why, "");
  ASSERT_EQ(p.title, "coopdyn view: incline");
  const std::string g = between(p.probe, "\"grounds\":[", ",\"plot\"");
  ASSERT_NE(g.find("\"vertices\":"), std::string::npos) << p.probe;
  EXPECT_EQ(g.find("\"normal\":"), g.rfind("\"normal\":")) << "one plane, one grid: " << g;
  const Vec3 gn = vec_after(g, "\"normal\":[");
  EXPECT_LT((gn - n).norm(), 1e-9) << "the grid's normal " << gn.transpose();
  std::string verts = g.substr(g.find("\"vertices\":") + 11);
  verts.erase(std::remove_if(verts.begin(), verts.end(), [](char ch) { return ch == '[' || ch == ']' || ch == '{' || ch == '}'; }),
              verts.end());
  const std::vector<double> v = numbers(verts);
  ASSERT_EQ(v.size(), 12u) << verts;
  double span = 0;
  for (int k = 0; k < 4; ++k) {
    const Vec3 x(v[3 * k], v[3 * k + 1], v[3 * k + 2]);
    EXPECT_NEAR(n.dot(x - point), 0, 1e-6) << "grid vertex " << x.transpose() << " off the plane";
    span = std::max(span, (x - point).norm());
  }
  EXPECT_GT(span, 1) << "the grid is a plane, not a point";
  // the wheel rolled down the slope on it, below where it started, and the contact report the page
  // shows is the rolling disk's on a slope of angle th: friction needed f_t / f_n = tan(th) / 3
  // (I = m r^2 / 2), here 0.3 / 3 = 0.1, utilisation 0.1 / mu = 0.2
  const auto row = csv_row(dir / "i.csv", 0.5);
  ASSERT_FALSE(row.empty());
  EXPECT_LT(std::stod(row.at("q:wheel.z")), c.z() - 1e-3);
  EXPECT_EQ(probe_num(p.probe, "{\"name\":\"wheel\",\"utilisation\"", "utilisation"), std::stod(row.at("wheel.utilisation")));
  EXPECT_NEAR(probe_num(p.probe, "{\"name\":\"wheel\",\"utilisation\"", "friction_needed"), 0.1, 1e-5) << p.probe;
  EXPECT_NEAR(probe_num(p.probe, "{\"name\":\"wheel\",\"utilisation\"", "utilisation"), 0.2, 2e-5) << p.probe;
}

// The plot of one wrench: a click on its arrow selects it (the click's place is this process's
// projection of the arrow), the plot's series are the CSV's six columns of that wrench (the same
// doubles), and its white cursor stands where the frame's time maps on the plot's axes, following
// the time slider.
TEST(ViewPlot, ClickedWrenchPlottedWithACursorOnTheSlider) {
  REQUIRE_BROWSER();
  TempDir dir("plot");
  // with zero torque the arms fall and pull the box apart: 855 N on arm1's end-effector at 0.7 s
  ASSERT_EQ(sim("two_puma_load", 0.8, 0.005, dir / "p.csv", dir / "sim.err"), 0) << slurp(dir / "sim.err");
  std::string err;
  ASSERT_EQ(view(scene_file("two_puma_load"), dir / "p.csv", dir / "p.html", dir / "e", &err), 0) << err;
  const System sys = load_scene(scene_file("two_puma_load"));
  const int f1 = 140, f2 = 40;  // frames (0.005 s apart)
  DevTools browser(chromium, dir / "p");
  const Browse a = browse(browser, dir / "p.html", "slider=" + std::to_string(f1) + "&paused=1", false);
  ASSERT_TRUE(a.ok) << a.log.substr(0, 3000);
  const PageState pa = page_state(a.dom);
  ASSERT_EQ(pa.title, "coopdyn view: two_puma_load");
  EXPECT_EQ(pa.probe.find("\"plot\":null") != std::string::npos, true) << "no plot before a wrench is picked";
  // a point on arm1.ee's force arrow 8 px or more from every other arrow drawn
  auto seg_dist = [](const Eigen::Vector2d& x, const Eigen::Vector2d& a0, const Eigen::Vector2d& a1) {
    const Eigen::Vector2d d = a1 - a0;
    const double s = d.squaredNorm() > 0 ? std::clamp((x - a0).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0.0;
    return (x - a0 - s * d).norm();
  };
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> others;
  Eigen::Vector2d o1, t1;
  for (const WrenchOutput& w : sys.wrenches.outputs) {
    if (w.kind == WrenchKind::kJoint) continue;
    const WorldForce wf = world_force(sys, dir / "p.csv", f1 * 0.005, w.name);
    const double fs = wrench_scale(pa.probe, w.name), ms = wrench_scale(pa.probe, w.name, "moment");
    const Eigen::Vector2d o = project(pa, wf.origin), tf = project(pa, wf.origin + wf.force / fs);
    if (w.name == "arm1.ee") o1 = o, t1 = tf;
    else others.emplace_back(o, tf);
    others.emplace_back(o, project(pa, wf.origin + wf.moment / ms));
  }
  ASSERT_GT((t1 - o1).norm(), 30);
  Eigen::Vector2d click(-1, -1);
  for (double s = 0.3; s <= 0.95 && click.x() < 0; s += 0.05) {
    const Eigen::Vector2d x = o1 + s * (t1 - o1);
    if (std::all_of(others.begin(), others.end(), [&](const auto& sg) { return seg_dist(x, sg.first, sg.second) > 12; })) click = x;
  }
  ASSERT_GE(click.x(), 0) << "no point of arm1.ee's force arrow clear of the others";
  char hash[128];
  std::snprintf(hash, sizeof hash, "slider=%d&paused=1&plotdata=1&click=%.1f,%.1f", f1, click.x() - pa.canvas_x,
                click.y() - pa.canvas_y);
  const Browse b = browse(browser, dir / "p.html", hash, true);
  const Browse c = browse(browser, dir / "p.html", "slider=" + std::to_string(f2) + "&paused=1&wrench=arm1.ee", true);
  ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
  ASSERT_TRUE(c.ok) << c.log.substr(0, 3000);
  const PageState pb = page_state(b.dom);
  ASSERT_EQ(pb.title, "coopdyn view: two_puma_load");
  ASSERT_EQ(between(pb.probe, "\"wrench\":\"", "\""), "arm1.ee") << "the click did not pick arm1.ee's arrow";

  // the series: every row's six columns
  std::vector<std::vector<double>> series;
  {
    const std::string values = between(b.dom, "\"values\":[[", "]]}");
    for (size_t at = 0, next; at < values.size(); at = next + 3) {
      next = values.find("],[", at);
      if (next == std::string::npos) next = values.size();
      series.push_back(numbers(values.substr(at, next - at)));
    }
  }
  ASSERT_EQ(series.size(), 6u);
  const coopdyn::testing::CsvText table = coopdyn::testing::read_csv_text(dir / "p.csv");
  const std::vector<std::string>& head = table.head;
  const char* comp[6] = {"mx", "my", "mz", "fx", "fy", "fz"};
  std::vector<size_t> col;
  for (const char* cn : comp)
    col.push_back(static_cast<size_t>(std::find(head.begin(), head.end(), std::string("arm1.ee.") + cn) - head.begin()));
  std::vector<double> times;
  size_t rows = 0;
  for (const auto& cells : table.rows) {
    times.push_back(std::stod(cells[0]));
    for (int j = 0; j < 6; ++j) {
      ASSERT_LT(rows, series[j].size());
      EXPECT_EQ(series[j][rows], std::stod(cells[col[j]])) << "arm1.ee." << comp[j] << " at row " << rows + 1;
    }
    ++rows;
  }
  for (int j = 0; j < 6; ++j) EXPECT_EQ(series[j].size(), rows) << comp[j];

  // the cursor: at the frame's time on the axes the probe gives, white in the screenshot there and
  // nowhere else on the plot
  for (const Browse* br : {&b, &c}) {
    const PageState ps = page_state(br->dom);
    const int frame = br == &b ? f1 : f2;
    ASSERT_EQ(ps.frame, frame);
    const std::string plot = ps.probe.substr(ps.probe.find("\"plot\":{"));
    // (the page's times are the CSV's to 9 digits)
    EXPECT_NEAR(probe_num(plot, "\"plot\"", "cursor_t"), times[frame], 1e-9);
    EXPECT_NEAR(probe_num(plot, "\"plot\"", "t0"), times.front(), 1e-9);
    EXPECT_NEAR(probe_num(plot, "\"plot\"", "t1"), times.back(), 1e-9);
    // two axes, moments (N*m) above forces (N), on one time axis
    const std::string axes = between(plot, "\"axes\":[", "]");
    const size_t split = axes.find("},{");
    ASSERT_NE(split, std::string::npos) << axes;
    const std::string ax1 = axes.substr(0, split), ax2 = axes.substr(split);
    const double left = num_after(ax1, "\"left\":"), width = num_after(ax1, "\"width\":");
    const double top1 = num_after(ax1, "\"top\":"), h1 = num_after(ax1, "\"height\":");
    const double top2 = num_after(ax2, "\"top\":"), h2 = num_after(ax2, "\"height\":");
    EXPECT_EQ(num_after(ax2, "\"left\":"), left);
    EXPECT_EQ(num_after(ax2, "\"width\":"), width);
    EXPECT_EQ(between(ax2, "\"unit\":\"", "\""), "N");
    EXPECT_GT(top2, top1 + h1);
    EXPECT_EQ(h2, h1);
    ASSERT_GT(width, 100);
    ASSERT_GT(h1, 40);
    EXPECT_GE(left, ps.canvas_x + ps.canvas_w) << "the plot beside the 3D view";
    const double x = left + (times[frame] - times.front()) / (times.back() - times.front()) * width;
    EXPECT_NEAR(probe_num(plot, "\"plot\"", "cursor_x"), x, 1e-6);
    auto white_in_column = [&](int px) {
      int n = 0;
      for (int y = static_cast<int>(top1) + 2; y < static_cast<int>(top1 + h1) - 2; ++y) {
        const unsigned char* q = br->shot.at(px, y);
        n += q[0] > 240 && q[1] > 240 && q[2] > 240;
      }
      return n;
    };
    const int cx = static_cast<int>(std::floor(x + 0.5));  // the page draws it at Math.round(x) + 0.5
    EXPECT_GT(white_in_column(cx), 0.9 * (h1 - 4)) << "no cursor at x = " << x << " (frame " << frame << ")";
    for (int px = static_cast<int>(left) + 2; px < static_cast<int>(left + width) - 2; ++px)
      if (std::abs(px - cx) > 1) {
        EXPECT_LT(white_in_column(px), 0.2 * h1) << "white at x = " << px << ", the cursor is at " << x;
      }
  }
}

}  // namespace
}  // namespace coopdyn
