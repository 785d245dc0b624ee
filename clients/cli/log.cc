// coopdyn log: an lcm-logger file -> one CSV per channel (coopdyn types), a per-channel summary
// (type, count, rate), and PNG plots of the wrenches (joint reactions apart) and the loop timing when
// matplotlib is available (/usr/bin/python3 with python3-matplotlib; optional: the CSVs never need it).
//
// The output_t channel's CSV is the per-step schema of clients/csv/step_csv.h, the one `coopdyn sim
// --out` writes (t first, the scene's names, codes as words, a units line), then the columns only a
// daemon has (log_time, utime, tick, mode, input, ...). The other channels' CSVs follow the same
// rules: names without units, the units in a '# units:' line, coordinates by the scene's names
// (commands sent without names get them from the outputs or --scene). --in FILE.csv plots a per-step
// CSV (a sim's) with the same plotter (clients/cli/log_plot.py, compiled in).
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <string>

#include "clients/cli/cli.h"
#include "clients/cli/lcm_log.h"
#include "clients/cli/progress.h"
#include "clients/csv/step_csv.h"
#include "service/dynamics/contacts.h"
#include "service/io/codec/codec.h"
#include "service/scene/scene.h"

namespace coopdyn::cli {

namespace {
struct Channel {
  io::MessageType type = io::MessageType::kUnknown;
  std::string header, path;
  std::FILE* f = nullptr;
  long count = 0, bad = 0;
  int64_t first_us = 0, last_us = 0;
  std::vector<std::string> q_names, v_names, wrench_names, stress_names, contact_names;  // output_t: the first's
  int action_col = -1;  // control_t: the action's column, written as a word
  bool sigma = false;   // output_t: the wrenches' sigma columns (the scene declares noise)
  bool bound = false;   // output_t: their friction bound columns (an estimate, joint losses compensated)
};

const char* kPlotScript =
#include "log_plot.inc"
    ;

// The names and units of a channel other than output_t, from io::to_csv's header: the same naming
// rules as the per-step CSV (units out of the names, coordinates by name: 'tau:3' of a command sent
// without names becomes the scene's fourth velocity name).
CsvColumns other_columns(io::MessageType type, const std::string& header, const StepSchema* scene, int* action_col) {
  std::map<std::string, std::string> unit_of;  // "q:NAME" -> unit
  if (scene) {
    for (size_t i = 0; i < scene->q_names.size(); ++i) unit_of["q:" + scene->q_names[i]] = scene->q_units[i];
    for (size_t i = 0; i < scene->v_names.size(); ++i) {
      unit_of["v:" + scene->v_names[i]] = scene->v_units[i];
      unit_of["tau:" + scene->v_names[i]] = scene->tau_units[i];
    }
  }
  CsvColumns c;
  c.add("log_time", "s");
  *action_col = -1;
  const std::vector<std::string> h = split_csv_line(header);
  for (size_t k = 0; k < h.size(); ++k) {
    std::string n = h[k];
    const auto colon = n.find(':');
    if (colon != std::string::npos && scene) {  // a coordinate given by its index: the scene's name
      const std::string what = n.substr(0, colon), idx = n.substr(colon + 1);
      const std::vector<std::string>& names = what == "q" ? scene->q_names : scene->v_names;
      if (!idx.empty() && idx.find_first_not_of("0123456789") == std::string::npos && std::stoul(idx) < names.size())
        n = what + ":" + names[std::stoul(idx)];
    }
    std::string unit = "1";
    if (n == "utime" || n == "input_utime") unit = "us";
    else if (n.size() > 3 && n.compare(n.size() - 3, 3, "_us") == 0) n.resize(n.size() - 3), unit = "us";
    else if (colon != std::string::npos) {
      const auto it = unit_of.find(n);
      const std::string what = n.substr(0, colon);
      unit = it != unit_of.end() ? it->second : what == "q" ? "rad or m" : what == "v" ? "rad/s or m/s" : "N*m or N";
    }
    if (type == io::MessageType::kControl && n == "action") *action_col = static_cast<int>(k), unit = "text";
    c.add(n, unit);
  }
  return c;
}

void write_header(std::FILE* f, const std::string& what, const CsvColumns& c) {
  std::fprintf(f, "# coopdyn log CSV %s: %s (docs/conventions.md)\n# units: ", kStepCsvVersion, what.c_str());
  for (size_t i = 0; i < c.units.size(); ++i) std::fprintf(f, "%s%s", i ? "," : "", c.units[i].c_str());
  std::fprintf(f, "\n");
  for (size_t i = 0; i < c.names.size(); ++i) std::fprintf(f, "%s%s", i ? "," : "", c.names[i].c_str());
  std::fprintf(f, "\n");
}

// The output_t columns only a daemon has, after the shared ones: log_time, then the fields whose csv
// writer (service/io/codec/output_fields.def) is not none or step, in the message's order.
#define COOPDYN_CALL(m, args) m args
#define COOPDYN_UNPAREN(...) __VA_ARGS__
#define COOPDYN_LOG_COLUMN(name, writer, unit) COOPDYN_LOG_COLUMN_##writer(name, unit)
#define COOPDYN_LOG_COLUMN_none(name, unit)
#define COOPDYN_LOG_COLUMN_step(name, unit)
#define COOPDYN_LOG_COLUMN_integer(name, unit) c->add(#name, unit);
#define COOPDYN_LOG_COLUMN_key(name, unit) c->add(#name, unit);
#define COOPDYN_LOG_COLUMN_closure(name, unit) \
  for (int k = 0; k < 4; ++k) c->add(std::string(#name "_") + kClosureKinds[k], kClosureUnits[k]);
#define COOPDYN_LOG_COLUMN_closure_at(name, unit) \
  for (int k = 0; k < 4; ++k) c->add(std::string("closure_") + kClosureKinds[k] + "_at", unit);
#define COOPDYN_LOG_COLUMN_wrench_bits(field, unit) \
  for (const auto& w : s.wrenches) c->add(w.name + "." #field, unit);
#define COOPDYN_LOG_COLUMN_joint_bits(field, unit) \
  for (const auto& n : s.v_names) c->add("limit:" + n, unit);
constexpr const char* kClosureKinds[4] = {"position", "orientation", "linear_velocity", "angular_velocity"};
constexpr const char* kClosureUnits[4] = {"m", "rad", "m/s", "rad/s"};
void add_log_columns(const StepSchema& s, CsvColumns* c) {
  c->add("log_time", "s");
#define COOPDYN_OUTPUT_FIELD(name, type, size, since, absent, on_error, csv, doc) \
  COOPDYN_CALL(COOPDYN_LOG_COLUMN, (name, COOPDYN_UNPAREN csv))
#include "service/io/codec/output_fields.def"
}

// The cells of the columns only a daemon has (add_log_columns), after the shared ones.
#define COOPDYN_LOG_CELL(name, writer, unit) COOPDYN_LOG_CELL_##writer(name)
#define COOPDYN_LOG_CELL_none(name)
#define COOPDYN_LOG_CELL_step(name)
#define COOPDYN_LOG_CELL_integer(name) l.sep(), l.integer(o.name);
#define COOPDYN_LOG_CELL_key(name) l.sep(), l.text(name##_key(o.name));
#define COOPDYN_LOG_CELL_closure(name) \
  for (double y : o.name) l.sep(), l.num(y);
#define COOPDYN_LOG_CELL_closure_at(name) \
  for (int c : o.name) { /* the constraint's name, empty if none */ \
    l.sep();                                                          \
    if (c >= 0 && c < static_cast<int>(o.constraint_names.size()))    \
      l.text(o.constraint_names[static_cast<size_t>(c)].c_str());     \
  }
#define COOPDYN_LOG_CELL_wrench_bits(name) \
  for (int m : o.name) l.sep(), l.integer(m);
#define COOPDYN_LOG_CELL_joint_bits(name) \
  for (int m : o.name) l.sep(), l.integer(m);
void write_log_cells(CsvLine& l, const io::DecodedOutput& o, double log_time) {
  l.sep(), l.num(log_time);
#define COOPDYN_OUTPUT_FIELD(name, type, size, since, absent, on_error, csv, doc) \
  COOPDYN_CALL(COOPDYN_LOG_CELL, (name, COOPDYN_UNPAREN csv))
#include "service/io/codec/output_fields.def"
}

// The shared cells of an output_t (its contact states as words, in r's buffer).
void step_row_of_output(const io::DecodedOutput& o, StepRow* r) {
  r->t = o.sim_time;
  r->q = csv_numbers(o.q);
  r->v = csv_numbers(o.v);
  r->tau = csv_numbers(o.tau);
  r->vdot = csv_numbers(o.vdot);
  r->wrenches = csv_wrenches(o.wrench);
  r->stress = csv_numbers(o.stress);
  r->friction_needed = o.contact_friction_needed.data();
  r->utilisation = o.contact_utilisation.data();
  r->contact_state.resize(o.contact_names.size());  // a channel's layout is fixed: no allocation after its first row
  for (size_t k = 0; k < o.contact_names.size(); ++k)
    r->contact_state[k] = contact_state_name(static_cast<ContactState>(o.contact_state[k]));
  r->status = o.status >= 0 && o.status <= 2 ? status_name(static_cast<Status>(o.status)) : "unknown";
  r->reason = reason_key(o.reason);
  r->rows = o.rows;
  r->rank = o.rank;
  r->indeterminate = o.indeterminate;
  r->condition = o.condition;
  r->residual = o.residual;
}

void write_output_row(CsvLine& l, StepRow& r, const io::DecodedOutput& o, double log_time, bool sigma, bool bound,
                      std::FILE* f) {
  step_row_of_output(o, &r);
  r.wrench_sigma = sigma ? csv_wrenches(o.wrench_sigma) : CsvNumbers{};
  r.wrench_bound = bound ? csv_wrenches(o.wrench_bound) : CsvNumbers{};
  write_step_cells(l, r);
  write_log_cells(l, o, log_time);
  l.end();
  l.write(f);
}

// Runs the plotter (clients/cli/log_plot.py) on a per-step CSV and a stats CSV ('' when none); it
// reports its stages on stderr when `progress` is on. The plotter itself tells a Python without
// matplotlib (exit 3): one Python start, not two.
int plot(const LogArgs& a, const std::string& out, const std::string& steps_csv, const std::string& stats_csv,
         bool progress) {
  std::fflush(stdout);  // the table before the plotter's own lines
  const std::string py = a.python;
  const std::string script = out + "/.plot.py";
  if (std::FILE* f = std::fopen(script.c_str(), "w")) {
    std::fputs(kPlotScript, f);
    std::fclose(f);
  }
  if (progress) std::fprintf(stderr, "coopdyn log: plotting %s with %s\n", steps_csv.c_str(), py.c_str());
  const int rc = std::system((shell_quote(py) + " " + shell_quote(script) + (progress ? " --progress " : " ") +
                              shell_quote(out) + " " + shell_quote(steps_csv) + " " + shell_quote(stats_csv))
                                 .c_str());
  std::remove(script.c_str());
  const int status = rc != -1 && WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  if (status == 127)
    std::printf("coopdyn log: no PNG plots: cannot run %s; the CSVs above are complete\n", py.c_str());
  else if (status == 3)
    std::printf(
        "coopdyn log: no PNG plots: %s cannot import matplotlib (Debian: apt-get install python3-matplotlib); "
        "the CSVs above are complete\n",
        py.c_str());
  else if (status != 0)
    std::printf("coopdyn log: plotting failed (exit %d); the CSVs are complete\n", status);
  return 0;
}

bool ends_with(const std::string& s, const std::string& x) {
  return s.size() >= x.size() && s.compare(s.size() - x.size(), x.size(), x) == 0;
}

// --in FILE.csv: true when it reads as a per-step CSV, else false, the reason printed.
bool is_step_csv(const std::string& in) {
  std::ifstream f(in);
  CsvHeader h;
  std::string err;
  if (!f || !read_step_csv_header(f, in, &h, &err)) {
    std::fprintf(stderr, "coopdyn log: %s\n", f ? err.c_str() : ("cannot read '" + in + "'").c_str());
    return false;
  }
  if (h.names.empty() || h.names[0] != "t" || h.units.empty()) {
    std::fprintf(stderr, "coopdyn log: %s:%d: not a per-step CSV (expected a '# units:' line and t first)\n", in.c_str(),
                 h.line_no);
    return false;
  }
  return true;
}

// The scene's names for the channels that may come before the first output (commands without
// names): from --scene, else from the log's first output_t; null when neither has them.
std::unique_ptr<StepSchema> names_for_commands(const std::string& in, const System* sys) {
  if (sys) return std::make_unique<StepSchema>(step_schema(*sys, "log"));
  std::unique_ptr<StepSchema> names;
  io::DecodedOutput o;
  read_lcm_log(in, [&](const LogMessage& ev) {
    if (ev.type != io::MessageType::kOutput || !io::decode_output(ev.data, ev.len, &o)) return true;
    names = std::make_unique<StepSchema>();
    std::string err;
    step_schema_from_names("", o.q_names, o.v_names, o.wrench_names, o.wrench_kind, o.wrench_frames, o.wrench_by,
                           o.stress_names, o.contact_names, nullptr, names.get(), &err);
    return false;
  });
  return names;
}

double file_size(const std::string& path) {
  struct stat st{};
  stat(path.c_str(), &st);
  return static_cast<double>(st.st_size);
}

// The log's conversion, message by message: each channel's CSV and counts.
struct Conversion {
  Conversion(const std::string& in_, const std::string& out_, const System* sys_, const StepSchema* names_)
      : in(in_), out(out_), sys(sys_), names(names_), total_bytes(file_size(in_)) {}
  std::string in, out;
  const System* sys;        // --scene, or null
  const StepSchema* names;  // names_for_commands, or null
  double total_bytes;       // the log's size (progress)
  double bytes = 0;
  long messages = 0;
  std::map<std::string, Channel> chans;
  int64_t t_first = -1;
  bool made_dir = false, write_failed = false;
  std::string failure;
  std::string header, row;  // io::to_csv's, of the last message
  io::DecodedOutput o;
  StepRow step;
  std::unique_ptr<CsvLine> line;  // sized by the output_t channel's columns

  bool fail(const std::string& why) {  // stops the reading
    failure = why;
    write_failed = true;
    return false;
  }
};

void report_progress(Progress& progress, Conversion& cv, const LogMessage& ev) {
  cv.bytes += 28.0 + static_cast<double>(ev.channel.size()) + ev.len;  // an event's header, channel and data
  if (!progress.on() || (++cv.messages & 255) != 0) return;
  const double frac = cv.total_bytes > 0 ? std::min(1.0, cv.bytes / cv.total_bytes) : 1.0;
  char what[96];
  std::snprintf(what, sizeof what, "%ld messages (%.0f %% of the log)", cv.messages, 100 * frac);
  progress.report(frac, what);
}

Channel& count_message(Conversion& cv, const LogMessage& ev) {
  if (cv.t_first < 0) cv.t_first = ev.timestamp_us;
  Channel& c = cv.chans[ev.channel];
  if (c.count == 0) {
    c.first_us = ev.timestamp_us;
    c.type = ev.type;
  }
  ++c.count;
  c.last_us = ev.timestamp_us;
  return c;
}

bool open_csv(Conversion& cv, Channel& c, const std::string& channel) {
  c.path = cv.out + "/" + channel + ".csv";
  c.f = std::fopen(c.path.c_str(), "w");
  if (!c.f) return cv.fail("cannot write '" + c.path + "'");
  return true;
}

// The output_t channel's CSV from its first output: the schema of its names (the scene's, with
// --scene), the header, the row buffer.
bool start_output_csv(Conversion& cv, Channel& c, const std::string& channel) {
  const io::DecodedOutput& o = cv.o;
  StepSchema s;
  std::string err;
  if (!step_schema_from_names(cv.sys ? cv.sys->name : "", o.q_names, o.v_names, o.wrench_names, o.wrench_kind, o.wrench_frames,
                              o.wrench_by, o.stress_names, o.contact_names, cv.sys, &s, &err))
    return cv.fail(cv.in + ": channel " + channel + ": " + err);
  if (s.scene.empty()) s.scene = "(not in the log; --scene names it)";
  // sigma columns: the scene's noise (--scene), else the first output's
  if (!cv.sys) s.sigma = o.sigma_source != 0;
  c.sigma = s.sigma;
  // friction bound columns: the first output is an estimate with the joint losses compensated
  s.bound = o.mode == static_cast<int>(io::Mode::kEstimate) && o.joint_losses == static_cast<int>(io::JointLosses::kCompensated);
  c.bound = s.bound;
  if (!open_csv(cv, c, channel)) return false;
  CsvColumns cols = shared_step_columns(s);
  add_log_columns(s, &cols);
  write_step_csv_header(c.f, s, cols);
  cv.line = std::make_unique<CsvLine>(cols.names.size());
  c.q_names = o.q_names, c.v_names = o.v_names, c.wrench_names = o.wrench_names;
  c.stress_names = o.stress_names, c.contact_names = o.contact_names;
  return true;
}

bool convert_output(Conversion& cv, Channel& c, const LogMessage& ev, double log_time) {
  const io::DecodedOutput& o = cv.o;
  if (!io::decode_output(ev.data, ev.len, &cv.o)) {
    ++c.bad;
    return true;
  }
  if (!c.f) {
    if (!start_output_csv(cv, c, ev.channel)) return false;
  } else if (o.q_names != c.q_names || o.v_names != c.v_names || o.wrench_names != c.wrench_names ||
             o.stress_names != c.stress_names || o.contact_names != c.contact_names) {
    ++c.bad;  // a different scene mid-log: its rows do not fit these columns
    return true;
  }
  write_output_row(*cv.line, cv.step, o, log_time, c.sigma, c.bound, c.f);
  return true;
}

// Any other coopdyn type: io::to_csv's row after log_time, control_t's action as a word.
bool convert_other(Conversion& cv, Channel& c, const LogMessage& ev, double log_time) {
  if (!io::to_csv(c.type, ev.data, ev.len, &cv.header, &cv.row)) {
    ++c.bad;
    return true;
  }
  if (!c.f) {
    if (!open_csv(cv, c, ev.channel)) return false;
    c.header = cv.header;
    write_header(c.f, ev.channel + " (" + io::type_name(c.type) + ")", other_columns(c.type, cv.header, cv.names, &c.action_col));
  }
  if (cv.header != c.header) {  // a different scene mid-log: its rows do not fit these columns
    ++c.bad;
    return true;
  }
  std::string& row = cv.row;
  if (c.action_col >= 0) {
    std::vector<std::string> cells = split_csv_line(row);
    cells[static_cast<size_t>(c.action_col)] = control_action_key(std::atoi(cells[static_cast<size_t>(c.action_col)].c_str()));
    row.clear();
    for (size_t k = 0; k < cells.size(); ++k) row += (k ? "," : "") + cells[k];
  }
  char lt[32];
  *std::to_chars(lt, lt + sizeof lt - 1, log_time).ptr = 0;
  std::fprintf(c.f, "%s,%s\n", lt, row.c_str());
  return true;
}

// One message of the log; false stops the reading (a write failed).
bool convert_message(Conversion& cv, Progress& progress, const LogMessage& ev) {
  if (!cv.made_dir) {  // once the log reads: a missing log makes no directory
    cv.made_dir = true;
    if (mkdir(cv.out.c_str(), 0755) != 0 && errno != EEXIST) return cv.fail("cannot create directory '" + cv.out + "'");
  }
  report_progress(progress, cv, ev);
  Channel& c = count_message(cv, ev);
  const double log_time = static_cast<double>(ev.timestamp_us - cv.t_first) * 1e-6;
  if (c.type == io::MessageType::kUnknown) return true;
  if (c.type == io::MessageType::kOutput) return convert_output(cv, c, ev, log_time);
  return convert_other(cv, c, ev, log_time);
}

// The table of channels (type, count, rate, CSV), closing the CSVs; the first output_t and
// loop_stats_t CSVs for the plotter.
void print_summary(std::map<std::string, Channel>& chans, std::string* out_csv, std::string* stats_csv) {
  std::printf("%-20s %-26s %9s %10s  %s\n", "channel", "type", "messages", "rate_hz", "csv");
  for (auto& [name, c] : chans) {
    if (c.f) std::fclose(c.f);
    const double span = static_cast<double>(c.last_us - c.first_us) * 1e-6;
    const double rate = c.count > 1 && span > 0 ? static_cast<double>(c.count - 1) / span : 0.0;
    std::printf("%-20s %-26s %9ld %10.1f  %s\n", name.c_str(), io::type_name(c.type), c.count, rate,
                c.path.empty() ? "-" : c.path.c_str());
    if (c.bad) std::printf("  (%ld messages of %s did not decode or changed layout; skipped)\n", c.bad, name.c_str());
    if (c.type == io::MessageType::kOutput && out_csv->empty()) *out_csv = c.path;
    if (c.type == io::MessageType::kLoopStats && stats_csv->empty()) *stats_csv = c.path;
  }
}
}  // namespace

void register_log(Cli& cli) {
  auto [c, a] = cli.add("log", cmd_log);
  value(c, "--in", a.in, "FILE", "the log (FILE.lcmlog), or a per-step CSV (FILE.csv) to plot")->required();
  value(c, "--out", a.out, "DIR",
        "directory for the CSVs and plots (default: the input's path without its extension, then _csv)");
  value(c, "--scene", a.scene, "FILE",
        "the run's scene: exact units of its joints and names for commands sent without names (default: from "
        "the log's outputs)");
  flag(c, "--no-plot", a.no_plot, "CSVs only");
  flag(c, "--progress", a.progress, "report progress on stderr (default: only when stderr is a terminal)");
  value(c, "--python", a.python, "PATH", "the Python that plots", Default::kShown);
}

int cmd_log(const LogArgs& a) {
  const std::string in = a.in;
  std::string out = a.out;
  if (out.empty()) {
    out = in;
    const auto dot = out.rfind('.');
    if (dot != std::string::npos && dot > out.rfind('/') + 1) out = out.substr(0, dot);
    out += "_csv";
  }
  if (ends_with(in, ".csv")) {  // a per-step CSV: plots only
    if (!is_step_csv(in)) return 1;
    if (a.no_plot) return 0;
    if (mkdir(out.c_str(), 0755) != 0 && errno != EEXIST) {
      std::fprintf(stderr, "coopdyn log: cannot create directory '%s'\n", out.c_str());
      return 1;
    }
    return plot(a, out, in, "", a.progress || isatty(STDERR_FILENO));
  }
  std::unique_ptr<System> sys;
  if (a.scene) {
    sys = std::make_unique<System>();
    if (const int rc = load_cli_scene(a, "log", sys.get())) return rc;
  }
  std::unique_ptr<StepSchema> names;
  try {
    names = names_for_commands(in, sys.get());
  } catch (const std::runtime_error& e) {
    std::fprintf(stderr, "coopdyn log: %s\n", e.what());
    return 1;
  }
  Conversion cv(in, out, sys.get(), names.get());
  Progress progress("coopdyn log", a.progress);
  try {
    read_lcm_log(in, [&](const LogMessage& ev) { return convert_message(cv, progress, ev); });
  } catch (const std::runtime_error& e) {
    std::fprintf(stderr, "coopdyn log: %s\n", e.what());
    return 1;
  }
  progress.done(std::to_string(cv.messages) + " messages");
  if (cv.write_failed) {
    std::fprintf(stderr, "coopdyn log: %s\n", cv.failure.c_str());
    for (auto& [name, c] : cv.chans)
      if (c.f) std::fclose(c.f);
    return 1;
  }
  std::string out_csv, stats_csv;
  print_summary(cv.chans, &out_csv, &stats_csv);
  if (a.no_plot || out_csv.empty()) return 0;
  return plot(a, out, out_csv, stats_csv, progress.on());
}

}  // namespace coopdyn::cli
