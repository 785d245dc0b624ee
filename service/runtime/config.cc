#include "service/runtime/config.h"

#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include <set>
#include <sstream>

#include "service/runtime/config_fields.h"
#include "service/text/input_limits.h"

namespace coopdyn::runtime {

const char* mode_name(ServiceMode m) { return m == ServiceMode::kSimulate ? "simulate" : "estimate"; }
bool parse_mode(const std::string& s, ServiceMode* m) {
  if (s == mode_name(ServiceMode::kSimulate)) *m = ServiceMode::kSimulate;
  else if (s == mode_name(ServiceMode::kEstimate)) *m = ServiceMode::kEstimate;
  else return false;
  return true;
}

const char* trigger_name(Trigger t) { return t == Trigger::kTick ? "tick" : "arrival"; }
bool parse_trigger(const std::string& s, Trigger* t) {
  if (s == trigger_name(Trigger::kTick)) *t = Trigger::kTick;
  else if (s == trigger_name(Trigger::kArrival)) *t = Trigger::kArrival;
  else return false;
  return true;
}

bool loop_asks_fifo(const RealtimeOptions& o) {
  return o.sched_fifo == SchedFifo::kOn || (o.sched_fifo == SchedFifo::kAuto && !(o.busy_poll && o.cpu < 0));
}

namespace {

struct Ctx {
  std::string file;
  [[noreturn]] void fail(const YAML::Node& n, const std::string& why) const {
    std::ostringstream s;
    s << file;
    if (n.IsDefined() && n.Mark().line >= 0) s << ":" << n.Mark().line + 1 << ":" << n.Mark().column + 1;
    s << ": " << why;
    throw ConfigError(text::cut_values(s.str()));
  }
  void check(const YAML::Node& n, const std::string& why) const {
    if (!why.empty()) fail(n, why);
  }
  void keys(const YAML::Node& n, const std::set<std::string>& allowed, const std::string& where) const {
    if (!n.IsMap()) fail(n, where + " must be a mapping");
    for (auto it = n.begin(); it != n.end(); ++it) {
      // `? [a, b]\n: 1` makes a key that is a list: as<std::string>() would throw
      if (!it->first.IsScalar()) fail(it->first, "a key in " + where + " must be a plain name, not a list or mapping");
      const std::string k = it->first.Scalar();
      if (!allowed.count(k)) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(it->first, "unknown key '" + k + "' in " + where + " (allowed: " + list + ")");
      }
    }
  }
  template <class T>
  T get(const YAML::Node& x, const char* key, T def, const char* what) const {
    if (!x.IsDefined() || x.IsNull()) return def;
    if (!x.IsScalar()) fail(x, std::string("'") + key + "' must be " + what);
    try {
      return x.as<T>();
    } catch (const YAML::Exception&) {
      fail(x, std::string("'") + key + "' must be " + what);
    }
  }
};

// The keys allowed in a section ("": the top level, whose sections are keys too).
std::set<std::string> keys_of(const std::string& section) {
  std::set<std::string> keys;
  for (const ConfigField& f : config_fields()) {
    if (f.section == section) keys.insert(f.key);
    else if (section.empty()) keys.insert(f.section);
  }
  return keys;
}

// A value as the field's kind reads it; absent or null keeps v (a refused null is no word).
void read_value(const ConfigField& f, const YAML::Node& x, const Ctx& c, FieldValue* v) {
  switch (f.kind) {
    case FieldKind::kRealOrOff:
      if (x.IsScalar() && x.Scalar() == "off") {
        v->x = 0;
        return;
      }
      [[fallthrough]];
    case FieldKind::kReal:
    case FieldKind::kCount: v->x = c.get<double>(x, f.key, v->x, f.what); return;
    case FieldKind::kInteger: v->n = c.get<long long>(x, f.key, v->n, f.what); return;
    case FieldKind::kFlag: v->b = c.get<bool>(x, f.key, v->b, f.what); return;
    case FieldKind::kChoice:
      if (f.null_refused) v->s.clear();
      [[fallthrough]];
    case FieldKind::kText: v->s = c.get<std::string>(x, f.key, v->s, f.what); return;
  }
}

bool is_choice(const ConfigField& f, const std::string& word) {
  for (const char* w : f.choices)
    if (word == w) return true;
  return false;
}

// One key of a section (or the top level) into cfg: read, checked against the keys before it, stored.
void read_field(const ConfigField& f, const YAML::Node& section, const Ctx& c, ServiceConfig* cfg) {
  const YAML::Node x = section[f.key];
  if (!x.IsDefined()) return;
  FieldValue v = f.get(*cfg);
  read_value(f, x, c, &v);
  if (f.kind == FieldKind::kChoice && !is_choice(f, v.s)) c.fail(x, field_path(f) + " must be " + choice_list(f));
  if (f.check) c.check(x, f.check(f, v, *cfg));
  f.set(*cfg, v);
}

ServiceConfig parse(const YAML::Node& root, const Ctx& c) {
  ServiceConfig cfg;
  if (!root.IsDefined() || root.IsNull()) return cfg;
  c.keys(root, keys_of(""), "the service config");
  std::string checked;  // the section whose keys were checked last
  for (const ConfigField& f : config_fields()) {
    const YAML::Node section = *f.section ? root[f.section] : root;
    if (!section.IsDefined()) continue;
    if (*f.section && checked != f.section) {
      c.keys(section, keys_of(f.section), f.section);
      checked = f.section;
    }
    read_field(f, section, c, &cfg);
  }
  return cfg;
}

std::string place(const std::string& name, const YAML::Mark& m) {
  if (m.line < 0) return name;
  return name + ":" + std::to_string(m.line + 1) + ":" + std::to_string(m.column + 1);
}

}  // namespace

ServiceConfig load_config_string(const std::string& yaml, const std::string& name) {
  Ctx c{name};
  // bounded before yaml-cpp sees it: its parser recurses per level (and stops at 500 with the
  // message "bad file")
  if (yaml.size() > text::kMaxConfigBytes)
    throw ConfigError(name + ": the service config is " + std::to_string(yaml.size()) + " bytes, more than the limit of " +
                      std::to_string(text::kMaxConfigBytes));
  if (const text::DepthExceeded d = text::yaml_depth_exceeds(yaml); d.exceeded)
    throw ConfigError(name + ":" + std::to_string(d.line) + ":" + std::to_string(d.column) + ": YAML nested deeper than " +
                      std::to_string(text::kMaxYamlDepth) + " levels (the limit for a config file)");
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::DeepRecursion& e) {
    throw ConfigError(name + ": YAML nested deeper than yaml-cpp's limit of " + std::to_string(e.depth()) + " levels");
  } catch (const YAML::Exception& e) {
    throw ConfigError(text::cut_values(place(name, e.mark) + ": " + e.msg));
  }
  // Nothing below may escape as anything but a ConfigError naming the file.
  ServiceConfig cfg;
  try {
    cfg = parse(root, c);
  } catch (const ConfigError&) {
    throw;
  } catch (const YAML::Exception& e) {
    throw ConfigError(text::cut_values(place(name, e.mark) + ": " + e.msg));
  } catch (const std::exception& e) {
    throw ConfigError(text::cut_values(name + ": " + e.what()));
  }
  try {
    validate(cfg);
  } catch (const ConfigError& e) {
    throw ConfigError(name + ": " + e.what());
  }
  return cfg;
}

ServiceConfig load_config(const std::string& path) {
  std::string yaml, why;
  if (!text::read_file(path, text::kMaxConfigBytes, "the service config", &yaml, &why)) throw ConfigError(path + ": " + why);
  return load_config_string(yaml, path);
}

void validate(const ServiceConfig& c) {
  for (const ConfigField& f : config_fields())
    if (f.check)
      if (const std::string why = f.check(f, f.get(c), c); !why.empty()) throw ConfigError(why);
}

}  // namespace coopdyn::runtime
