// CRBA: the mass matrix is symmetric positive definite and its columns are RNEA's.
#include <gtest/gtest.h>

#include "service/algorithms/crba.h"
#include "service/algorithms/kinematics.h"
#include "service/algorithms/rnea.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

TEST(Crba, MassMatrixIsSymmetricPositiveDefiniteAndMatchesRnea) {
  std::mt19937 rng(11);
  for (const auto& name : all_scenes()) {
    for (auto f : {Formulation::kMobilePlatform, Formulation::kClassic}) {
      SCOPED_TRACE(name + " " + formulation_name(f));
      const System sys = load(name, f);
      const Model& m = sys.model;
      Eigen::VectorXd q, v;
      random_state(sys, rng, 0.5, q, v);
      Data d(m);
      forward_kinematics(m, d, q, v);
      crba(m, d);
      EXPECT_LT((d.M - d.M.transpose()).norm(), 1e-12 * d.M.norm());
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(d.M);
      EXPECT_GT(es.eigenvalues().minCoeff(), 0.0);
      // column j of M = rnea(q, v, e_j) - rnea(q, v, 0)
      Eigen::VectorXd t0(m.nv()), tj(m.nv()), e = Eigen::VectorXd::Zero(m.nv());
      rnea(m, d, e, nullptr, t0);
      rnea_bias(m, d);
      EXPECT_LT((t0 - d.h).norm(), 1e-10 * (1 + t0.norm()));
      for (int j = 0; j < m.nv(); ++j) {
        e.setZero();
        e[j] = 1.0;
        rnea(m, d, e, nullptr, tj);
        const Eigen::VectorXd col = tj - t0;
        EXPECT_LT((col - d.M.col(j)).norm(), 1e-9 * (1 + d.M.col(j).norm())) << "column " << j;
      }
    }
  }
}
