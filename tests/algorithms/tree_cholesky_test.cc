// The tree-sparse factorization of the mass matrix: it reproduces M with the tree's sparsity, solves,
// names a DOF that moves no mass, and keeps each row to its own aligned chunks.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

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

// The factor's rows (and M's, Data::Mc) each start on a 64-byte boundary and own their chunks of
// Model::kFactorRowPad doubles, which the factorization updates whole: whatever the padding past a
// row's end holds never reaches an entry of M's factor (here NaN in every padding slot of Mc gives
// the same factor, bit for bit, as zeros).
TEST(TreeCholesky, RowsOwnAlignedChunksAndTheirPaddingNeverReachesTheFactor) {
  std::mt19937 rng(15);
  for (const auto& name : all_scenes()) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    const Model& m = sys.model;
    const int pad = Model::kFactorRowPad;
    for (int k = 0; k < m.nv(); ++k) {
      EXPECT_EQ(m.dof_row_offset[k] % pad, 0);
      const int end = k + 1 < m.nv() ? m.dof_row_offset[k + 1] : m.factor_size;
      EXPECT_GE(end - m.dof_row_offset[k], m.dof_depth[k] + 1);  // the path, the diagonal
      EXPECT_LT(end - m.dof_row_offset[k], m.dof_depth[k] + 1 + pad);
    }
    Eigen::VectorXd q, v;
    random_state(sys, rng, 0.5, q, v);
    Data d(m), dn(m);
#ifdef __AVX512F__  // the chunked loads need whole 64-byte rows (Eigen aligns to 64 with AVX-512)
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(d.Lc.data()) % 64, 0u);
#endif
    forward_kinematics(m, d, q, v);
    crba_compact(m, d);
    dn.Mc = d.Mc;
    for (int k = 0; k < m.nv(); ++k) {
      const int end = k + 1 < m.nv() ? m.dof_row_offset[k + 1] : m.factor_size;
      for (int i = m.dof_row_offset[k] + m.dof_depth[k] + 1; i < end; ++i) dn.Mc[i] = std::nan("");
    }
    ASSERT_TRUE(tree_cholesky_factor(m, d));
    ASSERT_TRUE(tree_cholesky_factor(m, dn));
    for (int k = 0; k < m.nv(); ++k) {
      const double* a = tree_factor_row(m, d, k);
      const double* b = tree_factor_row(m, dn, k);
      for (int p = 0; p <= m.dof_depth[k]; ++p) EXPECT_EQ(a[p], b[p]) << "row " << k << " entry " << p;
      EXPECT_EQ(d.Ld_inv[k], dn.Ld_inv[k]);
    }
  }
}
