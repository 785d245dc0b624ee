// The per-arm block Cholesky of Q (dynamics/q_blocks.h) against the dense Cholesky of the same Q:
// accelerations, multipliers, pseudo-joint stresses, rank, status, the condition estimate and every
// reported wrench equal to 1e-12 (relative to the largest component) on the arms-scaling scenes
// (bench/scenes/pumas_N.yaml, 1-8 PUMAs on one load) and on every shipped scene in every formulation
// that loads, at random states; rank-deficient systems fall back to the dense rank-revealing path.
#include <gtest/gtest.h>

#include <random>

#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

namespace {

std::string arms_scene(int n) { return std::string(COOPDYN_SOURCE_DIR) + "/bench/scenes/pumas_" + std::to_string(n) + ".yaml"; }

double rel(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  if (a.size() == 0) return 0.0;
  return (a - b).cwiseAbs().maxCoeff() / (1.0 + b.cwiseAbs().maxCoeff());
}

struct Compared {
  int evaluations = 0, block = 0;  // evaluations compared, of which the block path solved
};

// Evaluates the same states with the block path forced on (where the structure holds) and off.
Compared compare(const System& sys, const std::string& what, int states) {
  Workspace wb(sys), wd(sys);
  Compared c;
  if (!wb.qb.usable) return c;
  wb.use_q_blocks = true;
  wd.use_q_blocks = false;
  WrenchData fb(sys), fd(sys);
  std::mt19937 rng(11);
  for (int k = 0; k < states; ++k) {
    SCOPED_TRACE(what + " state " + std::to_string(k));
    Eigen::VectorXd q, v;
    if (k == 0) {
      q = sys.q0;
      v = sys.v0;
    } else {
      random_state(sys, rng, 0.2, q, v);
    }
    Eigen::VectorXd tau(sys.model.nv());
    for (int i = 0; i < tau.size(); ++i) tau[i] = std::sin(1.3 * i + k);
    const Diagnostics db = evaluate(sys, wb, q, v, tau);
    const Diagnostics dd = evaluate(sys, wd, q, v, tau);
    ++c.evaluations;
    c.block += wb.q_blocks_active ? 1 : 0;
    EXPECT_FALSE(wd.q_blocks_active);
    EXPECT_EQ(db.status, dd.status);
    EXPECT_EQ(db.reason, dd.reason);
    EXPECT_EQ(db.rank, dd.rank);
    EXPECT_NEAR(db.condition, dd.condition, 1e-9 * dd.condition);
    EXPECT_LE(rel(wb.vdot, wd.vdot), 1e-12);
    EXPECT_LE(rel(wb.lambda, wd.lambda), 1e-12);
    EXPECT_LE(rel(wb.stress, wd.stress), 1e-12);
    EXPECT_NEAR(db.residual, dd.residual, 1e-9 * (1.0 + dd.residual));
    if (db.status == Status::kError) continue;
    compute_wrenches(sys, wb, fb);
    compute_wrenches(sys, wd, fd);
    for (size_t t = 0; t < fb.W.size(); ++t) {
      const double scale = 1.0 + fd.W[t].cwiseAbs().maxCoeff();
      EXPECT_LE((fb.W[t] - fd.W[t]).cwiseAbs().maxCoeff(), 1e-12 * scale) << sys.wrenches.outputs[t].name;
      EXPECT_EQ(fb.indeterminate[t], fd.indeterminate[t]);
    }
  }
  return c;
}

}  // namespace

TEST(QBlocks, ArmsOnOneLoadEqualDense) {
  for (int n : {1, 2, 3, 4, 6, 8}) {
    const System sys = load_scene(arms_scene(n));
    ASSERT_EQ(sys.constraints.rows, 6 * n);
    Workspace ws(sys);
    // one group per arm, coupled through the platform's 6 DOFs; used by default from 3 arms on
    EXPECT_EQ(ws.qb.usable, n >= 2) << n;
    if (n >= 2) {
      EXPECT_EQ(static_cast<int>(ws.qb.groups.size()), n);
      EXPECT_EQ(ws.qb.common.size(), 6u);
    }
    EXPECT_EQ(ws.use_q_blocks, n >= Workspace::kQBlocksMinGroups);
    const Compared c = compare(sys, "pumas_" + std::to_string(n), 6);
    if (n >= 2) {
      EXPECT_EQ(c.block, c.evaluations) << "every state of " << n << " arms solved by blocks";
    }
  }
}

TEST(QBlocks, ShippedScenesEqualDenseOrFallBack) {
  std::vector<std::string> scenes = all_scenes();
  for (const auto& w : wheel_scenes()) scenes.push_back(w);
  int structured = 0, fell_back = 0;
  for (const auto& name : scenes)
    for (Formulation f : {Formulation::kMobilePlatform, Formulation::kClassic}) {
      System sys;
      try {
        sys = load(name, f);
      } catch (const std::exception&) {
        continue;  // the formulation does not apply to the scene
      }
      const Compared c = compare(sys, name + " / " + formulation_name(f), 4);
      structured += c.evaluations > 0 ? 1 : 0;
      fell_back += c.evaluations - c.block;
    }
  // two_puma_load, two_5dof_arms_load and two_iiwa_load in both forms, planar_arms_load (classic),
  // two_wheel_vehicle have the structure
  EXPECT_GE(structured, 8);
  // planar_arms_load's rows are dependent (rank 9 of 12) and the vehicle's rigid axle too: every one
  // of their states fails the block factorization and takes the dense rank-revealing path
  EXPECT_GE(fell_back, 8);
}
