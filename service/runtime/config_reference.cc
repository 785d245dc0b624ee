// The table of keys of docs/reference/config.md, made from the config's table (config_fields.h):
// coopdynd --print-config-reference prints it, and a test holds the page to it.
#include <initializer_list>

#include "service/runtime/config_fields.h"

namespace coopdyn::runtime {

namespace {

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) s.replace(at, from.size(), to);
  return s;
}

std::string default_cell(const ConfigField& f, const ServiceConfig& def) {
  const std::string v = field_text(f, f.get(def));
  const bool word = f.kind == FieldKind::kText || f.kind == FieldKind::kChoice;
  return (word ? "`" + (v.empty() ? std::string("\"\"") : v) + "`" : v) + f.default_note;
}

std::string range_cell(const ConfigField& f) {
  if (f.kind != FieldKind::kChoice) return replace_all(replace_all(f.range_note, "{lo}", number_text(f.lo)), "{hi}", number_text(f.hi));
  std::string s;
  for (const char* w : f.choices) s += (s.empty() ? "`" : ", `") + std::string(w) + "`";
  return s;
}

std::string row(std::initializer_list<std::string> cells) {
  std::string s = "|";
  for (const std::string& c : cells) s += (c.empty() ? " " : " " + c + " ") + "|";
  return s + "\n";
}

}  // namespace

std::string config_reference_markdown() {
  const ServiceConfig def;
  std::string s = "| key | default | range | meaning |\n|---|---|---|---|\n";
  for (const ConfigField& f : config_fields())
    s += row({"`" + field_path(f) + "`", default_cell(f, def), range_cell(f), f.doc});
  return s;
}

}  // namespace coopdyn::runtime
