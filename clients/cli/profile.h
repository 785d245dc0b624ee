// Torque profiles and lock targets given on the command line (--torque, --steer).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "clients/cli/commands.h"
#include "service/dynamics/system.h"

namespace coopdyn::cli {

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

// Adds every --torque PROFILE to *prof; prints the reason and returns 2 on a bad one, else 0.
int load_cli_profile(const ProfileArgs& a, const char* cmd, const System& sys, TorqueProfile* prof);
// Adds every --steer PROFILE (lock targets, rad or m) to *prof and lists their lock specs in *locks
// (parallel to prof->dofs()); each joint must be a pseudo-joint lock with a target_limit and the
// profile within it (checked at the profile's breakpoints); prints the reason and returns 2 if not.
int load_cli_targets(const ProfileArgs& a, const char* cmd, const System& sys, TorqueProfile* prof, std::vector<int>* locks);

}  // namespace coopdyn::cli
