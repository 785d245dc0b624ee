#include "clients/csv/step_csv.h"

#include <sstream>

#include "service/dynamics/wrench_components.h"
#include "service/dynamics/sigma/wrench_sigma.h"

namespace coopdyn::cli {

std::vector<std::string> split_csv_line(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string cell;
  while (std::getline(ss, cell, ',')) out.push_back(cell);
  if (!s.empty() && s.back() == ',') out.emplace_back();
  return out;
}

namespace {
// A floating joint's coordinate by its suffix (NAME.x .. NAME.qz, NAME.wx .. NAME.vz); "" otherwise.
const char* floating_q_unit(const std::string& n, const std::vector<std::string>& all) {
  const auto dot = n.rfind('.');
  if (dot == std::string::npos) return "";
  const std::string base = n.substr(0, dot), s = n.substr(dot + 1);
  bool floating = false;
  for (const auto& o : all) floating = floating || o == base + ".qw";
  if (!floating) return "";
  if (s == "x" || s == "y" || s == "z") return "m";
  if (s == "qw" || s == "qx" || s == "qy" || s == "qz") return "1";
  return "";
}
int floating_v_kind(const std::string& n, const std::vector<std::string>& all) {  // 1 angular, 2 linear, 0 not
  const auto dot = n.rfind('.');
  if (dot == std::string::npos) return 0;
  const std::string base = n.substr(0, dot), s = n.substr(dot + 1);
  int have = 0;
  for (const auto& o : all) have += o == base + ".wx" || o == base + ".vz";
  if (have != 2) return 0;
  if (s == "wx" || s == "wy" || s == "wz") return 1;
  if (s == "vx" || s == "vy" || s == "vz") return 2;
  return 0;
}
}  // namespace

StepSchema step_schema(const System& sys, const std::string& source) {
  const Model& m = sys.model;
  StepSchema s;
  s.scene = sys.name;
  s.source = source;
  s.q_names = m.q_names;
  s.v_names = m.v_names;
  s.q_units.resize(static_cast<size_t>(m.nq()));
  s.v_units.resize(static_cast<size_t>(m.nv()));
  s.tau_units.resize(static_cast<size_t>(m.nv()));
  s.vdot_units.resize(static_cast<size_t>(m.nv()));
  for (const Body& b : m.bodies) {
    const Joint& j = b.joint;
    for (int k = 0; k < j.nq; ++k) {
      const char* u = j.type == JointType::kPrismatic ? "m" : j.type == JointType::kFloating ? (k < 3 ? "m" : "1") : "rad";
      s.q_units[static_cast<size_t>(j.idx_q + k)] = u;
    }
    for (int k = 0; k < j.nv; ++k) {
      // floating: [w; v] in the body frame; prismatic: a translation; the rest rotations
      const bool linear = j.type == JointType::kPrismatic || (j.type == JointType::kFloating && k >= 3);
      const size_t i = static_cast<size_t>(j.idx_v + k);
      s.v_units[i] = linear ? "m/s" : "rad/s";
      s.tau_units[i] = linear ? "N" : "N*m";
      s.vdot_units[i] = linear ? "m/s^2" : "rad/s^2";
    }
  }
  for (const WrenchOutput& o : sys.wrenches.outputs) s.wrenches.push_back({o.name, wrench_kind_name(o.kind), o.frame, o.by});
  s.sigma = wrench_sigma_supported(sys);
  for (int k = 0; k < num_stresses(sys); ++k) {  // the pseudo-joints', then the joint couplings'
    s.stress_names.push_back(stress_name(sys, k));
    s.stress_units.push_back(stress_unit(sys, k));
  }
  for (const ConstraintSpec& c : sys.constraints.specs)
    if (c.kind == ConstraintKind::kRolling) s.contact_names.push_back(c.name);
  return s;
}

bool step_schema_from_names(const std::string& scene, const std::vector<std::string>& q_names,
                            const std::vector<std::string>& v_names, const std::vector<std::string>& wrench_names,
                            const std::vector<int>& wrench_kinds, const std::vector<std::string>& wrench_frames,
                            const std::vector<std::string>& wrench_by, const std::vector<std::string>& stress_names,
                            const std::vector<std::string>& contact_names, const System* sys, StepSchema* out,
                            std::string* err) {
  if (sys) {
    *out = step_schema(*sys, "log");
    auto same = [&](const char* what, const std::vector<std::string>& a, const std::vector<std::string>& b) {
      if (a == b) return true;
      *err = std::string("the log's ") + what + " are not those of scene '" + sys->name + "'";
      for (size_t i = 0; i < std::max(a.size(), b.size()); ++i)
        if (i >= a.size() || i >= b.size() || a[i] != b[i]) {
          *err += " (entry " + std::to_string(i) + ": log '" + (i < a.size() ? a[i] : "") + "', scene '" +
                  (i < b.size() ? b[i] : "") + "')";
          break;
        }
      return false;
    };
    std::vector<std::string> wn;
    for (const auto& w : out->wrenches) wn.push_back(w.name);
    return same("coordinates q", q_names, out->q_names) && same("velocities v", v_names, out->v_names) &&
           same("wrenches", wrench_names, wn) && same("stresses", stress_names, out->stress_names) &&
           same("contacts", contact_names, out->contact_names);
  }
  StepSchema& s = *out;
  s = StepSchema{};
  s.scene = scene;
  s.source = "log";
  s.q_names = q_names;
  s.v_names = v_names;
  for (const auto& n : q_names) {
    const char* u = floating_q_unit(n, q_names);
    s.q_units.push_back(*u ? u : "rad or m");
  }
  for (const auto& n : v_names) {
    const int k = floating_v_kind(n, v_names);
    s.v_units.push_back(k == 1 ? "rad/s" : k == 2 ? "m/s" : "rad/s or m/s");
    s.tau_units.push_back(k == 1 ? "N*m" : k == 2 ? "N" : "N*m or N");
    s.vdot_units.push_back(k == 1 ? "rad/s^2" : k == 2 ? "m/s^2" : "rad/s^2 or m/s^2");
  }
  static const char* kinds[5] = {"end_effector", "base", "tip", "axle", "joint"};
  for (size_t i = 0; i < wrench_names.size(); ++i) {
    const int k = i < wrench_kinds.size() ? wrench_kinds[i] : -1;
    s.wrenches.push_back({wrench_names[i], k >= 0 && k < 5 ? kinds[k] : "unknown", i < wrench_frames.size() ? wrench_frames[i] : "",
                          i < wrench_by.size() ? wrench_by[i] : ""});
  }
  s.stress_names = stress_names;
  for (const auto& n : stress_names) {
    size_t i = 0;
    while (i < v_names.size() && v_names[i] != n) ++i;
    s.stress_units.push_back(i < v_names.size() ? s.tau_units[i] : "N*m or N");
  }
  s.contact_names = contact_names;
  return true;
}

CsvColumns shared_step_columns(const StepSchema& s) {
  CsvColumns c;
  c.add("t", "s");
  for (size_t i = 0; i < s.q_names.size(); ++i) c.add("q:" + s.q_names[i], s.q_units[i]);
  for (size_t i = 0; i < s.v_names.size(); ++i) c.add("v:" + s.v_names[i], s.v_units[i]);
  for (size_t i = 0; i < s.v_names.size(); ++i) c.add("tau:" + s.v_names[i], s.tau_units[i]);
  for (size_t i = 0; i < s.v_names.size(); ++i) c.add("vdot:" + s.v_names[i], s.vdot_units[i]);
  for (const auto& w : s.wrenches) {
    for (int k = 0; k < 6; ++k) c.add(w.name + "." + kWrenchComponents[k], k < 3 ? "N*m" : "N");
    if (s.sigma)
      for (int k = 0; k < 6; ++k) c.add(w.name + ".sigma_" + kWrenchComponents[k], k < 3 ? "N*m" : "N");
    if (s.bound)
      for (int k = 0; k < 6; ++k) c.add(w.name + ".bound_" + kWrenchComponents[k], k < 3 ? "N*m" : "N");
  }
  for (size_t i = 0; i < s.stress_names.size(); ++i) c.add("stress:" + s.stress_names[i], s.stress_units[i]);
  for (const auto& n : s.contact_names) {
    c.add(n + ".friction_needed", "1");
    c.add(n + ".utilisation", "1");
    c.add(n + ".contact", "text");
  }
  for (const char* n : {"status", "reason"}) c.add(n, "text");
  for (const char* n : {"rows", "rank", "indeterminate", "condition"}) c.add(n, "1");
  c.add("residual", "m/s^2 or rad/s^2");
  return c;
}

void write_step_csv_header(std::FILE* f, const StepSchema& s, const CsvColumns& c) {
  std::fprintf(f, "# coopdyn per-step CSV %s: scene %s, source %s (docs/conventions.md)\n", kStepCsvVersion,
               s.scene.c_str(), s.source.c_str());
  for (const auto& w : s.wrenches)
    std::fprintf(f, "# wrench %s: kind %s, frame %s, by %s\n", w.name.c_str(), w.kind.c_str(), w.frame.c_str(), w.by.c_str());
  std::fprintf(f, "# units: ");
  for (size_t i = 0; i < c.units.size(); ++i) std::fprintf(f, "%s%s", i ? "," : "", c.units[i].c_str());
  std::fprintf(f, "\n");
  for (size_t i = 0; i < c.names.size(); ++i) std::fprintf(f, "%s%s", i ? "," : "", c.names[i].c_str());
  std::fprintf(f, "\n");
}

void write_step_cells(CsvLine& l, const StepRow& r) {
  l.clear();
  l.num(r.t);
  for (const CsvNumbers* x : {&r.q, &r.v, &r.tau, &r.vdot})
    for (size_t k = 0; k < x->size; ++k) l.sep(), l.num(x->data[k]);
  for (size_t w = 0; w < r.wrenches.size; w += 6) {
    for (size_t k = w; k < w + 6; ++k) l.sep(), l.num(r.wrenches.data[k]);
    if (r.wrench_sigma.size == r.wrenches.size)
      for (size_t k = w; k < w + 6; ++k) l.sep(), l.num(r.wrench_sigma.data[k]);
    if (r.wrench_bound.size == r.wrenches.size)
      for (size_t k = w; k < w + 6; ++k) l.sep(), l.num(r.wrench_bound.data[k]);
  }
  for (size_t k = 0; k < r.stress.size; ++k) l.sep(), l.num(r.stress.data[k]);
  for (size_t k = 0; k < r.contact_state.size(); ++k) {
    l.sep(), l.num(r.friction_needed[k]);
    l.sep(), l.num(r.utilisation[k]);
    l.sep(), l.text(r.contact_state[k]);
  }
  l.sep(), l.text(r.status);
  l.sep(), l.text(r.reason);
  l.sep(), l.integer(r.rows);
  l.sep(), l.integer(r.rank);
  l.sep(), l.integer(r.indeterminate);
  l.sep(), l.num(r.condition);
  l.sep(), l.num(r.residual);
}

bool read_step_csv_header(std::istream& in, const std::string& path, CsvHeader* h, std::string* err) {
  *h = CsvHeader{};
  std::string line, units_line;
  bool have_units = false;
  int units_at = 0;
  while (std::getline(in, line)) {
    ++h->line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] != '#') break;
    const std::string body = line.substr(1);
    h->comments.push_back(body);
    const std::string key = " units: ";
    if (body.compare(0, key.size(), key) == 0) {
      units_line = body.substr(key.size());
      have_units = true;
      units_at = h->line_no;
    }
  }
  if (line.empty() || line[0] == '#') {
    *err = path + ": no header line (expected the column names)";
    return false;
  }
  h->names = split_csv_line(line);
  if (have_units) {
    h->units = split_csv_line(units_line);
    if (h->units.size() != h->names.size()) {
      *err = path + ":" + std::to_string(units_at) + ": " + std::to_string(h->units.size()) + " units for " +
             std::to_string(h->names.size()) + " columns";
      return false;
    }
  }
  return true;
}

}  // namespace coopdyn::cli
