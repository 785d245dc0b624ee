// Bounded user input (service/text/input_limits.h): values cut in messages, files read with a
// size limit, and the nesting pre-scans that run before yaml-cpp and urdfdom (TinyXML) recurse.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <dirent.h>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>

#include "service/text/input_limits.h"

using namespace coopdyn::text;

namespace {
std::string tmp(const std::string& what) {
  return (::testing::TempDir().empty() ? std::string("/tmp/") : ::testing::TempDir()) + "input_limits_" +
         std::to_string(getpid()) + "_" + what;
}
std::string read(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}
bool valid_utf8(const std::string& s) {
  for (size_t i = 0; i < s.size();) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    const int n = c < 0x80 ? 1 : (c >> 5) == 6 ? 2 : (c >> 4) == 14 ? 3 : (c >> 3) == 30 ? 4 : 0;
    if (n == 0 || i + n > s.size()) return false;
    for (int k = 1; k < n; ++k)
      if ((static_cast<unsigned char>(s[i + k]) & 0xC0) != 0x80) return false;
    i += n;
  }
  return true;
}
// the smallest max_depth the pre-scan lets through
int estimated_depth(const std::string& text, bool xml) {
  for (int d = 0; d < 1000; ++d)
    if (!(xml ? xml_depth_exceeds(text, d) : yaml_depth_exceeds(text, d)).exceeded) return d;
  return 1000;
}
}  // namespace

TEST(InputLimits, LongValuesAreCutKeepingBothEnds) {
  const std::string v = "BEGIN" + std::string(100000, 'x') + "/the_file.yaml";
  const std::string s = shown(v);
  EXPECT_EQ(s.size(), kMaxShownChars);
  EXPECT_EQ(s.rfind("BEGIN", 0), 0u);
  EXPECT_NE(s.find("..."), std::string::npos);
  EXPECT_EQ(s.substr(s.size() - 14), "/the_file.yaml");
  EXPECT_EQ(shown("short"), "short");
  // never splits a UTF-8 character
  std::string utf;
  for (int i = 0; i < 50000; ++i) utf += "\xc3\xa9\xe2\x82\xac";  // e-acute, euro sign
  EXPECT_TRUE(valid_utf8(shown(utf)));
  EXPECT_LE(shown(utf).size(), kMaxShownChars);
  // in a message: every quoted value, either quote
  const std::string m = cut_values("f.yaml:1:1: unknown key '" + v + "' in scene, \"" + v + "\" too");
  EXPECT_LT(m.size(), 220u) << m.size();
  EXPECT_EQ(m.rfind("f.yaml:1:1: unknown key 'BEGIN", 0), 0u) << m;
  EXPECT_NE(m.find("' in scene, \"BEGIN"), std::string::npos) << m;
  // unquoted or unbalanced: the whole message is cut
  const std::string u = cut_values("f.yaml:1:1: bad value " + v + " 'unclosed" + v);
  EXPECT_LE(u.size(), kMaxMessageChars + 40);
  EXPECT_NE(u.find("more characters)"), std::string::npos) << u.substr(u.size() - 60);
  EXPECT_TRUE(valid_utf8(cut_values("'" + utf + "' and " + utf)));
}

TEST(InputLimits, TwoUnquotedPathsOfPathMaxStayWholeAValueStaysShort) {
  // the loaders print paths unquoted ("PATH:LINE: reason"): a scene and a URDF path of PATH_MAX
  // (4096) each fit a message whole, while a quoted value echoed from a file is still cut
  const std::string scene = "/" + std::string(4090, 's') + ".yaml", urdf = "/" + std::string(4090, 'u') + ".urdf";
  const std::string value(500, 'v');
  const std::string m = cut_values(scene + ":3:5: URDF " + urdf + ":12: link '" + value + "': no <inertia> element");
  EXPECT_NE(m.find(scene + ":3:5: URDF " + urdf + ":12: link '"), std::string::npos);
  EXPECT_NE(m.find("': no <inertia> element"), std::string::npos) << m.substr(m.size() - 100);
  EXPECT_EQ(m.find(value), std::string::npos) << "the value is cut to " << kMaxShownChars;
}

TEST(InputLimits, ReadFileRefusesDevicesFifosDirectoriesAndOversizeFiles) {
  std::string out, why;
  EXPECT_FALSE(read_file("/dev/zero", 1000, "the config", &out, &why));
  EXPECT_EQ(why, "the config is not a regular file");
  EXPECT_FALSE(read_file("/tmp", 1000, "the config", &out, &why));
  EXPECT_EQ(why, "the config is not a regular file");
  const std::string fifo = tmp("fifo");
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  // no writer: it returns (a blocking open would hang here until ctest's timeout)
  EXPECT_FALSE(read_file(fifo, 1000, "the config", &out, &why));
  EXPECT_EQ(why, "the config is not a regular file");
  unlink(fifo.c_str());
  EXPECT_FALSE(read_file("/no/such/file", 1000, "the config", &out, &why));
  EXPECT_EQ(why, "cannot open the config (No such file or directory)");
  const std::string big = tmp("big");
  std::ofstream(big) << std::string(1001, 'a');
  EXPECT_FALSE(read_file(big, 1000, "'big'", &out, &why));
  EXPECT_EQ(why, "'big' is 1001 bytes, more than the limit of 1000");
  ASSERT_TRUE(read_file(big, 1001, "'big'", &out, &why)) << why;
  EXPECT_EQ(out, std::string(1001, 'a'));
  unlink(big.c_str());
}

// 200,000 levels in every YAML form fail the pre-scan at once, at the place the limit is passed.
TEST(InputLimits, YamlNestedDeepIsCaughtBeforeTheParser) {
  std::string indented;
  for (int i = 0; i < 2000; ++i) indented += std::string(static_cast<size_t>(i), ' ') + "a:\n";
  std::string dashes;
  for (int i = 0; i < 200000; ++i) dashes += "- ";
  const std::vector<std::string> texts = {"a: " + std::string(200000, '['), std::string(200000, '{'),
                                          "x:\n  y: " + std::string(200000, '[') + std::string(200000, ']'), dashes,
                                          indented};
  for (const std::string& t : texts) {
    // caught where the limit is passed: the scan stops there, not at the end of the text
    const DepthExceeded d = yaml_depth_exceeds(t);
    EXPECT_TRUE(d.exceeded) << t.substr(0, 40);
    EXPECT_GE(d.line, 1);
    EXPECT_LE(d.line, 70) << t.substr(0, 40);
  }
  // 2 for the indentation level, 1 for "a:", so the 62nd bracket (column 65) passes 64
  EXPECT_EQ(yaml_depth_exceeds("a: " + std::string(200000, '[')).column, kMaxYamlDepth + 1);
  // brackets, dashes and '#' inside quotes, comments and block scalars do not count
  const std::string quiet = "a: '[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[['\n"
                            "b: \"{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{\\\"\"\n"
                            "c: 1  # [[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[\n"
                            "d: |\n  [[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[\n"
                            "  - - - - - - - - - - - - - - - - - - - - - - - - - - - - - - - - - - - - -\n"
                            "e: it's [1, 2]\n";
  EXPECT_FALSE(yaml_depth_exceeds(quiet).exceeded);
  EXPECT_NO_THROW(YAML::Load(quiet));
}

// The estimate is an upper bound: random documents of known depth, emitted in block, flow and
// mixed styles by yaml-cpp, never pass a limit below their depth.
TEST(InputLimits, YamlDepthEstimateIsNeverBelowTheRealDepth) {
  std::mt19937 rng(10);
  int worst_over = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const int depth = 1 + static_cast<int>(rng() % 40);
    YAML::Emitter e;
    std::function<void(int)> emit = [&](int d) {
      const bool flow = rng() % 4 == 0, map = rng() % 2 == 0;
      if (flow) e << YAML::Flow;
      if (map) e << YAML::BeginMap;
      else e << YAML::BeginSeq;
      const int n = 1 + static_cast<int>(rng() % 3);
      const int deep = static_cast<int>(rng() % static_cast<unsigned>(n));
      for (int k = 0; k < n; ++k) {
        if (map) e << YAML::Key << ("k" + std::to_string(k)) << YAML::Value;
        if (k == deep && d > 1) emit(d - 1);
        else e << (rng() % 2 ? "plain" : "it's: [quoted]");
      }
      if (map) e << YAML::EndMap;
      else e << YAML::EndSeq;
    };
    emit(depth);
    const std::string text = e.c_str();
    SCOPED_TRACE(text);
    ASSERT_TRUE(yaml_depth_exceeds(text, depth - 1).exceeded) << "estimate below the real depth " << depth;
    worst_over = std::max(worst_over, estimated_depth(text, false) - depth);
  }
  std::printf("yaml depth estimate: at most %d levels above the real depth in 300 random documents\n", worst_over);
}

TEST(InputLimits, XmlNestedDeepIsCaughtBeforeTheParser) {
  std::string x = "<?xml version=\"1.0\"?>\n<robot name=\"r\">\n<link name=\"a\">";
  for (int i = 0; i < 50000; ++i) x += "<x>";
  for (int i = 0; i < 50000; ++i) x += "</x>";
  x += "</link></robot>\n";
  const DepthExceeded d = xml_depth_exceeds(x);
  ASSERT_TRUE(d.exceeded);
  EXPECT_EQ(d.line, 3);
  EXPECT_EQ(d.column, 16 + 3 * (kMaxXmlDepth - 2));  // robot and link are 2 levels: the 31st <x>
  // comments, CDATA, self-closing tags and '>' in attribute values do not nest
  const std::string flat = "<!-- <a><a><a> --><robot a=\"x>y\"><![CDATA[<b><b>]]><link/><link name='>'/></robot>";
  EXPECT_EQ(estimated_depth(flat, true), 1);
}

// Every shipped file passes with a wide margin: the limits are for hostile input only.
TEST(InputLimits, ShippedFilesNestFarBelowTheLimits) {
  const std::string root = COOPDYN_SOURCE_DIR;
  int worst_yaml = 0, worst_xml = 0;
  for (const std::string& dir : {root + "/config/scenes", root + "/config/robots", root + "/config"}) {
    DIR* d = opendir(dir.c_str());
    ASSERT_NE(d, nullptr) << dir;
    while (dirent* e = readdir(d)) {
      const std::string n = e->d_name, path = dir + "/" + n;
      if (n.size() > 5 && n.substr(n.size() - 5) == ".yaml") worst_yaml = std::max(worst_yaml, estimated_depth(read(path), false));
      if (n.size() > 5 && n.substr(n.size() - 5) == ".urdf") worst_xml = std::max(worst_xml, estimated_depth(read(path), true));
    }
    closedir(d);
  }
  std::printf("shipped files: YAML depth estimate at most %d (limit %d), URDF depth %d (limit %d)\n", worst_yaml,
              kMaxYamlDepth, worst_xml, kMaxXmlDepth);
  EXPECT_LE(worst_yaml, kMaxYamlDepth / 4);
  EXPECT_LE(worst_xml, kMaxXmlDepth / 4);
}
