// Each wrench's sigma leaves coopdyn unchanged: output_t through a real LCM round trip (memq://),
// the per-step CSV (columns next to each wrench, numbers parsed back exactly), `coopdyn eval`'s JSON.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <future>
#include <mutex>

#include "clients/csv/step_csv.h"
#include "service/dynamics/sigma/wrench_sigma.h"
#include "service/io/codec/codec.h"
#include "tests/support/child_process.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
using daemon_test::Result;
using daemon_test::run_command;
using daemon_test::try_bus;
namespace {

const std::string kNoise = "noise: {tau: 0.2, joints: {arm1.q2: 1.5}}\n";

struct Evaluated {
  System sys;
  Workspace ws;
  WrenchData wd;
  WrenchSigmaData sd;
  Eigen::VectorXd tau;
  explicit Evaluated(const std::string& extra)
      : sys(load_scene_string(without_reactions(scene_text("two_puma_load")) + "\nreactions: all\n" + extra,
                              scene_path("two_puma_load"))),
        ws(sys), wd(sys), sd(sys), tau(Eigen::VectorXd::Constant(sys.model.nv(), 0.3)) {
    evaluate(sys, ws, sys.q0, sys.v0, tau);
    compute_wrenches(sys, ws, wd);
    compute_wrench_sigma(sys, ws, sd);
  }
};

// output_t published on memq:// and received: sigma_source and every wrench_sigma bit for bit; a
// scene without noise sends SIGMA_NONE and zeros.
io::DecodedOutput round_trip(Evaluated& e) {
  io::OutputFrame f;
  f.valid = true;
  f.q = &e.sys.q0;
  f.v = &e.sys.v0;
  f.tau = &e.tau;
  f.ws = &e.ws;
  f.wrenches = &e.wd;
  f.sigma = e.sd.declared ? &e.sd : nullptr;
  io::OutputEncoder enc(e.sys);
  std::vector<uint8_t> buf(static_cast<size_t>(enc.max_size()));
  const int len = enc.encode(f, buf.data(), static_cast<int>(buf.size()));
  EXPECT_GT(len, 0);
  io::DecodedOutput out;
  auto bus = try_bus("memq://");
  if (!bus) {
    ADD_FAILURE() << "no memq:// bus";
    return out;
  }
  std::promise<std::vector<uint8_t>> got;
  std::once_flag once;
  bus->subscribe("SIGMA_OUT", [&](const void* d, int n, long long) {
    std::call_once(once, [&] { got.set_value(std::vector<uint8_t>(static_cast<const uint8_t*>(d), static_cast<const uint8_t*>(d) + n)); });
  });
  bus->start();
  bus->publish("SIGMA_OUT", buf.data(), len);
  auto fut = got.get_future();
  if (fut.wait_for(std::chrono::seconds(10)) != std::future_status::ready) {
    ADD_FAILURE() << "the output never arrived";
    return out;
  }
  const std::vector<uint8_t> rx = fut.get();
  EXPECT_TRUE(io::decode_output(rx.data(), static_cast<int>(rx.size()), &out));
  bus->stop();
  return out;
}

TEST(WrenchSigmaOutputs, OutputTCarriesSigmaThroughLcm) {
  Evaluated e(kNoise);
  ASSERT_TRUE(e.sd.valid);
  const io::DecodedOutput o = round_trip(e);
  EXPECT_EQ(o.sigma_source, 1);  // SIGMA_TAU
  ASSERT_EQ(o.wrench_sigma.size(), e.sys.wrenches.outputs.size());
  double total = 0;
  for (size_t k = 0; k < o.wrench_sigma.size(); ++k)
    for (int c = 0; c < 6; ++c) {
      EXPECT_EQ(o.wrench_sigma[k][c], e.sd.sigma[k][c]) << e.sys.wrenches.outputs[k].name << " " << c;
      total += o.wrench_sigma[k][c];
    }
  EXPECT_GT(total, 0.0);
  Evaluated plain("");
  const io::DecodedOutput p = round_trip(plain);
  EXPECT_EQ(p.sigma_source, 0);  // SIGMA_NONE
  ASSERT_EQ(p.wrench_sigma.size(), plain.sys.wrenches.outputs.size());
  for (const auto& w : p.wrench_sigma)
    for (double x : w) EXPECT_EQ(x, 0.0);
}

// The per-step CSV: NAME.sigma_mx .. NAME.sigma_fz right after NAME.fz, same units; the numbers
// parse back to the same doubles. Without noise: no sigma column.
TEST(WrenchSigmaOutputs, StepCsvColumnsNextToEachWrenchRoundTrip) {
  Evaluated e(kNoise);
  const cli::StepSchema s = cli::step_schema(e.sys, "sim");
  ASSERT_TRUE(s.sigma);
  const cli::CsvColumns cols = cli::shared_step_columns(s);
  const std::string w0 = e.sys.wrenches.outputs[0].name;
  const int fz = index_of(cols.names, w0 + ".fz");
  ASSERT_GE(fz, 0);
  ASSERT_LT(fz + 6, static_cast<int>(cols.names.size()));
  EXPECT_EQ(cols.names[static_cast<size_t>(fz + 1)], w0 + ".sigma_mx");
  EXPECT_EQ(cols.units[static_cast<size_t>(fz + 1)], "N*m");
  EXPECT_EQ(cols.names[static_cast<size_t>(fz + 6)], w0 + ".sigma_fz");
  EXPECT_EQ(cols.units[static_cast<size_t>(fz + 6)], "N");
  EXPECT_FALSE(cli::step_schema(Evaluated("").sys, "sim").sigma);

  const std::string path = daemon_test::tmp_path("sigma.csv");
  std::FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  cli::write_step_csv_header(f, s, cols);
  cli::StepRow row;
  row.q = cli::csv_numbers(e.sys.q0);
  row.v = cli::csv_numbers(e.sys.v0);
  row.tau = cli::csv_numbers(e.tau);
  row.vdot = cli::csv_numbers(e.ws.vdot);
  row.wrenches = cli::csv_wrenches(e.wd.W);
  row.wrench_sigma = cli::csv_wrenches(e.sd.sigma);
  row.stress = cli::csv_numbers(e.ws.stress);
  cli::CsvLine line(cols.names.size());
  cli::write_step_cells(line, row);
  line.end();
  line.write(f);
  std::fclose(f);
  const CsvText t = read_csv_text(path);
  std::remove(path.c_str());
  ASSERT_EQ(t.head, cols.names);
  ASSERT_EQ(t.rows.size(), 1u);
  ASSERT_EQ(t.rows[0].size(), cols.names.size());
  for (size_t k = 0; k < e.sys.wrenches.outputs.size(); ++k) {
    static const char* comp[6] = {"mx", "my", "mz", "fx", "fy", "fz"};
    for (int c = 0; c < 6; ++c) {
      const std::string& n = e.sys.wrenches.outputs[k].name;
      const int is = index_of(t.head, n + ".sigma_" + comp[c]), iw = index_of(t.head, n + "." + comp[c]);
      EXPECT_EQ(std::strtod(t.rows[0][static_cast<size_t>(is)].c_str(), nullptr), e.sd.sigma[k][c]) << n;
      EXPECT_EQ(std::strtod(t.rows[0][static_cast<size_t>(iw)].c_str(), nullptr), e.wd.W[k][c]) << n;
    }
  }
}

// `coopdyn eval`: every wrench has "sigma": [6] (%.17g: parsed back exactly) with noise, none without.
TEST(WrenchSigmaOutputs, EvalJsonHasSigmaPerWrench) {
  Evaluated e(kNoise);
  // the scene with noise, its robot file by absolute path
  const std::string text = replace_once(without_reactions(scene_text("two_puma_load")), "file: ../robots/puma560.yaml",
                                        "file: " + std::string(COOPDYN_SOURCE_DIR) + "/config/robots/puma560.yaml") +
                           "\nreactions: all\n" + kNoise;
  const std::string path = daemon_test::tmp_path("sigma_scene.yaml");
  {
    std::ofstream out(path);
    out << text;
  }
  const Result r = run_command({COOPDYN_PATH, "eval", "--scene", path}, "eval_sigma");
  std::remove(path.c_str());
  ASSERT_EQ(r.rc, 0) << r.err;
  // each wrench's "sigma": [...] in output order
  size_t pos = 0;
  for (size_t k = 0; k < e.sys.wrenches.outputs.size(); ++k) {
    pos = r.out.find("{\"name\": \"" + e.sys.wrenches.outputs[k].name + "\"", pos);
    ASSERT_NE(pos, std::string::npos) << e.sys.wrenches.outputs[k].name;
    const size_t s = r.out.find("\"sigma\": [", pos);
    ASSERT_NE(s, std::string::npos);
    const char* p = r.out.c_str() + s + 10;
    for (int c = 0; c < 6; ++c) {
      char* end = nullptr;
      const double x = std::strtod(p, &end);
      EXPECT_EQ(x, e.sd.sigma[k][c]) << e.sys.wrenches.outputs[k].name << " " << c;
      p = end + 2;  // ", "
    }
    pos = s;
  }
  const Result plain = run_command({COOPDYN_PATH, "eval", "--scene", scene_path("two_puma_load")}, "eval_plain");
  ASSERT_EQ(plain.rc, 0) << plain.err;
  EXPECT_EQ(plain.out.find("\"sigma\""), std::string::npos);
}

}  // namespace
}  // namespace coopdyn::testing
