// The reported wrenches of a scene (wrench_outputs.h), completed after the trees are built.
#include <algorithm>
#include <set>

#include "service/scene/builder.h"

namespace coopdyn::scene_detail {

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
    if (listed[k] || cp.kind == ConstraintKind::kLock || cp.kind == ConstraintKind::kCouple) continue;  // stresses
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

}  // namespace coopdyn::scene_detail
