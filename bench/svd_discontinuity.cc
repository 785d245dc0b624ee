// Does the SVD baseline (METHOD s.6, the paper's (19)-(21)) report discontinuous wrenches?
//
// Path: two_puma_load (two PUMA 560 holding a 5 kg box, the box as the mobile platform), arm1's
// wrist joint q5 driven from 0.8 rad through the wrist singularity (q5 = 0: axes 4 and 6 aligned,
// the arm's own 6x6 Jacobian loses rank) to -0.4 rad. Every other coordinate (box pose, the other
// 11 joints) follows by Gauss-Newton on the closed-chain error (the two base welds) with q5 held,
// continued from the previous sample, so every sample satisfies the constraints to 1e-12 m.
// At each sample (v = 0, tau = 0: gravity statics) both methods evaluate the same state:
//   mobile_platform  Q = G M^-1 G^T, Cholesky (s.3)
//   svd              per tip, R_k from the SVD of G_k (its singular vectors), Q_r pseudo-inverse
// Columns of the CSV: s, q5, the singular values of each tip's G_k (what the baseline decomposes:
// platform columns included) and of the arm-only block of G_k (the arm's own Jacobian, rank 5 at
// the singularity), both methods' base wrenches [moment; force] in the base frame, ranks, and
// |lambda_svd - lambda_mp|. Then the largest jump between neighbouring samples of each method for
// 4 samplings: a discontinuity keeps its jump when the sampling is refined, a continuous curve's
// neighbour difference shrinks like 1/N.
//
// Usage: svd_discontinuity [OUT.csv]   (default bench/results/svd_discontinuity.csv)
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "service/algorithms/kinematics.h"
#include "service/dynamics/constrained_dynamics.h"
#include "service/scene/scene.h"

using namespace coopdyn;

namespace {

const double kQ5From = 0.8, kQ5To = -0.4;

int index_of(const std::vector<std::string>& v, const std::string& s) {
  for (size_t i = 0; i < v.size(); ++i)
    if (v[i] == s) return static_cast<int>(i);
  return -1;
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
  double s, q5;
  std::vector<Eigen::VectorXd> sv_tip, sv_arm;  // per tip
  std::vector<Vec6> w_mp, w_svd;                // per tip
  int rank_mp, rank_svd;
  double dlambda, pos_err;
};

std::vector<Sample> run(const System& mp, const System& svd, int n) {
  const Model& m = mp.model;
  const int iv = index_of(m.v_names, "arm1.q5"), iq = index_of(m.q_names, "arm1.q5");
  Data d(m);
  ConstraintData cd(m, mp.constraints);
  Workspace wm(mp), ws(svd);
  Eigen::VectorXd q = mp.q0;
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(m.nv());
  const int ntips = static_cast<int>(mp.constraints.specs.size());
  std::vector<Sample> out;
  for (int i = 0; i < n; ++i) {
    Sample S;
    S.s = n > 1 ? static_cast<double>(i) / (n - 1) : 0.0;
    S.q5 = kQ5From + S.s * (kQ5To - kQ5From);
    // continuation: approach the new q5 in small moves so Gauss-Newton stays on the same branch
    const double q5_prev = q[iq];
    const int sub = std::max(1, static_cast<int>(std::ceil(std::abs(S.q5 - q5_prev) / 0.01)));
    for (int k = 1; k <= sub; ++k) {
      q[iq] = q5_prev + (S.q5 - q5_prev) * k / sub;
      S.pos_err = close_chain(mp, d, cd, iv, q);
    }
    evaluate(mp, wm, q, zero, zero);
    evaluate(svd, ws, q, zero, zero);
    S.rank_mp = wm.diag.rank;
    S.rank_svd = ws.diag.rank;
    S.dlambda = (wm.lambda - ws.lambda).cwiseAbs().maxCoeff();
    for (int t = 0; t < ntips; ++t) {
      const int r0 = mp.constraints.row_offset[t], nk = mp.constraints.row_count[t];
      const Eigen::MatrixXd Gk = wm.cd.G.middleRows(r0, nk);
      S.sv_tip.push_back(Eigen::JacobiSVD<Eigen::MatrixXd>(Gk).singularValues());
      const std::string arm = "arm" + std::to_string(t + 1) + ".";
      Eigen::MatrixXd Ga(nk, 0);
      for (int c = 0; c < m.nv(); ++c)
        if (m.v_names[c].rfind(arm, 0) == 0) {
          Ga.conservativeResize(nk, Ga.cols() + 1);
          Ga.col(Ga.cols() - 1) = Gk.col(c);
        }
      S.sv_arm.push_back(Eigen::JacobiSVD<Eigen::MatrixXd>(Ga).singularValues());
      S.w_mp.push_back(tip_wrench(mp, wm, t));
      S.w_svd.push_back(tip_wrench(svd, ws, t));
    }
    out.push_back(S);
  }
  return out;
}

// largest |w(i+1) - w(i)| over tips and components (N or N*m), and where (path parameter)
double max_jump(const std::vector<Sample>& v, bool svd, double* at) {
  double J = 0;
  for (size_t i = 0; i + 1 < v.size(); ++i)
    for (size_t t = 0; t < v[i].w_mp.size(); ++t) {
      const Vec6 a = svd ? v[i].w_svd[t] : v[i].w_mp[t], b = svd ? v[i + 1].w_svd[t] : v[i + 1].w_mp[t];
      const double j = (b - a).cwiseAbs().maxCoeff();
      if (j > J) {
        J = j;
        *at = 0.5 * (v[i].s + v[i + 1].s);
      }
    }
  return J;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string out_path =
      argc > 1 ? argv[1] : std::string(COOPDYN_SOURCE_DIR) + "/bench/results/svd_discontinuity.csv";
  const std::string scene = std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/two_puma_load.yaml";
  SceneOverrides ov;
  ov.formulation = Formulation::kMobilePlatform;
  const System mp = load_scene(scene, ov);
  ov.formulation = Formulation::kSvdBaseline;
  const System svd = load_scene(scene, ov);

  const std::vector<Sample> path = run(mp, svd, 601);
  std::FILE* f = std::fopen(out_path.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "svd_discontinuity: cannot write %s\n", out_path.c_str());
    return 1;
  }
  static const char* comp[6] = {"mx", "my", "mz", "fx", "fy", "fz"};
  const int ntips = static_cast<int>(path[0].w_mp.size());
  std::fprintf(f, "s,arm1_q5,rank_mp,rank_svd,dlambda,position_error");
  for (int t = 0; t < ntips; ++t) {
    const std::string tn = mp.constraints.specs[t].name;
    for (int k = 0; k < path[0].sv_tip[t].size(); ++k) std::fprintf(f, ",%s.sv_G%d", tn.c_str(), k + 1);
    for (int k = 0; k < path[0].sv_arm[t].size(); ++k) std::fprintf(f, ",%s.sv_arm%d", tn.c_str(), k + 1);
    for (int k = 0; k < 6; ++k) std::fprintf(f, ",%s.mp.%s", tn.c_str(), comp[k]);
    for (int k = 0; k < 6; ++k) std::fprintf(f, ",%s.svd.%s", tn.c_str(), comp[k]);
  }
  std::fprintf(f, "\n");
  double worst_err = 0, worst_dl = 0, min_sv_arm = 1e300, min_sv_tip = 1e300, min_gap_tip = 1e300;
  for (const Sample& S : path) {
    std::fprintf(f, "%.9g,%.9g,%d,%d,%.3g,%.3g", S.s, S.q5, S.rank_mp, S.rank_svd, S.dlambda, S.pos_err);
    for (int t = 0; t < ntips; ++t) {
      for (int k = 0; k < S.sv_tip[t].size(); ++k) std::fprintf(f, ",%.12g", S.sv_tip[t][k]);
      for (int k = 0; k < S.sv_arm[t].size(); ++k) std::fprintf(f, ",%.12g", S.sv_arm[t][k]);
      for (int k = 0; k < 6; ++k) std::fprintf(f, ",%.12g", S.w_mp[t][k]);
      for (int k = 0; k < 6; ++k) std::fprintf(f, ",%.12g", S.w_svd[t][k]);
      min_sv_arm = std::min(min_sv_arm, S.sv_arm[t].minCoeff());
      min_sv_tip = std::min(min_sv_tip, S.sv_tip[t].minCoeff());
      for (int k = 0; k + 1 < S.sv_tip[t].size(); ++k) min_gap_tip = std::min(min_gap_tip, S.sv_tip[t][k] - S.sv_tip[t][k + 1]);
    }
    std::fprintf(f, "\n");
    worst_err = std::max(worst_err, S.pos_err);
    worst_dl = std::max(worst_dl, S.dlambda);
  }
  std::fclose(f);
  std::printf("path: arm1.q5 %.2f -> %.2f rad, 601 samples, constraint error <= %.2g m; wrote %s\n", kQ5From, kQ5To,
              worst_err, out_path.c_str());
  std::printf("smallest singular value: arm-only Jacobian %.3g, tip G_k (with platform columns) %.3g; smallest gap "
              "between neighbouring singular values of a G_k %.3g\n",
              min_sv_arm, min_sv_tip, min_gap_tip);
  std::printf("largest |lambda_svd - lambda_mp| along the path: %.3g\n", worst_dl);
  std::printf("%8s %22s %22s\n", "samples", "max jump mobile_pl.", "max jump svd");
  for (int n : {51, 201, 801, 3201}) {
    const std::vector<Sample> p = run(mp, svd, n);
    double a1 = 0, a2 = 0;
    const double j1 = max_jump(p, false, &a1), j2 = max_jump(p, true, &a2);
    std::printf("%8d %12.4g (s=%.3f) %12.4g (s=%.3f)\n", n, j1, a1, j2, a2);
  }
  return 0;
}
