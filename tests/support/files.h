// Files of the tests: a shipped scene's path, a whole file's bytes.
#pragma once

#include <fstream>
#include <sstream>
#include <string>

namespace coopdyn::testing {

inline std::string scene_path(const std::string& name) {
  return std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/" + name + ".yaml";
}

// The bytes of file p ("" when it cannot be read).
inline std::string slurp(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

}  // namespace coopdyn::testing
