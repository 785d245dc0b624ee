// Shared pieces of the coopdyn command line: scene loading, JSON output, torque profiles.
#pragma once

#include <limits>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/system.h"
#include "clients/cli/commands.h"

namespace coopdyn::cli {

// Writes the evaluation at (q, v, tau) as the JSON object documented in README.md.
void write_eval_json(std::FILE* f, const System& sys, const Workspace& ws, const Eigen::VectorXd& q,
                     const Eigen::VectorXd& v, const Eigen::VectorXd& tau);

// s as a JSON string literal: quotes, backslashes and control characters escaped, and "</" written
// as "<\/" so that no name can close an inline <script> (coopdyn view).
std::string json_string(const std::string& s);

// s as one shell word: as it is when it holds only characters the shell leaves alone, else in
// single quotes (for std::system and for printing commands a user can paste).
std::string shell_quote(const std::string& s);

// One warning line on f per rolling contact the evaluation in ws finds sliding or lifting off
// (contacts.h), prefixed with "t=T: " when t is finite; returns how many.
int warn_contacts(std::FILE* f, const char* cmd, const System& sys, const Workspace& ws,
                  double t = std::numeric_limits<double>::quiet_NaN());

// Torque profiles: "JOINT:constant:VALUE", "JOINT:step:VALUE:T0", "JOINT:pulse:VALUE:T0:T1",
// "JOINT:ramp:VALUE:T0:T1" (0 until T0, linear to VALUE at T1, then VALUE), or a CSV file
// "file.csv" whose header is "t,JOINT,..." (piecewise constant between rows). The same profiles give
// lock targets (--steer): the sum of the terms on a joint is its target.
class TorqueProfile {
 public:
  // Throws std::runtime_error with the reason on a bad spec.
  void add(const System& sys, const std::string& spec);
  void eval(double t, Eigen::VectorXd& tau) const;  // tau must be sized nv; set, not accumulated
  std::vector<int> dofs() const;                    // the velocity indices the profile names, ascending
  std::vector<double> breakpoints() const;          // 0 and every time where a term changes
 private:
  struct Term {
    int dof;
    int kind;  // 0 constant, 1 step, 2 pulse, 3 ramp
    double value, t0, t1;
  };
  std::vector<Term> terms_;
  std::vector<int> csv_dofs_;
  std::vector<double> csv_t_;
  std::vector<std::vector<double>> csv_rows_;
};

int velocity_index(const System& sys, const std::string& name);  // -1 if absent

// Loads --scene (with an optional --formulation override) for subcommand `cmd`; prints the reason
// and returns the exit status (2 usage, 1 scene error) on failure, 0 on success.
int load_cli_scene(const SceneArgs& a, const char* cmd, System* sys);
// Adds every --torque PROFILE to *prof; prints the reason and returns 2 on a bad one, else 0.
int load_cli_profile(const ProfileArgs& a, const char* cmd, const System& sys, TorqueProfile* prof);
// Adds every --steer PROFILE (lock targets, rad or m) to *prof and lists their lock specs in *locks
// (parallel to prof->dofs()); each joint must be a pseudo-joint lock with a target_limit and the
// profile within it (checked at the profile's breakpoints); prints the reason and returns 2 if not.
int load_cli_targets(const ProfileArgs& a, const char* cmd, const System& sys, TorqueProfile* prof, std::vector<int>* locks);

// Reads q, v, tau (each optional) from a JSON or YAML state file in the scene's coordinate order;
// prints the problem and returns false on a bad file.
bool read_state(const std::string& path, const System& sys, Eigen::VectorXd& q, Eigen::VectorXd& v, Eigen::VectorXd& tau);

}  // namespace coopdyn::cli
