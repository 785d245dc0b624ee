#include "service/scene/scene_yaml.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

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

void warn(const Ctx& c, const YAML::Node& n, const std::string& msg) {
  if (!c.warnings) return;
  std::ostringstream os;
  os << c.file;
  if (n.IsDefined() && n.Mark().line >= 0) os << ":" << n.Mark().line + 1 << ":" << n.Mark().column + 1;
  os << ": " << msg;
  c.warnings->push_back(os.str());
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

double get_joint_loss(const Ctx& c, const YAML::Node& n, const char* key, const std::string& what) {
  const double x = get_double(c, n, key, 0.0, what);
  if (!(std::isfinite(x) && x >= 0))
    fail(c, n[key], what + ": " + key + " must be a finite number >= 0 (" +
                        (std::string(key) == "damping" ? "N*m*s/rad or N*s/m" : "the Coulomb bound, N*m or N") + ")");
  return x;
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

double as_angle(const Ctx& c, const YAML::Node& n, const std::string& what) {
  const double x = as_double(c, n, what);
  if (std::abs(x) > 2 * M_PI + 1e-9) {
    std::ostringstream os;
    os.precision(6);
    os << what << " = " << x << " rad is more than a full turn: angles are radians (degrees? " << x << " deg = "
       << x * M_PI / 180 << " rad; pi, -pi, pi/2, -pi/2 may be written as words)";
    fail(c, n, os.str());
  }
  return x;
}

double as_length(const Ctx& c, const YAML::Node& n, const std::string& what) {
  const double x = as_double(c, n, what);
  if (std::abs(x) > 1e3) {
    std::ostringstream os;
    os << what << " = " << x << " m is more than 1 km: lengths are metres (millimetres?)";
    warn(c, n, os.str());
  }
  return x;
}

Transform read_pose_fields(const Ctx& c, const YAML::Node& n, const std::string& what) {
  Transform X;
  if (n["xyz"]) {
    const YAML::Node xyz = n["xyz"];
    as_list(c, xyz, 3, what + ".xyz");
    for (int k = 0; k < 3; ++k) X.p[k] = as_length(c, xyz[k], what + ".xyz[" + std::to_string(k) + "]");
  }
  const int forms = (n["rpy"] ? 1 : 0) + (n["quat"] ? 1 : 0) + (n["R"] ? 1 : 0);
  if (forms > 1) fail(c, n, what + ": give the rotation once, as rpy, quat or R");
  if (n["rpy"]) {
    const YAML::Node r = n["rpy"];
    as_list(c, r, 3, what + ".rpy");
    Vec3 rpy;
    for (int k = 0; k < 3; ++k) rpy[k] = as_angle(c, r[k], what + ".rpy[" + std::to_string(k) + "]");
    X.R = rpy_matrix(rpy);
  } else if (n["quat"]) {
    const auto l = as_list(c, n["quat"], 4, what + ".quat");
    const Quat qu(l[0], l[1], l[2], l[3]);  // scalar first: [w, x, y, z]
    if (std::abs(qu.norm() - 1.0) > 1e-6) {
      std::ostringstream os;
      os.precision(17);
      os << what << ".quat [w, x, y, z] has norm " << qu.norm() << ", not 1 (a unit quaternion, scalar first)";
      fail(c, n["quat"], os.str());
    }
    X.R = qu.normalized().toRotationMatrix();
  } else if (n["R"]) {
    const YAML::Node rn = n["R"];
    if (!rn.IsSequence() || rn.size() != 3) fail(c, rn, what + ".R must be three rows of three numbers");
    Mat3 R;
    for (int i = 0; i < 3; ++i) {
      const auto row = as_list(c, rn[i], 3, what + ".R[" + std::to_string(i) + "]");
      for (int j = 0; j < 3; ++j) R(i, j) = row[j];
    }
    const double orth = (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff();
    if (orth > 1e-6 || R.determinant() < 0) {
      std::ostringstream os;
      os << what << ".R is not a rotation (|R^T R - I| = " << orth << ", det " << R.determinant()
         << "): rows of an orthonormal matrix with det +1";
      fail(c, rn, os.str());
    }
    // the nearest rotation (polar factor): a matrix printed to a few digits closes to round-off
    Eigen::JacobiSVD<Mat3> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
    X.R = svd.matrixU() * svd.matrixV().transpose();
  }
  return X;
}

Transform get_pose(const Ctx& c, const YAML::Node& n, const std::string& what) {
  if (!n.IsDefined() || n.IsNull()) return Transform();
  check_keys(c, n, {"xyz", "rpy", "quat", "R"}, what);
  return read_pose_fields(c, n, what);
}

std::string inertia_plausibility(double m, const Mat3& I) {
  std::ostringstream os;
  if (m > 1e5) os << "mass " << m << " kg is more than 100 t (masses are kg: grams?)";
  Eigen::SelfAdjointEigenSolver<Mat3> es(I);
  const Vec3 p = es.eigenvalues().cwiseMax(0.0);  // ascending
  const double tol = 1e-9 * std::max(1e-300, p.maxCoeff());
  const bool rotor_only = p[0] <= tol && p[1] <= tol;  // a published idealization: only the moment about the axis
  if (!rotor_only && p[0] + p[1] < p[2] - tol) {
    if (os.tellp() > 0) os << "; ";
    os.precision(6);
    os << "principal moments " << p[0] << ", " << p[1] << ", " << p[2]
       << " kg m^2 break the triangle inequality (I1 + I2 >= I3 holds for every rigid body: a typo, or an "
          "inertia about another point than the centre of mass?)";
  }
  return os.str();
}

bool inertia_psd(const Mat3& I) {
  Eigen::SelfAdjointEigenSolver<Mat3> es(I);
  const Vec3 p = es.eigenvalues();
  const double tol = 1e-12 * std::max(1.0, p.cwiseAbs().maxCoeff());
  return I.allFinite() && !(p.minCoeff() < -tol);
}

// mass, com, inertia [ixx, iyy, izz, ixy, iyz, ixz] about the centre of mass
Inertia get_inertia(const Ctx& c, const YAML::Node& n, const std::string& what) {
  const double m = get_double(c, n, "mass", 0.0, what);
  if (m < 0.0) fail(c, n["mass"], what + ": negative mass " + std::to_string(m));
  Vec3 com = Vec3::Zero();
  if (n["com"]) {
    as_list(c, n["com"], 3, what + ".com");
    for (int k = 0; k < 3; ++k) com[k] = as_length(c, n["com"][k], what + ".com[" + std::to_string(k) + "]");
  }
  Mat3 I = Mat3::Zero();
  if (n["inertia"]) {
    auto v = as_list(c, n["inertia"], 6, what + ".inertia");
    I << v[0], v[3], v[5], v[3], v[1], v[4], v[5], v[4], v[2];
    if (!inertia_psd(I)) fail(c, n["inertia"], what + ": inertia tensor is not positive semi-definite");
  }
  // positive semi-definiteness is what M needs; the rest is a warning (published models use
  // rotor-only inertias, PUMA link 1 is [0, 0.35, 0], which the check accepts)
  // `accept_inertia: REASON` (a non-empty text, e.g. the source of measured values) accepts it
  const bool accepted = n["accept_inertia"] && n["accept_inertia"].IsScalar() && !n["accept_inertia"].Scalar().empty();
  if (n["accept_inertia"] && !accepted) fail(c, n["accept_inertia"], what + ": accept_inertia needs the reason as text");
  if (const std::string w = inertia_plausibility(m, I); !w.empty() && !accepted)
    warn(c, n["inertia"] ? n["inertia"] : n, what + ": " + w + " (accept_inertia: REASON on this entry accepts it)");
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
  if (!bounded::read_file(path, bounded::kMaxYamlBytes, path, &text, &why)) fail(c, where, why);
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
