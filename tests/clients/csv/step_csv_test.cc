// The one per-step CSV schema (clients/csv/step_csv.h): `coopdyn sim --out` and `coopdyn log` of a
// daemon's outputs write the same columns with the same units, and the same text where the runs
// are identical. The daemon runs in estimate mode over memq:// (the loop in this process) and is
// fed the simulator's own states; its outputs, the states and a command sent without names are
// written to an LCM log with LCM's event-log API, which `coopdyn log` converts.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>
#include <thread>

#include <unistd.h>

#include <lcm/lcm-cpp.hpp>

#include "clients/csv/step_csv.h"
#include "service/io/transport/lcm_bus.h"
#include "service/runtime/service_loop.h"
#include "tests/support/child_process.h"
#include "tests/support/daemon_test_util.h"

using namespace coopdyn;
using namespace coopdyn::daemon_test;
using namespace std::chrono_literals;

namespace {

struct Table {
  cli::CsvHeader h;
  std::vector<std::vector<std::string>> rows;
  int col(const std::string& n) const {
    const auto it = std::find(h.names.begin(), h.names.end(), n);
    return it == h.names.end() ? -1 : static_cast<int>(it - h.names.begin());
  }
};
Table read_table(const std::string& path) {
  Table t;
  std::ifstream f(path);
  std::string err;
  EXPECT_TRUE(cli::read_step_csv_header(f, path, &t.h, &err)) << err;
  for (std::string line; std::getline(f, line);) t.rows.push_back(cli::split_csv_line(line));
  for (const auto& r : t.rows) EXPECT_EQ(r.size(), t.h.names.size()) << path;
  return t;
}

struct Event {
  std::string channel;
  std::vector<uint8_t> data;
  int64_t utime;
};

// Simulates SCENE for 0.2 s, replays every row as a measured state into the daemon's loop in
// estimate mode, and converts the log of that run; returns the sim CSV and the log's directory.
void sim_and_replay(const std::string& scene, const std::vector<std::string>& torque, const std::string& tag,
                    std::string* sim_csv, std::string* log_path) {
  *sim_csv = tmp_path(tag + "_sim.csv");
  *log_path = tmp_path(tag + ".lcmlog");
  std::vector<std::string> argv = {COOPDYN_PATH, "sim", "--scene", scene_path(scene), "--duration", "0.2", "--dt", "0.002",
                                   "--out", *sim_csv};
  for (const auto& p : torque) argv.insert(argv.end(), {"--torque", p});
  {
    Child sim(argv, tag + "_sim");
    ASSERT_EQ(sim.wait(), 0) << slurp(sim.err);
  }
  const Table s = read_table(*sim_csv);
  const System sys = load_scene(scene_path(scene));
  const int nq = sys.model.nq(), nv = sys.model.nv();

  runtime::ServiceConfig cfg;
  cfg.mode = runtime::ServiceMode::kEstimate;
  io::LcmBus bus("memq://");
  runtime::ServiceLoop loop(sys, cfg, bus);
  bus.subscribe(cfg.state_channel, [&](const void* d, int n, long long t) { loop.states().offer(d, n, t); });
  std::mutex mu;
  std::vector<Event> events;
  std::atomic<int64_t> last_seq{-1};
  bus.subscribe(cfg.output_channel, [&](const void* d, int n, long long) {
    io::DecodedOutput o;
    if (io::decode_output(d, n, &o) && o.input == static_cast<int>(io::Input::kState)) last_seq = o.input_seq;
    std::lock_guard<std::mutex> lk(mu);
    events.push_back({cfg.output_channel, std::vector<uint8_t>(static_cast<const uint8_t*>(d), static_cast<const uint8_t*>(d) + n),
                      io::wall_us()});
  });
  bus.start();
  std::atomic<bool> stop{false};
  std::thread th([&] { loop.run(stop); });
  {  // a command without names (scene order): its CSV names the joints
    std::lock_guard<std::mutex> lk(mu);
    events.push_back({cfg.command_channel, io::encode_torque_command(io::wall_us(), 1, {}, std::vector<double>(nv, 0.5)),
                      io::wall_us()});
  }
  for (size_t r = 0; r < s.rows.size(); ++r) {
    std::vector<double> q(nq), v(nv), tau(nv);
    for (int i = 0; i < nq; ++i) q[i] = std::stod(s.rows[r][s.col("q:" + sys.model.q_names[i])]);
    for (int i = 0; i < nv; ++i) v[i] = std::stod(s.rows[r][s.col("v:" + sys.model.v_names[i])]);
    for (int i = 0; i < nv; ++i) tau[i] = std::stod(s.rows[r][s.col("tau:" + sys.model.v_names[i])]);
    const int64_t seq = static_cast<int64_t>(r) + 1;
    const auto b = io::encode_measured_state(io::wall_us(), seq, {}, q, {}, v, tau);
    {
      std::lock_guard<std::mutex> lk(mu);
      events.push_back({cfg.state_channel, b, io::wall_us()});
    }
    bus.publish(cfg.state_channel.c_str(), b.data(), static_cast<int>(b.size()));
    const auto end = std::chrono::steady_clock::now() + 5s;
    while (last_seq < seq && std::chrono::steady_clock::now() < end) std::this_thread::sleep_for(200us);
    ASSERT_GE(last_seq, seq) << "no output for state " << seq;
  }
  stop = true;
  th.join();
  bus.stop();
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) { return a.utime < b.utime; });
  lcm::LogFile log(*log_path, "w");
  ASSERT_TRUE(log.good());
  int64_t n = 0;
  for (Event& e : events) {
    lcm::LogEvent ev;
    ev.eventnum = n++;
    ev.timestamp = e.utime;
    ev.channel = e.channel;
    ev.datalen = static_cast<int32_t>(e.data.size());
    ev.data = e.data.data();
    ASSERT_EQ(log.writeEvent(&ev), 0);
  }
}

void expect_one_schema(const std::string& scene, const std::vector<std::string>& torque, const std::string& tag) {
  std::string sim_csv, log_path;
  sim_and_replay(scene, torque, tag, &sim_csv, &log_path);
  if (::testing::Test::HasFatalFailure()) return;
  const std::string dir = tmp_path(tag + "_csv"), dir_bare = tmp_path(tag + "_csv_bare");
  for (const auto& [d, with_scene] : {std::pair<std::string, bool>{dir, true}, {dir_bare, false}}) {
    std::vector<std::string> argv = {COOPDYN_PATH, "log", "--in", log_path, "--out", d, "--no-plot"};
    if (with_scene) argv.insert(argv.end(), {"--scene", scene_path(scene), "--progress"});
    Child conv(argv, tag + "_log");
    ASSERT_EQ(conv.wait(), 0) << slurp(conv.err);
    // progress on stderr only when asked (stderr is not a terminal here): the count of messages
    const std::string err = slurp(conv.err);
    if (with_scene) EXPECT_NE(err.find(" messages in "), std::string::npos) << err;
    else EXPECT_EQ(err, "");
  }
  const System sys = load_scene(scene_path(scene));
  const Table s = read_table(sim_csv), l = read_table(dir + "/COOPDYN_OUTPUT.csv"),
              b = read_table(dir_bare + "/COOPDYN_OUTPUT.csv");
  // the shared columns: the sim's before its own (position_error, then limit:JOINT), first in the
  // log's, same units
  const size_t n = static_cast<size_t>(std::find(s.h.names.begin(), s.h.names.end(), "position_error") - s.h.names.begin());
  ASSERT_LT(n, s.h.names.size());
  for (size_t i = n + 1; i < s.h.names.size(); ++i) EXPECT_EQ(s.h.names[i].rfind("limit:", 0), 0u) << s.h.names[i];
  ASSERT_GE(l.h.names.size(), n);
  for (size_t i = 0; i < n; ++i) {
    ASSERT_EQ(l.h.names[i], s.h.names[i]) << "column " << i;
    EXPECT_EQ(l.h.units[i], s.h.units[i]) << s.h.names[i];
    // without --scene, the log's own names give the same unit or say which two it may be
    const std::string& u = b.h.units[i];
    EXPECT_TRUE(u == s.h.units[i] || u.find(s.h.units[i] + " or ") == 0 || u.find(" or " + s.h.units[i]) != std::string::npos)
        << s.h.names[i] << ": " << u << " vs " << s.h.units[i];
    EXPECT_EQ(b.h.names[i], s.h.names[i]);
  }
  EXPECT_EQ(l.h.units[0], "s");
  // the comment lines name each wrench's kind and frame alike
  for (const WrenchOutput& o : sys.wrenches.outputs) {
    const std::string line = " wrench " + o.name + ": kind " + wrench_kind_name(o.kind) + ", frame " + o.frame + ", by " + o.by;
    EXPECT_NE(std::find(s.h.comments.begin(), s.h.comments.end(), line), s.h.comments.end()) << line;
    EXPECT_NE(std::find(l.h.comments.begin(), l.h.comments.end(), line), l.h.comments.end()) << line;
  }
  // the daemon's evaluation of each replayed state is the simulator's row, character for character
  // (state, torque, vdot, wrenches, stresses, contacts, status, reason, rank, condition, residual)
  const int c_input = l.col("input"), c_seq = l.col("input_seq");
  ASSERT_GE(c_input, 0);
  ASSERT_GE(c_seq, 0);
  int matched = 0;
  int64_t last = -1;
  for (const auto& row : l.rows) {
    if (row[static_cast<size_t>(c_input)] != "state") continue;
    const int64_t seq = std::stoll(row[static_cast<size_t>(c_seq)]);
    if (seq == last) continue;
    last = seq;
    ASSERT_LE(static_cast<size_t>(seq), s.rows.size());
    const auto& sr = s.rows[static_cast<size_t>(seq - 1)];
    for (size_t i = 1; i < n; ++i) ASSERT_EQ(row[i], sr[i]) << scene << " state " << seq << " column " << s.h.names[i];
    ++matched;
  }
  EXPECT_EQ(matched, static_cast<int>(s.rows.size()));
  // the command sent without names: its torques by the scene's velocity names
  const Table c = read_table(dir_bare + "/COOPDYN_COMMAND.csv");
  for (const auto& vn : sys.model.v_names) EXPECT_GE(c.col("tau:" + vn), 0) << vn;
  EXPECT_EQ(c.h.names[0], "log_time");
  EXPECT_EQ(c.h.units[c.col("utime")], "us");
  const Table st = read_table(dir_bare + "/COOPDYN_STATE.csv");
  for (const auto& qn : sys.model.q_names) EXPECT_GE(st.col("q:" + qn), 0) << qn;
  for (const std::string& d : {dir, dir_bare}) {
    for (const char* f : {"COOPDYN_OUTPUT.csv", "COOPDYN_COMMAND.csv", "COOPDYN_STATE.csv"}) std::remove((d + "/" + f).c_str());
    rmdir(d.c_str());
  }
  std::remove(sim_csv.c_str());
  std::remove(log_path.c_str());
}

}  // namespace

// A vehicle (a floating body, rolling contacts: friction needed, utilisation, contact state).
TEST(StepCsv, SimAndLogOfAVehicleShareColumnsUnitsAndValues) {
  expect_one_schema("two_wheel_vehicle", {"left_spin:constant:2"}, "step_csv_vehicle");
}

// A closed loop with a pseudo-joint (its stress column).
TEST(StepCsv, SimAndLogOfAFourBarShareColumnsUnitsAndValues) { expect_one_schema("four_bar", {}, "step_csv_four_bar"); }

// The units line reads back to each column's unit by joint type, and a units line that does not
// match the header is an error naming the file and line.
TEST(StepCsv, UnitsLineRoundTrips) {
  const System sys = load_scene(scene_path("two_wheel_vehicle"));
  const cli::StepSchema schema = cli::step_schema(sys, "sim");
  const cli::CsvColumns cols = cli::shared_step_columns(schema);
  const std::string path = tmp_path("step_csv_units.csv");
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    cli::write_step_csv_header(f, schema, cols);
    std::fclose(f);
  }
  std::ifstream in(path);
  cli::CsvHeader h;
  std::string err;
  ASSERT_TRUE(cli::read_step_csv_header(in, path, &h, &err)) << err;
  EXPECT_EQ(h.names, cols.names);
  EXPECT_EQ(h.units, cols.units);
  auto unit = [&](const std::string& n) {
    const auto it = std::find(h.names.begin(), h.names.end(), n);
    return it == h.names.end() ? std::string("absent") : h.units[static_cast<size_t>(it - h.names.begin())];
  };
  for (const Body& b : sys.model.bodies) {
    const Joint& j = b.joint;
    if (j.type == JointType::kRevolute) {
      EXPECT_EQ(unit("q:" + sys.model.q_names[j.idx_q]), "rad");
      EXPECT_EQ(unit("tau:" + sys.model.v_names[j.idx_v]), "N*m");
    } else if (j.type == JointType::kFloating) {
      EXPECT_EQ(unit("q:" + sys.model.q_names[j.idx_q]), "m");
      EXPECT_EQ(unit("q:" + sys.model.q_names[j.idx_q + 3]), "1");
      EXPECT_EQ(unit("v:" + sys.model.v_names[j.idx_v]), "rad/s");
      EXPECT_EQ(unit("vdot:" + sys.model.v_names[j.idx_v + 5]), "m/s^2");
      EXPECT_EQ(unit("tau:" + sys.model.v_names[j.idx_v + 4]), "N");
    }
  }
  const std::string w = sys.wrenches.outputs.at(0).name;
  EXPECT_EQ(unit(w + ".mz"), "N*m");
  EXPECT_EQ(unit(w + ".fx"), "N");
  EXPECT_EQ(unit("t"), "s");
  // a units line one short of the header
  std::ofstream(path) << "# units: s,rad\nt,q:a,q:b\n";
  std::ifstream bad(path);
  EXPECT_FALSE(cli::read_step_csv_header(bad, path, &h, &err));
  EXPECT_EQ(err, path + ":1: 2 units for 3 columns");
  std::remove(path.c_str());
}

// A row's shared cells are one per shared column, in their order: numbers shortest round-trip,
// the codes as the words given, a contact's three cells together.
TEST(StepCsv, RowCellsFollowTheSharedColumns) {
  cli::StepSchema s;
  std::string err;
  ASSERT_TRUE(cli::step_schema_from_names("s", {"a", "b"}, {"a"}, {"W"}, {0}, {"world"}, {"x"}, {"a"}, {"c"}, nullptr, &s, &err))
      << err;
  const cli::CsvColumns cols = cli::shared_step_columns(s);
  const double q[2] = {1, 2}, v[1] = {3}, tau[1] = {4}, vdot[1] = {5}, w[6] = {6, 7, 8, 9, 10, 11}, stress[1] = {12};
  const double friction_needed[1] = {0.5}, utilisation[1] = {0.25};
  cli::StepRow r;
  r.t = 0.125;
  r.q = {q, 2};
  r.v = {v, 1};
  r.tau = {tau, 1};
  r.vdot = {vdot, 1};
  r.wrenches = {w, 6};
  r.stress = {stress, 1};
  r.friction_needed = friction_needed;
  r.utilisation = utilisation;
  r.contact_state = {"slip"};
  r.status = "ok";
  r.reason = "none";
  r.rows = 3;
  r.rank = 2;
  r.indeterminate = 1;
  r.condition = -1;
  r.residual = 1e-9;
  cli::CsvLine line(cols.names.size());
  cli::write_step_cells(line, r);
  line.sep(), line.text("own");  // a source's own column after the shared ones
  line.end();
  char* buf = nullptr;
  size_t n = 0;
  std::FILE* f = open_memstream(&buf, &n);
  line.write(f);
  std::fclose(f);
  const std::string text(buf, n);
  std::free(buf);
  EXPECT_EQ(text, "0.125,1,2,3,4,5,6,7,8,9,10,11,12,0.5,0.25,slip,ok,none,3,2,1,-1,1e-09,own\n");
  EXPECT_EQ(cli::split_csv_line(text.substr(0, text.size() - 1)).size(), cols.names.size() + 1);
}
