#include "service/dynamics/integrators.h"

namespace coopdyn {

const char* integrator_name(Integrator i) {
  switch (i) {
    case Integrator::kSemiImplicitEuler: return "semi_implicit_euler";
    case Integrator::kRk4: return "rk4";
  }
  return "?";
}

bool parse_integrator(const std::string& s, Integrator* i) {
  for (Integrator x : {Integrator::kSemiImplicitEuler, Integrator::kRk4})
    if (s == integrator_name(x)) {
      *i = x;
      return true;
    }
  return false;
}

Stepper::Stepper(const System& sys) : ws(sys), ws_stage(sys) {
  for (int k = 0; k < 4; ++k) {
    k_q[k].setZero(sys.model.nq());
    k_v[k].setZero(sys.model.nv());
  }
  q_s.setZero(sys.model.nq());
  v_s.setZero(sys.model.nv());
}

const Diagnostics& step(const System& sys, Stepper& st, Integrator integ, double dt, const Eigen::VectorXd& tau,
                        Eigen::VectorXd& q, Eigen::VectorXd& v) {
  const Model& model = sys.model;
  const Diagnostics& d0 = evaluate(sys, st.ws, q, v, tau);
  if (d0.status == Status::kError) return d0;
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
  }
  return d0;
}

}  // namespace coopdyn
