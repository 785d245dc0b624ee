// coopdyn view on bad input: a clear error naming the file or the option, exit status 1 (2 for
// usage), no page.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/clients/view/view_test_util.h"

namespace coopdyn {
namespace {
using namespace view_test;

TEST(ViewErrors, NameTheFile) {
  TempDir dir("errors");
  ASSERT_EQ(sim("unicycle", 0.05, 0.01, dir / "u.csv", dir / "sim.err"), 0) << slurp(dir / "sim.err");
  const std::string fake_three = dir / "three.min.js";
  std::ofstream(fake_three) << "/* stand-in */ var THREE = {WebGLRenderer: null};\n";
  const std::string three = "--three-js '" + fake_three + "'";
  std::string err;

  // three.js missing or not three.js
  EXPECT_EQ(view(scene_file("unicycle"), dir / "u.csv", dir / "a.html", dir / "e", &err, "--three-js /nonexistent/three.min.js"), 1);
  EXPECT_NE(err.find("/nonexistent/three.min.js"), std::string::npos) << err;
  EXPECT_NE(err.find("libjs-three"), std::string::npos) << err;
  EXPECT_EQ(view(scene_file("unicycle"), dir / "u.csv", dir / "a.html", dir / "e", &err, "--three-js '" + dir / "u.csv" + "'"), 1);
  EXPECT_NE(err.find("is not three.js"), std::string::npos) << err;

  // the CSV of another scene
  EXPECT_EQ(view(scene_file("four_bar"), dir / "u.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "u.csv"), std::string::npos) << err;
  EXPECT_NE(err.find("four_bar"), std::string::npos) << err;

  // a missing wrench column, a short row, a bad number, no rows, no file
  const std::string csv = slurp(dir / "u.csv");
  // the comment and units lines, then the header at line hl (clients/csv/step_csv.h)
  size_t pos = 0;
  int hl = 1;
  while (csv[pos] == '#') pos = csv.find('\n', pos) + 1, ++hl;
  const std::string pre = csv.substr(0, pos), header = csv.substr(pos, csv.find('\n', pos) - pos);
  const std::string rest = csv.substr(csv.find('\n', pos));  // from the header's newline
  const std::string at_header = ":" + std::to_string(hl), at_row1 = ":" + std::to_string(hl + 1);
  {
    std::string h = header;
    const size_t at = h.find(",wheel.fz");
    ASSERT_NE(at, std::string::npos) << header;
    h.replace(at, 9, ",wheel.FZ");
    std::ofstream(dir / "nocol.csv") << pre << h << rest;
  }
  EXPECT_EQ(view(scene_file("unicycle"), dir / "nocol.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "nocol.csv" + at_header + ": no column 'wheel.fz'"), std::string::npos) << err;

  std::ofstream(dir / "short.csv") << pre << header << "\n" << rest.substr(1, 20) << "\n";
  EXPECT_EQ(view(scene_file("unicycle"), dir / "short.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "short.csv" + at_row1 + ":"), std::string::npos) << err;

  {
    std::string body = rest.substr(1);
    body.replace(body.find(','), 1, ",x");  // the first q of the first row
    std::ofstream(dir / "bad.csv") << pre << header << "\n" << body;
  }
  EXPECT_EQ(view(scene_file("unicycle"), dir / "bad.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "bad.csv" + at_row1 + ": bad number"), std::string::npos) << err;

  {  // a contact state that is none of ok, slip, lift_off; the contact report's columns missing
    std::string body = rest.substr(1);
    const size_t at = body.find(",-1,ok,ok,");
    ASSERT_NE(at, std::string::npos) << body.substr(0, body.find('\n'));
    body.replace(at, 10, ",-1,skid,ok,");
    std::ofstream(dir / "state.csv") << pre << header << "\n" << body;
    std::string h = header;
    h.replace(h.find(",wheel.utilisation"), 18, ",wheel.utilization");
    std::ofstream(dir / "nocontact.csv") << pre << h << rest;
  }
  EXPECT_EQ(view(scene_file("unicycle"), dir / "state.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "state.csv" + at_row1 + ": unknown contact state 'skid' in column 'wheel.contact'"), std::string::npos) << err;
  EXPECT_EQ(view(scene_file("unicycle"), dir / "nocontact.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "nocontact.csv" + at_header + ": no column 'wheel.utilisation'"), std::string::npos) << err;

  // a units line that does not match the header
  std::ofstream(dir / "units.csv") << "# units: s\n" << header << rest;
  EXPECT_EQ(view(scene_file("unicycle"), dir / "units.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "units.csv" + ":1: 1 units for "), std::string::npos) << err;

  std::ofstream(dir / "empty.csv") << pre << header << "\n";
  EXPECT_EQ(view(scene_file("unicycle"), dir / "empty.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find(dir / "empty.csv" + ": no rows"), std::string::npos) << err;

  EXPECT_EQ(view(scene_file("unicycle"), dir / "none.csv", dir / "a.html", dir / "e", &err, three), 1);
  EXPECT_NE(err.find("cannot open '" + dir / "none.csv" + "'"), std::string::npos) << err;

  EXPECT_FALSE(fs::exists(dir / "a.html"));
}

// Bad command lines of the new sources: one source at a time, --out for a file, a usable --listen
// (a malformed one, a port already taken: the error names it), exit status 2 for usage, 1 for the rest.
TEST(ViewErrors, SourcesAndListenAddress) {
  TempDir dir("usage");
  const std::string v = "'" + kBin + "' view --scene '" + scene_file("unicycle") + "' ";
  std::string err;
  EXPECT_EQ(run(v + "--csv a.csv --log b.lcmlog --out x.html", dir / "e", &err), 2);
  EXPECT_NE(err.find("--csv excludes --log"), std::string::npos) << err;
  EXPECT_EQ(run(v + "--log b.lcmlog", dir / "e", &err), 2);
  EXPECT_NE(err.find("--out VIEW.html"), std::string::npos) << err;
  EXPECT_EQ(run(v + "--live --log b.lcmlog", dir / "e", &err), 2);
  if (!COOPDYN_VIEW_LIVE) return;
  EXPECT_EQ(run(v + "--live --listen nonsense --lcm-url memq://", dir / "e", &err), 2);
  EXPECT_NE(err.find("--listen 'nonsense': expected HOST:PORT"), std::string::npos) << err;
  // a port this process holds
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ASSERT_EQ(listen(fd, 1), 0);
  socklen_t len = sizeof a;
  getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  const std::string taken = "127.0.0.1:" + std::to_string(ntohs(a.sin_port));
  EXPECT_EQ(run(v + "--live --listen " + taken + " --lcm-url memq://", dir / "e", &err), 1);
  EXPECT_NE(err.find("cannot listen on " + taken), std::string::npos) << err;
  close(fd);
}

}  // namespace
}  // namespace coopdyn
