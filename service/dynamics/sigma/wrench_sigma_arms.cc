#include "service/dynamics/sigma/wrench_sigma_arms.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <type_traits>

namespace coopdyn {

namespace {

using Mat6X = SigmaArms::Mat6X;

struct UnionFind {
  std::vector<int> p;
  explicit UnionFind(int n) : p(static_cast<size_t>(n)) { std::iota(p.begin(), p.end(), 0); }
  int find(int x) {
    while (p[x] != x) x = p[x] = p[p[x]];
    return x;
  }
  void join(int a, int b) { p[find(a)] = find(b); }
};

// per spec: the DOFs its rows reach after the tree solve (its support's paths to the root)
std::vector<std::vector<char>> spec_reach(const System& sys) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  std::vector<std::vector<char>> reach(cs.specs.size(), std::vector<char>(static_cast<size_t>(model.nv()), 0));
  for (size_t s = 0; s < cs.specs.size(); ++s)
    for (int d : cs.support[s])
      for (int a : model.body_support[model.dof_body[d]]) reach[s][a] = 1;
  return reach;
}

// the common DOFs (every spec reaches them, and all their ancestors are common too); empty: none
std::vector<int> common_dofs(const System& sys, const std::vector<std::vector<char>>& reach) {
  const Model& model = sys.model;
  std::vector<int> common;
  for (int d = 0; d < model.nv(); ++d) {
    bool all = !reach.empty();
    for (const auto& r : reach) all = all && r[d];
    if (all) common.push_back(d);
  }
  for (int d : common)
    for (int a : model.body_support[model.dof_body[d]])
      if (!std::binary_search(common.begin(), common.end(), a)) return {};
  return common;
}

// each non-common DOF's arm (-1 at the common ones): joined by a spec's rows and by the tree;
// each spec's arm (-1: it reaches the common DOFs only)
void arm_components(const System& sys, const std::vector<std::vector<char>>& reach, const std::vector<char>& is_common,
                    std::vector<int>& dof_arm, std::vector<int>& spec_arm) {
  const Model& model = sys.model;
  const int n = model.nv();
  UnionFind uf(n);
  for (const auto& r : reach) {
    int first = -1;
    for (int d = 0; d < n; ++d)
      if (r[d] && !is_common[d]) {
        if (first < 0) first = d;
        else uf.join(d, first);
      }
  }
  for (int d = 0; d < n; ++d)
    for (int a : model.body_support[model.dof_body[d]])
      if (!is_common[d] && !is_common[a]) uf.join(d, a);
  std::vector<int> id(static_cast<size_t>(n), -1);
  dof_arm.assign(static_cast<size_t>(n), -1);
  int arms = 0;
  for (int d = 0; d < n; ++d) {
    if (is_common[d]) continue;
    const int root = uf.find(d);
    if (id[root] < 0) id[root] = arms++;
    dof_arm[d] = id[root];
  }
  spec_arm.assign(reach.size(), -1);
  for (size_t s = 0; s < reach.size(); ++s)
    for (int d = 0; d < n && spec_arm[s] < 0; ++d)
      if (reach[s][d] && !is_common[d]) spec_arm[s] = dof_arm[d];
}

// the one arm an output reads (a spec's rows; a reaction: the DOFs on its body's path and below
// it, and its subtree's specs), or -1 (none, or more than one)
int output_arm(const System& sys, size_t k, const std::vector<int>& dof_arm, const std::vector<int>& spec_arm) {
  const Model& model = sys.model;
  const WrenchSet& set = sys.wrenches;
  const WrenchOutput& o = set.outputs[k];
  if (o.spec >= 0) return spec_arm[o.spec];
  int arm = -1;
  bool ok = true;
  auto see = [&](int a) {
    if (a < 0) return;
    if (arm >= 0 && a != arm) ok = false;
    arm = a;
  };
  for (int d : model.body_support[o.body]) see(dof_arm[d]);
  for (int j = 0; j < model.nbodies(); ++j)
    if (model.is_ancestor(o.body, j))
      for (int c = 0; c < model.bodies[j].joint.nv; ++c) see(dof_arm[model.bodies[j].joint.idx_v + c]);
  for (int t = set.out_spec_begin[k]; t < set.out_spec_begin[k + 1]; ++t) {
    const int a = spec_arm[set.out_spec[t].first];
    if (a < 0) ok = false;
    see(a);
  }
  return ok ? arm : -1;
}

// the noisy torques' arms, each arm's columns contiguous (sd.dofs is ascending): false otherwise
bool column_arms(WrenchSigmaData& sd, const std::vector<int>& dof_arm, int arms) {
  SigmaArms& A = sd.arm;
  A.j0.assign(static_cast<size_t>(arms), 0);
  A.nj.assign(static_cast<size_t>(arms), 0);
  int last = -1;
  for (size_t j = 0; j < sd.dofs.size(); ++j) {
    const int a = dof_arm[sd.dofs[j]];
    if (a < 0) return false;  // a noisy torque on a common DOF
    if (a != last) {
      if (A.nj[a] > 0) return false;
      A.j0[a] = static_cast<int>(j);
      last = a;
    }
    ++A.nj[a];
  }
  A.count = 0;
  A.pack = 0;
  for (int a = 0; a < arms; ++a) {
    A.count += A.nj[a] > 0;
    A.pack = std::max(A.pack, A.nj[a]);
  }
  return A.pack <= SigmaArms::kMaxPack;
}

}  // namespace

void sigma_arms_plan(const System& sys, WrenchSigmaData& sd) {
  SigmaArms& A = sd.arm;
  A.usable = false;
  const Formulation f = sys.options.formulation;
  if (!sd.declared || sd.dofs.empty() || sys.constraints.specs.size() < 2 ||
      !(f == Formulation::kMobilePlatform || f == Formulation::kClassic))
    return;
  const auto reach = spec_reach(sys);
  A.common = common_dofs(sys, reach);
  if (A.common.empty() || A.common.size() > 6) return;
  std::vector<char> is_common(static_cast<size_t>(sys.model.nv()), 0);
  for (int d : A.common) is_common[d] = 1;
  std::vector<int> dof_arm, spec_arm;
  arm_components(sys, reach, is_common, dof_arm, spec_arm);
  for (int a : spec_arm)
    if (a < 0) return;  // rows on the common DOFs alone: not one arm's
  const int arms = 1 + *std::max_element(dof_arm.begin(), dof_arm.end());
  if (arms < 2 || !column_arms(sd, dof_arm, arms)) return;
  const size_t no = sys.wrenches.outputs.size();
  A.out_arm.assign(no, -1);
  for (size_t k = 0; k < no; ++k)
    if ((A.out_arm[k] = output_arm(sys, k, dof_arm, spec_arm)) < 0) return;
  const int na = static_cast<int>(sd.dofs.size());
  A.Cf.setZero(6 * static_cast<Eigen::Index>(no), A.pack + static_cast<int>(A.common.size()));
  A.c.setZero(6, na);
  A.chat.setZero(6, na);
  A.ctot.setZero(6, A.pack);
  A.S_arm.assign(static_cast<size_t>(arms), Mat6::Zero());
  A.S_other.assign(static_cast<size_t>(arms), Mat6::Zero());
  A.B.assign(static_cast<size_t>(arms), SigmaArms::BMat::Zero());
  A.d_other.assign(static_cast<size_t>(arms), Vec6::Zero());
  A.chol_other.assign(static_cast<size_t>(arms), 0);
  A.usable = true;
}

bool sigma_arms_apply(const System& sys, const Workspace& ws, const WrenchSigmaData& sd) {
  return sd.arm.usable && sd.arm.count >= sd.arms_min && !sys.constraints.rolling_resistance &&
         ws.diag.indeterminate == 0 && (ws.q_blocks_active || ws.qs.fast_path);
}

void sigma_arms_columns(const WrenchSigmaData& sd, WrenchSigmaData::RowMat& X) {
  const SigmaArms& A = sd.arm;
  for (size_t a = 0; a < A.nj.size(); ++a)
    for (int s = 0; s < A.nj[a]; ++s) {
      const int j = A.j0[a] + s;
      X(sd.dofs[static_cast<size_t>(j)], s) = sd.S[j];
    }
  for (size_t i = 0; i < A.common.size(); ++i) X(A.common[i], A.pack + static_cast<int>(i)) = 1.0;
}

namespace {

// L L^T = S (L lower, zero above), unrolled at the fixed size (Eigen's LLT: ~3x the time); false
// where a pivot is not positive
bool cholesky6(const Mat6& S, Mat6& L) {
  L.setZero();
  for (int j = 0; j < 6; ++j) {
    double djj = S(j, j);
    for (int k = 0; k < j; ++k) djj -= L(j, k) * L(j, k);
    if (!(djj > 0.0)) return false;
    const double ljj = std::sqrt(djj), inv = 1.0 / ljj;
    L(j, j) = ljj;
    for (int i = j + 1; i < 6; ++i) {
      double t = S(i, j);
      for (int k = 0; k < j; ++k) t -= L(i, k) * L(j, k);
      L(i, j) = t * inv;
    }
  }
  return true;
}

// V_L^-1 from X's common rows of the unit-force columns; false where V_L is not safely positive
// definite (a pivot below 1e-4 of its diagonal entry: a near-singular arm)
bool common_inverse(WrenchSigmaData& sd) {
  SigmaArms& A = sd.arm;
  const int nC = static_cast<int>(A.common.size());
  Mat6 VL = Mat6::Identity();
  for (int i = 0; i < nC; ++i)
    for (int k = 0; k < nC; ++k) VL(i, k) = 0.5 * (sd.X(A.common[i], A.pack + k) + sd.X(A.common[k], A.pack + i));
  Mat6 L;
  if (!cholesky6(VL, L)) return false;
  for (int i = 0; i < nC; ++i)
    if (!(L(i, i) * L(i, i) > 1e-4 * VL(i, i))) return false;
  Mat6 Li = Mat6::Zero();  // L^-1 by forward substitution (fixed size; Eigen's solve goes through its blocked kernels)
  for (int c = 0; c < 6; ++c) {
    Li(c, c) = 1.0 / L(c, c);
    for (int i = c + 1; i < 6; ++i) {
      double t = 0.0;
      for (int k = c; k < i; ++k) t += L(i, k) * Li(k, c);
      Li(i, c) = -t / L(i, i);
    }
  }
  A.VLinv.noalias() = Li.transpose() * Li;
  return true;
}

// c_j = V_L^-1 T_j (T_j = S_j X(dof_j, unit-force columns), by the solve's symmetry), the slot
// sums ctot, chat_j = the other arms' c at j's slot, and each arm's and the others' sum of c c^T
void arm_sums(WrenchSigmaData& sd) {
  SigmaArms& A = sd.arm;
  const int nC = static_cast<int>(A.common.size()), na = static_cast<int>(sd.dofs.size());
  const size_t arms = A.nj.size();
  for (int j = 0; j < na; ++j) {
    Vec6 t = Vec6::Zero();
    const double* x = &sd.X(sd.dofs[static_cast<size_t>(j)], A.pack);
    for (int i = 0; i < nC; ++i) t[i] = sd.S[j] * x[i];
    A.c.col(j).noalias() = A.VLinv * t;
  }
  A.ctot.setZero();
  for (size_t a = 0; a < arms; ++a)
    for (int s = 0; s < A.nj[a]; ++s) A.ctot.col(s) += A.c.col(A.j0[a] + s);
  for (size_t a = 0; a < arms; ++a) {
    Mat6 S = Mat6::Zero();
    for (int s = 0; s < A.nj[a]; ++s) {
      const int j = A.j0[a] + s;
      A.chat.col(j) = A.ctot.col(s) - A.c.col(j);
      S.noalias() += A.c.col(j) * A.c.col(j).transpose();
    }
    A.S_arm[a] = S;
  }
  Mat6 pre = Mat6::Zero();
  for (size_t a = 0; a < arms; ++a) {
    A.S_other[a] = pre;
    pre += A.S_arm[a];
  }
  Mat6 suf = Mat6::Zero();
  for (size_t a = arms; a-- > 0;) {
    A.S_other[a] += suf;
    suf += A.S_arm[a];
  }
  for (size_t a = 0; a < arms; ++a) {  // B = [-chat | L_o]
    const int nh = A.nj[a];
    SigmaArms::BMat& B = A.B[a];
    for (int s = 0; s < nh; ++s) B.col(s) = -A.chat.col(A.j0[a] + s);
    Mat6 L;
    A.chol_other[a] = cholesky6(A.S_other[a], L);
    B.middleCols<6>(nh) = A.chol_other[a] ? L : Mat6::Zero();
    A.d_other[a] = A.S_other[a].diagonal().cwiseMax(0.0).cwiseSqrt();
  }
}

// output k's other arms' part of sigma^2 column by column (C_kj = V_k c_j), into q; C's row block
// too where sd.keep_C
void others_by_columns(WrenchSigmaData& sd, size_t k, const Mat6& V, int h, Vec6& q) {
  SigmaArms& A = sd.arm;
  q.setZero();
  for (size_t a = 0; a < A.nj.size(); ++a) {
    if (static_cast<int>(a) == h) continue;
    for (int s = 0; s < A.nj[a]; ++s) {
      const int j = A.j0[a] + s;
      const Vec6 w = V * A.c.col(j);
      q += w.cwiseAbs2();
      if (sd.keep_C) sd.C.block<6, 1>(6 * static_cast<Eigen::Index>(k), j) = w;
    }
  }
}

// output k (on arm h, keep_C): C's row block, its own columns P - V chat, the others' V c_j
void output_C(WrenchSigmaData& sd, size_t k, const Mat6& V) {
  SigmaArms& A = sd.arm;
  const int h = A.out_arm[k], nh = A.nj[h], j0 = A.j0[h];
  const Eigen::Index r0 = 6 * static_cast<Eigen::Index>(k);
  for (int s = 0; s < nh; ++s) sd.C.block<6, 1>(r0, j0 + s) = A.Cf.block<6, 1>(r0, s) - V * A.chat.col(j0 + s);
  Vec6 q;
  others_by_columns(sd, k, V, h, q);
}

// output k (on arm h, nh noisy torques): row r of [P - V chat | V L_o] is P's row r (zeros after)
// plus sum_i V(r, i) B.row(i), nw = nh + 6 entries (a compile-time 12 where nh = 6: the loops
// unrolled and vectorized); sigma_r its norm. Where the quadratic form's error bound could show (or
// S_other is singular) the other arms column by column instead.
template <class Nw>
void output_sigma(WrenchSigmaData& sd, size_t k, Nw nw) {
  SigmaArms& A = sd.arm;
  const int h = A.out_arm[k], nh = A.nj[h], nC = static_cast<int>(A.common.size());
  const SigmaArms::BMat& B = A.B[h];
  const Vec6& d = A.d_other[h];
  const double gamma = (static_cast<double>(sd.dofs.size()) + 16.0) * std::numeric_limits<double>::epsilon();
  Vec6 s_own, q, bound;
  const double* cf0 = &A.Cf(6 * static_cast<Eigen::Index>(k), 0);
  const Eigen::Index lc = A.Cf.outerStride();
  if constexpr (!std::is_same_v<Nw, int>) {  // 6 x 12 at fixed sizes: the rows in whole registers
    constexpr int N = Nw::value, NO = N - 6;
    using RM6 = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>;
    using RMO = Eigen::Matrix<double, 6, NO, Eigen::RowMajor>;
    using RMN = Eigen::Matrix<double, 6, N, Eigen::RowMajor>;
    const Eigen::Map<const RM6, 0, Eigen::OuterStride<>> V(cf0 + A.pack, Eigen::OuterStride<>(lc));
    const Eigen::Map<const RMO, 0, Eigen::OuterStride<>> P(cf0, Eigen::OuterStride<>(lc));
    RMN acc;
    if (nC == 6) acc.noalias() = V * B.template leftCols<N>();
    else acc.noalias() = V.leftCols(nC) * B.topLeftCorner(nC, N);
    s_own = (acc.template leftCols<NO>() + P).rowwise().squaredNorm();
    q = acc.template rightCols<6>().rowwise().squaredNorm();
    const Vec6 b = (nC == 6 ? (V.cwiseAbs() * d).eval() : (V.leftCols(nC).cwiseAbs() * d.head(nC)).eval());
    bound = gamma * b.cwiseAbs2();
  } else {
    for (int r = 0; r < 6; ++r) {
      const double* cf = cf0 + r * lc;
      const double* v = cf + A.pack;
      double acc[SigmaArms::kMaxPack + 6];
      for (int c = 0; c < nw; ++c) acc[c] = c < nh ? cf[c] : 0.0;
      double b = 0.0;
      for (int i = 0; i < nC; ++i) {
        const double* bi = B.data() + i * B.outerStride();
        for (int c = 0; c < nw; ++c) acc[c] += v[i] * bi[c];
        b += std::abs(v[i]) * d[i];
      }
      double so = 0.0, qo = 0.0;
      for (int c = 0; c < nw; ++c) (c < nh ? so : qo) += acc[c] * acc[c];
      s_own[r] = so;
      q[r] = qo;
      bound[r] = gamma * b * b;
    }
  }
  Vec6 sig = (s_own + q).cwiseSqrt();
  const double tol = A.guard * sig.maxCoeff();
  if (A.chol_other[h] && (bound.array() <= tol * sig.array().max(tol)).all()) {
    sd.sigma[k] = sig;
    return;
  }
  Mat6 V = Mat6::Zero();
  V.leftCols(nC) = A.Cf.block(6 * static_cast<Eigen::Index>(k), A.pack, 6, nC);
  others_by_columns(sd, k, V, h, q);  // the others' columns exact (their sum of squares)
  sd.sigma[k] = (s_own + q).cwiseSqrt();
  ++A.guarded;
}

void output_sigma(WrenchSigmaData& sd, size_t k) {
  SigmaArms& A = sd.arm;
  const int nh = A.nj[A.out_arm[k]];
  if (sd.keep_C) {
    const int nC = static_cast<int>(A.common.size());
    Mat6 V = Mat6::Zero();
    V.leftCols(nC) = A.Cf.block(6 * static_cast<Eigen::Index>(k), A.pack, 6, nC);
    return output_C(sd, k, V);
  }
  if (nh == 6) output_sigma(sd, k, std::integral_constant<int, 12>{});
  else output_sigma(sd, k, nh + 6);
}

}  // namespace

bool sigma_arms_finish(WrenchSigmaData& sd) {
  if (!common_inverse(sd)) return false;
  arm_sums(sd);
  sd.arm.guarded = 0;
  for (size_t k = 0; k < sd.sigma.size(); ++k) output_sigma(sd, k);
  return true;
}

}  // namespace coopdyn
