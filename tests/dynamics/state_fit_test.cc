// State completion from joint measurements (dynamics/state_fit.h): the load's pose and twist fitted
// from the arms' joints equal the simulated ones on closed states, a perturbed joint shows up as
// the closure residual the linearized least squares predicts, the fit is a least-squares optimum,
// and vehicles fit their chassis twist from the wheel spins but not their pose.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/QR>

#include "service/dynamics/integrators.h"
#include "service/dynamics/state_fit.h"
#include "tests/support/test_util.h"

namespace coopdyn {
namespace {

using testing::load;
using testing::random_state;

// A state that closes the constraints to round-off: (q, v) near q0 projected onto the manifold.
void closed_state(const System& sys, std::mt19937& rng, double spread, Eigen::VectorXd& q, Eigen::VectorXd& v) {
  random_state(sys, rng, spread, q, v);
  System s2 = sys;
  s2.options.projection_iterations = 50;
  Stepper st2(s2);
  for (int k = 0; k < 3; ++k) project_state(s2, st2, q, v);
}

// A closed state drawn from rng and the constraint rows there (G, err) for the fit's operators.
struct ClosedRows {
  Eigen::VectorXd q, v;
  Data d;
  ConstraintData cd;
  ClosedRows(const System& sys, std::mt19937& rng) : d(sys.model), cd(sys.model, sys.constraints) {
    closed_state(sys, rng, 0.2, q, v);
    forward_kinematics(sys.model, d, q, v);
    constraint_rows(sys.model, d, sys.constraints, q, v, cd);
  }
};

double closure_max(const Closure& c) {
  double m = 0;
  for (double x : c.value) m = std::max(m, x);
  return m;
}

// squared holonomic error at (q, v)
double cost(const System& sys, const StateFitPlan& plan, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  Data d(sys.model);
  ConstraintData cd(sys.model, sys.constraints);
  forward_kinematics(sys.model, d, q, v);
  constraint_rows(sys.model, d, sys.constraints, q, v, cd);
  double s = 0;
  for (int r = 0; r < sys.constraints.rows; ++r)
    if (plan.holonomic[r]) s += cd.err[r] * cd.err[r];
  return s;
}

struct Case {
  const char* scene;
  Formulation f;
};
const Case kCases[] = {{"two_puma_load", Formulation::kMobilePlatform},
                       {"two_puma_load", Formulation::kClassic},
                       {"two_5dof_arms_load", Formulation::kMobilePlatform},
                       {"planar_arms_load", Formulation::kMobilePlatform},
                       {"planar_arms_load", Formulation::kClassic}};

TEST(StateFit, PlanSaysWhatEachSceneMayOmit) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(std::string(c.scene) + " " + formulation_name(c.f));
    const System sys = load(c.scene, c.f);
    const StateFitPlan p = plan_state_fit(sys);
    EXPECT_EQ(p.fit_q.size(), 7u) << "one floating load";
    EXPECT_EQ(p.fit_v.size(), 6u);
    EXPECT_TRUE(p.q_fittable) << p.why_not_q;
    EXPECT_TRUE(p.v_fittable) << p.why_not_v;
  }
  // the four-bar has no floating body: nothing to fit
  EXPECT_FALSE(plan_state_fit(load("four_bar")).q_fittable);
  // a vehicle: its wheels fix the chassis' height, roll and pitch but not where it is
  for (const char* w : {"two_wheel_vehicle", "unicycle"}) {
    const StateFitPlan p = plan_state_fit(load(w));
    EXPECT_FALSE(p.q_fittable) << w;
    EXPECT_NE(std::string(p.why_not_q).find("chassis pose"), std::string::npos);
  }
}

// Along random closed states (and from a cold start at q0): the fitted pose and twist equal the
// true ones to round-off, with a residual at round-off.
TEST(StateFit, JointsOnlyGiveTheTrueLoadPoseAndTwist) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(std::string(c.scene) + " " + formulation_name(c.f));
    const System sys = load(c.scene, c.f);
    const StateFitPlan plan = plan_state_fit(sys);
    StateFitWorkspace ws(sys, plan);
    std::mt19937 rng(3);
    for (int trial = 0; trial < 12; ++trial) {
      Eigen::VectorXd q, v;
      closed_state(sys, rng, trial < 6 ? 0.05 : 0.4, q, v);  // the last ones far from the last fit
      Eigen::VectorXd qf = q, vf = v;
      for (int i : plan.fit_q) qf[i] = std::nan("");  // must not be read
      for (int i : plan.fit_v) vf[i] = std::nan("");
      const Closure& cl = fit_state(sys, plan, ws, true, true, qf, vf);
      EXPECT_LT(closure_max(cl), 1e-11) << "trial " << trial;
      // the quaternion is determined up to sign
      const int iq = plan.fit_q[3];
      const double sgn = qf.segment<4>(iq).dot(q.segment<4>(iq)) < 0 ? -1.0 : 1.0;
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(qf[plan.fit_q[k]], q[plan.fit_q[k]], 1e-11) << "trial " << trial;
      for (int k = 0; k < 4; ++k) EXPECT_NEAR(sgn * qf[iq + k], q[iq + k], 1e-11) << "trial " << trial;
      for (int d : plan.fit_v) EXPECT_NEAR(vf[d], v[d], 1e-10 * (1 + v.cwiseAbs().maxCoeff())) << "trial " << trial;
      for (int i = 0; i < q.size(); ++i)
        if (std::find(plan.fit_q.begin(), plan.fit_q.end(), i) == plan.fit_q.end()) {
          EXPECT_EQ(qf[i], q[i]) << "measured: untouched";
        }
      EXPECT_GE(cl.iterations, 1);
      EXPECT_LE(cl.iterations, 50);
    }
  }
}

// fit_operators' velocity operator: the fit is linear and homogeneous in the measured velocities,
// so the change of the fitted twist for a change dv of them is -Pv G dv (and the difference of two
// fits at v + dv and v): from the constraint Jacobian alone, to round-off of both.
TEST(StateFit, VelocityChangeIsTheFitOfTheChange) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(std::string(c.scene) + " " + formulation_name(c.f));
    const System sys = load(c.scene, c.f);
    const StateFitPlan plan = plan_state_fit(sys);
    StateFitWorkspace ws(sys, plan);
    std::mt19937 rng(5);
    ClosedRows at(sys, rng);
    Eigen::VectorXd& q = at.q;  // fit_state takes it writable (it fits no position here)
    const Eigen::VectorXd& v = at.v;
    const ConstraintData& cd = at.cd;
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    Eigen::VectorXd dv = Eigen::VectorXd::Zero(sys.model.nv());
    for (int i = 0; i < dv.size(); ++i) dv[i] = U(rng);
    Eigen::VectorXd v0 = v, v1 = v + dv, measured = dv;
    fit_state(sys, plan, ws, false, true, q, v0);
    fit_state(sys, plan, ws, false, true, q, v1);
    for (int i : plan.fit_v) measured[i] = 0.0;
    fit_operators(plan, ws, cd.G, false, true);
    const Eigen::VectorXd change = -ws.Pv * (cd.G * measured);
    for (size_t k = 0; k < plan.fit_v.size(); ++k) {
      const int i = plan.fit_v[k];
      EXPECT_NEAR(change[static_cast<Eigen::Index>(k)], v1[i] - v0[i], 1e-12 * (1 + v1.cwiseAbs().maxCoeff())) << i;
    }
    // the fit's own condition: the fitted entries of the change minimize |G change| with the
    // measured ones fixed, so G_u^T G change = 0 (G_u: G's fitted columns), to round-off of the
    // products' terms (measured 1e-15 of their largest, 5 to 7); and they are the fit's, neither
    // dv's (which the fit ignores) nor zero (measured 0.13 |dv| at least, 0.46 |dv| from dv's)
    const Eigen::MatrixXd& G = cd.G;
    Eigen::MatrixXd Gu(G.rows(), static_cast<Eigen::Index>(plan.fit_v.size()));
    Eigen::VectorXd fitted_change(Gu.cols()), fitted_dv(Gu.cols());
    for (Eigen::Index k = 0; k < Gu.cols(); ++k) {
      const int d = plan.fit_v[static_cast<size_t>(k)];
      Gu.col(k) = G.col(d);
      fitted_change[k] = v1[d] - v0[d];
      fitted_dv[k] = dv[d];
    }
    const Eigen::VectorXd normal = Gu.transpose() * (G * (v1 - v0));
    const double terms = (Gu.cwiseAbs().transpose() * (G.cwiseAbs() * (v1 - v0).cwiseAbs())).maxCoeff();
    EXPECT_LE(normal.cwiseAbs().maxCoeff(), 1e-12 * terms) << "G_u^T G (v1 - v0) = 0";
    EXPECT_GT(fitted_change.norm(), 1e-2 * dv.norm()) << "the fitted entries change with the measured ones";
    EXPECT_GT((fitted_change - fitted_dv).norm(), 1e-2 * dv.norm()) << "the fitted entries are the fit's, not dv's";
  }
}

// fit_operators' position operator: a measured joint moved by h moves the fitted pose by -Pq G h
// to first order. On a closed state (closure residual below 5e-14: the fit's response terms in
// the residual vanish) against central differences of the whole iterative fit (warm-started at the
// centre), step 1e-4: truncation O(h^2), measured 2e-10-8e-10 (it is 100x that at 1e-3); the fit's
// own tolerance (~1e-12 in the pose) / 2h stays below it here and dominates from 1e-5 down
// (3e-7 there). Asserted 1e-8 (absolute: m and rad per rad or m of the joint, O(1)).
TEST(StateFit, PositionResponseIsTheDerivativeOfTheFit) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(std::string(c.scene) + " " + formulation_name(c.f));
    const System sys = load(c.scene, c.f);
    const StateFitPlan plan = plan_state_fit(sys);
    ASSERT_TRUE(plan.q_fittable);
    StateFitWorkspace ws(sys, plan);
    std::mt19937 rng(9);
    const ClosedRows at(sys, rng);
    const Eigen::VectorXd& q = at.q;
    const Eigen::VectorXd& v = at.v;
    const ConstraintData& cd = at.cd;
    fit_operators(plan, ws, cd.G, true, false);
    const Eigen::MatrixXd K = -ws.Pq * cd.G;
    const double h = 1e-4;
    int compared = 0;
    for (const Body& b : sys.model.bodies) {
      if (b.joint.nv != 1 || b.joint.type == JointType::kFloating) continue;
      Eigen::VectorXd qp = q, qm = q, vp = v, vm = v;
      qp[b.joint.idx_q] += h;
      qm[b.joint.idx_q] -= h;
      ws.q_start = q;
      fit_state(sys, plan, ws, true, false, qp, vp);
      ws.q_start = q;
      fit_state(sys, plan, ws, true, false, qm, vm);
      // each floating joint's pose: d p / dq_j = R u, d R / dq_j = R [w]x for its tangent change
      // [w; u] (body frame, as integrate()), against central differences of p and R
      for (const Body& fb : sys.model.bodies) {
        if (fb.joint.type != JointType::kFloating) continue;
        const int iq = fb.joint.idx_q, iv = fb.joint.idx_v;
        auto rot = [&](const Eigen::VectorXd& x) { return Quat(x[iq + 3], x[iq + 4], x[iq + 5], x[iq + 6]).normalized().toRotationMatrix(); };
        Vec3 w, u;
        for (size_t k = 0; k < plan.fit_v.size(); ++k) {
          const int f = plan.fit_v[k] - iv;
          if (f >= 0 && f < 3) w[f] = K(static_cast<Eigen::Index>(k), b.joint.idx_v);
          if (f >= 3 && f < 6) u[f - 3] = K(static_cast<Eigen::Index>(k), b.joint.idx_v);
        }
        const Mat3 R = rot(q);
        const Vec3 dp = (qp.segment<3>(iq) - qm.segment<3>(iq)) / (2 * h);
        const Mat3 dR = (rot(qp) - rot(qm)) / (2 * h);
        EXPECT_LT((dp - R * u).cwiseAbs().maxCoeff(), 1e-8) << b.name;
        EXPECT_LT((dR - R * skew(w)).cwiseAbs().maxCoeff(), 1e-8) << b.name;
        EXPECT_GT(w.norm() + u.norm(), 1e-3) << b.name << ": the joint moves the fit";
      }
      ++compared;
    }
    EXPECT_GT(compared, 0);
  }
}

// A joint off by delta: the arms disagree. The residual left is what the linearized least
// squares predicts, (I - G_u G_u^+) e_0 with e_0 the error at the true load pose, to O(delta^2); it
// grows linearly with delta; and the fitted pose is a least-squares optimum (no pose nearby has a
// smaller squared error).
TEST(StateFit, PerturbedJointShowsAsTheClosureResidual) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(std::string(c.scene) + " " + formulation_name(c.f));
    const System sys = load(c.scene, c.f);
    const StateFitPlan plan = plan_state_fit(sys);
    StateFitWorkspace ws(sys, plan);
    std::mt19937 rng(5);
    Eigen::VectorXd q, v;
    closed_state(sys, rng, 0.1, q, v);
    // a joint of the first arm that is not a floating or pseudo coordinate: the second DOF of the tree
    int joint_q = -1;
    for (const Body& b : sys.model.bodies)
      if (b.joint.type == JointType::kRevolute && !b.joint.pseudo) {
        joint_q = b.joint.idx_q;
        if (joint_q > plan.fit_q.back() || plan.fit_q.front() > joint_q) break;
      }
    ASSERT_GE(joint_q, 0);
    double res[2];
    for (int k = 0; k < 2; ++k) {
      const double delta = k == 0 ? 1e-4 : 2e-4;
      Eigen::VectorXd qp = q, vp = v;
      qp[joint_q] += delta;
      // prediction from the true pose
      Data d(sys.model);
      ConstraintData cd(sys.model, sys.constraints);
      forward_kinematics(sys.model, d, qp, vp);
      constraint_rows(sys.model, d, sys.constraints, qp, vp, cd);
      std::vector<int> hol;
      for (int r = 0; r < sys.constraints.rows; ++r)
        if (plan.holonomic[r]) hol.push_back(r);
      Eigen::MatrixXd Gu(hol.size(), plan.fit_v.size());
      Eigen::VectorXd e0(hol.size());
      for (size_t i = 0; i < hol.size(); ++i) {
        e0[i] = cd.err[hol[i]];
        for (size_t j = 0; j < plan.fit_v.size(); ++j) Gu(i, j) = cd.G(hol[i], plan.fit_v[j]);
      }
      const Eigen::VectorXd predicted = e0 - Gu * Gu.completeOrthogonalDecomposition().solve(e0);
      const Closure& cl = fit_state(sys, plan, ws, true, false, qp, vp);
      double pos = 0, ori = 0;
      for (size_t i = 0; i < hol.size(); ++i)
        (plan.angular[hol[i]] ? ori : pos) = std::max(plan.angular[hol[i]] ? ori : pos, std::abs(predicted[i]));
      EXPECT_GT(pos + ori, 1e-3 * delta) << "the perturbation is visible";
      EXPECT_NEAR(cl.value[kClosurePosition], pos, 1e-3 * pos + 1e-13);
      EXPECT_NEAR(cl.value[kClosureOrientation], ori, 1e-3 * ori + 1e-13);
      res[k] = std::max(cl.value[kClosurePosition], cl.value[kClosureOrientation]);
      // optimality: the squared error grows in every direction of the fitted pose's tangent space
      const double c0 = cost(sys, plan, qp, vp);
      for (size_t j = 0; j < plan.fit_v.size(); ++j)
        for (double h : {-1e-5, 1e-5}) {
          Eigen::VectorXd dv = Eigen::VectorXd::Zero(sys.model.nv()), qh;
          dv[plan.fit_v[j]] = h;
          qh = qp;
          integrate(sys.model, qp, dv, 1.0, qh);
          EXPECT_GE(cost(sys, plan, qh, vp), c0 * (1 - 1e-9)) << "direction " << j << " step " << h;
        }
      if (k == 0) {
        // the worst residual names a constraint of the scene
        const int s = cl.spec[cl.value[kClosurePosition] > cl.value[kClosureOrientation] ? kClosurePosition : kClosureOrientation];
        ASSERT_GE(s, 0);
        EXPECT_LT(s, static_cast<int>(sys.constraints.specs.size()));
      }
    }
    EXPECT_NEAR(res[1] / res[0], 2.0, 2e-3) << "linear in delta";
  }
}

// A perturbed joint velocity: the twist fit is linear least squares, so the velocity residual is
// exactly (I - G_u G_u^+) G_m v_m.
TEST(StateFit, PerturbedJointVelocityShowsAsTheVelocityResidual) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(std::string(c.scene) + " " + formulation_name(c.f));
    const System sys = load(c.scene, c.f);
    const StateFitPlan plan = plan_state_fit(sys);
    StateFitWorkspace ws(sys, plan);
    std::mt19937 rng(8);
    Eigen::VectorXd q, v;
    closed_state(sys, rng, 0.1, q, v);
    Eigen::VectorXd vp = v;
    const int d0 = plan.fit_v.back() + 1 < sys.model.nv() ? plan.fit_v.back() + 1 : 0;
    vp[d0] += 0.01;
    for (int d : plan.fit_v) vp[d] = 0.0;
    Data dd(sys.model);
    ConstraintData cd(sys.model, sys.constraints);
    forward_kinematics(sys.model, dd, q, vp);
    constraint_rows(sys.model, dd, sys.constraints, q, vp, cd);
    Eigen::MatrixXd Gu(sys.constraints.rows, plan.fit_v.size());
    for (size_t j = 0; j < plan.fit_v.size(); ++j) Gu.col(j) = cd.G.col(plan.fit_v[j]);
    const Eigen::VectorXd r = cd.Gv - Gu * Gu.completeOrthogonalDecomposition().solve(cd.Gv);
    double lin = 0, ang = 0;
    for (int i = 0; i < sys.constraints.rows; ++i) (plan.angular[i] ? ang : lin) = std::max(plan.angular[i] ? ang : lin, std::abs(r[i]));
    Eigen::VectorXd qf = q;
    const Closure& cl = fit_state(sys, plan, ws, false, true, qf, vp);
    EXPECT_GT(lin + ang, 1e-5);
    EXPECT_NEAR(cl.value[kClosureLinearVelocity], lin, 1e-12);
    EXPECT_NEAR(cl.value[kClosureAngularVelocity], ang, 1e-12);
  }
}

// A car: four wheels (r = 0.3 m) at the corners of a 2.6 m x 1.5 m chassis. Its chassis twist
// follows from the wheel spins, its pose does not (it drives anywhere: the pose comes from the
// car's own estimator). The shipped two_wheel_vehicle cannot fit its twist: its rod pitching about
// the axle while the wheels counter-spin leaves every contact still, so its pitch rate must be
// measured (an IMU), and the plan says so.
TEST(StateFit, VehicleTwistFromWheelSpinsPoseFromItsEstimator) {
  const StateFitPlan p2 = plan_state_fit(load("two_wheel_vehicle"));
  EXPECT_FALSE(p2.v_fittable);
  EXPECT_FALSE(p2.q_fittable);
  const System sys = load_scene_string(coopdyn::testing::rigid_car_scene(), "car.yaml");
  const StateFitPlan plan = plan_state_fit(sys);
  EXPECT_FALSE(plan.q_fittable);
  ASSERT_TRUE(plan.v_fittable) << plan.why_not_v;
  StateFitWorkspace ws(sys, plan);
  std::mt19937 rng(2);
  std::normal_distribution<double> n(0, 1);
  for (int trial = 0; trial < 5; ++trial) {
    Eigen::VectorXd v = sys.v0;
    for (int i = 0; i < v.size(); ++i) v[i] = n(rng);
    Data d(sys.model);
    ConstraintData cd(sys.model, sys.constraints);
    forward_kinematics(sys.model, d, sys.q0, v);
    constraint_rows(sys.model, d, sys.constraints, sys.q0, v, cd);
    // a motion that rolls without slip
    v = testing::project_velocity(cd.G, v);
    Eigen::VectorXd q = sys.q0, vf = v;
    for (int k : plan.fit_v) vf[k] = 0.0;
    const Closure& cl = fit_state(sys, plan, ws, false, true, q, vf);
    for (int k : plan.fit_v) EXPECT_NEAR(vf[k], v[k], 1e-12 * (1 + v.norm())) << "trial " << trial;
    EXPECT_LT(cl.value[kClosureLinearVelocity], 1e-12);
    EXPECT_GT(std::abs(v[plan.fit_v[3]]), 1e-3) << "the car moves (straight: with no steering, no slip forbids a turn)";
  }
}

}  // namespace
}  // namespace coopdyn
