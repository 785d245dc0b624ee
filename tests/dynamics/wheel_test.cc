// Wheels (the paper's (27)-(54)): the rolling constraint's rows against finite differences, its
// contact frame, statics of the two-wheeled vehicle (34.335 N per wheel), passive straight rolling,
// the steady turn (lateral forces = m v^2 / R, external wrenches = momentum rate), the rolling disk
// in steady circular motion against the classical thin-disk relation, and the rigid-axle
// redundancy.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "service/algorithms/crba.h"
#include "service/algorithms/rnea.h"
#include "service/dynamics/integrators.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

namespace {

constexpr double kG = 9.81;

int spec_index(const System& sys, const std::string& name) {
  for (size_t s = 0; s < sys.constraints.specs.size(); ++s)
    if (sys.constraints.specs[s].name == name) return static_cast<int>(s);
  ADD_FAILURE() << "no constraint " << name;
  return 0;
}

// force of the ground on the wheel at the contact point, in the contact frame
Vec3 contact_force(const System& sys, const Workspace& ws, const std::string& name, unsigned* mask = nullptr) {
  const Vec6 w = tip_wrench(sys, ws, spec_index(sys, name), mask);
  EXPECT_EQ(w.head<3>().norm(), 0.0);  // point contact: no moment
  return w.tail<3>();
}

double total_mass(const Model& m) {
  double M = 0;
  for (const Body& b : m.bodies) M += b.inertia.m;
  return M;
}



// contact forces and gravity as one wrench about the world origin, world coordinates
Vec6 external_wrench(const System& sys, const Workspace& ws) {
  const Model& m = sys.model;
  Vec6 F = Vec6::Zero();
  for (size_t s = 0; s < sys.constraints.specs.size(); ++s) {
    const ConstraintSpec& c = sys.constraints.specs[s];
    if (c.kind != ConstraintKind::kRolling) continue;
    F += rolling_contact_frame(m, ws.data, c).act_force(tip_wrench(sys, ws, static_cast<int>(s)));
  }
  for (int i = 0; i < m.nbodies(); ++i) {
    const Inertia& I = m.bodies[i].inertia;
    Vec6 Fg;
    Fg << Vec3::Zero(), I.m * m.gravity_W;
    F += Transform(Mat3::Identity(), ws.data.X_WB[i].R * I.c + ws.data.X_WB[i].p).act_force(Fg);
  }
  return F;
}

// The vehicle in a steady left turn: axle midpoint on a circle of radius R about (0, R, 0) at
// speed V (heading +x at t = 0), wheels rolling, rod not pitching.
void vehicle_turn_state(const System& sys, double V, double R, Eigen::VectorXd& q, Eigen::VectorXd& v) {
  const Model& m = sys.model;
  q = sys.q0;
  v = Eigen::VectorXd::Zero(m.nv());
  const double Om = V / R, w = 0.25, r = 0.25;
  v.segment<6>(0) << 0, 0, Om, V, 0, 0;  // rod twist in the rod frame
  v[index_of(m.v_names, "left_spin")] = Om * (R - w) / r;
  v[index_of(m.v_names, "right_spin")] = Om * (R + w) / r;
}

}  // namespace

TEST(Wheel, ContactFrameConventions) {
  // positive spin about +axle rolls the wheel towards +x_C; y_C is to the left; C right-handed;
  // the contact point is the lowest point of the rim, r below the centre along the wheel plane
  const System sys = load("unicycle");
  const Model& m = sys.model;
  std::mt19937 rng(1);
  for (int k = 0; k < 10; ++k) {
    Eigen::VectorXd q, v;
    random_state(sys, rng, 0.6, q, v);
    Data d(m);
    forward_kinematics(m, d, q, v);
    const ConstraintSpec& c = sys.constraints.specs[0];
    const Transform X_WC = rolling_contact_frame(m, d, c);
    EXPECT_LT((X_WC.R.transpose() * X_WC.R - Mat3::Identity()).norm(), 1e-12);
    EXPECT_NEAR(X_WC.R.determinant(), 1.0, 1e-12);
    EXPECT_LT((X_WC.R.col(2) - Vec3::UnitZ()).norm(), 1e-15);
    const Vec3 a = d.X_WB[0].R * c.axle, p_centre = d.X_WB[0].p;
    EXPECT_NEAR(a.dot(X_WC.R.col(0)), 0.0, 1e-12);                  // heading is in the wheel plane
    EXPECT_NEAR((X_WC.p - p_centre).norm(), c.radius, 1e-12);       // on the rim
    EXPECT_NEAR(a.dot(X_WC.p - p_centre), 0.0, 1e-12);
    // lowest point of the rim: no rim point is lower
    const Vec3 u1 = a.unitOrthogonal(), u2 = a.cross(u1);
    for (int j = 0; j < 64; ++j) {
      const double t = 2 * M_PI * j / 64;
      EXPECT_GE((p_centre + c.radius * (std::cos(t) * u1 + std::sin(t) * u2)).z(), X_WC.p.z() - 1e-12);
    }
    // spin about +a with the contact point at rest moves the centre towards +x_C
    const Vec3 v_centre = (a).cross(p_centre - X_WC.p);
    EXPECT_GT(v_centre.dot(X_WC.R.col(0)), 0.0);
    EXPECT_NEAR(v_centre.dot(X_WC.R.col(1)), 0.0, 1e-12);
  }
}

TEST(Wheel, RollingRowsAndTheirDerivativeMatchFiniteDifferences) {
  // at arbitrary states (leaning, off the ground, moving): G v is the material velocity of the wheel
  // at the contact point in C; the normal row is the time derivative of the height (holonomic);
  // Gdot v is the derivative of G(q) v along the motion; x, y rows carry no position error
  std::mt19937 rng(2);
  for (const std::string name : {"unicycle", "two_wheel_vehicle"}) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    const Model& m = sys.model;
    double worst_gdot = 0, worst_u = 0, worst_h = 0;
    for (int k = 0; k < 20; ++k) {
      Eigen::VectorXd q, v;
      random_state(sys, rng, 0.5, q, v);
      v *= 3.0;
      Data d(m);
      ConstraintData cd(m, sys.constraints);
      forward_kinematics(m, d, q, v);
      constraint_rows(m, d, sys.constraints, q, v, cd);
      EXPECT_LT((cd.G * v - cd.Gv).norm(), 1e-12 * (1 + cd.Gv.norm()));
      const double eps = 1e-6;
      Eigen::VectorXd qp(m.nq()), qm(m.nq());
      integrate(m, q, v, eps, qp);
      integrate(m, q, v, -eps, qm);
      Data dp(m), dm(m);
      ConstraintData cp(m, sys.constraints), cm(m, sys.constraints);
      forward_kinematics(m, dp, qp, v);
      forward_kinematics(m, dm, qm, v);
      constraint_rows(m, dp, sys.constraints, qp, v, cp);
      constraint_rows(m, dm, sys.constraints, qm, v, cm);
      const Eigen::VectorXd gdot_fd = (cp.G * v - cm.G * v) / (2 * eps);
      worst_gdot = std::max(worst_gdot, (gdot_fd - cd.Gdot_v).norm() / (1 + cd.Gdot_v.norm()));
      EXPECT_LT((gdot_fd - cd.Gdot_v).norm(), 1e-6 * (1 + cd.Gdot_v.norm()));
      for (size_t s = 0; s < sys.constraints.specs.size(); ++s) {
        const ConstraintSpec& c = sys.constraints.specs[s];
        const int r0 = sys.constraints.row_offset[s];
        EXPECT_EQ(cd.err[r0], 0.0);
        EXPECT_EQ(cd.err[r0 + 1], 0.0);
        const Transform X_WC = rolling_contact_frame(m, d, c);
        EXPECT_NEAR(cd.err[r0 + 2], X_WC.p.z(), 1e-15);
        // material velocity: the body point at P, followed by finite differences
        const Vec3 p_B = d.X_WB[c.body].inverse().R * (X_WC.p - d.X_WB[c.body].p);
        const Vec3 u_fd = ((dp.X_WB[c.body].R * p_B + dp.X_WB[c.body].p) - (dm.X_WB[c.body].R * p_B + dm.X_WB[c.body].p)) / (2 * eps);
        const Vec3 u_C = X_WC.R.transpose() * u_fd;
        worst_u = std::max(worst_u, (u_C - cd.Gv.segment<3>(r0)).norm());
        EXPECT_LT((u_C - cd.Gv.segment<3>(r0)).norm(), 1e-7 * (1 + v.norm()));
        // holonomic normal row: d/dt height = (G v)_z, also off the constraint manifold
        const double hdot_fd = (cp.err[r0 + 2] - cm.err[r0 + 2]) / (2 * eps);
        worst_h = std::max(worst_h, std::abs(hdot_fd - cd.Gv[r0 + 2]));
        EXPECT_NEAR(hdot_fd, cd.Gv[r0 + 2], 1e-7 * (1 + v.norm()));
      }
    }
    std::printf("[ %s ] FD: Gdot v rel err %.2e, material velocity %.2e m/s, dh/dt %.2e m/s\n", name.c_str(), worst_gdot,
                worst_u, worst_h);
  }
}

TEST(Wheel, VehicleAtRestCarries34335NPerWheel) {
  // statics (the paper's results section; invariants): each wheel carries (3 + 3 + 1) kg * 9.81 / 2 = 34.335 N, no
  // tangential force; the rigid axle's lateral redundancy is detected and flagged
  const System sys = load("two_wheel_vehicle");
  EXPECT_NEAR(total_mass(sys.model), 7.0, 1e-15);
  Workspace ws(sys);
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
  const Diagnostics& d = evaluate(sys, ws, sys.q0, sys.v0, tau);
  EXPECT_EQ(d.status, Status::kIndeterminate);
  EXPECT_EQ(d.rows, 6);
  EXPECT_EQ(d.rank, 5);
  EXPECT_EQ(d.indeterminate, 1);
  EXPECT_LT(ws.vdot.cwiseAbs().maxCoeff(), 1e-12);
  for (const std::string w : {"left", "right"}) {
    unsigned mask = 0;
    const Vec3 f = contact_force(sys, ws, w, &mask);
    EXPECT_NEAR(f.z(), 34.335, 1e-10) << w;
    EXPECT_NEAR(f.x(), 0.0, 1e-10) << w;
    EXPECT_NEAR(f.y(), 0.0, 1e-10) << w;
    EXPECT_EQ(mask, 1u << 4) << w;  // only the lateral force (vy) is indeterminate
  }
}

TEST(Wheel, UnicycleAtRestCarriesItsWeight) {
  // the paper's wheel (platform at the centre, spin joint, contact joint, tip) at rest: the
  // contact force is the weight, along the normal; the same here for an upright wheel at rest and
  // for a rolling one (constant velocity)
  const System sys = load("unicycle");
  Workspace ws(sys);
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
  for (bool rolling : {false, true}) {
    const Eigen::VectorXd v = rolling ? sys.v0 : Eigen::VectorXd::Zero(sys.model.nv());
    const Diagnostics& d = evaluate(sys, ws, sys.q0, v, tau);
    EXPECT_EQ(d.status, Status::kOk);
    EXPECT_EQ(d.rank, 3);
    const Vec3 f = contact_force(sys, ws, "wheel");
    EXPECT_NEAR(f.z(), 3.0 * kG, 1e-10);
    EXPECT_NEAR(f.head<2>().norm(), 0.0, 1e-10);
  }
}

TEST(Wheel, Section9InvariantsAndAgreementWithKktAndSvd) {
  // residual, no work by the contact forces, equations of motion, a plain KKT solve, and the SVD
  // baseline (s.6) on both wheel scenes at random consistent moving states with torques
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-1, 1);
  for (const std::string name : {"unicycle", "two_wheel_vehicle"}) {
    SCOPED_TRACE(name);
    const System sys = load(name), svd = load(name, Formulation::kSvdBaseline);
    const Model& m = sys.model;
    Workspace ws(sys), wsv(svd);
    for (int k = 0; k < 10; ++k) {
      Eigen::VectorXd q, v;
      random_state(sys, rng, 0.0, q, v);  // q0 (on the manifold), random v
      {
        Data d(m);
        ConstraintData cd(m, sys.constraints);
        forward_kinematics(m, d, q, v);
        constraint_rows(m, d, sys.constraints, q, v, cd);
        v = project_velocity(cd.G, 3.0 * v);
      }
      Eigen::VectorXd tau = Eigen::VectorXd::Zero(m.nv());
      for (int i = 6; i < m.nv(); ++i) tau[i] = 2.0 * U(rng);  // drive torques (the platform is free)
      const Diagnostics& d = evaluate(sys, ws, q, v, tau);
      ASSERT_NE(d.status, Status::kError);
      const double scale = 1 + (ws.cd.G.cwiseAbs() * ws.vdot.cwiseAbs()).maxCoeff() + ws.cd.Gdot_v.cwiseAbs().maxCoeff();
      EXPECT_LT((ws.cd.G * ws.vdot + ws.cd.Gdot_v).cwiseAbs().maxCoeff(), 1e-10 * scale);
      EXPECT_LT(std::abs(ws.lambda.dot(ws.cd.G * v)), 1e-9 * (1 + ws.lambda.norm() * v.norm()));
      crba(sys.model, ws.data);  // evaluate() leaves the dense M out
      const Eigen::VectorXd r = ws.data.M * ws.vdot + ws.data.h - tau - ws.cd.G.transpose() * ws.lambda;
      EXPECT_LT(r.cwiseAbs().maxCoeff(), 1e-10 * (1 + ws.data.h.cwiseAbs().maxCoeff()));
      Eigen::VectorXd vdot, lambda;
      kkt_solve(ws.data.M, ws.cd.G, tau - ws.data.h, ws.cd.gamma, vdot, lambda);
      EXPECT_LT((vdot - ws.vdot).norm(), 1e-9 * (1 + vdot.norm()));
      EXPECT_LT((ws.cd.G.transpose() * (lambda - ws.lambda)).norm(), 1e-8 * (1 + lambda.norm()));
      evaluate(svd, wsv, q, v, tau);
      EXPECT_LT((wsv.vdot - ws.vdot).norm(), 1e-8 * (1 + vdot.norm()));
    }
  }
}

TEST(Wheel, StraightRollingKeepsSpeedSpinAndEnergy) {
  // no torque, straight rolling at 2 m/s for 2 s (RK4, 1 ms): velocity and spin constant (world
  // velocity and angular velocity of the platform, spin joint rates), energy constant, the contact
  // points' material velocity and height stay at zero (drift reported)
  for (const std::string name : {"two_wheel_vehicle", "unicycle"}) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    const Model& m = sys.model;
    Eigen::VectorXd q = sys.q0, v = sys.v0;
    if (name == "two_wheel_vehicle") {
      v[3] = 2.0;                                // rod forward at 2 m/s
      v[index_of(m.v_names, "left_spin")] = 8.0;  // 2 / 0.25
      v[index_of(m.v_names, "right_spin")] = 8.0;
    }
    const Eigen::VectorXd v0 = v;
    const Vec3 v0_W = v.segment<3>(3), w0_W = v.head<3>();  // the initial pose is the identity
    const double E0 = energy(sys, q, v);
    Stepper st(sys);
    const Eigen::VectorXd tau = Eigen::VectorXd::Zero(m.nv());
    double max_slip = 0, max_height = 0, max_dE = 0, max_dv = 0;
    for (int i = 0; i < 2000; ++i) {
      ASSERT_NE(step(sys, st, Integrator::kRk4, 1e-3, tau, q, v).status, Status::kError);
      max_slip = std::max(max_slip, st.ws.cd.Gv.cwiseAbs().maxCoeff());
      max_height = std::max(max_height, st.ws.cd.err.cwiseAbs().maxCoeff());
      max_dE = std::max(max_dE, std::abs(energy(sys, q, v) - E0));
      // world velocity of the platform's origin and its angular velocity, and the spin joints
      Data d(m);
      forward_kinematics(m, d, q, v);
      const Mat3& R = d.X_WB[0].R;
      max_dv = std::max(max_dv, (R * v.segment<3>(3) - v0_W).cwiseAbs().maxCoeff());
      max_dv = std::max(max_dv, (R * v.head<3>() - w0_W).cwiseAbs().maxCoeff());
      for (int k = 6; k < m.nv(); ++k) max_dv = std::max(max_dv, std::abs(v[k] - v0[k]));
    }
    // after 2 s at 2 m/s the wheel is 4 m further along x
    EXPECT_NEAR(q[0], 4.0, 1e-9);
    EXPECT_LT(max_dv, 1e-8);
    EXPECT_LT(max_dE, 1e-8 * E0);
    EXPECT_LT(max_slip, 1e-8);
    EXPECT_LT(max_height, 1e-9);
    std::printf("[ %s ] straight rolling 2 s: max |v - v0| %.2e, |E - E0| %.2e J (E0 %.4f J), slip %.2e m/s, height %.2e m\n",
                name.c_str(), max_dv, max_dE, E0, max_slip, max_height);
  }
}

TEST(Wheel, PerturbedRollingDriftStaysBounded) {
  // a rolling, leaning, steering unicycle for 3 s: the contact point's material velocity and height
  // stay near zero under Baumgarte stabilization, and the energy is kept to the integrator's error
  const System sys = load("unicycle");
  const Model& m = sys.model;
  Eigen::VectorXd q = sys.q0, v = sys.v0;
  v[0] = 0.5;  // lean rate (body x = heading at t = 0)
  v[2] = 0.8;  // yaw rate
  Data d(m);
  ConstraintData cd(m, sys.constraints);
  forward_kinematics(m, d, q, v);
  constraint_rows(m, d, sys.constraints, q, v, cd);
  v = project_velocity(cd.G, v);
  const double E0 = energy(sys, q, v);
  Stepper st(sys);
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(m.nv());
  double max_slip = 0, max_height = 0, max_dE = 0;
  for (int i = 0; i < 3000; ++i) {
    ASSERT_NE(step(sys, st, Integrator::kRk4, 1e-3, tau, q, v).status, Status::kError);
    max_slip = std::max(max_slip, st.ws.cd.Gv.cwiseAbs().maxCoeff());
    max_height = std::max(max_height, st.ws.cd.err.cwiseAbs().maxCoeff());
    max_dE = std::max(max_dE, std::abs(energy(sys, q, v) - E0));
  }
  EXPECT_LT(max_slip, 1e-6);
  EXPECT_LT(max_height, 1e-6);
  EXPECT_LT(max_dE, 1e-4 * E0);
  std::printf("[ unicycle ] leaning, steering 3 s: slip %.2e m/s, height %.2e m, |E - E0| %.2e J of %.3f J\n", max_slip,
              max_height, max_dE, E0);
}

TEST(Wheel, SteadyTurnLateralForcesAreCentripetal) {
  // the vehicle in a steady left turn (R = 2 m, V = 1.5 m/s), no torque: nothing accelerates in
  // the body frame, no longitudinal force, and the lateral forces sum to M V^2 / R; the normal
  // forces split by the wheels' gyroscopic moment (I_axle * spin * yaw rate, summed over both
  // wheels) balanced about the heading axis together with the centrifugal moment of nothing (all
  // masses on the axle): (N_R - N_L) * w = sum I3 psi_dot Omega
  const System sys = load("two_wheel_vehicle");
  const Model& m = sys.model;
  const double V = 1.5, R = 2.0, w = 0.25, Om = V / R, M = total_mass(m), I3 = 0.09375;
  Eigen::VectorXd q, v;
  vehicle_turn_state(sys, V, R, q, v);
  Workspace ws(sys);
  const Diagnostics& d = evaluate(sys, ws, q, v, Eigen::VectorXd::Zero(m.nv()));
  ASSERT_NE(d.status, Status::kError);
  EXPECT_EQ(d.indeterminate, 1);
  EXPECT_LT(ws.vdot.cwiseAbs().maxCoeff(), 1e-10);
  const Vec3 fl = contact_force(sys, ws, "left"), fr = contact_force(sys, ws, "right");
  EXPECT_NEAR(fl.x(), 0.0, 1e-10);
  EXPECT_NEAR(fr.x(), 0.0, 1e-10);
  EXPECT_NEAR(fl.y() + fr.y(), M * V * V / R, 1e-10);
  EXPECT_NEAR(fl.y(), fr.y(), 1e-10);  // min-norm split of the indeterminate lateral force
  EXPECT_NEAR(fl.z() + fr.z(), M * kG, 1e-10);
  const double spin_sum = v[index_of(m.v_names, "left_spin")] + v[index_of(m.v_names, "right_spin")];
  // moment about the heading axis x at the axle midpoint: wheel angular momentum I3 psi_dot y
  // precessing at Omega z changes at Omega z x I3 psi_dot y = -I3 psi_dot Omega x; the contact
  // forces give w (N_L - N_R) + r (f_yL + f_yR) (lateral forces act r below the axle, along +y)
  const double r = 0.25;
  EXPECT_NEAR(w * (fl.z() - fr.z()) + r * (fl.y() + fr.y()), -I3 * spin_sum * Om, 1e-9);
  std::printf("[ two_wheel_vehicle ] steady turn R %.1f m V %.1f m/s: lateral %.6f + %.6f = %.6f N (M V^2/R = %.6f), normal L %.4f R %.4f N\n",
              R, V, fl.y(), fr.y(), fl.y() + fr.y(), M * V * V / R, fl.z(), fr.z());
}

TEST(Wheel, ExternalWrenchesEqualTheMomentumRateAtEveryStep) {
  // s.9: contact forces + gravity = d/dt of the total spatial momentum (central differences along
  // the motion), at every step of a turn with the paper's drive torque on the left wheel
  // (internal: rod <-> wheel, it cancels)
  const System sys = load("two_wheel_vehicle");
  const Model& m = sys.model;
  Eigen::VectorXd q, v;
  vehicle_turn_state(sys, 1.5, 2.0, q, v);
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(m.nv());
  tau[index_of(m.v_names, "left_spin")] = 1.0;
  Stepper st(sys);
  double worst = 0;
  for (int i = 0; i < 300; ++i) {
    ASSERT_NE(evaluate(sys, st.ws, q, v, tau).status, Status::kError);
    const double eps = 1e-7;  // central differences: the error is O(eps^2) (rod spin ~30 rad/s)
    Eigen::VectorXd qp(m.nq()), qm(m.nq());
    integrate(m, q, v, eps, qp);
    integrate(m, q, v, -eps, qm);
    const Vec6 hdot = (total_momentum(m, qp, v + eps * st.ws.vdot) - total_momentum(m, qm, v - eps * st.ws.vdot)) / (2 * eps);
    const Vec6 F = external_wrench(sys, st.ws);
    worst = std::max(worst, (hdot - F).norm() / (1 + F.norm()));
    ASSERT_LT((hdot - F).norm(), 1e-7 * (1 + F.norm())) << "step " << i;
    step(sys, st, Integrator::kRk4, 1e-3, tau, q, v);
  }
  std::printf("[ two_wheel_vehicle ] momentum balance over 300 steps: worst |dh/dt - F_ext| / |F_ext| = %.2e\n", worst);
}

TEST(Wheel, RollingDiskSteadyCircleMatchesTheClassicalRelation) {
  // A uniform thin disk (I_axle = m r^2 / 2, I_diam = m r^2 / 4) leaning by phi into a steady turn
  // whose contact path has radius R precesses at
  //   Omega^2 = 4 g tan(phi) / (6 R - 5 r sin(phi))
  // with spin sigma = Omega R / r about the axle relative to the heading frame (rolling), its centre
  // on a circle of radius rho = R - r sin(phi). Derived from the rolling constraint and the angular
  // momentum balance about the centre (README "Wheels"). Set that state up and check that the
  // solver keeps it steady: the angular acceleration is sigma Omega n x a (the axle precessing), the
  // centre accelerates by Omega^2 rho towards the axis, the contact force is (0, m Omega^2 rho, m g)
  // in the contact frame; and a 1 % wrong precession rate is not steady (the lean accelerates).
  const System sys = load("unicycle");
  const Model& m = sys.model;
  const double r = 0.25, mass = 3.0;
  for (double phi : {0.1, 0.3, 0.6}) {
    for (double R : {1.0, 3.0}) {
      for (double factor : {1.0, 1.01}) {
        SCOPED_TRACE("phi " + std::to_string(phi) + " R " + std::to_string(R) + " factor " + std::to_string(factor));
        const double Om = factor * std::sqrt(4 * kG * std::tan(phi) / (6 * R - 5 * r * std::sin(phi)));
        const double sigma = Om * R / r, rho = R - r * std::sin(phi);
        const Mat3 Rot = Eigen::AngleAxisd(-phi, Vec3::UnitX()).toRotationMatrix();  // lean left
        const Vec3 n = Vec3::UnitZ(), a = Rot * Vec3::UnitY(), centre = Rot * Vec3(0, 0, r);
        const Vec3 w_W = Om * n + sigma * a;
        const Vec3 vc_W = w_W.cross(centre);  // contact point (origin) at rest
        ASSERT_NEAR(vc_W.x(), Om * rho, 1e-12);
        Eigen::VectorXd q = sys.q0, v(6);
        q.segment<3>(0) = centre;
        const Quat qu(Rot);
        q.segment<4>(3) << qu.w(), qu.x(), qu.y(), qu.z();
        v.head<3>() = Rot.transpose() * w_W;
        v.tail<3>() = Rot.transpose() * vc_W;
        Workspace ws(sys);
        ws.position_errors = true;
        const Diagnostics& d = evaluate(sys, ws, q, v, Eigen::VectorXd::Zero(6));
        ASSERT_EQ(d.status, Status::kOk);
        ASSERT_LT(ws.cd.err.cwiseAbs().maxCoeff(), 1e-15);
        ASSERT_LT(ws.cd.Gv.cwiseAbs().maxCoeff(), 1e-12);
        const Vec3 alpha_W = Rot * ws.vdot.head<3>();
        const Vec3 acc_W = Rot * (ws.vdot.tail<3>() + v.head<3>().cross(v.tail<3>()));
        const Vec3 alpha_steady = sigma * Om * n.cross(a), acc_steady = Om * Om * rho * Vec3::UnitY();
        const Vec3 f = contact_force(sys, ws, "wheel");
        if (factor == 1.0) {
          EXPECT_LT((alpha_W - alpha_steady).norm(), 1e-9 * alpha_steady.norm());
          EXPECT_LT((acc_W - acc_steady).norm(), 1e-9 * acc_steady.norm());
          EXPECT_NEAR(f.x(), 0.0, 1e-9);
          EXPECT_NEAR(f.y(), mass * Om * Om * rho, 1e-9);
          EXPECT_NEAR(f.z(), mass * kG, 1e-9);
        } else {
          // the lean accelerates: angular acceleration about the heading axis x
          EXPECT_GT(std::abs(alpha_W.x() - alpha_steady.x()), 1e-3);
        }
      }
    }
  }
  // and it stays steady in time: lean and precession rate after 1 s of simulation
  const double phi = 0.3, R = 2.0;
  const double Om = std::sqrt(4 * kG * std::tan(phi) / (6 * R - 5 * r * std::sin(phi))), sigma = Om * R / r;
  const Mat3 Rot = Eigen::AngleAxisd(-phi, Vec3::UnitX()).toRotationMatrix();
  const Vec3 a = Rot * Vec3::UnitY(), centre = Rot * Vec3(0, 0, r), w_W = Om * Vec3::UnitZ() + sigma * a;
  Eigen::VectorXd q = sys.q0, v(6);
  q.segment<3>(0) = centre;
  const Quat qu(Rot);
  q.segment<4>(3) << qu.w(), qu.x(), qu.y(), qu.z();
  v.head<3>() = Rot.transpose() * w_W;
  v.tail<3>() = Rot.transpose() * w_W.cross(centre);
  Stepper st(sys);
  double max_lean_err = 0;
  for (int i = 0; i < 1000; ++i) {
    step(sys, st, Integrator::kRk4, 1e-3, Eigen::VectorXd::Zero(6), q, v);
    Data d(m);
    forward_kinematics(m, d, q, v);
    const Vec3 ai = d.X_WB[0].R * Vec3::UnitY();
    max_lean_err = std::max(max_lean_err, std::abs(std::asin(-ai.z()) - phi));
  }
  Data d(m);
  forward_kinematics(m, d, q, v);
  const Vec3 w_end = d.X_WB[0].R * v.head<3>(), a_end = d.X_WB[0].R * Vec3::UnitY();
  const double Om_end = (w_end - w_end.dot(a_end) * a_end).dot(Vec3::UnitZ()) / (1 - a_end.z() * a_end.z());
  EXPECT_LT(max_lean_err, 1e-6);
  EXPECT_NEAR(Om_end, Om, 1e-6 * Om);
  // the centre went around its circle: heading turned by Omega * 1 s
  const Vec3 x_heading = a_end.cross(Vec3::UnitZ()).normalized();
  EXPECT_NEAR(std::atan2(x_heading.y(), x_heading.x()), Om * 1.0, 1e-6);
  std::printf("[ unicycle ] steady circle phi 0.3 rad R 2 m: Omega %.6f rad/s, spin %.4f rad/s; after 1 s lean error %.2e rad\n", Om,
              sigma, max_lean_err);
}

TEST(Wheel, RigidAxleRedundancyIsDetectedAndNeverNaN) {
  // the two lateral rows of a rigid axle are the same row: rank 5 of 6, one indeterminate
  // direction; min_norm splits it equally (the paper's eta = 0), compliance splits it inversely to
  // the wheels' lateral compliances; the net lateral force is the same; no NaN at any state
  const std::string text_min = [] {
    std::ifstream f(scene_path("two_wheel_vehicle"));
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  }();
  std::string text_c = text_min;
  const size_t at = text_c.find("\nredundancy: min_norm\n");
  ASSERT_NE(at, std::string::npos);
  text_c.replace(at, 22, "\nredundancy: compliance\n");
  const std::string left_line = "{name: left, type: rolling, body: left_wheel, axle: [0, 1, 0], radius: 0.25, compliance: [1e-6, 1e-6, 1e-6]}";
  const size_t cr = text_c.find(left_line);
  ASSERT_NE(cr, std::string::npos);
  text_c.replace(cr, left_line.size(),
                 "{name: left, type: rolling, body: left_wheel, axle: [0, 1, 0], radius: 0.25, compliance: [1e-6, 3e-6, 1e-6]}");
  const System mn = load_scene_string(text_min, "two_wheel_vehicle.yaml");
  const System cp = load_scene_string(text_c, "two_wheel_vehicle_compliance.yaml");
  ASSERT_EQ(cp.options.redundancy, Redundancy::kCompliance);
  Eigen::VectorXd q, v;
  vehicle_turn_state(mn, 1.5, 2.0, q, v);
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(mn.model.nv());
  Workspace wm(mn), wc(cp);
  evaluate(mn, wm, q, v, tau);
  evaluate(cp, wc, q, v, tau);
  for (Workspace* w : {&wm, &wc}) {
    EXPECT_EQ(w->diag.status, Status::kIndeterminate);
    EXPECT_EQ(w->diag.rank, 5);
    EXPECT_EQ(w->diag.indeterminate, 1);
  }
  EXPECT_LT((wm.vdot - wc.vdot).norm(), 1e-12);
  const Vec3 ml = contact_force(mn, wm, "left"), mr = contact_force(mn, wm, "right");
  const Vec3 cl = contact_force(cp, wc, "left"), crr = contact_force(cp, wc, "right");
  EXPECT_NEAR(ml.y() + mr.y(), cl.y() + crr.y(), 1e-10);
  EXPECT_NEAR(ml.y(), mr.y(), 1e-10);
  EXPECT_NEAR(crr.y(), 3.0 * cl.y(), 1e-9);  // force inversely proportional to compliance
  EXPECT_NEAR(ml.z(), cl.z(), 1e-10);
  // random states, on and off the manifold: finite, rank 5 (axle level) or 6 (axle tilted by the
  // perturbation), never an error
  std::mt19937 rng(4);
  for (int k = 0; k < 200; ++k) {
    Eigen::VectorXd qr, vr;
    random_state(mn, rng, k < 100 ? 0.0 : 0.3, qr, vr);
    Eigen::VectorXd t = Eigen::VectorXd::Random(mn.model.nv());
    for (Workspace* w : {&wm, &wc}) {
      const Diagnostics& d = evaluate(w == &wm ? mn : cp, *w, qr, vr, t);
      EXPECT_NE(d.status, Status::kError);
      EXPECT_TRUE(w->vdot.allFinite());
      EXPECT_TRUE(w->lambda.allFinite());
      if (k < 100) {
        EXPECT_EQ(d.rank, 5);
      }
    }
  }
}

TEST(Wheel, SceneErrorsNameTheProblem) {
  const std::string base = R"(
bodies:
  - {name: wheel, joint: {type: floating, q: {xyz: [0, 0, 0.25]}}, mass: 1, inertia: [0.1, 0.1, 0.1, 0, 0, 0]}
constraints:
)";
  auto err = [&](const std::string& c) {
    try {
      load_scene_string(base + c, "w.yaml");
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(err("  - {type: rolling, body: nowheel, axle: [0, 1, 0], radius: 0.25}").find("unknown wheel body"), std::string::npos);
  EXPECT_NE(err("  - {type: rolling, body: wheel, axle: [0, 1, 0], radius: -1}").find("radius must be > 0"), std::string::npos);
  EXPECT_NE(err("  - {type: rolling, body: wheel, axle: [0, 0, 0], radius: 0.25}").find("nonzero"), std::string::npos);
  // a wheel of radius 0.3 under a body placed for 0.25: closed by lifting the body (with a warning),
  // an error when the scene keeps its values
  {
    const System s = load_scene_string(base + "  - {type: rolling, body: wheel, axle: [0, 1, 0], radius: 0.3}", "w.yaml");
    ASSERT_EQ(s.warnings.size(), 1u);
    EXPECT_NE(s.warnings[0].find("initial state: the constraints were open by 0.05"), std::string::npos) << s.warnings[0];
  }
  {
    std::string no_close = "close_initial_state: false\n" + base;
    try {
      load_scene_string(no_close + "  - {type: rolling, body: wheel, axle: [0, 1, 0], radius: 0.3}", "w.yaml");
      ADD_FAILURE() << "no error";
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find("does not close constraint"), std::string::npos) << e.what();
    }
  }
  EXPECT_NE(err("  - {type: rolling, body: wheel, radius: 0.25}").find("missing 'axle'"), std::string::npos);
  EXPECT_EQ(err("  - {type: rolling, body: wheel, axle: [0, 2, 0], radius: 0.25}"), "no error");  // normalized
}

namespace {
// The vehicle reduced to the plane (the rod's spin is driven by the reaction alone and drops out):
// forward speed u and yaw rate Omega of the axle midpoint, wheel spins psi = (u -+ w Omega) / r.
//   (M + 2 I3 / r^2) du/dt = (tau_L + tau_R) / r
//   (Iz + 2 I3 w^2 / r^2) dOmega/dt = (tau_R - tau_L) w / r
// and each wheel's longitudinal force from its spin balance: I3 psi_ddot = tau - r f_x.
struct Planar {
  double u_dot, Om_dot, fx_l, fx_r;
};
Planar planar_vehicle(double tau_l, double tau_r) {
  const double M = 7.0, r = 0.25, w = 0.25, I3 = 0.09375, I1 = 0.046875, mw = 3.0, Iz_rod = 0.0233333333333;
  const double Iz = Iz_rod + 2 * (I1 + mw * w * w);
  Planar p;
  p.u_dot = (tau_l + tau_r) / r / (M + 2 * I3 / (r * r));
  p.Om_dot = (tau_r - tau_l) * w / r / (Iz + 2 * I3 * w * w / (r * r));
  p.fx_l = (tau_l - I3 * (p.u_dot - w * p.Om_dot) / r) / r;
  p.fx_r = (tau_r - I3 * (p.u_dot + w * p.Om_dot) / r) / r;
  return p;
}
}  // namespace

TEST(Wheel, PaperPulseForcesMatchThePlanarAnalysis) {
  // the paper's input (1 N*m on the left wheel) at rest: longitudinal forces from the planar
  // analysis, the rod spun backwards by the reaction (-tau / I_rod,axial), normal forces 34.335 N
  const System sys = load("two_wheel_vehicle");
  const Model& m = sys.model;
  Workspace ws(sys);
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(m.nv());
  tau[index_of(m.v_names, "left_spin")] = 1.0;
  ASSERT_NE(evaluate(sys, ws, sys.q0, sys.v0, tau).status, Status::kError);
  const Planar p = planar_vehicle(1.0, 0.0);
  const Vec3 fl = contact_force(sys, ws, "left"), fr = contact_force(sys, ws, "right");
  EXPECT_NEAR(fl.x(), p.fx_l, 1e-10);
  EXPECT_NEAR(fr.x(), p.fx_r, 1e-10);
  EXPECT_NEAR(fl.y() + fr.y(), 0.0, 1e-10);
  EXPECT_NEAR(fl.z(), 34.335, 1e-10);
  EXPECT_NEAR(fr.z(), 34.335, 1e-10);
  EXPECT_NEAR(ws.vdot[1], -1.0 / 0.005, 1e-8);  // rod.wy
  EXPECT_NEAR(ws.vdot[3], p.u_dot, 1e-10);      // rod.vx
  EXPECT_NEAR(ws.vdot[2], p.Om_dot, 1e-10);     // rod.wz
  std::printf("[ two_wheel_vehicle ] 1 N*m on the left wheel at rest: fx left %.6f right %.6f N, du/dt %.4f m/s^2, dOmega/dt %.4f rad/s^2\n",
              fl.x(), fr.x(), p.u_dot, p.Om_dot);
}

TEST(Wheel, PaperExperimentKeepsTheNormalForcesAt34335) {
  // The paper's 2 s with its pulse. The angular momentum about the line through the two contact
  // points stays zero (internal drive torques; contact forces on the line; gravity through it), so
  // w (N_L - N_R) = -Omega H_spin - r sum f_y = 0: both wheels carry 34.335 N throughout, up to the
  // integrator's error. After the pulse the vehicle turns steadily: sum f_y = M u Omega with
  // u = du/dt * 0.5 s and Omega = dOmega/dt * 0.5 s of the planar analysis.
  const System sys = load("two_wheel_vehicle");
  const Model& m = sys.model;
  Stepper st(sys);
  Eigen::VectorXd q = sys.q0, v = sys.v0, tau = Eigen::VectorXd::Zero(m.nv());
  const int il = index_of(m.v_names, "left_spin");
  double max_dn = 0;
  for (int i = 0; i <= 2000; ++i) {
    tau[il] = i < 500 ? 1.0 : 0.0;
    const Diagnostics& d = i < 2000 ? step(sys, st, Integrator::kRk4, 1e-3, tau, q, v) : evaluate(sys, st.ws, q, v, tau);
    ASSERT_EQ(d.status, Status::kIndeterminate);
    ASSERT_EQ(d.rank, 5);
    const Vec3 fl = contact_force(sys, st.ws, "left"), fr = contact_force(sys, st.ws, "right");
    max_dn = std::max({max_dn, std::abs(fl.z() - 34.335), std::abs(fr.z() - 34.335)});
    ASSERT_NEAR(fl.y(), fr.y(), 1e-9);
  }
  EXPECT_LT(max_dn, 1e-4);
  const Planar p = planar_vehicle(1.0, 0.0);
  const double u = 0.5 * p.u_dot, Om = 0.5 * p.Om_dot;
  const Vec3 fl = contact_force(sys, st.ws, "left"), fr = contact_force(sys, st.ws, "right");
  EXPECT_NEAR(fl.y() + fr.y(), 7.0 * u * Om, 1e-4);
  EXPECT_NEAR(fl.x(), 0.0, 1e-4);
  EXPECT_NEAR(fr.x(), 0.0, 1e-4);
  std::printf("[ two_wheel_vehicle ] paper's pulse, 2 s: max |N - 34.335| %.2e N; at 2 s sum f_y %.6f N (M u Omega = %.6f)\n", max_dn,
              fl.y() + fr.y(), 7.0 * u * Om);
}

TEST(Wheel, ContactForcesDoNotDependOnTheRodsAxialInertia) {
  // the drive reaction spins the rod about the axle; the rod is symmetric about it, so its axial
  // inertia changes how fast it spins (100 vs 10 rad/s after the pulse) but not the contact forces
  std::ifstream f(scene_path("two_wheel_vehicle"));
  std::stringstream ss;
  ss << f.rdbuf();
  std::string text = ss.str();
  const std::string rod_inertia = "inertia: [0.0233333333333, 0.005, 0.0233333333333, 0, 0, 0]";
  const size_t at = text.find(rod_inertia);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, rod_inertia.size(), "inertia: [0.0233333333333, 0.05, 0.0233333333333, 0, 0, 0]");
  const System a = load("two_wheel_vehicle"), b = load_scene_string(text, "heavy_rod.yaml");
  Stepper sa(a), sb(b);
  Eigen::VectorXd qa = a.q0, va = a.v0, qb = b.q0, vb = b.v0, tau = Eigen::VectorXd::Zero(a.model.nv());
  const int il = index_of(a.model.v_names, "left_spin");
  double worst = 0;
  for (int i = 0; i < 1000; ++i) {
    tau[il] = i < 500 ? 1.0 : 0.0;
    step(a, sa, Integrator::kRk4, 1e-3, tau, qa, va);
    step(b, sb, Integrator::kRk4, 1e-3, tau, qb, vb);
    for (const std::string w : {"left", "right"})
      worst = std::max(worst, (contact_force(a, sa.ws, w) - contact_force(b, sb.ws, w)).norm());
  }
  EXPECT_LT(worst, 1e-4);
  EXPECT_NEAR(va[1], -100.0, 1e-6);  // rod.wy after the pulse: -tau * 0.5 s / I_axial
  EXPECT_NEAR(vb[1], -10.0, 1e-6);
}

TEST(Wheel, SameAsThePapersJointStructure) {
  // The paper's wheel (Fig. 7, 9): yaw and lean as a 2-DOF joint at the ground contact, the spin
  // as a 1-DOF joint at the wheel centre, the contact tip moving on the ground. Built here as a tree
  // rooted at the contact (x, y prismatic; yaw about z; lean about the heading x_C at P; a rigid
  // radius up to the centre; spin about the axle), re-rooting the paper's mobile-platform chain.
  // The contact then stays on the ground by construction (the normal row of the rolling constraint
  // is identically zero: rank 2, its force 0 by min-norm), the normal force comes through the
  // root joints, and only the no-slip rows act. At the same physical state the wheel's spatial
  // acceleration and the ground's total wrench on the wheel at P must equal those of the floating
  // wheel with the rolling constraint (unicycle scene).
  const System paper = load_scene_string(R"(
bodies:
  - {name: base_x, joint: {type: prismatic, axis: [1, 0, 0], name: x}}
  - {name: base_y, parent: base_x, joint: {type: prismatic, axis: [0, 1, 0], name: y}}
  - {name: heading, parent: base_y, joint: {type: revolute, axis: [0, 0, 1], name: yaw}}
  - {name: lean, parent: heading, joint: {type: revolute, axis: [1, 0, 0], name: lean}}
  - name: wheel
    parent: lean
    placement: {xyz: [0, 0, 0.25]}
    joint: {type: revolute, axis: [0, 1, 0], name: spin}
    mass: 3.0
    inertia: [0.046875, 0.09375, 0.046875, 0, 0, 0]
constraints:
  - {name: wheel, type: rolling, body: wheel, axle: [0, 1, 0], radius: 0.25}
)",
                                         "paper_wheel.yaml");
  const System uni = load("unicycle");
  const Model &mp = paper.model, &mu = uni.model;
  const int wheel = mp.body_index("wheel");
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-1, 1);
  Workspace wp(paper), wu(uni);
  double worst = 0;
  for (int k = 0; k < 20; ++k) {
    // a leaning, turning, rolling state of the paper's tree (velocities projected onto the no-slip rows)
    Eigen::VectorXd q(5), v(5);
    q << U(rng), U(rng), 3 * U(rng), 0.8 * U(rng), 3 * U(rng);
    for (int i = 0; i < 5; ++i) v[i] = 5 * U(rng);
    Data d(mp);
    ConstraintData cd(mp, paper.constraints);
    forward_kinematics(mp, d, q, v);
    constraint_rows(mp, d, paper.constraints, q, v, cd);
    v = project_velocity(cd.G, v);
    const Eigen::VectorXd tau0 = Eigen::VectorXd::Zero(5);
    ASSERT_NE(evaluate(paper, wp, q, v, tau0).status, Status::kError);
    EXPECT_EQ(wp.diag.rank, 2);
    EXPECT_LT(wp.cd.G.row(2).cwiseAbs().maxCoeff(), 1e-14);
    // the same state for the floating wheel
    const Transform& X_WB = wp.data.X_WB[wheel];
    Eigen::VectorXd qu(7), vu(6);
    qu.head<3>() = X_WB.p;
    const Quat qq(X_WB.R);
    qu.segment<4>(3) << qq.w(), qq.x(), qq.y(), qq.z();
    vu = to_ref(wp.data, X_WB).inv_act(wp.data.V_W[wheel]);
    ASSERT_NE(evaluate(uni, wu, qu, vu, Eigen::VectorXd::Zero(6)).status, Status::kError);
    ASSERT_LT(wu.cd.Gv.norm(), 1e-12);
    // contact frames agree, and P is where the paper's 2-DOF joint sits
    const Transform X_WC = rolling_contact_frame(mp, wp.data, paper.constraints.specs[0]);
    const Transform X_WCu = rolling_contact_frame(mu, wu.data, uni.constraints.specs[0]);
    EXPECT_LT((X_WC.p - X_WCu.p).norm(), 1e-12);
    EXPECT_LT((X_WC.R - X_WCu.R).norm(), 1e-12);
    EXPECT_LT((X_WC.p - wp.data.X_WB[mp.body_index("lean")].p).norm(), 1e-12);
    // wheel spatial acceleration (body coordinates): the tree's S vdot + A0, the floating body's vdot
    Eigen::VectorXd tau_id(5);
    std::vector<Vec6> f_ext(mp.nbodies(), Vec6::Zero());
    Vec6 F_C = Vec6::Zero();
    F_C.tail<3>() = wp.lambda.head<3>();
    f_ext[wheel] = X_WB.inv_act_force(X_WC.act_force(F_C));
    rnea(mp, wp.data, wp.vdot, &f_ext, tau_id);
    EXPECT_LT(tau_id.norm(), 1e-9);  // no joint torque needed: the tree's own consistency
    const Vec6 a_tree = to_ref(wp.data, X_WB).inv_act(wp.data.a_W[wheel] + wp.data.A0_W[wheel]);
    EXPECT_LT((a_tree - wu.vdot).norm(), 1e-9 * (1 + wu.vdot.norm()));
    // the ground's total wrench on the wheel at P in C: root joint reaction + no-slip forces
    const Vec6 W_root = wp.data.X_WB[0].act_force(wp.data.f[0]);  // world coords, world origin
    const Vec6 W_C = X_WC.inv_act_force(W_root + X_WC.act_force(F_C));
    Vec6 W_uni = Vec6::Zero();
    W_uni.tail<3>() = tip_wrench(uni, wu, 0).tail<3>();
    EXPECT_LT((W_C - W_uni).norm(), 1e-9 * (1 + W_uni.norm())) << W_C.transpose() << " vs " << W_uni.transpose();
    worst = std::max(worst, (W_C - W_uni).norm() / (1 + W_uni.norm()));
    if (k == 0)
      std::printf("[ paper's wheel tree ] state 0: ground on wheel at P in C [m; f]: tree (%.3g %.3g %.3g; %.6f %.6f %.6f), rolling (%.3g %.3g %.3g; %.6f %.6f %.6f)\n",
                  W_C[0], W_C[1], W_C[2], W_C[3], W_C[4], W_C[5], W_uni[0], W_uni[1], W_uni[2], W_uni[3], W_uni[4], W_uni[5]);
  }
  std::printf("[ paper's wheel tree ] 20 states: worst relative wrench difference %.2e\n", worst);
}
