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

// What a free direction of the multipliers moves, when it moves one kind of row only: the basis is
// grouped by class, in this order (a direction that mixes kinds is kMixed).
enum class FreeClass : uint8_t {
  kWheelNormal = 0,        // the normal forces of rolling contacts (a rigid chassis on > 3 wheels)
  kWheelLateral = 1,       // their lateral forces (wheels on one rigid axle)
  kWheelLongitudinal = 2,  // their longitudinal forces
  kForce = 3,              // force rows of welds and points (an internal force between grasps)
  kMoment = 4,             // moment rows of welds
  kLock = 5,               // pseudo-joint locks and joint couplings (URDF <mimic>)
  kMixed = 6,
};
constexpr int kFreeClasses = 7;
const char* free_class_name(FreeClass c);  // "wheel_normal", ..., "mixed"

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

  // The free directions of lambda (an over-constrained system; 0 when determinate or failed): an
  // orthonormal basis of the null space of Q, grouped by FreeClass (within a class, the subspace
  // of directions that move that kind of row only), each column's largest component positive.
  // Within a class the basis is canonical (free_basis: pivoted on the rows the subspace moves
  // most), so it depends on the subspace only, not on round-off in the SVD that found it.
  int num_free = 0;
  Eigen::MatrixXd free_lambda;          // (rows x rows), first num_free columns
  std::vector<FreeClass> free_class;    // (rows), first num_free entries
  // free_W(6 k + c, d): component c of output k's wrench per unit of free direction d (the change
  // of the reported wrench along it, in the output's frame; any multiple may be added to W)
  Eigen::MatrixXd free_W;               // (6 outputs x rows)
  // workspace of the grouping (allocation-free Jacobi)
  Eigen::MatrixXd fb_N, fb_T, fb_A, fb_V;
  Eigen::VectorXd fb_w, fb_g;
  std::vector<uint8_t> row_class;       // (rows) FreeClass of each row
  std::vector<uint8_t> class_present;   // (kFreeClasses) some row has that class
};

// Fills wd.W and wd.indeterminate for the evaluation in ws (zeros when it failed).
void compute_wrenches(const System& sys, const Workspace& ws, WrenchData& wd);

// The pose in the world of output k's report frame (the frame its wrench is taken at and expressed
// in), after forward_kinematics: a tip's constraint frame, a link's frame, a wheel-centre frame.
Transform wrench_frame_pose(const System& sys, const Data& data, int k);

// The force of constraint spec s for multipliers lambda on the body of its frame A (rolling: the
// wheel), world coordinates at data.p_ref, into F[6]; the spec's frame from the evaluation (cd.X_RS).
// Linear in lambda (the rolling-resistance moment included): also the change of that force along a
// change of lambda.
void spec_force(const ConstraintSet& cs, const ConstraintData& cd, const double* lambda, int s, double* F);

}  // namespace coopdyn
