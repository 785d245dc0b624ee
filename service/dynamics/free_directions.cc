#include "service/dynamics/free_directions.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <vector>

#include "service/dynamics/wrench_components.h"

namespace coopdyn {

std::string free_direction_reading(const System& sys, const WrenchData& wd, int d) {
  const auto& outs = sys.wrenches.outputs;
  struct Part {
    double x;
    std::string what;
    std::string name;
  };
  std::vector<Part> parts;  // the tip components it moves (the multipliers themselves)
  double big = 0;
  for (size_t k = 0; k < outs.size(); ++k) {
    if (outs[k].spec < 0) continue;
    for (int c = 0; c < 6; ++c) big = std::max(big, std::abs(wd.free_W(6 * static_cast<Eigen::Index>(k) + c, d)));
  }
  for (size_t k = 0; k < outs.size(); ++k) {
    if (outs[k].spec < 0) continue;
    for (int c = 0; c < 6; ++c) {
      const double x = wd.free_W(6 * static_cast<Eigen::Index>(k) + c, d);
      if (std::abs(x) > 1e-9 * std::max(big, 1e-300)) parts.push_back({x, outs[k].name + "." + kWrenchComponents[c], outs[k].name});
    }
  }
  // largest first; sizes equal to 1e-9 keep the scene's order (the +0.5 / -0.5 of a load transfer
  // must not be ordered by round-off)
  const double unit = 1e-9 * std::max(big, 1e-300);
  std::stable_sort(parts.begin(), parts.end(), [unit](const Part& a, const Part& b) {
    return std::llround(std::abs(a.x) / unit) > std::llround(std::abs(b.x) / unit);
  });
  std::string list;
  std::set<std::string> who;
  for (size_t i = 0; i < parts.size(); ++i) {
    who.insert(parts[i].name);
    if (i >= 8) continue;
    char b[64];
    std::snprintf(b, sizeof b, "%s%s %+.3g", list.empty() ? "" : ", ", parts[i].what.c_str(), parts[i].x);
    list += b;
  }
  if (parts.size() > 8) list += ", ... (" + std::to_string(parts.size() - 8) + " more)";
  std::string names;
  for (const auto& n : who) names += (names.empty() ? "" : ", ") + n;
  const int n = static_cast<int>(who.size());
  switch (wd.free_class[static_cast<size_t>(d)]) {
    case FreeClass::kWheelNormal:
      return (n == 4 ? std::string("diagonal load transfer between the four wheels (a rigid chassis on four contacts, "
                                   "the wobbly table): ")
                     : "load transfer between " + std::to_string(n) + " wheels (a rigid body on more than three contacts): ") +
             list + "; the rigid model cannot say how they share the load: contact compliances decide it (redundancy: compliance)";
    case FreeClass::kWheelLateral:
      return "lateral forces shift between the wheels " + names + " (wheels on one rigid axle fight each other sideways): " +
             list + "; the split follows from tire compliances (redundancy: compliance)";
    case FreeClass::kWheelLongitudinal:
      return "longitudinal forces shift between the wheels " + names + ": " + list;
    case FreeClass::kForce:
      return "an internal force between " + names + " (a squeeze the rigid model cannot split): " + list;
    case FreeClass::kMoment:
      return "an internal moment between " + names + " (a twist the rigid model cannot split): " + list;
    case FreeClass::kLock: return "pseudo-joint locks or joint couplings that carry nothing determinate: " + list;
    case FreeClass::kMixed: break;
  }
  return "moves forces and moments together between " + names + ": " + list;
}

}  // namespace coopdyn
