#include "service/scene/scene.h"

#include <urdf_parser/urdf_parser.h>
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "service/algorithms/crba.h"
#include "service/algorithms/kinematics.h"
#include "service/algorithms/tree_cholesky.h"
#include "service/text/input_limits.h"

namespace bounded = coopdyn::text;  // size and depth limits of user files

namespace coopdyn {

namespace {

struct Ctx {
  std::string file;
  std::string dir;
};

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

// The components of a joint's reaction its bearings carry (WrenchOutput::constrained): all but the
// axes its DOFs move along, when those are axes of the report frame (the child's frame).
uint8_t bearing_mask(JointType t, const Vec3& axis, const Vec3& axis2) {
  auto clear = [](uint8_t m, const Vec3& a, int offset) -> uint8_t {
    for (int k = 0; k < 3; ++k)
      if (std::abs(std::abs(a[k]) - a.norm()) <= 1e-12 * a.norm()) m = static_cast<uint8_t>(m & ~(1u << (offset + k)));
    return m;
  };
  switch (t) {
    case JointType::kRevolute: return clear(0x3f, axis, 0);
    case JointType::kPrismatic: return clear(0x3f, axis, 3);
    case JointType::kRevolute2: return clear(clear(0x3f, axis, 0), axis2, 0);  // exact when both stay frame axes
    case JointType::kFloating: return 0;
    case JointType::kFixed: break;
  }
  return 0x3f;
}

WrenchOutput joint_output(const std::string& name, const std::string& frame, const std::string& by, int body,
                          bool reversed, int frame_body, const Transform& X_BF, uint8_t mask) {
  WrenchOutput o;
  o.name = name;
  o.frame = frame;
  o.by = by;
  o.kind = WrenchKind::kJoint;
  o.body = body;
  o.reversed = reversed;
  o.frame_body = frame_body;
  o.X_BF = X_BF;
  o.constrained = mask;
  return o;
}

// ---- DH robots ---------------------------------------------------------------------------------

// A serial robot as a chain of joints, URDF-style: joint i sits at X_origin (its frame in the
// previous link's frame, the robot base for i = 1), moves about `axis` (in the joint frame), and
// link i's frame is the joint frame after the motion. Standard DH and URDF both compile to this.
struct ChainJoint {
  std::string name;       // coordinate name suffix (DH: qK; URDF: the joint's name)
  std::string link_name;  // the child link (DH: linkK; URDF: the link's name)
  Transform X_origin;
  Vec3 axis = Vec3::UnitZ();
  bool prismatic = false;
  bool fixed = false;  // a fixed joint of the robot itself (URDF "fixed")
  Inertia I;           // link i, in link i's frame
  double armature = 0;
  double tau_limit = std::numeric_limits<double>::infinity();
};
struct Robot {
  std::string name;
  std::vector<std::string> warnings;  // what the scene leaves out or finds missing (never silent)
  std::vector<ChainJoint> joints;
  Transform X_last_EE;  // the end-effector frame in the last link's frame
  std::string base_link = "link0";
};

// the joint's motion X_JB(q): rotation about, or translation along, its axis
Transform chain_motion(const ChainJoint& j, double q) {
  if (j.prismatic) return Transform(Mat3::Identity(), j.axis * q);
  return Transform(Eigen::AngleAxisd(q, j.axis.normalized()).toRotationMatrix(), Vec3::Zero());
}

struct DhLink {
  double a = 0, d = 0, alpha = 0, offset = 0;
};
// K_i = Tz(d) Tx(a) Rx(alpha): the fixed part of the standard DH transform T_{i-1,i} = Rz(theta) K_i
Transform dh_fixed(const DhLink& l) { return trans(0, 0, l.d) * trans(l.a, 0, 0) * rot_x(l.alpha); }

Robot parse_robot(const Ctx& c, const YAML::Node& n, const std::string& name) {
  check_keys(c, n, {"source", "convention", "links", "file"}, "robot '" + name + "'");
  const std::string conv = get_string(c, n, "convention", "standard_dh");
  if (conv != "standard_dh") fail(c, n["convention"], "robot '" + name + "': only convention standard_dh is supported");
  Robot r;
  r.name = name;
  const YAML::Node links = require(c, n, "links", "robot '" + name + "'");
  if (!links.IsSequence() || links.size() == 0) fail(c, links, "robot '" + name + "': links must be a non-empty list");
  Transform K_prev;  // identity for joint 1: the DH base frame is the robot base
  for (size_t i = 0; i < links.size(); ++i) {
    const YAML::Node& l = links[i];
    const std::string w = "robot '" + name + "' link " + std::to_string(i + 1);
    check_keys(c, l, {"type", "a", "d", "alpha", "offset", "theta", "mass", "com", "inertia", "armature", "tau_limit"}, w);
    const std::string type = get_string(c, l, "type", "revolute");
    if (type != "revolute" && type != "prismatic") fail(c, l["type"], w + ": type must be revolute or prismatic");
    const bool prismatic = type == "prismatic";
    if (!prismatic && l["theta"])
      fail(c, l["theta"], w + ": theta is the variable of a revolute link (its constant part is 'offset')");
    if (prismatic && l["offset"])
      fail(c, l["offset"], w + ": a prismatic link's constant extension is 'd' (d + q along z); its fixed angle is 'theta'");
    DhLink dl;
    dl.a = get_double(c, l, "a", 0, w);
    dl.d = get_double(c, l, "d", 0, w);
    dl.alpha = get_double(c, l, "alpha", 0, w);
    dl.offset = get_double(c, l, "offset", 0, w);
    const double theta = get_double(c, l, "theta", 0, w);
    ChainJoint j;
    j.name = "q" + std::to_string(i + 1);
    j.link_name = "link" + std::to_string(i + 1);
    j.axis = Vec3::UnitZ();
    // revolute: joint i turns about z of DH frame i-1, so its URDF-style frame is K_{i-1} Rz(offset);
    // the link frame after the motion differs from DH frame i by K_i, which moves the inertia.
    // prismatic: T = Rz(theta) Tz(d + q) Tx(a) Rx(alpha) = Tz(q) [Rz(theta) K_i] (Tz and Rz commute),
    // so the joint slides along z of frame i-1 itself and Rz(theta) K_i is the fixed part.
    const Transform K = prismatic ? rot_z(theta) * dh_fixed(dl) : dh_fixed(dl);
    j.prismatic = prismatic;
    j.X_origin = prismatic ? K_prev : K_prev * rot_z(dl.offset);
    j.I = get_inertia(c, l, w).transformed(K);
    j.armature = get_double(c, l, "armature", 0, w);
    if (!(j.armature >= 0)) fail(c, l["armature"], w + ": armature must be >= 0");
    j.tau_limit = get_double(c, l, "tau_limit", std::numeric_limits<double>::infinity(), w);
    if (!(j.tau_limit >= 0)) fail(c, l["tau_limit"], w + ": tau_limit must be >= 0 (N*m or N; absent = no limit)");
    r.joints.push_back(j);
    K_prev = K;
  }
  r.X_last_EE = K_prev;  // DH frame n
  return r;
}

// A serial chain from a URDF file (urdfdom): from `base` link to `tip` link (defaults: the root and
// its only leaf). Revolute/continuous and prismatic joints move; fixed joints stay fixed.
// The text of the <link name="NAME" ...> element of a URDF, "" if absent (a plain scan: enough to
// tell whether the file gave an <inertial> that urdfdom could not read).
std::string urdf_link_text(const std::string& xml, const std::string& name) {
  for (size_t p = xml.find("<link"); p != std::string::npos; p = xml.find("<link", p + 5)) {
    const size_t end_tag = xml.find('>', p);
    if (end_tag == std::string::npos) break;
    const std::string tag = xml.substr(p, end_tag - p);
    if (tag.find("name=\"" + name + "\"") == std::string::npos && tag.find("name='" + name + "'") == std::string::npos) continue;
    if (xml[end_tag - 1] == '/') return tag;
    const size_t close = xml.find("</link>", end_tag);
    return xml.substr(p, (close == std::string::npos ? xml.size() : close) - p);
  }
  return "";
}
int line_of(const std::string& text, size_t pos) { return 1 + static_cast<int>(std::count(text.begin(), text.begin() + std::min(pos, text.size()), '\n')); }

Robot parse_urdf(const Ctx& c, const YAML::Node& where, const std::string& path, const std::string& name,
                 std::string base, std::string tip) {
  // bounded before urdfdom sees it: its TinyXML parser recurses per element without a limit
  std::string xml, why;
  if (!bounded::read_file(path, bounded::kMaxUrdfBytes, "URDF '" + path + "'", &xml, &why)) fail(c, where, why);
  if (const bounded::DepthExceeded d = bounded::xml_depth_exceeds(xml); d.exceeded)
    fail(c, where, "URDF '" + path + "' line " + std::to_string(d.line) + " column " + std::to_string(d.column) +
                       ": elements nested deeper than " + std::to_string(bounded::kMaxXmlDepth) +
                       " levels (the limit; URDF itself nests 5)");
  if (const size_t x = xml.find("xacro:"); x != std::string::npos)
    fail(c, where, "URDF '" + path + "' line " + std::to_string(line_of(xml, x)) +
                       " is a xacro macro: expand the file first (xacro FILE.urdf.xacro > FILE.urdf)");
  urdf::ModelInterfaceSharedPtr u = urdf::parseURDF(xml);
  if (!u) fail(c, where, "URDF '" + path + "' could not be parsed (see the urdfdom message above)");
  if (base.empty()) base = u->getRoot()->name;
  urdf::LinkConstSharedPtr lk = u->getLink(tip.empty() ? base : tip);
  if (!u->getLink(base)) fail(c, where, "URDF '" + path + "': no link '" + base + "'");
  if (tip.empty()) {
    urdf::LinkConstSharedPtr l = u->getLink(base);
    while (l->child_links.size() == 1) l = l->child_links[0];
    if (!l->child_links.empty()) fail(c, where, "URDF '" + path + "' branches below '" + l->name + "': give robots.<name>.tip");
    tip = l->name;
    lk = l;
  }
  if (!lk) fail(c, where, "URDF '" + path + "': no link '" + tip + "'");
  std::vector<urdf::JointConstSharedPtr> chain;
  for (urdf::LinkConstSharedPtr l = lk; l && l->name != base; l = l->getParent()) {
    if (!l->parent_joint) fail(c, where, "URDF '" + path + "': '" + tip + "' is not below '" + base + "'");
    chain.push_back(l->parent_joint);
  }
  std::reverse(chain.begin(), chain.end());
  auto pose = [](const urdf::Pose& p) {
    double x, y, z, w;
    p.rotation.getQuaternion(x, y, z, w);
    return Transform(Quat(w, x, y, z).normalized().toRotationMatrix(), Vec3(p.position.x, p.position.y, p.position.z));
  };
  Robot r;
  r.name = name;
  r.base_link = base;
  // nothing the file gives is lost silently: an <inertial> urdfdom could not read is an error, a
  // link without one and the links off the chain base..tip are reported
  std::set<std::string> on_chain = {base};
  for (const auto& jt : chain) on_chain.insert(jt->child_link_name);
  for (const auto& jt : chain) {
    urdf::LinkConstSharedPtr child = u->getLink(jt->child_link_name);
    const std::string text = urdf_link_text(xml, child->name);
    const bool given = text.find("<inertial") != std::string::npos;
    // urdfdom logs a malformed <inertial> (a misspelt attribute) and goes on with a zero mass: read
    // the <mass value=...> ourselves and require the two to agree
    static const std::regex mass_re("<mass\\s+value\\s*=\\s*[\"']([^\"']*)[\"']");
    std::smatch mm;
    const bool read = given && child->inertial && std::regex_search(text, mm, mass_re) &&
                      std::abs(std::strtod(mm[1].str().c_str(), nullptr) - child->inertial->mass) <=
                          1e-12 * std::max(1.0, std::abs(child->inertial->mass));
    if (given && !read)
      fail(c, where, "URDF '" + path + "' line " + std::to_string(line_of(xml, xml.find(text))) + ": link '" + child->name +
                         "' has an <inertial> that urdfdom could not read (see its message above: a misspelt attribute?); "
                         "its mass would be lost");
    if (given) continue;
    const bool frame_only = jt->type == urdf::Joint::FIXED;  // a flange or tool frame: massless by design
    if (!frame_only)
      r.warnings.push_back("URDF '" + path + "': link '" + child->name + "' (after moving joint '" + jt->name +
                           "') has no <inertial>: it moves no mass");
  }
  {
    std::string left;
    double mass = 0;
    std::vector<urdf::LinkConstSharedPtr> stack;
    for (const std::string& l : on_chain)
      for (const auto& ch : u->getLink(l)->child_links)
        if (!on_chain.count(ch->name)) stack.push_back(ch);
    while (!stack.empty()) {
      urdf::LinkConstSharedPtr l = stack.back();
      stack.pop_back();
      left += (left.empty() ? "" : ", ") + l->name;
      if (l->inertial) mass += l->inertial->mass;
      for (const auto& ch : l->child_links) stack.push_back(ch);
    }
    if (!left.empty()) {
      std::ostringstream os;
      os << "URDF '" << path << "': links off the chain " << base << " .. " << tip << " are left out: " << left << " ("
         << mass << " kg)";
      r.warnings.push_back(os.str());
    }
  }
  for (const auto& jt : chain) {
    urdf::LinkConstSharedPtr child = u->getLink(jt->child_link_name);
    Inertia I;
    if (child->inertial) {
      const auto& in = *child->inertial;
      if (in.mass < 0) fail(c, where, "URDF link '" + child->name + "': negative mass");
      Mat3 Ic;
      Ic << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
      const Transform X = pose(in.origin);
      I = Inertia(in.mass, X.p, X.R * Ic * X.R.transpose());
    }
    ChainJoint j;
    j.name = jt->name;
    j.link_name = child->name;
    j.X_origin = pose(jt->parent_to_joint_origin_transform);
    j.axis = Vec3(jt->axis.x, jt->axis.y, jt->axis.z);
    j.I = I;
    switch (jt->type) {
      case urdf::Joint::REVOLUTE:
      case urdf::Joint::CONTINUOUS: break;
      case urdf::Joint::PRISMATIC: j.prismatic = true; break;
      case urdf::Joint::FIXED: j.fixed = true; break;
      default: fail(c, where, "URDF joint '" + jt->name + "': only revolute, continuous, prismatic and fixed joints");
    }
    if (!j.fixed && !(j.axis.norm() > 0)) fail(c, where, "URDF joint '" + jt->name + "': zero axis");
    if (!j.fixed && jt->limits && jt->limits->effort > 0) j.tau_limit = jt->limits->effort;
    r.joints.push_back(j);
  }
  if (r.joints.empty()) fail(c, where, "URDF '" + path + "': no joints between '" + base + "' and '" + tip + "'");
  return r;
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

struct ArmSpec {
  std::string name;
  const Robot* robot = nullptr;
  Transform X_W_base;
  Transform tool;
  std::vector<double> q;
  std::vector<double> v;
  std::set<int> fixed;  // 1-based joint numbers held fixed
  bool grasp_given = false;
  Transform X_L_EE;
  std::array<double, 6> compliance{{0, 0, 0, 0, 0, 0}};
  YAML::Node node;
};

// the end-effector (before the tool) in the robot base frame at the arm's q
Transform chain_forward(const ArmSpec& a) {
  Transform X;
  for (size_t i = 0; i < a.robot->joints.size(); ++i) X = X * a.robot->joints[i].X_origin * chain_motion(a.robot->joints[i], a.q[i]);
  return X * a.robot->X_last_EE;
}

void set_floating_q(Eigen::VectorXd& q, int idx, const Transform& X) {
  q.segment<3>(idx) = X.p;
  Quat qu(X.R);
  qu.normalize();
  q[idx + 3] = qu.w();
  q[idx + 4] = qu.x();
  q[idx + 5] = qu.y();
  q[idx + 6] = qu.z();
}

struct Builder {
  Ctx c;
  System sys;
  std::vector<double> q0, v0;  // indexed like the model as it grows
  std::vector<unsigned char> q_given;  // (nq) the scene gave this coordinate's initial value
  std::vector<double> tau_lim;
  std::vector<int> q_floating_idx;

  int add(const std::string& name, int parent, const Transform& X_PJ, const Joint& j, const Inertia& I,
          const std::vector<double>& jq, const std::vector<double>& jv, double tau_limit, const YAML::Node& where) {
    int id;
    try {
      id = sys.model.add_body(name, parent, X_PJ, j, I);
    } catch (const std::invalid_argument& e) {
      fail(c, where, e.what());
    }
    const Joint& jj = sys.model.bodies[id].joint;
    for (int k = 0; k < jj.nq; ++k) {
      q0.push_back(k < static_cast<int>(jq.size()) ? jq[k] : 0.0);
      q_given.push_back(k < static_cast<int>(jq.size()) ? 1 : 0);
    }
    for (int k = 0; k < jj.nv; ++k) {
      v0.push_back(k < static_cast<int>(jv.size()) ? jv[k] : 0.0);
      tau_lim.push_back(tau_limit);
    }
    return id;
  }
};

void build_arms(Builder& B, const YAML::Node& root, const std::map<std::string, Robot>& robots, bool mobile_platform) {
  const Ctx& c = B.c;
  const YAML::Node load = require(c, root, "load", "scene");
  check_keys(c, load, {"name", "mass", "com", "inertia", "pose", "velocity", "actuated"}, "load");
  const std::string load_name = get_string(c, load, "name", "load");
  // the platform DOFs of the load take no command force unless the scene declares a drive on it
  // (thrusters, a positioner): tau_limit 0 = a command must be exactly 0 there (Reject::kUnactuated)
  const double load_limit = get_bool(c, load, "actuated", false) ? std::numeric_limits<double>::infinity() : 0.0;
  const Inertia I_load = get_inertia(c, load, "load");
  const Transform X_W_L = get_pose(c, require(c, load, "pose", "load"), "load.pose");

  std::vector<ArmSpec> arms;
  const YAML::Node an = require(c, root, "arms", "scene");
  if (!an.IsSequence() || an.size() == 0) fail(c, an, "arms must be a non-empty list");
  for (const auto& a : an) {
    check_keys(c, a, {"name", "robot", "base", "tool", "q", "v", "grasp", "fixed_joints", "compliance"}, "arm");
    ArmSpec s;
    s.node = YAML::Node(a);
    s.name = get_string(c, a, "name", "");
    if (s.name.empty()) fail(c, a, "arm: missing 'name'");
    const std::string rn = get_string(c, a, "robot", "");
    auto it = robots.find(rn);
    if (it == robots.end()) fail(c, a["robot"].IsDefined() ? a["robot"] : a, "arm '" + s.name + "': unknown robot '" + rn + "'");
    s.robot = &it->second;
    const int n = static_cast<int>(s.robot->joints.size());
    int nm = 0;  // joints that can move (a URDF's own fixed joints take no q)
    for (const ChainJoint& cj : s.robot->joints) nm += cj.fixed ? 0 : 1;
    s.X_W_base = get_pose(c, require(c, a, "base", "arm '" + s.name + "'"), "arm '" + s.name + "'.base");
    s.tool = get_pose(c, a["tool"], "arm '" + s.name + "'.tool");
    const std::vector<double> qm = as_list(c, require(c, a, "q", "arm '" + s.name + "'"), nm, "arm '" + s.name + "'.q");
    const std::vector<double> vm = a["v"] ? as_list(c, a["v"], nm, "arm '" + s.name + "'.v") : std::vector<double>(nm, 0.0);
    for (int i = 0, k = 0; i < n; ++i) {
      const bool f = s.robot->joints[i].fixed;
      s.q.push_back(f ? 0.0 : qm[k]);
      s.v.push_back(f ? 0.0 : vm[k]);
      k += f ? 0 : 1;
    }
    if (a["fixed_joints"]) {
      for (double x : as_list(c, a["fixed_joints"], -1, "arm '" + s.name + "'.fixed_joints")) {
        const int k = static_cast<int>(x);
        if (k < 1 || k > n) fail(c, a["fixed_joints"], "arm '" + s.name + "': fixed joint " + std::to_string(k) + " out of range");
        s.fixed.insert(k);
      }
    }
    const YAML::Node g = a["grasp"];
    if (g.IsDefined() && !g.IsNull() && !(g.IsScalar() && g.as<std::string>() == "at_initial_state")) {
      s.grasp_given = true;
      s.X_L_EE = get_pose(c, g, "arm '" + s.name + "'.grasp");
    }
    s.compliance = get_compliance(c, a["compliance"], "arm '" + s.name + "'.compliance");
    arms.push_back(s);
  }
  // grasps: given ones must close with the load pose, missing ones are read off the initial state
  for (ArmSpec& s : arms) {
    const Transform X_W_EE = s.X_W_base * chain_forward(s) * s.tool;
    if (s.grasp_given) {
      const Vec6 e = pose_error((X_W_L * s.X_L_EE).inverse() * X_W_EE);
      if (e.cwiseAbs().maxCoeff() > 1e-6) {
        std::ostringstream os;
        os << "initial state does not close: arm '" << s.name << "' end-effector misses its grasp on the load by "
           << e.tail<3>().norm() << " m and " << e.head<3>().norm() << " rad";
        fail(c, s.node, os.str());
      }
    } else {
      s.X_L_EE = X_W_L.inverse() * X_W_EE;
    }
  }

  Model& model = B.sys.model;
  ConstraintSet& cs = B.sys.constraints;
  Joint jf;
  jf.type = JointType::kFloating;
  jf.name = load_name;
  std::vector<double> lq(7, 0.0), lv(6, 0.0);
  {
    Eigen::VectorXd tmp(7);
    set_floating_q(tmp, 0, X_W_L);
    for (int k = 0; k < 7; ++k) lq[k] = tmp[k];
    if (load["velocity"]) {
      auto l = as_list(c, load["velocity"], 6, "load.velocity");
      for (int k = 0; k < 6; ++k) lv[k] = l[k];
    }
  }
  if (mobile_platform) {
    // the load is the root; each arm hangs from it last link first (METHOD s.3). Body B_k of the
    // reversed chain is link k's frame moved to joint k+1 (link_k * X_origin_{k+1}), so that joint
    // k+1 reversed is a plain motion about -axis at the origin of its parent.
    const int L = B.add(load_name, -1, Transform(), jf, I_load, lq, lv, load_limit, load);
    std::vector<WrenchOutput>& outs = B.sys.wrenches.outputs;
    for (const ArmSpec& s : arms) {
      const auto& J = s.robot->joints;
      const int n = static_cast<int>(J.size());
      Joint fixed;
      fixed.type = JointType::kFixed;
      int parent = B.add(s.name + "." + J[n - 1].link_name, L, s.X_L_EE * s.tool.inverse() * s.robot->X_last_EE.inverse(),
                         fixed, J[n - 1].I, {}, {}, 0, s.node);
      // the end-effector wrench is the reaction across the grasp: the load is the tree parent of the
      // arm's last link, framed and named as the classic form's grasp weld
      model.add_frame(s.name + ".ee", parent, s.robot->X_last_EE * s.tool);
      model.add_frame(load_name + "." + s.name, L, s.X_L_EE);
      {
        WrenchOutput o = joint_output(s.name + ".ee", s.name + ".ee", load_name + "." + s.name, parent, false, parent,
                                      s.robot->X_last_EE * s.tool, 0x3f);
        o.kind = WrenchKind::kEndEffector;
        outs.push_back(o);
      }
      std::vector<WrenchOutput> arm_joints;
      for (int i = n; i >= 1; --i) {
        const ChainJoint& cj = J[i - 1];
        const int link_i = parent;  // the tree parent of joint i reversed is link i's side
        Joint j;
        const bool held = cj.fixed || s.fixed.count(i);
        j.type = held ? JointType::kFixed : (cj.prismatic ? JointType::kPrismatic : JointType::kRevolute);
        j.axis = -cj.axis;
        j.name = s.name + "." + cj.name;
        j.armature = cj.armature;
        Transform X_PJ = i == n ? Transform() : J[i].X_origin.inverse();
        if (held) X_PJ = X_PJ * chain_motion(cj, -s.q[i - 1]);
        // the arm's base is welded to the world, so its inertia does no work; a nominal rotational
        // inertia (no mass, hence no weight) keeps M regular for the joint that moves only the base
        const Inertia I = i > 1 ? J[i - 2].I.transformed(cj.X_origin.inverse()) : Inertia(0.0, Vec3::Zero(), 1e-3 * Mat3::Identity());
        const std::string body = s.name + "." + (i > 1 ? J[i - 2].link_name : s.robot->base_link);
        parent = B.add(body, parent, X_PJ, j, I, {s.q[i - 1]}, {s.v[i - 1]}, cj.tau_limit, s.node);
        // the reaction of link i-1 on link i is the tree's reaction negated, framed in link i: the
        // joint frame of the reversed joint (X_PJ without a held joint's motion)
        arm_joints.push_back(joint_output(s.name + "." + cj.name, s.name + "." + cj.link_name, body, parent, true, link_i,
                                          i == n ? Transform() : J[i].X_origin.inverse(),
                                          held ? 0x3f : bearing_mask(j.type, cj.axis, cj.axis)));
      }
      outs.insert(outs.end(), arm_joints.rbegin(), arm_joints.rend());  // in the robot's order, as classic
      model.add_frame(s.name + ".base", parent, J[0].X_origin.inverse());
      ConstraintSpec w;
      w.name = s.name + ".base";
      w.kind = ConstraintKind::kWeld;
      w.frame_a = model.frame_index(s.name + ".base");
      w.frame_b = -1;
      w.X_WA_target = s.X_W_base;
      w.compliance = s.compliance;
      cs.specs.push_back(w);
      WrenchOutput o;
      o.name = o.frame = s.name + ".base";
      o.by = "world";
      o.kind = WrenchKind::kBase;
      o.spec = static_cast<int>(cs.specs.size()) - 1;
      outs.push_back(o);
    }
  } else {
    std::vector<WrenchOutput>& outs = B.sys.wrenches.outputs;
    for (const ArmSpec& s : arms) {
      const auto& J = s.robot->joints;
      const int n = static_cast<int>(J.size());
      int parent = -1;
      for (int i = 1; i <= n; ++i) {
        const ChainJoint& cj = J[i - 1];
        Joint j;
        const bool held = cj.fixed || s.fixed.count(i);
        j.type = held ? JointType::kFixed : (cj.prismatic ? JointType::kPrismatic : JointType::kRevolute);
        j.axis = cj.axis;
        j.name = s.name + "." + cj.name;
        j.armature = cj.armature;
        Transform X_PJ = (i == 1 ? s.X_W_base : Transform()) * cj.X_origin;
        if (held) X_PJ = X_PJ * chain_motion(cj, s.q[i - 1]);
        parent = B.add(s.name + "." + cj.link_name, parent, X_PJ, j, cj.I, {s.q[i - 1]}, {s.v[i - 1]}, cj.tau_limit, s.node);
        const std::string by = s.name + "." + (i > 1 ? J[i - 2].link_name : s.robot->base_link);
        outs.push_back(joint_output(s.name + "." + cj.name, s.name + "." + cj.link_name, by, parent, false, parent,
                                    Transform(), held ? 0x3f : bearing_mask(j.type, cj.axis, cj.axis)));
        if (i == 1) {  // the base wrench is the reaction at joint 1, in the base frame
          model.add_frame(s.name + ".base", -1, s.X_W_base);
          WrenchOutput o = joint_output(s.name + ".base", s.name + ".base", "world", parent, false, -1, s.X_W_base, 0x3f);
          o.kind = WrenchKind::kBase;
          outs.push_back(o);
        }
      }
      model.add_frame(s.name + ".ee", parent, s.robot->X_last_EE * s.tool);
    }
    const int L = B.add(load_name, -1, Transform(), jf, I_load, lq, lv, load_limit, load);
    for (const ArmSpec& s : arms) {
      model.add_frame(load_name + "." + s.name, L, s.X_L_EE);
      ConstraintSpec w;
      w.name = s.name + ".ee";
      w.kind = ConstraintKind::kWeld;
      w.frame_a = model.frame_index(s.name + ".ee");
      w.frame_b = model.frame_index(load_name + "." + s.name);
      w.compliance = s.compliance;
      cs.specs.push_back(w);
      WrenchOutput o;
      o.name = o.frame = s.name + ".ee";
      o.by = load_name + "." + s.name;
      o.kind = WrenchKind::kEndEffector;
      o.spec = static_cast<int>(cs.specs.size()) - 1;
      outs.push_back(o);
    }
  }
}

void build_bodies(Builder& B, const YAML::Node& root) {
  const Ctx& c = B.c;
  Model& model = B.sys.model;
  const YAML::Node bn = require(c, root, "bodies", "scene");
  if (!bn.IsSequence() || bn.size() == 0) fail(c, bn, "bodies must be a non-empty list");
  for (const auto& b : bn) {
    check_keys(c, b, {"name", "parent", "placement", "joint", "mass", "com", "inertia"}, "body");
    const std::string name = get_string(c, b, "name", "");
    if (name.empty()) fail(c, b, "body: missing 'name'");
    const std::string pn = get_string(c, b, "parent", "world");
    int parent = -1;
    if (pn != "world") {
      parent = model.body_index(pn);
      if (parent < 0) fail(c, b["parent"], "body '" + name + "': unknown parent '" + pn + "' (parents must come first)");
    }
    const Transform X_PJ = get_pose(c, b["placement"], "body '" + name + "'.placement");
    const Inertia I = get_inertia(c, b, "body '" + name + "'");
    Joint j;
    std::vector<double> jq, jv;
    const YAML::Node jn = b["joint"];
    if (!jn.IsDefined() || jn.IsNull()) {
      j.type = JointType::kFixed;
    } else {
      check_keys(c, jn, {"type", "axis", "axis2", "name", "pseudo", "q", "v", "armature", "tau_limit", "actuated"},
                 "joint of '" + name + "'");
      const std::string t = get_string(c, jn, "type", "");
      if (t == "fixed") j.type = JointType::kFixed;
      else if (t == "revolute") j.type = JointType::kRevolute;
      else if (t == "prismatic") j.type = JointType::kPrismatic;
      else if (t == "revolute2") j.type = JointType::kRevolute2;
      else if (t == "floating") j.type = JointType::kFloating;
      else fail(c, jn["type"].IsDefined() ? jn["type"] : jn, "body '" + name + "': unknown joint type '" + t +
                "' (fixed, revolute, prismatic, revolute2, floating)");
      if (jn["axis"]) j.axis = as_vec3(c, jn["axis"], "joint axis");
      if (jn["axis2"]) j.axis2 = as_vec3(c, jn["axis2"], "joint axis2");
      j.name = get_string(c, jn, "name", name);
      j.pseudo = get_bool(c, jn, "pseudo", false);
      j.armature = get_double(c, jn, "armature", 0.0, "joint");
      if (!(j.armature >= 0)) fail(c, jn["armature"], "body '" + name + "': armature must be >= 0");
      if (j.pseudo && j.type != JointType::kRevolute && j.type != JointType::kPrismatic)
        fail(c, jn, "body '" + name + "': a pseudo-joint must be revolute or prismatic");
      if (j.type == JointType::kFloating) {
        Eigen::VectorXd tmp(7);
        set_floating_q(tmp, 0, get_pose(c, jn["q"], "floating joint q"));
        jq.assign(tmp.data(), tmp.data() + 7);
        jv = jn["v"] ? as_list(c, jn["v"], 6, "joint v") : std::vector<double>(6, 0.0);
      } else {
        const int nq = joint_nq(j.type);
        if (jn["q"]) jq = jn["q"].IsSequence() ? as_list(c, jn["q"], nq, "joint q") : std::vector<double>{as_double(c, jn["q"], "joint q")};
        if (jn["v"]) jv = jn["v"].IsSequence() ? as_list(c, jn["v"], nq, "joint v") : std::vector<double>{as_double(c, jn["v"], "joint v")};
        if (static_cast<int>(jq.size()) > nq || static_cast<int>(jv.size()) > nq) fail(c, jn, "body '" + name + "': too many q/v values");
      }
    }
    double lim = std::numeric_limits<double>::infinity();
    if (jn.IsDefined() && !jn.IsNull()) {
      // a floating joint (a vehicle's body, a free wheel) and a pseudo-joint (absent from the real
      // structure) have no drive: unactuated (tau_limit 0) unless declared; any other joint is
      // actuated unless `actuated: false` (a passive joint)
      const bool by_default = j.type != JointType::kFloating && !j.pseudo;
      const bool actuated = get_bool(c, jn, "actuated", by_default);
      if (actuated && j.pseudo) fail(c, jn["actuated"], "body '" + name + "': a pseudo-joint cannot be actuated");
      if (!actuated && jn["tau_limit"])
        fail(c, jn["tau_limit"], "body '" + name + "': tau_limit on an unactuated joint (" +
                                     (j.type == JointType::kFloating ? "a floating joint needs 'actuated: true'" : "it is declared or pseudo") + ")");
      lim = actuated ? get_double(c, jn, "tau_limit", std::numeric_limits<double>::infinity(), "joint") : 0.0;
      if (!(lim >= 0)) fail(c, jn["tau_limit"], "body '" + name + "': tau_limit must be >= 0 (N*m or N; absent = no limit)");
    }
    const int id = B.add(name, parent, X_PJ, j, I, jq, jv, lim, b);
    if (j.type != JointType::kFloating)  // a floating joint transmits nothing
      B.sys.wrenches.outputs.push_back(joint_output(j.name.empty() ? name : j.name, name,
                                                    parent >= 0 ? model.bodies[parent].name : "world", id, false, id,
                                                    Transform(), bearing_mask(j.type, j.axis, j.axis2)));
  }
  if (root["frames"]) {
    for (const auto& f : root["frames"]) {
      check_keys(c, f, {"name", "body", "xyz", "rpy"}, "frame");
      const std::string fname = get_string(c, f, "name", "");
      const std::string bname = get_string(c, f, "body", "world");
      int body = -1;
      if (bname != "world") {
        body = model.body_index(bname);
        if (body < 0) fail(c, f, "frame '" + fname + "': unknown body '" + bname + "'");
      }
      Transform X;
      if (f["xyz"]) X.p = as_vec3(c, f["xyz"], "frame xyz");
      if (f["rpy"]) X.R = rpy_matrix(as_vec3(c, f["rpy"], "frame rpy"));
      try {
        model.add_frame(fname, body, X);
      } catch (const std::invalid_argument& e) {
        fail(c, f, e.what());
      }
    }
  }
  if (root["constraints"]) {
    for (const auto& k : root["constraints"]) {
      check_keys(c, k, {"name", "type", "frame", "to", "axes", "target", "compliance", "body", "axle", "radius"}, "constraint");
      ConstraintSpec s;
      s.name = get_string(c, k, "name", "");
      const std::string type = get_string(c, k, "type", "weld");
      if (type == "rolling") {
        // a wheel rolling without slip on the ground z = 0 (ConstraintKind::kRolling)
        for (const char* key : {"frame", "to", "axes", "target"})
          if (k[key]) fail(c, k[key], "constraint '" + s.name + "': '" + key + "' does not apply to a rolling wheel");
        s.kind = ConstraintKind::kRolling;
        const std::string bname = get_string(c, k, "body", "");
        s.body = model.body_index(bname);
        if (s.body < 0) fail(c, k["body"].IsDefined() ? k["body"] : k, "constraint '" + s.name + "': unknown wheel body '" + bname + "'");
        if (s.name.empty()) s.name = bname;
        const Vec3 axle = as_vec3(c, require(c, k, "axle", "constraint '" + s.name + "'"), "constraint '" + s.name + "'.axle");
        const double axle_norm = axle.norm();  // inf when a component is near DBL_MAX (the square overflows)
        if (!(axle_norm >= 1e-9 && axle_norm <= 1e150))
          fail(c, k["axle"], "constraint '" + s.name + "': axle must be a nonzero vector of norm at most 1e150");
        s.axle = axle.normalized();
        s.radius = as_double(c, require(c, k, "radius", "constraint '" + s.name + "'"), "constraint '" + s.name + "'.radius");
        if (!(s.radius > 0)) fail(c, k["radius"], "constraint '" + s.name + "': radius must be > 0");
        if (k["compliance"]) {  // scalar or [x, y, z] of the contact frame (m/N)
          const YAML::Node cn = k["compliance"];
          std::vector<double> l = cn.IsScalar() ? std::vector<double>(3, as_double(c, cn, "compliance"))
                                                : as_list(c, cn, 3, "constraint '" + s.name + "'.compliance");
          for (int i = 0; i < 3; ++i) {
            if (l[i] < 0) fail(c, cn, "constraint '" + s.name + "': compliance must be >= 0");
            s.compliance[3 + i] = l[i];
          }
        }
        s.axes = {{false, false, false, true, true, true}};
        B.sys.constraints.specs.push_back(s);
        continue;
      }
      for (const char* key : {"body", "axle", "radius"})
        if (k[key]) fail(c, k[key], "constraint '" + s.name + "': '" + key + "' only applies to type rolling");
      if (type != "weld" && type != "point") fail(c, k, "constraint '" + s.name + "': unknown type '" + type + "' (weld, point, rolling)");
      const std::string fa = get_string(c, k, "frame", "");
      s.frame_a = model.frame_index(fa);
      if (s.frame_a < 0) fail(c, k["frame"].IsDefined() ? k["frame"] : k, "constraint '" + s.name + "': unknown frame '" + fa + "'");
      if (s.name.empty()) s.name = fa;
      const std::string to = get_string(c, k, "to", "world");
      if (to != "world") {
        s.frame_b = model.frame_index(to);
        if (s.frame_b < 0) fail(c, k["to"], "constraint '" + s.name + "': unknown frame '" + to + "'");
      }
      s.axes = type == "point" ? std::array<bool, 6>{{false, false, false, true, true, true}} : get_axes(c, k["axes"], "constraint '" + s.name + "'");
      s.compliance = get_compliance(c, k["compliance"], "constraint '" + s.name + "'.compliance");
      if (k["target"]) {
        if (s.frame_b >= 0) fail(c, k["target"], "constraint '" + s.name + "': 'target' only applies to welds to the world");
        s.X_WA_target = get_pose(c, k["target"], "constraint target");
      } else {
        s.X_WA_target.p.setConstant(std::numeric_limits<double>::quiet_NaN());  // read off q0 below
      }
      B.sys.constraints.specs.push_back(s);
    }
  }
}

// Completes the wrench outputs (wrench_outputs.h): the builders listed end-effectors, bases and joint
// reactions; here every other constraint becomes a tip, every wheel on a jointed parent an axle, and
// `reactions: all | none | [joint, ...]` (default none) selects the joint reactions.
void build_wrench_outputs(const Ctx& c, const YAML::Node& root, System& sys) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  std::vector<WrenchOutput>& outs = sys.wrenches.outputs;
  std::vector<char> listed(cs.specs.size(), 0);
  for (const WrenchOutput& o : outs)
    if (o.spec >= 0) listed[o.spec] = 1;
  for (size_t k = 0; k < cs.specs.size(); ++k) {
    const ConstraintSpec& cp = cs.specs[k];
    if (listed[k] || cp.kind == ConstraintKind::kLock) continue;
    WrenchOutput o;
    o.kind = WrenchKind::kTip;
    o.spec = static_cast<int>(k);
    o.name = cp.name;
    uint8_t mask = 0;
    for (int a = 0; a < 6; ++a)
      if (cp.axes[a]) mask = static_cast<uint8_t>(mask | (1u << a));
    o.constrained = mask;
    if (cp.kind == ConstraintKind::kRolling) {
      o.frame = cp.name + ".contact";
      o.by = "ground";
      outs.push_back(o);
      const Body& wb = model.bodies[cp.body];
      if (wb.parent >= 0 && wb.joint.type != JointType::kFloating) {
        WrenchOutput x;
        x.kind = WrenchKind::kAxle;
        x.name = cp.name + ".axle";
        x.frame = cp.name + ".centre";
        x.by = model.bodies[wb.parent].name;
        x.body = cp.body;
        x.centre_of = static_cast<int>(k);
        x.constrained = 0x3d;  // all but my: the drive torque about the lateral axis (an upright wheel)
        outs.push_back(x);
      }
    } else {
      o.frame = model.frames[cp.frame_a].name;
      o.by = cp.frame_b < 0 ? "world" : model.frames[cp.frame_b].name;
      outs.push_back(o);
    }
  }
  // joint reactions: none unless asked for (a scene pays only for what it publishes)
  const YAML::Node rn = root["reactions"];
  std::set<std::string> keep;
  bool all = false;
  if (rn.IsDefined() && !rn.IsNull()) {
    if (rn.IsScalar() && (rn.as<std::string>() == "all" || rn.as<std::string>() == "none")) {
      all = rn.as<std::string>() == "all";
    } else if (rn.IsSequence()) {
      std::set<std::string> joints;
      for (const WrenchOutput& o : outs)
        if (o.kind == WrenchKind::kJoint) joints.insert(o.name);
      for (const auto& x : rn) {
        const std::string nm = x.IsScalar() ? x.as<std::string>() : "";
        if (!joints.count(nm)) {
          std::string list;
          for (const auto& j : joints) list += (list.empty() ? "" : ", ") + j;
          fail(c, x, "reactions: unknown joint '" + nm + "' (joints: " + list + ")");
        }
        if (!keep.insert(nm).second) fail(c, x, "reactions: joint '" + nm + "' listed twice");
      }
    } else {
      fail(c, rn, "reactions must be all, none or a list of joint names");
    }
  }
  outs.erase(std::remove_if(outs.begin(), outs.end(),
                            [&](const WrenchOutput& o) { return o.kind == WrenchKind::kJoint && !all && !keep.count(o.name); }),
             outs.end());
  std::set<std::string> names;
  for (const WrenchOutput& o : outs)
    if (!names.insert(o.name).second)
      fail(c, rn.IsDefined() ? rn : root, "two reported wrenches are named '" + o.name +
                                              "' (a joint and a constraint?): rename one of them");
}

}  // namespace

namespace {
// The YAML entry of a constraint, by name (for errors); the scene's root if it has none of its own.
YAML::Node constraint_node(const YAML::Node& root, const std::string& name) {
  const YAML::Node cs = root["constraints"];
  if (cs && cs.IsSequence())
    for (const YAML::Node& n : cs)
      if (n.IsMap() && n["name"] && n["name"].IsScalar() && n["name"].Scalar() == name) return n;
  return root;
}

// Gauss-Newton on the holonomic rows' position error over the velocity coordinates `cols`
// (min-norm steps), then v projected onto G v = 0 over all non-pseudo coordinates. Returns the
// largest position error left.
double close_over(const System& sys, const std::vector<int>& cols, Eigen::VectorXd& q) {
  const Model& m = sys.model;
  const ConstraintSet& set = sys.constraints;
  Data d(m);
  ConstraintData cd(m, set);
  std::vector<int> hol;
  for (size_t s = 0; s < set.specs.size(); ++s)
    for (int k = 0; k < set.row_count[s]; ++k)
      if (set.specs[s].kind != ConstraintKind::kRolling || set.row_axis[s][k] == 5) hol.push_back(set.row_offset[s] + k);
  Eigen::MatrixXd J(hol.size(), cols.size());
  Eigen::VectorXd e(hol.size()), dv = Eigen::VectorXd::Zero(m.nv());
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(m.nv());
  auto error_at = [&](const Eigen::VectorXd& qq, bool fill) {
    forward_kinematics(m, d, qq, v0);
    constraint_rows(m, d, set, qq, v0, cd);
    double e2 = 0;
    for (size_t i = 0; i < hol.size(); ++i) {
      e2 += cd.err[hol[i]] * cd.err[hol[i]];
      if (!fill) continue;
      e[i] = cd.err[hol[i]];
      for (size_t j = 0; j < cols.size(); ++j) J(i, j) = cd.G(hol[i], cols[j]);
    }
    return e2;
  };
  double e2 = error_at(q, true);
  Eigen::VectorXd q_try = q;
  for (int it = 0; it < 200 && e2 > 1e-28 && !cols.empty(); ++it) {
    const Eigen::VectorXd x = J.completeOrthogonalDecomposition().solve(e);
    // Gauss-Newton step, halved until the squared error drops (at most 0.5 rad or m per step)
    double step = std::min(1.0, 0.5 / std::max(1e-300, x.cwiseAbs().maxCoeff()));
    bool improved = false;
    for (int h = 0; h < 30 && !improved; ++h, step *= 0.5) {
      dv.setZero();
      for (size_t j = 0; j < cols.size(); ++j) dv[cols[j]] = -step * x[j];
      integrate(m, q, dv, 1.0, q_try);
      normalize_configuration(m, q_try);
      const double e2_try = error_at(q_try, false);
      if (e2_try < e2) {
        q = q_try;
        e2 = error_at(q, true);
        improved = true;
      }
    }
    if (!improved) break;  // a least-squares minimum that does not close (or round-off)
  }
  error_at(q, true);
  return e.size() ? e.cwiseAbs().maxCoeff() : 0.0;
}

void close_initial_state(System& sys, const std::vector<unsigned char>& q_given, const std::vector<unsigned char>& keep,
                         std::vector<std::string>* warnings) {
  const Model& m = sys.model;
  const ConstraintSet& set = sys.constraints;
  if (set.rows == 0) return;
  Data d(m);
  ConstraintData cd(m, set);
  forward_kinematics(m, d, sys.q0, sys.v0);
  constraint_rows(m, d, set, sys.q0, sys.v0, cd);
  const double e0 = cd.err.cwiseAbs().maxCoeff(), g0 = cd.Gv.cwiseAbs().maxCoeff();
  const Eigen::VectorXd q_scene = sys.q0;
  if (e0 > 1e-9) {
    // with a keep list: every joint but those; else first the coordinates the scene gave no value,
    // then all (least change); pseudo-joints never (they are locked where the scene puts them)
    std::vector<int> open, all;
    for (int bi = 0; bi < m.nbodies(); ++bi) {
      const Joint& j = m.bodies[bi].joint;
      if (j.pseudo) continue;
      bool given = false;
      for (int k = 0; k < j.nq; ++k) given = given || q_given[j.idx_q + k];
      const bool kept = !keep.empty() && keep[bi];
      for (int k = 0; k < j.nv; ++k) {
        if (!kept) all.push_back(j.idx_v + k);
        if (!given && keep.empty()) open.push_back(j.idx_v + k);
      }
    }
    Eigen::VectorXd q = sys.q0;
    double left = HUGE_VAL;
    const char* which = "every joint not in close_initial_state.keep";
    if (keep.empty()) {
      left = close_over(sys, open, q);
      which = "the coordinates the scene gives no initial value";
    }
    if (left > 1e-10) {
      q = sys.q0;
      left = close_over(sys, all, q);
      if (keep.empty()) which = "every coordinate (least change)";
    }
    if (left > 1e-6) return;  // the caller reports the constraint that stays open
    sys.q0 = q;
    std::ostringstream os;
    os.precision(6);
    os << "initial state: the constraints were open by " << e0 << " (rad, m); closed to " << left << " by moving " << which << ":";
    int listed = 0;
    for (int i = 0; i < m.nq(); ++i)
      if (std::abs(sys.q0[i] - q_scene[i]) > 1e-12) {
        if (listed++ < 12) os << " " << m.q_names[i] << " " << q_scene[i] << " -> " << sys.q0[i];
      }
    if (listed > 12) os << " (and " << listed - 12 << " more)";
    os << " (close_initial_state: false keeps the scene's values and makes this an error)";
    warnings->push_back(os.str());
    // the locks hold the pseudo-joints where they are; welds to the world keep their targets
  }
  forward_kinematics(m, d, sys.q0, sys.v0);
  constraint_rows(m, d, set, sys.q0, sys.v0, cd);
  const double g1 = cd.Gv.cwiseAbs().maxCoeff();
  if (g1 > 1e-9) {
    std::vector<int> cols;
    for (int i = 0; i < m.nv(); ++i)
      if (!m.bodies[m.dof_body[i]].joint.pseudo) cols.push_back(i);
    Eigen::MatrixXd G(set.rows, cols.size());
    for (size_t j = 0; j < cols.size(); ++j) G.col(j) = cd.G.col(cols[j]);
    const Eigen::VectorXd x = G.completeOrthogonalDecomposition().solve(cd.Gv);
    const Eigen::VectorXd v_scene = sys.v0;
    for (size_t j = 0; j < cols.size(); ++j) sys.v0[cols[j]] -= x[j];
    std::ostringstream os;
    os.precision(6);
    os << "initial velocity: projected onto the constraints (velocity error " << std::max(g0, g1) << " -> 0):";
    for (int i = 0; i < m.nv(); ++i)
      if (std::abs(sys.v0[i] - v_scene[i]) > 1e-12) os << " " << m.v_names[i] << " " << v_scene[i] << " -> " << sys.v0[i];
    warnings->push_back(os.str());
  }
}
}  // namespace

System load_scene_string(const std::string& text, const std::string& file, const SceneOverrides& ov) {
  Builder B;
  B.c.file = file;
  B.c.dir = std::filesystem::path(file).parent_path().string();
  const Ctx& c = B.c;
  check_yaml_text(text, file);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::DeepRecursion& e) {
    throw SceneError(file + ": YAML nested deeper than yaml-cpp's limit of " + std::to_string(e.depth()) + " levels");
  } catch (const YAML::ParserException& e) {
    throw SceneError(bounded::cut_values(file + ":" + std::to_string(e.mark.line + 1) + ":" +
                                      std::to_string(e.mark.column + 1) + ": YAML syntax error: " + e.msg));
  }
  if (!root.IsMap()) fail(c, root, "a scene must be a YAML mapping");
  try {
    check_keys(c, root, {"name", "description", "source", "gravity", "formulation", "redundancy", "stabilization", "solver",
                         "robots", "load", "arms", "bodies", "frames", "constraints", "reactions", "close_initial_state"},
               "scene");
    System& sys = B.sys;
    sys.name = get_string(c, root, "name", std::filesystem::path(file).stem().string());
    if (root["gravity"]) sys.model.gravity_W = as_vec3(c, root["gravity"], "gravity");
    const std::string fs = get_string(c, root, "formulation", "mobile_platform");
    if (!parse_formulation(fs, &sys.options.formulation))
      fail(c, root["formulation"], "unknown formulation '" + fs + "' (mobile_platform, classic, pseudo_joint, svd)");
    if (ov.formulation) sys.options.formulation = *ov.formulation;
    const std::string red = get_string(c, root, "redundancy", "min_norm");
    if (red == "min_norm") sys.options.redundancy = Redundancy::kMinNorm;
    else if (red == "compliance") sys.options.redundancy = Redundancy::kCompliance;
    else fail(c, root["redundancy"], "unknown redundancy rule '" + red + "' (min_norm, compliance)");
    if (root["stabilization"]) {
      const YAML::Node st = root["stabilization"];
      if (st.IsScalar() && st.as<std::string>() == "none") {
      } else {
        check_keys(c, st, {"baumgarte", "projection"}, "stabilization");
        if (st["projection"]) {
          check_keys(c, st["projection"], {"iterations"}, "stabilization.projection");
          const double it = get_double(c, st["projection"], "iterations", 3, "projection");
          if (it < 1 || it > 50) fail(c, st["projection"], "projection iterations must be in 1..50");
          sys.options.projection_iterations = static_cast<int>(it);
        }
      }
      if (st.IsMap() && st["baumgarte"]) {
        const YAML::Node bg = st["baumgarte"];
        check_keys(c, bg, {"alpha", "beta"}, "stabilization.baumgarte");
        sys.constraints.stabilize = true;
        sys.constraints.baumgarte_alpha = get_double(c, bg, "alpha", 0.0, "baumgarte");
        sys.constraints.baumgarte_beta = get_double(c, bg, "beta", 0.0, "baumgarte");
        if (sys.constraints.baumgarte_alpha < 0 || sys.constraints.baumgarte_beta < 0)
          fail(c, bg, "Baumgarte gains must be >= 0");
      }
    }
    if (root["solver"]) {  // divergence bound of step() (SolverOptions::max_speed)
      const YAML::Node so = root["solver"];
      if (!so.IsMap()) fail(c, so, "'solver' must be a mapping, e.g. {max_speed: 1e4}");
      check_keys(c, so, {"max_speed"}, "solver");
      const YAML::Node ms = so["max_speed"];
      if (ms.IsScalar() && ms.as<std::string>() == "off") sys.options.max_speed = std::numeric_limits<double>::infinity();
      else sys.options.max_speed = get_double(c, so, "max_speed", sys.options.max_speed, "solver");
      if (!(sys.options.max_speed > 0)) fail(c, ms, "solver.max_speed must be > 0 (rad/s or m/s per DOF) or 'off'");
    }
    std::map<std::string, Robot> robots;
    if (root["robots"]) {
      for (const auto& kv : root["robots"]) {
        const std::string rn = kv.first.as<std::string>();
        YAML::Node rnode = kv.second;
        if (rnode["urdf"]) {
          check_keys(c, rnode, {"urdf", "base", "tip", "source"}, "robot '" + rn + "'");
          const std::string path = (std::filesystem::path(c.dir) / rnode["urdf"].as<std::string>()).string();
          robots[rn] = parse_urdf(c, rnode["urdf"], path, rn, get_string(c, rnode, "base", ""), get_string(c, rnode, "tip", ""));
        } else if (rnode["file"]) {
          const std::string rel = rnode["file"].as<std::string>();
          const std::string path = (std::filesystem::path(c.dir) / rel).string();
          Ctx rc{path, std::filesystem::path(path).parent_path().string()};
          YAML::Node rf = load_yaml_file(c, path, rnode["file"]);
          robots[rn] = parse_robot(rc, rf, rn);
        } else {
          robots[rn] = parse_robot(c, rnode, rn);
        }
      }
    }
    for (const auto& [rn, rb] : robots) sys.warnings.insert(sys.warnings.end(), rb.warnings.begin(), rb.warnings.end());
    const bool has_arms = root["arms"].IsDefined(), has_bodies = root["bodies"].IsDefined();
    if (has_arms == has_bodies) fail(c, root, "a scene declares either 'arms' (with a 'load') or 'bodies', not both or neither");
    if (has_arms) {
      // the SVD baseline is the paper's, in its classic setting (METHOD s.6): arms rooted at the world
      build_arms(B, root, robots,
                 sys.options.formulation != Formulation::kClassic && sys.options.formulation != Formulation::kSvdBaseline);
    } else {
      if (sys.options.formulation == Formulation::kClassic && root["formulation"].as<std::string>("") != "classic")
        fail(c, root, "formulation classic applies to scenes with arms holding a load");
      build_bodies(B, root);
    }
    Model& model = sys.model;
    sys.q0 = Eigen::Map<Eigen::VectorXd>(B.q0.data(), static_cast<Eigen::Index>(B.q0.size()));
    sys.v0 = Eigen::Map<Eigen::VectorXd>(B.v0.data(), static_cast<Eigen::Index>(B.v0.size()));
    sys.tau_limit = Eigen::Map<Eigen::VectorXd>(B.tau_lim.data(), static_cast<Eigen::Index>(B.tau_lim.size()));

    // pseudo-joint locks are rows of the solve, except in the explicit Schur form (24)-(26)
    if (sys.options.formulation != Formulation::kPseudoJointSchur) {
      for (int d : model.pseudo_dofs) {
        ConstraintSpec s;
        s.kind = ConstraintKind::kLock;
        s.dof = d;
        const Body& body = model.bodies[model.dof_body[d]];
        s.name = "lock:" + body.joint.name;
        s.q_index = body.joint.idx_q + (d - body.joint.idx_v);
        s.q_target = sys.q0[s.q_index];
        sys.constraints.specs.push_back(s);
      }
    }
    build_wrench_outputs(c, root, sys);
    // welds to the world without an explicit target hold the frame where q0 puts it
    Data data(model);
    forward_kinematics(model, data, sys.q0, sys.v0);
    for (ConstraintSpec& s : sys.constraints.specs)
      if (s.kind == ConstraintKind::kWeld && s.frame_b < 0 && !s.X_WA_target.p.allFinite())
        s.X_WA_target = frame_pose(model, data, s.frame_a);
    sys.constraints.compile(model);
    sys.wrenches.compile(model, sys.constraints);

    // The initial state must satisfy the constraints: loops close themselves (close_initial_state,
    // on by default) by moving the coordinates the scene left without a value, else all of them,
    // and the velocity is projected onto the constraints; what moved is reported in the warnings.
    // What cannot be closed is an error at the constraint, per axis.
    // close_initial_state: true (default) | false | {keep: [JOINT, ...]}: the joints whose given
    // values are kept (then every other joint may move)
    bool close = true;
    std::vector<unsigned char> keep;  // per body: its joint is kept; empty: no keep list
    if (const YAML::Node ci = root["close_initial_state"]; ci && ci.IsMap()) {
      check_keys(c, ci, {"keep"}, "close_initial_state");
      keep.assign(model.nbodies(), 0);
      const YAML::Node kl = ci["keep"];
      if (!kl || !kl.IsSequence()) fail(c, ci, "close_initial_state.keep must be a list of joint names");
      for (const YAML::Node& k : kl) {
        const int b = k.IsScalar() ? model.joint_index(k.Scalar()) : -1;
        if (b < 0) fail(c, k, "close_initial_state.keep: unknown joint '" + (k.IsScalar() ? k.Scalar() : std::string("?")) + "'");
        keep[b] = 1;
      }
    } else {
      close = get_bool(c, root, "close_initial_state", true);
    }
    if (close) close_initial_state(sys, B.q_given, keep, &sys.warnings);
    ConstraintData cd(model, sys.constraints);
    forward_kinematics(model, data, sys.q0, sys.v0);
    constraint_rows(model, data, sys.constraints, sys.q0, sys.v0, cd);
    for (size_t s = 0; s < sys.constraints.specs.size(); ++s) {
      const int r0 = sys.constraints.row_offset[s], n = sys.constraints.row_count[s];
      const double pe = cd.err.segment(r0, n).cwiseAbs().maxCoeff();
      const double ve = cd.Gv.segment(r0, n).cwiseAbs().maxCoeff();
      if (pe > 1e-6 || ve > 1e-6) {
        static const char* const axis[6] = {"rx", "ry", "rz", "x", "y", "z"};
        const ConstraintSpec& sp = sys.constraints.specs[s];
        std::ostringstream os;
        os << (pe > 1e-6 ? "initial state does not close constraint '" : "initial velocity violates constraint '") << sp.name
           << "'" << (close ? " (close_initial_state could not close it)" : "") << ": "
           << (pe > 1e-6 ? "position error" : "velocity error") << " per axis";
        for (int k = 0; k < n; ++k) {
          const int ax = sys.constraints.row_axis[s][k];
          os << " " << (sp.kind == ConstraintKind::kLock ? "q" : axis[ax]) << " " << (pe > 1e-6 ? cd.err[r0 + k] : cd.Gv[r0 + k]);
        }
        os << (sp.kind == ConstraintKind::kWeld ? " (rad, m; in the tip frame)" : "");
        fail(c, constraint_node(root, sp.name), os.str());
      }
    }
    crba(model, data);
    int bad = -1;
    if (!tree_cholesky_factor(model, data, 1e-13, &bad)) {
      fail(c, root, "mass matrix is singular at the initial state: velocity coordinate '" + model.v_names[bad] +
                        "' moves no mass (give its subtree a mass or inertia, or the joint an armature)");
    }
    return sys;
  } catch (const SceneError& e) {
    throw SceneError(bounded::cut_values(e.what()));  // no echoed value longer than 80 characters
  } catch (const YAML::Exception& e) {
    throw SceneError(bounded::cut_values(file + ":" + std::to_string(e.mark.line + 1) + ":" +
                                      std::to_string(e.mark.column + 1) + ": " + e.msg));
  }
}

System load_scene(const std::string& path, const SceneOverrides& ov) {
  std::string text, why;
  if (!bounded::read_file(path, bounded::kMaxYamlBytes, "scene file", &text, &why)) throw SceneError(path + ": " + why);
  return load_scene_string(text, path, ov);
}

}  // namespace coopdyn
