// The uncertainty of every reported wrench from declared torque noise (service/dynamics/sigma/wrench_sigma.h):
// its response matrix against finite differences of whole evaluations, its standard deviations
// against Monte Carlo, and the scene key `noise`.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "service/dynamics/sigma/wrench_sigma.h"
#include "tests/support/sigma_monte_carlo.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {

// A shipped scene with every joint reaction and the noise declaration `noise` appended.
System noisy(const std::string& name, const std::string& noise, std::optional<Formulation> f = std::nullopt,
             const std::string& extra = "") {
  SceneOverrides ov;
  ov.formulation = f;
  return load_scene_string(without_reactions(scene_text(name)) + "\nreactions: all\nnoise: " + noise + "\n" + extra,
                           scene_path(name), ov);
}

// A state near q0 (the constraints hold to first order: enough for an affine map at a fixed state)
// and random torques on the actuated DOFs.
void some_state(const System& sys, unsigned seed, Eigen::VectorXd& q, Eigen::VectorXd& v, Eigen::VectorXd& tau) {
  std::mt19937 rng(seed);
  q = sys.q0;
  v = sys.v0;
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (int i = 0; i < sys.model.nv(); ++i) v[i] += 0.3 * U(rng);
  tau = Eigen::VectorXd::Zero(sys.model.nv());
  for (int i = 0; i < sys.model.nv(); ++i)
    if (sys.tau_limit[i] > 0 && std::isfinite(sys.tau_limit[i])) tau[i] = 5.0 * U(rng);
}

struct Case {
  std::string scene, noise;
  std::optional<Formulation> f;
  std::string extra;
};
std::vector<Case> cases() {
  return {{"two_puma_load", "{tau: 0.2, joints: {arm1.q2: 1.5}}", std::nullopt, ""},  // closed chain, mobile platform
          {"two_puma_load", "{tau: 0.2}", Formulation::kClassic, ""},
          {"two_iiwa_load", "{tau: 0.3}", std::nullopt, ""},
          {"planar_arms_load", "{tau: 0.1}", std::nullopt, ""},                     // over-constrained (planar)
          {"four_wheel_car", "{tau: 2.0}", std::nullopt, ""},                         // wheels, axles, steer locks
          {"four_wheel_car", "{tau: 2.0}", std::nullopt, "ground: {rolling_resistance: 0.02}\n"},
          {"two_wheel_vehicle", "{tau: 1.0}", std::nullopt, ""},
          {"four_bar", "{tau: 0.5}", std::nullopt, ""}};
}
std::string without_ground(std::string t, const std::string& extra) {
  if (extra.empty()) return t;
  const auto p = t.find("\nground:");
  if (p != std::string::npos) t.erase(p, t.find('\n', p + 1) - p);
  return t;
}
System load_case(const Case& c) {
  SceneOverrides ov;
  ov.formulation = c.f;
  const std::string t = without_ground(without_reactions(scene_text(c.scene)), c.extra);
  return load_scene_string(t + "\nreactions: all\nnoise: " + c.noise + "\n" + c.extra, scene_path(c.scene), ov);
}

// Column j of C / S_j is d w / d tau_j: the wrenches are affine in tau at a fixed state, so a central
// difference of two whole evaluations (step 1 N m) is exact up to round-off.
TEST(WrenchSigma, ResponseMatchesFiniteDifferencesOfWholeEvaluations) {
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.scene + " " + c.noise + " " + c.extra + (c.f ? formulation_name(*c.f) : ""));
    const System sys = load_case(c);
    Workspace ws(sys);
    WrenchData wd(sys), wp(sys), wm(sys);
    WrenchSigmaData sd(sys);
    ASSERT_TRUE(sd.declared);
    Eigen::VectorXd q, v, tau;
    some_state(sys, 3, q, v, tau);
    ASSERT_NE(evaluate(sys, ws, q, v, tau).status, Status::kError);
    compute_wrenches(sys, ws, wd);
    compute_wrench_sigma(sys, ws, sd);
    ASSERT_TRUE(sd.valid);
    const size_t no = sys.wrenches.outputs.size();
    double worst = 0.0, scale = 0.0;
    for (size_t j = 0; j < sd.dofs.size(); ++j) {
      const double h = 1.0;
      Eigen::VectorXd tp = tau, tm = tau;
      tp[sd.dofs[j]] += h;
      tm[sd.dofs[j]] -= h;
      evaluate(sys, ws, q, v, tp);
      compute_wrenches(sys, ws, wp);
      evaluate(sys, ws, q, v, tm);
      compute_wrenches(sys, ws, wm);
      for (size_t k = 0; k < no; ++k)
        for (int i = 0; i < 6; ++i) {
          const double fd = (wp.W[k][i] - wm.W[k][i]) / (2 * h);
          const double an = sd.C(static_cast<Eigen::Index>(6 * k + i), static_cast<Eigen::Index>(j)) / sd.S[j];
          worst = std::max(worst, std::abs(fd - an));
          scale = std::max(scale, std::abs(an));
          EXPECT_NEAR(an, fd, 1e-7 * std::max(1.0, std::abs(fd)))
              << sys.wrenches.outputs[k].name << " component " << i << " tau " << sys.model.v_names[sd.dofs[j]];
        }
    }
    EXPECT_GT(scale, 0.0);  // something responds
    // sigma is the row norm of C
    for (size_t k = 0; k < no; ++k)
      for (int i = 0; i < 6; ++i)
        EXPECT_DOUBLE_EQ(sd.sigma[k][i], sd.C.row(static_cast<Eigen::Index>(6 * k + i)).norm());
  }
}

// 300 evaluations with torques drawn from the declared noise: each component's sample variance
// s^2 against sigma^2. For n normal samples (n - 1) s^2 / sigma^2 is chi-square with n - 1 degrees
// of freedom, relative standard deviation sqrt(2 / (n - 1)) = 0.082; the bound is 5 of those.
// Components without noise (sigma 0: a direction no noisy torque reaches) vary by round-off only.
TEST(WrenchSigma, MonteCarloReproducesEachComponentsStandardDeviation) {
  for (const Case& c : {cases()[0], cases()[4], cases()[3]}) {
    SCOPED_TRACE(c.scene);
    const System sys = load_case(c);
    Workspace ws(sys);
    WrenchData wd(sys);
    WrenchSigmaData sd(sys);
    Eigen::VectorXd q, v, tau;
    some_state(sys, 5, q, v, tau);
    evaluate(sys, ws, q, v, tau);
    compute_wrenches(sys, ws, wd);
    compute_wrench_sigma(sys, ws, sd);
    ASSERT_TRUE(sd.valid);
    const size_t no = sys.wrenches.outputs.size();
    const int n = 300;
    std::mt19937 rng(11);
    std::normal_distribution<double> N01(0.0, 1.0);
    Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(6 * no, 1), sum2 = sum;
    std::vector<Vec6> W0 = wd.W;
    double wmax = 0.0;
    for (const Vec6& w : W0) wmax = std::max(wmax, w.cwiseAbs().maxCoeff());
    for (int s = 0; s < n; ++s) {
      Eigen::VectorXd t = tau;
      for (size_t j = 0; j < sd.dofs.size(); ++j) t[sd.dofs[j]] += sd.S[static_cast<Eigen::Index>(j)] * N01(rng);
      evaluate(sys, ws, q, v, t);
      compute_wrenches(sys, ws, wd);
      for (size_t k = 0; k < no; ++k)
        for (int i = 0; i < 6; ++i) {
          const double x = wd.W[k][i] - W0[k][i];
          sum(6 * k + i) += x;
          sum2(6 * k + i) += x * x;
        }
    }
    const double tol = 5.0 * std::sqrt(2.0 / (n - 1));
    int compared = 0;
    for (size_t k = 0; k < no; ++k)
      for (int i = 0; i < 6; ++i) {
        const double mean = sum(6 * k + i) / n;
        const double var = (sum2(6 * k + i) - n * mean * mean) / (n - 1);
        const double sg = sd.sigma[k][i];
        if (sg < 1e-9 * (1.0 + wmax)) {
          EXPECT_LT(std::sqrt(std::max(var, 0.0)), 1e-8 * (1.0 + wmax)) << sys.wrenches.outputs[k].name << " " << i;
          continue;
        }
        ++compared;
        EXPECT_NEAR(var / (sg * sg), 1.0, tol) << sys.wrenches.outputs[k].name << " component " << i;
      }
    EXPECT_GT(compared, 6);
  }
}

// Joint reactions included: the axial component of a joint's reaction carries that joint's own
// torque (minus its armature term), so its sigma is at least of the order of the joint's noise.
TEST(WrenchSigma, JointReactionsAndTipsCarrySigma) {
  const System sys = noisy("two_puma_load", "{tau: 0.2}");
  Workspace ws(sys);
  WrenchData wd(sys);
  WrenchSigmaData sd(sys);
  evaluate(sys, ws, sys.q0, sys.v0, Eigen::VectorXd::Zero(sys.model.nv()));
  compute_wrenches(sys, ws, wd);
  compute_wrench_sigma(sys, ws, sd);
  ASSERT_TRUE(sd.valid);
  int joints = 0, ends = 0;
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k) {
    const WrenchOutput& o = sys.wrenches.outputs[k];
    EXPECT_TRUE(sd.sigma[k].allFinite());
    if (o.kind == WrenchKind::kJoint) {
      ++joints;
      EXPECT_GT(sd.sigma[k].norm(), 0.0) << o.name;
    }
    if (o.kind == WrenchKind::kEndEffector) {
      ++ends;
      EXPECT_GT(sd.sigma[k].tail<3>().norm(), 0.0) << o.name;
    }
  }
  EXPECT_GT(joints, 6);
  EXPECT_EQ(ends, 2);
}

// Nothing declared: nothing computed, sigma zero, valid false. A formulation without sigma
// (pseudo_joint, svd): valid false.
TEST(WrenchSigma, AbsentOrUnsupportedSaysSo) {
  const System plain = load_with_reactions("two_puma_load");
  WrenchSigmaData none(plain);
  EXPECT_FALSE(none.declared);
  Workspace ws(plain);
  evaluate(plain, ws, plain.q0, plain.v0, Eigen::VectorXd::Zero(plain.model.nv()));
  compute_wrench_sigma(plain, ws, none);
  EXPECT_FALSE(none.valid);
  EXPECT_EQ(plain.tau_noise.size(), plain.model.nv());
  EXPECT_EQ(plain.tau_noise.cwiseAbs().sum(), 0.0);
  const System svd = noisy("two_puma_load", "{tau: 0.2}", Formulation::kSvdBaseline);
  Workspace w2(svd);
  WrenchSigmaData s2(svd);
  EXPECT_FALSE(s2.declared);  // no sigma columns either (step_schema)
  evaluate(svd, w2, svd.q0, svd.v0, Eigen::VectorXd::Zero(svd.model.nv()));
  compute_wrench_sigma(svd, w2, s2);
  EXPECT_FALSE(s2.valid);
  for (const Vec6& s : s2.sigma) EXPECT_EQ(s.norm(), 0.0);
}

// Joints at rest have their friction free within its bound (the separate interval of
// friction_bound.h): sigma is the spread with it left free, the frictionless scene's, while stiction
// holds them; when every joint slides (friction of fixed size, opposing the motion) the response to
// tau is the frictionless one too.
TEST(WrenchSigma, WhileStictionHoldsAJointAndWhileSlidingTheFrictionlessOne) {
  System sys = noisy("two_puma_load", "{tau: 0.2}");
  const System plain = noisy("two_puma_load", "{tau: 0.2}");
  for (Body& b : sys.model.bodies)
    if (b.joint.nv == 1 && !b.joint.pseudo) b.joint.friction = 2.0;
  Workspace ws(sys), wp(plain);
  WrenchSigmaData sd(sys), sp(plain);
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
  evaluate(sys, ws, sys.q0, sys.v0, tau);
  evaluate(plain, wp, plain.q0, plain.v0, tau);
  ASSERT_GT(ws.friction_stuck, 0);
  compute_wrench_sigma(sys, ws, sd);
  compute_wrench_sigma(plain, wp, sp);
  ASSERT_TRUE(sd.valid && sp.valid);
  for (size_t k = 0; k < sd.sigma.size(); ++k)
    EXPECT_LE((sd.sigma[k] - sp.sigma[k]).norm(), 1e-9 * (1 + sp.sigma[k].norm())) << k;
  // every friction joint moving: sigma equals the frictionless scene's
  Eigen::VectorXd v = sys.v0;
  for (int d : ws.friction_dofs) v[d] = v[d] + 0.3;  // not a closing velocity: the map at a state is all we need
  evaluate(sys, ws, sys.q0, v, tau);
  evaluate(plain, wp, plain.q0, v, tau);
  ASSERT_EQ(ws.friction_stuck, 0);
  compute_wrench_sigma(sys, ws, sd);
  compute_wrench_sigma(plain, wp, sp);
  ASSERT_TRUE(sd.valid && sp.valid);
  for (size_t k = 0; k < sd.sigma.size(); ++k)
    EXPECT_LE((sd.sigma[k] - sp.sigma[k]).norm(), 1e-9 * (1 + sp.sigma[k].norm())) << k;
}

// `noise`: every actuated DOF gets tau, a joint's own value overrides it, unactuated DOFs none.
TEST(WrenchSigma, SceneKeyNoise) {
  const System sys = noisy("two_puma_load", "{tau: 0.2, joints: {arm2.q3: 0.7, arm1.q1: 0}}");
  for (int i = 0; i < sys.model.nv(); ++i) {
    const std::string& nm = sys.model.v_names[i];
    const bool act = sys.tau_limit[i] > 0 && sys.model.bodies[sys.model.dof_body[i]].joint.type != JointType::kFloating;
    const double want = nm == "arm2.q3" ? 0.7 : nm == "arm1.q1" ? 0.0 : act ? 0.2 : 0.0;
    EXPECT_EQ(sys.tau_noise[i], want) << nm;
  }
  const std::string t = without_reactions(scene_text("two_puma_load"));
  const int line = static_cast<int>(std::count(t.begin(), t.end(), '\n')) + 2;  // the appended noise line
  auto err = [&](const std::string& noise) {
    try {
      load_scene_string(t + "\nnoise: " + noise + "\n", scene_path("s"));  // beside the robot files
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("(loaded)");
  };
  const std::string at = "/s.yaml:" + std::to_string(line) + ":";
  EXPECT_NE(err("{tau: -0.1}").find(at), std::string::npos) << err("{tau: -0.1}");
  EXPECT_NE(err("{tau: -0.1}").find(">= 0"), std::string::npos);
  EXPECT_NE(err("{tau: .nan}").find(at), std::string::npos) << err("{tau: .nan}");
  EXPECT_NE(err("{tau: .inf}").find(at), std::string::npos) << err("{tau: .inf}");
  EXPECT_NE(err("{tau: 0.1, joints: {arm9.q1: 1}}").find("unknown joint 'arm9.q1'"), std::string::npos);
  EXPECT_NE(err("{tau: 0.1, joints: {arm9.q1: 1}}").find(at), std::string::npos);
  EXPECT_NE(err("{tau: 0.1, joints: {load.wx: 1}}").find("not actuated"), std::string::npos) << err("{tau: 0.1, joints: {load.wx: 1}}");
  EXPECT_NE(err("{tau: 0.1, qq: 0.01}").find(at), std::string::npos) << err("{tau: 0.1, qq: 0.01}");
  EXPECT_NE(err("{q: -1e-3}").find(at), std::string::npos) << err("{q: -1e-3}");
  EXPECT_NE(err("{v: .nan}").find(at), std::string::npos) << err("{v: .nan}");
  EXPECT_NE(err("{joints: {load.wx: {v: 0.1}}}").find("not a measured 1-DOF joint"), std::string::npos)
      << err("{joints: {load.wx: {v: 0.1}}}");
  EXPECT_NE(err("{joints: {arm1.q1: {tau: 1, w: 2}}}").find(at), std::string::npos) << err("{joints: {arm1.q1: {tau: 1, w: 2}}}");
  EXPECT_NE(err("0.1").find("mapping"), std::string::npos);
}

// `noise: {q, v}`: every measured 1-DOF joint (not the load's floating joint, not a pseudo-joint)
// gets them, a joint's own {tau, q, v} overrides them.
TEST(WrenchSigma, SceneKeyStateNoise) {
  const System sys = noisy("two_puma_load", "{q: 1e-4, v: 2e-3, joints: {arm2.q3: {q: 5e-4, tau: 0.3}, arm1.q1: {v: 0}}}");
  for (int i = 0; i < sys.model.nv(); ++i) {
    const std::string& nm = sys.model.v_names[i];
    const bool meas = sys.model.bodies[sys.model.dof_body[i]].joint.type != JointType::kFloating;
    EXPECT_EQ(sys.q_noise[i], nm == "arm2.q3" ? 5e-4 : meas ? 1e-4 : 0.0) << nm;
    EXPECT_EQ(sys.v_noise[i], nm == "arm1.q1" ? 0.0 : meas ? 2e-3 : 0.0) << nm;
    EXPECT_EQ(sys.tau_noise[i], nm == "arm2.q3" ? 0.3 : 0.0) << nm;
  }
  WrenchSigmaData sd(sys);
  EXPECT_TRUE(sd.declared);
  EXPECT_EQ(sd.dofs.size(), 1u);
  EXPECT_EQ(sd.q_dofs.size(), 12u);
  EXPECT_EQ(sd.v_dofs.size(), 11u);
}

// The measurement-noise columns against whole evaluations: column j / S_j is d w / d x_j at the
// state, here by central differences of two full evaluate() + compute_wrenches() (step 1e-4: their
// truncation error ~1e-8 relative, their round-off ~1e-12 |w| / 1e-4). The position columns' own
// forward step (1e-7) leaves O(1e-7 |d2w/dx2|): up to 8e-5 on the iiwa pair, hence the bound 1e-4
// (the velocity columns are exact tangents: wrench_sigma_velocity_test.cc).
TEST(WrenchSigma, StateNoiseColumnsMatchWholeEvaluations) {
  for (const Case& c : {Case{"two_puma_load", "{q: 1e-3, v: 1e-2}", std::nullopt, ""},
                        Case{"two_iiwa_load", "{tau: 0.3, q: 1e-3, v: 1e-2}", std::nullopt, ""},  // URDF damping
                        Case{"two_puma_load", "{q: 1e-3, v: 1e-2}", Formulation::kClassic, ""},
                        Case{"planar_arms_load", "{q: 1e-3, v: 1e-2}", std::nullopt, ""},
                        Case{"four_wheel_car", "{tau: 1, q: 1e-3, v: 1e-2}", std::nullopt, "ground: {rolling_resistance: 0.02}\n"}}) {
    SCOPED_TRACE(c.scene + " " + c.noise + (c.f ? formulation_name(*c.f) : ""));
    const System sys = load_case(c);
    Workspace ws(sys);
    WrenchData wp(sys), wm(sys);
    WrenchSigmaData sd(sys);
    Eigen::VectorXd q, v, tau;
    some_state(sys, 7, q, v, tau);
    ASSERT_NE(evaluate(sys, ws, q, v, tau).status, Status::kError);
    compute_wrench_sigma(sys, ws, sd, q, v, tau);
    ASSERT_TRUE(sd.valid);
    // over-constrained (the planar pair, the car's four wheels): no position columns (the rule's
    // null space turns with q)
    const bool indet = ws.diag.indeterminate > 0;
    EXPECT_EQ(indet, c.scene == "planar_arms_load" || c.scene == "four_wheel_car");
    const int na = static_cast<int>(sd.dofs.size()), nq = indet ? 0 : static_cast<int>(sd.q_dofs.size());
    EXPECT_EQ(sd.source, (na ? WrenchSigmaData::kTau : 0) | (indet ? 0 : WrenchSigmaData::kQ) | WrenchSigmaData::kV);
    ASSERT_EQ(sd.ncols, na + nq + static_cast<int>(sd.v_dofs.size()));
    double scale = 0.0;
    for (int j = na; j < sd.ncols; ++j) {
      const bool is_q = j < na + nq;
      const int d = is_q ? sd.q_dofs[j - na] : sd.v_dofs[j - na - nq];
      const double S = is_q ? sd.Sq[j - na] : sd.Sv[j - na - nq];
      const double h = 1e-4;
      Eigen::VectorXd qp = q, qm = q, vp = v, vm = v;
      if (is_q) {
        qp[sd.q_index[j - na]] += h;
        qm[sd.q_index[j - na]] -= h;
      } else {
        vp[d] += h;
        vm[d] -= h;
      }
      evaluate(sys, ws, qp, vp, tau);
      compute_wrenches(sys, ws, wp);
      evaluate(sys, ws, qm, vm, tau);
      compute_wrenches(sys, ws, wm);
      for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k)
        for (int i = 0; i < 6; ++i) {
          const double fd = (wp.W[k][i] - wm.W[k][i]) / (2 * h);
          const double an = sd.C(static_cast<Eigen::Index>(6 * k + i), j) / S;
          scale = std::max(scale, std::abs(an));
          EXPECT_NEAR(an, fd, 1e-4 * std::max(1.0, std::abs(fd)))
              << sys.wrenches.outputs[k].name << " component " << i << (is_q ? " q " : " v ") << sys.model.v_names[d];
        }
    }
    EXPECT_GT(scale, 0.0);
  }
}

// 300 evaluations at states drawn from the declared position and velocity noise (every measured
// joint at once) against sigma. The noise is small (S_q = 1e-4 rad, S_v = 1e-3 rad/s), where the
// wrenches are nearly linear: the linearization error, measured on every draw as
// |w(x + dx) - w(x) - C z| (z the draw in standard deviations; second order, ~ S^2 |d2w/dx2|), is
// bounded by 2e-2 of the largest sigma (7e-3 measured on the PUMA pair), which moves a variance by
// a few percent at most: far inside the sampling error of the variance (chi-square, 5 standard
// deviations: 0.41 relative), the bound asserted on the variance.
TEST(WrenchSigma, MonteCarloReproducesStateNoiseSigma) {
  for (const Case& c : {Case{"two_puma_load", "{q: 1e-4, v: 1e-3}", std::nullopt, ""},
                        Case{"two_iiwa_load", "{tau: 0.2, q: 1e-4, v: 1e-3}", std::nullopt, ""}}) {
    SCOPED_TRACE(c.scene);
    const System sys = load_case(c);
    Workspace ws(sys);
    WrenchData wd(sys);
    WrenchSigmaData sd(sys);
    Eigen::VectorXd q, v, tau;
    some_state(sys, 5, q, v, tau);
    evaluate(sys, ws, q, v, tau);
    compute_wrenches(sys, ws, wd);
    compute_wrench_sigma(sys, ws, sd, q, v, tau);
    ASSERT_TRUE(sd.valid);
    const std::vector<Vec6> W0 = wd.W;
    const size_t no = W0.size();
    const int n = 300;
    NoiseDraws draws(sd.ncols, 13);
    WrenchMoments mom(no);
    const double smax = largest_sigma(sd);
    for (int s = 0; s < n; ++s) {
      const Eigen::VectorXd& z = draws.next();
      Eigen::VectorXd qs = q, vs = v, ts = tau;
      apply_noise_draw(sd, z, qs, vs, ts);
      ASSERT_NE(evaluate(sys, ws, qs, vs, ts).status, Status::kError);
      compute_wrenches(sys, ws, wd);
      mom.add(wd.W, W0, sd.C.leftCols(sd.ncols) * z);
    }
    const double lin_err = mom.lin_err;
    EXPECT_LT(lin_err, 2e-2 * smax);  // the linearization error, stated above
    const double tol = 5.0 * std::sqrt(2.0 / (n - 1));
    int compared = 0;
    for (size_t k = 0; k < no; ++k)
      for (int i = 0; i < 6; ++i) {
        const double mean = mom.sum[6 * k + i] / n;
        const double var = (mom.sum2[6 * k + i] - n * mean * mean) / (n - 1);
        const double sg = sd.sigma[k][i];
        if (sg < 1e-6 * smax) continue;
        ++compared;
        EXPECT_NEAR(var / (sg * sg), 1.0, tol) << sys.wrenches.outputs[k].name << " component " << i;
      }
    EXPECT_GT(compared, 30);
  }
}

// Simulate mode (the state is exact): the torque noise only, whatever q and v noise is declared;
// a scene that declares only q and v noise then has no sigma.
TEST(WrenchSigma, SimulateModeCarriesTorqueNoiseOnly) {
  const System both = noisy("two_puma_load", "{tau: 0.2, q: 1e-3, v: 1e-2}");
  const System tau_only = noisy("two_puma_load", "{tau: 0.2}");
  const System state_only = noisy("two_puma_load", "{q: 1e-3}");
  Workspace w1(both), w2(tau_only), w3(state_only);
  WrenchSigmaData s1(both), s2(tau_only), s3(state_only);
  Eigen::VectorXd q, v, tau;
  some_state(both, 3, q, v, tau);
  evaluate(both, w1, q, v, tau);
  evaluate(tau_only, w2, q, v, tau);
  evaluate(state_only, w3, q, v, tau);
  compute_wrench_sigma(both, w1, s1);
  compute_wrench_sigma(tau_only, w2, s2);
  compute_wrench_sigma(state_only, w3, s3);
  ASSERT_TRUE(s1.valid && s2.valid);
  EXPECT_EQ(s1.source, WrenchSigmaData::kTau);
  for (size_t k = 0; k < s1.sigma.size(); ++k) EXPECT_EQ(s1.sigma[k], s2.sigma[k]) << k;
  EXPECT_TRUE(s3.declared);
  EXPECT_FALSE(s3.valid);
  EXPECT_EQ(s3.source, 0);
  // estimate mode adds the measurement noise: every component's variance grows by its own share
  compute_wrench_sigma(both, w1, s1, q, v, tau);
  EXPECT_EQ(s1.source, WrenchSigmaData::kTau | WrenchSigmaData::kQ | WrenchSigmaData::kV);
  int grew = 0;
  for (size_t k = 0; k < s1.sigma.size(); ++k)
    for (int i = 0; i < 6; ++i) {
      EXPECT_GE(s1.sigma[k][i], s2.sigma[k][i] * (1 - 1e-12));
      grew += s1.sigma[k][i] > s2.sigma[k][i] * (1 + 1e-6);
    }
  EXPECT_GT(grew, 30);
}

}  // namespace
}  // namespace coopdyn::testing
