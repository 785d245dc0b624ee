#include "clients/cli/cli.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>

namespace coopdyn::cli {

std::string command_description(const std::string& name) {
#define COOPDYN_COMMAND(n, description) \
  if (name == #n) return description;
#include "clients/cli/commands.def"
#undef COOPDYN_COMMAND
  return "";
}

namespace {

// Every option takes its value through a callback (not CLI11's own conversion): the numbers
// convert as the commands always converted them, and one place sets up what CLI11 parses.
CLI::Option* bound_option(CLI::App* app, const std::string& name, const std::string& type, const std::string& help,
                  std::function<void(const std::string&)> store) {
  CLI::Option* o = app->add_option(
      name,
      [store](const CLI::results_t& r) {
        for (const std::string& s : r) store(s);
        return true;
      },
      help);
  return o->type_name(type)->expected(1);
}

CLI::Option* checked_number(CLI::Option* o) {
  static const CLI::Validator kNumber = CLI::Validator(CLI::Number).description("");  // no ":NUMBER" in the help
  return o->check(kNumber);
}

CLI::Option* shown(CLI::Option* o, Default d, const std::string& def) {
  if (d == Default::kShown) o->default_str(def);
  return o;
}

// The leading whole part, as std::stoll (the validator has checked that the text is a number).
long long leading_integer(const std::string& s) { return std::strtoll(s.c_str(), nullptr, 10); }

}  // namespace

CLI::Option* value(CLI::App* app, const std::string& name, std::string& into, const std::string& type,
                   const std::string& help, Default d) {
  const std::string def = into;
  return shown(bound_option(app, name, type, help, [&into](const std::string& s) { into = s; }), d, def);
}

CLI::Option* value(CLI::App* app, const std::string& name, std::optional<std::string>& into, const std::string& type,
                   const std::string& help) {
  return bound_option(app, name, type, help, [&into](const std::string& s) { into = s; });
}

CLI::Option* number(CLI::App* app, const std::string& name, double& into, const std::string& type,
                    const std::string& help, Default d) {
  return shown(checked_number(bound_option(app, name, type, help, [&into](const std::string& s) { into = std::strtod(s.c_str(), nullptr); })),
               d, show(into));
}

CLI::Option* number(CLI::App* app, const std::string& name, int& into, const std::string& type,
                    const std::string& help, Default d) {
  return shown(checked_number(bound_option(app, name, type, help,
                                   [&into](const std::string& s) { into = static_cast<int>(leading_integer(s)); })),
               d, std::to_string(into));
}

CLI::Option* number(CLI::App* app, const std::string& name, long long& into, const std::string& type,
                    const std::string& help, Default d) {
  return shown(checked_number(bound_option(app, name, type, help, [&into](const std::string& s) { into = leading_integer(s); })),
               d, std::to_string(into));
}

CLI::Option* number(CLI::App* app, const std::string& name, WholeNumber& into, const std::string& type,
                    const std::string& help, Default d) {
  const std::string def = into.text;
  return shown(checked_number(bound_option(app, name, type, help,
                                   [&into](const std::string& s) {
                                     char* end = nullptr;
                                     errno = 0;
                                     into.value = std::strtol(s.c_str(), &end, 10);
                                     into.text = s;
                                     into.whole = end != s.c_str() && *end == '\0' && errno != ERANGE;
                                   })),
               d, def);
}

CLI::Option* number(CLI::App* app, const std::string& name, std::optional<double>& into, const std::string& type,
                    const std::string& help) {
  return checked_number(bound_option(app, name, type, help, [&into](const std::string& s) { into = std::strtod(s.c_str(), nullptr); }));
}

CLI::Option* number(CLI::App* app, const std::string& name, std::optional<long long>& into, const std::string& type,
                    const std::string& help) {
  return checked_number(bound_option(app, name, type, help, [&into](const std::string& s) { into = leading_integer(s); }));
}

CLI::Option* repeated(CLI::App* app, const std::string& name, std::vector<std::string>& into, const std::string& type,
                      const std::string& help) {
  return bound_option(app, name, type, help, [&into](const std::string& s) { into.push_back(s); })
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
}

CLI::Option* flag(CLI::App* app, const std::string& name, bool& into, const std::string& help) {
  return app->add_flag_callback(name, [&into] { into = true; }, help);
}

int Cli::run_chosen() const {
  for (const Command& c : commands_)
    if (c.app->parsed()) return c.run();
  return 2;
}

void scene_options(CLI::App* app, SceneArgs& into, bool required) {
  CLI::Option* s = value(app, "--scene", into.scene, "FILE", "scene file (YAML; config/scenes/)");
  if (required) s->required();
  value(app, "--formulation", into.formulation, "NAME",
        "override the scene's formulation (its formulation: key): mobile_platform, classic, pseudo_joint or svd");
}

void profile_options(CLI::App* app, ProfileArgs& into, const std::string& torque_help, const std::string& steer_help) {
  repeated(app, "--torque", into.torque, "PROFILE", torque_help);
  repeated(app, "--steer", into.steer, "PROFILE", steer_help);
  app->footer(
      "PROFILE: JOINT:constant:VALUE | JOINT:step:VALUE:T0 | JOINT:pulse:VALUE:T0:T1 | JOINT:ramp:VALUE:T0:T1 (0 until T0,\n"
      "linear to VALUE at T1) | FILE.csv (header t,JOINT,...; piecewise constant between rows). JOINT is a velocity\n"
      "coordinate of the scene (coopdyn eval lists them). --steer PROFILE: the position target (rad or m) of a locked\n"
      "joint (a pseudo-joint with a target_limit, e.g. a car's fl_steer), the sum of its terms; 0 where none is on.");
}

std::string show(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", x);
  return b;
}

}  // namespace coopdyn::cli
