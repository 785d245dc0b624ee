// Computes the wrenches a system reports (wrench_outputs.h) from one evaluation: the constraint
// multipliers as they are, the joint reactions from one backward pass (joint_reactions.h) over the
// bodies asked for. Call after evaluate() (or step(), on Stepper::ws) with the same workspace: it
// reads the evaluation's accelerations, multipliers, bias forces and constraint frames (ws.cd.X_RS).
// Allocation-free after construction; never throws.
#pragma once

#include <cstdint>
#include <vector>

#include "service/dynamics/constrained_dynamics.h"

namespace coopdyn {

struct WrenchData {
  explicit WrenchData(const System& sys);
  std::vector<Vec6> W;                  // per output: [moment; force] in its frame
  std::vector<uint8_t> indeterminate;   // per output: bit k, component k is not determined by the
                                        // physics (it moves along a free direction of lambda)
  // per body, world coordinates at data.p_ref
  std::vector<Vec6> f_ext, a, acc, R;   // f_ext: the constraint forces on the bodies of the pass
  std::vector<Vec6> dF_spec;            // per pass spec (WrenchSet::pass_specs): its force for a free
                                        // direction of lambda
  Eigen::VectorXd dlam;                 // (rows) a free direction of lambda
};

// Fills wd.W and wd.indeterminate for the evaluation in ws (zeros when it failed).
void compute_wrenches(const System& sys, const Workspace& ws, WrenchData& wd);

// The pose in the world of output k's report frame (the frame its wrench is taken at and expressed
// in), after forward_kinematics: a tip's constraint frame, a link's frame, a wheel-centre frame.
Transform wrench_frame_pose(const System& sys, const Data& data, int k);

}  // namespace coopdyn
