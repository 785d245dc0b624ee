// The velocity columns of each wrench's sigma as tangents (service/dynamics/wrench_sigma_velocity.h)
// against differences of the residuals they linearize (tests/dynamics/wrench_sigma_reference.cc):
// the generalized-force change (X0), the constraint right-hand side's (Gm) and the wrenches' own
// change (Cd), column by column.
#include <gtest/gtest.h>

#include <random>

#include "service/dynamics/wrench_sigma.h"
#include "tests/dynamics/wrench_sigma_reference.h"
#include "tests/support/test_util.h"

namespace coopdyn::testing {
namespace {

System noisy(const std::string& name, const std::string& extra = "") {
  std::string t = without_reactions(scene_text(name));
  if (!extra.empty()) {  // replaces the scene's ground
    const auto p = t.find("\nground:");
    if (p != std::string::npos) t.erase(p, t.find('\n', p + 1) - p);
  }
  return load_scene_string(t + "\nreactions: all\nnoise: {tau: 0.2, q: 1e-3, v: 1e-2}\n" + extra, scene_path(name));
}

void random_v_tau(const System& sys, unsigned seed, Eigen::VectorXd& v, Eigen::VectorXd& tau) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  v = sys.v0;
  tau = Eigen::VectorXd::Zero(sys.model.nv());
  for (int i = 0; i < sys.model.nv(); ++i) {
    v[i] += 0.3 * U(rng);
    tau[i] = 2.0 * U(rng);
  }
}

// the largest difference of the velocity columns of X0, Gm and Cd, relative to each matrix's
// largest entry over those columns
struct Diff {
  double x0 = 0, gm = 0, cd = 0;
};
Diff velocity_columns_diff(const WrenchSigmaData& a, const WrenchSigmaData& b, int na, int nq, int nv) {
  auto rel = [](const auto& A, const auto& B) {
    const double s = std::max(B.cwiseAbs().maxCoeff(), 1e-300);
    return (A - B).cwiseAbs().maxCoeff() / s;
  };
  Diff d;
  d.x0 = rel(a.X0.middleCols(na + nq, nv), b.X0.middleCols(na + nq, nv));
  d.gm = rel(a.Gm.middleCols(na + nq, nv), b.Gm.middleCols(na + nq, nv));
  d.cd = rel(a.Cd.middleCols(nq, nv), b.Cd.middleCols(nq, nv));
  return d;
}

TEST(WrenchSigmaVelocity, DebugSweep) {
  for (const char* name : {"two_puma_load", "two_iiwa_load", "four_wheel_car", "four_wheel_car_rr", "trike", "two_wheel_vehicle", "unicycle", "pr2_box", "tiago_pro_box"}) {
    SCOPED_TRACE(name);
    const std::string n = name;
    const bool rr = n == "four_wheel_car_rr";
    const System sys = noisy(rr ? "four_wheel_car" : name, rr ? "ground: {rolling_resistance: 0.02}\n" : "");
    Workspace ws(sys);
    WrenchSigmaData fast(sys), ref(sys);
    Eigen::VectorXd v, tau;
    random_v_tau(sys, 3, v, tau);
    ASSERT_NE(evaluate(sys, ws, sys.q0, v, tau).status, Status::kError);
    compute_wrench_sigma(sys, ws, fast, sys.q0, v, tau);
    const int na = static_cast<int>(fast.dofs.size()), nv = static_cast<int>(fast.v_dofs.size());
    const int nq = fast.ncols - na - nv;
    std::printf("%-18s", name);
    for (double h : {1e-1, 1e-2, 1e-3, 1e-4, 1e-5, -1.0}) {
      reference::velocity_step = h;
      reference::compute_wrench_sigma(sys, ws, ref, sys.q0, v, tau);
      const Diff d = velocity_columns_diff(fast, ref, na, nq, nv);
      std::printf(" h %g: %.1e %.1e %.1e |", h, d.x0, d.gm, d.cd);
    }
    std::printf("\n");
    reference::velocity_step = 1e-2;
  }
}

}  // namespace
}  // namespace coopdyn::testing
