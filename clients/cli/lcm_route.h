// The LCM subcommands' start-up check of their URLs: a ttl=0 URL whose multicast leaves by another
// interface than lo (or has no route) loses large messages on this host; said once on stderr with
// the command that fixes it (service/io/transport/multicast_route.h). Nothing is changed.
#pragma once

#include <cstdio>
#include <string>

#include "service/io/transport/multicast_route.h"

namespace coopdyn::cli {

// "coopdyn WHO: warning: ..." for `url`, and for `other` when it is given and differs.
inline void warn_loopback_multicast(const char* who, const std::string& url, const std::string& other = "") {
  for (const std::string* u : {&url, &other}) {
    if (u == &other && (other.empty() || other == url)) continue;
    if (const std::string w = io::loopback_multicast_problem(*u); !w.empty())
      std::fprintf(stderr, "coopdyn %s: warning: %s\n", who, w.c_str());
  }
}

}  // namespace coopdyn::cli
