// coopdyn: offline evaluation and simulation of a scene, and the LCM clients of coopdynd.
#include <iostream>
#include <string>

#include "clients/cli/cli.h"
#include "service/version.h"

int main(int argc, char** argv) {
  using namespace coopdyn::cli;
  CLI::App app{"coopdyn " COOPDYN_VERSION
               ": constrained dynamics of cooperating manipulators, offline (eval, sim, bench) and as clients of "
               "coopdynd (send, log, control, track, view, spy)",
               "coopdyn"};
  app.set_version_flag("--version", "coopdyn " COOPDYN_VERSION, "print the version and exit");
  app.require_subcommand(1);
  app.footer("Run 'coopdyn COMMAND --help' for the options of a command and their defaults.");
  app.failure_message([](const CLI::App* a, const CLI::Error& e) {
    std::string cmd = a->get_name();
    for (const CLI::App* s : a->get_subcommands()) cmd += " " + s->get_name();
    return cmd + ": " + e.what() + "\nRun '" + cmd + " --help' for the options.\n";
  });
  Cli cli(&app);
#define COOPDYN_COMMAND(name, description) register_##name(cli);
#include "clients/cli/commands.def"
#undef COOPDYN_COMMAND
  if (argc < 2) {  // no command: the usage, as an error
    std::cerr << app.help();
    return 2;
  }
  if (argv[1][0] != '-') {  // CLI11 would only say that a subcommand is required
    try {
      app.get_subcommand(argv[1]);
    } catch (const CLI::OptionNotFound&) {
      std::cerr << "coopdyn: unknown command '" << argv[1] << "'\n" << app.help();
      return 2;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help and --version: stdout, 0; errors: stderr, 2
  }
  return cli.run_chosen();
}
