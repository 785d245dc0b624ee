// The sim CSV reproduces its run: every row's state read back (17 significant digits) evaluates to
// the row's own vdot and wrenches bit for bit, so a state taken from the CSV picks up no
// stabilization terms of its own (its constraint error is the run's, not the print's).
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>

#include "service/dynamics/wrenches.h"
#include "tests/support/child_process.h"
#include "tests/support/daemon_test_util.h"

using namespace coopdyn;
using namespace coopdyn::daemon_test;

namespace {
std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string c;
  while (std::getline(ss, c, ',')) out.push_back(c);
  return out;
}

void expect_rows_reproduce(const std::string& scene, const std::vector<std::string>& extra) {
  const std::string csv = tmp_path("sim_csv_" + scene + ".csv");
  std::vector<std::string> argv = {COOPDYN_PATH, "sim", "--scene", scene_path(scene), "--duration", "0.2", "--dt", "0.002",
                                   "--out", csv};
  argv.insert(argv.end(), extra.begin(), extra.end());
  {
    Child sim(argv, "sim_" + scene);
    ASSERT_EQ(sim.wait(), 0) << slurp(sim.err);
  }
  const System sys = load_scene(scene_path(scene));
  const int nq = sys.model.nq(), nv = sys.model.nv();
  std::ifstream f(csv);
  std::string line;
  while (std::getline(f, line) && !line.empty() && line[0] == '#') {}  // the comment and units lines
  ASSERT_FALSE(line.empty());
  const std::vector<std::string> head = split(line);
  std::map<std::string, int> col;
  for (size_t i = 0; i < head.size(); ++i) col[head[i]] = static_cast<int>(i);
  for (int i = 0; i < nv; ++i) ASSERT_TRUE(col.count("vdot:" + sys.model.v_names[i])) << "vdot:" << sys.model.v_names[i];
  Workspace ws(sys);
  ws.position_errors = true;  // the closure is read below
  WrenchData wd(sys);
  Eigen::VectorXd q(nq), v(nv), tau(nv);
  int rows = 0;
  double max_err = 0;
  while (std::getline(f, line)) {
    const std::vector<std::string> c = split(line);
    ASSERT_EQ(c.size(), head.size());
    for (int i = 0; i < nq; ++i) q[i] = std::stod(c[col["q:" + sys.model.q_names[i]]]);
    for (int i = 0; i < nv; ++i) v[i] = std::stod(c[col["v:" + sys.model.v_names[i]]]);
    for (int i = 0; i < nv; ++i) tau[i] = std::stod(c[col["tau:" + sys.model.v_names[i]]]);
    evaluate(sys, ws, q, v, tau);
    for (int i = 0; i < nv; ++i)
      ASSERT_EQ(ws.vdot[i], std::stod(c[col["vdot:" + sys.model.v_names[i]]])) << scene << " row " << rows << " " << sys.model.v_names[i];
    compute_wrenches(sys, ws, wd);
    static const char* comp[6] = {"mx", "my", "mz", "fx", "fy", "fz"};
    for (size_t o = 0; o < sys.wrenches.outputs.size(); ++o)
      for (int k = 0; k < 6; ++k)
        ASSERT_EQ(wd.W[o][k], std::stod(c[col[sys.wrenches.outputs[o].name + "." + comp[k]]])) << scene << " row " << rows;
    if (ws.cd.err.size()) max_err = std::max(max_err, ws.cd.err.cwiseAbs().maxCoeff());
    ++rows;
  }
  EXPECT_EQ(rows, 101);
  // the runs stay on their constraints (the read-back states are the run's, near round-off)
  EXPECT_LT(max_err, 1e-8) << scene;
}
}  // namespace

TEST(SimCsv, RowsReadBackEvaluateToTheirOwnVdotAndWrenches) {
  expect_rows_reproduce("two_puma_load", {"--torque", "arm1.q2:pulse:5:0.05:0.1"});
  expect_rows_reproduce("four_bar", {"--torque", "j1:constant:0.5"});
  expect_rows_reproduce("two_wheel_vehicle", {});  // Baumgarte + projection: no terms of its own either
}

namespace {
std::vector<std::string> lines_of(const std::string& path) {
  std::ifstream f(path);
  std::vector<std::string> out;
  for (std::string l; std::getline(f, l);) out.push_back(l);
  return out;
}
}  // namespace

// --every N writes the steps 0, N, 2N, ...: the same header, floor(steps / N) + 1 rows, and row k is
// row k N of the full run character for character (the decimated run computes the same states; only
// the writing is skipped). Progress goes to stderr only when asked (stderr is not a terminal here),
// and the CSV is unchanged by it.
TEST(SimCsv, EveryNWritesEveryNthRowOfTheFullRunExactly) {
  const std::string full = tmp_path("sim_every_full.csv"), dec = tmp_path("sim_every_7.csv");
  const std::vector<std::string> base = {COOPDYN_PATH, "sim", "--scene", scene_path("two_wheel_vehicle"), "--duration",
                                         "0.2", "--dt", "0.002", "--torque", "left_spin:constant:2"};
  std::vector<std::string> a = base, b = base;
  a.insert(a.end(), {"--out", full});
  b.insert(b.end(), {"--out", dec, "--every", "7", "--progress"});
  std::string err_a, err_b;
  {
    Child sim(a, "sim_every_full");
    ASSERT_EQ(sim.wait(), 0) << slurp(sim.err);
    err_a = slurp(sim.err);
  }
  {
    Child sim(b, "sim_every_7");
    ASSERT_EQ(sim.wait(), 0) << slurp(sim.err);
    err_b = slurp(sim.err);
  }
  const std::vector<std::string> F = lines_of(full), D = lines_of(dec);
  size_t h = 0;  // the header's index, after the comment and units lines
  while (h < F.size() && F[h][0] == '#') ++h;
  ASSERT_EQ(F.size(), h + 1 + 101u);  // comments, header, steps 0..100
  ASSERT_EQ(D.size(), h + 1 + 100u / 7 + 1);
  for (size_t k = 0; k <= h; ++k) EXPECT_EQ(D[k], F[k]);
  for (size_t k = h + 1; k < D.size(); ++k) EXPECT_EQ(D[k], F[h + 1 + (k - h - 1) * 7]) << "row " << k - h - 1;
  EXPECT_EQ(split(D.back())[0], "0.196");  // t of step 98
  EXPECT_EQ(err_a, "") << "no progress unless asked or on a terminal";
  EXPECT_NE(err_b.find("100 steps in"), std::string::npos) << err_b;
  // a bad N is a usage error naming the option
  Child bad({COOPDYN_PATH, "sim", "--scene", scene_path("two_wheel_vehicle"), "--duration", "0.01", "--dt", "0.001",
             "--every", "0"},
            "sim_every_bad");
  EXPECT_EQ(bad.wait(), 2);
  EXPECT_NE(slurp(bad.err).find("--every"), std::string::npos);
}
