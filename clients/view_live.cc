// coopdyn view --live: not built yet (the next commit serves the page and its WebSocket).
#include <cstdio>

#include "clients/view.h"

namespace coopdyn::cli {
int run_view_live(const System&, const std::string&, const std::string&, const std::string&, const std::string&, double, int) {
  std::fprintf(stderr, "coopdyn view: --live is not built yet\n");
  return 1;
}
}  // namespace coopdyn::cli
