// The definition of each wrench's sigma before its fast path: the reference the fast path is
// tested against (same arguments and results as compute_wrench_sigma of wrench_sigma.h).
#pragma once

#include "service/dynamics/wrench_sigma.h"

namespace coopdyn::reference {

void compute_wrench_sigma(const System& sys, Workspace& ws, WrenchSigmaData& sd);
void compute_wrench_sigma(const System& sys, Workspace& ws, WrenchSigmaData& sd, const Eigen::VectorXd& q,
                          const Eigen::VectorXd& v, const Eigen::VectorXd& tau);

}  // namespace coopdyn::reference
