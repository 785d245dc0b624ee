// RNEA: its gravity term and its power against physics.
#include <gtest/gtest.h>

#include "service/algorithms/kinematics.h"
#include "service/algorithms/rnea.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

TEST(Rnea, GravityTermIsTheGradientOfPotentialEnergy) {
  // h(q, 0) = dV/dq along each velocity direction (finite differences of the potential)
  std::mt19937 rng(12);
  for (const auto& name : all_scenes()) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    const Model& m = sys.model;
    Eigen::VectorXd q, v;
    random_state(sys, rng, 0.5, q, v);
    Data d(m);
    forward_kinematics(m, d, q, Eigen::VectorXd::Zero(m.nv()));
    rnea_bias(m, d);
    const double eps = 1e-6;
    for (int j = 0; j < m.nv(); ++j) {
      Eigen::VectorXd e = Eigen::VectorXd::Zero(m.nv()), qp(m.nq()), qm(m.nq());
      e[j] = 1;
      integrate(m, q, e, eps, qp);
      integrate(m, q, e, -eps, qm);
      const double g = (potential_energy(m, qp) - potential_energy(m, qm)) / (2 * eps);
      EXPECT_NEAR(d.h[j], g, 1e-6 * (1 + std::abs(g))) << m.v_names[j];
    }
  }
}

TEST(Rnea, KineticEnergyRateEqualsPowerOfTheUnconstrainedMotion) {
  // free motion, no gravity, no torque: vdot = -M^-1 h keeps T = v^T M v / 2 constant, so
  // dT/dt computed by finite differences along (q, v) -> (q + eps v, v + eps vdot) is zero
  std::mt19937 rng(13);
  for (const auto& name : all_scenes()) {
    SCOPED_TRACE(name);
    System sys = load(name);
    Model& m = sys.model;
    m.gravity_W.setZero();
    Eigen::VectorXd q, v;
    random_state(sys, rng, 0.5, q, v);
    Data d(m);
    forward_kinematics(m, d, q, v);
    rnea_bias(m, d);
    crba(m, d);
    const Eigen::VectorXd vdot = d.M.ldlt().solve(-d.h);
    auto T = [&](const Eigen::VectorXd& qq, const Eigen::VectorXd& vv) {
      Data dd(m);
      forward_kinematics(m, dd, qq, vv);
      crba(m, dd);
      return 0.5 * vv.dot(dd.M * vv);
    };
    const double eps = 1e-6;
    Eigen::VectorXd qp(m.nq()), qm(m.nq());
    integrate(m, q, v, eps, qp);
    integrate(m, q, v, -eps, qm);
    const double dT = (T(qp, v + eps * vdot) - T(qm, v - eps * vdot)) / (2 * eps);
    EXPECT_NEAR(dT, 0.0, 1e-6 * (1 + T(q, v)));
  }
}
