// Measurement noise through the state fit (state_fit_sigma.h): in estimate mode the load's pose and
// twist are fitted from the measured joints, so a joint's position noise moves them too. With the
// fit in the linearization (WrenchSigmaData::refit), each position / velocity column equals the
// derivative of the whole estimator (refit, evaluate, wrenches), and Monte Carlo draws of the joint
// measurements, refitted and evaluated, reproduce sigma; holding the fitted pose does not.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "service/dynamics/integrators.h"
#include "service/dynamics/state_fit_sigma.h"
#include "service/dynamics/wrench_sigma.h"
#include "tests/support/sigma_monte_carlo.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

namespace {

System noisy(const std::string& scene, const std::string& noise) {
  return load_scene_string(without_reactions(scene_text(scene)) + "\nreactions: all\nnoise: " + noise + "\n", scene_path(scene));
}

// A measured state: 0.2 s simulated from the scene's initial state under constant torques (a
// state that closes the constraints, moving), then the load's pose and twist fitted from the
// joints as the daemon does with a state that omits them; the torques those of the last step.
struct Measured {
  Eigen::VectorXd q, v, tau;
};
Measured measured(const System& sys, const StateFitPlan& plan, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Measured m{sys.q0, sys.v0, Eigen::VectorXd::Zero(sys.model.nv())};
  for (int i = 0; i < sys.model.nv(); ++i)
    if (sys.tau_limit[i] > 0 && std::isfinite(sys.tau_limit[i])) m.tau[i] = 5.0 * U(rng);
  Stepper st(sys);
  for (int k = 0; k < 200; ++k) EXPECT_NE(step(sys, st, Integrator::kRk4, 1e-3, m.tau, m.q, m.v).status, Status::kError);
  StateFitWorkspace fws(sys, plan);
  fit_state(sys, plan, fws, true, true, m.q, m.v);
  return m;
}

// The whole estimator at a measurement: refit (warm-started at `start`), evaluate, wrenches.
void estimate(const System& sys, const StateFitPlan& plan, StateFitWorkspace& fws, const Eigen::VectorXd& start,
              Eigen::VectorXd q, Eigen::VectorXd v, const Eigen::VectorXd& tau, Workspace& ws, WrenchData& wd) {
  for (int i : plan.fit_q) fws.q_start[i] = start[i];
  fws.have_start = true;
  fit_state(sys, plan, fws, true, true, q, v);
  ASSERT_NE(evaluate(sys, ws, q, v, tau).status, Status::kError);
  compute_wrenches(sys, ws, wd);
}

}  // namespace

// Column j / S_j against central differences (step 1e-4) of the whole estimator: the joint moved,
// the load refitted, a full evaluation; the same bound as the held columns (1e-4, absolute or
// relative above 1: the columns' forward step of 1e-7 times the curvature, plus the refit's own
// tolerance, 1e-14 / 1e-7). The fitted pose matters: held, some position column is off by more.
TEST(WrenchSigmaFit, ColumnsAreTheDerivativesOfTheRefittedEstimate) {
  for (const std::string scene : {"two_puma_load", "two_iiwa_load"}) {
    SCOPED_TRACE(scene);
    const System sys = noisy(scene, "{q: 1e-3, v: 1e-2}");
    const StateFitPlan plan = plan_state_fit(sys);
    ASSERT_TRUE(plan.q_fittable);
    ASSERT_TRUE(plan.v_fittable);
    const Measured m = measured(sys, plan, 7);
    Workspace ws(sys);
    WrenchData wp(sys), wm(sys);
    WrenchSigmaData sd(sys), held(sys);
    FitRefit refit(sys, plan);
    refit.set(m.q, true, true);
    sd.refit = &refit;
    ASSERT_NE(evaluate(sys, ws, m.q, m.v, m.tau).status, Status::kError);
    compute_wrench_sigma(sys, ws, held, m.q, m.v, m.tau);
    compute_wrench_sigma(sys, ws, sd, m.q, m.v, m.tau);
    ASSERT_TRUE(sd.valid);
    ASSERT_EQ(ws.diag.indeterminate, 0);
    const int na = static_cast<int>(sd.dofs.size()), nq = static_cast<int>(sd.q_dofs.size());
    ASSERT_GT(nq, 0);
    StateFitWorkspace fws(sys, plan);
    double held_off = 0.0;
    for (int j = na; j < sd.ncols; ++j) {
      const bool is_q = j < na + nq;
      const double S = is_q ? sd.Sq[j - na] : sd.Sv[j - na - nq], h = 1e-4;
      Eigen::VectorXd qp = m.q, qm = m.q, vp = m.v, vm = m.v;
      if (is_q) {
        qp[sd.q_index[j - na]] += h;
        qm[sd.q_index[j - na]] -= h;
      } else {
        vp[sd.v_dofs[j - na - nq]] += h;
        vm[sd.v_dofs[j - na - nq]] -= h;
      }
      estimate(sys, plan, fws, m.q, qp, vp, m.tau, ws, wp);
      estimate(sys, plan, fws, m.q, qm, vm, m.tau, ws, wm);
      for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k)
        for (int i = 0; i < 6; ++i) {
          const double fd = (wp.W[k][i] - wm.W[k][i]) / (2 * h);
          const Eigen::Index r = static_cast<Eigen::Index>(6 * k + i);
          EXPECT_NEAR(sd.C(r, j) / S, fd, 1e-4 * std::max(1.0, std::abs(fd)))
              << sys.wrenches.outputs[k].name << " component " << i << (is_q ? " q " : " v ") << j;
          held_off = std::max(held_off, std::abs(held.C(r, j) / S - fd) / std::max(1.0, std::abs(fd)));
        }
    }
    EXPECT_GT(held_off, 1e-2) << "holding the fitted load pose should miss the derivative";
  }
}

// 300 measurements drawn from the declared joint position noise (S_q = 1e-4 rad on every measured
// joint at once), each refitted and evaluated as the daemon does, against sigma. As for the held
// linearization (wrench_sigma_test.cc), the noise is small enough for the wrenches to be nearly
// linear: the linearization error |w(x + dx) - w(x) - C z|, measured on every draw, is bounded by
// 2e-2 of the largest sigma (asserted; measured 8e-4 on both pairs), which moves a variance by a few
// percent at most, inside the sampling error of the variance (chi-square, 5 standard deviations:
// 0.41 relative), the bound asserted on each component's variance ratio. The sigma of a held load
// pose falls outside that bound on some components (measured: 17 of 96 on the PUMA pair, 45 of 118
// on the iiwa pair).
TEST(WrenchSigmaFit, MonteCarloOfRefittedMeasurementsReproducesSigma) {
  for (const std::string scene : {"two_puma_load", "two_iiwa_load"}) {
    SCOPED_TRACE(scene);
    const System sys = noisy(scene, "{q: 1e-4}");
    const StateFitPlan plan = plan_state_fit(sys);
    const Measured m = measured(sys, plan, 5);
    Workspace ws(sys);
    WrenchData wd(sys);
    WrenchSigmaData sd(sys), held(sys);
    FitRefit refit(sys, plan);
    refit.set(m.q, true, true);
    sd.refit = &refit;
    ASSERT_NE(evaluate(sys, ws, m.q, m.v, m.tau).status, Status::kError);
    compute_wrenches(sys, ws, wd);
    compute_wrench_sigma(sys, ws, held, m.q, m.v, m.tau);
    compute_wrench_sigma(sys, ws, sd, m.q, m.v, m.tau);
    ASSERT_TRUE(sd.valid);
    const std::vector<Vec6> W0 = wd.W;
    const size_t no = W0.size();
    const int n = 300;
    NoiseDraws draws(sd.ncols, 13);
    WrenchMoments mom(no);
    const double smax = largest_sigma(sd);
    StateFitWorkspace fws(sys, plan);
    for (int s = 0; s < n; ++s) {
      const Eigen::VectorXd& z = draws.next();
      Eigen::VectorXd qs = m.q, vs = m.v, ts = m.tau;
      apply_noise_draw(sd, z, qs, vs, ts);
      estimate(sys, plan, fws, m.q, qs, vs, ts, ws, wd);
      mom.add(wd.W, W0, sd.C.leftCols(sd.ncols) * z);
    }
    const double lin_err = mom.lin_err;
    EXPECT_LT(lin_err, 2e-2 * smax);  // the linearization error, stated above
    const double tol = 5.0 * std::sqrt(2.0 / (n - 1));
    int compared = 0, held_outside = 0;
    double worst = 0.0;
    for (size_t k = 0; k < no; ++k)
      for (int i = 0; i < 6; ++i) {
        const double mean = mom.sum[6 * k + i] / n;
        const double var = (mom.sum2[6 * k + i] - n * mean * mean) / (n - 1);
        const double sg = sd.sigma[k][i], sh = held.sigma[k][i];
        if (sg < 1e-6 * smax) continue;
        ++compared;
        worst = std::max(worst, std::abs(var / (sg * sg) - 1.0));
        EXPECT_NEAR(var / (sg * sg), 1.0, tol) << sys.wrenches.outputs[k].name << " component " << i;
        held_outside += std::abs(var / (sh * sh) - 1.0) > tol;
      }
    EXPECT_GT(compared, 30);
    std::printf("%s: lin_err %.3g of max sigma %.3g; worst |var/sigma^2 - 1| %.3f (tol %.3f); held sigma outside: %d of %d\n",
                scene.c_str(), lin_err, smax, worst, tol, held_outside, compared);
    EXPECT_GT(held_outside, 0) << "holding the fitted load pose should miss some component's spread";
  }
}
