// What the error-against-run-time report (bench/accuracy.cc, bench/README.md) relies on: against
// an analytic answer (not a reference run), the errors of the state AND of the constraint forces
// shrink at the integrator's order. The rolling disk in steady precession (tests/dynamics/wheel_test.cc,
// RollingDiskSteadyCircleMatchesTheClassicalRelation) is exact in closed form at every time:
// the state turns about the vertical through the turn's centre at Omega, the wheel spins by
// sigma t about its axle, and the contact force is (0, m Omega^2 rho, m g) in the contact frame.
#include <gtest/gtest.h>

#include <cmath>

#include "service/dynamics/integrators.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

namespace {

constexpr double kG = 9.81;

struct Errors {
  double state = 0, force = 0;
};

// max over samples (every 4 ms, 0.5 s) of |state - exact| and |contact force - exact|
Errors precession_errors(Integrator integ, double dt) {
  const System sys = load("unicycle");
  const double r = 0.25, mass = 3.0, phi = 0.3, R = 2.0;
  const double Om = std::sqrt(4 * kG * std::tan(phi) / (6 * R - 5 * r * std::sin(phi)));
  const double sigma = Om * R / r, rho = R - r * std::sin(phi);
  const Mat3 Rot = Eigen::AngleAxisd(-phi, Vec3::UnitX()).toRotationMatrix();  // lean left
  const Vec3 c0 = Rot * Vec3(0, 0, r), w0 = Om * Vec3::UnitZ() + sigma * (Rot * Vec3::UnitY());
  const Vec3 vc0 = w0.cross(c0), P(0, R, 0);
  auto exact = [&](double t, Eigen::VectorXd& q, Eigen::VectorXd& v) {
    const Mat3 Rz = Eigen::AngleAxisd(Om * t, Vec3::UnitZ()).toRotationMatrix();
    const Mat3 R_WB = Rz * Rot * Eigen::AngleAxisd(sigma * t, Vec3::UnitY()).toRotationMatrix();
    q = sys.q0;
    q.segment<3>(0) = P + Rz * (c0 - P);
    const Quat qu(R_WB);
    q.segment<4>(3) << qu.w(), qu.x(), qu.y(), qu.z();
    v.resize(6);
    v.head<3>() = R_WB.transpose() * (Rz * w0);
    v.tail<3>() = R_WB.transpose() * (Rz * vc0);
  };
  const Vec3 f_exact(0, mass * Om * Om * rho, mass * kG);
  Eigen::VectorXd q, v, qe, ve;
  exact(0, q, v);
  Stepper st(sys);
  Workspace ws(sys);
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(6);
  const long per_sample = std::lround(4e-3 / dt);
  Errors e;
  for (int k = 1; k <= 125; ++k) {
    for (long i = 0; i < per_sample; ++i) EXPECT_NE(step(sys, st, integ, dt, tau, q, v).status, Status::kError);
    exact(k * 4e-3, qe, ve);
    if (qe.segment<4>(3).dot(q.segment<4>(3)) < 0) qe.segment<4>(3) *= -1;
    evaluate(sys, ws, q, v, tau);
    e.state = std::max({e.state, (q - qe).cwiseAbs().maxCoeff(), (v - ve).cwiseAbs().maxCoeff()});
    e.force = std::max(e.force, (tip_wrench(sys, ws, 0).tail<3>() - f_exact).cwiseAbs().maxCoeff());
  }
  return e;
}

}  // namespace

TEST(Accuracy, SteadyPrecessionErrorsShrinkAtTheIntegratorsOrder) {
  // RK4: halving the step divides both errors by 2^4 = 16
  const Errors a = precession_errors(Integrator::kRk4, 4e-3), b = precession_errors(Integrator::kRk4, 2e-3);
  EXPECT_GT(a.state / b.state, 13.0);
  EXPECT_LT(a.state / b.state, 19.0);
  EXPECT_GT(a.force / b.force, 13.0);
  EXPECT_LT(a.force / b.force, 19.0);
  // and the answer is the analytic one: at 2 ms the state is within 1e-6 and the force within 1e-5 N
  EXPECT_LT(b.state, 1e-6);
  EXPECT_LT(b.force, 1e-5);
  // semi-implicit and implicit Euler: first order, halving the step halves the errors
  for (Integrator integ : {Integrator::kSemiImplicitEuler, Integrator::kImplicitEuler}) {
    SCOPED_TRACE(integrator_name(integ));
    const Errors c = precession_errors(integ, 2e-3), d = precession_errors(integ, 1e-3);
    EXPECT_GT(c.state / d.state, 1.7);
    EXPECT_LT(c.state / d.state, 2.4);
    EXPECT_GT(c.force / d.force, 1.7);
    EXPECT_LT(c.force / d.force, 2.4);
  }
}
