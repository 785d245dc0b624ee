// coopdyn view --live when the build found no websocketpp or standalone asio (clients/CMakeLists.txt).
#include <cstdio>

#include "clients/view/view.h"

namespace coopdyn::cli {
int run_view_live(const System&, const ViewVisuals&, const std::string&, const std::string&, const std::string&, const std::string&,
                  const std::string&, double, int) {
  std::fprintf(stderr,
               "coopdyn view: --live is not in this build: it needs websocketpp and standalone asio (Debian: apt-get install "
               "libwebsocketpp-dev libasio-dev), then cmake again\n");
  return 1;
}
}  // namespace coopdyn::cli
