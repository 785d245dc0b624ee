// coopdyn spy, without a display: the java command it runs (a stand-in java records its arguments),
// the types jar it finds in the build tree or an installed layout, every missing piece named with
// its Debian package, and, where a JDK, liblcm-java and libjchart2d-java are installed and the types
// jar was built, the same JVM options starting lcm-spy on this JDK (--help) and lcm-spy's own type
// database resolving each coopdyn message's fingerprint to its class.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "service/io/codec/codec.h"
#include "tests/support/child_process.h"

using namespace coopdyn;
using namespace coopdyn::daemon_test;

namespace {

Result run(const std::vector<std::string>& argv, const std::string& tag) { return run_command(argv, "spy_" + tag); }
bool has(const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; }
bool is_file(const std::string& p, off_t* size = nullptr) {
  struct stat st;
  if (stat(p.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return false;
  if (size) *size = st.st_size;
  return true;
}
void write(const std::string& path, const std::string& text, bool exec = false) {
  std::ofstream(path) << text;
  if (exec) chmod(path.c_str(), 0755);
}

// a scratch directory, removed at the end
struct Dir {
  std::string path = tmp_path("spy_dir");
  Dir() {
    std::system(("rm -rf '" + path + "' && mkdir -p '" + path + "'").c_str());
  }
  ~Dir() { std::system(("rm -rf '" + path + "'").c_str()); }
};

const std::string kUrl = private_udpm_url(0);

}  // namespace

TEST(Spy, RunsJavaWithLcmSpyTheTypesAndTheUrl) {
  Dir d;
  const std::string java = d.path + "/java", args = d.path + "/args", lcm = d.path + "/lcm.jar",
                    chart = d.path + "/jchart2d.jar", types = d.path + "/coopdyn_types.jar";
  write(java, "#!/bin/sh\nfor a in \"$@\"; do echo \"$a\"; done > '" + args + "'\n", true);  // records its arguments
  for (const std::string& j : {lcm, chart, types}) write(j, "PK");
  const std::vector<std::string> base = {COOPDYN_PATH, "spy", "--java", java, "--lcm-jar", lcm,
                                         "--jchart2d-jar", chart, "--types-jar", types, "--lcm-url", kUrl};
  std::vector<std::string> print = base;
  print.push_back("--print");
  const Result p = run(print, "print");
  ASSERT_EQ(p.rc, 0) << p.err;
  // Debian's lcm-spy script's JVM options without -Xincgc, and the types jar on the class path
  EXPECT_EQ(p.out, java + " -server -Djava.net.preferIPv4Stack=true -Xmx128m -Xms64m -ea -cp " + lcm + ":" + chart + ":" +
                       types + " lcm.spy.Spy '--lcm-url=" + kUrl + "'\n");
  const Result r = run(base, "exec");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_EQ(slurp(args), "-server\n-Djava.net.preferIPv4Stack=true\n-Xmx128m\n-Xms64m\n-ea\n-cp\n" + lcm + ":" + chart + ":" +
                             types + "\nlcm.spy.Spy\n--lcm-url=" + kUrl + "\n");
  // the default URL is the daemon's
  const Result def = run({COOPDYN_PATH, "spy", "--java", java, "--lcm-jar", lcm, "--jchart2d-jar", chart, "--types-jar",
                          types, "--print"},
                         "default_url");
  EXPECT_TRUE(has(def.out, "'--lcm-url=udpm://239.255.76.67:7667?ttl=0'")) << def.out;
  const Result h = run({COOPDYN_PATH, "spy", "--help"}, "help");
  EXPECT_EQ(h.rc, 0);
  for (const char* o : {"--lcm-url URL=udpm://239.255.76.67:7667?ttl=0", "--types-jar", "--lcm-jar FILE=", "--jchart2d-jar FILE=/usr/share/java/jchart2d.jar",
                        "--java", "--print"})
    EXPECT_TRUE(has(h.out, o)) << o << " in\n" << h.out;
}

TEST(Spy, NamesEveryMissingPieceAndItsPackage) {
  const Result r = run({COOPDYN_PATH, "spy", "--java", "/no/such/java", "--lcm-jar", "/no/lcm.jar", "--jchart2d-jar",
                        "/no/jchart2d.jar", "--types-jar", "/no/coopdyn_types.jar", "--print"},
                       "missing");
  EXPECT_EQ(r.rc, 1);
  EXPECT_EQ(r.out, "");
  for (const char* s : {"/no/such/java (--java): not an executable file", "/no/lcm.jar: missing", "apt install liblcm-java",
                        "/no/jchart2d.jar: missing", "apt install libjchart2d-java", "/no/coopdyn_types.jar (--types-jar): missing"})
    EXPECT_TRUE(has(r.err, s)) << s << " in\n" << r.err;
  // no java anywhere
  const Result j = run({"/usr/bin/env", "-u", "JAVA_HOME", "PATH=/nonexistent", COOPDYN_PATH, "spy", "--print"}, "no_java");
  EXPECT_EQ(j.rc, 1);
  EXPECT_TRUE(has(j.err, "java: not on PATH nor in $JAVA_HOME/bin")) << j.err;
  EXPECT_TRUE(has(j.err, "apt install default-jre")) << j.err;
}

TEST(Spy, FindsTheTypesJarOfAnInstalledLayoutOrSaysWhenItIsBuilt) {
  // a copy of coopdyn in PREFIX/bin: it looks for PREFIX/coopdyn_types.jar (a build tree) and
  // PREFIX/share/coopdyn/java/coopdyn_types.jar (installed)
  Dir d;
  ASSERT_EQ(std::system(("mkdir -p '" + d.path + "/bin' '" + d.path + "/share/coopdyn/java' && cp '" + std::string(COOPDYN_PATH) + "' '" +
                         d.path + "/bin/coopdyn'")
                            .c_str()),
            0);
  const std::string exe = d.path + "/bin/coopdyn", jar = d.path + "/share/coopdyn/java/coopdyn_types.jar";
  const std::vector<std::string> cmd = {exe, "spy", "--java", "/bin/true", "--lcm-jar", exe, "--jchart2d-jar", exe, "--print"};
  const Result none = run(cmd, "no_types");
  EXPECT_EQ(none.rc, 1);
  EXPECT_TRUE(has(none.err, "coopdyn_types.jar: not found (looked for " + d.path + "/bin/../coopdyn_types.jar and " +
                                d.path + "/bin/../share/coopdyn/java/coopdyn_types.jar)"))
      << none.err;
  EXPECT_TRUE(has(none.err, "only when a JDK (javac, jar) and LCM's lcm.jar were present when cmake configured")) << none.err;
  write(jar, "");  // what the build leaves when javac failed
  const Result empty = run(cmd, "empty_types");
  EXPECT_EQ(empty.rc, 1);
  EXPECT_TRUE(has(empty.err, jar + ": empty")) << empty.err;
  write(jar, "PK");
  const Result ok = run(cmd, "installed_types");
  EXPECT_EQ(ok.rc, 0) << ok.err;
  EXPECT_TRUE(has(ok.out, ":" + jar + " lcm.spy.Spy")) << ok.out;
}

TEST(Spy, LcmSpyStartsOnThisJdkAndKnowsEveryCoopdynType) {
  off_t size = 0;
  if (!is_file(COOPDYN_TYPES_JAR, &size) || size == 0 || !is_file(COOPDYN_LCM_JAR) ||
      !is_file("/usr/share/java/jchart2d.jar") || std::system("command -v java > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "needs java, " << COOPDYN_LCM_JAR << " (liblcm-java), /usr/share/java/jchart2d.jar (libjchart2d-java) and "
                 << COOPDYN_TYPES_JAR << " (built when a JDK was present at configure time)";
  const Result p = run({COOPDYN_PATH, "spy", "--print"}, "real_print");
  ASSERT_EQ(p.rc, 0) << p.err;
  EXPECT_TRUE(has(p.out, ":" + std::string(COOPDYN_TYPES_JAR) + " lcm.spy.Spy")) << "the build tree's jar: " << p.out;
  std::vector<std::string> argv;
  std::istringstream words(p.out);
  for (std::string w; words >> w;) argv.push_back(w);
  ASSERT_EQ(argv.size(), 10u) << p.out;
  // the JVM options are accepted by this JDK and lcm-spy's main runs (--help needs no display; it
  // prints its usage on stderr and exits 1); Debian's lcm-spy script stops before main on JDK 17.
  argv.back() = "--help";
  const Result h = run(argv, "real_help");
  EXPECT_TRUE(has(h.err, "usage: lcm-spy [options]") && has(h.err, "-l, --lcm-url=URL")) << h.out << h.err;
  EXPECT_FALSE(has(h.err, "Unrecognized option")) << h.err;
  // lcm-spy's type database, on the same class path, maps each fingerprint to the coopdyn class
  Dir d;
  write(d.path + "/SpyTypes.java",
        "public class SpyTypes {\n"
        "  public static void main(String[] a) {\n"
        "    lcm.spy.LCMTypeDatabase db = new lcm.spy.LCMTypeDatabase();\n"
        "    for (String f : a) {\n"
        "      Class<?> c = db.getClassByFingerprint(Long.parseLong(f));\n"
        "      System.out.println(\"type \" + (c == null ? \"none\" : c.getName()));\n"
        "    }\n"
        "  }\n"
        "}\n");
  std::vector<std::string> check = {"/usr/bin/env", "java", argv[6], argv[7], d.path + "/SpyTypes.java"};
  std::string want;
  for (io::MessageType t : {io::MessageType::kOutput, io::MessageType::kLoopStats, io::MessageType::kTorqueCommand,
                            io::MessageType::kMeasuredState, io::MessageType::kControl}) {
    check.push_back(std::to_string(io::fingerprint(t)));
    want += std::string("type ") + io::type_name(t) + "\n";
  }
  const Result t = run(check, "types");
  ASSERT_EQ(t.rc, 0) << t.err;
  std::string got;
  std::istringstream lines(t.out);
  for (std::string l; std::getline(lines, l);)
    if (l.rfind("type ", 0) == 0) got += l + "\n";
  EXPECT_EQ(got, want) << t.out << t.err;
}
