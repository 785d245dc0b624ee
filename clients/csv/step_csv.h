// The one per-step CSV schema (docs/conventions.md, "Per-step CSV"): what `coopdyn sim --out` writes
// for a simulated run and what `coopdyn log` writes for a daemon's output_t channel.
//
//   # coopdyn per-step CSV 1: scene NAME, source sim|log            (comment lines first)
//   # wrench NAME: kind KIND, frame FRAME, by BY                     (one per reported wrench)
//   # units: s,rad,...                                               (one unit per column)
//   t,q:NAME...,v:NAME...,tau:NAME...,vdot:NAME...,W.mx..W.fz...,stress:NAME...,
//     C.friction_needed,C.utilisation,C.contact...,status,reason,rows,rank,indeterminate,condition,
//     (with declared noise, W.sigma_mx..W.sigma_fz after each wrench's W.mx..W.fz: wrench_sigma.h;
//     then, from an estimate with the joint losses compensated, W.bound_mx..W.bound_fz: friction_bound.h)
//     residual, then the columns of one source only (sim: position_error; log: log_time, utime,
//     tick, mode, input, ...)
//
// Names are the scene's (coordinates, wrench outputs, contacts), never positions; codes are words
// (status ok, reason none, input command, ...); numbers are shortest round-trip (std::to_chars).
// Writers: write_step_csv_header() the header, write_step_cells() each row's shared cells, then the
// source's own. Readers skip the leading '#' lines (pandas: comment='#'); read_step_csv_header()
// returns the names with their units, split_csv_line() a row's cells.
#pragma once

#include <charconv>
#include <cstdio>
#include <istream>
#include <string>
#include <vector>

#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/system.h"
#include "service/io/codec/messages.h"

namespace coopdyn::cli {

constexpr const char* kStepCsvVersion = "1";

// The names (and units) a per-step CSV is made of, from a scene or from a daemon's output.
struct StepSchema {
  std::string scene, source;  // source: "sim" or "log"
  std::vector<std::string> q_names, q_units, v_names, v_units, tau_units, vdot_units;
  struct Wrench {
    std::string name, kind, frame, by;
  };
  std::vector<Wrench> wrenches;
  std::vector<std::string> stress_names, stress_units, contact_names;
  bool sigma = false;  // each wrench's six columns are followed by its standard deviations
                       // (NAME.sigma_mx .. NAME.sigma_fz, same units): the scene declares noise
  bool bound = false;  // then by its friction bound (NAME.bound_mx .. NAME.bound_fz, same units): a
                       // daemon's estimate with the joint losses compensated
};

// A scene's schema: units by joint type (revolute rad, prismatic m, floating m / 1 / rad/s / m/s).
StepSchema step_schema(const System& sys, const std::string& source);

// The schema of a daemon's outputs from their names. With sys (the run's scene), the names must be
// the scene's (else false and *err says which differs) and the units are the scene's; without it a
// floating joint's coordinates get theirs from their suffixes (.x m, .qw 1, .wx rad/s, .vx m/s)
// and any other joint "rad or m" (the log does not say whether a joint is revolute or prismatic).
bool step_schema_from_names(const std::string& scene, const std::vector<std::string>& q_names,
                            const std::vector<std::string>& v_names, const std::vector<std::string>& wrench_names,
                            const std::vector<int>& wrench_kinds, const std::vector<std::string>& wrench_frames,
                            const std::vector<std::string>& wrench_by, const std::vector<std::string>& stress_names,
                            const std::vector<std::string>& contact_names, const System* sys, StepSchema* out,
                            std::string* err);

// Column names with their units, in order.
struct CsvColumns {
  std::vector<std::string> names, units;
  void add(const std::string& name, const std::string& unit) {
    names.push_back(name);
    units.push_back(unit);
  }
};

// The columns every source writes, in this order: t ... residual.
CsvColumns shared_step_columns(const StepSchema& s);

// The comment lines, the units line and the header line.
void write_step_csv_header(std::FILE* f, const StepSchema& s, const CsvColumns& c);

// Reads the leading '#' lines and the header line of a CSV (a per-step CSV or any CSV without
// them: units then empty). *line_no is the header's line number. False with *err on an empty file
// or a units line whose count differs from the header's.
struct CsvHeader {
  std::vector<std::string> names, units;  // units: empty when the file has no units line
  std::vector<std::string> comments;      // the '#' lines, without the '#'
  int line_no = 0;
};
bool read_step_csv_header(std::istream& in, const std::string& path, CsvHeader* h, std::string* err);

// Words for the codes (the CSV's text columns; the names of output_t's constants in lower case),
// from the code tables (service/io/codec/codes.def, service/dynamics/reasons.def).
using io::control_action_key;
using io::control_result_key;
using io::input_key;
using io::mode_key;
using io::reason_key;

// A CSV line assembled in a buffer sized once (the row of a per-step CSV: no allocation per row).
class CsvLine {
 public:
  explicit CsvLine(size_t columns) : buf_(columns * 32 + 64) {}
  void clear() { n_ = 0; }
  void num(double x) {  // shortest round-trip
    reserve(32);
    n_ = static_cast<size_t>(std::to_chars(buf_.data() + n_, buf_.data() + buf_.size(), x).ptr - buf_.data());
  }
  void integer(long long x) {
    reserve(24);
    n_ = static_cast<size_t>(std::to_chars(buf_.data() + n_, buf_.data() + buf_.size(), x).ptr - buf_.data());
  }
  void text(const char* s) {
    while (*s) {
      reserve(1);
      buf_[n_++] = *s++;
    }
  }
  void sep() { reserve(1), buf_[n_++] = ','; }
  void end() { reserve(1), buf_[n_++] = '\n'; }
  void write(std::FILE* f) const { std::fwrite(buf_.data(), 1, n_, f); }

 private:
  void reserve(size_t k) {  // grows only when a text cell is longer than the sizing assumed
    if (n_ + k > buf_.size()) buf_.resize(2 * buf_.size() + k);
  }
  std::vector<char> buf_;
  size_t n_ = 0;
};

// n numbers of a source, read where they are (an Eigen vector, a std::vector; wrenches: 6 each, the
// wrenches laid end to end as in a std::vector<Vec6>): a row copies nothing.
struct CsvNumbers {
  const double* data = nullptr;
  size_t size = 0;
};
template <class V>  // std::vector<double>, Eigen::VectorXd
CsvNumbers csv_numbers(const V& x) {
  return {x.data(), static_cast<size_t>(x.size())};
}
template <class W>  // std::vector<Vec6>, std::vector<std::array<double, 6>>
CsvNumbers csv_wrenches(const std::vector<W>& w) {
  static_assert(sizeof(W) == 6 * sizeof(double), "a wrench is six numbers, the wrenches end to end");
  return {w.empty() ? nullptr : w.front().data(), 6 * w.size()};
}

// One step's values in the order of shared_step_columns, whatever computed them (a simulated step,
// a daemon's output_t).
struct StepRow {
  double t = 0;
  CsvNumbers q, v, tau, vdot, wrenches, stress;  // wrenches: mx my mz fx fy fz of each
  CsvNumbers wrench_sigma;  // (schema.sigma) the same layout: each wrench's standard deviations
  CsvNumbers wrench_bound;  // (schema.bound) the same layout: each wrench's friction bound
  // per contact: friction needed, utilisation (contact_state.size() of each) and the state's word
  const double* friction_needed = nullptr;
  const double* utilisation = nullptr;
  std::vector<const char*> contact_state;  // sized by the caller once per layout (no allocation per row)
  const char* status = "";
  const char* reason = "";
  long long rows = 0, rank = 0, indeterminate = 0;
  double condition = 0;  // -1: infinite, as output_t
  double residual = 0;
};

// Starts line l with the shared cells of row r (t ... residual); the caller appends the columns of
// its own source (l.sep() before each), then l.end().
void write_step_cells(CsvLine& l, const StepRow& r);

// The cells of one CSV line (no quoting: the schema's names and values hold no comma); a trailing
// comma gives a last empty cell.
std::vector<std::string> split_csv_line(const std::string& s);

}  // namespace coopdyn::cli
