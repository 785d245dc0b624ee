#include "service/dynamics/integrators.h"

#include <cmath>

#include "service/algorithms/kinematics.h"
#include "service/dynamics/jacobi.h"

namespace coopdyn {

const char* integrator_name(Integrator i) {
  switch (i) {
    case Integrator::kSemiImplicitEuler: return "semi_implicit_euler";
    case Integrator::kRk4: return "rk4";
    case Integrator::kImplicitEuler: return "implicit_euler";
  }
  return "?";
}

bool parse_integrator(const std::string& s, Integrator* i) {
  for (Integrator x : {Integrator::kSemiImplicitEuler, Integrator::kRk4, Integrator::kImplicitEuler})
    if (s == integrator_name(x)) {
      *i = x;
      return true;
    }
  return false;
}

Stepper::Stepper(const System& sys)
    : ws(sys), ws_stage(sys), proj_qs(sys.constraints.rows) {
  ws.position_errors = true;  // the start state's closure is reported (the loop, coopdyn sim); the stages' is not
  for (int k = 0; k < 4; ++k) {
    k_q[k].setZero(sys.model.nq());
    k_v[k].setZero(sys.model.nv());
  }
  q_s.setZero(sys.model.nq());
  v_s.setZero(sys.model.nv());
  const int nv = sys.model.nv();
  Ja.setZero(nv, nv);
  Jb.setZero(nv, nv);
  K.setZero(nv, nv);
  lu = Eigen::PartialPivLU<Eigen::MatrixXd>(nv);
  vdot0.setZero(nv);
  dq.setZero(nv);
  rhs_v.setZero(nv);
  q_start.setZero(sys.model.nq());
  v_start.setZero(sys.model.nv());
  const int m = sys.constraints.rows;
  {  // sized whether or not the scene projects: project_state may be called on any Stepper
    GGt.setZero(m, m);
    eA.setZero(m, m);
    eV.setZero(m, m);
    ew.setZero(m);
    r.setZero(m);
    dv.setZero(sys.model.nv());
    proj_opt = sys.options;
    proj_opt.redundancy = Redundancy::kMinNorm;
  }
}

namespace {
// x <- G^T (G G^T)^+ b (rank-safe): the minimum-norm solution of G x = b, least squares when b is
// not in the range of G
void apply_pinv(const System& sys, Stepper& st, const Eigen::MatrixXd& G, const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  const int m = sys.constraints.rows;
  st.GGt.noalias() = G * G.transpose();
  if (st.projection_solve == Stepper::ProjectionSolve::kCholesky) {
    // the factorization of the constrained solve (q_solve.h): Cholesky when G G^T is well
    // conditioned, else pivoted Cholesky with its null space; (G G^T)^+ b by minimum norm
    st.proj_qs.factor(st.GGt, st.proj_opt, st.r);  // st.r: no compliance (minimum norm ignores it)
    st.proj_qs.solve(b, st.ew);
    x.noalias() = G.transpose() * st.ew;
    return;
  }
  st.eA = st.GGt;
  jacobi_eigen(st.eA, st.ew, st.eV);
  const double emax = m ? std::max(st.ew[m - 1], 0.0) : 0.0;
  st.r.noalias() = st.eV.transpose() * b;
  for (int i = 0; i < m; ++i) st.r[i] = st.ew[i] > sys.options.rank_tol * emax && emax > 0 ? st.r[i] / st.ew[i] : 0.0;
  st.ew.noalias() = st.eV * st.r;  // reuse as (G G^T)^+ b
  x.noalias() = G.transpose() * st.ew;
}
// Coulomb friction: a friction joint that slid at the step's start (|v| > rest_speed) and whose
// velocity changed sign within the step (at its end, or at an RK4 stage, where the friction's sign
// flipped and its stage slope with it) stops, at rest at the step's end; the next evaluation's
// stiction solve decides whether it stays there. A joint at rest at the start has no sign to
// cross (its velocity is zero to round-off, whose sign says nothing): the stiction solve decided
// whether it breaks away, and the step keeps what the stages give.
void stop_reversed_friction_joints(const Stepper& st, Integrator integ, double dt, Eigen::VectorXd& v) {
  for (int d : st.ws.friction_dofs) {
    const double v0 = st.v_start[d];
    if (std::abs(v0) <= st.ws.rest_speed) continue;
    bool crossed = v0 * v[d] < 0.0;
    if (integ == Integrator::kRk4)
      for (int s = 1; s < 4; ++s) crossed = crossed || v0 * (v0 + (s == 3 ? 1.0 : 0.5) * dt * st.k_v[s - 1][d]) < 0.0;
    if (crossed) v[d] = 0.0;
  }
}

}  // namespace

double project_state(const System& sys, Stepper& st, Eigen::VectorXd& q, Eigen::VectorXd& v) {
  const Model& model = sys.model;
  Workspace& ws = st.ws_stage;
  double err = 0.0;
  bool current = false;  // ws.cd holds the rows at the present q (skips a second evaluation after a break)
  for (int it = 0; it < std::max(1, sys.options.projection_iterations); ++it) {
    forward_kinematics(model, ws.data, q, v);
    constraint_rows(model, ws.data, sys.constraints, q, v, ws.cd);
    err = ws.cd.err.size() ? ws.cd.err.cwiseAbs().maxCoeff() : 0.0;
    current = true;
    if (err < 1e-13) break;
    apply_pinv(sys, st, ws.cd.G, ws.cd.err, st.dv);
    integrate(model, q, st.dv, -1.0, q);
    current = false;
  }
  if (!current) {
    forward_kinematics(model, ws.data, q, v);
    constraint_rows(model, ws.data, sys.constraints, q, v, ws.cd);
    err = ws.cd.err.size() ? ws.cd.err.cwiseAbs().maxCoeff() : 0.0;
  }
  apply_pinv(sys, st, ws.cd.G, ws.cd.Gv, st.dv);
  v -= st.dv;
  return err;
}

const Diagnostics& step(const System& sys, Stepper& st, Integrator integ, double dt, const Eigen::VectorXd& tau,
                        Eigen::VectorXd& q, Eigen::VectorXd& v) {
  const Diagnostics& d0 = evaluate(sys, st.ws, q, v, tau);
  if (d0.status == Status::kError) return d0;
  return step_evaluated(sys, st, integ, dt, tau, q, v);
}

const Diagnostics& step_evaluated(const System& sys, Stepper& st, Integrator integ, double dt, const Eigen::VectorXd& tau,
                                  Eigen::VectorXd& q, Eigen::VectorXd& v) {
  const Model& model = sys.model;
  const Diagnostics& d0 = st.ws.diag;
  if (d0.status == Status::kError) return d0;
  st.q_start = q;
  st.v_start = v;
  switch (integ) {
    case Integrator::kSemiImplicitEuler:
      v += dt * st.ws.vdot;
      integrate(model, q, v, dt, q);
      break;
    case Integrator::kRk4: {
      static const double c[4] = {0.0, 0.5, 0.5, 1.0};
      q_derivative(model, q, v, st.k_q[0]);
      st.k_v[0] = st.ws.vdot;
      for (int s = 1; s < 4; ++s) {
        st.q_s = q + (c[s] * dt) * st.k_q[s - 1];
        normalize_configuration(model, st.q_s);
        st.v_s = v + (c[s] * dt) * st.k_v[s - 1];
        const Diagnostics& ds = evaluate(sys, st.ws_stage, st.q_s, st.v_s, tau);
        if (ds.status == Status::kError) return ds;
        q_derivative(model, st.q_s, st.v_s, st.k_q[s]);
        st.k_v[s] = st.ws_stage.vdot;
      }
      q += (dt / 6.0) * (st.k_q[0] + 2.0 * st.k_q[1] + 2.0 * st.k_q[2] + st.k_q[3]);
      v += (dt / 6.0) * (st.k_v[0] + 2.0 * st.k_v[1] + 2.0 * st.k_v[2] + st.k_v[3]);
      normalize_configuration(model, q);
      break;
    }
    case Integrator::kImplicitEuler: {
      const int nv = model.nv();
      st.vdot0 = st.ws.vdot;
      // finite-difference Jacobians of vdot(q, v), q perturbed in the tangent space
      const double scale_q = 1e-7, scale_v = 1e-7 * (1.0 + v.cwiseAbs().maxCoeff());
      for (int i = 0; i < nv; ++i) {
        st.dq.setZero();
        st.dq[i] = 1.0;
        integrate(model, q, st.dq, scale_q, st.q_s);
        const Diagnostics& da = evaluate(sys, st.ws_stage, st.q_s, v, tau);
        if (da.status == Status::kError) return da;
        st.Ja.col(i) = (st.ws_stage.vdot - st.vdot0) / scale_q;
        st.v_s = v;
        st.v_s[i] += scale_v;
        const Diagnostics& db = evaluate(sys, st.ws_stage, q, st.v_s, tau);
        if (db.status == Status::kError) return db;
        st.Jb.col(i) = (st.ws_stage.vdot - st.vdot0) / scale_v;
      }
      st.K.setIdentity();
      st.K -= dt * st.Jb;
      st.K -= (dt * dt) * st.Ja;
      st.rhs_v = st.vdot0;
      st.rhs_v.noalias() += dt * (st.Ja * v);
      st.rhs_v *= dt;
      st.lu.compute(st.K);
      st.dq = st.lu.solve(st.rhs_v);  // dv
      if (!st.dq.allFinite()) {
        st.ws.diag.status = Status::kError;
        st.ws.diag.reason = Reason::kNonFiniteResult;
        return st.ws.diag;
      }
      v += st.dq;
      integrate(model, q, v, dt, q);
      break;
    }
  }
  stop_reversed_friction_joints(st, integ, dt, v);
  if (sys.options.projection_iterations > 0 && sys.constraints.rows > 0) project_state(sys, st, q, v);
  // divergence detector: written as !(|v_i| <= bound) so that NaN trips it too
  int bad = -2;
  if (!q.allFinite()) bad = -1;
  else
    for (int i = 0; i < v.size(); ++i)
      if (!(std::abs(v[i]) <= sys.options.max_speed) || !std::isfinite(v[i])) {
        bad = i;
        break;
      }
  if (bad != -2) {
    st.diverged_speed = bad >= 0 ? std::abs(v[bad]) : 0.0;
    q = st.q_start;
    v = st.v_start;
    st.ws.diag.status = Status::kError;
    st.ws.diag.reason = Reason::kDiverged;
    st.ws.diag.bad_index = bad;
    return st.ws.diag;
  }
  return d0;
}

}  // namespace coopdyn
