#include "service/scene/urdf_file.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <set>
#include <iomanip>
#include <limits>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "service/text/input_limits.h"

namespace coopdyn::scene_detail {

namespace bounded = coopdyn::text;

namespace {

// One tag of an XML text: <name a="v" ...>, </name> or <name .../>; `begin` is the position of '<'.
struct XmlTag {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attrs;
  size_t begin = 0, end = 0;  // [begin, end) the tag's text
  bool closing = false, self_closing = false;
  const std::string* attr(const std::string& a) const {
    for (const auto& kv : attrs)
      if (kv.first == a) return &kv.second;
    return nullptr;
  }
};

bool xml_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

// Calls fn on every tag in t[from, to) in order, comments, CDATA, processing instructions and
// declarations skipped, until fn returns false. An unterminated tag ends the scan (urdfdom reports it).
void xml_tags(const std::string& t, size_t from, size_t to, const std::function<bool(const XmlTag&)>& fn) {
  auto skip_to = [&](size_t p, const char* end) {
    const size_t e = t.find(end, p);
    return e == std::string::npos ? to : e + std::strlen(end);
  };
  for (size_t i = t.find('<', from); i < to; i = t.find('<', i)) {
    if (t.compare(i, 4, "<!--") == 0) i = skip_to(i + 4, "-->");
    else if (t.compare(i, 9, "<![CDATA[") == 0) i = skip_to(i + 9, "]]>");
    else if (t.compare(i, 2, "<?") == 0) i = skip_to(i + 2, "?>");
    else if (t.compare(i, 2, "<!") == 0) i = skip_to(i + 2, ">");
    else {
      XmlTag g;
      g.begin = i;
      size_t p = i + 1;
      if (p < to && t[p] == '/') g.closing = true, ++p;
      const size_t n0 = p;
      while (p < to && !xml_space(t[p]) && t[p] != '>' && t[p] != '/') ++p;
      g.name = t.substr(n0, p - n0);
      for (;;) {
        while (p < to && xml_space(t[p])) ++p;
        if (p >= to) return;
        if (t[p] == '>') break;
        if (t[p] == '/') {
          g.self_closing = true;
          ++p;
          continue;
        }
        const size_t a0 = p;
        while (p < to && !xml_space(t[p]) && t[p] != '=' && t[p] != '>' && t[p] != '/') ++p;
        std::string an = t.substr(a0, p - a0), av;
        while (p < to && xml_space(t[p])) ++p;
        if (p < to && t[p] == '=') {
          ++p;
          while (p < to && xml_space(t[p])) ++p;
          if (p >= to) return;
          const char q = t[p];
          if (q == '"' || q == '\'') {
            const size_t e = t.find(q, p + 1);
            if (e == std::string::npos || e >= to) return;
            av = t.substr(p + 1, e - p - 1);
            p = e + 1;
          }
        }
        if (an.empty()) ++p;  // a stray character: step over it
        else g.attrs.emplace_back(std::move(an), std::move(av));
      }
      g.end = p + 1;
      if (!fn(g)) return;
      i = g.end;
    }
  }
}

// The first element named `name` inside t[from, to) (outside comments): [*b, *e) holds it whole.
bool find_element(const std::string& t, size_t from, size_t to, const std::function<bool(const XmlTag&)>& is_it,
                  size_t* b, size_t* e) {
  bool found = false, closed = false;
  int depth = 0;
  std::string name;
  xml_tags(t, from, to, [&](const XmlTag& g) {
    if (!found) {
      if (g.closing || !is_it(g)) return true;
      found = true;
      *b = g.begin;
      *e = g.end;
      name = g.name;
      closed = g.self_closing;
      return !closed;
    }
    if (g.name == name && !g.self_closing) depth += g.closing ? -1 : 1;
    *e = g.end;
    closed = depth < 0;
    return !closed;
  });
  if (found && !closed) *e = to;  // never closed: to the end (urdfdom reports it)
  return found;
}

// a number as the whole of an attribute's text (surrounding spaces allowed)
bool number(const std::string& s, double* x) {
  const char* p = s.c_str();
  char* end = nullptr;
  *x = std::strtod(p, &end);
  if (end == p) return false;
  while (*end && xml_space(*end)) ++end;
  return *end == 0 && std::isfinite(*x);
}

// three numbers separated by spaces
bool numbers3(const std::string& s, double v[3]) {
  std::istringstream is(s);
  std::string w[4];
  int n = 0;
  while (n < 4 && is >> w[n]) ++n;
  if (n != 3) return false;
  for (int k = 0; k < 3; ++k)
    if (!number(w[k], &v[k])) return false;
  return true;
}

// The xacro namespace's prefixes: "xacro" and every prefix declared with a URI that names xacro.
std::set<std::string> xacro_prefixes(const std::string& xml) {
  std::set<std::string> p = {"xacro"};
  xml_tags(xml, 0, xml.size(), [&](const XmlTag& g) {
    for (const auto& kv : g.attrs)
      if (kv.first.rfind("xmlns:", 0) == 0 && kv.second.find("xacro") != std::string::npos) p.insert(kv.first.substr(6));
    return true;
  });
  return p;
}

// An element or attribute in the xacro namespace outside comments and CDATA: its position, or npos.
size_t xacro_use(const std::string& xml) {
  const std::set<std::string> pre = xacro_prefixes(xml);
  auto in_ns = [&](const std::string& n) {
    const size_t colon = n.find(':');
    return colon != std::string::npos && pre.count(n.substr(0, colon)) > 0;
  };
  size_t at = std::string::npos;
  xml_tags(xml, 0, xml.size(), [&](const XmlTag& g) {
    bool x = in_ns(g.name);
    for (const auto& kv : g.attrs) x = x || (kv.first.rfind("xmlns:", 0) != 0 && in_ns(kv.first));
    if (x) at = g.begin;
    return !x;
  });
  return at;
}

// Each <mimic> element of the text read as urdfdom would: `joint` required, multiplier and offset
// numbers; an attribute it ignores (a misspelt multiplier, which would be 1) is an error.
void check_mimic_elements(const Ctx& c, const YAML::Node& where, const UrdfFile& f) {
  xml_tags(f.xml, 0, f.xml.size(), [&](const XmlTag& g) {
    if (g.closing || g.name != "mimic") return true;
    const std::string at = urdf_at(f, g.begin) + ": <mimic> ";
    if (!g.attr("joint")) fail(c, where, at + "has no joint attribute (the joint it follows)");
    for (const auto& kv : g.attrs) {
      double x;
      if (kv.first != "joint" && kv.first != "multiplier" && kv.first != "offset")
        fail(c, where, at + "attribute '" + kv.first + "' is not one of joint, multiplier, offset (misspelt? it would be lost)");
      if (kv.first != "joint" && !number(kv.second, &x))
        fail(c, where, at + kv.first + " '" + kv.second + "' is not a number");
    }
    return true;
  });
}

// UrdfFile::link_at and joint_at: the <link> and <joint> children of <robot> (a <joint> inside a
// <transmission> is not one), in one scan.
void index_elements(UrdfFile& f) {
  int depth = 0;
  std::map<std::string, std::pair<size_t, size_t>>* open = nullptr;
  std::string open_name;
  xml_tags(f.xml, 0, f.xml.size(), [&](const XmlTag& g) {
    if (g.closing) {
      if (--depth == 1 && open) {
        (*open)[open_name].second = g.end;
        open = nullptr;
      }
      return true;
    }
    if (depth == 1 && (g.name == "link" || g.name == "joint")) {
      const std::string* n = g.attr("name");
      auto& index = g.name == "link" ? f.link_at : f.joint_at;
      if (n && !index.count(*n)) {
        index[*n] = {g.begin, g.end};
        if (!g.self_closing) open = &index, open_name = *n;
      }
    }
    if (!g.self_closing) ++depth;
    return true;
  });
}

// The file's mass times its size squared (kg*m^2): the total mass of its links and the largest
// distance of a link frame from the root link's frame with every joint at zero.
double robot_inertia_scale(const UrdfFile& f) {
  double mass = 0, size = 0;
  std::vector<std::pair<urdf::LinkConstSharedPtr, Transform>> todo;
  todo.emplace_back(f.model->getRoot(), Transform());
  while (!todo.empty()) {
    const auto [l, X_RL] = todo.back();
    todo.pop_back();
    if (l->inertial && l->inertial->mass > 0) mass += l->inertial->mass;
    size = std::max(size, X_RL.p.norm());
    for (const auto& ch : l->child_links)
      if (ch->parent_joint) todo.emplace_back(ch, X_RL * urdf_pose(ch->parent_joint->parent_to_joint_origin_transform));
  }
  return std::isfinite(mass * size * size) ? mass * size * size : 0.0;
}

}  // namespace

std::string urdf_at(const UrdfFile& f) { return "URDF " + f.path; }
std::string urdf_at(const UrdfFile& f, size_t pos) { return "URDF " + f.path + ":" + std::to_string(line_of(f.xml, pos)); }

UrdfFile read_urdf(const Ctx& c, const YAML::Node& where, const std::string& path, bool repair_any,
                   const std::string& repair_option) {
  UrdfFile f;
  f.path = path;
  std::string& xml = f.xml;
  std::string why;
  // bounded before urdfdom sees it: its TinyXML parser recurses per element without a limit
  if (!bounded::read_file(path, bounded::kMaxUrdfBytes, "URDF " + path, &xml, &why)) fail(c, where, why);
  if (const bounded::DepthExceeded d = bounded::xml_depth_exceeds(xml); d.exceeded)
    fail(c, where, urdf_at(f) + ":" + std::to_string(d.line) + ":" + std::to_string(d.column) +
                       ": elements nested deeper than " + std::to_string(bounded::kMaxXmlDepth) +
                       " levels (the limit; URDF itself nests 5)");
  // xacro's output keeps xmlns:xacro and often xacro calls in comments: only an element or an
  // attribute in the namespace makes a macro
  if (const size_t x = xacro_use(xml); x != std::string::npos)
    fail(c, where, urdf_at(f, x) + ": the file is a xacro macro (an element or attribute in the xacro namespace): "
                       "expand it first (xacro FILE.urdf.xacro > FILE.urdf) and give the expanded file");
  f.model = urdf::parseURDF(xml);
  if (!f.model) fail(c, where, urdf_at(f) + ": could not be parsed (see the urdfdom message above)");
  check_mimic_elements(c, where, f);
  index_elements(f);
  f.repair_option = repair_option;
  f.repair_limit = repair_any ? std::numeric_limits<double>::infinity() : kInertiaRepairTolerance * robot_inertia_scale(f);
  return f;
}

int line_of(const std::string& text, size_t pos) { return 1 + static_cast<int>(std::count(text.begin(), text.begin() + std::min(pos, text.size()), '\n')); }

bool urdf_element(const std::string& xml, const std::string& kind, const std::string& name, size_t* begin, size_t* end) {
  return find_element(
      xml, 0, xml.size(),
      [&](const XmlTag& g) {
        const std::string* n = g.attr("name");
        return g.name == kind && n && *n == name;
      },
      begin, end);
}

bool urdf_element(const UrdfFile& f, const std::string& kind, const std::string& name, size_t* begin, size_t* end) {
  const auto& index = kind == "link" ? f.link_at : f.joint_at;
  const auto it = index.find(name);
  if (it == index.end()) return false;
  *begin = it->second.first;
  *end = it->second.second;
  return true;
}

std::string urdf_link_text(const std::string& xml, const std::string& name) {
  size_t b, e;
  return urdf_element(xml, "link", name, &b, &e) ? xml.substr(b, e - b) : "";
}

Transform urdf_pose(const urdf::Pose& p) {
  double x, y, z, w;
  p.rotation.getQuaternion(x, y, z, w);
  return Transform(Quat(w, x, y, z).normalized().toRotationMatrix(), Vec3(p.position.x, p.position.y, p.position.z));
}

// a link's <inertial> in the link frame; a negative mass is an error
Inertia link_inertia(const Ctx& c, const YAML::Node& where, const urdf::Link& l) {
  const auto& in = *l.inertial;
  if (in.mass < 0) fail(c, where, "URDF link '" + l.name + "': negative mass");
  Mat3 Ic;
  Ic << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  const Transform X = urdf_pose(in.origin);
  return Inertia(in.mass, X.p, X.R * Ic * X.R.transpose());
}

namespace {

// An <inertial> as the text gives it.
struct TextInertial {
  double mass = 0, I[6] = {0, 0, 0, 0, 0, 0};  // ixx iyy izz ixy ixz iyz
  urdf::Pose origin;
};

// Reads the <inertial> element [b, e) of link `link` as urdfdom should; what it cannot read is an
// error with its line.
TextInertial read_text_inertial(const Ctx& c, const YAML::Node& where, const UrdfFile& f, const std::string& link,
                                size_t b, size_t e) {
  static const char* six[6] = {"ixx", "iyy", "izz", "ixy", "ixz", "iyz"};
  TextInertial t;
  bool mass = false, inertia = false;
  auto bad = [&](size_t pos, const std::string& why) {
    fail(c, where, urdf_at(f, pos) + ": link '" + link + "': " + why + "; urdfdom cannot read this <inertial> (it would "
                   "drop its mass or zero its inertia)");
  };
  auto num = [&](const XmlTag& g, const char* a, double* x) {
    const std::string* s = g.attr(a);
    if (s && !number(*s, x)) bad(g.begin, std::string("<") + g.name + "> " + a + " '" + *s + "' is not a number");
    return s != nullptr;
  };
  xml_tags(f.xml, b, e, [&](const XmlTag& g) {
    if (g.closing || g.begin == b) return true;
    if (g.name == "mass") {
      if (!num(g, "value", &t.mass)) {
        std::string given;
        for (const auto& kv : g.attrs) given += " " + kv.first;
        bad(g.begin, "<mass> has no value attribute" + (given.empty() ? "" : " (given:" + given + ")"));
      }
      mass = true;
    } else if (g.name == "inertia") {
      std::string missing, unknown;
      for (int k = 0; k < 6; ++k)
        if (!num(g, six[k], &t.I[k])) missing += std::string(missing.empty() ? "" : ", ") + six[k];
      for (const auto& kv : g.attrs)
        if (std::find_if(six, six + 6, [&](const char* s) { return kv.first == s; }) == six + 6)
          unknown += (unknown.empty() ? "" : ", ") + kv.first;
      if (!missing.empty())
        bad(g.begin, "<inertia> lacks " + missing + (unknown.empty() ? "" : " (given instead: " + unknown + "; misspelt?)"));
      inertia = true;
    } else if (g.name == "origin") {
      double xyz[3] = {0, 0, 0}, rpy[3] = {0, 0, 0};
      if (const std::string* s = g.attr("xyz"); s && !numbers3(*s, xyz)) bad(g.begin, "<origin> xyz '" + *s + "' is not three numbers");
      if (const std::string* s = g.attr("rpy"); s && !numbers3(*s, rpy)) bad(g.begin, "<origin> rpy '" + *s + "' is not three numbers");
      t.origin.position = urdf::Vector3(xyz[0], xyz[1], xyz[2]);
      t.origin.rotation.setFromRPY(rpy[0], rpy[1], rpy[2]);
    } else {
      bad(g.begin, "element <" + g.name + "> is not one of <origin>, <mass>, <inertia> (misspelt?)");
    }
    return true;
  });
  if (!mass) bad(b, "no <mass> element");
  if (!inertia) bad(b, "no <inertia> element");
  return t;
}

// whether urdfdom's numbers are the text's
bool same_inertial(const TextInertial& t, const urdf::Inertial& u) {
  const double I[6] = {u.ixx, u.iyy, u.izz, u.ixy, u.ixz, u.iyz};
  auto near = [](double a, double b) { return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(a)); };
  bool same = near(t.mass, u.mass);
  for (int k = 0; k < 6; ++k) same = same && near(t.I[k], I[k]);
  const Transform a = urdf_pose(t.origin), b = urdf_pose(u.origin);
  return same && (a.R - b.R).cwiseAbs().maxCoeff() <= 1e-12 && (a.p - b.p).cwiseAbs().maxCoeff() <= 1e-12 * (1 + a.p.norm());
}

// a number in 3 significant digits
std::string fmt_g(double x) {
  std::ostringstream os;
  os.precision(3);
  os << x;
  return os.str();
}

// A non-PSD tensor I replaced in `in` (urdfdom's model) by the nearest positive semi-definite one in
// the Frobenius norm (its negative eigenvalues set to zero), when within f.repair_limit; else an
// error naming the option. Returns the warning.
std::string repair_inertia(const Ctx& c, const YAML::Node& where, const UrdfFile& f, const std::string& at, const Mat3& I,
                           urdf::Inertial& in) {
  const Eigen::SelfAdjointEigenSolver<Mat3> es(I);
  const Vec3 lam = es.eigenvalues();
  std::ostringstream os;
  os.precision(3);
  os << "inertia tensor is not positive semi-definite (eigenvalues " << lam[0] << ", " << lam[1] << ", " << lam[2]
     << " kg*m^2)";
  if (!(-lam[0] <= f.repair_limit))
    fail(c, where, at + ": " + os.str() + ", beyond the repair tolerance " + fmt_g(f.repair_limit) + " kg*m^2 (" +
                       fmt_g(kInertiaRepairTolerance) + " of the robot's mass times its size squared): correct the file, "
                       "or give " + f.repair_option + " to replace it by the nearest positive semi-definite tensor");
  const Mat3 R = es.eigenvectors() * lam.cwiseMax(0.0).asDiagonal() * es.eigenvectors().transpose();
  const Mat3 J = 0.5 * (R + R.transpose());
  // the tensor as written is in the <inertial>'s frame, as urdfdom's numbers are
  in.ixx = J(0, 0), in.iyy = J(1, 1), in.izz = J(2, 2), in.ixy = J(0, 1), in.ixz = J(0, 2), in.iyz = J(1, 2);
  os.precision(17);
  os << "; replaced by the nearest positive semi-definite tensor (its negative eigenvalues set to 0; a change of "
     << std::setprecision(3) << (J - I).norm() << " kg*m^2, within " << (std::isfinite(f.repair_limit) ? "the tolerance " +
        fmt_g(f.repair_limit) + " kg*m^2" : f.repair_option) << "): ixx " << std::setprecision(17) << J(0, 0)
     << " iyy " << J(1, 1) << " izz " << J(2, 2) << " ixy " << J(0, 1) << " ixz " << J(0, 2) << " iyz " << J(1, 2);
  const Vec3 p = lam.cwiseMax(0.0);
  if (p[0] + p[1] < p[2] * (1 - 1e-9)) os << " (its principal moments break the triangle inequality)";
  return os.str();
}

}  // namespace

bool check_urdf_inertial(const Ctx& c, const YAML::Node& where, const UrdfFile& f, const std::string& link,
                         std::vector<std::string>* warnings) {
  size_t lb, le, b, e;
  if (!urdf_element(f, "link", link, &lb, &le)) return false;
  if (!find_element(f.xml, lb + 1, le, [](const XmlTag& g) { return g.name == "inertial"; }, &b, &e)) return false;
  const TextInertial t = read_text_inertial(c, where, f, link, b, e);
  const urdf::LinkConstSharedPtr l = f.model->getLink(link);
  const std::string at = urdf_at(f, b) + ": link '" + link + "'";
  if (!l || !l->inertial || !same_inertial(t, *l->inertial))
    fail(c, where, at + ": urdfdom read its <inertial> otherwise than written (see its message above); refused");
  if (t.mass < 0) fail(c, where, at + ": negative mass");
  Mat3 I;
  I << t.I[0], t.I[3], t.I[4], t.I[3], t.I[1], t.I[5], t.I[4], t.I[5], t.I[2];
  if (!inertia_psd(I)) {
    warnings->push_back(at + ": " + repair_inertia(c, where, f, at, I, *f.model->links_.at(link)->inertial));
    return true;
  }
  if (const std::string w = inertia_plausibility(t.mass, I); !w.empty()) warnings->push_back(at + ": " + w);
  return true;
}

// Nothing the file gives is lost silently: an <inertial> urdfdom could not read is an error, a
// moving link without one a warning.
void check_link_inertial(const Ctx& c, const YAML::Node& where, const UrdfFile& f, const urdf::Joint& jt, std::vector<std::string>* warnings) {
  if (check_urdf_inertial(c, where, f, jt.child_link_name, warnings)) return;
  const bool frame_only = jt.type == urdf::Joint::FIXED;  // a flange or tool frame: massless by design
  if (!frame_only)
    warnings->push_back(urdf_at(f) + ": link '" + jt.child_link_name + "' (after moving joint '" + jt.name +
                        "') has no <inertial>: it moves no mass");
}

std::vector<UrdfMimic> read_mimics(const UrdfFile& f) {
  std::vector<UrdfMimic> out;
  for (const auto& kv : f.model->joints_) {
    const urdf::Joint& j = *kv.second;
    if (!j.mimic) continue;
    UrdfMimic m;
    m.joint = j.name;
    m.mimicked = j.mimic->joint_name;
    m.multiplier = j.mimic->multiplier;
    m.offset = j.mimic->offset;
    size_t b = 0, e = 0;
    if (urdf_element(f, "joint", j.name, &b, &e))
      find_element(f.xml, b + 1, e, [](const XmlTag& g) { return g.name == "mimic"; }, &b, &e);
    m.source = urdf_at(f, b);
    out.push_back(m);
  }
  std::sort(out.begin(), out.end(), [](const UrdfMimic& a, const UrdfMimic& b) {
    return a.source.size() != b.source.size() ? a.source.size() < b.source.size() : a.source < b.source;
  });
  return out;
}

}  // namespace coopdyn::scene_detail
