#include "service/dynamics/state_fit.h"

#include <algorithm>
#include <cmath>

#include <Eigen/SVD>

#include "service/algorithms/kinematics.h"
#include "service/dynamics/jacobi.h"

namespace coopdyn {

namespace {
int column_rank(const Eigen::MatrixXd& A) {
  if (A.cols() == 0) return 0;
  if (A.rows() == 0) return 0;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A);
  const Eigen::VectorXd& s = svd.singularValues();
  const double tol = 1e-9 * std::max(1.0, s.size() ? s[0] : 0.0);
  int r = 0;
  for (Eigen::Index i = 0; i < s.size(); ++i) r += s[i] > tol ? 1 : 0;
  return r;
}
}  // namespace

StateFitPlan plan_state_fit(const System& sys) {
  const Model& m = sys.model;
  const ConstraintSet& set = sys.constraints;
  StateFitPlan p;
  for (const Body& b : m.bodies) {
    const Joint& j = b.joint;
    if (j.type == JointType::kFloating) {
      for (int k = 0; k < j.nq; ++k) p.fit_q.push_back(j.idx_q + k);
      for (int k = 0; k < j.nv; ++k) p.fit_v.push_back(j.idx_v + k);
    } else if (j.pseudo) {
      for (int k = 0; k < j.nq; ++k) p.pseudo_q.push_back(j.idx_q + k);
      for (int k = 0; k < j.nv; ++k) p.pseudo_v.push_back(j.idx_v + k);
    }
  }
  p.holonomic.assign(set.rows, 0);
  p.angular.assign(set.rows, 0);
  for (size_t s = 0; s < set.specs.size(); ++s) {
    const ConstraintSpec& c = set.specs[s];
    for (int k = 0; k < set.row_count[s]; ++k) {
      const int r = set.row_offset[s] + k, ax = set.row_axis[s][k];
      switch (c.kind) {
        case ConstraintKind::kWeld:
          p.holonomic[r] = 1;
          p.angular[r] = ax < 3 ? 1 : 0;
          break;
        case ConstraintKind::kLock:
        case ConstraintKind::kCouple:
          p.holonomic[r] = 1;
          p.angular[r] = m.bodies[m.dof_body[c.dof]].joint.type == JointType::kPrismatic ? 0 : 1;
          break;
        case ConstraintKind::kRolling:
          p.holonomic[r] = ax == 5 ? 1 : 0;  // the contact height; x, y are the no-slip rows
          p.angular[r] = 0;
          break;
      }
    }
  }
  const int nu = static_cast<int>(p.fit_v.size());
  if (nu == 0) {
    p.why_not_q = p.why_not_v = "the scene has no floating body";
    return p;
  }
  // the rank of G over the fitted columns, at the initial state
  Data data(m);
  ConstraintData cd(m, set);
  forward_kinematics(m, data, sys.q0, sys.v0);
  constraint_rows(m, data, set, sys.q0, sys.v0, cd);
  int n_hol = 0;
  for (unsigned char h : p.holonomic) n_hol += h;
  Eigen::MatrixXd Gh(n_hol, nu), Ga(set.rows, nu);
  for (int r = 0, h = 0; r < set.rows; ++r) {
    for (int k = 0; k < nu; ++k) Ga(r, k) = cd.G(r, p.fit_v[k]);
    if (p.holonomic[r]) Gh.row(h++) = Ga.row(r);
  }
  p.q_fittable = column_rank(Gh) == nu;
  if (!p.q_fittable) p.why_not_q = "the constraints do not fix the floating bodies' pose (give it: a vehicle's chassis pose comes from its own estimator)";
  p.v_fittable = column_rank(Ga) == nu;
  if (!p.v_fittable) p.why_not_v = "the constraints do not fix the floating bodies' velocity";
  for (int d : p.fit_v)
    if (sys.tau_limit[d] > 0) {
      p.v_fittable = false;
      p.why_not_v = "the scene declares the floating bodies actuated (their tau must be given with their velocity)";
    }
  return p;
}

StateFitWorkspace::StateFitWorkspace(const System& sys, const StateFitPlan& plan)
    // llt constructed in place: Eigen's LLT(size) leaves its info unset, and a copy or move reads it
    : data(sys.model), cd(sys.model, sys.constraints), llt(static_cast<Eigen::Index>(plan.fit_v.size())) {
  const int nu = static_cast<int>(plan.fit_v.size()), rows = sys.constraints.rows;
  for (unsigned char h : plan.holonomic) n_hol += h;
  q_start = sys.q0;
  Gu.setZero(rows, nu);
  r.setZero(rows);
  N.setZero(nu, nu);
  llt.compute(Eigen::MatrixXd::Identity(nu, nu));  // sets its info: a copy of the workspace reads it
  V.setZero(nu, nu);
  w.setZero(nu);
  b.setZero(nu);
  x.setZero(nu);
  dv.setZero(sys.model.nv());
  q_try = sys.q0;
  Pq.setZero(nu, rows);
  Pv.setZero(nu, rows);
}

void closure_residual(const ConstraintSet& set, const StateFitPlan& plan, const ConstraintData& cd, Closure* out) {
  for (int k = 0; k < 4; ++k) {
    out->value[k] = 0.0;
    out->spec[k] = -1;
  }
  for (int r = 0; r < set.rows; ++r) {
    const int kp = plan.angular[r] ? kClosureOrientation : kClosurePosition;
    const int kv = plan.angular[r] ? kClosureAngularVelocity : kClosureLinearVelocity;
    const double e = std::abs(cd.err[r]), gv = std::abs(cd.Gv[r]);
    // NaN compares false: a non-finite residual is kept as NaN so that no tolerance passes it
    if (plan.holonomic[r] && (e > out->value[kp] || std::isnan(e))) {
      out->value[kp] = e;
      out->spec[kp] = set.row_spec[r];
    }
    if (gv > out->value[kv] || std::isnan(gv)) {
      out->value[kv] = gv;
      out->spec[kv] = set.row_spec[r];
    }
  }
}

namespace {
// x = (A^T A)^+ A^T b for A = ws.Gu's first `rows` rows, b = ws.r's first rows (rank-safe)
void least_squares(StateFitWorkspace& ws, int rows) {
  const int nu = static_cast<int>(ws.N.rows());
  const auto A = ws.Gu.topRows(rows);
  ws.N.noalias() = A.transpose() * A;
  ws.b.noalias() = A.transpose() * ws.r.head(rows);
  // the fast path: a Cholesky of the normal matrix when it is well conditioned (its pivots within
  // 1e-10 of each other: the fitted coordinates are well determined); else the rank-safe
  // pseudo-inverse from a Jacobi eigen-decomposition
  ws.llt.compute(ws.N);
  if (ws.llt.info() == Eigen::Success) {
    const auto d = ws.llt.matrixLLT().diagonal();
    const double dmin = d.minCoeff(), dmax = d.maxCoeff();
    if (dmin > 0 && dmin * dmin > 1e-10 * dmax * dmax) {
      ws.x = ws.b;
      ws.llt.solveInPlace(ws.x);
      return;
    }
  }
  ws.N.noalias() = A.transpose() * A;
  jacobi_eigen(ws.N, ws.w, ws.V);
  const double wmax = nu ? std::max(ws.w[nu - 1], 0.0) : 0.0;
  ws.x.noalias() = ws.V.transpose() * ws.b;
  for (int i = 0; i < nu; ++i) ws.x[i] = wmax > 0 && ws.w[i] > 1e-12 * wmax ? ws.x[i] / ws.w[i] : 0.0;
  ws.b.noalias() = ws.V * ws.x;
  ws.x = ws.b;
}

// fills ws.Gu (holonomic rows first) and ws.r (their errors) from ws.cd; returns max |e| over them
double holonomic_system(const StateFitPlan& plan, StateFitWorkspace& ws) {
  const int rows = static_cast<int>(plan.holonomic.size()), nu = static_cast<int>(plan.fit_v.size());
  double emax = 0.0;
  for (int r = 0, h = 0; r < rows; ++r) {
    if (!plan.holonomic[r]) continue;
    for (int k = 0; k < nu; ++k) ws.Gu(h, k) = ws.cd.G(r, plan.fit_v[k]);
    ws.r[h] = ws.cd.err[r];
    emax = std::max(emax, std::abs(ws.cd.err[r]));
    ++h;
  }
  return emax;
}

double error_norm2(const StateFitPlan& plan, const ConstraintData& cd) {
  double s = 0.0;
  for (size_t r = 0; r < plan.holonomic.size(); ++r)
    if (plan.holonomic[r]) s += cd.err[r] * cd.err[r];
  return s;
}
}  // namespace

void fit_position_step(const System& sys, const StateFitPlan& plan, StateFitWorkspace& ws, const Eigen::VectorXd& q,
                       const Eigen::VectorXd& v, Eigen::VectorXd* dx) {
  forward_kinematics(sys.model, ws.data, q, v);
  constraint_rows(sys.model, ws.data, sys.constraints, q, v, ws.cd);
  holonomic_system(plan, ws);
  least_squares(ws, ws.n_hol);
  *dx = -ws.x;
}

namespace {

// The fitted velocities: with ws.r (rows) the constraint rows' velocity of the measured ones (the
// fitted ones zero in v), the least squares over the fitted columns of G, written into v.
void solve_fitted_velocities(const StateFitPlan& plan, StateFitWorkspace& ws, const Eigen::MatrixXd& G, int rows,
                             Eigen::VectorXd& v) {
  const int nu = static_cast<int>(plan.fit_v.size());
  for (int r = 0; r < rows; ++r)
    for (int k = 0; k < nu; ++k) ws.Gu(r, k) = G(r, plan.fit_v[k]);
  least_squares(ws, rows);
  for (int k = 0; k < nu; ++k) v[plan.fit_v[k]] = -ws.x[k];
}

// P's first `rows` columns = (A^T A)^+ A^T for A = ws.Gu's first rows: least_squares' factorization
// (Cholesky when well conditioned, else the Jacobi pseudo-inverse), every right-hand side at once
void pseudo_inverse(StateFitWorkspace& ws, int rows, Eigen::MatrixXd& P) {
  const int nu = static_cast<int>(ws.N.rows());
  const auto A = ws.Gu.topRows(rows);
  auto X = P.leftCols(rows);
  ws.N.noalias() = A.transpose() * A;
  X = A.transpose();
  ws.llt.compute(ws.N);
  if (ws.llt.info() == Eigen::Success) {
    const auto d = ws.llt.matrixLLT().diagonal();
    const double dmin = d.minCoeff(), dmax = d.maxCoeff();
    if (dmin > 0 && dmin * dmin > 1e-10 * dmax * dmax) {
      ws.llt.solveInPlace(X);
      return;
    }
  }
  ws.N.noalias() = A.transpose() * A;
  jacobi_eigen(ws.N, ws.w, ws.V);
  const double wmax = nu ? std::max(ws.w[nu - 1], 0.0) : 0.0;
  for (int i = 0; i < nu; ++i) ws.b[i] = wmax > 0 && ws.w[i] > 1e-12 * wmax ? 1.0 / ws.w[i] : 0.0;
  for (int i = 0; i < nu; ++i)  // N = V diag(b) V^T, the pseudo-inverse of A^T A
    for (int j = 0; j < nu; ++j) {
      double s = 0.0;
      for (int k = 0; k < nu; ++k) s += ws.V(i, k) * ws.b[k] * ws.V(j, k);
      ws.N(i, j) = s;
    }
  X.noalias() = ws.N * A.transpose();
}

}  // namespace

void fit_operators(const StateFitPlan& plan, StateFitWorkspace& ws, const Eigen::MatrixXd& G, bool positions,
                   bool velocities) {
  const int nu = static_cast<int>(plan.fit_v.size()), rows = static_cast<int>(G.rows());
  if (nu == 0) return;
  if (positions) {
    for (int r = 0, h = 0; r < rows; ++r)
      if (plan.holonomic[r]) {
        for (int k = 0; k < nu; ++k) ws.Gu(h, k) = G(r, plan.fit_v[k]);
        ++h;
      }
    pseudo_inverse(ws, ws.n_hol, ws.Pq);
    // the holonomic rows' columns to their row indices (descending: a column is read before it
    // is overwritten, its index h <= r)
    for (int r = rows - 1, h = ws.n_hol - 1; r >= 0; --r) {
      if (plan.holonomic[r]) ws.Pq.col(r) = ws.Pq.col(h--);
      else ws.Pq.col(r).setZero();
    }
  }
  if (velocities) {
    for (int r = 0; r < rows; ++r)
      for (int k = 0; k < nu; ++k) ws.Gu(r, k) = G(r, plan.fit_v[k]);
    pseudo_inverse(ws, rows, ws.Pv);
  }
}

const Closure& fit_state(const System& sys, const StateFitPlan& plan, StateFitWorkspace& ws, bool fit_q, bool fit_v,
                         Eigen::VectorXd& q, Eigen::VectorXd& v) {
  const Model& m = sys.model;
  const ConstraintSet& set = sys.constraints;
  const int nu = static_cast<int>(plan.fit_v.size());
  ws.closure.iterations = 0;
  if (fit_q && nu > 0) {
    // start from the last fit (a measured trajectory moves little per tick), else q0
    for (int i : plan.fit_q) q[i] = ws.q_start[i];
    forward_kinematics(m, ws.data, q, v);
    constraint_rows(m, ws.data, set, q, v, ws.cd);
    double e2 = error_norm2(plan, ws.cd);
    constexpr int kMaxIterations = 50;
    for (int it = 0; it < kMaxIterations && e2 > 0.0; ++it) {
      // closed to round-off (1e-14 rad or m): nothing a step could improve
      if (holonomic_system(plan, ws) < 1e-14) break;
      least_squares(ws, ws.n_hol);
      // converged: the step is below 1e-13 (rad, m), round-off for a metre-size system (or a NaN
      // step: stop, the residual says so)
      if (!(ws.x.cwiseAbs().maxCoeff() > 1e-13)) break;
      ws.dv.setZero();
      bool improved = false;
      for (double step = 1.0; step > 1e-2; step *= 0.5) {
        for (int k = 0; k < nu; ++k) ws.dv[plan.fit_v[k]] = -step * ws.x[k];
        integrate(m, q, ws.dv, 1.0, ws.q_try);
        normalize_configuration(m, ws.q_try);
        forward_kinematics(m, ws.data, ws.q_try, v);
        constraint_rows(m, ws.data, set, ws.q_try, v, ws.cd);
        const double e2_try = error_norm2(plan, ws.cd);
        if (e2_try < e2) {
          e2 = e2_try;
          for (int i : plan.fit_q) q[i] = ws.q_try[i];
          improved = true;
          break;
        }
      }
      ++ws.closure.iterations;
      if (!improved) break;  // at the least-squares minimum to round-off
    }
    if (std::isfinite(e2)) {
      for (int i : plan.fit_q) ws.q_start[i] = q[i];
    } else {
      for (int i : plan.fit_q) ws.q_start[i] = sys.q0[i];
    }
  }
  if (fit_v && nu > 0) {
    for (int d : plan.fit_v) v[d] = 0.0;
    forward_kinematics(m, ws.data, q, v);
    constraint_rows(m, ws.data, set, q, v, ws.cd);  // cd.Gv = G_m v_m
    ws.r.head(set.rows) = ws.cd.Gv.head(set.rows);
    solve_fitted_velocities(plan, ws, ws.cd.G, set.rows, v);
  }
  forward_kinematics(m, ws.data, q, v);
  constraint_rows(m, ws.data, set, q, v, ws.cd);
  closure_residual(set, plan, ws.cd, &ws.closure);
  return ws.closure;
}

}  // namespace coopdyn
