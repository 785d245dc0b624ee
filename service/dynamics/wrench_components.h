// The names of a wrench's six components, in the order of every [moment; force] vector (CSV
// columns NAME.mx .. NAME.fz, free-direction labels): written once.
#pragma once

namespace coopdyn {

inline constexpr const char* kWrenchComponents[6] = {"mx", "my", "mz", "fx", "fy", "fz"};

}  // namespace coopdyn
