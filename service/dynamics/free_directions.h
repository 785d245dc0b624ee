// A one-line reading of a free direction of the constraint multipliers (WrenchData::free_lambda),
// for people: which reported wrench components it moves, and what that means in the common cases
// (the diagonal load transfer of a chassis on four wheels, the lateral split on a rigid axle, an
// internal force between grasps). Text: for clients and start-up logs, not for the loop.
#pragma once

#include <string>

#include "service/dynamics/wrenches.h"

namespace coopdyn {

std::string free_direction_reading(const System& sys, const WrenchData& wd, int d);

}  // namespace coopdyn
