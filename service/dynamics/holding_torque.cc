#include "service/dynamics/holding_torque.h"

#include <algorithm>
#include <cmath>

namespace coopdyn {

std::vector<unsigned char> default_actuated(const System& sys) {
  const Model& m = sys.model;
  std::vector<unsigned char> a(m.nv(), 1);
  for (int i = 0; i < m.nv(); ++i) {
    const Joint& j = m.bodies[m.dof_body[i]].joint;
    if (j.type == JointType::kFloating || j.pseudo || !(sys.tau_limit[i] > 0)) a[i] = 0;
  }
  return a;
}

HoldWorkspace::HoldWorkspace(const System& sys, const std::vector<unsigned char>& actuated) : ws(sys) {
  const int n = sys.model.nv(), m = sys.constraints.rows;
  for (int i = 0; i < n; ++i)
    if (actuated[i]) act.push_back(i);
  const int na = static_cast<int>(act.size());
  // G^T padded to n x max(m, 1) columns: its left singular vectors U span range(G^T) (first rank
  // columns) and the null space of G (the rest), one fixed size whatever the rank
  Gt.setZero(n, std::max(m, 1));
  svd_G = Eigen::JacobiSVD<Eigen::MatrixXd>(n, std::max(m, 1), Eigen::ComputeFullU);
  A.setZero(n, std::max(na, 1));
  svd_A = Eigen::JacobiSVD<Eigen::MatrixXd>(n, std::max(na, 1), Eigen::ComputeThinU | Eigen::ComputeThinV);
  b.setZero(n);
  x.setZero(std::max(na, 1));
  w.setOnes(std::max(na, 1));
  for (int c = 0; c < na; ++c)
    if (std::isfinite(sys.tau_limit[act[c]])) w[c] = sys.tau_limit[act[c]];
}

bool holding_torque(const System& sys, HoldWorkspace& hw, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                    Eigen::VectorXd& tau) {
  const int n = sys.model.nv(), m = sys.constraints.rows, na = static_cast<int>(hw.act.size());
  tau.setZero();
  hw.residual = 0;
  if (na == 0) return true;
  const Eigen::VectorXd& zero = tau;
  const Diagnostics& d = evaluate(sys, hw.ws, q, v, zero);  // h and G at (q, v)
  if (d.status == Status::kError && d.reason == Reason::kNonFiniteInput) return false;
  const Eigen::VectorXd& h = hw.ws.data.h;
  int r = 0;  // rank of G
  if (m > 0) {
    hw.Gt.leftCols(m) = hw.ws.cd.G.transpose();
    hw.svd_G.compute(hw.Gt);
    const Eigen::VectorXd& s = hw.svd_G.singularValues();
    for (int i = 0; i < s.size(); ++i)
      if (s[i] > 1e-10 * s[0]) ++r;
  }
  // rows of U^T beyond the rank: N^T. A = N^T S_a^T, b = N^T h (range rows zeroed: same solution)
  const Eigen::MatrixXd& U = hw.svd_G.matrixU();
  for (int i = 0; i < n; ++i) {
    const bool free = m == 0 || i >= r;
    double bi = 0;
    for (int k = 0; k < n; ++k) bi += (m == 0 ? (k == i ? 1.0 : 0.0) : U(k, i)) * h[k];
    hw.b[i] = free ? bi : 0.0;
    for (int c = 0; c < na; ++c)
      hw.A(i, c) = free ? hw.w[c] * (m == 0 ? (hw.act[c] == i ? 1.0 : 0.0) : U(hw.act[c], i)) : 0.0;
  }
  hw.svd_A.compute(hw.A);
  // minimum-norm least squares x = V S^+ U^T b, by hand (JacobiSVD::solve allocates a temporary)
  const Eigen::VectorXd& sa = hw.svd_A.singularValues();
  hw.x.setZero();
  for (int k = 0; k < sa.size(); ++k) {
    if (!(sa[k] > 1e-10 * sa[0])) break;
    const double c = hw.svd_A.matrixU().col(k).dot(hw.b) / sa[k];
    hw.x.noalias() += c * hw.svd_A.matrixV().col(k);
  }
  for (int c = 0; c < na; ++c) tau[hw.act[c]] = hw.w[c] * hw.x[c];
  hw.b.noalias() -= hw.A * hw.x;
  hw.residual = hw.b.norm();
  return tau.allFinite();
}

int clamp_to_torque_limits(const System& sys, const HoldWorkspace& hw, Eigen::VectorXd& tau) {
  int clamped = 0;
  for (int i : hw.act) {
    const double lim = sys.tau_limit[i];
    if (std::abs(tau[i]) <= lim) continue;
    tau[i] = std::max(-lim, std::min(lim, tau[i]));
    ++clamped;
  }
  return clamped;
}

}  // namespace coopdyn
