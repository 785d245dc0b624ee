#include "clients/cli/cli.h"

#include <cstdio>

namespace coopdyn::cli {

namespace {
std::string key_of(const std::string& name) { return name.rfind("--", 0) == 0 ? name.substr(2) : name; }
}  // namespace

CLI::Option* Command::value(const std::string& name, const std::string& type, const std::string& help,
                            const std::string& def) {
  const std::string key = key_of(name);
  CLI::Option* o = app->add_option(
      name,
      [this, key](const CLI::results_t& r) {
        for (const std::string& s : r) args.kv.emplace(key, s);
        return true;
      },
      help);
  o->type_name(type)->expected(1);
  if (!def.empty()) o->default_str(def);
  return o;
}

CLI::Option* Command::number(const std::string& name, const std::string& type, const std::string& help,
                             const std::string& def) {
  static const CLI::Validator kNumber = CLI::Validator(CLI::Number).description("");  // no ":NUMBER" in the help
  return value(name, type, help, def)->check(kNumber);
}

CLI::Option* Command::repeated(const std::string& name, const std::string& type, const std::string& help) {
  return value(name, type, help)->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
}

CLI::Option* Command::flag(const std::string& name, const std::string& help) {
  const std::string key = key_of(name);
  return app->add_flag_callback(name, [this, key] { args.kv.emplace(key, ""); }, help);
}

Command& Cli::add(const std::string& name, const std::string& description, int (*run)(const Args&)) {
  Command& c = commands_.emplace_back();
  c.app = app_->add_subcommand(name, description);
  c.run = run;
  return c;
}

Command* Cli::chosen() {
  for (Command& c : commands_)
    if (c.app->parsed()) return &c;
  return nullptr;
}

void scene_options(Command& c, bool required) {
  CLI::Option* s = c.value("--scene", "FILE", "scene file (YAML; config/scenes/)");
  if (required) s->required();
  c.value("--formulation", "NAME",
          "override the scene's formulation (its formulation: key): mobile_platform, classic, pseudo_joint or svd");
}

const char* const kProfileHelp =
    "PROFILE: JOINT:constant:VALUE | JOINT:step:VALUE:T0 | JOINT:pulse:VALUE:T0:T1 | JOINT:ramp:VALUE:T0:T1 (0 until T0,\n"
    "linear to VALUE at T1) | FILE.csv (header t,JOINT,...; piecewise constant between rows). JOINT is a velocity\n"
    "coordinate of the scene (coopdyn eval lists them). --steer PROFILE: the position target (rad or m) of a locked\n"
    "joint (a pseudo-joint with a target_limit, e.g. a car's fl_steer), the sum of its terms; 0 where none is on.";

std::string show(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", x);
  return b;
}

}  // namespace coopdyn::cli
