// Spatial algebra: transforms, duality and inertia against their 6x6 matrix forms.
#include <gtest/gtest.h>

#include <random>

#include "service/spatial/spatial.h"

using namespace coopdyn;

namespace {
Transform random_transform(std::mt19937& rng) {
  std::normal_distribution<double> N;
  const Vec3 w(N(rng), N(rng), N(rng));
  return Transform(exp_so3(w), Vec3(N(rng), N(rng), N(rng)));
}
Vec6 rv(std::mt19937& rng) {
  std::normal_distribution<double> N;
  Vec6 x;
  for (int i = 0; i < 6; ++i) x[i] = N(rng);
  return x;
}
}  // namespace

TEST(Spatial, TransformActionsMatchMatrixAndInvert) {
  std::mt19937 rng(1);
  for (int k = 0; k < 20; ++k) {
    const Transform X = random_transform(rng), Y = random_transform(rng);
    const Vec6 m = rv(rng), f = rv(rng);
    EXPECT_LT((X.act(m) - X.motion_matrix() * m).norm(), 1e-12);
    EXPECT_LT((X.inv_act(X.act(m)) - m).norm(), 1e-12);
    EXPECT_LT((X.inv_act_force(X.act_force(f)) - f).norm(), 1e-12);
    // force transform is the dual: X* = X^-T
    EXPECT_LT((X.act_force(f) - X.motion_matrix().inverse().transpose() * f).norm(), 1e-10);
    // power is frame independent
    EXPECT_NEAR(X.act(m).dot(X.act_force(f)), m.dot(f), 1e-10);
    // composition reads by its letters: X_AC = X_AB * X_BC
    EXPECT_LT(((X * Y).act(m) - X.act(Y.act(m))).norm(), 1e-12);
    EXPECT_LT(((X * X.inverse()).motion_matrix() - Mat6::Identity()).norm(), 1e-12);
  }
}

TEST(Spatial, CrossProductsAreDual) {
  std::mt19937 rng(2);
  const Vec6 v = rv(rng), m = rv(rng), f = rv(rng);
  // crf(v) = -crm(v)^T  =>  f . (v x m) = -(v x* f) . m
  EXPECT_NEAR(f.dot(cross_motion(v, m)), -cross_force(v, f).dot(m), 1e-12);
  EXPECT_LT(cross_motion(v, v).norm(), 1e-14);
}

TEST(Spatial, InertiaMatchesMatrixAndTransforms) {
  std::mt19937 rng(3);
  std::normal_distribution<double> N;
  for (int k = 0; k < 10; ++k) {
    Mat3 A;
    for (int i = 0; i < 9; ++i) A(i / 3, i % 3) = N(rng);
    const Inertia I(1.0 + std::abs(N(rng)), Vec3(N(rng), N(rng), N(rng)), A * A.transpose());
    const Vec6 V = rv(rng);
    EXPECT_LT((I * V - I.matrix() * V).norm(), 1e-11);
    const Transform X = random_transform(rng);
    // I_A = X_AB^* I_B X_AB^-1
    const Mat6 IA = X.motion_matrix().inverse().transpose() * I.matrix() * X.motion_matrix().inverse();
    EXPECT_LT((I.transformed(X).matrix() - IA).norm(), 1e-10);
    // sum of two inertias is the sum of matrices
    Inertia J = I;
    J += I.transformed(X);
    EXPECT_LT((J.matrix() - (I.matrix() + IA)).norm(), 1e-10);
  }
}

TEST(Spatial, ExpLogRoundTrip) {
  std::mt19937 rng(4);
  std::normal_distribution<double> N;
  for (int k = 0; k < 50; ++k) {
    Vec3 w(N(rng), N(rng), N(rng));
    if (w.norm() > 3.0) w *= 3.0 / w.norm();
    EXPECT_LT((log_so3(exp_so3(w)) - w).norm(), 1e-9);
    EXPECT_LT((exp_so3(w) - Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix()).norm(), 1e-12);
  }
  EXPECT_LT(log_so3(Mat3::Identity()).norm(), 1e-15);
}
