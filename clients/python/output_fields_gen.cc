// Writes the Python module coopdyn.output_fields (the field lists of output_t and loop_stats_t) to
// the file named by its argument, or to stdout; run by the build (clients/python/CMakeLists.txt).
// With --markdown: the output_t table of docs/reference/messages.md, to stdout.
#include <cstdio>
#include <string>

#include "service/io/codec/output_schema.h"

int main(int argc, char** argv) {
  const bool md = argc > 1 && std::string(argv[1]) == "--markdown";
  const std::string text = md ? coopdyn::io::output_fields_markdown() : coopdyn::io::output_fields_python();
  std::FILE* f = argc > 1 && !md ? std::fopen(argv[1], "w") : stdout;
  if (!f) {
    std::fprintf(stderr, "output_fields_gen: cannot write '%s'\n", argv[1]);
    return 1;
  }
  const bool ok = std::fputs(text.c_str(), f) >= 0;
  if (f != stdout && std::fclose(f) != 0) return 1;
  return ok ? 0 : 1;
}
