// The per-arm block Cholesky of Q (dynamics/q_blocks.h) against the dense Cholesky of the same Q:
// accelerations, multipliers, pseudo-joint stresses, rank, status, the condition estimate and every
// reported wrench equal to 1e-12 (relative to the largest component) on the arms-scaling scenes
// (bench/scenes/pumas_N.yaml, 1-8 PUMAs on one load), on the same without joint armature and on 1-8
// iiwa arms from their URDF (nominal base links), and on every shipped scene in every formulation
// that loads, at random states; rank-deficient systems fall back to the dense rank-revealing path.
#include <gtest/gtest.h>

#include <cstdio>
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
Compared compare(const System& sys, const std::string& what, int states, double tol = 1e-12) {
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
    EXPECT_LE(rel(wb.vdot, wd.vdot), tol);
    EXPECT_LE(rel(wb.lambda, wd.lambda), tol);
    EXPECT_LE(rel(wb.stress, wd.stress), tol);
    EXPECT_NEAR(db.residual, dd.residual, 1e-9 * (1.0 + dd.residual));
    if (db.status == Status::kError) continue;
    compute_wrenches(sys, wb, fb);
    compute_wrenches(sys, wd, fd);
    for (size_t t = 0; t < fb.W.size(); ++t) {
      const double scale = 1.0 + fd.W[t].cwiseAbs().maxCoeff();
      EXPECT_LE((fb.W[t] - fd.W[t]).cwiseAbs().maxCoeff(), tol * scale) << sys.wrenches.outputs[t].name;
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

// Arms whose joint 1 has no armature (System::nominal_bases): the PUMAs with every armature removed,
// 1-8 on one box. The block path factors Q once with the nominal base-link directions last (the
// reduced rows of every arm first, then the N x N Schur complement of the dropped rows): its
// condition (the leading pivots') and its solution equal the dense path's. Q itself carries the nominal direction's
// eigenvalue (~1 / the nominal inertia, 1e3 above the others), so the two paths' round-off differs
// more than with armature: 1e-11 relative (measured up to 4.4e-12 on the joint wrenches at 8 arms).
// And 1-8 KUKA iiwa 14 arms read from their URDF: their joint 1 moves link 0, which has the URDF's
// mass, so there is no nominal inertia; the block path as with armature.
TEST(QBlocks, ArmsWithoutArmatureEqualDense) {
  for (const std::string& kind : {std::string("pumas_%_no_armature"), std::string("iiwa_%")})
    for (int n : {1, 2, 3, 4, 6, 8}) {
      std::string name = kind;
      name.replace(name.find('%'), 1, std::to_string(n));
      SCOPED_TRACE(name);
      const System sys = load_scene(std::string(COOPDYN_SOURCE_DIR) + "/bench/scenes/" + name + ".yaml");
      const bool puma = kind[0] == 'p';
      ASSERT_EQ(sys.nominal_bases.size(), puma ? static_cast<size_t>(n) : 0u);
      Workspace ws(sys);
      EXPECT_EQ(ws.qb.usable, n >= 2);
      EXPECT_EQ(ws.qb.has_nominal, puma && n >= 2);
      if (n >= 2) {
        EXPECT_EQ(static_cast<int>(ws.qb.groups.size()), n);
        for (const QBlocks::Group& g : ws.qb.groups) EXPECT_EQ(g.nominal.size(), puma ? 1u : 0u);
      }
      EXPECT_EQ(ws.use_q_blocks, n >= (puma ? Workspace::kQBlocksMinGroupsNominal : Workspace::kQBlocksMinGroups));
      const Compared c = compare(sys, name, 6, puma ? 1e-11 : 1e-12);
      if (n >= 2) {
        EXPECT_EQ(c.block, c.evaluations) << "every state solved by blocks";
      }
    }
}

// The nominal directions' reflections are taken once, at the scene's initial configuration
// (QBlocks::set_nominal_reference, QSolver's likewise): joint 1's motion seen from the weld frame on
// its base link is the same in every configuration, so an evaluation keeps that reference (block
// path from 3 arms, dense path below) where its own direction equals it to round-off, and its
// results, kept or not, equal those of the
// reflections taken from the state's own constraint rows (a workspace without a reference, as every
// evaluation did before): the same rank and status, the condition to 1e-10 relative, the
// accelerations, multipliers and wrenches to 1e-11 (the round-off of these systems: the dense and
// block paths differ by as much, ArmsWithoutArmatureEqualDense).
TEST(QBlocks, NominalReferenceKeptOrNotGivesTheSameSolution) {
  for (int n : {1, 2, 3, 4, 8}) {
    SCOPED_TRACE(n);
    const System sys = load_scene(std::string(COOPDYN_SOURCE_DIR) + "/bench/scenes/pumas_" + std::to_string(n) +
                                  "_no_armature.yaml");
    Workspace wr(sys), wo(sys);
    for (QBlocks::Group& g : wo.qb.groups) {
      g.u_ref.clear();
      g.at_ref = false;
    }
    wo.qs.nominal_u_ref.clear();
    wo.qs.nominal_at_ref = false;
    WrenchData fr(sys), fo(sys);
    std::mt19937 rng(23);
    int kept = 0;
    for (int k = -1; k < 12; ++k) {  // -1: the initial configuration, the reference's own
      Eigen::VectorXd q = sys.q0, v = Eigen::VectorXd::Zero(sys.model.nv());
      if (k >= 0) random_state(sys, rng, k < 6 ? 0.2 : 1.5, q, v);
      Eigen::VectorXd tau(sys.model.nv());
      for (int i = 0; i < tau.size(); ++i) tau[i] = 3.0 * std::sin(0.7 * i + k);
      const Diagnostics dr = evaluate(sys, wr, q, v, tau);
      const Diagnostics dd = evaluate(sys, wo, q, v, tau);
      EXPECT_EQ(wr.q_blocks_active, n >= Workspace::kQBlocksMinGroupsNominal);
      bool at_ref = wr.q_blocks_active || wr.qs.nominal_at_ref;
      if (wr.q_blocks_active)
        for (const QBlocks::Group& g : wr.qb.groups) at_ref = at_ref && g.at_ref;
      kept += at_ref;
      // At the initial configuration the rows are the reference's, bit for bit: kept on any machine.
      // Elsewhere the direction's round-off decides (with fused multiply-adds every state here keeps
      // it; without, as in the sanitizer build, some take their own): counted, not judged.
      if (k < 0) {
        EXPECT_TRUE(at_ref);
      }
      EXPECT_EQ(dr.status, dd.status);
      EXPECT_EQ(dr.rank, dd.rank);
      EXPECT_NEAR(dr.condition, dd.condition, 1e-10 * dd.condition);
      EXPECT_LE(rel(wr.vdot, wo.vdot), 1e-11);
      EXPECT_LE(rel(wr.lambda, wo.lambda), 1e-11);
      compute_wrenches(sys, wr, fr);
      compute_wrenches(sys, wo, fo);
      for (size_t t = 0; t < fr.W.size(); ++t)
        EXPECT_LE((fr.W[t] - fo.W[t]).cwiseAbs().maxCoeff(), 1e-11 * (1.0 + fo.W[t].cwiseAbs().maxCoeff()));
    }
    std::printf("[nominal reference] %d arm(s): kept at %d of 13 states\n", n, kept);
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
