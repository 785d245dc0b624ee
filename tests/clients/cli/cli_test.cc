// The command lines of coopdyn and coopdynd (CLI11), run as real processes: unknown flags, missing
// and malformed values are errors on stderr with exit 2 and nothing done; --help goes to stdout with
// exit 0 and shows the options and their defaults; --version; the old flags keep their meaning.
#include <gtest/gtest.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "service/version.h"
#include "tests/support/child_process.h"
#include "tests/support/files.h"

using namespace coopdyn::daemon_test;

namespace {

std::string scene(const std::string& name) { return std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/" + name + ".yaml"; }

Result run(const std::vector<std::string>& argv, const std::string& tag) { return run_command(argv, "cli_" + tag); }
bool has(const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; }
std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> f;
  std::istringstream s(line);
  for (std::string x; std::getline(s, x, ',');) f.push_back(x);
  return f;
}

}  // namespace

TEST(Cli, UnknownFlagIsAnErrorThatNamesIt) {
  // each otherwise complete (a missing required option is reported first)
  const std::string s = scene("two_puma_load");
  const std::vector<std::vector<std::string>> cmds = {
      {"eval", "--scene", s},
      {"sim", "--scene", s, "--duration", "0.01", "--dt", "0.001"},
      {"send", "--scene", s, "--torque", "arm1.q1:constant:1", "--lcm-url", "memq://", "--duration", "0"},
      {"log", "--in", "/no/such.lcmlog"},
      {"control", "--action", "pause", "--lcm-url", "memq://", "--no-wait"},
      {"track", "--scene", s, "--lcm-url", "memq://", "--duration", "0.1"},
      {"view", "--scene", s, "--csv", "/no/such.csv", "--out", "/tmp/coopdyn_cli_view.html"},
  };
  for (std::vector<std::string> argv : cmds) {
    const std::string sub = argv[0];
    SCOPED_TRACE(sub);
    argv.insert(argv.begin(), COOPDYN_PATH);
    argv.insert(argv.end(), {"--bogus", "1"});
    const Result r = run(argv, "unknown_" + sub);
    EXPECT_EQ(r.rc, 2);
    EXPECT_TRUE(has(r.err, "--bogus")) << r.err;
    EXPECT_EQ(r.out, "") << "nothing run";
  }
  const Result d = run({COOPDYND_PATH, "--scene", scene("two_puma_load"), "--bogus", "1"}, "unknown_d");
  EXPECT_EQ(d.rc, 2);
  EXPECT_TRUE(has(d.err, "--bogus")) << d.err;
  EXPECT_EQ(d.out, "") << "the daemon did not run (no summary line)";
}

TEST(Cli, AMistypedOutFlagWritesNothingInsteadOfDumpingTheCsv) {
  // the example: `--outt x.csv` used to run the simulation and print the CSV to stdout
  const std::string path = tmp_path("outt.csv");
  std::remove(path.c_str());
  const Result r = run({COOPDYN_PATH, "sim", "--scene", scene("two_puma_load"), "--duration", "0.01", "--dt", "0.001",
                     "--outt", path},
                    "outt");
  EXPECT_EQ(r.rc, 2);
  EXPECT_TRUE(has(r.err, "--outt")) << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_NE(access(path.c_str(), F_OK), 0) << "no file written";
}

TEST(Cli, AMissingOrMalformedValueIsAnError) {
  const Result r = run({COOPDYN_PATH, "sim", "--scene", scene("two_puma_load"), "--dt", "0.001", "--duration"}, "no_value");
  EXPECT_EQ(r.rc, 2);
  EXPECT_TRUE(has(r.err, "--duration")) << r.err;
  EXPECT_EQ(r.out, "");
  // a value that is the next option is not taken as the value
  const Result n = run({COOPDYN_PATH, "sim", "--scene", scene("two_puma_load"), "--duration", "--dt", "0.001"}, "next_opt");
  EXPECT_EQ(n.rc, 2);
  EXPECT_TRUE(has(n.err, "--duration")) << n.err;
  const Result x = run({COOPDYN_PATH, "sim", "--scene", scene("two_puma_load"), "--duration", "abc", "--dt", "0.001"}, "nan");
  EXPECT_EQ(x.rc, 2);
  EXPECT_TRUE(has(x.err, "--duration") && has(x.err, "abc")) << x.err;
  EXPECT_EQ(x.out, "");
  const Result req = run({COOPDYN_PATH, "sim", "--scene", scene("two_puma_load"), "--dt", "0.001"}, "required");
  EXPECT_EQ(req.rc, 2);
  EXPECT_TRUE(has(req.err, "--duration")) << req.err;
  const Result d = run({COOPDYND_PATH, "--scene", scene("two_puma_load"), "--duration"}, "no_value_d");
  EXPECT_EQ(d.rc, 2);
  EXPECT_TRUE(has(d.err, "--duration")) << d.err;
  EXPECT_EQ(d.out, "") << "the daemon did not run";
  const Result ds = run({COOPDYND_PATH, "--duration", "1"}, "no_scene_d");
  EXPECT_EQ(ds.rc, 2);
  EXPECT_TRUE(has(ds.err, "--scene")) << ds.err;
  // a wait for the acknowledgement that is not a positive number of seconds: refused before sending
  for (const char* t : {"0", "-1", "nan", "inf"}) {
    const Result c = run({COOPDYN_PATH, "control", "--action", "pause", "--lcm-url", "memq://", "--timeout", t}, "timeout");
    EXPECT_EQ(c.rc, 2) << t;
    EXPECT_TRUE(has(c.err, "--timeout")) << c.err;
    EXPECT_FALSE(has(c.err, "no acknowledgement")) << "nothing was sent: " << c.err;
  }
}

TEST(Cli, EverySubcommandHasHelpOnStdoutWithItsOptionsAndDefaults) {
  struct Case {
    const char* sub;
    std::vector<std::string> shows;  // options and the defaults the code applies (CLI11 2.1: NAME=default)
  };
  const std::vector<Case> cases = {
      {"eval", {"--scene", "--state", "--formulation"}},
      {"sim", {"--scene", "--duration", "--dt", "--integrator NAME=rk4", "--torque", "--out", "--every N=1", "--progress",
               "JOINT:pulse:VALUE:T0:T1"}},
      {"send", {"--torque", "--states", "--joints-only", "--rate HZ=100", "--lcm-url URL=udpm://239.255.76.67:7667?ttl=0",
                "--measure-latency", "--no-check", "--output-url"}},
      {"log", {"--in", "--out", "--scene", "--no-plot", "--progress", "--python PATH=/usr/bin/python3"}},
      {"control", {"--action", "reset_to_state", "--state", "--no-wait", "--channel C=COOPDYN_CONTROL"}},
      {"track", {"--duration S=6", "--radius M=0.05", "--period S=4", "--squeeze N=20", "--out"}},
      {"view", {"--scene", "--csv", "--log", "--live", "--out", "--max-frames N=2000", "--channel NAME=COOPDYN_OUTPUT",
                "--listen HOST:PORT=127.0.0.1:8765", "--lcm-url URL=udpm://239.255.76.67:7667?ttl=0", "--rate HZ=50",
                "--queue N=32", "--three-js FILE=/usr/share/javascript/three/three.min.js"}},
      {"bench", {"--scene", "--min-time S=0.5", "--repetitions N=15", "--json", "--formulation"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.sub);
    const Result r = run({COOPDYN_PATH, c.sub, "--help"}, std::string("help_") + c.sub);
    EXPECT_EQ(r.rc, 0);
    EXPECT_EQ(r.err, "");
    for (const std::string& s : c.shows) EXPECT_TRUE(has(r.out, s)) << "missing '" << s << "' in\n" << r.out;
  }
  const Result top = run({COOPDYN_PATH, "--help"}, "help_top");
  EXPECT_EQ(top.rc, 0);
  EXPECT_EQ(top.err, "");
  for (const char* sub : {"eval", "sim", "send", "log", "control", "track", "view", "bench"}) EXPECT_TRUE(has(top.out, sub)) << top.out;
  const Result d = run({COOPDYND_PATH, "--help"}, "help_d");
  EXPECT_EQ(d.rc, 0);
  EXPECT_EQ(d.err, "");
  for (const char* o : {"--scene", "--config", "--lcm-url", "--mode", "--trigger WHEN=tick", "--rate", "--duration", "--version"})
    EXPECT_TRUE(has(d.out, o)) << d.out;
}

TEST(Cli, NoSubcommandPrintsTheUsageAsAnError) {
  const Result r = run({COOPDYN_PATH}, "none");
  EXPECT_NE(r.rc, 0);
  EXPECT_EQ(r.out, "");
  for (const char* sub : {"eval", "sim", "send", "log", "control", "track", "view", "bench"}) EXPECT_TRUE(has(r.err, sub)) << r.err;
  const Result u = run({COOPDYN_PATH, "bogus"}, "unknown_sub");
  EXPECT_EQ(u.rc, 2);
  EXPECT_TRUE(has(u.err, "bogus")) << u.err;
}

TEST(Cli, VersionOfBothBinariesIsTheProjectVersion) {
  EXPECT_STREQ(COOPDYN_VERSION, COOPDYN_PROJECT_VERSION) << "service/version.h is generated from project(VERSION)";
  const Result c = run({COOPDYN_PATH, "--version"}, "version");
  EXPECT_EQ(c.rc, 0);
  EXPECT_EQ(c.out, std::string("coopdyn ") + COOPDYN_PROJECT_VERSION + "\n");
  EXPECT_EQ(c.err, "");
  const Result d = run({COOPDYND_PATH, "--version"}, "version_d");
  EXPECT_EQ(d.rc, 0);
  EXPECT_EQ(d.out, std::string("coopdynd (coopdyn) ") + COOPDYN_PROJECT_VERSION + "\n");
  EXPECT_EQ(d.err, "");
}

TEST(Cli, OldFlagsKeepTheirMeaning) {
  // --key=value, a repeated --torque (both applied, in the scene's order) and a negative value
  const Result r = run({COOPDYN_PATH, "sim", "--scene=" + scene("two_puma_load"), "--duration", "0.002", "--dt", "0.001",
                     "--torque", "arm1.q1:constant:1.5", "--torque", "arm2.q2:constant:-0.5"},
                    "old_flags");
  ASSERT_EQ(r.rc, 0) << r.err;
  std::istringstream csv(r.out);
  std::string header, first;
  while (std::getline(csv, header) && !header.empty() && header[0] == '#') {}  // the comment and units lines
  ASSERT_TRUE(std::getline(csv, first));
  const std::vector<std::string> h = split(header), v = split(first);
  ASSERT_EQ(h.size(), v.size());
  int seen = 0;
  for (size_t i = 0; i < h.size(); ++i) {
    if (h[i].rfind("tau:", 0) != 0) continue;
    const double tau = std::strtod(v[i].c_str(), nullptr);
    if (h[i] == "tau:arm1.q1" || h[i] == "tau:arm2.q2") {
      EXPECT_EQ(tau, h[i] == "tau:arm1.q1" ? 1.5 : -0.5);
      ++seen;
    } else {
      EXPECT_EQ(tau, 0.0) << h[i];
    }
  }
  EXPECT_EQ(seen, 2);
  // a bare flag between options (--no-plot), the required --in
  const Result l = run({COOPDYN_PATH, "log", "--no-plot", "--in", "/no/such.lcmlog"}, "log_flag");
  EXPECT_EQ(l.rc, 1) << "got to reading the log: " << l.err;
  EXPECT_TRUE(has(l.err, "/no/such.lcmlog")) << l.err;
}

// coopdyn bench on shipped scenes: the JSON parses, every number is finite and positive, and the rows
// are the evaluation plus one step per integrator, twice (with and without) where the scene projects.
// No wall-clock limit is asserted; --min-time keeps the run short.
TEST(Cli, BenchPrintsOneRowPerIntegratorAndProjectionWithFinitePositiveCosts) {
  struct Case {
    const char* scene;
    bool projects;
  };
  for (const Case& c : {Case{"two_puma_load", false}, Case{"two_wheel_vehicle", true}}) {
    SCOPED_TRACE(c.scene);
    const Result r = run({COOPDYN_PATH, "bench", "--scene", scene(c.scene), "--min-time", "0.03", "--repetitions", "5",
                          "--json"},
                         std::string("bench_") + c.scene);
    ASSERT_EQ(r.rc, 0) << r.err;
    YAML::Node j;
    ASSERT_NO_THROW(j = YAML::Load(r.out)) << r.out;
    EXPECT_EQ(j["name"].as<std::string>(), c.scene);
    EXPECT_EQ(j["projection_iterations"].as<int>() > 0, c.projects);
    std::set<std::string> names, want = {"evaluate", "step:semi_implicit_euler", "step:rk4", "step:implicit_euler"};
    if (c.projects)
      for (const char* i : {"semi_implicit_euler", "rk4", "implicit_euler"}) want.insert(std::string("step:") + i + "+projection");
    ASSERT_TRUE(j["rows"].IsSequence()) << r.out;
    for (const YAML::Node& row : j["rows"]) {
      const std::string name = row["name"].as<std::string>();
      EXPECT_TRUE(names.insert(name).second) << "row twice: " << name;
      for (const char* k : {"median", "p10", "p90", "wall_median"}) {
        const double x = row[k].as<double>();
        EXPECT_TRUE(std::isfinite(x) && x > 0.0) << name << "." << k << " = " << x;
      }
      const double mad = row["mad"].as<double>();
      EXPECT_TRUE(std::isfinite(mad) && mad >= 0.0) << name;
      EXPECT_LE(row["p10"].as<double>(), row["median"].as<double>()) << name;
      EXPECT_LE(row["median"].as<double>(), row["p90"].as<double>()) << name;
      EXPECT_GE(row["batch"].as<long>(), 1) << name;
      EXPECT_EQ(row["repetitions"].as<int>(), 5) << name;
      EXPECT_EQ(row["projection"].as<bool>(), name.find("+projection") != std::string::npos) << name;
    }
    EXPECT_EQ(names, want);
  }
  // the table form: a header and one line per row
  const Result t = run({COOPDYN_PATH, "bench", "--scene", scene("unicycle"), "--min-time", "0.02", "--repetitions", "3"},
                       "bench_table");
  ASSERT_EQ(t.rc, 0) << t.err;
  for (const char* row : {"evaluate", "step:semi_implicit_euler", "step:rk4", "step:implicit_euler", "median", "p90"})
    EXPECT_TRUE(has(t.out, row)) << t.out;
}

TEST(Cli, BenchOnAMissingOrBrokenSceneNamesTheFile) {
  const Result m = run({COOPDYN_PATH, "bench", "--scene", "/no/such/scene.yaml"}, "bench_missing");
  EXPECT_EQ(m.rc, 1);
  EXPECT_TRUE(has(m.err, "/no/such/scene.yaml")) << m.err;
  EXPECT_EQ(m.out, "");
  const std::string broken = "/tmp/coopdyn_cli_bench_broken_" + std::to_string(getpid()) + ".yaml";
  {
    std::FILE* f = std::fopen(broken.c_str(), "w");
    ASSERT_TRUE(f);
    std::fputs("name: broken\nbodies: [unclosed\n", f);
    std::fclose(f);
  }
  const Result b = run({COOPDYN_PATH, "bench", "--scene", broken}, "bench_broken");
  std::remove(broken.c_str());
  EXPECT_EQ(b.rc, 1);
  EXPECT_TRUE(has(b.err, broken)) << b.err;
  EXPECT_EQ(b.out, "");
}

// docs/reference/cli.md is written by docs/reference/cli.sh from the programs' --help: the page in
// the tree is what the script writes from these binaries.
TEST(Cli, ReferencePageIsWhatItsScriptWritesFromTheHelp) {
  const std::string bin = std::string(COOPDYN_PATH).substr(0, std::string(COOPDYN_PATH).rfind('/'));
  const std::string docs = std::string(COOPDYN_SOURCE_DIR) + "/docs/reference/";
  const Result r = run({"/bin/bash", docs + "cli.sh", bin}, "reference");
  ASSERT_EQ(r.rc, 0) << r.err;
  std::ifstream f(docs + "cli.md");
  std::stringstream page;
  page << f.rdbuf();
  EXPECT_EQ(r.out, page.str()) << "the page is stale: docs/reference/cli.sh build/bin > docs/reference/cli.md";
}

TEST(Cli, EvalAndSimReportAUrdfMimicCouplingAsAStress) {
  // a two-joint URDF arm, j2 mimicking j1 (q2 = 2 q1 + 0.1), swinging under gravity in its plane:
  // eval lists the coupling's force as the stress of arm.j2 and vdot_2 = 2 vdot_1; sim has its column
  const std::string dir = ::testing::TempDir(), tag = std::to_string(::getpid());
  const std::string urdf = dir + "cli_mimic_" + tag + ".urdf", yaml = dir + "cli_mimic_" + tag + ".yaml";
  std::ofstream(urdf)
      << "<robot name=\"m\"><link name=\"base\"/>\n"
         "<link name=\"l1\"><inertial><origin xyz=\"0.25 0 0\"/><mass value=\"2\"/><inertia ixx=\"0.001\" iyy=\"0.04\" izz=\"0.04\" "
         "ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
         "<link name=\"l2\"><inertial><origin xyz=\"0.2 0 0\"/><mass value=\"1.5\"/><inertia ixx=\"0.001\" iyy=\"0.02\" izz=\"0.02\" "
         "ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
         "<joint name=\"j1\" type=\"continuous\"><parent link=\"base\"/><child link=\"l1\"/><axis xyz=\"0 0 1\"/></joint>\n"
         "<joint name=\"j2\" type=\"continuous\"><parent link=\"l1\"/><child link=\"l2\"/><origin xyz=\"0.5 0 0\"/><axis xyz=\"0 0 1\"/>"
         "<mimic joint=\"j1\" multiplier=\"2\" offset=\"0.1\"/></joint></robot>\n";
  std::ofstream(yaml) << "name: cli_mimic\ngravity: [0, -9.81, 0]\nrobots:\n  m: {urdf: " << urdf
                      << "}\narms:\n  - {name: arm, robot: m, base: {xyz: [0, 0, 0]}, q: [0.3, 0.7]}\n";
  const Result e = run({COOPDYN_PATH, "eval", "--scene", yaml}, "mimic_eval");
  ASSERT_EQ(e.rc, 0) << e.err;
  const YAML::Node j = YAML::Load(e.out);
  ASSERT_EQ(j["stresses"].size(), 1u) << e.out;
  EXPECT_EQ(j["stresses"][0]["joint"].as<std::string>(), "arm.j2");
  EXPECT_EQ(j["stresses"][0]["unit"].as<std::string>(), "N*m");
  EXPECT_GT(std::abs(j["stresses"][0]["value"].as<double>()), 0.1) << "gravity loads the coupling";
  const double a1 = j["vdot"][0].as<double>(), a2 = j["vdot"][1].as<double>();
  EXPECT_NEAR(a2, 2 * a1, 1e-12 * (1 + std::abs(a1)));
  const Result s = run({COOPDYN_PATH, "sim", "--scene", yaml, "--duration", "0.002", "--dt", "0.001"}, "mimic_sim");
  ASSERT_EQ(s.rc, 0) << s.err;
  EXPECT_TRUE(has(s.out, ",stress:arm.j2")) << s.out.substr(0, 400);
  std::remove(urdf.c_str());
  std::remove(yaml.c_str());
}

TEST(Cli, EvalAndSimHoldTheRobotStillWithHold) {
  // --hold adds coopdynd's holding torques: the PR2 holding its box does not move (eval's vdot and a
  // sim's last state), where without it the torso lift drops at g
  const std::string s = scene("pr2_box");
  const Result free = run({COOPDYN_PATH, "eval", "--scene", s}, "hold_free");
  ASSERT_EQ(free.rc, 0) << free.err;
  const Result held = run({COOPDYN_PATH, "eval", "--scene", s, "--hold"}, "hold_eval");
  ASSERT_EQ(held.rc, 0) << held.err;
  double a_free = 0, a_held = 0;
  for (const auto& x : YAML::Load(free.out)["vdot"]) a_free = std::max(a_free, std::abs(x.as<double>()));
  for (const auto& x : YAML::Load(held.out)["vdot"]) a_held = std::max(a_held, std::abs(x.as<double>()));
  EXPECT_NEAR(a_free, 9.81, 1e-6);
  EXPECT_LT(a_held, 1e-7);
  const Result sim = run({COOPDYN_PATH, "sim", "--scene", s, "--hold", "--duration", "0.05", "--dt", "0.001"}, "hold_sim");
  ASSERT_EQ(sim.rc, 0) << sim.err;
  std::vector<std::string> rows;
  std::istringstream in(sim.out);
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '#') rows.push_back(line);
  ASSERT_GE(rows.size(), 3u);
  const std::vector<std::string> head = split(rows[0]), first = split(rows[1]), last = split(rows.back());
  for (size_t k = 0; k < head.size(); ++k)
    if (head[k].rfind("q:", 0) == 0) {
      EXPECT_NEAR(std::stod(last[k]), std::stod(first[k]), 1e-6) << head[k];
    }
}

// A state file by coordinate name is the positional one (mobile_platform: an arm's joints run from
// its tip to its base, so a positional list is easy to get wrong), and an unknown name is an error
// at its line.
TEST(Cli, EvalStateByNameEqualsThePositionalList) {
  const std::string s = scene("two_puma_load");
  const Result base = run({COOPDYN_PATH, "eval", "--scene", s}, "byname_base");
  ASSERT_EQ(base.rc, 0) << base.err;
  const YAML::Node b = YAML::Load(base.out);
  std::vector<std::string> vn;
  for (const auto& x : b["coordinates"]["v"]) vn.push_back(x.as<std::string>());
  std::vector<double> tau(vn.size(), 0.0);
  const size_t q1 = static_cast<size_t>(std::find(vn.begin(), vn.end(), "arm1.q1") - vn.begin());
  ASSERT_LT(q1, vn.size());
  tau[q1] = 2.5;
  std::ostringstream pos;
  pos << "{\"tau\": [";
  for (size_t i = 0; i < tau.size(); ++i) pos << (i ? ", " : "") << tau[i];
  pos << "]}";
  const std::string fp = "/tmp/coopdyn_cli_state_pos.json", fn = "/tmp/coopdyn_cli_state_name.json",
                    fb = "/tmp/coopdyn_cli_state_bad.json";
  std::ofstream(fp) << pos.str();
  std::ofstream(fn) << "{\"tau\": {\"arm1.q1\": 2.5}}";
  std::ofstream(fb) << "{\"tau\": {\n  \"arm1.q9\": 2.5}}";
  const Result a = run({COOPDYN_PATH, "eval", "--scene", s, "--state", fp}, "byname_pos");
  const Result n = run({COOPDYN_PATH, "eval", "--scene", s, "--state", fn}, "byname_name");
  ASSERT_EQ(a.rc, 0) << a.err;
  ASSERT_EQ(n.rc, 0) << n.err;
  EXPECT_EQ(a.out, n.out);
  EXPECT_NE(a.out, base.out) << "the torque was applied";
  const Result bad = run({COOPDYN_PATH, "eval", "--scene", s, "--state", fb}, "byname_bad");
  EXPECT_EQ(bad.rc, 1);
  EXPECT_TRUE(has(bad.err, fb + ":2:3: 'tau' has no coordinate 'arm1.q9'")) << bad.err;
}

// Limits exceeded are reported per joint: eval's limits_exceeded, sim's limit:JOINT columns and its
// warning (two iiwa arms: URDF speed limit of joint 1 1.4835 rad/s).
TEST(Cli, EvalAndSimReportTheJointLimitsExceeded) {
  const std::string s = scene("two_iiwa_load"), f = "/tmp/coopdyn_cli_state_fast.json";
  std::ofstream(f) << "{\"v\": {\"arm1.iiwa_joint_1\": 1.5}}";
  const Result e = run({COOPDYN_PATH, "eval", "--scene", s, "--state", f}, "limits_eval");
  ASSERT_EQ(e.rc, 0) << e.err;
  const YAML::Node lim = YAML::Load(e.out)["limits_exceeded"];
  ASSERT_TRUE(lim.IsSequence()) << e.out;
  bool found = false;
  for (const auto& x : lim)
    if (x["joint"].as<std::string>() == "arm1.iiwa_joint_1") found = x["exceeded"][0].as<std::string>() == "velocity";
  EXPECT_TRUE(found) << e.out;
  EXPECT_TRUE(has(e.err, "past their limits")) << e.err;
  const Result within = run({COOPDYN_PATH, "eval", "--scene", s}, "limits_within");
  ASSERT_EQ(within.rc, 0);
  EXPECT_EQ(YAML::Load(within.out)["limits_exceeded"].size(), 0u);
  // 0.3 s without torques: the arms fall past their speed limits, column by column
  const Result sim = run({COOPDYN_PATH, "sim", "--scene", s, "--duration", "0.3", "--dt", "0.001"}, "limits_sim");
  ASSERT_EQ(sim.rc, 0) << sim.err;
  EXPECT_TRUE(has(sim.err, "passes its velocity limit")) << sim.err;
  std::vector<std::string> rows;
  std::istringstream in(sim.out);
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '#') rows.push_back(line);
  const std::vector<std::string> head = split(rows[0]), first = split(rows[1]), last = split(rows.back());
  int flagged = 0;
  for (size_t k = 0; k < head.size(); ++k) {
    if (head[k].rfind("limit:", 0) != 0) continue;
    EXPECT_EQ(first[k], "0") << head[k] << ": the scene starts within its limits";
    const int bits = std::stoi(last[k]);
    if (!(bits & 2)) continue;
    ++flagged;
    const size_t vc = static_cast<size_t>(std::find(head.begin(), head.end(), "v:" + head[k].substr(6)) - head.begin());
    ASSERT_LT(vc, head.size());
    EXPECT_GT(std::abs(std::stod(last[vc])), 1.3) << head[k] << ": flagged past a speed limit of 1.31 rad/s or more";
  }
  EXPECT_GT(flagged, 0);
}

// send --others takes hold or zero, nothing else.
TEST(Cli, SendOthersIsHoldOrZero) {
  const Result r = run({COOPDYN_PATH, "send", "--scene", scene("two_puma_load"), "--torque", "arm1.q1:constant:1",
                        "--others", "free", "--no-check", "--duration", "0"}, "others");
  EXPECT_EQ(r.rc, 2);
  EXPECT_TRUE(has(r.err, "--others must be hold or zero")) << r.err;
}

TEST(Cli, SendReplaysEveryRowOfAOneKilohertzCsvOnceAtOneKilohertz) {
  // coopdyn send --states at the CSV's own rate sends row k as message k, every row once, in order,
  // although k / rate may round just below the row's time k h (before, 14 of these 1001 rows went
  // twice). Recorded through LCM's file provider (no network: nothing can be lost), read back by
  // coopdyn log, each message matched to its row by the values of q.
  const std::string dir = ::testing::TempDir() + "cli_replay_" + std::to_string(::getpid());
  ASSERT_EQ(std::system(("mkdir -p '" + dir + "'").c_str()), 0);
  const std::string s = scene("two_puma_load"), csv = dir + "/sim.csv", log = dir + "/states.lcmlog";
  const Result sim = run({COOPDYN_PATH, "sim", "--scene", s, "--duration", "1", "--dt", "0.001", "--out", csv}, "replay_sim");
  ASSERT_EQ(sim.rc, 0) << sim.err;
  const Result send = run({COOPDYN_PATH, "send", "--scene", s, "--states", csv, "--rate", "1000", "--no-check", "--lcm-url",
                           "file://" + log + "?mode=w"},
                          "replay_send");
  ASSERT_EQ(send.rc, 0) << send.err;
  const Result conv = run({COOPDYN_PATH, "log", "--in", log, "--out", dir + "/log", "--no-plot", "--scene", s}, "replay_log");
  ASSERT_EQ(conv.rc, 0) << conv.err;
  const coopdyn::testing::CsvText rows = coopdyn::testing::read_csv_text(csv);
  const coopdyn::testing::CsvText sent = coopdyn::testing::read_csv_text(dir + "/log/COOPDYN_STATE.csv");
  ASSERT_EQ(rows.rows.size(), 1001u);
  ASSERT_EQ(sent.rows.size(), rows.rows.size()) << "one message per row";
  std::vector<std::pair<size_t, size_t>> q_cols;  // (sim column, log column) of every q
  for (size_t i = 0; i < rows.head.size(); ++i)
    if (rows.head[i].rfind("q:", 0) == 0)
      for (size_t j = 0; j < sent.head.size(); ++j)
        if (sent.head[j] == rows.head[i]) q_cols.push_back({i, j});
  ASSERT_GE(q_cols.size(), 18u);
  for (size_t k = 0; k < rows.rows.size(); ++k)
    for (const auto& [i, j] : q_cols)
      ASSERT_EQ(std::strtod(sent.rows[k][j].c_str(), nullptr), std::strtod(rows.rows[k][i].c_str(), nullptr))
          << "message " << k << " is not row " << k << " (" << rows.head[i] << ")";
  std::system(("rm -rf '" + dir + "'").c_str());
}
