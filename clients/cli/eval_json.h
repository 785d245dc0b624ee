// The report of one evaluation (coopdyn eval): the JSON object on stdout, the contact warnings on stderr.
#pragma once

#include <cstdio>
#include <limits>

#include <Eigen/Core>

#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/system.h"

namespace coopdyn::cli {

// Writes the evaluation at (q, v, tau) as the JSON object documented in README.md. ws is the
// evaluation's (non-const: the wrenches' sigma solves through its factors, wrench_sigma.h).
void write_eval_json(std::FILE* f, const System& sys, Workspace& ws, const Eigen::VectorXd& q,
                     const Eigen::VectorXd& v, const Eigen::VectorXd& tau);

// One warning line on f per rolling contact the evaluation in ws finds sliding or lifting off
// (contacts.h), prefixed with "t=T: " when t is finite; returns how many.
int warn_contacts(std::FILE* f, const char* cmd, const System& sys, const Workspace& ws,
                  double t = std::numeric_limits<double>::quiet_NaN());

}  // namespace coopdyn::cli
