// Integrators and stabilization: convergence order, energy of passive motion, constraint drift.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "service/algorithms/crba.h"
#include "service/dynamics/integrators.h"
#include "tests/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

namespace {
struct SimRun {
  Eigen::VectorXd q, v;
  double max_err = 0;
};
SimRun simulate(const System& sys, Integrator integ, double dt, double T) {
  Stepper st(sys);
  SimRun r{sys.q0, sys.v0};
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
  const long n = std::lround(T / dt);
  for (long i = 0; i < n; ++i) {
    const Diagnostics& d = step(sys, st, integ, dt, tau, r.q, r.v);
    EXPECT_NE(d.status, Status::kError);
    r.max_err = std::max(r.max_err, st.ws.cd.err.cwiseAbs().maxCoeff());
  }
  return r;
}
}  // namespace

TEST(Integrators, Rk4ConvergesAtFourthOrderAndEulerAtFirst) {
  // four-bar released from rest under gravity: errors against a fine RK4 reference
  const System sys = load("four_bar");
  const double T = 0.2;
  const SimRun ref = simulate(sys, Integrator::kRk4, 1e-4 / 4, T);
  const double e1 = (simulate(sys, Integrator::kRk4, 4e-3, T).q - ref.q).norm();
  const double e2 = (simulate(sys, Integrator::kRk4, 2e-3, T).q - ref.q).norm();
  EXPECT_GT(e1 / e2, 12.0);  // 2^4 = 16
  EXPECT_LT(e1 / e2, 20.0);
  const double s1 = (simulate(sys, Integrator::kSemiImplicitEuler, 2e-3, T).q - ref.q).norm();
  const double s2 = (simulate(sys, Integrator::kSemiImplicitEuler, 1e-3, T).q - ref.q).norm();
  EXPECT_GT(s1 / s2, 1.7);  // 2^1
  EXPECT_LT(s1 / s2, 2.4);
}

TEST(Integrators, PassiveMotionConservesEnergy) {
  // zero torque, no damping, no stabilization: kinetic + potential energy constant up to the
  // integrator's error, which shrinks with the step
  for (const std::string name : {"four_bar", "two_puma_load"}) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    const double E0 = energy(sys, sys.q0, sys.v0);
    const SimRun a = simulate(sys, Integrator::kRk4, 1e-3, 0.3);
    const SimRun b = simulate(sys, Integrator::kRk4, 5e-4, 0.3);
    const double da = std::abs(energy(sys, a.q, a.v) - E0), db = std::abs(energy(sys, b.q, b.v) - E0);
    EXPECT_LT(da, 1e-3 * (1 + std::abs(E0)));
    EXPECT_LT(db, da + 1e-12);
  }
}

TEST(Integrators, StabilizationBoundsTheConstraintDrift) {
  // semi-implicit Euler drifts off the loop closure without stabilization; Baumgarte bounds the
  // drift; projection removes it
  const std::string base = [] {
    std::ifstream f(scene_path("four_bar"));
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  }();
  const System none = load_scene_string(base, "fb.yaml");
  const System baum = load_scene_string(base + "stabilization: {baumgarte: {alpha: 200, beta: 10000}}\n", "fb.yaml");
  const System proj = load_scene_string(base + "stabilization: {projection: {iterations: 3}}\n", "fb.yaml");
  const SimRun rn = simulate(none, Integrator::kSemiImplicitEuler, 2e-3, 1.0);
  const SimRun rb = simulate(baum, Integrator::kSemiImplicitEuler, 2e-3, 1.0);
  const SimRun rp = simulate(proj, Integrator::kSemiImplicitEuler, 2e-3, 1.0);
  EXPECT_GT(rn.max_err, 1e-5);
  EXPECT_LT(rb.max_err, 0.2 * rn.max_err);
  Stepper st(proj);
  Eigen::VectorXd q = rp.q, v = rp.v;
  EXPECT_LT(project_state(proj, st, q, v), 1e-10);
  EXPECT_LT(rp.max_err, 0.01 * rn.max_err);
}

TEST(Integrators, ImplicitEulerConvergesAtFirstOrderAndTamesStiffStabilization) {
  const System sys = load("four_bar");
  const double T = 0.2;
  const SimRun ref = simulate(sys, Integrator::kRk4, 1e-4 / 4, T);
  const double e1 = (simulate(sys, Integrator::kImplicitEuler, 2e-3, T).q - ref.q).norm();
  const double e2 = (simulate(sys, Integrator::kImplicitEuler, 1e-3, T).q - ref.q).norm();
  EXPECT_GT(e1 / e2, 1.7);
  EXPECT_LT(e1 / e2, 2.4);
  // Baumgarte gains far too high for a 2 ms step (alpha 1e4 /s, beta 1e8 /s^2): semi-implicit
  // Euler blows up within 10 steps (tests/stiff_extreme_test.cc); the implicit step stays stable
  // and the stiff stabilization then holds the loop closed
  const System stiff = load_scene_string(scene_text("four_bar") + "stabilization: {baumgarte: {alpha: 10000, beta: 100000000}}\n",
                                         "stiff.yaml");
  const SimRun r = simulate(stiff, Integrator::kImplicitEuler, 2e-3, 1.0);
  EXPECT_TRUE(r.q.allFinite() && r.v.allFinite());
  EXPECT_LT(r.max_err, 1e-3);
  std::printf("implicit Euler, Baumgarte 1e4/1e8 at 2 ms, 1 s: max constraint error %.3g\n", r.max_err);
}

TEST(Integrators, EveryIntegratorStopsADivergedStepAndKeepsTheStartState) {
  // The wheel spinning at 200 rad/s under a scene bound of 150 rad/s: whatever the integrator, the
  // first step's end state breaks the bound on the spin DOF, so step() answers kError / kDiverged,
  // names that DOF and leaves q, v bit-for-bit at the start; with the default bound (1e4) the same
  // step is legal and changes the state.
  const std::string t = replace_once(scene_text("unicycle"), "v: [0, 8, 0, 2, 0, 0]", "v: [0, 200, 0, 50, 0, 0]");
  const System tight = load_scene_string(t + "solver: {max_speed: 150}\n", "tight.yaml");
  const System normal = load_scene_string(t, "normal.yaml");
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(tight.model.nv());
  int spin = -1;
  tight.v0.cwiseAbs().maxCoeff(&spin);
  for (Integrator integ : {Integrator::kSemiImplicitEuler, Integrator::kRk4, Integrator::kImplicitEuler}) {
    SCOPED_TRACE(integrator_name(integ));
    Stepper st(tight);
    Eigen::VectorXd q = tight.q0, v = tight.v0;
    const Diagnostics& d = step(tight, st, integ, 1e-3, tau, q, v);
    EXPECT_EQ(d.status, Status::kError);
    EXPECT_EQ(d.reason, Reason::kDiverged);
    EXPECT_EQ(d.bad_index, spin);
    EXPECT_GT(st.diverged_speed, 150.0);
    EXPECT_EQ(q, tight.q0);
    EXPECT_EQ(v, tight.v0);
    Stepper sn(normal);
    Eigen::VectorXd qn = normal.q0, vn = normal.v0;
    EXPECT_NE(step(normal, sn, integ, 1e-3, tau, qn, vn).status, Status::kError);
    EXPECT_GT((qn - normal.q0).norm(), 0.1);  // the wheel turned 0.2 rad
  }
}
