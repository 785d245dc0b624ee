// The fast path of each wrench's sigma (service/dynamics/sigma/wrench_sigma.cc) against its previous
// definition (wrench_sigma_reference.cc): on every shipped scene with every joint reaction reported
// and noise declared on every joint (torque, position, velocity), in both modes and both
// formulations, the square root C of each covariance, the sigmas and what they contain agree to
// 1e-10 relative to the largest entry of each output's block, or to 1e-13 of the largest entry of C
// for a block that is zero but for round-off (a reaction nothing loads: 1e-23 against 2e-14 seen on
// the TIAGo's base), the two differing only in the order of the floating-point operations (and,
// in the velocity columns, the fast path's tangents against the reference's central differences,
// exact for those terms but for round-off: wrench_sigma_velocity_test.cc; in the position columns
// that are tangents, against its five-point central differences of step 1e-3, truncation ~1e-12:
// wrench_sigma_position_test.cc).
#include <gtest/gtest.h>

#include <random>

#include "service/dynamics/sigma/wrench_sigma.h"
#include "tests/dynamics/sigma/wrench_sigma_reference.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {

const char* const kScenes[] = {"four_bar",   "four_wheel_car", "planar_arms_load", "pr2_box",           "tiago_pro_box",
                               "trike",      "two_5dof_arms_load", "two_iiwa_load", "two_puma_load", "two_wheel_vehicle",
                               "unicycle"};

// every output's block of C and its sigmas against the reference's
void expect_same(const System& sys, const WrenchSigmaData& fast, const WrenchSigmaData& ref) {
  ASSERT_EQ(fast.valid, ref.valid);
  ASSERT_EQ(fast.source, ref.source);
  ASSERT_EQ(fast.ncols, ref.ncols);
  const double all = ref.C.leftCols(ref.ncols).cwiseAbs().maxCoeff();
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k) {
    const auto Cr = ref.C.block(6 * static_cast<Eigen::Index>(k), 0, 6, ref.ncols);
    const auto Cf = fast.C.block(6 * static_cast<Eigen::Index>(k), 0, 6, fast.ncols);
    const double scale = std::max(Cr.cwiseAbs().maxCoeff(), 1e-3 * all);
    if (fast.c_filled) {
      EXPECT_LE((Cf - Cr).cwiseAbs().maxCoeff(), 1e-10 * scale) << sys.wrenches.outputs[k].name;
    }
    EXPECT_LE((fast.sigma[k] - ref.sigma[k]).cwiseAbs().maxCoeff(), 1e-10 * scale) << sys.wrenches.outputs[k].name;
  }
}

// at the evaluated state: the simulate-mode (torque noise) and the estimate-mode (torque, position,
// velocity noise) sigma against the reference's
void expect_same_in_both_modes(const System& sys, Workspace& ws, WrenchSigmaData& fast, WrenchSigmaData& ref,
                               const Eigen::VectorXd& v, const Eigen::VectorXd& tau) {
  compute_wrench_sigma(sys, ws, fast);
  reference::compute_wrench_sigma(sys, ws, ref);
  ASSERT_TRUE(fast.valid);
  expect_same(sys, fast, ref);
  compute_wrench_sigma(sys, ws, fast, sys.q0, v, tau);
  reference::compute_wrench_sigma(sys, ws, ref, sys.q0, v, tau);
  ASSERT_TRUE(fast.valid);
  EXPECT_TRUE(fast.source & WrenchSigmaData::kV);
  expect_same(sys, fast, ref);
}

// One scene, in its own formulation or the classic one, with `reactions: R` and noise on every
// joint: the fast sigma against the reference in both modes. False where the pair does not apply
// (classic without a load), propagates no noise or fails to evaluate; composite counts the fast
// path's reactions by composite inertias.
bool compare_with_reactions(const std::string& scene, const std::string& path, bool classic, const std::string& reactions,
                            int seed, int* composite = nullptr) {
  SCOPED_TRACE(path + (classic ? " classic" : "") + ", reactions: " + reactions);
  SceneOverrides ov;
  if (classic) ov.formulation = Formulation::kClassic;
  const std::string text = without_reactions(scene) + "\nreactions: " + reactions + "\nnoise: {tau: 0.2, q: 1e-3, v: 1e-2}\n";
  if (classic && text.find("\nload:") == std::string::npos) return false;
  const System sys = load_scene_string(text, path, ov);
  if (!wrench_sigma_supported(sys)) return false;
  Workspace ws(sys);
  WrenchSigmaData fast(sys), ref(sys);
  Eigen::VectorXd v, tau;
  reference::random_v_tau(sys, seed, v, tau);
  if (evaluate(sys, ws, sys.q0, v, tau).status == Status::kError) return false;
  expect_same_in_both_modes(sys, ws, fast, ref, v, tau);
  if (composite) *composite += fast.composite;
  return true;
}

TEST(WrenchSigmaFast, EqualsThePreviousDefinitionOnEveryShippedScene) {
  int compared = 0;
  for (const char* name : kScenes)
    for (const bool classic : {false, true})  // the scene's own formulation; classic where it applies
      compared += compare_with_reactions(scene_text(name), scene_path(name), classic, "all", 3);
  EXPECT_GE(compared, 12);  // how many pairs (scene, formulation) propagate noise
}

// Without the joint reactions (`reactions: none`: the end-effector, base, tip and axle wrenches) the
// reactions left (the bases) are read off composite inertias where that is far cheaper than the pass
// over the bodies (WrenchSigmaData::composite): every shipped scene, both formulations, and 1, 2
// and 4 PUMAs, both modes, against the reference's pass.
TEST(WrenchSigmaFast, EqualsThePreviousDefinitionWithCompositeReactions) {
  std::vector<std::pair<std::string, std::string>> scenes;  // (text, path)
  for (const char* name : kScenes) scenes.emplace_back(scene_text(name), scene_path(name));
  for (int n : {1, 2, 4}) {
    const std::string path = std::string(COOPDYN_SOURCE_DIR) + "/bench/scenes/pumas_" + std::to_string(n) + ".yaml";
    scenes.emplace_back(slurp(path), path);
  }
  int composite = 0, compared = 0;
  for (const auto& [scene, path] : scenes)
    for (const bool classic : {false, true}) compared += compare_with_reactions(scene, path, classic, "none", 5, &composite);
  EXPECT_GE(compared, 15);
  EXPECT_GE(composite, 8);  // the arms' bases: the PUMAs, the iiwas, the planar and 5-DOF arms
}

// Arms without joint-1 armature on the dense path (1 and 2 PUMAs, bench/scenes): Q is factored
// with the nominal directions last (q_solve.h), and the fast row solve goes through that basis;
// the reference solves the dense Q with Eigen's LDLT.
TEST(WrenchSigmaFast, EqualsThePreviousDefinitionWithNominalBaseLinks) {
  for (int n : {1, 2}) {
    const std::string path = std::string(COOPDYN_SOURCE_DIR) + "/bench/scenes/pumas_" + std::to_string(n) + "_no_armature.yaml";
    SCOPED_TRACE(path);
    const System sys = load_scene_string(without_reactions(slurp(path)) + "\nreactions: all\nnoise: {tau: 0.2, q: 1e-3, v: 1e-2}\n", path);
    ASSERT_FALSE(sys.nominal_bases.empty());
    ASSERT_TRUE(wrench_sigma_supported(sys));
    Workspace ws(sys);
    WrenchSigmaData fast(sys), ref(sys);
    Eigen::VectorXd v, tau;
    reference::random_v_tau(sys, 3, v, tau);
    ASSERT_NE(evaluate(sys, ws, sys.q0, v, tau).status, Status::kError);
    ASSERT_TRUE(ws.qs.nominal_active);
    ASSERT_FALSE(ws.q_blocks_active);
    expect_same_in_both_modes(sys, ws, fast, ref, v, tau);
  }
}

// From 3 arms on Q is factored by blocks (q_blocks.h), and without joint-1 armature as one factor
// with the nominal rows last (has_nominal); the reference solves Q densely (Eigen's LDLT of
// G M^-1 G^T). 3, 4 and 8 PUMAs (bench/scenes) with and without armature, both formulations, both
// modes, at two states.
TEST(WrenchSigmaFast, EqualsTheDenseSolveWithTheBlockFactorOfQ) {
  int with_nominal = 0;
  for (int n : {3, 4, 8})
    for (const char* suffix : {"", "_no_armature"})
      for (const bool classic : {false, true}) {
        const std::string path =
            std::string(COOPDYN_SOURCE_DIR) + "/bench/scenes/pumas_" + std::to_string(n) + suffix + ".yaml";
        SCOPED_TRACE(path + (classic ? " classic" : ""));
        SceneOverrides ov;
        if (classic) ov.formulation = Formulation::kClassic;
        const System sys =
            load_scene_string(without_reactions(slurp(path)) + "\nreactions: all\nnoise: {tau: 0.2, q: 1e-3, v: 1e-2}\n", path, ov);
        ASSERT_TRUE(wrench_sigma_supported(sys));
        Workspace ws(sys);
        WrenchSigmaData fast(sys), ref(sys);
        for (unsigned seed : {3u, 11u}) {
          Eigen::VectorXd v, tau;
          reference::random_v_tau(sys, seed, v, tau);
          ASSERT_NE(evaluate(sys, ws, sys.q0, v, tau).status, Status::kError);
          ASSERT_TRUE(ws.q_blocks_active);
          EXPECT_EQ(ws.qb.has_nominal, !sys.nominal_bases.empty());
          if (!classic) {  // the classic form has no nominal base links
            EXPECT_EQ(ws.qb.has_nominal, std::string(suffix) != "");
          }
          with_nominal += ws.qb.has_nominal;
          expect_same_in_both_modes(sys, ws, fast, ref, v, tau);
        }
      }
  EXPECT_GT(with_nominal, 0);
}

// The arm form (wrench_sigma_arms.h: the packed torques, the load's unit forces and one 6 x 6
// quadratic form per output) from two arms on, C filled (keep_C: its 6 x 6 products) and not
// (sigma only), and with every output's other arms summed by columns (the guard's path), against
// the reference's every column: the shipped scenes and 2, 3, 4 and 8 PUMAs with and without
// armature, both formulations, every reaction and none, simulate mode, two states. It must take
// the PUMAs (arms_used) and fall back where the structure does not hold.
TEST(WrenchSigmaFast, ArmFormEqualsThePreviousDefinition) {
  std::vector<std::pair<std::string, std::string>> scenes;  // (text, path)
  for (const char* name : kScenes) scenes.emplace_back(scene_text(name), scene_path(name));
  for (int n : {2, 3, 4, 8})
    for (const char* suffix : {"", "_no_armature"}) {
      const std::string path = std::string(COOPDYN_SOURCE_DIR) + "/bench/scenes/pumas_" + std::to_string(n) + suffix + ".yaml";
      scenes.emplace_back(slurp(path), path);
    }
  int used = 0, pumas_used = 0, compared = 0, guarded = 0;
  for (const auto& [scene, path] : scenes)
    for (const bool classic : {false, true})
      for (const char* reactions : {"all", "none"})
        for (const bool keep : {false, true}) {
          SCOPED_TRACE(path + (classic ? " classic" : "") + ", reactions: " + reactions + (keep ? ", keep_C" : ""));
          SceneOverrides ov;
          if (classic) ov.formulation = Formulation::kClassic;
          const std::string text = without_reactions(scene) + "\nreactions: " + reactions + "\nnoise: {tau: 0.2}\n";
          if (classic && text.find("\nload:") == std::string::npos) continue;
          const System sys = load_scene_string(text, path, ov);
          if (!wrench_sigma_supported(sys)) continue;
          Workspace ws(sys);
          WrenchSigmaData fast(sys), ref(sys), guarded_all(sys);
          fast.arms_min = 2;
          fast.keep_C = keep;
          guarded_all.arms_min = 2;
          guarded_all.arm.guard = 0.0;  // every output's other arms by columns (the guard's path)
          for (int seed : {3, 11}) {
            Eigen::VectorXd v, tau;
            reference::random_v_tau(sys, seed, v, tau);
            if (evaluate(sys, ws, sys.q0, v, tau).status == Status::kError) continue;
            compute_wrench_sigma(sys, ws, fast);
            reference::compute_wrench_sigma(sys, ws, ref);
            ASSERT_TRUE(fast.valid);
            EXPECT_EQ(fast.c_filled, keep || !fast.arms_used);
            expect_same(sys, fast, ref);
            if (!keep) {
              compute_wrench_sigma(sys, ws, guarded_all);
              EXPECT_EQ(guarded_all.arms_used, fast.arms_used);
              if (fast.arms_used) {
                EXPECT_EQ(guarded_all.arm.guarded, static_cast<int>(sys.wrenches.outputs.size()));
              }
              expect_same(sys, guarded_all, ref);
            }
            ++compared;
            used += fast.arms_used;
            guarded += fast.arm.guarded;
            if (path.find("pumas_") != std::string::npos) {
              EXPECT_TRUE(fast.arms_used);
              pumas_used += fast.arms_used;
            }
          }
        }
  EXPECT_GE(compared, 100);
  EXPECT_EQ(pumas_used, 8 * 2 * 2 * 2 * 2);  // 8 PUMA scenes, both formulations, reactions, keep_C, states
  std::printf("arm form: %d of %d evaluations, %d outputs guarded\n", used, compared, guarded);
}

}  // namespace
}  // namespace coopdyn::testing
