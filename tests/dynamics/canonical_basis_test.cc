// The canonical basis of a subspace depends on the subspace only: two orthonormal bases of one
// subspace (one the other turned by a random rotation within it) give the same columns up to sign,
// orthonormal, spanning the same subspace; the first column is the projection of the coordinate
// axis the subspace moves most, so a subspace spanned by coordinate axes gives those axes.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "service/dynamics/canonical_basis.h"

using namespace coopdyn;

namespace {
Eigen::MatrixXd canonical(Eigen::MatrixXd B) {
  Eigen::VectorXd g(B.cols());
  canonical_basis(B.data(), B.outerStride(), static_cast<int>(B.rows()), static_cast<int>(B.cols()), g.data());
  for (Eigen::Index c = 0; c < B.cols(); ++c) {  // sign: largest entry positive, as take() does
    Eigen::Index i;
    B.col(c).cwiseAbs().maxCoeff(&i);
    if (B(i, c) < 0) B.col(c) *= -1;
  }
  return B;
}
}  // namespace

TEST(CanonicalBasis, SameColumnsFromAnyBasisOfTheSubspace) {
  std::srand(7);
  for (int trial = 0; trial < 20; ++trial) {
    const int m = 4 + trial % 9, j = 1 + trial % 4;
    const Eigen::MatrixXd B = Eigen::HouseholderQR<Eigen::MatrixXd>(Eigen::MatrixXd::Random(m, j))
                                  .householderQ() * Eigen::MatrixXd::Identity(m, j);
    const Eigen::MatrixXd R = Eigen::HouseholderQR<Eigen::MatrixXd>(Eigen::MatrixXd::Random(j, j)).householderQ();
    const Eigen::MatrixXd C1 = canonical(B), C2 = canonical(B * R);
    EXPECT_LT((C1 - C2).cwiseAbs().maxCoeff(), 1e-12) << "m " << m << " j " << j;
    EXPECT_LT((C1.transpose() * C1 - Eigen::MatrixXd::Identity(j, j)).cwiseAbs().maxCoeff(), 1e-13);
    EXPECT_LT((C1 * C1.transpose() - B * B.transpose()).cwiseAbs().maxCoeff(), 1e-13);  // the same projector
  }
}

TEST(CanonicalBasis, EqualDiagonalsTakeTheFirstRow) {
  // the span of (e0 + e2)/sqrt2 and (e1 + e3)/sqrt2, handed over rotated by 30 degrees: every row
  // of the projector has 1/2 on its diagonal, so the first row (0) pivots, then the first row the
  // rest still moves (1): the columns come back as the two sums
  const double s = std::sqrt(0.5), c30 = std::cos(M_PI / 6), s30 = std::sin(M_PI / 6);
  Eigen::MatrixXd B(4, 2);
  B << s, 0, 0, s, s, 0, 0, s;
  Eigen::Matrix2d R;
  R << c30, -s30, s30, c30;
  const Eigen::MatrixXd C = canonical(B * R);
  EXPECT_LT((C - B).cwiseAbs().maxCoeff(), 1e-15);
}
