// The command line of coopdyn on CLI11: each subcommand binds its options straight into the typed
// members of its NameArgs (commands.h) in register_NAME, next to cmd_NAME(const NameArgs&). CLI11
// parses and validates them (unknown flags, missing values, numbers) and writes --help with the
// defaults, the members' initial values. Adding a subcommand: its NameArgs and declarations in
// commands.h, register_NAME(Cli&) next to its cmd_NAME, and its line in commands.def (its name and
// the description --help shows).
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "clients/cli/commands.h"
#include "clients/cli/common.h"

namespace coopdyn::cli {

// A subcommand being registered: its CLI11 app and the struct its options bind into.
// The line `coopdyn --help` shows for a subcommand (commands.def).
std::string command_description(const std::string& name);

template <class A>
struct Bound {
  CLI::App* app;
  A& args;
};

class Cli {
 public:
  explicit Cli(CLI::App* app) : app_(app) {}
  // `coopdyn NAME`: its options bind into an A, which `run` gets after a successful parse
  template <class A>
  Bound<A> add(const std::string& name, int (*run)(const A&)) {
    auto args = std::make_shared<A>();
    CLI::App* app = app_->add_subcommand(name, command_description(name));
    commands_.push_back({app, [args, run] { return run(*args); }});
    return {app, *args};
  }
  // after a successful parse: runs the chosen subcommand and returns its exit status (2 when none)
  int run_chosen() const;

 private:
  struct Command {
    CLI::App* app;
    std::function<int()> run;
  };
  CLI::App* app_;
  std::vector<Command> commands_;
};

// Whether --help shows the member's initial value as the option's default.
enum class Default { kHidden, kShown };

// --name VALUE, at most once, into `into`; `type` names the value in the help (FILE, S, HZ, ...).
CLI::Option* value(CLI::App* app, const std::string& name, std::string& into, const std::string& type,
                   const std::string& help, Default d = Default::kHidden);
CLI::Option* value(CLI::App* app, const std::string& name, std::optional<std::string>& into, const std::string& type,
                   const std::string& help);
// The same, checked to be a number (a floating-point one: an integer member takes its leading whole
// part, as std::stoll does).
CLI::Option* number(CLI::App* app, const std::string& name, double& into, const std::string& type,
                    const std::string& help, Default d = Default::kHidden);
CLI::Option* number(CLI::App* app, const std::string& name, int& into, const std::string& type,
                    const std::string& help, Default d = Default::kHidden);
CLI::Option* number(CLI::App* app, const std::string& name, long long& into, const std::string& type,
                    const std::string& help, Default d = Default::kHidden);
CLI::Option* number(CLI::App* app, const std::string& name, WholeNumber& into, const std::string& type,
                    const std::string& help, Default d = Default::kHidden);
CLI::Option* number(CLI::App* app, const std::string& name, std::optional<double>& into, const std::string& type,
                    const std::string& help);
CLI::Option* number(CLI::App* app, const std::string& name, std::optional<long long>& into, const std::string& type,
                    const std::string& help);
// --name VALUE, repeatable; every value is kept, in order
CLI::Option* repeated(CLI::App* app, const std::string& name, std::vector<std::string>& into, const std::string& type,
                      const std::string& help);
// --name, no value
CLI::Option* flag(CLI::App* app, const std::string& name, bool& into, const std::string& help);

// --scene FILE (required or not) and --formulation NAME, read by load_cli_scene.
void scene_options(CLI::App* app, SceneArgs& into, bool required);
// --torque PROFILE and --steer PROFILE (repeatable), read by load_cli_profile and load_cli_targets,
// with what each means in `torque_help` and `steer_help`, and the syntax of PROFILE in the footer.
void profile_options(CLI::App* app, ProfileArgs& into, const std::string& torque_help, const std::string& steer_help);

// A number as the help shows it (%g).
std::string show(double x);

}  // namespace coopdyn::cli
