#include "service/scene/robot_chain.h"

namespace coopdyn::scene_detail {

Transform chain_motion(const ChainJoint& j, double q) {
  if (j.prismatic) return Transform(Mat3::Identity(), j.axis * q);
  return Transform(Eigen::AngleAxisd(q, j.axis.normalized()).toRotationMatrix(), Vec3::Zero());
}

struct DhLink {
  double a = 0, d = 0, alpha = 0, offset = 0;
};
// K_i = Tz(d) Tx(a) Rx(alpha): the fixed part of the standard DH transform T_{i-1,i} = Rz(theta) K_i
Transform dh_fixed(const DhLink& l) { return trans(0, 0, l.d) * trans(l.a, 0, 0) * rot_x(l.alpha); }

// A link's position limits `limits: [LOWER, UPPER]` (angles as the link's others, lengths for a
// prismatic link) and speed limit `v_limit` (rad/s or m/s): reported when exceeded, never enforced.
void dh_limits(const Ctx& c, const YAML::Node& l, const std::string& w, bool prismatic, ChainJoint* j) {
  if (const YAML::Node lim = l["limits"]) {
    if (!lim.IsSequence() || lim.size() != 2) fail(c, lim, w + ": limits must be [LOWER, UPPER]");
    auto at = [&](size_t k) {
      return prismatic ? as_length(c, lim[k], w + ".limits") : as_angle(c, lim[k], w + ".limits");
    };
    j->lower = at(0);
    j->upper = at(1);
    if (!(j->lower < j->upper)) fail(c, lim, w + ": limits must be [LOWER, UPPER] with LOWER < UPPER");
  }
  j->v_limit = get_double(c, l, "v_limit", std::numeric_limits<double>::infinity(), w);
  if (!(j->v_limit > 0)) fail(c, l["v_limit"], w + ": v_limit must be > 0 (rad/s or m/s; absent = no limit)");
}

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
    check_keys(c, l, {"type", "a", "d", "alpha", "offset", "theta", "mass", "com", "inertia", "armature", "damping", "friction", "tau_limit", "limits", "v_limit", "accept_inertia"}, w);
    const std::string type = get_string(c, l, "type", "revolute");
    if (type != "revolute" && type != "prismatic") fail(c, l["type"], w + ": type must be revolute or prismatic");
    const bool prismatic = type == "prismatic";
    if (!prismatic && l["theta"])
      fail(c, l["theta"], w + ": theta is the variable of a revolute link (its constant part is 'offset')");
    if (prismatic && l["offset"])
      fail(c, l["offset"], w + ": a prismatic link's constant extension is 'd' (d + q along z); its fixed angle is 'theta'");
    DhLink dl;
    auto length = [&](const char* k) { return l[k] ? as_length(c, l[k], w + "." + k) : 0.0; };
    auto angle = [&](const char* k) { return l[k] ? as_angle(c, l[k], w + "." + k) : 0.0; };
    dl.a = length("a");
    dl.d = length("d");
    dl.alpha = angle("alpha");
    dl.offset = angle("offset");
    const double theta = angle("theta");
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
    j.damping = get_joint_loss(c, l, "damping", w);
    j.friction = get_joint_loss(c, l, "friction", w);
    j.tau_limit = get_double(c, l, "tau_limit", std::numeric_limits<double>::infinity(), w);
    if (!(j.tau_limit >= 0)) fail(c, l["tau_limit"], w + ": tau_limit must be >= 0 (N*m or N; absent = no limit)");
    dh_limits(c, l, w, prismatic, &j);
    r.joints.push_back(j);
    K_prev = K;
  }
  r.X_last_EE = K_prev;  // DH frame n
  return r;
}

}  // namespace coopdyn::scene_detail
