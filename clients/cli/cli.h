// The command line of coopdyn on CLI11: each subcommand registers its options (register_eval in
// eval.cc, ...) and CLI11 parses and validates them (unknown flags, missing values, numbers) and
// writes --help with the defaults; the values land in the subcommand's Args (common.h), which its
// cmd_* function reads as before. Adding a subcommand: a register_NAME(Cli&) next to its cmd_NAME,
// declared in common.h, and one line in main.cc.
#pragma once

#include <CLI/CLI.hpp>

#include <deque>
#include <string>

#include "clients/cli/common.h"

namespace coopdyn::cli {

struct Command {
  CLI::App* app = nullptr;
  Args args;
  int (*run)(const Args&) = nullptr;

  // --name VALUE, at most once; `type` names the value in the help (FILE, S, HZ, ...), `def` is the
  // default the help shows (the subcommand applies it when the option is absent)
  CLI::Option* value(const std::string& name, const std::string& type, const std::string& help,
                     const std::string& def = "");
  // the same, checked to be a number
  CLI::Option* number(const std::string& name, const std::string& type, const std::string& help,
                      const std::string& def = "");
  // --name VALUE, repeatable; every value is kept, in order (Args::all)
  CLI::Option* repeated(const std::string& name, const std::string& type, const std::string& help);
  // --name, no value
  CLI::Option* flag(const std::string& name, const std::string& help);
};

class Cli {
 public:
  explicit Cli(CLI::App* app) : app_(app) {}
  Command& add(const std::string& name, const std::string& description, int (*run)(const Args&));
  // after a successful parse: the chosen subcommand, or nullptr
  Command* chosen();

 private:
  CLI::App* app_;
  std::deque<Command> commands_;  // stable addresses: the option callbacks hold them
};

// --scene FILE (required or not) and --formulation NAME, read by load_cli_scene.
void scene_options(Command& c, bool required);
// The syntax of --torque PROFILE, for the help of the subcommands that take it.
extern const char* const kProfileHelp;

// Defaults shared by the LCM subcommands (and shown in their --help).
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";
// A number as the help shows it (%g).
std::string show(double x);

}  // namespace coopdyn::cli
