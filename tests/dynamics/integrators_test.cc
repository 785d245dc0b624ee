// Integrators and stabilization: convergence order, energy of passive motion, constraint drift.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <sstream>

#include "service/algorithms/crba.h"
#include "service/algorithms/kinematics.h"
#include "service/dynamics/integrators.h"
#include "tests/support/test_util.h"

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
  // Euler blows up within 10 steps (tests/system/stiff_extreme_test.cc); the implicit step stays stable
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

namespace {
// max |position error| and max |G v| of the scene's constraints at (q, v)
std::pair<double, double> constraint_residuals(const System& sys, Workspace& ws, const Eigen::VectorXd& q,
                                               const Eigen::VectorXd& v) {
  forward_kinematics(sys.model, ws.data, q, v);
  constraint_rows(sys.model, ws.data, sys.constraints, q, v, ws.cd);
  return {ws.cd.err.cwiseAbs().maxCoeff(), (ws.cd.G * v).cwiseAbs().maxCoeff()};
}
}  // namespace

TEST(Integrators, ProjectionByCholeskyEqualsTheEigenDecompositionAndRemovesTheResidual) {
  // the rank-revealing Cholesky of the solve (fast path or pivoted, minimum norm) gives the same
  // projected state as the former Jacobi eigen-decomposition of G G^T, on a rolling car whose 12
  // contact rows are rank deficient, the vehicle, and a closed chain (the four-bar)
  const std::string proj = "stabilization: {projection: {iterations: 3}}\n";
  const std::string four_bar = [] {
    std::ifstream f(scene_path("four_bar"));
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  }();
  struct Case {
    std::string name;
    System sys;
  };
  std::vector<Case> cases;
  cases.push_back({"car", load_scene_string(rigid_car_scene() + proj, "car.yaml")});
  cases.push_back({"two_wheel_vehicle", load("two_wheel_vehicle")});
  cases.push_back({"four_bar", load_scene_string(four_bar + proj, "fb.yaml")});
  int rank_path = 0;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const System& sys = c.sys;
    ASSERT_GT(sys.options.projection_iterations, 0);
    Stepper chol(sys), eig(sys);
    eig.projection_solve = Stepper::ProjectionSolve::kEigen;
    Workspace ws(sys);
    std::mt19937 rng(12);
    for (int k = 0; k < 20; ++k) {
      Eigen::VectorXd q0, v0;
      random_state(sys, rng, k % 2 ? 0.01 : 1e-4, q0, v0);
      const auto before = constraint_residuals(sys, ws, q0, v0);
      Eigen::VectorXd qc = q0, vc = v0, qe = q0, ve = v0;
      const double ec = project_state(sys, chol, qc, vc);
      const double ee = project_state(sys, eig, qe, ve);
      rank_path += chol.proj_qs.fast_path ? 0 : 1;
      EXPECT_LT((qc - qe).cwiseAbs().maxCoeff(), 1e-12) << k;
      EXPECT_LT((vc - ve).cwiseAbs().maxCoeff(), 1e-12 * (1 + v0.cwiseAbs().maxCoeff())) << k;
      EXPECT_NEAR(ec, ee, 1e-12) << k;
      const auto after = constraint_residuals(sys, ws, qc, vc);
      if (before.first > 1e-12) {
        EXPECT_LT(after.first, 1e-3 * before.first) << k;
      }
      EXPECT_LT(after.first, 1e-10) << k;
      EXPECT_LT(after.second, 1e-10 * (1 + v0.cwiseAbs().maxCoeff())) << k << ": G v left " << after.second;
      EXPECT_GT(before.second, 1e3 * after.second) << k;
    }
  }
  EXPECT_GT(rank_path, 0) << "the rank-deficient (pivoted) path was never taken";
}

TEST(Integrators, TheStartStateReportsItsPositionErrorsAndNothingElseDependsOnThem) {
  // The closure the loop and coopdyn sim report is read from Stepper::ws after step(): its
  // position errors are those of constraint_rows at the start state, bit for bit, with every
  // integrator. An evaluation in a workspace that does not ask for them (Workspace::position_errors
  // false: the stages, a plain evaluate()) gives the same accelerations, forces, stresses and
  // diagnostics to the bit, its errors NaN (nobody can read a stale value) unless Baumgarte
  // stabilization reads them.
  std::mt19937 rng(11);
  const std::vector<System> systems = {load("two_puma_load"), load("four_bar", Formulation::kClassic),
                                       load("two_iiwa_load", Formulation::kPseudoJointSchur), load("four_wheel_car"),
                                       load("pr2_box")};
  for (const System& sys : systems) {
    SCOPED_TRACE(sys.name);
    const Model& m = sys.model;
    for (Integrator integ : {Integrator::kSemiImplicitEuler, Integrator::kRk4, Integrator::kImplicitEuler}) {
      Eigen::VectorXd q0, v0;
      random_state(sys, rng, 0.05, q0, v0);
      v0 *= 0.1;
      const Eigen::VectorXd tau = Eigen::VectorXd::Constant(m.nv(), 0.5);
      Stepper st(sys);
      Eigen::VectorXd q = q0, v = v0;
      ASSERT_NE(step(sys, st, integ, 1e-3, tau, q, v).status, Status::kError);
      Data d(m);
      ConstraintData cd(m, sys.constraints);
      forward_kinematics(m, d, q0, v0);
      constraint_rows(m, d, sys.constraints, q0, v0, cd);
      ASSERT_TRUE(cd.err.allFinite());
      EXPECT_EQ(std::memcmp(cd.err.data(), st.ws.cd.err.data(), sizeof(double) * cd.err.size()), 0);
      EXPECT_GT(cd.err.cwiseAbs().maxCoeff(), 1e-4);  // off the constraints: errors to report

      Workspace plain(sys), asked(sys);
      asked.position_errors = true;
      const Diagnostics dp = evaluate(sys, plain, q0, v0, tau);
      const Diagnostics da = evaluate(sys, asked, q0, v0, tau);
      EXPECT_EQ(dp.status, da.status);
      EXPECT_EQ(dp.rank, da.rank);
      EXPECT_EQ(std::memcmp(&dp.condition, &da.condition, sizeof(double)), 0);
      EXPECT_EQ(std::memcmp(&dp.residual, &da.residual, sizeof(double)), 0);
      EXPECT_EQ(plain.vdot, asked.vdot);
      EXPECT_EQ(plain.lambda, asked.lambda);
      EXPECT_EQ(plain.stress, asked.stress);
      EXPECT_EQ(std::memcmp(cd.err.data(), asked.cd.err.data(), sizeof(double) * cd.err.size()), 0);
      if (sys.constraints.stabilize) {
        EXPECT_EQ(std::memcmp(cd.err.data(), plain.cd.err.data(), sizeof(double) * cd.err.size()), 0);
      } else {
        EXPECT_TRUE(plain.cd.err.array().isNaN().all());
      }
    }
  }
}
