#include "service/scene/scene_yaml.h"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <sstream>

#include "service/text/input_limits.h"

namespace coopdyn::scene_detail {

namespace bounded = coopdyn::text;  // size and depth limits of user files

[[noreturn]] void fail(const Ctx& c, const YAML::Node& n, const std::string& msg) {
  std::ostringstream os;
  os << c.file;
  if (n.IsDefined() && n.Mark().line >= 0) os << ":" << n.Mark().line + 1 << ":" << n.Mark().column + 1;
  os << ": " << msg;
  throw SceneError(os.str());
}

void check_keys(const Ctx& c, const YAML::Node& n, std::initializer_list<const char*> allowed, const std::string& what) {
  if (!n.IsMap()) fail(c, n, what + " must be a mapping");
  std::set<std::string> ok(allowed.begin(), allowed.end()), seen;
  for (const auto& kv : n) {
    const std::string k = kv.first.as<std::string>();
    if (!seen.insert(k).second) fail(c, kv.first, "duplicate key '" + k + "' in " + what + " (YAML keeps only one of them)");
    if (!ok.count(k)) {
      std::string list;
      for (const auto& a : allowed) list += std::string(list.empty() ? "" : ", ") + a;
      fail(c, kv.first, "unknown key '" + k + "' in " + what + " (allowed: " + list + ")");
    }
  }
}

YAML::Node require(const Ctx& c, const YAML::Node& n, const char* key, const std::string& what) {
  YAML::Node v = n[key];
  if (!v.IsDefined() || v.IsNull()) fail(c, n, what + ": missing '" + key + "'");
  return v;
}

double as_double(const Ctx& c, const YAML::Node& n, const std::string& what) {
  double x;
  if (!n.IsScalar()) fail(c, n, what + " must be a number");
  try {
    const std::string s = n.as<std::string>();
    if (s == "pi") return M_PI;
    if (s == "-pi") return -M_PI;
    if (s == "pi/2") return M_PI / 2;
    if (s == "-pi/2") return -M_PI / 2;
    x = n.as<double>();
  } catch (const YAML::Exception&) {
    fail(c, n, what + " must be a number, got '" + n.as<std::string>() + "'");
  }
  if (!std::isfinite(x)) fail(c, n, what + " must be finite");
  return x;
}

double get_double(const Ctx& c, const YAML::Node& n, const char* key, double def, const std::string& what) {
  YAML::Node v = n[key];
  if (!v.IsDefined() || v.IsNull()) return def;
  return as_double(c, v, what + "." + key);
}

std::string get_string(const Ctx& c, const YAML::Node& n, const char* key, const std::string& def) {
  YAML::Node v = n[key];
  if (!v.IsDefined() || v.IsNull()) return def;
  if (!v.IsScalar()) fail(c, v, std::string("'") + key + "' must be a string");
  return v.as<std::string>();
}

bool get_bool(const Ctx& c, const YAML::Node& n, const char* key, bool def) {
  YAML::Node v = n[key];
  if (!v.IsDefined() || v.IsNull()) return def;
  try {
    return v.as<bool>();
  } catch (const YAML::Exception&) {
    fail(c, v, std::string("'") + key + "' must be true or false");
  }
}

std::vector<double> as_list(const Ctx& c, const YAML::Node& n, int expect, const std::string& what) {
  if (!n.IsSequence()) fail(c, n, what + " must be a list");
  if (expect >= 0 && static_cast<int>(n.size()) != expect)
    fail(c, n, what + " must have " + std::to_string(expect) + " entries, got " + std::to_string(n.size()));
  std::vector<double> out;
  for (size_t i = 0; i < n.size(); ++i) out.push_back(as_double(c, n[i], what + "[" + std::to_string(i) + "]"));
  return out;
}

Vec3 as_vec3(const Ctx& c, const YAML::Node& n, const std::string& what) {
  auto l = as_list(c, n, 3, what);
  return Vec3(l[0], l[1], l[2]);
}

Transform get_pose(const Ctx& c, const YAML::Node& n, const std::string& what) {
  if (!n.IsDefined() || n.IsNull()) return Transform();
  check_keys(c, n, {"xyz", "rpy"}, what);
  Transform X;
  if (n["xyz"]) X.p = as_vec3(c, n["xyz"], what + ".xyz");
  if (n["rpy"]) X.R = rpy_matrix(as_vec3(c, n["rpy"], what + ".rpy"));
  return X;
}

// mass, com, inertia [ixx, iyy, izz, ixy, iyz, ixz] about the centre of mass
Inertia get_inertia(const Ctx& c, const YAML::Node& n, const std::string& what) {
  const double m = get_double(c, n, "mass", 0.0, what);
  if (m < 0.0) fail(c, n["mass"], what + ": negative mass " + std::to_string(m));
  Vec3 com = Vec3::Zero();
  if (n["com"]) com = as_vec3(c, n["com"], what + ".com");
  Mat3 I = Mat3::Zero();
  if (n["inertia"]) {
    auto v = as_list(c, n["inertia"], 6, what + ".inertia");
    I << v[0], v[3], v[5], v[3], v[1], v[4], v[5], v[4], v[2];
    Eigen::SelfAdjointEigenSolver<Mat3> es(I);
    const Vec3 p = es.eigenvalues();
    const double tol = 1e-12 * std::max(1.0, p.cwiseAbs().maxCoeff());
    if (p.minCoeff() < -tol) fail(c, n["inertia"], what + ": inertia tensor is not positive semi-definite");
    // The triangle inequality of physical bodies is not enforced: published models use idealized
    // rotor-only inertias (PUMA link 1 is [0, 0.35, 0]); positive semi-definiteness is what M needs.
  }
  return Inertia(m, com, I);
}

std::array<bool, 6> get_axes(const Ctx& c, const YAML::Node& n, const std::string& what) {
  std::array<bool, 6> ax{{false, false, false, false, false, false}};
  if (!n.IsDefined() || n.IsNull()) return {{true, true, true, true, true, true}};
  if (!n.IsSequence() || n.size() == 0) fail(c, n, what + ": axes must be a non-empty list of wx wy wz vx vy vz");
  static const char* names[6] = {"wx", "wy", "wz", "vx", "vy", "vz"};
  for (const auto& a : n) {
    const std::string s = a.as<std::string>();
    int k = -1;
    for (int i = 0; i < 6; ++i)
      if (s == names[i]) k = i;
    if (k < 0) fail(c, a, what + ": unknown axis '" + s + "' (use wx wy wz vx vy vz)");
    ax[k] = true;
  }
  return ax;
}

std::array<double, 6> get_compliance(const Ctx& c, const YAML::Node& n, const std::string& what) {
  std::array<double, 6> cp{{0, 0, 0, 0, 0, 0}};
  if (!n.IsDefined() || n.IsNull()) return cp;
  if (n.IsScalar()) {
    const double x = as_double(c, n, what);
    cp.fill(x);
  } else {
    auto l = as_list(c, n, 6, what);
    for (int i = 0; i < 6; ++i) cp[i] = l[i];
  }
  for (double x : cp)
    if (x < 0) fail(c, n, what + ": compliance must be >= 0");
  return cp;
}

// Bounded before yaml-cpp sees it (size, nesting pre-scan): its parser recurses per level and
// stops at 500 with the message "bad file".
void check_yaml_text(const std::string& text, const std::string& file) {
  if (text.size() > bounded::kMaxYamlBytes)
    throw SceneError(file + ": " + std::to_string(text.size()) + " bytes, more than the limit of " +
                     std::to_string(bounded::kMaxYamlBytes) + " for a scene or robot file");
  if (const bounded::DepthExceeded d = bounded::yaml_depth_exceeds(text); d.exceeded)
    throw SceneError(file + ":" + std::to_string(d.line) + ":" + std::to_string(d.column) + ": YAML nested deeper than " +
                     std::to_string(bounded::kMaxYamlDepth) + " levels (the limit for a scene or robot file)");
}

YAML::Node load_yaml_file(const Ctx& c, const std::string& path, const YAML::Node& where) {
  std::string text, why;
  if (!bounded::read_file(path, bounded::kMaxYamlBytes, "'" + path + "'", &text, &why)) fail(c, where, why);
  check_yaml_text(text, path);
  try {
    return YAML::Load(text);
  } catch (const YAML::DeepRecursion& e) {
    throw SceneError(path + ": YAML nested deeper than yaml-cpp's limit of " + std::to_string(e.depth()) + " levels");
  } catch (const YAML::ParserException& e) {
    throw SceneError(path + ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1) +
                     ": YAML syntax error: " + e.msg);
  }
}

}  // namespace coopdyn::scene_detail
