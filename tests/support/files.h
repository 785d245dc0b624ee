// Files of the tests: a shipped scene's path, a whole file's bytes, a CSV's header and rows.
#pragma once

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

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

// A CSV read as text after its leading '#' lines (a per-step CSV's comments and units): the header's
// names and each row's cells, split at every comma (the CSVs of coopdyn quote nothing).
struct CsvText {
  std::vector<std::string> head;
  std::vector<std::vector<std::string>> rows;
};
inline std::vector<std::string> csv_cells(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
  return cells;
}
inline CsvText read_csv_text(const std::string& path) {
  CsvText t;
  std::ifstream f(path);
  std::string line;
  while (std::getline(f, line) && !line.empty() && line[0] == '#') {}
  t.head = csv_cells(line);
  while (std::getline(f, line)) t.rows.push_back(csv_cells(line));
  return t;
}

}  // namespace coopdyn::testing
