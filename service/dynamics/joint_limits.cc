#include "service/dynamics/joint_limits.h"

#include <cmath>
#include <limits>

namespace coopdyn {

namespace {
double at(const Eigen::VectorXd& x, int i, double none) { return x.size() > i ? x[i] : none; }
}  // namespace

LimitData::LimitData(const System& sys) : mask(static_cast<size_t>(sys.model.nv()), 0) {
  const double inf = std::numeric_limits<double>::infinity();
  for (int d = 0; d < sys.model.nv(); ++d) {
    const bool pos = std::isfinite(at(sys.q_lower, d, -inf)) || std::isfinite(at(sys.q_upper, d, inf));
    const double tl = at(sys.tau_limit, d, inf);
    const bool vel = std::isfinite(at(sys.v_limit, d, inf)), eff = std::isfinite(tl) && tl > 0;
    if (!pos && !vel && !eff) continue;
    dofs.push_back(d);
    const Joint& j = sys.model.bodies[static_cast<size_t>(sys.model.dof_body[static_cast<size_t>(d)])].joint;
    q_index.push_back(pos && j.nq == 1 ? j.idx_q : -1);
  }
}

int check_joint_limits(const System& sys, LimitData& d, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                       const Eigen::VectorXd& tau) {
  const double inf = std::numeric_limits<double>::infinity();
  d.exceeded = 0;
  d.any = 0;
  for (size_t k = 0; k < d.dofs.size(); ++k) {
    const int i = d.dofs[k], qi = d.q_index[k];
    uint8_t b = 0;
    if (qi >= 0 && (q[qi] < at(sys.q_lower, i, -inf) || q[qi] > at(sys.q_upper, i, inf))) b |= kLimitPosition;
    if (std::abs(v[i]) > at(sys.v_limit, i, inf)) b |= kLimitVelocity;
    const double tl = at(sys.tau_limit, i, inf);
    if (tl > 0 && std::abs(tau[i]) > tl) b |= kLimitEffort;
    d.mask[static_cast<size_t>(i)] = b;
    d.any |= b;
    if (b) ++d.exceeded;
  }
  return d.exceeded;
}

const char* limit_word(LimitBit b) {
  switch (b) {
    case kLimitPosition: return "position";
    case kLimitVelocity: return "velocity";
    case kLimitEffort: return "effort";
  }
  return "?";
}

}  // namespace coopdyn
