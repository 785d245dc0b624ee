// The field lists of output_t (output_fields.def) and loop_stats_t (stats_fields.def) as text: the
// output_t table of docs/reference/messages.md (a test checks the file holds exactly it) and the
// Python module coopdyn.output_fields (written at build time by output_fields_gen). Allocates; for
// tools and tests only.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

namespace coopdyn::io {

// The markdown table: "| field | meaning |", then one row per field with a doc, the fields after it
// with an empty doc joined to its row (vectors as `name[]`, four-arrays `name[4]`).
inline std::string output_fields_markdown() {
  std::string t = "| field | meaning |\n|---|---|\n", names, doc;
  auto flush = [&] {
    if (!names.empty()) t += "| " + names + " | " + doc + " |\n";
    names.clear();
  };
  auto add = [&](const char* name, const std::string& type, const char* d) {
    if (*d) flush(), doc = d;
    std::string n = std::string("`") + name;
    if (type == "f4" || type == "i4") n += "[4]";
    else if (type == "dirs") n += "[][]";
    else if (type == "names" || type == "ints" || type == "reals" || type == "wrenches") n += "[]";
    names += (names.empty() ? "" : ", ") + n + "`";
  };
#define COOPDYN_OUTPUT_FIELD(name, type, size, since, absent, on_error, csv, doc) add(#name, #type, doc);
#include "service/io/codec/output_fields.def"
  flush();
  return t;
}

// Python: OUTPUT_FIELDS, (name, type, size, since, absent) in the message's order; STATS_FIELDS,
// (name, since); STATS_LAYOUTS, {fingerprint: version} of loop_stats_t's older layouts.
inline std::string output_fields_python() {
  std::string t =
      "\"\"\"The fields of output_t and loop_stats_t (generated from service/io/codec/output_fields.def and\n"
      "stats_fields.def by output_fields_gen at build time: do not edit).\"\"\"\n\nOUTPUT_FIELDS = [\n";
  char b[256];
#define COOPDYN_OUTPUT_FIELD(name, type, size, since, absent, on_error, csv, doc)                       \
  std::snprintf(b, sizeof b, "    (\"%s\", \"%s\", \"%s\", %d, %d),\n", #name, #type, #size, since, absent); \
  t += b;
#include "service/io/codec/output_fields.def"
  t += "]\n\nSTATS_FIELDS = [\n";
#define COOPDYN_STATS_FIELD(lcm, frame, put, since)                 \
  std::snprintf(b, sizeof b, "    (\"%s\", %d),\n", #lcm, since); \
  t += b;
#include "service/io/codec/stats_fields.def"
  t += "]\n\nSTATS_LAYOUTS = {\n";
#define COOPDYN_STATS_LAYOUT(hash, version)                                                               \
  std::snprintf(b, sizeof b, "    bytes.fromhex(\"%016llx\"): %d,\n", static_cast<unsigned long long>(hash), \
                version);                                                                                 \
  t += b;
#include "service/io/codec/stats_fields.def"
  t += "}\n";
  return t;
}

}  // namespace coopdyn::io
