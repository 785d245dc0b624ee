// What the coopdyn view tests share: the programs run in a fresh directory, the page's state read
// from its DOM, where a point of the scene falls in its screenshot, and the rows of a CSV.
//
// The browser tests run `coopdyn sim` and `coopdyn view`, then headless Chromium, driven over its
// DevTools protocol, on the page with a hash that picks the frame (#t=, #slider=) and pauses. Each
// waits for the event it needs (the page set up, a played time, frames received), never for a
// fixed time. They read the page's DOM (the title, which carries any JavaScript error, the time
// text and the #probe element with the camera) and its screenshot (PNG, read with libpng). The
// expected arrow is computed here, not by the page: the wrench columns of the CSV row, the report
// frame's pose from this process's own forward kinematics of the row's q, the force scale the page
// shows, and a pinhole projection with the page's camera.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "service/algorithms/kinematics.h"
#include "service/constraints/constraints.h"
#include "service/dynamics/wrenches.h"
#include "service/scene/scene.h"
#include "tests/support/devtools.h"
#include "tests/support/files.h"
#include "tests/support/png_reader.h"
#include "tests/support/private_udpm_url.h"

namespace coopdyn::view_test {

using testing::between;
using testing::DevTools;
using testing::find_chromium;
using testing::Image;
using testing::private_udpm_url;
using testing::slurp;

namespace fs = std::filesystem;
inline const std::string kSrc = COOPDYN_SOURCE_DIR;
inline const std::string kBin = COOPDYN_BIN;
inline constexpr char kThree[] = "/usr/share/javascript/three/three.min.js";

inline std::string scene_file(const std::string& name) { return kSrc + "/config/scenes/" + name + ".yaml"; }

// A fresh directory per test, removed at the end.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name) {
    path = fs::temp_directory_path() / ("coopdyn_view_test_" + std::to_string(getpid()) + "_" + name);
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    if (!std::getenv("COOPDYN_KEEP_TEST_FILES")) fs::remove_all(path, ec);
  }
  std::string operator/(const std::string& f) const { return (path / f).string(); }
};

// Runs a shell command; returns its exit status and its stderr in *err.
inline int run(const std::string& cmd, const std::string& err_file, std::string* err = nullptr) {
  const int rc = std::system((cmd + " 2> '" + err_file + "'").c_str());
  if (err) *err = slurp(err_file);
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

inline int sim(const std::string& scene, double duration, double dt, const std::string& csv, const std::string& err_file) {
  char buf[64];
  std::snprintf(buf, sizeof buf, " --duration %g --dt %g", duration, dt);
  return run("'" + kBin + "' sim --scene '" + scene_file(scene) + "'" + buf + " --out '" + csv + "'", err_file);
}

inline int view(const std::string& scene_path, const std::string& csv, const std::string& html, const std::string& err_file,
                std::string* err, const std::string& extra = "") {
  return run("'" + kBin + "' view --scene '" + scene_path + "' --csv '" + csv + "' --out '" + html + "' " + extra, err_file, err);
}

#define REQUIRE_BROWSER()                                                                                  \
  const std::string chromium = find_chromium();                                                            \
  if (chromium.empty())                                                                                    \
    GTEST_SKIP() << "Chromium not installed (Debian: apt-get install chromium, or set COOPDYN_CHROMIUM): " \
                    "browser test skipped";                                                                \
  if (!fs::exists(kThree)) GTEST_SKIP() << kThree << " missing (Debian: apt-get install libjs-three): browser test skipped"

inline double num_after(const std::string& s, const std::string& key) {
  const size_t i = s.find(key);
  return i == std::string::npos ? NAN : std::strtod(s.c_str() + i + key.size(), nullptr);
}
inline Vec3 vec_after(const std::string& s, const std::string& key) {  // key ends with '['
  size_t i = s.find(key);
  if (i == std::string::npos) return Vec3::Constant(NAN);
  const char* p = s.c_str() + i + key.size();
  Vec3 v;
  for (int k = 0; k < 3; ++k) {
    char* end;
    v[k] = std::strtod(p, &end);
    p = end + 1;  // the comma
  }
  return v;
}

// The arrow scale (N or N*m per metre, key "force" or "moment") the page draws wrench `name` at: one
// per kind of wrench, from the wrenches shown, times its zoom.
inline double wrench_scale(const std::string& probe, const std::string& name, const std::string& key = "force") {
  const size_t i = probe.find("{\"name\":\"" + name + "\",\"group\"");
  return i == std::string::npos ? NAN : num_after(probe.substr(i), "\"" + key + "\":");
}

// What a page's DOM says about itself.
struct PageState {
  std::string title, time_text, probe, error;
  bool ready = false;
  int frame = -1;
  double t = NAN, force_scale = NAN, fov = NAN;
  double canvas_x = NAN, canvas_y = NAN, canvas_w = NAN, canvas_h = NAN;  // the 3D canvas in the page, CSS px
  double window_w = NAN, window_h = NAN;                                  // the page's viewport
  Vec3 eye, target, up;
};
inline PageState page_state(const std::string& dom) {
  PageState s;
  s.title = between(dom, "<title>", "</title>");
  s.time_text = between(dom, "<span id=\"time\">", "</span>");
  s.error = between(dom, "<div id=\"error\"", "</div>");
  s.probe = between(dom, "<pre id=\"probe\">", "</pre>");
  s.ready = dom.find("data-ready=\"1\"") != std::string::npos;
  s.frame = static_cast<int>(num_after(s.probe, "\"frame\":"));
  s.t = num_after(s.probe, "\"t\":");
  s.force_scale = num_after(s.probe, "\"force_scale\":");
  s.fov = num_after(s.probe, "\"fov\":");
  const std::string canvas = between(s.probe, "\"canvas\":{", "}");
  s.canvas_x = num_after(canvas, "\"left\":");
  s.canvas_y = num_after(canvas, "\"top\":");
  s.canvas_w = num_after(canvas, "\"width\":");
  s.canvas_h = num_after(canvas, "\"height\":");
  const std::string window = between(s.probe, "\"window\":{", "}");
  s.window_w = num_after(window, "\"width\":");
  s.window_h = num_after(window, "\"height\":");
  s.eye = vec_after(s.probe, "\"eye\":[");
  s.target = vec_after(s.probe, "\"target\":[");
  s.up = vec_after(s.probe, "\"up\":[");
  return s;
}
// (the same 900 x 600 CSS px the DOM was laid out in).
struct Browse {
  std::string dom;
  Image shot;
  bool ok = false;
  std::string log;
};
inline Browse browse(DevTools& browser, const std::string& html, const std::string& hash, bool screenshot) {
  Browse b;
  b.dom = browser.load("file://" + html + "#" + hash, &b.log);
  if (!b.log.empty()) return b;
  b.dom = browser.dom();
  if (screenshot && !browser.screenshot(&b.shot)) {
    b.log = "no screenshot; " + browser.log();
    return b;
  }
  const PageState p = page_state(b.dom);
  if (screenshot && (b.shot.w != p.window_w || b.shot.h != p.window_h)) {
    b.log = "a screenshot of " + std::to_string(b.shot.w) + " x " + std::to_string(b.shot.h) + " px of a page laid out in " +
            std::to_string(p.window_w) + " x " + std::to_string(p.window_h);
    return b;
  }
  b.ok = !b.dom.empty();
  return b;
}

// Pinhole projection as three.js's PerspectiveCamera.lookAt(target) with camera.up: the pixel of
// the page (x right, y down) where p falls in the page's 3D canvas (its rectangle from the probe).
inline Eigen::Vector2d project(const PageState& c, const Vec3& p) {
  const double w = c.canvas_w, h = c.canvas_h;
  const Vec3 z = (c.eye - c.target).normalized(), x = c.up.cross(z).normalized(), y = z.cross(x);
  const Vec3 d = p - c.eye;
  const double depth = -d.dot(z), f = 1.0 / std::tan(c.fov * M_PI / 360.0);
  const double nx = f * d.dot(x) / (depth * (w / h)), ny = f * d.dot(y) / depth;
  return {c.canvas_x + (nx + 1) / 2 * w, c.canvas_y + (1 - ny) / 2 * h};
}

// The pixels of the screenshot inside the page's 3D canvas that are of a colour.
inline int count_in_canvas(const Image& im, const PageState& p, bool (*is_colour)(const unsigned char*)) {
  int n = 0;
  for (int y = static_cast<int>(p.canvas_y); y < std::min<int>(im.h, static_cast<int>(p.canvas_y + p.canvas_h)); ++y)
    for (int x = static_cast<int>(p.canvas_x); x < std::min<int>(im.w, static_cast<int>(p.canvas_x + p.canvas_w)); ++x)
      n += is_colour(im.at(x, y));
  return n;
}

// The CSV row at time t: every column by name.
inline std::map<std::string, std::string> csv_row(const std::string& csv, double t) {
  const coopdyn::testing::CsvText table = coopdyn::testing::read_csv_text(csv);
  for (const auto& cells : table.rows)
    if (cells.size() == table.head.size() && std::abs(std::stod(cells[0]) - t) < 1e-9) {
      std::map<std::string, std::string> r;
      for (size_t i = 0; i < table.head.size(); ++i) r[table.head[i]] = cells[i];
      return r;
    }
  return {};
}

// The force of wrench `name` at the CSV row at time t, in the world: its application point and the
// force vector, from the row's q (own forward kinematics) and the row's wrench columns.
struct WorldForce {
  Vec3 origin, force, moment;
};
inline WorldForce world_force(const System& sys, const std::string& csv, double t, const std::string& name) {
  const auto row = csv_row(csv, t);
  EXPECT_FALSE(row.empty()) << "no row at t=" << t << " in " << csv;
  const Model& m = sys.model;
  Eigen::VectorXd q(m.nq());
  for (int i = 0; i < m.nq(); ++i) q[i] = std::stod(row.at("q:" + m.q_names[i]));
  Data data(m);
  forward_kinematics(m, data, q, Eigen::VectorXd::Zero(m.nv()));
  const Vec3 f_F(std::stod(row.at(name + ".fx")), std::stod(row.at(name + ".fy")), std::stod(row.at(name + ".fz")));
  const Vec3 m_F(std::stod(row.at(name + ".mx")), std::stod(row.at(name + ".my")), std::stod(row.at(name + ".mz")));
  for (const ConstraintSpec& c : sys.constraints.specs)
    if (c.kind == ConstraintKind::kRolling && c.name == name) {  // a wheel's ground force: the contact frame
      const Transform X = rolling_contact_frame(m, data, c);
      return {X.p, X.R * f_F, X.R * m_F};
    }
  for (const WrenchOutput& o : sys.wrenches.outputs)
    if (o.name == name) {
      const int fi = m.frame_index(o.frame);
      EXPECT_GE(fi, 0) << "frame " << o.frame << " of " << name << " is not a model frame";
      if (fi < 0) break;
      const Transform X = frame_pose(m, data, fi);
      return {X.p, X.R * f_F, X.R * m_F};
    }
  ADD_FAILURE() << "no wrench " << name;
  return {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
}

inline bool is_force_colour(const unsigned char* p) { return p[0] > 200 && p[1] < 90 && p[2] > 200; }   // #ff00ff
inline bool is_moment_colour(const unsigned char* p) { return p[0] < 90 && p[1] > 200 && p[2] > 200; }  // #00ffff

// The force-coloured pixels of the canvas form an arrow from the projection of its origin to the
// projection of its tip: none before the origin or past the tip (a few pixels of antialiasing
// aside), some at both ends, none far from the line between them.
inline bool is_indet_force_colour(const unsigned char* p) { return p[0] > 200 && p[1] > 90 && p[1] < 170 && p[2] < 60; }  // #ff8000
inline void expect_arrow_at(const Image& im, const PageState& p, const Eigen::Vector2d& o, const Eigen::Vector2d& tip,
                     const std::string& what, bool (*is_colour)(const unsigned char*) = is_force_colour) {
  const Eigen::Vector2d axis = tip - o;
  const double L = axis.norm();
  ASSERT_GT(L, 30) << what << ": the projected arrow is too short to judge (" << L << " px)";
  const Eigen::Vector2d u = axis / L;
  double smin = INFINITY, smax = -INFINITY, dmax = 0;
  int n = 0;
  for (int y = static_cast<int>(p.canvas_y); y < std::min<int>(im.h, static_cast<int>(p.canvas_y + p.canvas_h)); ++y)
    for (int x = static_cast<int>(p.canvas_x); x < std::min<int>(im.w, static_cast<int>(p.canvas_x + p.canvas_w)); ++x) {
      if (!is_colour(im.at(x, y))) continue;
      const Eigen::Vector2d d = Eigen::Vector2d(x + 0.5, y + 0.5) - o;
      const double s = d.dot(u);
      smin = std::min(smin, s);
      smax = std::max(smax, s);
      dmax = std::max(dmax, std::abs(d.x() * u.y() - d.y() * u.x()));
      ++n;
    }
  ASSERT_GT(n, 30) << what << ": no force arrow in the screenshot (expected from (" << o.transpose() << ") to ("
                   << tip.transpose() << "))";
  EXPECT_NEAR(smax, L, 5) << what << ": the arrow's tip is off its projection " << tip.transpose();
  EXPECT_NEAR(smin, 0, 5) << what << ": the arrow's base is off its projection " << o.transpose();
  EXPECT_LT(dmax, 0.2 * L + 4) << what << ": force-coloured pixels away from the arrow's line";
}

// two_puma_load with `noise` (scene text: declared noise) appended, written into `dir` (its robot
// file by absolute path).
inline std::string noisy_scene(const TempDir& dir, const std::string& noise) {
  std::string text = slurp(scene_file("two_puma_load"));
  const std::string from = "file: ../robots/", to = "file: " + kSrc + "/config/robots/";
  for (size_t at = 0; (at = text.find(from, at)) != std::string::npos; at += to.size()) text.replace(at, from.size(), to);
  const std::string path = dir / "noisy.yaml";
  std::ofstream(path) << text << noise;
  return path;
}

// The 3D band the probe reads back from the scene: {"centre":[x,y,z],"half":[a,b,c]} of `key`
// (sigma_f, sigma_m, bound_f, bound_m) in the band entry of wrench `name`.
struct Drawn {
  bool found = false;
  Vec3 centre = Vec3::Constant(NAN), half = Vec3::Constant(NAN);
};
inline Drawn drawn(const std::string& probe, const std::string& name, const std::string& key) {
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

// The plot as the probe gives it: its two axes (moments, forces: the rectangle in page CSS px and
// the value range) and, per component at the cursor's frame, the value and the +-sigma band and
// friction bound drawn about it (lo, hi in N*m or N; y of each in page CSS px).
struct PlotAxes {
  double left = NAN, top = NAN, width = NAN, height = NAN, lo = NAN, hi = NAN;
  double y(double v) const { return top + (hi - v) / (hi - lo) * height; }  // where value v is drawn
};
struct PlotEdge {
  bool found = false;
  double lo = NAN, hi = NAN, y_lo = NAN, y_hi = NAN;
};
struct PlotBand {
  bool found = false;
  double value = NAN, y = NAN;
  PlotEdge sigma, bound;
};
inline std::vector<PlotAxes> plot_axes(const std::string& probe) {
  std::vector<PlotAxes> out;
  const std::string all = between(probe, "\"axes\":[", "]");
  for (size_t at = 0; (at = all.find('{', at)) != std::string::npos; ++at) {
    const std::string a = all.substr(at, all.find('}', at) - at);
    out.push_back({num_after(a, "\"left\":"), num_after(a, "\"top\":"), num_after(a, "\"width\":"),
                   num_after(a, "\"height\":"), num_after(a, "\"lo\":"), num_after(a, "\"hi\":")});
  }
  return out;
}
inline PlotEdge plot_edge(const std::string& entry, const std::string& key) {
  PlotEdge e;
  const size_t at = entry.find("\"" + key + "\":{");
  if (at == std::string::npos) return e;
  const std::string s = entry.substr(at, entry.find('}', at) - at);
  e.found = true;
  e.lo = num_after(s, "\"lo\":");
  e.hi = num_after(s, "\"hi\":");
  e.y_lo = num_after(s, "\"y_lo\":");
  e.y_hi = num_after(s, "\"y_hi\":");
  return e;
}
inline PlotBand plot_band(const std::string& probe, const std::string& comp) {  // comp: mx .. fz
  PlotBand b;
  const size_t plot = probe.find("\"plot\":{"), bands = plot == std::string::npos ? plot : probe.find("\"bands\":[", plot);
  if (bands == std::string::npos) return b;
  const size_t at = probe.find("{\"c\":\"" + comp + "\"", bands);
  if (at == std::string::npos) return b;
  const size_t next = probe.find("{\"c\":\"", at + 1);
  // (the last entry runs to the probe's end: what follows the plot has no sigma, bound or value)
  const std::string entry = probe.substr(at, next == std::string::npos ? std::string::npos : next - at);
  b.found = true;
  b.value = num_after(entry, "\"value\":");
  b.y = num_after(entry, "\"y\":");
  b.sigma = plot_edge(entry, "sigma");
  b.bound = plot_edge(entry, "bound");
  return b;
}
inline const char* const kComponents[6] = {"mx", "my", "mz", "fx", "fy", "fz"};

inline std::vector<double> numbers(const std::string& list) {  // "1,2.5,3" -> {1, 2.5, 3}
  std::vector<double> out;
  const char* p = list.c_str();
  while (*p) {
    char* end;
    out.push_back(std::strtod(p, &end));
    if (end == p) break;
    p = *end == ',' ? end + 1 : end;
  }
  return out;
}

}  // namespace coopdyn::view_test
