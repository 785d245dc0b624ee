// Joint limits exceeded at a state and torque: per DOF, which of its limits (System::q_lower,
// q_upper, v_limit, tau_limit) the state (q, v) and the applied torque tau pass. Reported, never
// enforced: the dynamics go on; the caller (coopdynd's loop, coopdyn sim and eval) says so.
//   kPosition  q < q_lower or q > q_upper (rad or m), a 1-DOF joint's coordinate
//   kVelocity  |v| > v_limit (rad/s or m/s)
//   kEffort    |tau| > tau_limit (N*m or N) on an actuated DOF (tau_limit > 0: an unactuated DOF's
//              torque is the constraint's business, not a limit)
// A value exactly at its limit is within it; a NaN passes every limit (the evaluation reports it).
// A System without limit vectors (sizes 0, a system built by hand) has none.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "service/dynamics/system.h"

namespace coopdyn {

enum LimitBit : uint8_t { kLimitPosition = 1, kLimitVelocity = 2, kLimitEffort = 4 };

struct LimitData {
  explicit LimitData(const System& sys);  // sizes everything; the only allocation
  std::vector<int> dofs;      // the DOFs with any finite limit, ascending
  std::vector<int> q_index;   // (dofs) each one's coordinate in q (-1: no position limit)
  std::vector<uint8_t> mask;  // (nv) LimitBit bits of the last check, 0 on DOFs without limits
  int exceeded = 0;           // DOFs with any bit set
  uint8_t any = 0;            // the union of every DOF's bits
};

// Fills d.mask, d.exceeded and d.any at (q (nq), v (nv), tau (nv)); returns d.exceeded.
// Allocation-free, O(DOFs with limits).
int check_joint_limits(const System& sys, LimitData& d, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                       const Eigen::VectorXd& tau);

// "position", "velocity" or "effort": the word of one bit (eval JSON, messages)
const char* limit_word(LimitBit b);

}  // namespace coopdyn
