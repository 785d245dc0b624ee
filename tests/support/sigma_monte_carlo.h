// Monte Carlo of declared noise (wrench_sigma.h), shared by the sigma tests: one draw applied to a
// state, and the moments of the wrenches' changes with their largest difference from the linear
// prediction C z.
#pragma once

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "service/dynamics/sigma/wrench_sigma.h"

namespace coopdyn::testing {

// Draws of one standard normal per noise source, from a seeded generator.
struct NoiseDraws {
  NoiseDraws(int sources, unsigned seed) : rng(seed), z(sources) {}
  const Eigen::VectorXd& next() {
    for (Eigen::Index j = 0; j < z.size(); ++j) z[j] = N01(rng);
    return z;
  }
  std::mt19937 rng;
  std::normal_distribution<double> N01{0.0, 1.0};
  Eigen::VectorXd z;
};

// the largest standard deviation of any component of any output
inline double largest_sigma(const WrenchSigmaData& sd) {
  double smax = 0.0;
  for (const Vec6& s : sd.sigma) smax = std::max(smax, s.maxCoeff());
  return smax;
}

// tau, q and v moved by the draw z (one standard normal per noise source, sd's column order:
// torques, then positions, then velocities)
inline void apply_noise_draw(const WrenchSigmaData& sd, const Eigen::VectorXd& z, Eigen::VectorXd& q,
                             Eigen::VectorXd& v, Eigen::VectorXd& tau) {
  const int na = static_cast<int>(sd.dofs.size()), nq = static_cast<int>(sd.q_dofs.size());
  for (int j = 0; j < na; ++j) tau[sd.dofs[j]] += sd.S[j] * z[j];
  for (int j = 0; j < nq; ++j) q[sd.q_index[j]] += sd.Sq[j] * z[na + j];
  for (int j = 0; j < static_cast<int>(sd.v_dofs.size()); ++j) v[sd.v_dofs[j]] += sd.Sv[j] * z[na + nq + j];
}

// Sums and sums of squares of each component's change W - W0, and the largest |change - C z|.
struct WrenchMoments {
  explicit WrenchMoments(size_t outputs)
      : sum(Eigen::VectorXd::Zero(6 * static_cast<Eigen::Index>(outputs))), sum2(sum) {}
  void add(const std::vector<Vec6>& W, const std::vector<Vec6>& W0, const Eigen::VectorXd& lin) {
    for (size_t k = 0; k < W0.size(); ++k)
      for (int i = 0; i < 6; ++i) {
        const Eigen::Index r = 6 * static_cast<Eigen::Index>(k) + i;
        const double x = W[k][i] - W0[k][i];
        lin_err = std::max(lin_err, std::abs(x - lin[r]));
        sum[r] += x;
        sum2[r] += x * x;
      }
  }
  Eigen::VectorXd sum, sum2;
  double lin_err = 0.0;
};

}  // namespace coopdyn::testing
