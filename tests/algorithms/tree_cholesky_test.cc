// The tree-sparse factorization of the mass matrix: it reproduces M with the tree's sparsity, solves,
// and names a DOF that moves no mass.
#include <gtest/gtest.h>

#include "service/algorithms/crba.h"
#include "service/algorithms/kinematics.h"
#include "service/algorithms/tree_cholesky.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

TEST(TreeCholesky, FactorReproducesMassMatrixWithTreeSparsityAndSolves) {
  std::mt19937 rng(14);
  for (const auto& name : all_scenes()) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    const Model& m = sys.model;
    Eigen::VectorXd q, v;
    random_state(sys, rng, 0.5, q, v);
    Data d(m);
    forward_kinematics(m, d, q, v);
    crba(m, d);
    ASSERT_TRUE(tree_cholesky_factor(m, d));
    // L^T L with L lower triangular and a positive diagonal is unique: reproducing M with L stored
    // only over the ancestor paths shows that the factorization needs no fill-in
    const Eigen::MatrixXd L = tree_factor_dense(m, d);
    EXPECT_LT((L.transpose() * L - d.M).norm(), 1e-12 * d.M.norm());
    for (int i = 0; i < m.nv(); ++i)
      for (int j = 0; j < i; ++j) {
        bool anc = false;
        for (int k = m.dof_parent[i]; k >= 0; k = m.dof_parent[k]) anc |= (k == j);
        if (!anc) {
          EXPECT_EQ(L(i, j), 0.0) << "fill-in at " << i << "," << j;
        }
      }
    Eigen::VectorXd b = Eigen::VectorXd::Random(m.nv()), x = b;
    tree_solve_M(m, d, x);
    EXPECT_LT((d.M * x - b).norm(), 1e-10 * (1 + b.norm()));
    // each triangular solve alone (their steps pair a parent with its only child DOF)
    x = b;
    tree_solve_Lt(m, d, x);
    EXPECT_LT((L.transpose() * x - b).norm(), 1e-12 * (1 + b.norm()) * (1 + L.norm() * x.norm()));
    x = b;
    tree_solve_L(m, d, x);
    EXPECT_LT((L * x - b).norm(), 1e-12 * (1 + b.norm()) * (1 + L.norm() * x.norm()));
  }
}

// Model::dof_elim_steps, which the factorization and the solves follow: every DOF once, after all
// its descendants, and a DOF paired with its parent only where it is the parent's only child DOF.
TEST(TreeCholesky, EliminationStepsVisitEveryDofAfterItsDescendants) {
  for (const auto& name : all_scenes()) {
    SCOPED_TRACE(name);
    const Model& m = load(name).model;
    const int n = m.nv();
    std::vector<int> at(n, -1), children(n, 0);
    for (int k = 0; k < n; ++k)
      if (m.dof_parent[k] >= 0) ++children[m.dof_parent[k]];
    int t = 0, pairs = 0;
    for (const auto& [k, j] : m.dof_elim_steps) {
      ASSERT_EQ(at[k], -1);
      at[k] = t++;
      if (j < 0) continue;
      EXPECT_EQ(m.dof_parent[k], j);
      EXPECT_EQ(children[j], 1);
      ASSERT_EQ(at[j], -1);
      at[j] = t++;
      ++pairs;
    }
    EXPECT_EQ(t, n);
    for (int k = 0; k < n; ++k) {
      if (m.dof_parent[k] >= 0) {
        EXPECT_GT(at[m.dof_parent[k]], at[k]) << "DOF " << k;
      }
    }
    if (n >= 2) {
      EXPECT_GT(pairs, 0);  // every shipped scene has a chain
    }
  }
}

TEST(TreeCholesky, ReportsTheDofThatMovesNoMass) {
  Model m;
  Joint r;
  r.type = JointType::kRevolute;
  r.name = "massless";
  m.add_body("b", -1, Transform(), r, Inertia());
  Data d(m);
  forward_kinematics(m, d, Eigen::VectorXd::Zero(1), Eigen::VectorXd::Zero(1));
  crba(m, d);
  int bad = -1;
  EXPECT_FALSE(tree_cholesky_factor(m, d, 1e-13, &bad));
  EXPECT_EQ(bad, 0);
}
