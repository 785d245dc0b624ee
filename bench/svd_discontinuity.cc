// The SVD baseline as the paper states it (its (19)-(21)) against the mobile-platform
// method, where the paper makes its claims. Writes two CSVs and prints the summary tables of
// bench/README.md ("The SVD baseline, measured").
//
// (1) Through a singularity: two_puma_load, arm1's wrist q5 driven from +0.6 rad through the wrist
//     singularity (q5 = 0: axes 4 and 6 aligned, arm1's own 6x6 Jacobian loses rank) to -0.6 rad.
//     Every other coordinate follows by Gauss-Newton on the closed-chain error with q5 held,
//     continued from the previous sample (constraint error <= 1e-12 m). At each sample (v = 0,
//     tau = 0: gravity statics) both methods evaluate the same state; arm1's end-effector wrench
//     (the load's wrench on it, frame arm1.ee, the same quantity in both), the singular values of
//     arm1's own Jacobian, the baseline's kept rank, and |vdot_svd - vdot_mp|. Then the largest jump
//     between neighbouring samples for 51..3201 samples (odd counts: the middle sample is q5 = 0):
//     a discontinuity keeps its jump under refinement, a continuous curve's shrinks like 1/N.
// (2) A deficient arm: two_5dof_arms_load (joint 6 held: each arm's own Jacobian has rank 5),
//     arm1's shoulder q2 swept over +-0.3 rad around the initial state (chain closed as above). Per
//     sample: the rigid grasp's force along the dropped direction u = N(J^T) (what the baseline
//     loses), in N and as a share of the grasp force, and how fast the baseline's grasp opens
//     (u . (G vdot - gamma), m/s^2 or rad/s^2).
//
// Usage: svd_discontinuity [OUT_DIR]   (default bench/results)
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "service/algorithms/kinematics.h"
#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/wrenches.h"
#include "service/scene/scene.h"

using namespace coopdyn;

namespace {

int index_of(const std::vector<std::string>& v, const std::string& s) {
  for (size_t i = 0; i < v.size(); ++i)
    if (v[i] == s) return static_cast<int>(i);
  return -1;
}
Eigen::VectorXd remap(const std::vector<std::string>& to, const std::vector<std::string>& from, const Eigen::VectorXd& x) {
  Eigen::VectorXd y(static_cast<Eigen::Index>(to.size()));
  for (size_t i = 0; i < to.size(); ++i) y[static_cast<Eigen::Index>(i)] = x[index_of(from, to[i])];
  return y;
}

// Gauss-Newton on the constraint error with velocity coordinate `held` not moved (min-norm steps).
double close_chain(const System& sys, Data& d, ConstraintData& cd, int held, Eigen::VectorXd& q) {
  const Model& m = sys.model;
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(m.nv());
  double err = 0;
  for (int it = 0; it < 50; ++it) {
    forward_kinematics(m, d, q, zero);
    constraint_rows(m, d, sys.constraints, q, zero, cd);
    err = cd.err.cwiseAbs().maxCoeff();
    if (err < 1e-13) break;
    Eigen::MatrixXd Gf = cd.G;
    Gf.col(held).setZero();
    const Eigen::VectorXd dv = Gf.completeOrthogonalDecomposition().solve(cd.err);
    integrate(m, q, dv, -1.0, q);
  }
  return err;
}

struct Sample {
  double s = 0, x = 0, pos_err = 0;
  Eigen::VectorXd sv;       // singular values of arm1's own Jacobian (the baseline's SVD)
  int kept = 0;             // directions the baseline keeps for arm1
  Vec6 w_mp, w_svd;         // arm1.ee: the load's wrench on the end-effector, frame arm1.ee
  double dvdot = 0;         // max |vdot_svd - vdot_mp|
  double lost = 0, share = 0, opening = 0;  // (2): rigid force along u, its share, u . (G vdot - gamma)
};

struct Path {
  std::string scene, joint;
  double from, to;
};

std::vector<Sample> run(const System& mp, const System& sv, const Path& p, int n) {
  const Model& m = mp.model;
  const int iv = index_of(m.v_names, p.joint), iq = index_of(m.q_names, p.joint);
  Data d(m);
  ConstraintData cd(m, mp.constraints);
  Workspace wm(mp), ws(sv);
  WrenchData dm(mp);
  int ee = -1;
  for (size_t k = 0; k < mp.wrenches.outputs.size(); ++k)
    if (mp.wrenches.outputs[k].name == "arm1.ee") ee = static_cast<int>(k);
  int spec = -1;
  for (size_t s = 0; s < sv.constraints.specs.size(); ++s)
    if (sv.constraints.specs[s].name == "arm1.ee") spec = static_cast<int>(s);
  Eigen::VectorXd q = mp.q0;
  const double x0 = q[iq];
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(m.nv()), zs = Eigen::VectorXd::Zero(sv.model.nv());
  std::vector<Sample> out;
  for (int i = 0; i < n; ++i) {
    Sample S;
    S.s = n > 1 ? static_cast<double>(i) / (n - 1) : 0.0;
    S.x = x0 + p.from + S.s * (p.to - p.from);
    const double prev = q[iq];
    const int sub = std::max(1, static_cast<int>(std::ceil(std::abs(S.x - prev) / 0.01)));
    for (int k = 1; k <= sub; ++k) {
      q[iq] = prev + (S.x - prev) * k / sub;
      S.pos_err = close_chain(mp, d, cd, iv, q);
    }
    evaluate(mp, wm, q, zero, zero);
    compute_wrenches(mp, wm, dm);
    const Eigen::VectorXd qs = remap(sv.model.q_names, m.q_names, q);
    evaluate(sv, ws, qs, zs, zs);
    S.w_mp = dm.W[ee];
    Vec6 w = Vec6::Zero();
    for (int k = 0; k < 6; ++k) w[sv.constraints.row_axis[spec][k]] = ws.lambda[sv.constraints.row_offset[spec] + k];
    S.w_svd = w;
    S.sv = ws.tip_s[spec];
    S.kept = ws.tip_rank[spec];
    S.dvdot = (remap(m.v_names, sv.model.v_names, ws.vdot) - wm.vdot).cwiseAbs().maxCoeff();
    // the direction the arm cannot move in: the last left singular vector of its own Jacobian
    const Eigen::VectorXd u = ws.tip_U[spec].col(5);
    S.lost = std::abs(u.dot(S.w_mp));
    S.share = S.lost / S.w_mp.norm();
    const int r0 = sv.constraints.row_offset[spec];
    S.opening = u.dot(ws.cd.G.middleRows(r0, 6) * ws.vdot - ws.cd.gamma.segment(r0, 6));
    out.push_back(S);
  }
  return out;
}

double max_jump(const std::vector<Sample>& v, bool svd, double* at) {
  double J = 0;
  for (size_t i = 0; i + 1 < v.size(); ++i) {
    const Vec6 a = svd ? v[i].w_svd : v[i].w_mp, b = svd ? v[i + 1].w_svd : v[i + 1].w_mp;
    const double j = (b - a).cwiseAbs().maxCoeff();
    if (j > J) {
      J = j;
      *at = 0.5 * (v[i].x + v[i + 1].x);
    }
  }
  return J;
}

void write_csv(const std::string& path, const std::vector<Sample>& v, const char* xname) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "svd_discontinuity: cannot write %s\n", path.c_str());
    return;
  }
  static const char* comp[6] = {"mx", "my", "mz", "fx", "fy", "fz"};
  std::fprintf(f, "s,%s,position_error,kept", xname);
  for (int k = 0; k < v[0].sv.size(); ++k) std::fprintf(f, ",sv%d", k + 1);
  for (int k = 0; k < 6; ++k) std::fprintf(f, ",mp.%s", comp[k]);
  for (int k = 0; k < 6; ++k) std::fprintf(f, ",svd.%s", comp[k]);
  std::fprintf(f, ",dvdot,lost,share,opening\n");
  for (const Sample& S : v) {
    std::fprintf(f, "%.17g,%.17g,%.3g,%d", S.s, S.x, S.pos_err, S.kept);
    for (int k = 0; k < S.sv.size(); ++k) std::fprintf(f, ",%.17g", S.sv[k]);
    for (int k = 0; k < 6; ++k) std::fprintf(f, ",%.17g", S.w_mp[k]);
    for (int k = 0; k < 6; ++k) std::fprintf(f, ",%.17g", S.w_svd[k]);
    std::fprintf(f, ",%.6g,%.17g,%.17g,%.17g\n", S.dvdot, S.lost, S.share, S.opening);
  }
  std::fclose(f);
  std::printf("wrote %s\n", path.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  const std::string dir = argc > 1 ? argv[1] : std::string(COOPDYN_SOURCE_DIR) + "/bench/results";
  auto scene = [](const std::string& n, Formulation f) {
    SceneOverrides ov;
    ov.formulation = f;
    return load_scene(std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/" + n + ".yaml", ov);
  };
  {  // (1) through the wrist singularity
    const Path p{"two_puma_load", "arm1.q5", 0.6 - 0.8, -0.6 - 0.8};  // q0 has q5 = 0.8: from +0.6 to -0.6
    const System mp = scene(p.scene, Formulation::kMobilePlatform), sv = scene(p.scene, Formulation::kSvdBaseline);
    const std::vector<Sample> v = run(mp, sv, p, 601);
    write_csv(dir + "/svd_singularity.csv", v, "arm1_q5");
    double err = 0, smin = 1e300, gap = 1e300;
    int drops = 0;
    for (const Sample& S : v) {
      err = std::max(err, S.pos_err);
      smin = std::min(smin, S.sv.minCoeff());
      for (int k = 0; k + 1 < S.sv.size(); ++k) gap = std::min(gap, S.sv[k] - S.sv[k + 1]);
      drops += S.kept < 6;
    }
    std::printf("(1) two_puma_load, arm1.q5 +0.6 -> -0.6 rad, 601 samples, constraint error <= %.2g m\n", err);
    std::printf("    smallest singular value of arm1's own Jacobian %.3g; smallest gap between neighbouring "
                "singular values %.3g; samples where the baseline drops a direction: %d\n",
                smin, gap, drops);
    std::printf("    %8s %26s %26s %12s\n", "samples", "max jump mobile_platform", "max jump svd (at q5)", "drops");
    for (int n : {51, 201, 801, 3201}) {
      const std::vector<Sample> w = run(mp, sv, p, n);
      double a1 = 0, a2 = 0;
      const double j1 = max_jump(w, false, &a1), j2 = max_jump(w, true, &a2);
      int dr = 0;
      for (const Sample& S : w) dr += S.kept < 6;
      std::printf("    %8d %14.4g N or N*m %14.4g (%+.4f) %12d\n", n, j1, j2, a2, dr);
    }
    // the window where a direction is dropped: q5 within sqrt(rank_tol) relative of the singularity
    const Path z{"two_puma_load", "arm1.q5", -0.8 + 1e-4, -0.8 - 1e-4};
    const std::vector<Sample> w = run(mp, sv, z, 201);
    double lo = 1e300, hi = -1e300, lost = 0, share = 0;
    for (const Sample& S : w)
      if (S.kept < 6) {
        lo = std::min(lo, S.x);
        hi = std::max(hi, S.x);
        lost = std::max(lost, (S.w_svd - S.w_mp).cwiseAbs().maxCoeff());
        share = std::max(share, S.share);
      }
    std::printf("    dropped for q5 in [%.3g, %.3g] rad; there the baseline's arm1.ee wrench differs by up to %.4g "
                "(N or N*m), the rigid grasp's force along u is %.3g of its wrench\n",
                lo, hi, lost, share);
  }
  {  // (2) the deficient arm
    const Path p{"two_5dof_arms_load", "arm1.q2", -0.3, 0.3};
    const System mp = scene(p.scene, Formulation::kMobilePlatform), sv = scene(p.scene, Formulation::kSvdBaseline);
    const std::vector<Sample> v = run(mp, sv, p, 121);
    write_csv(dir + "/svd_deficient.csv", v, "arm1_q2");
    double lmin = 1e300, lmax = 0, smin = 1e300, smax = 0, omax = 0, dv = 0;
    for (const Sample& S : v) {
      lmin = std::min(lmin, S.lost);
      lmax = std::max(lmax, S.lost);
      smin = std::min(smin, S.share);
      smax = std::max(smax, S.share);
      omax = std::max(omax, std::abs(S.opening));
      dv = std::max(dv, S.dvdot);
    }
    std::printf("(2) two_5dof_arms_load, arm1.q2 swept +-0.3 rad (121 samples), the baseline keeps %d of 6 directions:\n",
                v[0].kept);
    std::printf("    rigid grasp force along the dropped direction %.4g .. %.4g (N, N*m), %.1f .. %.1f %% of the grasp "
                "wrench; the baseline's grasp opens at up to %.3g m/s^2 (rad/s^2) along it; max |vdot_svd - vdot_mp| %.3g\n",
                lmin, lmax, 100 * smin, 100 * smax, omax, dv);
  }
  return 0;
}
