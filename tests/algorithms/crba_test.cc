// RNEA, CRBA and the tree-sparse factorization: identities between them and with physics.
#include <gtest/gtest.h>

#include "service/algorithms/crba.h"
#include "service/algorithms/kinematics.h"
#include "service/algorithms/rnea.h"
#include "service/algorithms/tree_cholesky.h"
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

TEST(Rnea, GravityTermIsTheGradientOfPotentialEnergy) {
  // h(q, 0) = dV/dq along each velocity direction (finite differences of the potential)
  std::mt19937 rng(12);
  for (const auto& name : all_scenes()) {
    SCOPED_TRACE(name);
    const System sys = load(name);
    const Model& m = sys.model;
    Eigen::VectorXd q, v;
    random_state(sys, rng, 0.5, q, v);
    Data d(m);
    forward_kinematics(m, d, q, Eigen::VectorXd::Zero(m.nv()));
    rnea_bias(m, d);
    const double eps = 1e-6;
    for (int j = 0; j < m.nv(); ++j) {
      Eigen::VectorXd e = Eigen::VectorXd::Zero(m.nv()), qp(m.nq()), qm(m.nq());
      e[j] = 1;
      integrate(m, q, e, eps, qp);
      integrate(m, q, e, -eps, qm);
      const double g = (potential_energy(m, qp) - potential_energy(m, qm)) / (2 * eps);
      EXPECT_NEAR(d.h[j], g, 1e-6 * (1 + std::abs(g))) << m.v_names[j];
    }
  }
}

TEST(Rnea, KineticEnergyRateEqualsPowerOfTheUnconstrainedMotion) {
  // free motion, no gravity, no torque: vdot = -M^-1 h keeps T = v^T M v / 2 constant, so
  // dT/dt computed by finite differences along (q, v) -> (q + eps v, v + eps vdot) is zero
  std::mt19937 rng(13);
  for (const auto& name : all_scenes()) {
    SCOPED_TRACE(name);
    System sys = load(name);
    Model& m = sys.model;
    m.gravity_W.setZero();
    Eigen::VectorXd q, v;
    random_state(sys, rng, 0.5, q, v);
    Data d(m);
    forward_kinematics(m, d, q, v);
    rnea_bias(m, d);
    crba(m, d);
    const Eigen::VectorXd vdot = d.M.ldlt().solve(-d.h);
    auto T = [&](const Eigen::VectorXd& qq, const Eigen::VectorXd& vv) {
      Data dd(m);
      forward_kinematics(m, dd, qq, vv);
      crba(m, dd);
      return 0.5 * vv.dot(dd.M * vv);
    };
    const double eps = 1e-6;
    Eigen::VectorXd qp(m.nq()), qm(m.nq());
    integrate(m, q, v, eps, qp);
    integrate(m, q, v, -eps, qm);
    const double dT = (T(qp, v + eps * vdot) - T(qm, v - eps * vdot)) / (2 * eps);
    EXPECT_NEAR(dT, 0.0, 1e-6 * (1 + T(q, v)));
  }
}

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
