// Nothing the loop calls allocates after start-up: evaluate(), compute_wrenches() and step() of every
// scene and every formulation, thousands of times, under a counting heap.
#define COOPDYN_COUNTING_ALLOCATOR_IMPL
#include "tests/support/counting_allocator.h"

#include <gtest/gtest.h>

#include <optional>

#include "service/dynamics/integrators.h"
#include "service/dynamics/contacts.h"
#include "service/dynamics/holding_torque.h"
#include "service/dynamics/sigma/wrench_sigma.h"
#include "service/dynamics/wrenches.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

namespace {
// Inputs prepared before counting: `count` states, every other one at rest (v = 0, spread 0) and the
// others spread by 0.2 (random_state), with random torques.
struct Inputs {
  std::vector<Eigen::VectorXd> q, v, tau;
};
Inputs inputs_at_rest_and_moving(const System& sys, unsigned seed, int count) {
  std::mt19937 rng(seed);
  Inputs in;
  for (int k = 0; k < count; ++k) {
    Eigen::VectorXd q, v;
    random_state(sys, rng, k % 2 ? 0.2 : 0.0, q, v);
    in.q.push_back(q);
    in.v.push_back(v);
    in.tau.push_back(Eigen::VectorXd::Random(sys.model.nv()));
  }
  return in;
}
}  // namespace

TEST(NoAllocation, EvaluateAndStepOfEveryScene) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  for (const auto& name : all_scenes()) {
    for (auto f : {Formulation::kMobilePlatform, Formulation::kClassic, Formulation::kPseudoJointSchur,
                   Formulation::kSvdBaseline}) {
      if (name == "four_bar" && f == Formulation::kMobilePlatform) continue;
      if (name != "four_bar" && f == Formulation::kPseudoJointSchur) continue;
      SCOPED_TRACE(name + " " + formulation_name(f));
      const System sys = load_with_reactions(name, f);  // every wrench output, joint reactions included
      Stepper st(sys);
      WrenchData wd(sys);
      std::mt19937 rng(5);
      const int n = sys.model.nv();
      std::vector<Eigen::VectorXd> qs, vs, taus;  // inputs prepared before counting
      for (int k = 0; k < 16; ++k) {
        Eigen::VectorXd q, v;
        random_state(sys, rng, 0.2, q, v);
        qs.push_back(q);
        vs.push_back(v);
        taus.push_back(Eigen::VectorXd::Random(n));
      }
      Eigen::VectorXd q = sys.q0, v = sys.v0;
      const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
      evaluate(sys, st.ws, q, v, zero);  // warm-up outside the count is not needed, but harmless
      long evals = 0;
      {
        AllocationCounter c;
        for (int k = 0; k < 2000; ++k) {
          evaluate(sys, st.ws, qs[k % 16], vs[k % 16], taus[k % 16]);
          compute_wrenches(sys, st.ws, wd);
          ++evals;
        }
        for (int k = 0; k < 500; ++k) step(sys, st, k % 2 ? Integrator::kRk4 : Integrator::kSemiImplicitEuler, 1e-3, zero, q, v);
        for (int k = 0; k < 5; ++k) step(sys, st, Integrator::kImplicitEuler, 1e-3, zero, q, v);
        EXPECT_EQ(c.count(), 0);
      }
      EXPECT_EQ(evals, 2000);
      EXPECT_TRUE(q.allFinite());
    }
  }
}

// Joint friction and damping on every arm joint of the two-PUMA scene, every formulation: the
// stiction solve at rest (half the states) and the sliding law in motion allocate nothing.
TEST(NoAllocation, EvaluateAndStepWithJointFriction) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  for (auto f : {Formulation::kMobilePlatform, Formulation::kClassic, Formulation::kSvdBaseline}) {
    SCOPED_TRACE(formulation_name(f));
    System sys = load_with_reactions("two_puma_load", f);
    for (Body& b : sys.model.bodies)
      if (b.joint.nv == 1 && b.name.rfind("arm", 0) == 0) {
        b.joint.friction = 2.0;
        b.joint.damping = 0.5;
      }
    Stepper st(sys);
    WrenchData wd(sys);
    Inputs in = inputs_at_rest_and_moving(sys, 7, 16);
    for (int k = 0; k < 16; k += 2) in.v[k].setZero();  // every joint at rest: the stiction solve
    Eigen::VectorXd q = sys.q0, v = sys.v0;
    const Eigen::VectorXd tau = Eigen::VectorXd::Constant(sys.model.nv(), 0.5);
    int at_rest = 0;
    {
      AllocationCounter c;
      for (int k = 0; k < 400; ++k) {
        evaluate(sys, st.ws, in.q[k % 16], in.v[k % 16], in.tau[k % 16]);
        compute_wrenches(sys, st.ws, wd);
        at_rest += st.ws.rest_count;
      }
      for (int k = 0; k < 100; ++k) step(sys, st, Integrator::kRk4, 1e-3, tau, q, v);
      EXPECT_EQ(c.count(), 0);
    }
    EXPECT_GT(at_rest, 0);  // the stiction solve ran
    EXPECT_TRUE(q.allFinite());
  }
}

// The per-arm block solve of Q (dynamics/q_blocks.h): the arms-scaling scenes, where it is the
// default, and forced on the two-arm scenes, including planar_arms_load (classic), whose dependent
// rows make it fall back to the dense Q and the rank-revealing solve at every state.
TEST(NoAllocation, BlockSolveOfQAndItsFallback) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  struct Case {
    std::string path;
    std::optional<Formulation> f;
    bool blocks;         // the block factorization succeeds
    bool dense = false;  // the dense path (not the blocks) is asked for
  };
  const std::string arms = std::string(COOPDYN_SOURCE_DIR) + "/bench/scenes/pumas_";
  for (const Case& c : {Case{arms + "4.yaml", std::nullopt, true}, Case{arms + "8.yaml", std::nullopt, true},
                        Case{scene_path("two_puma_load"), Formulation::kClassic, true},
                        Case{scene_path("planar_arms_load"), Formulation::kClassic, false},
                        // nominal base links (joint 1 without armature): the reduced Q's factor too
                        Case{arms + "8_no_armature.yaml", std::nullopt, true},
                        Case{scene_path("planar_arms_load"), Formulation::kMobilePlatform, false},
                        // the dense path's single factor with the nominal directions last
                        Case{arms + "2_no_armature.yaml", std::nullopt, false, true}}) {
    SCOPED_TRACE(c.path);
    SceneOverrides ov;
    ov.formulation = c.f;
    const System sys = load_scene(c.path, ov);
    Stepper st(sys);
    ASSERT_TRUE(st.ws.qb.usable);
    st.ws.use_q_blocks = !c.dense;
    WrenchData wd(sys);
    std::mt19937 rng(5);
    std::vector<Eigen::VectorXd> qs, vs;
    for (int k = 0; k < 8; ++k) {
      Eigen::VectorXd q, v;
      random_state(sys, rng, 0.2, q, v);
      qs.push_back(q);
      vs.push_back(v);
    }
    Eigen::VectorXd q = sys.q0, v = sys.v0;
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(sys.model.nv());
    int by_blocks = 0, by_nominal_last = 0;
    {
      AllocationCounter counter;
      for (int k = 0; k < 400; ++k) {
        evaluate(sys, st.ws, qs[k % 8], vs[k % 8], zero);
        by_blocks += st.ws.q_blocks_active ? 1 : 0;
        by_nominal_last += st.ws.qs.nominal_active ? 1 : 0;
        compute_wrenches(sys, st.ws, wd);
      }
      for (int k = 0; k < 100; ++k) step(sys, st, Integrator::kRk4, 1e-3, zero, q, v);
      EXPECT_EQ(counter.count(), 0);
    }
    EXPECT_EQ(by_blocks, c.blocks ? 400 : 0);
    EXPECT_EQ(by_nominal_last, c.dense ? 400 : 0);
    EXPECT_TRUE(q.allFinite());
  }
}

TEST(NoAllocation, EvaluateAndStepOfTheWheelScenes) {
  // rolling constraints (the vehicle on its rank-deficient path), mobile platform and SVD baseline
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  for (const auto& name : wheel_scenes()) {
    for (auto f : {Formulation::kMobilePlatform, Formulation::kSvdBaseline}) {
      SCOPED_TRACE(name + " " + formulation_name(f));
      const System sys = load_with_reactions(name, f);
      Stepper st(sys);
      WrenchData wd(sys);
      ContactData cts(sys);
      const int n = sys.model.nv();
      const Inputs in = inputs_at_rest_and_moving(sys, 6, 16);
      const auto& qs = in.q;
      const auto& vs = in.v;
      const auto& taus = in.tau;
      Eigen::VectorXd q = sys.q0, v = sys.v0, tau = Eigen::VectorXd::Zero(n);
      if (n > 6) tau[6] = 1.0;  // the vehicle's left drive torque
      {
        AllocationCounter c;
        for (int k = 0; k < 2000; ++k) {
          evaluate(sys, st.ws, qs[k % 16], vs[k % 16], taus[k % 16]);
          compute_wrenches(sys, st.ws, wd);  // the vehicle: axles, and the null-space pass (rank 5 of 6)
          compute_contacts(sys, st.ws, cts);
        }
        for (int k = 0; k < 500; ++k) step(sys, st, k % 2 ? Integrator::kRk4 : Integrator::kSemiImplicitEuler, 1e-3, tau, q, v);
        EXPECT_EQ(c.count(), 0);
      }
      EXPECT_TRUE(q.allFinite());
    }
  }
}

TEST(NoAllocation, EvaluateStepAndHoldOfTheRealRobots) {
  // whole URDF trees (36 and 45 DOF) with mimic couplings, grasps and, for TIAGo Pro, four wheels;
  // the holding torques too (the daemon's safe torque when no command arrives)
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  for (const std::string name : {"pr2_box", "tiago_pro_box"}) {
    SCOPED_TRACE(name);
    const System sys = load_with_reactions(name, Formulation::kMobilePlatform);
    Stepper st(sys);
    WrenchData wd(sys);
    ContactData cts(sys);
    HoldWorkspace hw(sys, default_actuated(sys));
    const int n = sys.model.nv();
    const Inputs in = inputs_at_rest_and_moving(sys, 7, 8);
    const auto& qs = in.q;
    const auto& vs = in.v;
    const auto& taus = in.tau;
    Eigen::VectorXd q = sys.q0, v = sys.v0, tau = Eigen::VectorXd::Zero(n);
    {
      AllocationCounter c;
      for (int k = 0; k < 200; ++k) {
        evaluate(sys, st.ws, qs[k % 8], vs[k % 8], taus[k % 8]);
        compute_wrenches(sys, st.ws, wd);
        compute_contacts(sys, st.ws, cts);
      }
      for (int k = 0; k < 20; ++k) holding_torque(sys, hw, qs[k % 8], vs[k % 8], tau);
      for (int k = 0; k < 50; ++k) step(sys, st, k % 2 ? Integrator::kRk4 : Integrator::kSemiImplicitEuler, 1e-3, tau, q, v);
      EXPECT_EQ(c.count(), 0);
    }
    EXPECT_TRUE(q.allFinite());
  }
}

TEST(NoAllocation, WrenchSigmaOfNoisyScenes) {
  // each wrench's sigma from declared torque noise and from q and v noise (wrench_sigma.h): closed chains on both fast
  // paths (Cholesky, the block solve of 4 arms, with and without armature: the nominal rows last),
  // the planar pair (rank path), the car with rolling
  // resistance (the fixed point), every joint reaction
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  const std::string arms = std::string(COOPDYN_SOURCE_DIR) + "/bench/scenes/pumas_4.yaml";
  const std::string nominal = std::string(COOPDYN_SOURCE_DIR) + "/bench/scenes/pumas_4_no_armature.yaml";
  struct Case {
    std::string path, extra;
    std::optional<Formulation> f;
  };
  for (const Case& c : {Case{scene_path("two_puma_load"), "", std::nullopt}, Case{scene_path("two_puma_load"), "", Formulation::kClassic},
                        Case{scene_path("planar_arms_load"), "", std::nullopt}, Case{arms, "", std::nullopt}, Case{nominal, "", std::nullopt},
                        Case{scene_path("four_wheel_car"), "mu: 0.85, rolling_resistance: 0.02}", std::nullopt}}) {
    SCOPED_TRACE(c.path);
    SceneOverrides ov;
    ov.formulation = c.f;
    std::string text = without_reactions(slurp(c.path));
    if (!c.extra.empty()) text = replace_once(text, "mu: 0.85}", c.extra);
    // torque noise, and the measured joints' position and velocity noise (estimate mode's columns)
    const System sys = load_scene_string(text + "\nreactions: all\nnoise: {tau: 0.2, q: 1e-4, v: 1e-3}\n", c.path, ov);
    Workspace ws(sys);
    WrenchData wd(sys);
    WrenchSigmaData sd(sys), sa(sys), sk(sys);  // sa, sk: the arm form from two arms (wrench_sigma_arms.h), sk keeping C
    sa.arms_min = sk.arms_min = 2;
    sk.keep_C = true;
    ASSERT_TRUE(sd.declared);
    const Inputs in = inputs_at_rest_and_moving(sys, 8, 16);
    int arm_form = 0;
    {
      AllocationCounter cnt;
      for (int k = 0; k < 500; ++k) {
        evaluate(sys, ws, in.q[k % 16], in.v[k % 16], in.tau[k % 16]);
        compute_wrenches(sys, ws, wd);
        compute_wrench_sigma(sys, ws, sd);
        compute_wrench_sigma(sys, ws, sa);
        compute_wrench_sigma(sys, ws, sk);
        arm_form += sa.arms_used && sk.arms_used;
        compute_wrench_sigma(sys, ws, sd, in.q[k % 16], in.v[k % 16], in.tau[k % 16]);
      }
      EXPECT_EQ(cnt.count(), 0);
    }
    if (c.path == arms || c.path == nominal) {
      EXPECT_GT(arm_form, 0);
    }
    EXPECT_TRUE(sd.valid);
    if (c.path == nominal) {
      EXPECT_TRUE(ws.q_blocks_active && ws.qb.has_nominal);
    }
    // (over-constrained evaluations have no position columns: wrench_sigma.h)
    EXPECT_EQ(sd.source, WrenchSigmaData::kTau | WrenchSigmaData::kV | (ws.diag.indeterminate > 0 ? 0 : WrenchSigmaData::kQ));
  }
}

TEST(NoAllocation, TheCounterSeesEigenAndStdAllocations) {
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  AllocationCounter c;
  Eigen::VectorXd x(1000);
  x.setOnes();
  std::vector<int> v(10);
  EXPECT_GE(c.count(), 2);
  EXPECT_EQ(x.sum() + v.size(), 1010);
}

TEST(NoAllocation, RollingResistanceAndTheContactReport) {
  // the car with rolling resistance: the fixed-point iterations on the factored Q, the contact
  // report, and steps with projection
  if (!kCountingAvailable) GTEST_SKIP() << "the counting heap is unavailable under AddressSanitizer";
  const System sys = load_scene_string(replace_once(scene_text("four_wheel_car"), "mu: 0.85}", "mu: 0.85, rolling_resistance: 0.012}"),
                                       scene_path("four_wheel_car"));
  Stepper st(sys);
  WrenchData wd(sys);
  ContactData cts(sys);
  const int n = sys.model.nv();
  Eigen::VectorXd q = sys.q0, v = Eigen::VectorXd::Zero(n), tau = Eigen::VectorXd::Zero(n);
  v[3] = 15.0;
  for (const char* w : {"fl_spin", "fr_spin", "rl_spin", "rr_spin"}) v[velocity_index_of(sys, w)] = 15.0 / 0.31;
  {
    AllocationCounter c;
    for (int k = 0; k < 500; ++k) {
      step(sys, st, Integrator::kRk4, 1e-3, tau, q, v);
      compute_wrenches(sys, st.ws, wd);
      compute_contacts(sys, st.ws, cts);
    }
    EXPECT_EQ(c.count(), 0);
  }
  EXPECT_GT(st.ws.rr_iterations, 1);
  EXPECT_LT(v[3], 15.0);  // it slowed
}
