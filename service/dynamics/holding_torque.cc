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
  for (int i = 0; i < n; ++i) (actuated[i] ? act : unact).push_back(i);
  const int na = static_cast<int>(act.size()), nu = static_cast<int>(unact.size());
  // factorization path
  const ConstraintSet& cs = sys.constraints;
  const int ns = static_cast<int>(cs.specs.size());
  scale.setOnes(n);
  for (int i : act)
    if (std::isfinite(sys.tau_limit[i])) scale[i] = 1.0 / sys.tau_limit[i];
  for (int s = 0; s < ns; ++s) Gb.push_back(Block::Zero(n, 6));
  common.resize(static_cast<size_t>(ns) * ns);
  for (int s = 0; s < ns; ++s)
    for (int t = s; t < ns; ++t)
      std::set_intersection(cs.support[s].begin(), cs.support[s].end(), cs.support[t].begin(), cs.support[t].end(),
                            std::back_inserter(common[static_cast<size_t>(s) * ns + t]));
  for (int s = 0; s < ns; ++s)
    for (int k = 0; k < cs.row_count[s]; ++k) row_spec.push_back(s);
  H.setZero(m, m);
  perm.assign(m, 0);
  Z.setZero(m, nu);
  S.setZero(nu, nu);
  g.setZero(m);
  mu.setZero(m);
  nu_rhs.setZero(nu);
  f.setZero(n);
  hb.setZero(n);
  // reference path: G^T padded to n x max(m, 1) columns: its left singular vectors U span range(G^T)
  // (first rank columns) and the null space of G (the rest), one fixed size whatever the rank
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

namespace {

// Gs Gs^T into hw.H and g = Gs b (b = h scaled), summed per pair of specs over the DOFs both touch
void gram(const System& sys, HoldWorkspace& hw, const Workspace& ws, const Eigen::VectorXd& h) {
  const ConstraintSet& cs = sys.constraints;
  const int ns = static_cast<int>(cs.specs.size());
  const Eigen::MatrixXd& G = ws.cd.G;
  for (int s = 0; s < ns; ++s) {
    HoldWorkspace::Block& B = hw.Gb[s];
    const int r0 = cs.row_offset[s], nk = cs.row_count[s];
    Vec6 acc = Vec6::Zero();
    for (int d : cs.support[s]) {
      const double* gc = G.col(d).data() + r0;
      for (int k = 0; k < nk; ++k) B(d, k) = gc[k] * hw.scale[d];
      acc += (h[d] * hw.scale[d]) * B.row(d).transpose();
    }
    for (int k = 0; k < nk; ++k) hw.g[r0 + k] = acc[k];
  }
  for (int s = 0; s < ns; ++s)
    for (int t = s; t < ns; ++t) {
      const std::vector<int>& dofs = hw.common[static_cast<size_t>(s) * ns + t];
      const int rs = cs.row_offset[s], rt = cs.row_offset[t], ks = cs.row_count[s], kt = cs.row_count[t];
      if (dofs.empty()) {
        hw.H.block(rs, rt, ks, kt).setZero();
        if (s != t) hw.H.block(rt, rs, kt, ks).setZero();
        continue;
      }
      Mat6 acc = Mat6::Zero();
      for (int d : dofs) acc.noalias() += hw.Gb[s].row(d).transpose() * hw.Gb[t].row(d);
      hw.H.block(rs, rt, ks, kt) = acc.topLeftCorner(ks, kt);
      if (s != t) hw.H.block(rt, rs, kt, ks) = acc.topLeftCorner(ks, kt).transpose();
    }
}

// Cholesky of hw.H with diagonal pivoting, in place (column-major, both triangles read): on return
// the kept rows are perm[0..rank) and L (rank x rank, lower) sits in H's rows and columns 0..rank in
// pivot order. False when a pivot lies between kDrop and kKeep times the largest diagonal (the rank
// is not clear-cut: the caller falls back to the SVDs).
bool pivoted_cholesky(HoldWorkspace& hw, int m, int* rank) {
  double* a = hw.H.data();
  auto at = [&](int i, int j) -> double& { return a[static_cast<size_t>(j) * m + i]; };
  for (int i = 0; i < m; ++i) hw.perm[i] = i;
  double dmax = 0.0;
  for (int i = 0; i < m; ++i) dmax = std::max(dmax, at(i, i));
  *rank = 0;
  if (!(dmax > 0.0) || !std::isfinite(dmax)) return m == 0;
  for (int j = 0; j < m; ++j) {
    int p = j;
    for (int i = j + 1; i < m; ++i)
      if (at(i, i) > at(p, p)) p = i;
    const double d = at(p, p);
    if (d <= HoldWorkspace::kDrop * dmax) break;
    if (!(d >= HoldWorkspace::kKeep * dmax)) return false;
    if (p != j) {  // symmetric swap of rows and columns j and p (the whole matrix: L's rows move too)
      for (int i = 0; i < m; ++i) std::swap(at(i, j), at(i, p));
      for (int i = 0; i < m; ++i) std::swap(at(j, i), at(p, i));
      std::swap(hw.perm[j], hw.perm[p]);
    }
    const double l = std::sqrt(d), inv = 1.0 / l;
    at(j, j) = l;
    for (int i = j + 1; i < m; ++i) at(i, j) *= inv;
    for (int c = j + 1; c < m; ++c) {  // trailing update, lower triangle and diagonal
      const double f = at(c, j);
      for (int i = c; i < m; ++i) at(i, c) -= at(i, j) * f;
    }
    for (int c = j + 1; c < m; ++c)  // keep the upper triangle symmetric for the next swaps
      for (int i = j + 1; i < c; ++i) at(i, c) = at(c, i);
    ++*rank;
  }
  return true;
}

// x <- L^-1 x (lower, rank r, in H in pivot order)
void forward(const HoldWorkspace& hw, int r, double* x) {
  const int m = static_cast<int>(hw.H.rows());
  const double* a = hw.H.data();
  for (int j = 0; j < r; ++j) {
    x[j] /= a[static_cast<size_t>(j) * m + j];
    for (int i = j + 1; i < r; ++i) x[i] -= a[static_cast<size_t>(j) * m + i] * x[j];
  }
}

// x <- L^-T x
void backward(const HoldWorkspace& hw, int r, double* x) {
  const int m = static_cast<int>(hw.H.rows());
  const double* a = hw.H.data();
  for (int j = r - 1; j >= 0; --j) {
    double s = x[j];
    for (int i = j + 1; i < r; ++i) s -= a[static_cast<size_t>(j) * m + i] * x[i];
    x[j] = s / a[static_cast<size_t>(j) * m + j];
  }
}

// The factorization path (holding_torque.h); false where it cannot decide (the caller takes the SVDs).
bool hold_factored(const System& sys, HoldWorkspace& hw, const Workspace& ws, const Eigen::VectorXd& h,
                   Eigen::VectorXd& tau) {
  const int m = sys.constraints.rows, nu = static_cast<int>(hw.unact.size());
  const Eigen::MatrixXd& G = ws.cd.G;
  gram(sys, hw, ws, h);
  int r = 0;
  if (!pivoted_cholesky(hw, m, &r)) return false;
  // z = L^-1 g_r and Z = L^-1 G_u,r in pivot order; S = Z^T Z, rhs h_u - Z^T z
  for (int i = 0; i < r; ++i) hw.mu[i] = hw.g[hw.perm[i]];
  forward(hw, r, hw.mu.data());
  for (int u = 0; u < nu; ++u) {
    double* zc = hw.Z.col(u).data();
    for (int i = 0; i < r; ++i) zc[i] = G(hw.perm[i], hw.unact[u]);
    forward(hw, r, zc);
  }
  if (nu > 0) {
    hw.S.noalias() = hw.Z.topRows(r).transpose() * hw.Z.topRows(r);
    double smax = 0.0;
    for (int u = 0; u < nu; ++u) {
      hw.nu_rhs[u] = h[hw.unact[u]] - hw.Z.col(u).head(r).dot(hw.mu.head(r));
      smax = std::max(smax, hw.S(u, u));
    }
    // unpivoted Cholesky of S (lower, in place), every pivot >= kKeep * the largest diagonal
    for (int j = 0; j < nu; ++j) {
      double d = hw.S(j, j);
      for (int k = 0; k < j; ++k) d -= hw.S(j, k) * hw.S(j, k);
      if (!(d >= HoldWorkspace::kKeep * smax) || !(smax > 0.0)) return false;
      const double l = std::sqrt(d);
      hw.S(j, j) = l;
      for (int i = j + 1; i < nu; ++i) {
        double s = hw.S(i, j);
        for (int k = 0; k < j; ++k) s -= hw.S(i, k) * hw.S(j, k);
        hw.S(i, j) = s / l;
      }
    }
    hw.S.topLeftCorner(nu, nu).triangularView<Eigen::Lower>().solveInPlace(hw.nu_rhs);
    hw.S.topLeftCorner(nu, nu).triangularView<Eigen::Lower>().transpose().solveInPlace(hw.nu_rhs);
    hw.mu.head(r).noalias() += hw.Z.topRows(r) * hw.nu_rhs;  // z + Z nu
  }
  backward(hw, r, hw.mu.data());  // -mu_r in pivot order
  // f = h + G^T mu over each spec's support (mu zero on the rows not kept)
  hw.g.setZero();
  for (int i = 0; i < r; ++i) hw.g[hw.perm[i]] = -hw.mu[i];
  hw.f = h;
  const ConstraintSet& cs = sys.constraints;
  for (size_t s = 0; s < cs.specs.size(); ++s) {
    const int r0 = cs.row_offset[s], nk = cs.row_count[s];
    for (int d : cs.support[s]) hw.f[d] += G.col(d).segment(r0, nk).dot(hw.g.segment(r0, nk));
  }
  double res = 0.0;
  for (int u : hw.unact) res += hw.f[u] * hw.f[u];
  hw.residual = std::sqrt(res);
  if (!(hw.residual <= 1e-9 * (1.0 + h.cwiseAbs().maxCoeff()))) return false;
  for (int i : hw.act) tau[i] = hw.f[i];
  return true;
}

bool hold_svd(const System& sys, HoldWorkspace& hw, const Workspace& ws, const Eigen::VectorXd& h,
              Eigen::VectorXd& tau) {
  const int n = sys.model.nv(), m = sys.constraints.rows, na = static_cast<int>(hw.act.size());
  tau.setZero();
  hw.residual = 0;
  hw.factored = false;
  if (na == 0) return true;
  int r = 0;  // rank of G
  if (m > 0) {
    hw.Gt.leftCols(m) = ws.cd.G.transpose();
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
  if (tau.allFinite()) return true;
  tau.setZero();
  return false;
}

// The hold for the bias h: the factorization path, else the SVDs.
bool hold(const System& sys, HoldWorkspace& hw, const Workspace& ws, const Eigen::VectorXd& h, Eigen::VectorXd& tau) {
  tau.setZero();
  hw.residual = 0;
  hw.factored = false;
  if (hw.act.empty()) return true;
  if (hold_factored(sys, hw, ws, h, tau) && tau.allFinite()) {
    hw.factored = true;
    return true;
  }
  return hold_svd(sys, hw, ws, h, tau);
}

}  // namespace

bool holding_torque_svd(const System& sys, HoldWorkspace& hw, const Workspace& ws, Eigen::VectorXd& tau) {
  return hold_svd(sys, hw, ws, ws.data.h, tau);
}

bool holding_torque(const System& sys, HoldWorkspace& hw, const Workspace& ws, Eigen::VectorXd& tau) {
  return hold(sys, hw, ws, ws.data.h, tau);
}

void mass_times(const Model& model, const Data& data, const Eigen::VectorXd& v, Eigen::VectorXd& out) {
  out.setZero();
  for (int k = 0; k < model.nv(); ++k) {
    const double* row = data.Mc.data() + model.dof_row_offset[k];
    const int* path = model.dof_path.data() + model.dof_path_offset[k];
    const int depth = model.dof_depth[k];
    double s = row[depth] * v[k];
    for (int i = 0; i < depth; ++i) {
      s += row[i] * v[path[i]];
      out[path[i]] += row[i] * v[k];
    }
    out[k] += s;
  }
}

bool braking_torque(const System& sys, HoldWorkspace& hw, const Workspace& ws, const Eigen::VectorXd& v,
                    double time_constant, Eigen::VectorXd& tau) {
  if (!(time_constant > 0)) return hold(sys, hw, ws, ws.data.h, tau);
  mass_times(sys.model, ws.data, v, hw.hb);
  hw.hb = ws.data.h - hw.hb / time_constant;
  return hold(sys, hw, ws, hw.hb, tau);
}

bool holding_torque(const System& sys, HoldWorkspace& hw, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                    Eigen::VectorXd& tau) {
  if (!begin_evaluation(sys, hw.ws, q, v)) {
    tau.setZero();
    hw.residual = 0;
    hw.factored = false;
    return false;
  }
  return holding_torque(sys, hw, hw.ws, tau);
}

bool braking_torque(const System& sys, HoldWorkspace& hw, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                    double time_constant, Eigen::VectorXd& tau) {
  if (!begin_evaluation(sys, hw.ws, q, v)) {
    tau.setZero();
    hw.residual = 0;
    hw.factored = false;
    return false;
  }
  return braking_torque(sys, hw, hw.ws, v, time_constant, tau);
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
