// coopdyn spy: lcm-spy with coopdyn's message types, on the daemon's URL.
//
// Runs `java ... -cp lcm.jar:jchart2d.jar:coopdyn_types.jar lcm.spy.Spy --lcm-url=URL`: the JVM
// options of Debian's lcm-spy script without -Xincgc, which JDK 9 removed (JDK 17, Debian 12's, stops
// with "Unrecognized option: -Xincgc"), and the types jar on the class path (the script's fixed -cp
// has no room for it; lcm-spy finds message classes on the class path and in $CLASSPATH by their
// fingerprint). Every missing piece is named with the Debian package that provides it.
#include <sys/stat.h>
#include <unistd.h>

#include <climits>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "clients/cli/cli.h"

#ifndef COOPDYN_LCM_JAR
#define COOPDYN_LCM_JAR "/usr/share/java/lcm.jar"
#endif
#ifndef COOPDYN_INSTALL_DATADIR
#define COOPDYN_INSTALL_DATADIR "share"
#endif

namespace coopdyn::cli {

const char* const kLcmJar = COOPDYN_LCM_JAR;
const char* const kJchart2dJar = "/usr/share/java/jchart2d.jar";

namespace {

bool is_file(const std::string& p, off_t* size = nullptr) {
  struct stat st;
  if (stat(p.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return false;
  if (size) *size = st.st_size;
  return true;
}

std::string exe_dir() {
  char buf[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return "";
  std::string p(buf, static_cast<size_t>(n));
  return p.substr(0, p.rfind('/'));
}

// java: $JAVA_HOME/bin/java, else the first on PATH
std::string find_java() {
  if (const char* h = std::getenv("JAVA_HOME"); h && *h) {
    const std::string j = std::string(h) + "/bin/java";
    if (access(j.c_str(), X_OK) == 0) return j;
  }
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "/usr/bin:/bin";
  size_t b = 0;
  while (b <= dirs.size()) {
    size_t e = dirs.find(':', b);
    if (e == std::string::npos) e = dirs.size();
    const std::string j = (e > b ? dirs.substr(b, e - b) : ".") + "/java";
    if (access(j.c_str(), X_OK) == 0 && is_file(j)) return j;
    b = e + 1;
  }
  return "";
}

}  // namespace

void register_spy(Cli& cli) {
  auto [c, a] = cli.add("spy", cmd_spy);
  value(c, "--lcm-url", a.lcm_url, "URL", "LCM URL to listen on (the daemon's lcm_url)", Default::kShown);
  value(c, "--types-jar", a.types_jar, "FILE",
        "coopdyn's Java types (default: coopdyn_types.jar of the build tree next to bin/, or the installed "
        "share/coopdyn/java/coopdyn_types.jar)");
  value(c, "--lcm-jar", a.lcm_jar, "FILE", "LCM's Java library (Debian liblcm-java)", Default::kShown);
  value(c, "--jchart2d-jar", a.jchart2d_jar, "FILE", "lcm-spy's chart library (Debian libjchart2d-java)", Default::kShown);
  value(c, "--java", a.java, "FILE", "the java command (default: $JAVA_HOME/bin/java, else java on PATH)");
  flag(c, "--print", a.print, "print the command instead of running it (after the same checks)");
}

int cmd_spy(const SpyArgs& a) {
  std::vector<std::string> missing;
  std::string java = a.java;
  if (java.empty()) {
    java = find_java();
    if (java.empty())
      missing.push_back("java: not on PATH nor in $JAVA_HOME/bin (a Java runtime, 8 or newer; Debian 12: "
                        "apt install default-jre, which is OpenJDK 17)");
  } else if (access(java.c_str(), X_OK) != 0) {
    missing.push_back(java + " (--java): not an executable file");
  }
  const std::string& lcm_jar = a.lcm_jar;
  if (!is_file(lcm_jar)) missing.push_back(lcm_jar + ": missing (LCM's Java library and lcm-spy; Debian: apt install liblcm-java)");
  const std::string& chart_jar = a.jchart2d_jar;
  if (!is_file(chart_jar))
    missing.push_back(chart_jar + ": missing (the chart library lcm-spy plots with; Debian: apt install libjchart2d-java)");
  std::string types = a.types_jar;
  const char* const kWhy =
      "it is built only when a JDK (javac, jar) and LCM's lcm.jar were present when cmake configured the build: "
      "apt install default-jdk-headless liblcm-java, then cmake -S . -B build && cmake --build build (and "
      "cmake --install build to install it)";
  if (types.empty()) {
    const std::string dir = exe_dir();
    const std::vector<std::string> tried = {dir + "/../coopdyn_types.jar",
                                            dir + "/../" COOPDYN_INSTALL_DATADIR "/coopdyn/java/coopdyn_types.jar"};
    for (const std::string& t : tried)
      if (types.empty() && is_file(t)) {
        char real[PATH_MAX];
        types = realpath(t.c_str(), real) ? std::string(real) : t;
      }
    if (types.empty()) missing.push_back("coopdyn_types.jar: not found (looked for " + tried[0] + " and " + tried[1] + "); " + kWhy);
  } else if (!is_file(types)) {
    missing.push_back(types + " (--types-jar): missing");
  }
  off_t size = 0;
  if (!types.empty() && is_file(types, &size) && size == 0)
    missing.push_back(types + ": empty (the JDK failed while the build made it; see the build's warning)");
  if (!missing.empty()) {
    std::fprintf(stderr, "coopdyn spy: cannot run lcm-spy:\n");
    for (const std::string& m : missing) std::fprintf(stderr, "  %s\n", m.c_str());
    return 1;
  }
  const std::vector<std::string> argv = {java,      "-server", "-Djava.net.preferIPv4Stack=true", "-Xmx128m", "-Xms64m", "-ea",
                                         "-cp",     lcm_jar + ":" + chart_jar + ":" + types,
                                         "lcm.spy.Spy", "--lcm-url=" + a.lcm_url};
  if (a.print) {
    std::string line;
    for (const std::string& s : argv) line += (line.empty() ? "" : " ") + shell_quote(s);
    std::printf("%s\n", line.c_str());
    return 0;
  }
  std::vector<char*> args;
  for (const std::string& s : argv) args.push_back(const_cast<char*>(s.c_str()));
  args.push_back(nullptr);
  std::fflush(stdout);
  execv(java.c_str(), args.data());
  std::perror(("coopdyn spy: " + java).c_str());
  return 1;
}

}  // namespace coopdyn::cli
