// coopdyn: offline evaluation and simulation of a scene.
#include <cstdio>
#include <cstring>
#include <string>

#include "clients/common.h"

namespace {
void usage() {
  std::fprintf(stderr,
               "usage:\n"
               "  coopdyn eval --scene FILE [--state FILE.json] [--formulation NAME]\n"
               "  coopdyn sim  --scene FILE --duration T --dt H [--integrator semi_implicit_euler|rk4|implicit_euler]\n"
               "               [--torque PROFILE]... [--formulation NAME] [--out FILE.csv]\n"
               "  coopdyn send --scene FILE (--torque PROFILE... | --states SIM.csv [--joints-only]) [--rate HZ] [--duration S]\n"
               "               [--lcm-url URL] [--channel C] [--seq N] [--measure-latency] [--output-channel C] [--no-check]\n"
               "  coopdyn log  --in FILE.lcmlog [--out DIR] [--no-plot]\n"
               "  coopdyn control --action reset|reset_to_state|pause|resume|clear_fault [--scene FILE --state FILE.json]\n"
               "               [--lcm-url URL] [--channel C] [--output-url URL] [--output-channel C] [--seq N] [--no-wait]\n"
               "  coopdyn track --scene FILE [--duration S] [--radius M] [--period S] [--squeeze N] [--out FILE.csv]\n"
               "               [--lcm-url URL] [--channel C] [--output-url URL] [--output-channel C]\n"
               "  coopdyn view --scene FILE --csv SIM.csv --out VIEW.html [--max-frames N] [--three-js FILE]\n"
               "PROFILE: JOINT:constant:VALUE | JOINT:step:VALUE:T0 | JOINT:pulse:VALUE:T0:T1 | FILE.csv\n");
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
    usage();
    return argc < 2 ? 2 : 0;
  }
  const std::string cmd = argv[1];
  coopdyn::cli::Args a;
  if (!coopdyn::cli::parse_args(argc, argv, 2, &a)) {
    usage();
    return 2;
  }
  if (cmd == "eval") return coopdyn::cli::cmd_eval(a);
  if (cmd == "sim") return coopdyn::cli::cmd_sim(a);
  if (cmd == "send") return coopdyn::cli::cmd_send(a);
  if (cmd == "log") return coopdyn::cli::cmd_log(a);
  if (cmd == "control") return coopdyn::cli::cmd_control(a);
  if (cmd == "track") return coopdyn::cli::cmd_track(a);
  if (cmd == "view") return coopdyn::cli::cmd_view(a);
  std::fprintf(stderr, "coopdyn: unknown command '%s'\n", cmd.c_str());
  usage();
  return 2;
}
